"""The CasADi tracking model: dynamics, linearisation and cost against independent answers.

- Dynamics: a fine RK4 integration of ``d/dt pose = R(theta) @ twist`` with the
  twist held constant (the exact answer up to ~1e-13).
- Linearisation: central finite differences of the dynamics at seeded random
  points, and the affine model reproducing ``f`` at its own linearisation point.
- Cost: a hand-written NumPy version of the cost stated in ``Weights``' docstring.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from numpy.typing import ArrayLike

from mpc.model import (
    SMALL_ROTATION,
    TrackingModel,
    Weights,
    integrate,
    make_weights,
    twist_integral,
)
from mpc.robots import SwerveRobot, preset

DT = 0.05
HORIZON = 6


def rk4_pose(pose: np.ndarray, twist: np.ndarray, dt: float, steps: int = 2000) -> np.ndarray:
    """Integrate d/dt pose = R(theta) @ twist for ``dt`` seconds with a fine classic RK4."""

    def rate(p: np.ndarray) -> np.ndarray:
        c, s = math.cos(p[2]), math.sin(p[2])
        return np.array([c * twist[0] - s * twist[1], s * twist[0] + c * twist[1], twist[2]])

    h = dt / steps
    p = np.array(pose, dtype=float)
    for _ in range(steps):
        k1 = rate(p)
        k2 = rate(p + 0.5 * h * k1)
        k3 = rate(p + 0.5 * h * k2)
        k4 = rate(p + h * k3)
        p = p + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return p


def integral_function(dt: float) -> ca.Function:
    """``twist_integral`` wrapped as a CasADi function of (pose, twist)."""
    pose, twist = ca.SX.sym("x", 3), ca.SX.sym("u", 3)
    return ca.Function("integral", [pose, twist], [twist_integral(pose, twist, dt)])


def make_model(robot_name: str = "mecanum", weights: Weights | None = None,
               tick: float | None = None) -> TrackingModel:
    return TrackingModel(preset(robot_name), HORIZON, DT, weights or Weights(), tick=tick)


def evaluate(function: ca.Function, *args: ArrayLike) -> np.ndarray:
    return np.asarray(function(*[np.asarray(a, dtype=float) for a in args]).full(),
                      dtype=float).ravel()


# Rotation over one tick, |omega dt| [rad], around the Taylor switch at 1e-3.
ANGLES = {
    "zero": 0.0,
    "tiny": 1e-9,
    "below_switch": SMALL_ROTATION * (1.0 - 1e-6),
    "above_switch": SMALL_ROTATION * (1.0 + 1e-6),
    "moderate": 0.2,
    "large": 2.5,
    "beyond_pi": -4.0,
}


# Dynamics ------------------------------------------------------------------


@pytest.mark.parametrize("angle", ANGLES.values(), ids=ANGLES.keys())
@pytest.mark.parametrize("dt", [DT, 0.3])
def test_twist_integral_matches_fine_rk4(angle: float, dt: float) -> None:
    rng = np.random.default_rng(1)
    integral = integral_function(dt)
    for _ in range(5):
        pose = rng.uniform([-2.0, -2.0, -7.0], [2.0, 2.0, 7.0])
        twist = np.array([*rng.uniform(-1.5, 1.5, 2), angle / dt])
        np.testing.assert_allclose(
            evaluate(integral, pose, twist), rk4_pose(pose, twist, dt), rtol=0, atol=1e-12
        )


@pytest.mark.parametrize("angle", ANGLES.values(), ids=ANGLES.keys())
def test_model_dynamics_is_the_twist_integral_at_the_model_dt(angle: float) -> None:
    model = make_model()
    pose, twist = np.array([0.3, -1.2, 2.0]), np.array([0.7, -0.4, angle / DT])
    np.testing.assert_allclose(
        evaluate(model.dynamics, pose, twist), rk4_pose(pose, twist, DT), rtol=0, atol=1e-12
    )


def test_hand_answers() -> None:
    """Straight line, pure rotation and a quarter circle, worked out by hand."""
    integral = integral_function(1.0)
    # Straight: heading pi/2 and a body twist forward moves along +y.
    np.testing.assert_allclose(
        evaluate(integral, [1.0, 2.0, math.pi / 2], [0.5, 0.0, 0.0]),
        [1.0, 2.5, math.pi / 2], atol=1e-15)
    # Pure rotation: the position stays.
    np.testing.assert_allclose(
        evaluate(integral, [1.0, 2.0, 0.3], [0.0, 0.0, -1.2]), [1.0, 2.0, -0.9], atol=1e-15)
    # Quarter circle of radius 1 counter-clockwise, starting at heading 0.
    np.testing.assert_allclose(
        evaluate(integral, [0.0, 0.0, 0.0], [math.pi / 2, 0.0, math.pi / 2]),
        [1.0, 1.0, math.pi / 2], atol=1e-15)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_dynamics_and_jacobians_are_continuous_across_the_taylor_switch(sign: float) -> None:
    """Both sides of |omega dt| = 1e-3 agree to rounding in value and derivatives."""
    model = make_model()
    below = sign * np.nextafter(SMALL_ROTATION, 0.0) / DT
    above = sign * np.nextafter(SMALL_ROTATION, 1.0) / DT
    pose = np.array([0.4, -0.2, 1.1])
    twist_below, twist_above = np.array([0.8, -0.6, below]), np.array([0.8, -0.6, above])
    np.testing.assert_allclose(evaluate(model.dynamics, pose, twist_below),
                               evaluate(model.dynamics, pose, twist_above), rtol=0, atol=1e-15)
    lin = make_model().linearization  # mapped over HORIZON stages: evaluate both in one call
    poses = np.repeat(pose[:, None], HORIZON, axis=1)
    twists = np.repeat(twist_below[:, None], HORIZON, axis=1)
    twists[:, 1] = twist_above
    rows = np.asarray(lin(poses, twists).full())
    np.testing.assert_allclose(rows[:, 0], rows[:, 1], rtol=0, atol=1e-12)


# Linearisation -------------------------------------------------------------


def unpack_rows(column: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(c, A, B) from one stage's 21 rows (c, vec A, vec B), vec column-major."""
    return column[:3], column[3:12].reshape(3, 3, order="F"), column[12:21].reshape(3, 3, order="F")


def finite_difference_jacobians(model: TrackingModel, pose: np.ndarray, twist: np.ndarray,
                                step: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    def f(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return evaluate(model.dynamics, x, u)

    eye = np.eye(3)
    wrt_pose = np.column_stack(
        [(f(pose + step * e, twist) - f(pose - step * e, twist)) / (2 * step) for e in eye])
    wrt_twist = np.column_stack(
        [(f(pose, twist + step * e) - f(pose, twist - step * e)) / (2 * step) for e in eye])
    return wrt_pose, wrt_twist


def random_stages(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """3 x n poses and twists; a few twists sit at omega = 0 or next to the Taylor switch."""
    poses = rng.uniform([-3.0, -3.0, -7.0], [3.0, 3.0, 7.0], size=(n, 3)).T
    twists = rng.uniform([-1.0, -1.0, -4.0], [1.0, 1.0, 4.0], size=(n, 3)).T
    special = [0.0, 0.999 * SMALL_ROTATION / DT, -1.001 * SMALL_ROTATION / DT, 60.0]
    twists[2, : len(special)] = special
    return poses, twists


def test_linearization_shape_when_called_with_3xN() -> None:
    model = make_model()
    out = model.linearization(np.zeros((3, HORIZON)), np.zeros((3, HORIZON)))
    assert isinstance(out, ca.DM)
    assert out.shape == (21, HORIZON)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_linearization_matches_finite_differences(seed: int) -> None:
    model = make_model()
    poses, twists = random_stages(np.random.default_rng(seed), HORIZON)
    rows = np.asarray(model.linearization(poses, twists).full())
    for k in range(HORIZON):
        _, a, b = unpack_rows(rows[:, k])
        fd_a, fd_b = finite_difference_jacobians(model, poses[:, k], twists[:, k])
        np.testing.assert_allclose(a, fd_a, rtol=0, atol=1e-7, err_msg=f"A at stage {k}")
        np.testing.assert_allclose(b, fd_b, rtol=0, atol=1e-7, err_msg=f"B at stage {k}")


@pytest.mark.parametrize("seed", [3, 4])
def test_affine_model_reproduces_dynamics_at_its_linearisation_point(seed: int) -> None:
    model = make_model()
    poses, twists = random_stages(np.random.default_rng(seed), HORIZON)
    rows = np.asarray(model.linearization(poses, twists).full())
    for k in range(HORIZON):
        c, a, b = unpack_rows(rows[:, k])
        expected = evaluate(model.dynamics, poses[:, k], twists[:, k])
        np.testing.assert_allclose(c + a @ poses[:, k] + b @ twists[:, k], expected,
                                   rtol=0, atol=1e-12)


def test_linearization_structure_at_theta_zero_and_rest() -> None:
    """At heading 0 and zero twist: A = I except dx/dtheta, dy/dtheta = 0; B = dt * I."""
    model = make_model()
    rows = np.asarray(model.linearization(np.zeros((3, HORIZON)), np.zeros((3, HORIZON))).full())
    c, a, b = unpack_rows(rows[:, 0])
    np.testing.assert_array_equal(c, np.zeros(3))
    np.testing.assert_allclose(a, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(b, DT * np.eye(3), atol=1e-15)


# Cost ------------------------------------------------------------------------


def hand_cost(model: TrackingModel, z: np.ndarray, p: np.ndarray, exact: bool = False) -> float:
    """The cost written from Weights' docstring, in NumPy, independent of the CasADi code
    (path mode: the reference at the planned progress, expanded around where it was
    sampled, to second order if ``exact``)."""
    n, w, robot = model.horizon, model.weights, model.robot
    variables, parameters = model.layouts
    poses, twists = variables.view(z, "poses"), variables.view(z, "twists")
    poses_ref = parameters.view(p, "poses_ref").copy()
    twists_ref = parameters.view(p, "twists_ref").copy()
    directions = parameters.view(p, "directions")
    last = parameters.view(p, "last_twist")
    contour, extra = 0.0, 0.0
    if model.path:
        progress = variables.view(z, "progress")
        shift = progress - parameters.view(p, "progress_guess")
        poses_ref += parameters.view(p, "path_rates") * shift[:, None]
        if exact:
            poses_ref += 0.5 * parameters.view(p, "path_curvatures") * shift[:, None] ** 2
        rates = np.diff(progress) / model.durations
        twists_ref = parameters.view(p, "feedforward_rates") * rates[:, None]
        contour = w.contour
        extra = (w.progress * float(np.sum((model.max_progress_rate - rates) ** 2))
                 - w.progress_reward * float(np.sum(shift[1:]))
                 + w.progress_rate * float(np.sum(np.diff(rates) ** 2)))

    def pose_term(k: int, diagonal: np.ndarray) -> float:
        error = poses[k] - poses_ref[k]
        along = directions[k] @ error[:2]
        across = directions[k, 0] * error[1] - directions[k, 1] * error[0]
        relief = (1.0 - w.along_track) * min(diagonal[0], diagonal[1])
        return float(error @ (diagonal * error) - relief * along**2 + contour * across**2)

    positions = robot.wheel_positions if robot.steered else None
    # The reference's own change of twist between stage midpoints; into stage 0, from the
    # previous tick (midpoint h_0 before stage 0's), extrapolated from stages 0 and 1.
    h = model.durations
    reference_change = np.zeros((n, 3))
    reference_change[1:] = np.diff(twists_ref, axis=0)
    if n > 1:
        reference_change[0] = (twists_ref[1] - twists_ref[0]) * h[0] / (0.5 * (h[0] + h[1]))
    total = 0.0
    for k in range(n):
        if k > 0:
            total += pose_term(k, w.pose)
        deviation = twists[k] - twists_ref[k]
        change = twists[k] - (last if k == 0 else twists[k - 1]) - reference_change[k]
        total += deviation @ (w.twist * deviation) + change @ (w.rate * change)
        if positions is not None:  # swerve: change of every module's ground velocity
            vx = change[0] - change[2] * positions[:, 1]
            vy = change[1] + change[2] * positions[:, 0]
            total += w.module_rate * float(np.sum(vx**2 + vy**2))
    return total + pose_term(n, w.terminal) + extra


CUSTOM_WEIGHTS = Weights(pose=np.array([150.0, 90.0, 30.0]), twist=np.array([2.0, 0.5, 0.3]),
                         rate=np.array([0.4, 0.1, 0.05]), terminal=np.array([500.0, 300.0, 70.0]),
                         along_track=0.3, module_rate=2.5)


@pytest.mark.parametrize("tick", [None, 0.4 * DT], ids=["uniform", "short first stage"])
@pytest.mark.parametrize("robot_name", ["mecanum", "swerve"])
@pytest.mark.parametrize("weights", [Weights(), CUSTOM_WEIGHTS], ids=["default", "custom"])
def test_cost_matches_hand_written_cost(robot_name: str, weights: Weights,
                                        tick: float | None) -> None:
    model = make_model(robot_name, weights, tick)
    z, p = model.symbols()
    cost = ca.Function("cost", [z, p], [model.cost(z, p)])
    rng = np.random.default_rng(7)
    for _ in range(5):
        zv = rng.normal(size=model.layouts.variables.size)
        pv = rng.normal(size=model.layouts.parameters.size)
        expected = hand_cost(model, zv, pv)
        assert float(cost(zv, pv)) == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_swerve_rate_term_includes_module_ground_velocity() -> None:
    """Only the rate term changes with module_rate, by module_rate * sum_i |v_i(du)|^2."""
    robot = preset("swerve")
    assert isinstance(robot, SwerveRobot)
    base = make_model("swerve", Weights(module_rate=0.0))
    heavy = make_model("swerve", Weights(module_rate=3.0))
    du = np.array([0.2, -0.1, 0.7])
    velocity = robot.module_velocities(du)
    expected = 3.0 * np.sum(velocity**2)
    assert du @ (heavy.rate_matrix - base.rate_matrix) @ du == pytest.approx(expected, rel=1e-12)
    # Swedish wheels have no module term whatever module_rate says.
    swedish = make_model("mecanum", Weights(module_rate=3.0))
    np.testing.assert_array_equal(swedish.rate_matrix, np.diag(Weights().rate))


def test_layouts_are_the_documented_concatenations() -> None:
    """The one written statement of z and p (mpc.model.layout), checked against the
    concatenation its docstring describes; NumPy views and CasADi symbols agree."""
    model = make_model()
    rng = np.random.default_rng(5)
    n = HORIZON
    parts = {"x0": rng.normal(size=3), "poses_ref": rng.normal(size=(n + 1, 3)),
             "twists_ref": rng.normal(size=(n, 3)), "directions": rng.normal(size=(n + 1, 2)),
             "last_twist": rng.normal(size=3)}
    packed = np.concatenate([a.ravel() for a in parts.values()])
    variables, parameters = model.layouts
    assert parameters.size == packed.size
    symbol = ca.SX.sym("p", parameters.size)
    for name, value in parts.items():
        np.testing.assert_array_equal(parameters.view(packed, name), value)
        column_major = ca.Function("f", [symbol], [parameters.symbol(symbol, name)])(packed)
        np.testing.assert_array_equal(np.asarray(column_major).T.reshape(value.shape), value)
    z = rng.normal(size=variables.size)
    assert variables.size == 3 * (n + 1) + 3 * n
    np.testing.assert_array_equal(variables.view(z, "poses"), z[: 3 * (n + 1)].reshape(n + 1, 3))
    np.testing.assert_array_equal(variables.view(z, "twists"), z[3 * (n + 1):].reshape(n, 3))


@pytest.mark.parametrize("robot_name", ["omni3", "swerve"])
def test_cost_is_quadratic_in_z(robot_name: str) -> None:
    """f(z) = f(0) + g'z + z'Hz/2 exactly, with H, g from CasADi at z = 0 (what the QP uses)."""
    model = make_model(robot_name, CUSTOM_WEIGHTS)
    z, p = model.symbols()
    cost_expr = model.cost(z, p)
    hessian, gradient = ca.hessian(cost_expr, z)
    terms = ca.Function("terms", [z, p], [cost_expr, gradient, hessian])
    rng = np.random.default_rng(11)
    pv = rng.normal(size=model.layouts.parameters.size)
    # Directions of travel are unit vectors fading to 0 (|t_k| <= 1), as reference_terms makes them.
    n = model.horizon
    directions = model.layouts.parameters.view(pv, "directions")
    directions[:] = rng.normal(size=(n + 1, 2))
    directions *= rng.uniform(0.0, 1.0, (n + 1, 1)) / np.linalg.norm(directions, axis=1)[:, None]
    size = model.layouts.variables.size
    f0, g0, h0 = (np.asarray(v.full()) for v in terms(np.zeros(size), pv))
    for _ in range(3):
        zv = rng.normal(size=size)
        f, _, h = (np.asarray(v.full()) for v in terms(zv, pv))
        np.testing.assert_allclose(h, h0, rtol=0, atol=1e-10)  # Hessian independent of z
        quadratic = f0.item() + g0.ravel() @ zv + 0.5 * zv @ h0 @ zv
        assert f.item() == pytest.approx(quadratic, rel=1e-10)
    # With |t_k| <= 1 and along_track in [0, 1] the Hessian is positive semidefinite (a convex QP).
    assert np.linalg.eigvalsh(h0).min() > -1e-9


@pytest.mark.parametrize("rotation", [0.0, 1e-9, 0.999e-3, 1.001e-3, 0.4, -3.0])
def test_numpy_integral_matches_the_casadi_dynamics(rotation: float) -> None:
    """The NumPy twin (delay prediction) agrees with the CasADi model on both branches."""
    function = integral_function(DT)
    rng = np.random.default_rng(12)
    for _ in range(5):
        pose = rng.uniform([-3, -3, -4], [3, 3, 4])
        twist = np.array([*rng.uniform(-2, 2, 2), rotation / DT])
        np.testing.assert_allclose(integrate(pose, twist, DT), evaluate(function, pose, twist),
                                   rtol=0, atol=1e-14)


@pytest.mark.parametrize("tick", [None, 0.5 * DT], ids=["uniform", "short first stage"])
@pytest.mark.parametrize("exact", [False, True])
def test_path_mode_cost_matches_hand_written_cost(exact: bool, tick: float | None) -> None:
    """Contouring geometry: the error against the reference expanded at the planned
    progress, the across-path weight, the progress terms (CUSTOM weights, path mode)."""
    weights = make_weights({"pose": [150.0, 90.0, 30.0], "contour": 700.0, "progress": 0.3,
                            "progress_reward": 0.7, "progress_rate": 0.05})
    model = TrackingModel(preset("mecanum"), HORIZON, DT, weights, path=True, tick=tick)
    z, p = model.symbols()
    cost = ca.Function("cost", [z, p], [model.cost(z, p, exact=exact)])
    rng = np.random.default_rng(17)
    for _ in range(5):
        zv = rng.normal(size=model.layouts.variables.size)
        pv = rng.normal(size=model.layouts.parameters.size)
        assert float(cost(zv, pv)) == pytest.approx(hand_cost(model, zv, pv, exact), rel=1e-12)


def test_contour_error_by_hand() -> None:
    """One stage by hand (horizon 1: the terminal stage): direction of travel +y, the robot
    3 cm to the right of and 1 cm behind its reference point: across error 3 cm (weight
    terminal + contour), along 1 cm (weight terminal)."""
    weights = make_weights({"pose": 0.0, "twist": 0.0, "rate": 0.0,
                            "terminal": [100.0, 100.0, 0.0], "contour": 900.0, "progress": 0.0,
                            "progress_reward": 0.0, "progress_rate": 0.0})
    model = TrackingModel(preset("mecanum"), 1, DT, weights, path=True)
    variables, parameters = model.layouts
    zv, pv = np.zeros(variables.size), np.zeros(parameters.size)
    parameters.view(pv, "directions")[:] = [0.0, 1.0]
    variables.view(zv, "poses")[:] = [0.03, -0.01, 0.0]  # x right of +y travel, y behind
    z, p = model.symbols()
    value = float(ca.Function("cost", [z, p], [model.cost(z, p)])(zv, pv))
    assert value == pytest.approx((100.0 + 900.0) * 0.03**2 + 100.0 * 0.01**2, rel=1e-12)
