"""The compiled tick's row screen: which rows may leave daqp's problem, and when.

``tick.c`` hands daqp only the rows in play: a stage's rows by their place in it (every
stage alike) leave once no plan has had them active for :data:`SCREEN_AFTER` ticks, each
plan is checked against the rows left out and the tick solved again with those it breaks
(every row after two such rounds), so the optimum is the same (a plan optimal without some
rows and within them is optimal with them: the QP is strictly convex). With a budget
(``max_iter`` given) the solves of a tick share its iterations. The Python tick's screen
(:mod:`mpc.solvers.row_screen`) is the same rule; the virtual machine hands daqp every
row (the same optimum, as the tests check).

Where it runs is :func:`screened_places` (the rule, in code): the rows a robot marks as
seldom needed (``StageLimits.screened``: a motor model's voltage, current and traction
rows) that move with the plan (``prepare`` gives them every tick, so a row whitened alone
is one row's work), and only where a stage has at least :data:`SCREEN_FROM_ROWS` of them:
daqp's passes over its rows are what the screen saves, measured with the shortcut off in
the same run (``mpc-bench perf --sections compiled --motors``, row
``compiled-unscreened``; docs/guide/compiled-tick.md, "Motor-aware robots").
"""

from __future__ import annotations

from mpc.robots.limits import StageLimits
from mpc.solvers import row_screen

#: Ticks without a plan that has a row active before it leaves daqp's problem (the
#: Python tick's :data:`mpc.solvers.row_screen.SCREEN_AFTER`); read when a controller is
#: built (0: every row in daqp's problem, for measuring the screen's gain).
SCREEN_AFTER = row_screen.SCREEN_AFTER

#: The library's own default (``MPC_SCREEN_AFTER``, what an exported library starts with):
#: a constant, so that changing :data:`SCREEN_AFTER` does not compile another library.
LIBRARY_AFTER = 50

#: Rows a stage from which the screen runs (fewer: every row in daqp's problem).
SCREEN_FROM_ROWS = 1


def screened_places(limits: StageLimits, rows_move: bool) -> int:
    """Rows a stage the screen covers (``MPC_SCREEN_ROWS``: every row of a stage, by its
    place), or 0 for no screen: ``limits`` marked ``screened``, its rows moving with the
    plan (``rows_move``) and at least :data:`SCREEN_FROM_ROWS` a stage."""
    if not (limits.screened and rows_move) or limits.rows < SCREEN_FROM_ROWS:
        return 0
    return int(limits.rows)


def screen_after(places: int) -> int:
    """The screen's ``after`` for a tick with ``places`` screened rows a stage (0: off)."""
    return int(SCREEN_AFTER) if places > 0 and SCREEN_AFTER > 0 else 0
