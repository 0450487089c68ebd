"""What a solver returns for one tick."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from mpc.robots.base import FloatArray


@dataclass(frozen=True, eq=False)
class SolveResult:
    """One solve of the tracking problem.

    Attributes:
        success: the solver converged and its output is finite.
        status: the solver's own status text (e.g. OSQP's ``"solved"``).
        poses: planned poses (N+1, 3) [m, m, rad].
        twists: planned body twists (N, 3) [m/s, m/s, rad/s].
        solve_time: the solver's own time for this tick [s].
        iterations: solver iterations.
    """

    success: bool
    status: str
    poses: FloatArray
    twists: FloatArray
    solve_time: float
    iterations: int


class TrackingSolver(Protocol):
    """What the controller needs of a solver; :class:`~mpc.qp.QpSolver` and
    :class:`~mpc.nlp.NlpSolver` both take the same inputs and return the same result,
    so a test can hold one against the other."""

    name: str

    def reset(self) -> None:
        """Forget any warm start."""

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
        """One tick: initial pose (3,), reference poses (N+1, 3), feedforward twists (N, 3),
        directions of travel (N+1, 2), last command (3,), and the guess to start from."""
        ...
