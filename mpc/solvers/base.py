"""What both solver paths share: the per-tick result and the protocol they implement."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from mpc.arrays import FloatArray
from mpc.model.layout import TickInput
from mpc.profiling import TickProfile


@dataclass(frozen=True, eq=False)
class SolveResult:
    """One solve of the tracking problem.

    Attributes:
        success: the solver converged (or stopped with a usable iterate) and its output
            is finite.
        status: the solver's own status text (e.g. OSQP's ``"solved"``).
        poses: planned poses (N+1, 3) [m, m, rad].
        twists: planned body twists (N, 3) [m/s, m/s, rad/s].
        solve_time: the solver's own time for this tick [s].
        iterations: solver iterations.
        progress: path mode, the planned progress ``s_0 .. s_N`` [s] (None in time mode).

    The arrays belong to this result: a solver never writes to them again, so the
    controller may keep them (warm start, fallback, ``Command.predicted_poses``).
    """

    success: bool
    status: str
    poses: FloatArray
    twists: FloatArray
    solve_time: float
    iterations: int
    progress: FloatArray | None = None


class TrackingSolver(Protocol):
    """What the controller needs of a solver. :class:`~mpc.solvers.qp.QpSolver` and
    :class:`~mpc.solvers.nlp.NlpSolver` take the same input and return the same result,
    so a test can hold one against the other."""

    name: str
    profile: TickProfile | None  # marks the solver's own phases when set

    def reset(self) -> None:
        """Forget any warm start."""

    def solve(self, tick: TickInput) -> SolveResult:
        """One tick from the parameters and the guess in ``tick``."""
        ...
