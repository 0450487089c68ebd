"""Wheel limits as linear rows on each stage of a plan: what the QP paths constrain.

For stage ``k`` of a plan of twists ``u_0 .. u_{N-1}`` (``u_{-1}``: the last command)::

    lower[k] <= now[k] @ u_k + before[k] @ u_{k-1} <= upper[k]        (m rows a stage)

An acceleration limit bounds the change ``u_k - u_{k-1}`` over ``change_times[k]``, the
time between the two twists' starts (one control tick for ``k = 0``, see
:attr:`mpc.model.tracking.TrackingModel.change_times`).

A robot whose rows never change (Swedish wheels, balls: speed rows ``C`` and
acceleration rows ``C (u_k - u_{k-1})``) fills them once. A robot whose exact
limits are not linear (a swerve module's speed disk, its steering rate)
refills them every tick, linearised around the plan the solver starts from;
the solvers take them as they are.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from mpc.arrays import FloatArray, IntArray

#: Sides of the polygon a QP path takes for a disk limit where it takes one (a swerve
#: module's with ``polygon_sides`` given or an axle offset, a caster's).
DEFAULT_POLYGON_SIDES = 16


class SpeedRows(NamedTuple):
    """Wheel speed limits as linear rows: ``|rows @ xi| <= scale * max_wheel_speed[wheel]``.

    ``rows`` (m, 3) [rad/s per twist unit], ``wheel`` (m,) the wheel each row
    belongs to, ``scale`` <= 1 (1 where the rows are exact, the inscribed
    polygon's apothem for a disk).
    """

    rows: FloatArray
    wheel: IntArray
    scale: float


@dataclass(eq=False)
class StageLimits:
    """The rows and bounds of every stage (see the module docstring).

    Attributes:
        now: coefficients on ``u_k`` (N, m, 3) [rad/s per twist unit].
        before: coefficients on ``u_{k-1}`` (N, m, 3).
        lower, upper: bounds (N, m) [rad/s]; +-inf where a row is off this tick.
        constant: the values never change after set-up.
        change_times: time from ``u_{k-1}`` to ``u_k`` (N,) [s].
        changed: whether the last refill changed any row (the solvers skip the update
            when not).
        moving: if not None, a refill changes only each stage's first ``moving`` rows (and
            its ``guards`` last ones), and those are on ``u_k`` alone (``before`` zero
            there): a solver that transforms the rows (daqp's whitening) redoes only them.
        guards: each stage's last ``guards`` rows hold by themselves in the plans met so
            far and are kept only to catch a plan that moves far from the guess: a solver
            may leave them out of its problem, check its plan against them, and solve
            again with every row when the plan breaks one (the same answer: a plan optimal
            without some rows and within them is optimal with them). They are on ``u_k``
            alone (``before`` zero there), and a refill may change them as well as the
            first ``moving`` rows.
        inside: if not None, the moving rows (guards too) are re-aimed supporting lines of
            convex sets that they all contain (swerve's speed disks), and ``inside(twists,
            ratio)`` says whether a plan's twists (N, 3) keep within those sets shrunk by
            ``ratio``: a solver may then keep the rows of an earlier refill, for a plan
            that keeps within the sets with none of those rows active is the answer with
            the rows of any refill (it satisfies them all, and is optimal without them).
        screened: most of the rows bind seldom (a motor model's voltage, current and
            traction rows: a manoeuvre binds a few kinds): a solver may leave out of its
            problem the rows no plan has needed for a while, check each plan against them,
            and solve again with those it breaks (the same answer, as for ``guards``).
        memory: whatever the robot keeps between refills.
    """

    now: FloatArray
    before: FloatArray
    lower: FloatArray
    upper: FloatArray
    constant: bool
    change_times: FloatArray
    changed: bool = True
    moving: int | None = None
    guards: int = 0
    inside: Callable[[FloatArray, float], bool] | None = None
    screened: bool = False
    memory: dict[str, FloatArray] = field(default_factory=dict)

    @property
    def rows(self) -> int:
        """Rows a stage (m)."""
        return int(self.now.shape[1])

    @property
    def horizon(self) -> int:
        return int(self.now.shape[0])


def outermost(speed: SpeedRows, limit: FloatArray) -> SpeedRows:
    """``speed``'s rows without those the others imply, for the bounds
    ``speed.scale * limit[wheel]``: of two-sided rows ``|a x + b y + c omega| <= B`` alike
    in ``a``, ``b`` and ``B`` (a swerve's polygon: every module's row for one direction),
    the two with the least and the greatest ``c`` hold the rest (``c`` between them makes
    a row's value a weighted mean of theirs). The rows kept stay in their order.

    A swerve's 16-gon loses half its rows (for a direction, the four modules' ``c`` are
    the module positions' moments about it: two of them the extremes, the others
    between or equal to them): the QP is the same, with fewer rows for daqp to scan and
    no duplicated rows for it to step around.
    """
    scale = max(float(np.abs(speed.rows).max(initial=0.0)), 1.0)
    groups: dict[tuple[float, float, float], list[int]] = {}
    for index, (row, bound) in enumerate(zip(speed.rows, limit[speed.wheel], strict=True)):
        key = (round(float(row[0]) / scale, 12), round(float(row[1]) / scale, 12), float(bound))
        groups.setdefault(key, []).append(index)
    kept: set[int] = set()
    for members in groups.values():
        moments = speed.rows[members, 2]
        kept |= {members[int(np.argmin(moments))], members[int(np.argmax(moments))]}
    order = np.array(sorted(kept), dtype=np.intp)
    return SpeedRows(speed.rows[order], speed.wheel[order], speed.scale)


def linear_stage_limits(speed: SpeedRows, max_speed: FloatArray, max_accel: FloatArray | None,
                        change_times: FloatArray) -> StageLimits:
    """Constant rows from linear speed rows ``|C u| <= scale * max_speed[wheel]`` and, with
    acceleration limits, ``|C (u_k - u_{k-1})| <= scale * max_accel[wheel] * change_times[k]``
    (each set without the rows the others imply: :func:`outermost`)."""
    horizon = len(change_times)
    fast = outermost(speed, max_speed)
    rows = fast.rows
    speed_bound = speed.scale * max_speed[fast.wheel]
    now, before = [rows], [np.zeros_like(rows)]
    bounds = [speed_bound]
    if max_accel is not None:
        quick = outermost(speed, max_accel)
        now.append(quick.rows)
        before.append(-quick.rows)
        bounds.append(speed.scale * max_accel[quick.wheel])  # per second: times below
    stage_now = np.concatenate(now)
    stage_before = np.concatenate(before)
    bound = np.tile(np.concatenate(bounds), (horizon, 1))
    bound[:, speed_bound.size:] *= np.asarray(change_times, dtype=float)[:, None]
    return StageLimits(
        now=np.broadcast_to(stage_now, (horizon, *stage_now.shape)).copy(),
        before=np.broadcast_to(stage_before, (horizon, *stage_before.shape)).copy(),
        lower=-bound, upper=bound, constant=True,
        change_times=np.array(change_times, dtype=float))


def stage_values(limits: StageLimits, twists: FloatArray, last: FloatArray | None = None,
                 out: FloatArray | None = None) -> FloatArray:
    """The rows' values (N, m) at a plan's ``twists`` (N, 3) (into ``out`` if given):
    ``now[k] @ u_k + before[k] @ u_{k-1}``, stage 0's part on the command before it,
    ``last``, left out when None (a solver keeps it in the stage's bounds)."""
    values = np.empty((limits.horizon, limits.rows)) if out is None else out
    np.matmul(limits.now, twists[:, :, None], out=values[:, :, None])
    if limits.horizon > 1:
        values[1:] += np.matmul(limits.before[1:], twists[:-1, :, None])[:, :, 0]
    if last is not None:
        values[0] += limits.before[0] @ last
    return values


def overshoot(limits: StageLimits, values: FloatArray) -> FloatArray:
    """How far each of the rows' ``values`` (N, m) is past its bounds (<= 0 within)."""
    return np.maximum(values - limits.upper, limits.lower - values)


#: How far past a row a plan may be and still count as within it, relative to the rows'
#: largest finite bound (at least 1): rounding, not a broken row.
ROUNDING = 1e-9


def rounding_slack(*bounds: FloatArray) -> float:
    """:data:`ROUNDING` times the largest finite magnitude among ``bounds`` (at least 1)."""
    values = np.abs(np.concatenate([np.ravel(b) for b in bounds]))
    return ROUNDING * max(1.0, float(values[np.isfinite(values)].max(initial=0.0)))


def leading_rows(limits: StageLimits, rows: int) -> StageLimits:
    """The first ``rows`` rows of every stage of ``limits`` as limits of their own: views
    of the same arrays, so a refill of ``limits`` refills them (``changed`` is the caller's
    to carry over)."""
    return StageLimits(now=limits.now[:, :rows], before=limits.before[:, :rows],
                       lower=limits.lower[:, :rows], upper=limits.upper[:, :rows],
                       constant=limits.constant, change_times=limits.change_times,
                       changed=limits.changed, moving=limits.moving, inside=limits.inside,
                       screened=limits.screened)


def trailing_rows(limits: StageLimits, rows: int) -> StageLimits:
    """The last ``rows`` rows of every stage of ``limits`` (views, as :func:`leading_rows`)."""
    m = limits.rows
    return StageLimits(now=limits.now[:, m - rows:], before=limits.before[:, m - rows:],
                       lower=limits.lower[:, m - rows:], upper=limits.upper[:, m - rows:],
                       constant=limits.constant, change_times=limits.change_times,
                       changed=limits.changed)
