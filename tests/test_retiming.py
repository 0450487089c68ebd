"""Tests of the time-optimal retimer against independent answers.

- A second method: forward-backward integration in the phase plane (s, b = sdot^2)
  on a fine grid, with its own path geometry (the library's body twist and central
  differences of it) and the admissible sddot at each (s, b) solved in closed form.
- Closed forms: a circle at fixed heading on an omni-4 "X" without acceleration
  limits; a straight line rest to rest under a speed cap (a trapezoid).
- The output itself: wheel speed and acceleration on a time grid much finer than
  the solve grid, steady laps, rest at the ends, the speed cap, and sample()'s
  derivatives against central differences of sample().pose.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from closed_loop import ACCEL_PRESETS

from mpc.robots import Robot, omni, preset
from trajectories import (
    Circle,
    FigureEight,
    PathDerivatives,
    RetimedTrajectory,
    SpinHeading,
    Trajectory,
    TrajectoryError,
    Waypoints,
    body_twist,
    feasibility,
    retiming_problem,
    time_optimal,
)

SHAPES = ("circle", "figure8")
HEADINGS = ("fixed", "tangent")
FEASIBLE = 1.0 + 1e-6  # peak demand allowed anywhere in time
PHASE_POINTS = 4000  # grid of the second method (the retimer's default grid: 1000 cells)
AGREEMENT = 0.01  # relative lap-time agreement required between the two methods


def _shape(name: str, heading: str, period: float = 10.0) -> Trajectory:
    spec = 0.0 if heading == "fixed" else "tangent"
    if name == "circle":
        return Circle(1.0, period, heading=spec)
    return FigureEight(1.0, period, heading=spec)


# ---------------------------------------------------------------- second method


def _geometry(path: Trajectory, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """g = body twist per unit sdot and h = dg/ds by central differences, each (m, 3)."""
    step = 1e-5 * (s[-1] - s[0])
    g = body_twist(path.sample(s))
    h = (body_twist(path.sample(s + step)) - body_twist(path.sample(s - step))) / (2.0 * step)
    return g, h


class _PhasePlane:
    """Admissible sddot at (s_k, b) from ||P_i b + Q_i a|| <= A_i, P_i = W_i h, Q_i = W_i g.

    |Q|^2 a^2 + 2 b (P.Q) a + |P|^2 b^2 - A^2 <= 0: an interval of a whose
    discriminant A^2 |Q|^2 - b^2 (|P|^2 |Q|^2 - (P.Q)^2) must be >= 0 (the
    cross term vanishes for one signed speed, d = 1). A wheel with Q = 0 only
    bounds b: |P| b <= A.
    """

    def __init__(self, robot: Robot, g: np.ndarray, h: np.ndarray) -> None:
        blocks = robot.wheel_blocks
        accel = robot.max_wheel_accel
        p = np.einsum("ndj,mj->mnd", blocks, h)
        q = np.einsum("ndj,mj->mnd", blocks, g)
        self.qq = (q * q).sum(axis=2)
        self.pq = (p * q).sum(axis=2)
        self.pp = (p * p).sum(axis=2)
        self.cross = np.maximum(self.pp * self.qq - self.pq**2, 0.0)
        limits = np.zeros(blocks.shape[0]) if accel is None else np.asarray(accel) ** 2
        self.limit2 = np.broadcast_to(limits, self.qq.shape)
        self.limited = accel is not None
        self.rows = [
            list(zip(*(row.tolist() for row in arrays), strict=True))
            for arrays in zip(self.qq, self.pq, self.cross, self.pp, self.limit2, strict=True)
        ]

    def interval(self, k: int, b: float) -> tuple[float, float]:
        """(lowest, highest) sddot allowed at grid point k and b; lowest > highest if none."""
        low, high = -math.inf, math.inf
        if not self.limited:
            return low, high
        for qq, pq, cross, pp, limit2 in self.rows[k]:
            if qq < 1e-14:
                if pp * b * b > limit2:
                    return math.inf, -math.inf
                continue
            disc = limit2 * qq - b * b * cross
            if disc < 0.0:
                return math.inf, -math.inf
            root = math.sqrt(disc)
            low = max(low, (-b * pq - root) / qq)
            high = min(high, (-b * pq + root) / qq)
        return low, high

    def _admissible(self, b: np.ndarray) -> np.ndarray:
        """Whether some sddot is allowed at every grid point with its b (vectorised)."""
        bb = b[:, np.newaxis]
        moving = self.qq >= 1e-14
        disc = self.limit2 * self.qq - bb**2 * self.cross
        root = np.sqrt(np.maximum(disc, 0.0))
        qq = np.where(moving, self.qq, 1.0)
        low = np.where(moving, (-bb * self.pq - root) / qq, -np.inf).max(axis=1)
        high = np.where(moving, (-bb * self.pq + root) / qq, np.inf).min(axis=1)
        each = np.where(moving, disc >= 0.0, self.pp * bb**2 <= self.limit2)
        return each.all(axis=1) & (low <= high)

    def accel_curve(self, bound: np.ndarray) -> np.ndarray:
        """Largest b <= bound at each point with some sddot allowed (bisection)."""
        if not self.limited:
            return bound.copy()
        low, high = np.zeros(bound.size), bound.copy()
        low = np.where(self._admissible(high), high, low)
        for _ in range(60):
            middle = 0.5 * (low + high)
            ok = self._admissible(middle)
            low = np.where(ok, middle, low)
            high = np.where(ok, high, middle)
        return low


def phase_plane_lap(path: Trajectory, robot: Robot, periodic: bool,
                    points: int = PHASE_POINTS, max_speed: float | None = None) -> float:
    """Lap time [s] by forward-backward integration of b = sdot^2 on ``points`` cells.

    Greatest profile under the speed bounds with (b_{k+1} - b_k) / (2 ds) at most
    the highest sddot at (s_k, b_k) and at least the lowest at (s_{k+1}, b_{k+1}),
    found by sweeping forward and backward (cyclically for steady laps) until
    nothing changes.
    """
    span = path.period if path.period is not None else path.duration
    assert span is not None
    s = path.start_time + span * np.linspace(0.0, 1.0, points + 1)
    g, h = _geometry(path, s)
    wheel = np.linalg.norm(np.einsum("ndj,mj->mnd", robot.wheel_blocks, g), axis=2)
    demand = (wheel / robot.max_wheel_speed).max(axis=1)
    if max_speed is not None:
        demand = np.maximum(demand, np.hypot(g[:, 0], g[:, 1]) / max_speed)
    with np.errstate(divide="ignore"):
        bound = np.minimum(1.0 / demand**2, 1e6)
    plane = _PhasePlane(robot, g, h)
    b = plane.accel_curve(bound)
    if periodic:
        b[0] = b[-1] = min(b[0], b[-1])
    else:
        b[0] = b[-1] = 0.0
    ds = span / points
    for _ in range(50):
        before = b.copy()
        _sweep(plane, b, ds, periodic, forward=True)
        _sweep(plane, b, ds, periodic, forward=False)
        if np.array_equal(before, b):
            break
    rates = np.sqrt(b)
    return float(np.sum(2.0 * ds / (rates[:-1] + rates[1:])))


def _sweep(plane: _PhasePlane, b: np.ndarray, ds: float, periodic: bool, forward: bool) -> None:
    last = b.size - 1
    laps = 2 if periodic else 1
    for step in range(laps * last):
        k = step % last
        if forward:
            here, there = k, k + 1
            rate = plane.interval(here, b[here])[1]
        else:
            here, there = last - k, last - k - 1
            rate = -plane.interval(here, b[here])[0]
        reach = max(b[here] + 2.0 * ds * rate, 0.0)
        if reach < b[there]:
            b[there] = reach
        if periodic:
            b[0] = b[last] = min(b[0], b[last])


# ---------------------------------------------------------------- shared results


_RETIMED: dict[tuple[str, str, str], RetimedTrajectory] = {}


def _retimed(robot_name: str, shape: str, heading: str) -> RetimedTrajectory:
    """time_optimal of a 1 m shape on a preset, computed once per test session."""
    key = (robot_name, shape, heading)
    if key not in _RETIMED:
        _RETIMED[key] = time_optimal(_shape(shape, heading), preset(robot_name))
    return _RETIMED[key]


def _accel_demand(retimed: Trajectory, robot: Robot, times: np.ndarray) -> np.ndarray:
    """max_i ||W_i du/dt|| / max_wheel_accel_i at ``times``, du/dt from sample()'s fields.

    u = R(theta)^T v  =>  du/dt = R^T a + thetadot (u_y, -u_x, 0) for the (x, y) part.
    """
    sample = retimed.sample(times)
    theta = sample.pose[:, 2]
    cos, sin = np.cos(theta), np.sin(theta)
    velocity, accel = sample.velocity, sample.acceleration
    ux = cos * velocity[:, 0] + sin * velocity[:, 1]
    uy = cos * velocity[:, 1] - sin * velocity[:, 0]
    rate = np.stack([
        cos * accel[:, 0] + sin * accel[:, 1] + velocity[:, 2] * uy,
        cos * accel[:, 1] - sin * accel[:, 0] - velocity[:, 2] * ux,
        accel[:, 2],
    ], axis=1)
    wheel = np.linalg.norm(np.einsum("ndj,mj->mnd", robot.wheel_blocks, rate), axis=2)
    assert robot.max_wheel_accel is not None
    return (wheel / robot.max_wheel_accel).max(axis=1)


# ---------------------------------------------------------------- the second method


@pytest.mark.parametrize("heading", HEADINGS)
@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("robot_name", ACCEL_PRESETS)
def test_lap_time_agrees_with_phase_plane_integration(robot_name: str, shape: str,
                                                      heading: str) -> None:
    retimed = _retimed(robot_name, shape, heading)
    expected = phase_plane_lap(retimed.source, preset(robot_name), periodic=True)
    assert retimed.period == retimed.lap_time
    assert retimed.lap_time == pytest.approx(expected, rel=AGREEMENT)
    # the cone program is the more conservative discretisation, and close: 0.06% or better
    assert 0.0 <= retimed.lap_time / expected - 1.0 < 1e-3


@pytest.mark.parametrize("heading", HEADINGS)
@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("robot_name", ACCEL_PRESETS)
def test_timed_trajectory_is_within_every_limit_between_grid_points(
        robot_name: str, shape: str, heading: str) -> None:
    robot = preset(robot_name)
    retimed = _retimed(robot_name, shape, heading)
    cells = retimed.grid.s.size - 1
    samples = 16 * cells + 1  # 16 times finer than the solve grid, in time
    speed = feasibility(retimed, robot, samples=samples).peak_ratio
    assert 1.0 - 1e-4 < speed <= FEASIBLE
    times = np.linspace(0.0, retimed.lap_time, samples)
    accel = _accel_demand(retimed, robot, times).max()
    assert accel <= FEASIBLE
    info = retimed.info
    assert info is not None and info.status == "Solved"
    assert 1.0 <= info.stretch < 1.0 + 1e-4
    assert info.speed_demand <= 1.0 and info.accel_demand <= 1.0


def test_rest_to_rest_agrees_with_phase_plane_and_ends_at_rest() -> None:
    robot = preset("omni3")
    source = _shape("figure8", "tangent")
    retimed = time_optimal(source, robot, periodic=False)
    assert retimed.period is None and retimed.end_time == pytest.approx(retimed.lap_time)
    expected = phase_plane_lap(source, robot, periodic=False)
    assert retimed.lap_time == pytest.approx(expected, rel=AGREEMENT)
    assert retimed.lap_time > _retimed("omni3", "figure8", "tangent").lap_time
    ends = retimed.sample([retimed.start_time, retimed.lap_time, retimed.lap_time + 1.0])
    np.testing.assert_allclose(ends.velocity, 0.0, atol=1e-12)
    np.testing.assert_allclose(ends.pose[2], ends.pose[1], atol=1e-9)
    np.testing.assert_allclose(ends.acceleration[2], 0.0)
    assert retimed.grid.sdot[0] == 0.0 and retimed.grid.sdot[-1] == 0.0
    times = np.linspace(0.0, retimed.lap_time, 16001)
    assert feasibility(retimed, robot, samples=16001).peak_ratio <= FEASIBLE
    assert _accel_demand(retimed, robot, times).max() <= FEASIBLE


def test_waypoints_from_rest_to_rest() -> None:
    robot = preset("mecanum")
    source = Waypoints([1.0, 3.0, 5.0, 8.0],
                       [[0.0, 0.0, 0.0], [1.0, 0.5, 0.4], [2.0, -0.5, 0.8], [3.0, 0.0, 0.0]])
    retimed = time_optimal(source, robot)
    end = retimed.end_time
    assert retimed.period is None and retimed.start_time == 1.0 and end is not None
    expected = phase_plane_lap(source, robot, periodic=False)
    assert retimed.lap_time == pytest.approx(expected, rel=AGREEMENT)
    ends = retimed.sample([1.0, end])
    np.testing.assert_allclose(ends.pose, source.sample([1.0, 8.0]).pose, atol=1e-9)
    np.testing.assert_allclose(ends.velocity, 0.0, atol=1e-9)
    assert feasibility(retimed, robot, samples=16001).peak_ratio <= FEASIBLE
    times = np.linspace(1.0, end, 16001)
    assert _accel_demand(retimed, robot, times).max() <= FEASIBLE


# ---------------------------------------------------------------- closed forms


def _omni4_without_accel_limits() -> Robot:
    robot = omni(n_wheels=4, base_radius=0.20, wheel_radius=0.05, max_wheel_speed=20.0,
                 first_wheel_angle=math.pi / 4.0, max_wheel_accel=None)
    np.testing.assert_allclose(robot.wheel_blocks, preset("omni4").wheel_blocks, atol=1e-15)
    return robot


@pytest.mark.parametrize("radius", [0.5, 1.5])
def test_circle_at_fixed_heading_on_omni4_x_matches_closed_form(radius: float) -> None:
    # At fixed heading the body moves along phi (the circle's tangent direction) at speed v
    # and wheel i's rim turns at r phidot_i = v sin(phi - alpha_i), alpha_i = 45 + 90 i deg.
    # Top speed v(phi) = r w / max_i |sin(phi - alpha_i)|, so the lap is
    # T = integral of R dphi / v(phi) = R / (r w) * integral_0^{2 pi} max_i |sin(phi - alpha_i)|.
    # On [0, pi/2] the max is sin(phi + pi/4) (wheel at 135 deg), integral 2 cos(pi/4);
    # four such quarters: T = R * 8 cos(pi/4) / (r w).
    robot = _omni4_without_accel_limits()
    expected = radius * 8.0 * math.cos(math.pi / 4.0) / (0.05 * 20.0)
    retimed = time_optimal(Circle(radius, 3.0, center=(0.3, -0.2), heading=0.4 - 0.4), robot)
    assert retimed.lap_time == pytest.approx(expected, rel=2e-5)
    assert feasibility(retimed, robot, samples=16001).peak_ratio <= FEASIBLE
    speeds = np.hypot(*retimed.sample(np.linspace(0.0, retimed.lap_time, 4001)).velocity[:, :2].T)
    # fastest where two wheels share the load (phi = 0 mod 90 deg): r w / cos(pi/4)
    assert speeds.max() == pytest.approx(1.0 / math.cos(math.pi / 4.0), rel=1e-3)
    assert speeds.min() == pytest.approx(1.0, rel=1e-4)  # a wheel in line with the motion


def test_circle_at_fixed_heading_on_mecanum_matches_closed_form() -> None:
    # Rim speeds vx -+ vy (omega = 0): the largest is |vx| + |vy| = v (|cos phi| + |sin phi|),
    # so T = R / (r w) * integral_0^{2 pi} (|cos phi| + |sin phi|) dphi = 8 R / (r w);
    # the preset's acceleration limit is not met on a 1 m circle.
    robot = preset("mecanum")
    retimed = time_optimal(Circle(1.0, 10.0, heading=0.0), robot)
    assert retimed.lap_time == pytest.approx(8.0 * 1.0 / (0.05 * 20.0), rel=5e-5)
    assert retimed.info is not None and retimed.info.accel_demand < 1.0


class _Line(Trajectory):
    """A straight segment from the origin along ``direction`` [rad] at 1 m/s, ``length`` [m]."""

    def __init__(self, length: float, direction: float) -> None:
        self._length = length
        self._unit = np.array([math.cos(direction), math.sin(direction)])
        super().__init__(0.0)

    @property
    def end_time(self) -> float:
        return self._length

    def _path(self, t: np.ndarray) -> PathDerivatives:
        zero = np.zeros(np.shape(t) + (2,))
        return PathDerivatives(np.multiply.outer(t, self._unit), zero + self._unit, zero, zero)


@pytest.mark.parametrize(("length", "cap"), [(2.0, 0.5), (0.05, 0.5)])
def test_straight_line_with_speed_cap_is_a_trapezoid(length: float, cap: float) -> None:
    # Along a fixed direction phi at fixed heading the wheel accelerations are
    # a sin(phi - alpha_i) / r, so the path acceleration limit is A r / max_i |sin(phi - alpha_i)|.
    robot = preset("omni4")
    direction = 0.3
    alphas = math.pi / 4.0 + 0.5 * math.pi * np.arange(4)
    accel = 40.0 * 0.05 / np.abs(np.sin(direction - alphas)).max()  # [m/s^2]
    assert cap < 1.0 / np.abs(np.sin(direction - alphas)).max()  # the wheel speed limit is not met
    if length >= cap * cap / accel:  # trapezoid: accelerate, cruise at the cap, brake
        expected = length / cap + cap / accel
    else:  # triangle: never reaches the cap
        expected = 2.0 * math.sqrt(length / accel)
    retimed = time_optimal(_Line(length, direction), robot, max_speed=cap)
    assert retimed.lap_time == pytest.approx(expected, rel=2e-3)
    sample = retimed.sample(np.linspace(0.0, retimed.lap_time, 8001))
    speed = np.hypot(sample.velocity[:, 0], sample.velocity[:, 1])
    assert speed.max() <= cap * FEASIBLE
    path_accel = np.hypot(sample.acceleration[:, 0], sample.acceleration[:, 1])
    assert path_accel.max() <= accel * FEASIBLE
    assert path_accel.max() == pytest.approx(accel, rel=1e-5)


class _BackAndForth(Trajectory):
    """x = cos(t), y = 0: periodic (2 pi), reverses at x = +-1 where dq/ds = 0."""

    def __init__(self) -> None:
        super().__init__(0.0)

    @property
    def period(self) -> float:
        return 2.0 * math.pi

    def _path(self, t: np.ndarray) -> PathDerivatives:
        zero = np.zeros_like(t)
        return PathDerivatives(*(np.stack((f, zero), axis=-1) for f in (
            np.cos(t), -np.sin(t), -np.cos(t), np.sin(t))))


def test_a_path_that_reverses_stops_there_two_trapezoids() -> None:
    # Nothing bounds sdot where dq/ds = 0, yet the robot must stop to reverse: each
    # 2 m pass along x is a rest-to-rest trapezoid at the omni-4 X's top speed along x,
    # r w / cos(pi/4), and acceleration A r / cos(pi/4).
    robot = preset("omni4")
    speed, accel = 1.0 / math.cos(math.pi / 4.0), 2.0 / math.cos(math.pi / 4.0)
    expected = 2.0 * (2.0 / speed + speed / accel)
    retimed = time_optimal(_BackAndForth(), robot)
    assert retimed.lap_time == pytest.approx(expected, rel=2e-4)
    turn = retimed.sample([0.0, 0.5 * retimed.lap_time])
    np.testing.assert_allclose(turn.velocity, 0.0, atol=1e-9)
    assert feasibility(retimed, robot, samples=16001).peak_ratio <= FEASIBLE


# ---------------------------------------------------------------- the timed trajectory


@pytest.mark.parametrize(("shape", "winding"), [("circle", 2.0 * math.pi), ("figure8", 0.0)])
def test_steady_laps_repeat(shape: str, winding: float) -> None:
    retimed = _retimed("mecanum", shape, "tangent")
    grid = retimed.grid
    assert grid.sdot[0] == grid.sdot[-1] > 0.0
    assert grid.t[0] == 0.0 and grid.t[-1] == pytest.approx(retimed.lap_time, rel=1e-15)
    rng = np.random.default_rng(7)
    times = rng.uniform(-5.0, 5.0, 50)
    first, later = retimed.sample(times), retimed.sample(times + 2.0 * retimed.lap_time)
    np.testing.assert_allclose(later.pose[:, :2], first.pose[:, :2], atol=1e-9)
    np.testing.assert_allclose(later.pose[:, 2], first.pose[:, 2] + 2.0 * winding, atol=1e-9)
    np.testing.assert_allclose(later.velocity, first.velocity, atol=1e-8)
    np.testing.assert_allclose(later.acceleration, first.acceleration, atol=1e-6)
    # across the seam of a lap: the speed is continuous
    seam = retimed.sample([retimed.lap_time - 1e-9, retimed.lap_time + 1e-9])
    np.testing.assert_allclose(seam.velocity[0], seam.velocity[1], atol=1e-7)


def test_sample_derivatives_match_finite_differences_of_the_pose() -> None:
    retimed = _retimed("omni3", "figure8", "tangent")
    rng = np.random.default_rng(11)
    times = rng.uniform(-retimed.lap_time, 2.0 * retimed.lap_time, 200)
    phase = np.mod(times, retimed.lap_time)
    grid_times = retimed.grid.t
    nearest = np.abs(phase[:, np.newaxis] - grid_times[np.newaxis, :]).min(axis=1)
    times = times[nearest > 1e-5]  # sddot jumps at grid points: stay clear of them
    step = 1e-6
    sample = retimed.sample(times)
    before, after = retimed.sample(times - step), retimed.sample(times + step)
    velocity = (after.pose - before.pose) / (2.0 * step)
    np.testing.assert_allclose(sample.velocity, velocity, atol=1e-7)
    accel = (after.velocity - before.velocity) / (2.0 * step)
    np.testing.assert_allclose(sample.acceleration, accel, atol=1e-6)
    path = retimed.path(times)
    np.testing.assert_allclose(path.position, sample.pose[:, :2], atol=1e-15)
    np.testing.assert_allclose(path.velocity, sample.velocity[:, :2], atol=1e-15)
    np.testing.assert_allclose(path.acceleration, sample.acceleration[:, :2], atol=1e-12)
    jerk = (retimed.path(times + step).acceleration - retimed.path(times - step).acceleration)
    np.testing.assert_allclose(path.jerk, jerk / (2.0 * step), atol=1e-5)
    heading = retimed.heading.evaluate(times, path)
    np.testing.assert_allclose(heading.angle, sample.pose[:, 2], atol=1e-15)
    np.testing.assert_allclose(heading.rate, sample.velocity[:, 2], atol=1e-12)
    np.testing.assert_allclose(heading.acceleration, sample.acceleration[:, 2], atol=1e-10)


def test_the_source_heading_is_kept() -> None:
    tangent = _retimed("swerve", "figure8", "tangent")
    sample = tangent.sample(np.linspace(0.0, 3.0 * tangent.lap_time, 3001))
    direction = np.arctan2(sample.velocity[:, 1], sample.velocity[:, 0])
    turn = np.angle(np.exp(1j * (sample.pose[:, 2] - direction)))
    np.testing.assert_allclose(turn, 0.0, atol=1e-9)
    source = FigureEight(1.0, 10.0, heading=SpinHeading(rate=0.7, initial=0.2))
    spinning = time_optimal(source, preset("omni4"), samples=200)
    times = np.linspace(-2.0, 2.0 * spinning.lap_time, 301)
    s, sdot, sddot = spinning.path_parameter(times)
    np.testing.assert_allclose(spinning.sample(times).pose, source.sample(s).pose, atol=1e-12)
    np.testing.assert_allclose(spinning.sample(times).velocity[:, 2], 0.7 * sdot, atol=1e-12)
    assert sddot.shape == times.shape


def test_caps_on_path_speed_and_heading_rate() -> None:
    robot = preset("swerve")  # 1.5 m/s at the rim
    capped = time_optimal(Circle(1.0, 10.0, heading=0.0), robot, max_speed=1.0)
    assert capped.lap_time == pytest.approx(2.0 * math.pi, rel=1e-6)
    source = _shape("figure8", "fixed")
    capped = time_optimal(source, robot, max_speed=0.8)
    sample = capped.sample(np.linspace(0.0, capped.lap_time, 16001))
    speed = np.hypot(sample.velocity[:, 0], sample.velocity[:, 1])
    assert 0.8 * (1.0 - 1e-4) < speed.max() <= 0.8 * FEASIBLE
    expected = phase_plane_lap(source, robot, periodic=True, max_speed=0.8)
    assert capped.lap_time == pytest.approx(expected, rel=AGREEMENT)
    assert capped.lap_time > _retimed("swerve", "figure8", "fixed").lap_time
    turning = time_optimal(Circle(1.0, 10.0, heading="tangent"), robot, max_heading_rate=0.5)
    assert turning.lap_time == pytest.approx(2.0 * math.pi / 0.5, rel=1e-6)
    assert np.abs(turning.sample(np.linspace(0.0, 13.0, 101)).velocity[:, 2]).max() <= 0.5


@pytest.mark.parametrize("period", [0.5, 50.0])
def test_only_the_geometry_matters(period: float) -> None:
    # the source's own timing and where the path lies are not part of the answer
    robot = preset("omni3")
    reference = _retimed("omni3", "figure8", "tangent").lap_time
    moved = FigureEight(1.0, period, center=(3.0, -2.0), heading="tangent")
    assert time_optimal(moved, robot).lap_time == pytest.approx(reference, rel=1e-6)


def test_grid_and_info_are_exposed_read_only() -> None:
    retimed = _retimed("omni4", "circle", "fixed")
    grid = retimed.grid
    assert grid.s.shape == grid.sdot.shape == grid.t.shape == (1001,)
    assert grid.sddot.shape == (1000,)
    np.testing.assert_allclose(grid.s[[0, -1]], [0.0, 10.0])
    for array in grid:
        with pytest.raises(ValueError):
            array[0] = 1.0
    s, sdot, _ = retimed.path_parameter(grid.t[:-1])
    np.testing.assert_allclose(s, grid.s[:-1], atol=1e-12)
    np.testing.assert_allclose(sdot, grid.sdot[:-1], atol=1e-12)
    info = retimed.info
    assert info is not None
    assert retimed.lap_time == pytest.approx(info.solver_lap_time * info.stretch, rel=1e-9)
    assert "RetimedTrajectory" in repr(retimed) and "steady laps" in repr(retimed)


# ---------------------------------------------------------------- bad input


class _Endless(Trajectory):
    """A straight line at 1 m/s, neither periodic nor finite."""

    def _path(self, t: np.ndarray) -> PathDerivatives:
        zero = np.zeros(np.shape(t) + (2,))
        velocity = zero.copy()
        velocity[..., 0] = 1.0
        return PathDerivatives(velocity * np.asarray(t)[..., np.newaxis], velocity, zero, zero)


class _FakeRobot:
    def __init__(self, blocks: object, speed: object, accel: object = None) -> None:
        self.wheel_blocks = blocks
        self.max_wheel_speed = speed
        self.max_wheel_accel = accel


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"path": "circle"}, "path must be a trajectories.Trajectory"),
    ({"path": _Endless(0.0)}, "path must be periodic or finite"),
    ({"path": Waypoints([0.0, 1.0], [[0, 0, 0], [1, 0, 0]]), "periodic": True},
     "periodic=True needs a periodic path"),
    ({"periodic": "yes"}, "periodic must be None, True or False"),
    ({"samples": 3},
     r"samples must be an integer from 16 to 20000 \(grid cells along the path; .*got 3"),
    ({"samples": 100.0}, "samples must be an integer from 16 to 20000"),
    ({"samples": True}, "samples must be an integer from 16 to 20000"),
    ({"max_speed": -1.0}, r"max_speed \[m/s\] must be a finite number > 0, got -1.0"),
    ({"max_speed": math.nan}, r"max_speed \[m/s\] must be a finite number > 0"),
    ({"max_heading_rate": "fast"}, r"max_heading_rate \[rad/s\] must be a finite number > 0"),
    ({"robot": object()}, "robot must have wheel_blocks"),
    ({"robot": _FakeRobot(np.zeros((3, 3)), np.ones(3))}, r"wheel_blocks of shape \(3, 3\)"),
    ({"robot": _FakeRobot(np.ones((3, 1, 3)), np.ones(2))}, "max_wheel_speed"),
    ({"robot": _FakeRobot(np.ones((3, 1, 3)), -np.ones(3))}, "max_wheel_speed"),
    ({"robot": _FakeRobot(np.ones((3, 1, 3)), np.ones(3), np.zeros(3))}, "max_wheel_accel"),
    ({"robot": _FakeRobot(np.full((3, 1, 3), np.nan), np.ones(3))}, "not all finite"),
])
def test_bad_arguments_are_named(kwargs: dict[str, object], message: str) -> None:
    arguments: dict[str, object] = {"path": Circle(1.0, 10.0), "robot": preset("omni4")}
    arguments.update(kwargs)
    path, robot = arguments.pop("path"), arguments.pop("robot")
    with pytest.raises(TrajectoryError, match=message):
        time_optimal(path, robot, **arguments)  # type: ignore[arg-type]


def test_a_path_of_zero_length_is_refused() -> None:
    still = Waypoints([0.0, 1.0, 2.0], [[0.5, 0.5, 0.2]] * 3)
    with pytest.raises(TrajectoryError, match="a path of zero length"):
        time_optimal(still, preset("omni3"))


def test_a_path_that_needs_a_failed_wheel_is_refused() -> None:
    robot = preset("omni4").derated({0: 0.0})
    with pytest.raises(TrajectoryError, match="speed limit is 0 rad/s"):
        time_optimal(Circle(1.0, 10.0), robot)


def test_a_solver_failure_names_the_status(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(retiming_problem, "MAX_ITERATIONS", 2)
    with pytest.raises(TrajectoryError, match="clarabel status MaxIterations after 2 iterations"):
        time_optimal(Circle(1.0, 10.0), preset("omni4"), samples=50)


@pytest.mark.parametrize(("s", "sdot", "periodic", "message"), [
    ([0.0, 5.0, 10.0], [1.0, 1.0], True, "same length"),
    ([0.0, 5.0, 5.0], [1.0, 1.0, 1.0], True, "strictly increasing"),
    ([0.0, 5.0, 10.0], [1.0, -1.0, 1.0], True, "sdot must be >= 0"),
    ([0.0, 5.0, 10.0], [0.0, 0.0, 1.0], False, "two neighbouring grid points"),
    ([0.0, 5.0, 9.0], [1.0, 1.0, 1.0], True, "one source period"),
    ([0.0, 5.0, 10.0], [1.0, 1.0, 2.0], True, "same sdot at both ends"),
    ([0.0, 5.0, 10.0], [1.0, 1.0, 1.0], 1, "periodic must be True or False"),
])
def test_retimed_trajectory_checks_its_grid(s: list[float], sdot: list[float],
                                            periodic: bool, message: str) -> None:
    with pytest.raises(TrajectoryError, match=message):
        RetimedTrajectory(Circle(1.0, 10.0), s, sdot, periodic=periodic)


def test_a_retimed_trajectory_from_its_own_grid() -> None:
    # constant sdot = 2 on a 10 s circle: the same circle in 5 s
    source = Circle(1.0, 10.0, heading="tangent")
    faster = RetimedTrajectory(source, np.linspace(0.0, 10.0, 17), np.full(17, 2.0),
                               periodic=True)
    assert faster.period == pytest.approx(5.0, rel=1e-14) and faster.info is None
    times = np.linspace(-3.0, 7.0, 23)
    expected = Circle(1.0, 5.0, heading="tangent").sample(times)
    sample = faster.sample(times)
    np.testing.assert_allclose(sample.pose, expected.pose, atol=1e-12)
    np.testing.assert_allclose(sample.velocity, expected.velocity, atol=1e-12)
    np.testing.assert_allclose(sample.acceleration, expected.acceleration, atol=1e-12)


def _slow_steering_swerve(steer_rate: float) -> Robot:
    from mpc.robots import swerve

    return swerve(module_positions=[[0.25, 0.25], [0.25, -0.25], [-0.25, 0.25],
                                    [-0.25, -0.25]], wheel_radius=0.05, max_wheel_speed=30.0,
                  max_steer_rate=steer_rate, max_wheel_accel=60.0)


@pytest.mark.parametrize("steer_rate", [0.5, 1.0])
def test_circle_at_fixed_heading_on_swerve_with_slow_steering_matches_closed_form(
        steer_rate: float) -> None:
    # At fixed heading every module moves with the body, along the circle's tangent, which
    # turns at v / R: the steering limit caps the speed at v = steer_rate R (below the
    # wheels' 1.5 m/s and the 3 m/s^2 their acceleration allows at R = 1 m), so a lap of
    # 2 pi R takes 2 pi / steer_rate, whatever the radius.
    robot = _slow_steering_swerve(steer_rate)
    retimed = time_optimal(Circle(1.0, 3.0, heading=0.2), robot)
    assert retimed.lap_time == pytest.approx(2.0 * math.pi / steer_rate, rel=1e-4)
    assert retimed.info is not None
    assert retimed.info.steer_demand == pytest.approx(1.0, abs=1e-4)
    report = feasibility(retimed, robot, samples=4001)
    assert report.steer_ratio == pytest.approx(1.0, abs=1e-4) and report.is_feasible
    # the same circle twice as fast asks twice the steering rate
    twice = Circle(1.0, math.pi / steer_rate, heading=0.2)
    assert feasibility(twice, robot).steer_ratio == pytest.approx(2.0, rel=1e-9)
    assert not feasibility(twice, robot).is_feasible


def _module_turn_rates(trajectory: Trajectory, robot: Robot, times: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Each module's direction rate by finite differences of its velocity's angle (modulo a
    half turn, the flip rule) and its speed [rad/s], (k - 1, n): the independent answer."""
    velocities = robot.wheel_velocities(trajectory.body_twist(times))  # (k, n, 2)
    angles = np.unwrap(2.0 * np.arctan2(velocities[..., 1], velocities[..., 0]), axis=0) / 2.0
    rates = np.abs(np.diff(angles, axis=0)) / np.diff(times)[:, None]
    speeds = np.linalg.norm(velocities, axis=-1)
    return rates, np.minimum(speeds[1:], speeds[:-1])


@pytest.mark.parametrize(("name", "path"), [
    ("swerve", "out-and-back"), ("caster4", "out-and-back"), ("caster4", "figure8")])
def test_retimed_steered_modules_turn_within_their_steering_rate(name: str, path: str) -> None:
    """Tight turns (a 0.1 m radius out-and-back, a 0.3 m figure-eight) at the wheels' own
    pace ask the steered modules to turn several times faster than they can; the retimed
    timing keeps every module that moves above the steering floor within its rate
    (finite differences of the module angles, not the retimer's own measure)."""
    from trajectories import OutAndBack
    from trajectories.steering import STEER_FLOOR

    robot = preset(name)
    source = (OutAndBack(2.0, 8.0, width=0.2) if path == "out-and-back"
              else FigureEight(0.3, 8.0))
    retimed = time_optimal(source, robot, samples=400)
    assert retimed.info is not None and retimed.info.steer_demand <= 1.0
    from types import SimpleNamespace

    unsteered = SimpleNamespace(wheel_blocks=robot.wheel_blocks,
                                max_wheel_speed=robot.max_wheel_speed,
                                max_wheel_accel=robot.max_wheel_accel)  # no steering limits
    unlimited = time_optimal(source, unsteered, samples=400)
    # the steering limits bind (measured 1.018x on the swerve, 1.16x and 1.26x on casters)
    assert retimed.lap_time > 1.01 * unlimited.lap_time
    assert feasibility(unlimited, robot).steer_ratio > 1.3  # ... which ignoring them breaks
    times = np.linspace(0.0, retimed.lap_time, 40001)
    rates, speeds = _module_turn_rates(retimed, robot, times)
    counted = speeds > STEER_FLOOR * robot.max_wheel_speed * (1.0 + 1e-3)
    limits = robot.max_steer_rates
    assert limits is not None
    assert (rates[counted] <= np.broadcast_to(limits, rates.shape)[counted]
            * (1.0 + 2e-3)).all()


@pytest.mark.parametrize(("length", "start"), [(2.0, 0.3), (2.0, 0.5), (0.004, 0.5)])
def test_a_pass_from_a_moving_start_is_the_trapezoid_from_that_speed(length: float,
                                                                      start: float) -> None:
    """``start_speed``: a new plan for a robot under way. On the straight line at a cap the
    pass starts at the robot's speed, speeds up to the cap and brakes to rest: (cap - v0) /
    A + (L - (cap^2 - v0^2) / 2A - cap^2 / 2A) / cap + cap / A; a line too short to brake
    from v0 starts slower (never a plan that cannot stop)."""
    robot = preset("omni4")
    direction, cap = 0.3, 0.5
    alphas = math.pi / 4.0 + 0.5 * math.pi * np.arange(4)
    accel = 40.0 * 0.05 / np.abs(np.sin(direction - alphas)).max()  # [m/s^2], as above
    retimed = time_optimal(_Line(length, direction), robot, max_speed=cap, periodic=False,
                           start_speed=start)
    first = float(np.hypot(*retimed.sample(0.0).velocity[:2]))
    if start * start / (2.0 * accel) <= length:  # it can stop from the robot's speed
        cruise = length - (cap**2 - start**2) / (2 * accel) - cap**2 / (2 * accel)
        expected = (cap - start) / accel + cruise / cap + cap / accel
        assert first == pytest.approx(start, rel=1e-3)
        assert retimed.lap_time == pytest.approx(expected, rel=2e-3)
    else:
        assert first <= math.sqrt(2.0 * accel * length) * FEASIBLE  # slower: it stops in time
    sample = retimed.sample(np.linspace(0.0, retimed.lap_time, 8001))
    path_accel = np.hypot(sample.acceleration[:, 0], sample.acceleration[:, 1])
    assert path_accel.max() <= accel * FEASIBLE
    assert float(np.hypot(*retimed.sample(retimed.lap_time).velocity[:2])) < 1e-12  # at rest
    with pytest.raises(TrajectoryError, match="start_speed applies to one pass"):
        time_optimal(Circle(1.0, 3.0), robot, start_speed=0.5)


def test_a_spinning_heading_does_not_stretch_the_lap_at_the_steering_floor() -> None:
    """The steering demand is continuous at the floor (``min(rate / limit, speed /
    floor)``): a module just over its floor between grid points used to count its whole
    turn rate, and that one spike scaled a caster's spinning figure-eight to 11x its solver
    lap (49.8 against 4.39 s). What the check still finds between grid points is repaired
    where it is (1.17x the solver lap when the whole lap was scaled for it; 1.007x)."""
    from trajectories import SpinHeading

    retimed = time_optimal(FigureEight(0.5, 10.0, heading=SpinHeading(0.75)), preset("caster4"))
    assert retimed.info is not None
    assert retimed.info.stretch < 1.02
    assert retimed.info.steer_demand <= 1.0 + 1e-9


def test_a_knot_inside_a_cell_is_repaired_where_it_is() -> None:
    """A monotone (PCHIP) interpolant through a 3 m line that ends by turning in place: its
    curvature jumps at the knot where the turn begins (x'' about -80 before, 0 after),
    inside a grid cell, and the cell's acceleration between grid points is 3x the limit.
    Scaling the whole lap for it doubled the lap (8.94 against 4.48 s); bounding that
    cell's speeds and solving again costs 0.9 %, and the timing stays within every limit
    (checked by :func:`feasibility` on its own samples)."""
    from scipy.interpolate import PchipInterpolator

    from trajectories import SampledTrajectory

    robot = preset("mecanum")
    poses = np.stack([np.linspace(0.0, 3.0, 61), np.zeros(61), np.zeros(61)], axis=1)
    poses = np.vstack([poses, [3.0, 0.0, math.pi / 2]])
    steps = np.diff(poses, axis=0)
    lengths = np.hypot(np.hypot(steps[:, 0], steps[:, 1]), 0.3 * steps[:, 2])
    times = np.concatenate(([0.0], np.cumsum(lengths)))
    path = SampledTrajectory(times, poses, PchipInterpolator(times, poses, axis=0)(times, 1))
    retimed = time_optimal(path, robot, periodic=False, max_speed=1.0)
    assert retimed.info is not None and retimed.info.repairs >= 1
    assert retimed.info.stretch < 1.02
    assert feasibility(retimed, robot, samples=20001).peak_ratio <= 1.0 + 1e-6
    times = np.linspace(0.0, retimed.lap_time, 40001)  # wheel accelerations by differences
    wheels = retimed.body_twist(times) @ robot.wheel_blocks[:, 0].T
    accel = np.abs(np.diff(wheels, axis=0)) / np.diff(times)[:, None]
    assert robot.max_wheel_accel is not None
    assert (accel <= robot.max_wheel_accel * 1.01).all()
    scaled = time_optimal(path, robot, periodic=False, max_speed=1.0, max_repairs=0)
    assert scaled.info is not None and scaled.info.repairs == 0
    assert scaled.lap_time > 1.5 * retimed.lap_time
    for bad in (-1, 21, 1.5, True):
        with pytest.raises(TrajectoryError, match="max_repairs must be an integer from 0 to 20"):
            time_optimal(path, robot, periodic=False, max_repairs=bad)  # type: ignore[arg-type]


def test_a_failed_module_is_not_held_to_its_steering_rate() -> None:
    """A swerve module with speed limit 0 is held at rest: its direction (rounding) has no
    steering demand. Pivoting about it takes as long as about a module derated to 1e-6."""
    from trajectories import TangentHeading

    robot = preset("swerve")
    pivot = Circle(math.hypot(0.3, 0.3), 5.0, heading=TangentHeading(math.pi / 4))
    failed = robot.derated({0: 0.0})
    assert feasibility(pivot, failed).steer_ratio < 1e-9
    assert time_optimal(pivot, failed).lap_time == pytest.approx(
        time_optimal(pivot, robot.derated({0: 1e-6})).lap_time, rel=1e-6)


@pytest.mark.parametrize("name", ["mecanum", "swerve"])
def test_a_sampled_path_without_accelerations_is_checked_at_its_knots(name: str) -> None:
    """Samples joined by cubic Hermite pieces (no accelerations given: C1) have an
    acceleration that jumps at every sample; the check takes each knot from both sides, so
    the timing keeps the wheel accelerations within their limits there too (finite
    differences of the retimed wheel velocities; measured 1.0016x and 1.0026x the limit
    when the uniform check grid straddled the knots)."""
    from trajectories import SampledTrajectory

    source = FigureEight(1.0, 10.0, heading="tangent")
    times = np.linspace(0.0, 10.0, 21)
    sample = source.sample(times)
    path = SampledTrajectory(times, sample.pose, sample.velocity)
    from benchmarks.retiming_cases import peak_wheel_accel_ratio

    robot = preset(name)
    retimed = time_optimal(path, robot, periodic=False)
    assert peak_wheel_accel_ratio(retimed, robot) <= 1.0 + 2e-4


def test_the_retiming_cases_script_measures_what_the_readme_quotes() -> None:
    """``python -m benchmarks.retiming_cases``: its cheap parts by themselves (the goal
    overshoot of the plain splines and of path_reference; the steering case), and it takes
    no options."""
    from benchmarks import retiming_cases

    lines: list[str] = []
    overshoot = retiming_cases.goal_overshoot(lines.append)
    assert overshoot["natural splines"] > 0.1 and overshoot["path_reference"] < 1e-9
    steered, unsteered, demand = retiming_cases.steering(lines.append)
    assert steered > 1.2 * unsteered and demand > 2.0
    assert len(lines) == 3
    assert retiming_cases.main(["--bogus"]) == 2
