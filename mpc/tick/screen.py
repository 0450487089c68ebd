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
from mpc.robots.wheels.swerve.limits import FACES, GUARD_FACES
from mpc.solvers import row_screen

#: Ticks without a plan that has a row active before it leaves daqp's problem (the
#: Python tick's :data:`mpc.solvers.row_screen.SCREEN_AFTER`); read when a controller is
#: built (0: every row in daqp's problem, for measuring the screen's gain).
SCREEN_AFTER = row_screen.SCREEN_AFTER

#: The library's own default (``MPC_SCREEN_AFTER``, what an exported library starts with):
#: a constant, so that changing :data:`SCREEN_AFTER` does not compile another library.
LIBRARY_AFTER = 50

#: Rows a stage from which a motor model's rows are screened (fewer: every row in daqp's
#: problem; omni-3's 21 gained nothing, Mecanum's and omni-4's 28 did).
SCREEN_FROM_ROWS = 24

#: A place's kind (``MPC_SCREEN_PLACES``): always in daqp's problem, in until unneeded, out
#: until a plan breaks it (swerve's guard faces).
ALWAYS, UNTIL_UNNEEDED, GUARD = 0, 1, 2

#: Whether swerve's guard faces (:data:`~mpc.robots.wheels.swerve.limits.GUARD_FACES`) start
#: out of daqp's problem in the compiled tick.
SWERVE_GUARDS = True


def screened_places(limits: StageLimits, motor: bool, faces: int) -> tuple[int, ...]:
    """The screen's places (``MPC_SCREEN_PLACES``: each of a stage's rows by kind), or
    ``()`` for no screen. A motor model's rows (``motor``: ``limits`` marked ``screened``,
    every row moving with the plan) where a stage has at least :data:`SCREEN_FROM_ROWS`:
    every place in until unneeded. Swerve (``faces``: a stage's speed faces, first in its
    rows, :data:`FACES` a module, from :class:`mpc.tick.steered.Steering`; 0 for other
    robots) with :data:`SWERVE_GUARDS`: the guard faces out until a plan breaks one, the
    rest always in."""
    if motor and limits.screened and limits.rows >= SCREEN_FROM_ROWS:
        return (UNTIL_UNNEEDED,) * int(limits.rows)
    if faces and SWERVE_GUARDS:
        guards = {FACES * module + face for module in range(faces // FACES)
                  for face in GUARD_FACES}
        return tuple(GUARD if place in guards else ALWAYS for place in range(int(limits.rows)))
    return ()


def screen_after(places: tuple[int, ...]) -> int:
    """The screen's ``after`` for a tick with screen ``places`` (0: off, every row in)."""
    return int(SCREEN_AFTER) if places and SCREEN_AFTER > 0 else 0
