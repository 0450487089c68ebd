"""What a solver returns for one tick."""

from __future__ import annotations

from dataclasses import dataclass

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
