"""The tracking problem in CasADi: one model, used by both solvers.

- State ``x = (px, py, theta)`` (world pose), input ``u = (vx, vy, omega)``
  (body twist, held constant over a tick of ``dt`` seconds).
- Dynamics: the exact integral of a constant body twist (an SE(2)
  exponential), with a Taylor series where ``|omega dt|`` is tiny so that
  values and derivatives stay finite.
- Cost: :class:`~mpc.weights.Weights` over the decision vector
  ``z = (x_0 .. x_N, u_0 .. u_{N-1})`` and the parameter vector
  ``p = (x0, xref_0 .. xref_N, uref_0 .. uref_{N-1}, t_0 .. t_N, u_prev)``
  where ``t_k`` is the reference's direction of travel (2,).

The exact path (:mod:`mpc.nlp`) hands these expressions to IPOPT; the fast
path (:mod:`mpc.qp`) evaluates the cost's Hessian and gradient (the cost is
quadratic in ``z``) and one mapped call of :attr:`linearization` each tick.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from mpc.robots.base import FloatArray, Robot
from mpc.weights import Weights

#: Below this ``|omega * dt|`` [rad] the dynamics use their Taylor series.
SMALL_ROTATION = 1e-3

#: Reference speed [m/s] below which the direction of travel fades to zero.
DIRECTION_SPEED = 0.01


def twist_integral(pose: ca.SX, twist: ca.SX, dt: float) -> ca.SX:
    """Pose after driving a constant body twist for ``dt`` seconds.

    ``p+ = p + R(theta) @ V(omega dt) @ (vx, vy) dt``, ``theta+ = theta + omega dt`` with
    ``V(a) = [[sin a / a, -(1 - cos a) / a], [(1 - cos a) / a, sin a / a]]``.
    """
    angle = twist[2] * dt
    small = ca.fabs(angle) < SMALL_ROTATION
    safe = ca.if_else(small, 1.0, angle)  # never divide by ~0, even in the unused branch
    sin_over = ca.if_else(small, 1 - angle**2 / 6 + angle**4 / 120, ca.sin(safe) / safe)
    # 1 - cos a = 2 sin^2(a / 2) avoids cancellation.
    cos_over = ca.if_else(
        small, angle / 2 - angle**3 / 24 + angle**5 / 720, 2 * ca.sin(safe / 2) ** 2 / safe
    )
    forward = dt * (sin_over * twist[0] - cos_over * twist[1])
    left = dt * (cos_over * twist[0] + sin_over * twist[1])
    c, s = ca.cos(pose[2]), ca.sin(pose[2])
    return ca.vertcat(pose[0] + c * forward - s * left, pose[1] + s * forward + c * left,
                      pose[2] + angle)


class BufferedFunction:
    """Zero-copy evaluation of a CasADi function into preallocated NumPy arrays.

    CasADi reads a C-ordered (rows, cols) array as its cols x rows column-major
    input, so a (N, 3) array is a 3 x N argument. Calling the object evaluates
    the function from ``inputs`` into ``outputs`` (which must stay alive: the
    object keeps references), with none of the per-call conversion cost of
    ``function(...)``.
    """

    def __init__(self, function: ca.Function, inputs: Sequence[FloatArray],
                 outputs: Sequence[FloatArray]) -> None:
        self.arrays = (*inputs, *outputs)
        buffer: Any
        buffer, self._evaluate = function.buffer()
        for index, array in enumerate(inputs):
            buffer.set_arg(index, array.data)
        for index, array in enumerate(outputs):
            buffer.set_res(index, array.data)
        self._buffer = buffer

    def __call__(self) -> None:
        self._evaluate()


def twist_logarithm(start: ca.SX, end: ca.SX, dt: float) -> ca.SX:
    """The constant body twist that drives ``start`` exactly to ``end`` in ``dt`` (the inverse
    of :func:`twist_integral`); columns are stages, so ``start``/``end`` may be 3 x N.

    With ``a = dtheta`` and ``d`` the displacement in the start's body frame,
    ``(vx, vy) dt = [[h cot h, h], [-h, h cot h]] @ d`` where ``h = a / 2``
    (series ``1 - a^2 / 12`` for ``h cot h`` near zero).
    """
    delta = end - start
    c, s = ca.cos(start[2, :]), ca.sin(start[2, :])
    forward = c * delta[0, :] + s * delta[1, :]
    left = c * delta[1, :] - s * delta[0, :]
    half = delta[2, :] / 2
    small = ca.fabs(half) < SMALL_ROTATION / 2
    safe = ca.if_else(small, 1.0, half)
    diagonal = ca.if_else(small, 1 - half**2 / 3, safe / ca.tan(safe))
    return ca.vertcat(diagonal * forward + half * left, diagonal * left - half * forward,
                      delta[2, :]) / dt


@dataclass(eq=False)
class TrackingModel:
    """CasADi functions and expressions of the tracking problem for one robot.

    Args:
        robot: the drive layout (its wheel maps give the limits).
        horizon: number of control intervals ``N`` >= 1.
        dt: control interval [s].
        weights: cost weights.
    """

    robot: Robot
    horizon: int
    dt: float
    weights: Weights
    dynamics: ca.Function = field(init=False)
    linearization: ca.Function = field(init=False)
    reference_terms: ca.Function = field(init=False)
    rate_matrix: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        pose, twist = ca.SX.sym("x", 3), ca.SX.sym("u", 3)
        following = twist_integral(pose, twist, self.dt)
        self.dynamics = ca.Function("dynamics", [pose, twist], [following], ["x", "u"], ["x_next"])
        wrt_pose = ca.jacobian(following, pose)
        wrt_twist = ca.jacobian(following, twist)
        # Affine model x+ ~ A x + B u + c around (pose, twist); rows (c, vec A, vec B),
        # vec column-major as CasADi stores it.
        offset = following - wrt_pose @ pose - wrt_twist @ twist
        stage = ca.Function(
            "stage_linearization",
            [pose, twist],
            [ca.densify(ca.vertcat(offset, ca.vec(wrt_pose), ca.vec(wrt_twist)))],
        )
        self.linearization = stage.map(self.horizon)
        # Reference window terms: the feedforward twists (the SE(2) logarithm
        # between consecutive reference poses, consistent with the discrete
        # dynamics) and the unit directions of travel (fading to 0 when the
        # reference stops).
        n = self.horizon
        poses, velocities = ca.SX.sym("poses", 3, n + 1), ca.SX.sym("velocities", 3, n + 1)
        planar = velocities[:2, :]
        scale = ca.sqrt(ca.sum1(planar**2) + DIRECTION_SPEED**2)
        self.reference_terms = ca.Function(
            "reference_terms",
            [poses, velocities],
            [ca.densify(twist_logarithm(poses[:, :-1], poses[:, 1:], self.dt)),
             ca.densify(planar / ca.repmat(scale, 2, 1))],
            ["poses", "velocities"],
            ["feedforward", "directions"],
        )
        self.rate_matrix = self._rate_matrix()

    def _rate_matrix(self) -> FloatArray:
        """The 3x3 weight of ``u_k - u_{k-1}``: diagonal rate plus module velocity change."""
        matrix = np.diag(self.weights.rate)
        if self.robot.wheel_dim == 2 and self.weights.module_rate > 0.0:
            radius = float(getattr(self.robot, "wheel_radius", 1.0))
            ground = self.robot.wheel_blocks * radius  # module ground velocity per twist
            matrix = matrix + self.weights.module_rate * np.einsum("ndi,ndj->ij", ground, ground)
        return matrix

    # Layout of z and p -------------------------------------------------
    @property
    def n_poses(self) -> int:
        return 3 * (self.horizon + 1)

    @property
    def n_variables(self) -> int:
        return self.n_poses + 3 * self.horizon

    @property
    def n_parameters(self) -> int:
        return 3 + 3 * (self.horizon + 1) + 3 * self.horizon + 2 * (self.horizon + 1) + 3

    def pack_parameters(
        self,
        pose: FloatArray,
        poses_ref: FloatArray,
        twists_ref: FloatArray,
        directions: FloatArray,
        last_twist: FloatArray,
    ) -> FloatArray:
        """``p`` from the initial pose (3,), reference poses (N+1, 3), feedforward twists
        (N, 3), directions of travel (N+1, 2) and the last command (3,)."""
        return np.concatenate(
            (pose, poses_ref.ravel(), twists_ref.ravel(), directions.ravel(), last_twist)
        )

    def split(self, z: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Poses (N+1, 3) and twists (N, 3) from a decision vector."""
        return z[: self.n_poses].reshape(-1, 3), z[self.n_poses :].reshape(-1, 3)

    def symbols(self) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
        """Symbolic ``z``, ``p``, poses (3 x N+1) and twists (3 x N) views of ``z``."""
        z = ca.SX.sym("z", self.n_variables)
        p = ca.SX.sym("p", self.n_parameters)
        poses = ca.reshape(z[: self.n_poses], 3, self.horizon + 1)
        twists = ca.reshape(z[self.n_poses :], 3, self.horizon)
        return z, p, poses, twists

    def cost(self, poses: ca.SX, twists: ca.SX, p: ca.SX) -> ca.SX:
        """The tracking cost (see :class:`~mpc.weights.Weights`) as a CasADi expression."""
        n = self.horizon
        start = 3
        poses_ref = ca.reshape(p[start : start + 3 * (n + 1)], 3, n + 1)
        start += 3 * (n + 1)
        twists_ref = ca.reshape(p[start : start + 3 * n], 3, n)
        start += 3 * n
        directions = ca.reshape(p[start : start + 2 * (n + 1)], 2, n + 1)
        last = p[-3:]
        weights = self.weights
        r, s = ca.DM(np.diag(weights.twist)), ca.DM(self.rate_matrix)

        def pose_cost(k: int, diagonal: FloatArray) -> ca.SX:
            error = poses[:, k] - poses_ref[:, k]
            along = ca.dot(directions[:, k], error[:2])
            relief = (1.0 - weights.along_track) * float(min(diagonal[0], diagonal[1]))
            return ca.bilin(ca.DM(np.diag(diagonal)), error, error) - relief * along**2

        total = ca.SX(0)
        for k in range(n):
            if k > 0:
                total += pose_cost(k, weights.pose)
            deviation = twists[:, k] - twists_ref[:, k]
            change = twists[:, k] - (last if k == 0 else twists[:, k - 1])
            total += ca.bilin(r, deviation, deviation) + ca.bilin(s, change, change)
        return total + pose_cost(n, weights.terminal)
