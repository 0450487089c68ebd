"""The motor-aware MPC's commands on the motor plant, judged by a model written here from
the robots' geometry and WPILib's own ``DCMotor`` (robotpy-wpimath): no command asks a
motor for more voltage than the sagged battery gives, more current than its limit, or a
contact for more than ``mu N``, on references that ask for more than the robot can do."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.motors import free_speed_reference
from mpc import Controller
from mpc.robots import motor_preset
from mpc.sim import simulate

wpimath_plant = pytest.importorskip("wpimath.system.plant")

DT = 0.05
G = 9.81


def _maps(name: str) -> tuple[list[np.ndarray], float, float]:
    """Per wheel the (rows, 3) map from the twist to its ground velocity along the
    directions its effort pushes [m/s], by hand; wheel radius [m]; the factor from a
    Mecanum wheel's rim force to its contact force (along its rollers)."""
    if name == "swerve":
        points = [(0.3, 0.3), (0.3, -0.3), (-0.3, 0.3), (-0.3, -0.3)]
        return [np.array([[1.0, 0.0, -y], [0.0, 1.0, x]]) for x, y in points], 0.05, 1.0
    # Mecanum FL, FR, RL, RR at (+-0.15, +-0.125): WPILib's inverse kinematics
    k = 0.15 + 0.125
    rows = [[1.0, -1.0, -k], [1.0, 1.0, k], [1.0, 1.0, -k], [1.0, -1.0, k]]
    return [np.array([row]) for row in rows], 0.05, math.sqrt(2.0)


def _judge(name: str, commands: list, motor, dyn) -> dict[str, float]:
    """The largest ratio of each limit over the commands' steps (1 = at the limit)."""
    maps, radius, roller = _maps(name)
    a = np.vstack(maps)  # (rows, 3): wrench = a^T f, f the rim forces stacked
    mass = np.diag([dyn.mass, dyn.mass, dyn.yaw_inertia])
    n = len(maps)
    load = dyn.mass * G / n
    worst = {"voltage": 0.0, "current": 0.0, "traction": 0.0}
    last = np.zeros(3)
    last_speeds = np.zeros(n)
    for command in commands:
        twist = np.asarray(command.twist, dtype=float)
        for u_turn, speeds in ((twist, command.wheel_speeds),
                                (last, last_speeds)):
            accel = (twist - last) / DT + np.array([-u_turn[2] * u_turn[1],
                                                    u_turn[2] * u_turn[0], 0.0])
            forces = a @ np.linalg.solve(a.T @ a, mass @ accel)  # min-norm rim forces
            rate = (twist - last) / DT
            torque = np.zeros(n)
            contact = np.zeros(n)
            for i in range(n):
                f = forces[2 * i:2 * i + 2] if name == "swerve" else forces[i:i + 1]
                if name == "swerve":
                    angle = command.steer_angles[i]
                    along = np.array([math.cos(angle), math.sin(angle)])
                    drive = float(along @ f)
                    spin = float(along @ (maps[i] @ rate)) / radius
                    contact[i] = float(np.hypot(*f))
                else:
                    drive = float(f[0])
                    spin = float(maps[i][0] @ rate) / radius
                    contact[i] = abs(drive) * roller
                torque[i] = drive * radius + dyn.wheel_inertia * spin
            volts = np.array([motor.voltage(float(t), float(w))
                              for t, w in zip(torque, speeds, strict=True)])
            amps = np.array([motor.current(float(t)) for t in torque])  # the gearbox's
            power = float(np.sum(volts * amps))
            e, r = dyn.battery_voltage, dyn.battery_resistance
            bus = 0.5 * (e + math.sqrt(max(e * e - 4.0 * r * max(power, 0.0), 0.0)))
            worst["voltage"] = max(worst["voltage"], float(np.abs(volts).max()) / bus)
            worst["current"] = max(worst["current"],
                                   float(np.abs(amps).max()) / dyn.current_limit)
            worst["traction"] = max(worst["traction"],
                                    float(contact.max()) / (dyn.friction * load))
        last, last_speeds = twist, np.asarray(command.wheel_speeds, dtype=float)
    return worst


@pytest.mark.parametrize(("name", "motor"), [("swerve", "krakenX60"), ("mecanum", "NEO550")])
@pytest.mark.parametrize(("size", "ratio"), [(1.0, 1.3), (3.0, 1.2)])
def test_commands_within_every_limit(name: str, motor: str, size: float, ratio: float) -> None:
    robot = motor_preset(name)
    dyn = robot.dynamics
    assert dyn is not None
    wpilib_motor = getattr(wpimath_plant.DCMotor, motor)(1).withReduction(dyn.gearing)
    reference = free_speed_reference("figure8", robot, ratio, size)
    controller = Controller(robot, reference, 20, DT, command_ramp=True)
    commands = []
    step = controller.step

    def record(*args, **kwargs):
        command = step(*args, **kwargs)
        commands.append(command)
        return command

    controller.step = record  # type: ignore[method-assign]
    simulate(controller, 3.0, plant="motor", robot=robot, seed=0)
    worst = _judge(name, commands, wpilib_motor, dyn)
    # the reference asks for more: the commands go to the limits, and not past them
    assert max(worst.values()) > 0.9, worst
    for limit, ratio_used in worst.items():
        assert ratio_used <= 1.0 + 1e-9, (limit, worst)
