"""DC motor and SysId models: hand-derived values, validation, and agreement with WPILib.

The WPILib comparisons need the optional ``wpilib`` extra (robotpy-wpimath)
and are skipped without it; the hand-derived checks always run.
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from mpc.errors import RobotError
from mpc.robots import MOTOR_PRESETS, DCMotor, SysIdMotor

RTOL = 1e-9

#: Our preset names and WPILib's (robotpy) factory names.
WPILIB_NAMES = {
    "cim": "CIM", "mini_cim": "miniCIM", "bag": "bag", "vex_775pro": "vex775Pro",
    "rs775_125": "RS775_125", "banebots_rs775": "banebotsRS775",
    "andymark_9015": "andymark9015", "banebots_rs550": "banebotsRS550", "neo": "NEO",
    "neo_550": "NEO550", "neo_vortex": "neoVortex", "falcon_500": "falcon500",
    "falcon_500_foc": "falcon500FOC", "kraken_x60": "krakenX60",
    "kraken_x60_foc": "krakenX60FOC", "kraken_x44": "krakenX44",
    "kraken_x44_foc": "krakenX44FOC", "minion": "minion", "romi_builtin": "romiBuiltIn",
}


def wpimath_plant() -> ModuleType:
    """wpimath.system.plant, or skip the test without robotpy-wpimath."""
    pytest.importorskip("wpimath")
    from wpimath.system import plant

    return plant


# ---------------------------------------------------------------- hand-derived values


@pytest.mark.parametrize("count", [1, 3])
def test_stall_and_free_speed_points(count: int) -> None:
    motor = DCMotor(12.0, 2.0, 100.0, 4.0, 500.0, count)
    stall_torque, stall_current = 2.0 * count, 100.0 * count
    assert motor.R == pytest.approx(12.0 / stall_current, rel=1e-15)
    assert motor.kt == pytest.approx(0.02, rel=1e-15)
    # at stall: nominal voltage gives stall current and stall torque, and vice versa
    assert motor.current(0.0, 12.0) == pytest.approx(stall_current, rel=1e-12)
    assert motor.torque(stall_current) == pytest.approx(stall_torque, rel=1e-12)
    assert motor.voltage(stall_torque, 0.0) == pytest.approx(12.0, rel=1e-12)
    assert motor.speed(stall_torque, 12.0) == pytest.approx(0.0, abs=1e-9)
    # at free speed and nominal voltage the motor draws its free current (friction torque)
    free_current = 4.0 * count
    assert motor.current(500.0, 12.0) == pytest.approx(free_current, rel=1e-12)
    assert motor.speed(motor.torque(free_current), 12.0) == pytest.approx(500.0, rel=1e-12)
    assert motor.voltage(motor.torque(free_current), 500.0) == pytest.approx(12.0, rel=1e-12)
    # kv: free speed over the back-EMF voltage V - R I_free = 12 (1 - 4/100) = 11.52 V
    assert motor.kv == pytest.approx(500.0 / 11.52, rel=1e-14)
    assert motor.current_for_torque(stall_torque) == pytest.approx(stall_current, rel=1e-12)


def test_kraken_x60_numbers() -> None:
    motor = DCMotor.kraken_x60(2)
    assert motor.free_speed == pytest.approx(6000.0 * 2.0 * math.pi / 60.0, rel=1e-15)
    assert motor.total_stall_torque == pytest.approx(14.18)
    assert motor.R == pytest.approx(12.0 / 732.0)
    assert motor.kt == pytest.approx(7.09 / 366.0)


def test_reduction_scales_torque_and_speed_only() -> None:
    motor = DCMotor.neo(2)
    geared = motor.with_reduction(6.75)
    assert geared.count == 2
    assert geared.R == pytest.approx(motor.R, rel=1e-15)
    assert geared.kt == pytest.approx(motor.kt * 6.75, rel=1e-15)
    assert geared.kv == pytest.approx(motor.kv / 6.75, rel=1e-15)
    # the same electrical point seen through the gears
    torque, speed = 1.3, 40.0
    assert geared.voltage(torque * 6.75, speed / 6.75) == pytest.approx(
        motor.voltage(torque, speed), rel=1e-12)


def test_methods_take_arrays() -> None:
    motor = DCMotor.falcon_500()
    torques = np.array([0.0, 1.0, 2.0])
    speeds = np.array([10.0, 20.0, 30.0])
    voltages = motor.voltage(torques, speeds)
    assert voltages.shape == (3,)
    np.testing.assert_allclose(motor.speed(torques, voltages), speeds, rtol=1e-12)


def test_every_preset_builds_with_a_count() -> None:
    for name in MOTOR_PRESETS:
        single = DCMotor.preset(name)
        assert getattr(DCMotor, name)(4) == DCMotor.preset(name, 4)
        assert DCMotor.preset(name, 4).R == pytest.approx(single.R / 4, rel=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"nominal_voltage": True}, "nominal_voltage"),
        ({"stall_torque": -1.0}, "stall_torque"),
        ({"stall_current": 0.0}, "stall_current"),
        ({"free_current": math.nan}, "free_current"),
        ({"free_speed": math.inf}, "free_speed"),
        ({"count": 0}, "count"),
        ({"count": 2.0}, "count"),
        ({"count": True}, "count"),
        ({"free_current": 200.0}, "below stall_current"),
    ],
)
def test_invalid_motor(kwargs: dict[str, object], message: str) -> None:
    values: dict[str, object] = {"nominal_voltage": 12.0, "stall_torque": 2.0,
                                 "stall_current": 100.0, "free_current": 2.0,
                                 "free_speed": 500.0}
    values.update(kwargs)
    with pytest.raises(RobotError, match=message):
        DCMotor(**values)  # type: ignore[arg-type]


def test_invalid_preset_and_reduction() -> None:
    with pytest.raises(RobotError, match="unknown motor preset"):
        DCMotor.preset("kraken")
    with pytest.raises(RobotError, match="gearing"):
        DCMotor.neo().with_reduction(0.0)
    with pytest.raises(RobotError, match="count"):
        DCMotor.neo(-1)


def test_sysid_hand_values() -> None:
    wheel = SysIdMotor(kS=0.2, kV=0.1, kA=0.01)
    assert wheel.voltage(10.0, 5.0) == pytest.approx(0.2 + 1.0 + 0.05)
    assert wheel.voltage(-10.0, 0.0) == pytest.approx(-1.2)
    assert wheel.voltage(0.0, 0.0) == 0.0
    assert wheel.max_speed(12.0) == pytest.approx(118.0)
    assert wheel.max_acceleration(12.0, 100.0) == pytest.approx((12.0 - 0.2 - 10.0) / 0.01)
    # from metres: kV 2.0 V s/m on a 5 cm wheel is 0.1 V s/rad
    linear = SysIdMotor.from_linear(0.2, 2.0, 0.2, wheel_radius=0.05)
    assert linear.kV == pytest.approx(0.1) and linear.kA == pytest.approx(0.01)
    # a step at constant speed needs the steady voltage
    assert wheel.voltage_for_step(10.0, 10.0, 0.02) == pytest.approx(1.2, rel=1e-12)
    with pytest.raises(RobotError, match="kV"):
        SysIdMotor(0.1, 0.0, 0.0)
    with pytest.raises(RobotError, match="kS"):
        SysIdMotor(True, 0.1, 0.0)


def test_sysid_step_reaches_next_speed() -> None:
    """Integrating the model's ODE under the step voltage lands on the next speed."""
    wheel = SysIdMotor(kS=0.3, kV=0.12, kA=0.02)
    speed, target, dt = 5.0, 8.0, 0.02
    volts = wheel.voltage_for_step(speed, target, dt)

    def rate(w: float) -> float:  # the kS term uses the sign at the start, as WPILib's does
        return float((volts - wheel.kS * np.sign(speed) - wheel.kV * w) / wheel.kA)

    steps = 200
    h = dt / steps
    w = speed
    for _ in range(steps):  # classical Runge-Kutta
        k1 = rate(w)
        k2 = rate(w + h / 2 * k1)
        k3 = rate(w + h / 2 * k2)
        k4 = rate(w + h * k3)
        w += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert w == pytest.approx(target, rel=1e-10)


# ---------------------------------------------------------------- WPILib agreement


def _samples(rng: np.random.Generator, motor: DCMotor, n: int) -> dict[str, np.ndarray]:
    scale_t, scale_w = motor.total_stall_torque, motor.free_speed
    return {
        "torque": rng.uniform(-1.5, 1.5, n) * scale_t,
        "speed": rng.uniform(-1.5, 1.5, n) * scale_w,
        "current": rng.uniform(-1.5, 1.5, n) * motor.total_stall_current,
        "voltage": rng.uniform(-1.2, 1.2, n) * motor.nominal_voltage,
    }


def _compare(ours: DCMotor, theirs: Any, rng: np.random.Generator) -> None:
    """Constants and every method of our motor against a wpimath DCMotor."""
    t = theirs
    for attribute, value in (("R", ours.R), ("Kv", ours.kv), ("Kt", ours.kt),
                             ("stallTorque", ours.total_stall_torque),
                             ("stallCurrent", ours.total_stall_current),
                             ("freeCurrent", ours.total_free_current),
                             ("freeSpeed", ours.free_speed),
                             ("nominalVoltage", ours.nominal_voltage)):
        assert value == pytest.approx(getattr(t, attribute), rel=RTOL, abs=0.0), attribute
    s = _samples(rng, ours, 40)
    pairs = [
        (ours.voltage(s["torque"], s["speed"]),
         [t.voltage(a, b) for a, b in zip(s["torque"], s["speed"], strict=True)]),
        (ours.current(s["speed"], s["voltage"]),
         [t.current(a, b) for a, b in zip(s["speed"], s["voltage"], strict=True)]),
        (ours.current_for_torque(s["torque"]), [t.current(a) for a in s["torque"]]),
        (ours.torque(s["current"]), [t.torque(a) for a in s["current"]]),
        (ours.speed(s["torque"], s["voltage"]),
         [t.speed(a, b) for a, b in zip(s["torque"], s["voltage"], strict=True)]),
    ]
    for mine, wpilib in pairs:
        np.testing.assert_allclose(mine, wpilib, rtol=RTOL, atol=0.0)


@pytest.mark.parametrize("name", MOTOR_PRESETS)
def test_presets_agree_with_wpilib(name: str) -> None:
    plant = wpimath_plant()
    if not hasattr(plant.DCMotor, WPILIB_NAMES[name]):
        pytest.skip(f"this robotpy-wpimath has no {WPILIB_NAMES[name]} preset")
    rng = np.random.default_rng(sorted(MOTOR_PRESETS).index(name))
    for count in (1, 2, 4):
        theirs = getattr(plant.DCMotor, WPILIB_NAMES[name])(count)
        ours = DCMotor.preset(name, count)
        _compare(ours, theirs, rng)
        for gearing in (6.75, 0.5, 150.0):
            _compare(ours.with_reduction(gearing), theirs.withReduction(gearing), rng)


def test_wpilib_has_no_preset_we_lack() -> None:
    plant = wpimath_plant()
    static = type(plant.DCMotor.NEO)  # the factories are static; methods and fields are not
    factories = {name for name in dir(plant.DCMotor)
                 if not name.startswith("_") and isinstance(getattr(plant.DCMotor, name), static)}
    assert "NEO" in factories and factories <= set(WPILIB_NAMES.values())


def test_random_motors_agree_with_wpilib() -> None:
    plant = wpimath_plant()
    rng = np.random.default_rng(18)
    for _ in range(30):
        stall = rng.uniform(1.0, 500.0)
        args = (rng.uniform(3.0, 24.0), rng.uniform(0.05, 10.0), stall,
                rng.uniform(0.0, 0.2) * stall, rng.uniform(10.0, 2000.0))
        count = int(rng.integers(1, 5))
        ours = DCMotor(*args, count=count)
        _compare(ours, plant.DCMotor(*args, count), rng)
        gearing = rng.uniform(0.2, 50.0)
        _compare(ours.with_reduction(gearing), plant.DCMotor(*args, count).withReduction(gearing),
                 rng)


def test_sysid_agrees_with_simple_motor_feedforward() -> None:
    pytest.importorskip("wpimath")
    from wpimath.controller import SimpleMotorFeedforwardRadians

    rng = np.random.default_rng(7)
    for _ in range(30):
        ks, kv, ka = rng.uniform(0.0, 0.5), rng.uniform(0.01, 0.5), rng.uniform(0.0, 0.1)
        dt = rng.uniform(0.005, 0.05)
        ours = SysIdMotor(ks, kv, ka)
        theirs = SimpleMotorFeedforwardRadians(ks, kv, ka, dt)
        for speed, next_speed in rng.uniform(-50.0, 50.0, (10, 2)):
            assert ours.voltage_for_step(speed, next_speed, dt) == pytest.approx(
                theirs.calculate(speed, next_speed), rel=RTOL, abs=1e-12)
            assert ours.voltage(speed, 0.0) == pytest.approx(theirs.calculate(speed), rel=RTOL)
            if ka > 0.0:
                assert ours.max_acceleration(12.0, speed) == pytest.approx(
                    theirs.maxAchievableAcceleration(12.0, speed), rel=RTOL)
            assert ours.max_speed(12.0, 3.0) == pytest.approx(
                theirs.maxAchievableVelocity(12.0, 3.0), rel=RTOL)
