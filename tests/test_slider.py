"""The wheel on a radial slider: kinematics against the shared notes' worked values, the
rolling and no-slip equations solved independently, round trips and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpc.errors import RobotError
from mpc.robots import mobility
from mpc.robots.wheels.slider.kinematics import SliderUnit, slider_twist


def _unit(alpha: float, radius: float = 0.05) -> SliderUnit:
    return SliderUnit(rail_angle=alpha, stroke=(0.15, 0.35), wheel_radius=radius,
                      max_wheel_speed=30.0, max_steer_rate=10.0, max_slider_speed=0.5)


@pytest.mark.parametrize(("alpha", "beta", "length", "twist", "slide", "drive", "tolerance"), [
    (0.0, 0.0, 0.25, (0.3, 0.0, 0.0), -0.3, 0.0, 1e-12),
    (0.0, 0.0, 0.25, (0.0, 0.3, 0.0), 0.0, 6.0, 1e-12),
    (0.0, 0.0, 0.25, (0.0, 0.0, 1.0), 0.0, 5.0, 1e-12),
    (math.pi / 2, 0.5, 0.2, (0.2, 0.1, 0.5), -0.045370, -2.278988, 5e-7),  # 6 digits given
])
def test_worked_values(alpha: float, beta: float, length: float, twist: tuple[float, ...],
                       slide: float, drive: float, tolerance: float) -> None:
    phidot, ldot = _unit(alpha).joint_rates(twist, beta, length)
    assert ldot == pytest.approx(slide, abs=tolerance)
    assert phidot == pytest.approx(drive, abs=tolerance * 50)


def test_rates_solve_the_rolling_and_no_slip_equations() -> None:
    rng = np.random.default_rng(42)
    for _ in range(200):
        alpha, beta = rng.uniform(-math.pi, math.pi), rng.uniform(-1.2, 1.2)
        length, radius = rng.uniform(0.1, 0.4), rng.uniform(0.03, 0.08)
        vx, vy, omega = rng.uniform(-1, 1, size=3)
        # the two equations as written, solved as a 2 x 2 system in (phidot, ldot)
        a_b = alpha + beta
        rolling = -math.sin(a_b) * vx + math.cos(a_b) * vy + length * math.cos(beta) * omega
        no_slip = math.cos(a_b) * vx + math.sin(a_b) * vy + length * math.sin(beta) * omega
        expected = np.linalg.solve([[radius, math.sin(beta)], [0.0, math.cos(beta)]],
                                   [rolling, -no_slip])
        got = _unit(alpha, radius).joint_rates((vx, vy, omega), beta, length)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


def _swom() -> tuple[SliderUnit, ...]:
    """Four units in an X, as SWOM."""
    return tuple(_unit(math.pi / 4 + k * math.pi / 2) for k in range(4))


def test_forward_after_inverse_gives_back_the_twist() -> None:
    units = _swom()
    rng = np.random.default_rng(7)
    for _ in range(100):
        twist = rng.uniform(-1, 1, size=3)
        betas, lengths = rng.uniform(-1.2, 1.2, size=4), rng.uniform(0.15, 0.35, size=4)
        rates = np.array([unit.joint_rates(twist, b, length)
                          for unit, b, length in zip(units, betas, lengths, strict=True)])
        back = slider_twist(units, betas, lengths, rates[:, 0], rates[:, 1])
        np.testing.assert_allclose(back, twist, rtol=1e-12, atol=1e-12)


def test_finite_differences_show_no_lateral_slip() -> None:
    """The contact point's world velocity, by central differences of its position as the
    body moves with the twist and the slider with its rate: nothing along the axle, and
    ``r phidot`` along the rolling direction."""
    unit = _unit(0.7)
    twist = np.array([0.4, -0.25, 0.8])
    beta, length, heading = 0.3, 0.22, 0.4
    phidot, ldot = unit.joint_rates(twist, beta, length)

    def contact(t: float) -> np.ndarray:  # world position of the contact at time t
        theta = heading + twist[2] * t
        # the body's origin under a constant body twist (exact arc)
        c, s = math.sin(twist[2] * t) / twist[2], (1.0 - math.cos(twist[2] * t)) / twist[2]
        local = np.array([c * twist[0] - s * twist[1], s * twist[0] + c * twist[1]])
        rot = np.array([[math.cos(heading), -math.sin(heading)],
                        [math.sin(heading), math.cos(heading)]])
        origin = rot @ local
        rail = np.array([math.cos(unit.rail_angle + theta), math.sin(unit.rail_angle + theta)])
        return origin + (length + ldot * t) * rail

    h = 1e-5
    velocity = (contact(h) - contact(-h)) / (2 * h)
    world = heading + unit.rail_angle + beta
    axle = np.array([math.cos(world), math.sin(world)])
    rolling = np.array([-math.sin(world), math.cos(world)])
    assert abs(velocity @ axle) < 1e-6
    assert velocity @ rolling == pytest.approx(unit.wheel_radius * phidot, abs=1e-6)


def test_free_sliders_are_omnidirectional() -> None:
    wheels = [{"type": "slider", "x": 0.2 * math.cos(a), "y": 0.2 * math.sin(a)}
              for a in np.radians([45, 135, 225, 315])]
    assert tuple(mobility({"wheels": wheels})) == (3, 0)


def test_bad_units_and_poses() -> None:
    with pytest.raises(RobotError, match="l_min < l_max"):
        SliderUnit(0.0, (0.3, 0.2), 0.05, 30.0, 10.0, 0.5)
    with pytest.raises(RobotError, match="max_slider_speed"):
        SliderUnit(0.0, (0.1, 0.2), 0.05, 30.0, 10.0, 0.0)
    with pytest.raises(RobotError, match="90 deg from the rail"):
        _unit(0.0).joint_rates((0.1, 0.0, 0.0), math.pi / 2, 0.2)
    with pytest.raises(RobotError, match="twist"):
        _unit(0.0).joint_rates((0.1, 0.0), 0.0, 0.2)
    with pytest.raises(RobotError, match="steer_angles"):
        slider_twist(_swom(), [0.0] * 3, [0.2] * 4, [0.0] * 4, [0.0] * 4)
