"""The tracking problem in CasADi: one model, used by both solvers.

- State ``x = (px, py, theta)`` (world pose), input ``u = (vx, vy, omega)``
  (body twist, held constant over a stage). Stage 0 lasts one control tick,
  the others ``dt`` seconds (:attr:`TrackingModel.durations`): longer stages
  look further ahead for the same work a tick, and the first twist, the one
  sent, still covers exactly the next tick.
- Dynamics: the exact SE(2) integral of a constant body twist (:mod:`.se2`).
- Cost (:class:`~mpc.model.weights.Weights`) over the decision vector ``z``
  and the parameter vector ``p`` of :func:`~mpc.model.layout.tracking_layouts`.

The exact path (:mod:`mpc.solvers.nlp`) hands these expressions to IPOPT;
the fast path (:mod:`mpc.solvers.qp`) evaluates the cost's Hessian and
gradient (the cost is quadratic in ``z``) and one mapped call of
:attr:`TrackingModel.linearization` each tick.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.model.layout import TrackingLayouts, tracking_layouts
from mpc.model.se2 import twist_integral, twist_logarithm
from mpc.model.weights import Weights
from mpc.robots.base import Robot

#: Reference speed [m/s] below which the direction of travel fades to zero.
DIRECTION_SPEED = 0.01

#: [m^2/s^2] keeps the norm of a reference change smooth at rest.
_TINY = 1e-12


@dataclass(eq=False)
class TrackingModel:
    """CasADi functions and expressions of the tracking problem for one robot.

    Args:
        robot: the drive layout (its wheel maps give the limits).
        horizon: number of control intervals ``N`` >= 1.
        dt: duration of stages 1 .. N-1 of the plan [s].
        weights: cost weights.
        path: path mode: the progress ``s_k`` along the reference is a decision
            variable (see :mod:`mpc.model.layout`), the pose error is measured against
            the reference at ``s_k``, expanded around the sampled ``sbar_k``.
        max_progress_rate: path mode, the progress rate ``(s_{k+1} - s_k) / h_k`` lies in
            ``[0, max_progress_rate]``: never backwards, catching up at most this fast.
        tick: the control interval [s], <= ``dt`` (default ``dt``): the duration of
            stage 0, and the time from the last command to the plan's first twist.

    Attributes:
        durations: ``h_k``, each stage's duration (N,) [s]: ``(tick, dt, ..., dt)``.
        offsets: each stage's start from the plan's start (N+1,) [s] (the last: the end).
        change_times: the time from ``u_{k-1}`` to ``u_k`` (N,) [s], what an acceleration
            limit allows a change over: ``(tick, h_0, ..., h_{N-2})``.
        layouts: the named layouts of ``z`` and ``p``.
        flow: ``x_next = flow(x, u, h)``, the pose after ``h`` seconds.
        dynamics: ``x_next = dynamics(x, u)``, one stage of ``dt``.
        linearization: over the N stages, ``(x_k, u_k) -> (c_k, vec A_k, vec B_k)``
            (21 rows a stage, vec column-major) with ``x+ ~ A x + B u + c``.
        reference_terms: ``(poses (3 x N+1), velocities (3 x N+1)) -> (feedforward (3 x N),
            directions (2 x N+1))``: the SE(2) logarithm between consecutive reference
            poses over ``h_k`` (so a robot on the reference stays on it under the discrete
            model) and the unit directions of travel, fading to 0 when the reference stops.
        rollout: ``(x0 (3), u (3 x N)) -> (x (3 x N+1), vec B_k (9 x N))``: the poses the
            twists drive the model through from ``x0``, and ``B_k = df/du`` along them.
        rate_matrix: the 3x3 weight of ``u_k - u_{k-1}``.
    """

    robot: Robot
    horizon: int
    dt: float
    weights: Weights
    path: bool = False
    max_progress_rate: float = 2.0
    tick: float | None = None
    layouts: TrackingLayouts = field(init=False)
    dynamics: ca.Function = field(init=False)
    linearization: ca.Function = field(init=False)
    rollout: ca.Function = field(init=False)
    reference_terms: ca.Function = field(init=False)
    rate_matrix: FloatArray = field(init=False)
    durations: FloatArray = field(init=False)
    offsets: FloatArray = field(init=False)
    change_times: FloatArray = field(init=False)
    flow: ca.Function = field(init=False)

    def __post_init__(self) -> None:
        n = self.horizon
        tick = self.dt if self.tick is None else self.tick
        if not 0.0 < tick <= self.dt:
            raise ValueError(f"tick must be in (0, dt = {self.dt}], got {tick}")
        self.tick = tick
        self.durations = np.full(n, self.dt)
        self.durations[0] = tick
        if tick == self.dt:
            self.offsets = self.dt * np.arange(n + 1.0)  # k dt exactly, as sampled elsewhere
        else:
            self.offsets = np.concatenate(([0.0], tick + self.dt * np.arange(n)))
        self.change_times = np.concatenate(([tick], self.durations[:-1]))
        for array in (self.durations, self.offsets, self.change_times):
            array.setflags(write=False)
        steered = self.robot.joint_parameter_size(n)
        self.layouts = tracking_layouts(n, self.path, steered)
        pose, twist, h = ca.SX.sym("x", 3), ca.SX.sym("u", 3), ca.SX.sym("h")
        following = twist_integral(pose, twist, h)
        self.flow = ca.Function("flow", [pose, twist, h], [following], ["x", "u", "h"],
                                ["x_next"])
        self.dynamics = ca.Function("dynamics", [pose, twist], [self.flow(pose, twist, self.dt)],
                                    ["x", "u"], ["x_next"])
        wrt_pose = ca.jacobian(following, pose)
        wrt_twist = ca.jacobian(following, twist)
        offset = following - wrt_pose @ pose - wrt_twist @ twist
        stage = ca.Function(
            "stage_linearization", [pose, twist, h],
            [ca.densify(ca.vertcat(offset, ca.vec(wrt_pose), ca.vec(wrt_twist)))])
        hs = ca.DM(self.durations).T
        poses, inputs = ca.SX.sym("x", 3, n), ca.SX.sym("u", 3, n)
        self.linearization = ca.Function("linearization", [poses, inputs],
                                         [stage.map(n)(poses, inputs, hs)])
        sensitivity = ca.Function("input_sensitivity", [pose, twist, h],
                                  [ca.densify(ca.vec(wrt_twist))]).map(n)
        start = ca.SX.sym("x0", 3)
        poses = ca.horzcat(start, self.flow.mapaccum(n)(start, inputs, hs))
        self.rollout = ca.Function("rollout", [start, inputs],
                                   [poses, sensitivity(poses[:, :-1], inputs, hs)],
                                   ["x0", "u"], ["x", "B"])
        poses, velocities = ca.SX.sym("poses", 3, n + 1), ca.SX.sym("velocities", 3, n + 1)
        self.reference_terms = ca.Function(
            "reference_terms", [poses, velocities],
            [feedforward_twists(poses[:, :-1], poses[:, 1:], hs),
             reference_directions(velocities)],
            ["poses", "velocities"], ["feedforward", "directions"])
        gram = self.robot.module_velocity_gram()
        self.rate_matrix = np.diag(self.weights.rate) + self.weights.module_rate * gram

    def symbols(self) -> tuple[ca.SX, ca.SX]:
        """Symbolic ``z`` and ``p``."""
        return (ca.SX.sym("z", self.layouts.variables.size),
                ca.SX.sym("p", self.layouts.parameters.size))

    def reference_poses(self, z: ca.SX, p: ca.SX, exact: bool) -> ca.SX:
        """The reference pose each stage's error is measured against, 3 x (N+1).

        Time mode: ``poses_ref``. Path mode: the reference at the planned progress
        ``s_k``, expanded around the sampled ``sbar_k``: to first order (the QP keeps
        the cost quadratic) or, with ``exact``, to second order (the NLP; the
        progress stays within a trust region of ``sbar_k``).
        """
        variables, parameters = self.layouts
        poses_ref = parameters.symbol(p, "poses_ref")
        if not self.path:
            return poses_ref
        shift = ca.repmat((variables.symbol(z, "progress")
                           - parameters.symbol(p, "progress_guess")).T, 3, 1)
        expanded = poses_ref + parameters.symbol(p, "path_rates") * shift
        if exact:
            expanded += 0.5 * parameters.symbol(p, "path_curvatures") * shift**2
        return expanded

    def progress_cost(self, z: ca.SX, p: ca.SX) -> ca.SX:
        """Path mode: the reward for progress and the smoothing of its rate (0 in time mode)."""
        if not self.path:
            return ca.SX(0)
        progress = self.layouts.variables.symbol(z, "progress")
        rates = (progress[1:] - progress[:-1]) / ca.DM(self.durations)
        # Pull every stage's rate towards the fastest allowed: a push that does not fade
        # along the horizon, with curvature (unlike a linear reward, which leaves the QP
        # flat along the path and slow for a first-order solver).
        push = self.weights.progress * ca.sumsqr(self.max_progress_rate - rates)
        bends = rates[1:] - rates[:-1]
        # A constant pull on every stage's progress: where the robot can keep up, the
        # progress stays pinned to the clock (its upper bound) despite small errors.
        guess = self.layouts.parameters.symbol(p, "progress_guess")
        pull = -self.weights.progress_reward * ca.sum1(progress[1:] - guess[1:])
        return push + pull + self.weights.progress_rate * ca.sumsqr(bends)

    def cost(self, z: ca.SX, p: ca.SX, exact: bool = False) -> ca.SX:
        """The tracking cost (see :class:`~mpc.model.weights.Weights`) as a CasADi expression;
        ``exact`` as in :meth:`reference_poses`."""
        variables, parameters = self.layouts
        poses, twists = variables.symbol(z, "poses"), variables.symbol(z, "twists")
        poses_ref = self.reference_poses(z, p, exact)
        twists_ref = parameters.symbol(p, "twists_ref")
        directions = parameters.symbol(p, "directions")
        last = parameters.symbol(p, "last_twist")
        weights = self.weights
        r, s = ca.DM(np.diag(weights.twist)), ca.DM(self.rate_matrix)

        contour = weights.contour if self.path else 0.0

        def pose_cost(k: int, diagonal: FloatArray) -> ca.SX:
            error = poses[:, k] - poses_ref[:, k]
            along = ca.dot(directions[:, k], error[:2])
            across = directions[0, k] * error[1] - directions[1, k] * error[0]
            relief = (1.0 - weights.along_track) * float(min(diagonal[0], diagonal[1]))
            return (ca.bilin(ca.DM(np.diag(diagonal)), error, error) - relief * along**2
                    + contour * across**2)

        total = ca.SX(0)
        sampled = twists_ref
        if self.path:  # the feedforward at the planned progress rate, not the sampled one
            progress = variables.symbol(z, "progress")
            rates = ca.repmat(((progress[1:] - progress[:-1]) / ca.DM(self.durations)).T, 3, 1)
            twists_ref = parameters.symbol(p, "feedforward_rates") * rates
        for k in range(self.horizon):
            if k > 0:
                total += pose_cost(k, weights.pose)
            deviation = twists[:, k] - twists_ref[:, k]
            change = self._change(twists[:, k], last if k == 0 else twists[:, k - 1],
                                  twists_ref, sampled, k)
            total += ca.bilin(r, deviation, deviation) + ca.bilin(s, change, change)
        return total + pose_cost(self.horizon, weights.terminal) + self.progress_cost(z, p)

    def _change(self, twist: ca.SX, before: ca.SX, twists_ref: ca.SX, sampled: ca.SX,
                k: int) -> ca.SX:
        """The change into stage ``k`` (from ``before`` to ``twist``) that the rate terms
        weigh, beyond the reference's own (``twists_ref``; ``sampled``: its parameters).

        A robot with dynamics: what its motor rows bound, the body's acceleration times the
        change's time ``h``: ``u_k - u_{k-1} + h coriolis``, the Coriolis term the
        reference's (at the change's middle) plus that of the plan's turn rate beyond the
        reference's, ``(omega - omega_ref) x v_ref`` (linear: the cost stays quadratic).
        Weighing the body-frame change instead let a plan meet the reference's change by
        turning the body, which costs no force. (The other first-order part, ``omega_ref x
        (v - v_ref)``, is left out: a pull on the velocity the twist term already weighs,
        it drove the swerve preset's tangent-heading circle into its voltage limit.) Of the
        reference's own change it excuses only what friction allows (``max_acceleration
        h``): beyond that the excuse pulled the plan after the reference's acceleration
        instead of its poses."""
        reference = self._reference_change(twists_ref, k)
        dynamics = self.robot.dynamics
        if dynamics is None:
            return twist - before - reference
        h = float(self.change_times[k])
        about = sampled[:, 0] if k == 0 else 0.5 * (sampled[:, k] + sampled[:, k - 1])
        own = _coriolis(about)
        middle = 0.5 * (twist + before) - about
        linear = own + ca.vertcat(-middle[2] * about[1], middle[2] * about[0], 0.0)
        reference = reference + h * own
        limit = dynamics.max_acceleration
        if limit is not None:  # a factor of the parameters only: the cost stays quadratic
            ask = self._reference_change(sampled, k) + h * own
            scale = ca.fmin(1.0, limit * h / ca.sqrt(ask[0]**2 + ask[1]**2 + _TINY))
            reference = ca.vertcat(scale * reference[0], scale * reference[1], reference[2])
        return twist - before + h * linear - reference

    def _reference_change(self, twists_ref: ca.SX, k: int) -> ca.SX:
        """The reference's own change of twist into stage ``k`` (what the rate terms do not
        penalise: a robot on the reference pays nothing for following its turns). For
        ``k = 0`` the change from the previous tick, extrapolated from stages 0 and 1."""
        if k > 0:
            return twists_ref[:, k] - twists_ref[:, k - 1]
        if self.horizon < 2:
            return ca.SX.zeros(3)
        middles = self.offsets[:-1] + 0.5 * self.durations
        slope = float(self.durations[0] / (middles[1] - middles[0]))
        return slope * (twists_ref[:, 1] - twists_ref[:, 0])

    def shooting_gaps(self, z: ca.SX, p: ca.SX) -> ca.SX:
        """``(x_0 - x0, x_{k+1} - f(x_k, u_k))`` stacked: zero on a consistent plan."""
        variables, parameters = self.layouts
        poses, twists = variables.symbol(z, "poses"), variables.symbol(z, "twists")
        following = self.flow.map(self.horizon)(poses[:, :-1], twists,
                                                ca.DM(self.durations).T)
        return ca.vertcat(poses[:, 0] - parameters.symbol(p, "x0"),
                          ca.vec(poses[:, 1:] - following))


def _coriolis(twist: ca.SX) -> ca.SX:
    """``omega x v`` of a body twist (3,): the body acceleration is ``du/dt`` plus it."""
    return ca.vertcat(-twist[2] * twist[1], twist[2] * twist[0], 0.0)


def feedforward_twists(starts: ca.SX, ends: ca.SX, durations: ca.DM) -> ca.SX:
    """Each stage's feedforward (3 x K): the constant body twist that drives its start pose
    exactly to its end pose in its duration (``durations``, 1 x K [s]), the SE(2)
    logarithm per second."""
    return ca.densify(twist_logarithm(starts, ends, 1.0) / ca.repmat(durations, 3, 1))


def reference_directions(velocities: ca.SX) -> ca.SX:
    """The reference's planar direction at each point (2 x K) of its world velocities
    (3 x K): unit where it moves, shrinking to 0 below :data:`DIRECTION_SPEED`."""
    planar = velocities[:2, :]
    scale = ca.sqrt(ca.sum1(planar**2) + DIRECTION_SPEED**2)
    return ca.densify(planar / ca.repmat(scale, 2, 1))
