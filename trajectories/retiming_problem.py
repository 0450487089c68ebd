"""The numerics of :mod:`trajectories.retiming`: path geometry, the cone program, the check.

The math is stated once, in :mod:`trajectories.retiming`. Here, in its symbols:
:func:`path_geometry` gives g(s) and h(s) = dg/ds on a grid, :class:`Limits`
measures demands against the robot's limits, :func:`solve_lap` solves the
second-order cone program for b = sdot^2 on the grid (with clarabel) and
:func:`cell_demands` measures the interpolated timing between grid points.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, NamedTuple

import clarabel
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from mpc.validation import shown

from ._validation import FloatArray
from .base import Trajectory
from .errors import TrajectoryError
from .steering import steer_demand

#: Statuses of clarabel whose solution is used (the check afterwards makes it feasible).
_ACCEPTED_STATUSES = ("Solved", "AlmostSolved")
#: Interior-point iterations clarabel may take (it needs 10 to 35 on the benchmark paths).
MAX_ITERATIONS = 200

_Index = npt.NDArray[np.integer[Any]]
#: Where the path does not move (g = 0) nothing bounds b; it is capped there at this
#: many times the median bound.
STILL_BOUND_FACTOR = 1e4


class PathGeometry(NamedTuple):
    """The path at path parameters ``s`` (m,) [s of the source's time].

    ``twist`` is g = R(theta)^T dq/ds, the body twist per unit sdot, (m, 3)
    [m, m, rad per s of the source]; ``twist_rate`` is h = dg/ds, (m, 3).
    """

    s: FloatArray
    twist: FloatArray
    twist_rate: FloatArray


def path_geometry(source: Trajectory, s: FloatArray) -> PathGeometry:
    """g and h at ``s`` from the source's pose, velocity and acceleration sampled at s.

    With u = R^T dq/ds = (ux, uy, thetadot):
    h = R^T d2q/ds2 + dtheta/ds * (uy, -ux, 0), the last term from dR^T/ds.
    """
    sample = source.sample(s)
    theta = sample.pose[:, 2]
    cos, sin = np.cos(theta), np.sin(theta)
    dq, d2q = sample.velocity, sample.acceleration
    g = np.empty_like(dq)
    g[:, 0] = cos * dq[:, 0] + sin * dq[:, 1]
    g[:, 1] = cos * dq[:, 1] - sin * dq[:, 0]
    g[:, 2] = dq[:, 2]
    h = np.empty_like(d2q)
    h[:, 0] = cos * d2q[:, 0] + sin * d2q[:, 1] + dq[:, 2] * g[:, 1]
    h[:, 1] = cos * d2q[:, 1] - sin * d2q[:, 0] - dq[:, 2] * g[:, 0]
    h[:, 2] = d2q[:, 2]
    return PathGeometry(s, g, h)


@dataclass(frozen=True)
class Limits:
    """The limits one timing must respect (validated by the caller).

    ``wheel_blocks`` (n, d, 3) maps a body twist to wheel velocities [rad/s];
    ``wheel_speed`` (n,) [rad/s] (0: a failed wheel held at rest);
    ``wheel_accel`` (n,) [rad/s^2] or None; ``path_speed`` [m/s] and
    ``heading_rate`` [rad/s] optional caps; ``steer_rate`` (n,) [rad/s] the steering
    limits of steered modules (``d = 2``; :mod:`trajectories.steering`) or None.
    """

    wheel_blocks: FloatArray
    wheel_speed: FloatArray
    wheel_accel: FloatArray | None
    path_speed: float | None
    heading_rate: float | None
    steer_rate: FloatArray | None = None

    def steer_demand(self, geometry: PathGeometry) -> FloatArray:
        """Peak steering demand over the steered modules at sdot = 1, shape (m,); 0 if none.
        Like the speed demand it scales with sdot (:mod:`trajectories.steering`)."""
        if self.steer_rate is None:
            return np.zeros(geometry.s.shape)
        return steer_demand(self.wheel_blocks, self.wheel_speed, self.steer_rate,
                            geometry.twist, geometry.twist_rate)

    def speed_demand(self, twist: FloatArray) -> FloatArray:
        """Peak speed / limit over every speed limit at sdot = 1, shape (m,); inf: cannot move."""
        wheel = np.linalg.norm(np.einsum("ndj,mj->mnd", self.wheel_blocks, twist), axis=2)
        working = self.wheel_speed > 0.0
        ratio = np.where(
            working,
            wheel / np.where(working, self.wheel_speed, 1.0),
            np.where(wheel > 1e-12, np.inf, 0.0),
        ).max(axis=1)
        if self.path_speed is not None:
            ratio = np.maximum(ratio, np.hypot(twist[:, 0], twist[:, 1]) / self.path_speed)
        if self.heading_rate is not None:
            ratio = np.maximum(ratio, np.abs(twist[:, 2]) / self.heading_rate)
        return ratio

    def accel_demand(self, geometry: PathGeometry, b: FloatArray, a: FloatArray) -> FloatArray:
        """max_i ||W_i (h b + g a)|| / max_wheel_accel_i per row, shape (m,); 0 if unlimited."""
        if self.wheel_accel is None:
            return np.zeros(b.shape)
        rate = geometry.twist_rate * b[:, np.newaxis] + geometry.twist * a[:, np.newaxis]
        wheel = np.linalg.norm(np.einsum("ndj,mj->mnd", self.wheel_blocks, rate), axis=2)
        return (wheel / self.wheel_accel).max(axis=1)


class ConeSolution(NamedTuple):
    """b = sdot^2 on the grid (m,) and how clarabel got there."""

    b: FloatArray
    status: str
    iterations: int
    solve_time: float  # [s] clarabel's own timer
    build_time: float  # [s] assembling the matrices


class _Rows:
    """Constraint rows A x + s = rhs, s in a cone, collected cone by cone (clarabel's order)."""

    def __init__(self) -> None:
        self.rows: list[_Index] = []
        self.cols: list[_Index] = []
        self.vals: list[FloatArray] = []
        self.rhs: list[FloatArray] = []
        self.cones: list[object] = []
        self.count = 0

    def add(self, rows: _Index, cols: _Index, vals: FloatArray, rhs: FloatArray) -> None:
        """Entries with row numbers relative to this block of ``rhs.size`` rows."""
        self.rows.append(rows.ravel() + self.count)
        self.cols.append(cols.ravel())
        self.vals.append(vals.ravel())
        self.rhs.append(rhs)
        self.count += rhs.size

    def matrix(self, width: int) -> sp.csc_matrix:
        where = (np.concatenate(self.rows), np.concatenate(self.cols))
        return sp.csc_matrix((np.concatenate(self.vals), where), shape=(self.count, width))


def solve_lap(
    geometry: PathGeometry, limits: Limits, bound: FloatArray, periodic: bool,
    start: float = 0.0,
) -> ConeSolution:
    """The fastest b = sdot^2 on the (uniform) grid of ``geometry``, b <= ``bound``; one
    pass (not ``periodic``) starts at b_0 <= ``start`` (0: from rest) and ends at rest.

    Solved in scaled variables so that every number clarabel sees is of order 1:
    sigma = (s - s_0) / S in [0, 1] and b~ = b / B0, a~ = a S / B0 (B0 the
    median of the positive ``bound``), so the lap time is S / sqrt(B0) * sum 2 dsigma d~_k.
    x = (b~ (m), a~ (m - 1), c~ (m), d~ (m - 1)).
    Raises TrajectoryError naming clarabel's status if it finds no solution.
    """
    started = time.perf_counter()
    m = geometry.s.size
    cells = m - 1
    span = float(geometry.s[-1] - geometry.s[0])
    scale = float(np.median(bound[bound > 0.0]))
    offsets = {"b": 0, "a": m, "c": m + cells, "d": 2 * m + cells}
    width = 2 * m + 2 * cells
    zero, nonnegative, cones = _Rows(), _Rows(), _Rows()
    _dynamics_rows(zero, offsets, cells, periodic, start > 0.0)
    points = np.arange(m)
    nonnegative.add(points, offsets["b"] + points, np.ones(m), bound / scale)
    if not periodic and start > 0.0:  # b_0 <= start: at most the speed the robot has now
        nonnegative.add(np.zeros(1, dtype=int), np.array([offsets["b"]]), np.ones(1),
                        np.array([min(start, float(bound[0])) / scale]))
    if limits.wheel_accel is not None:
        _accel_rows(nonnegative, cones, geometry, limits.wheel_blocks,
                    limits.wheel_accel / scale, span, offsets)
    _time_cones(cones, offsets, m)
    objective = np.zeros(width)
    objective[offsets["d"] :] = 2.0 / cells
    blocks = (zero, nonnegative, cones)
    matrix = sp.vstack([block.matrix(width) for block in blocks], format="csc")
    rhs = np.concatenate([np.concatenate(block.rhs) for block in blocks])
    kinds: list[object] = [clarabel.ZeroConeT(zero.count), clarabel.NonnegativeConeT(
        nonnegative.count)]
    kinds += cones.cones
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.max_iter = MAX_ITERATIONS
    built = time.perf_counter() - started
    solver = clarabel.DefaultSolver(sp.csc_matrix((width, width)), objective, matrix, rhs,
                                    kinds, settings)
    solution = solver.solve()
    status = str(solution.status)
    if status not in _ACCEPTED_STATUSES:
        raise TrajectoryError(
            f"the retiming cone program was not solved: clarabel status {status} after "
            f"{solution.iterations} iterations ({m} grid points)"
        )
    b = np.clip(np.asarray(solution.x[:m]) * scale, 0.0, bound)
    return ConeSolution(b, status, int(solution.iterations), float(solution.solve_time), built)


def _dynamics_rows(zero: _Rows, offsets: dict[str, int], cells: int, periodic: bool,
                   moving_start: bool = False) -> None:
    """b~_{k+1} - b~_k - 2 dsigma a~_k = 0, then b~_N = b~_0 (periodic) or b~_0 = b~_N = 0
    (b~_N = 0 alone with a ``moving_start``: its bound is a row of its own)."""
    k = np.arange(cells)
    rows = np.repeat(k, 3)
    cols = np.stack([offsets["b"] + k + 1, offsets["b"] + k, offsets["a"] + k], axis=1)
    vals = np.tile([1.0, -1.0, -2.0 / cells], cells)
    zero.add(rows, cols, vals, np.zeros(cells))
    last = offsets["b"] + cells
    if periodic:
        zero.add(np.array([0, 0]), np.array([last, offsets["b"]]), np.array([1.0, -1.0]),
                 np.zeros(1))
    elif moving_start:
        zero.add(np.array([0]), np.array([last]), np.ones(1), np.zeros(1))
    else:
        zero.add(np.array([0, 1]), np.array([offsets["b"], last]), np.ones(2), np.zeros(2))


def _accel_rows(nonnegative: _Rows, cones: _Rows, geometry: PathGeometry, blocks: FloatArray,
                scaled_accel: FloatArray, span: float, offsets: dict[str, int]) -> None:
    """||W_i (h b + g a_k)|| <= A_i at both ends of every cell k, in the scaled variables:
    ||W_i (h b~ + g / S a~)|| <= A_i / B0 (``scaled_accel``), each row divided by its limit.

    One wheel velocity (d = 1): two linear rows; a vector (d >= 2): a cone of dimension 1 + d.
    """
    per_limit = 1.0 / scaled_accel[np.newaxis, :, np.newaxis]
    coeff_b = np.einsum("ndj,mj->mnd", blocks, geometry.twist_rate) * per_limit
    coeff_a = np.einsum("ndj,mj->mnd", blocks, geometry.twist) * (per_limit / span)
    cells = geometry.s.size - 1
    ends = np.arange(cells)[:, np.newaxis] + np.array([0, 1])  # (cells, 2) grid points
    on_b, on_a = coeff_b[ends], coeff_a[ends]  # (cells, 2, n, d)
    shape = on_b.shape
    col_b = np.broadcast_to((offsets["b"] + ends)[:, :, None, None], shape)
    col_a = np.broadcast_to((offsets["a"] + np.arange(cells))[:, None, None, None], shape)
    if shape[3] == 1:
        signs = np.array([1.0, -1.0])
        rows = np.arange(on_b.size * 2).reshape(shape[:3] + (2,))
        col_b2 = np.broadcast_to(col_b, rows.shape)
        col_a2 = np.broadcast_to(col_a, rows.shape)
        nonnegative.add(np.concatenate([rows.ravel(), rows.ravel()]),
                        np.concatenate([col_b2.ravel(), col_a2.ravel()]),
                        np.concatenate([(on_b * signs).ravel(), (on_a * signs).ravel()]),
                        np.ones(rows.size))
        return
    dim = shape[3] + 1
    count = on_b.size // shape[3]
    rows = (np.arange(count).reshape(shape[:3]) * dim)[..., np.newaxis] + 1 + np.arange(shape[3])
    rhs = np.zeros((count, dim))
    rhs[:, 0] = 1.0
    cones.add(np.concatenate([rows.ravel(), rows.ravel()]),
              np.concatenate([col_b.ravel(), col_a.ravel()]),
              np.concatenate([-on_b.ravel(), -on_a.ravel()]), rhs.ravel())
    cones.cones += [clarabel.SecondOrderConeT(dim)] * count


def _time_cones(cones: _Rows, offsets: dict[str, int], m: int) -> None:
    """c_k^2 <= b_k and d_k (c_k + c_{k+1}) >= 1 as second-order cones of dimension 3.

    x y >= z^2 (x, y >= 0) is ||(2 z, x - y)|| <= x + y.
    """
    p = np.arange(m)
    ib, ic, idd = offsets["b"] + p, offsets["c"] + p, offsets["d"]
    rows = np.stack([3 * p, 3 * p + 1, 3 * p + 2], axis=1)
    cols = np.stack([ib, ic, ib], axis=1)
    vals = np.tile([-1.0, -2.0, -1.0], (m, 1))
    rhs = np.tile([1.0, 0.0, -1.0], m)
    cones.add(rows, cols, vals, rhs)
    k = np.arange(m - 1)
    rows = np.repeat(3 * k[:, None] + np.array([0, 2]), 3, axis=1)
    cols = np.tile(np.stack([idd + k, ic[:-1], ic[1:]], axis=1), 2)
    vals = np.tile([-1.0, -1.0, -1.0, -1.0, 1.0, 1.0], (m - 1, 1))
    cones.add(rows, cols, vals, np.tile([0.0, 2.0, 0.0], m - 1))
    cones.cones += [clarabel.SecondOrderConeT(3)] * (2 * m - 1)


def cell_demands(fine: PathGeometry, limits: Limits, b: FloatArray,
                 points: PathGeometry | None = None
                 ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each coarse cell's peak speed, acceleration and steering demand (cells,) (1 = at a
    limit) of the timing ``b`` between grid points.

    ``b`` is sdot^2 on a coarse grid whose points are every r-th point of
    ``fine`` (r = refinement); inside each cell b is linear in s (constant
    sddot = a_k), as the retimed trajectory interpolates it. The speed demand
    is the largest ratio at sdot = sqrt(b); the acceleration demand uses the
    cell's own a_k at both of its ends, so a grid point is checked with both
    neighbouring cells. ``points``: more places to check, anywhere in the span (a
    piecewise path's knots, from both sides: its acceleration may jump there).
    """
    cells = b.size - 1
    refine = (fine.s.size - 1) // cells
    step = float(fine.s[-1] - fine.s[0]) / cells
    fraction = np.arange(refine + 1) / refine
    b_inside = b[:-1, np.newaxis] + np.diff(b)[:, np.newaxis] * fraction  # (cells, refine + 1)
    index = np.arange(cells)[:, np.newaxis] * refine + np.arange(refine + 1)
    speed = limits.speed_demand(fine.twist)[index] * np.sqrt(b_inside)
    steer = limits.steer_demand(fine)[index] * np.sqrt(b_inside)
    a = np.repeat(np.diff(b) / (2.0 * step), refine + 1)
    inside = PathGeometry(fine.s[index].ravel(), fine.twist[index].reshape(-1, 3),
                          fine.twist_rate[index].reshape(-1, 3))
    accel = limits.accel_demand(inside, b_inside.ravel(), a).reshape(cells, refine + 1)
    peaks = speed.max(axis=1), accel.max(axis=1), steer.max(axis=1)
    if points is not None and points.s.size:
        where = (points.s - fine.s[0]) / step
        cell = np.clip(np.floor(where).astype(np.intp), 0, cells - 1)
        b_at = b[cell] + (b[cell + 1] - b[cell]) * np.clip(where - cell, 0.0, 1.0)
        rate = np.sqrt(b_at)
        at_points = (limits.speed_demand(points.twist) * rate,
                     limits.accel_demand(points, b_at, (b[cell + 1] - b[cell]) / (2.0 * step)),
                     limits.steer_demand(points) * rate)
        for peak, value in zip(peaks, at_points, strict=True):
            np.maximum.at(peak, cell, value)
    return peaks

def lap_time(s: FloatArray, b: FloatArray) -> float:
    """Lap time [s] of b = sdot^2 on the grid s: sum 2 ds / (sqrt(b_k) + sqrt(b_k+1))."""
    rates = np.sqrt(b)
    return float(np.sum(2.0 * np.diff(s) / (rates[:-1] + rates[1:])))


def speed_bound(limits: Limits, geometry: PathGeometry) -> FloatArray:
    """Upper bound on b = sdot^2 at each grid point from every speed limit and the steering
    limits; raises if 0 twice."""
    demand = np.maximum(limits.speed_demand(geometry.twist), limits.steer_demand(geometry))
    moving = demand > 0.0
    with np.errstate(divide="ignore"):
        bound = np.where(moving, 1.0 / np.where(moving, demand, 1.0) ** 2, np.inf)
    finite = bound[np.isfinite(bound) & (bound > 0.0)]
    if finite.size == 0:
        raise TrajectoryError("the robot cannot drive this path at all: every point of it "
                              "needs a wheel whose speed limit is 0 rad/s")
    cap = STILL_BOUND_FACTOR * float(np.median(finite))
    bound = np.minimum(bound, cap)
    blocked = np.flatnonzero((bound[:-1] == 0.0) & (bound[1:] == 0.0))
    if blocked.size:
        s = geometry.s[int(blocked[0])]
        raise TrajectoryError(
            f"the robot cannot drive this path: near s={shown(s)} s it needs a wheel whose speed "
            "limit is 0 rad/s (a failed wheel) to turn"
        )
    return bound
