"""Exact path: the nonlinear tracking problem solved by IPOPT (the yardstick).

Multiple shooting over ``z = (x_0..x_N, u_0..u_{N-1})`` with the exact
dynamics, parameterised by ``p = (x0, reference window, last command)``,
built once and warm started from the shifted previous plan. Wheel limits are
exact: linear rows for Swedish wheels, disks ``|W_i u|^2 <= limit^2`` for
swerve modules (and the same on consecutive twists for acceleration).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mpc.model import TrackingModel
from mpc.robots.base import FloatArray
from mpc.solution import SolveResult


class NlpSolver:
    """IPOPT solver of a :class:`~mpc.model.TrackingModel`.

    Args:
        model: the tracking problem.
        max_iter: IPOPT iterations per tick at most.
        time_limit: IPOPT wall time per tick at most [s]; 0 for none.
        tolerance: IPOPT's ``tol``.
    """

    name = "ipopt"

    def __init__(
        self,
        model: TrackingModel,
        max_iter: int = 100,
        time_limit: float = 0.0,
        tolerance: float = 1e-8,
    ) -> None:
        self.model = model
        robot = model.robot
        n = model.horizon
        z, p, poses, twists = model.symbols()
        following = model.dynamics.map(n)(poses[:, :-1], twists)
        constraints = [poses[:, 0] - p[:3], ca.vec(poses[:, 1:] - following)]
        lower: list[ArrayLike] = [np.zeros(3 * (n + 1))]
        upper: list[ArrayLike] = [np.zeros(3 * (n + 1))]

        blocks = [ca.DM(robot.wheel_blocks[i]) for i in range(robot.n_wheels)]
        speed = robot.max_wheel_speed
        accel = robot.max_wheel_accel
        last = p[-3:]
        for k in range(n):
            change = twists[:, k] - (last if k == 0 else twists[:, k - 1])
            for i, block in enumerate(blocks):
                constraints.append(self._wheel(block, twists[:, k]))
                lower.append(self._lower(block, speed[i]))
                upper.append(self._upper(block, speed[i]))
                if accel is not None:
                    bound = accel[i] * model.dt
                    constraints.append(self._wheel(block, change))
                    lower.append(self._lower(block, bound))
                    upper.append(self._upper(block, bound))
        problem = {"x": z, "p": p, "f": model.cost(poses, twists, p),
                   "g": ca.vertcat(*constraints)}
        options: dict[str, Any] = {
            "expand": True,
            "print_time": False,
            "record_time": True,
            "error_on_fail": False,
            "ipopt": {
                "print_level": 0,
                "sb": "yes",
                "max_iter": int(max_iter),
                "tol": float(tolerance),
                "max_wall_time": float(time_limit) if time_limit > 0 else 1e20,
            },
        }
        self._solver = ca.nlpsol("tracking_nlp", "ipopt", problem, options)
        self._lbg = np.concatenate([np.atleast_1d(v) for v in lower])
        self._ubg = np.concatenate([np.atleast_1d(v) for v in upper])

    @staticmethod
    def _wheel(block: ca.DM, twist: ca.SX) -> ca.SX:
        velocity = block @ twist
        return velocity if block.shape[0] == 1 else ca.sumsqr(velocity)

    @staticmethod
    def _lower(block: ca.DM, bound: float) -> float:
        return -bound if block.shape[0] == 1 else -np.inf

    @staticmethod
    def _upper(block: ca.DM, bound: float) -> float:
        return bound if block.shape[0] == 1 else bound**2

    def reset(self) -> None:
        """Nothing to forget: IPOPT is warm started from the primal guess only."""

    def solve(
        self,
        pose: FloatArray,
        poses_ref: FloatArray,
        twists_ref: FloatArray,
        directions: FloatArray,
        last_twist: FloatArray,
        guess_poses: FloatArray,
        guess_twists: FloatArray,
    ) -> SolveResult:
        """Solve one tick from the guess (N+1, 3) poses and (N, 3) twists."""
        model = self.model
        guess = np.concatenate((guess_poses.ravel(), guess_twists.ravel()))
        params = model.pack_parameters(pose, poses_ref, twists_ref, directions, last_twist)
        output = self._solver(x0=guess, p=params, lbg=self._lbg, ubg=self._ubg)
        stats = self._solver.stats()
        solution = output["x"].full().ravel()
        success = bool(stats.get("success", False)) and bool(np.all(np.isfinite(solution)))
        poses, twists = model.split(solution)
        return SolveResult(
            success=success,
            status=str(stats.get("return_status", "unknown")),
            poses=poses,
            twists=twists,
            solve_time=float(stats.get("t_wall_total", 0.0)),
            iterations=int(stats.get("iter_count", 0)),
        )
