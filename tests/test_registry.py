"""A new wheel type is one class plus a registry entry: no library file changes.

The toy layout below (two driven balls, each spun by two actuators about the
body's x and y axes, each actuator a "wheel" with its own limit) lives only
in this file. It is registered, built from a description, tracked by both
solver paths and driven by the simulated plant.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np
import pytest

from mpc import Controller
from mpc.arrays import FloatArray, readonly
from mpc.errors import RobotError
from mpc.robots import Robot, SpeedRows, WheelCommands, from_dict, register, robot_types
from mpc.sim import simulate
from trajectories import Circle


@dataclass(frozen=True, eq=False)
class TwoBallRobot(Robot):
    """Balls of radius r at body points p_j; actuator rates w_x = -(vy + omega px) / r,
    w_y = (vx - omega py) / r (the test's own hand-derived kinematics)."""

    kind = "two_balls"

    positions: Sequence[Sequence[float]] = ()
    radius: float = 0.05
    max_speed: float = 20.0

    def __post_init__(self) -> None:
        rows = []
        for px, py in self.positions:
            rows.append([0.0, -1.0, -px])
            rows.append([1.0, 0.0, -py])
        blocks = np.array(rows)[:, None, :] / self.radius
        object.__setattr__(self, "wheel_blocks", readonly(blocks))
        object.__setattr__(self, "nominal_max_wheel_speed",
                           readonly(np.full(len(rows), self.max_speed)))
        object.__setattr__(self, "nominal_max_wheel_accel", readonly(np.full(len(rows), 40.0)))
        self._finish()

    @property
    def wheel_positions(self) -> FloatArray:
        return np.repeat(np.asarray(self.positions, dtype=float), 2, axis=0)

    def wheel_speeds(self, twist):  # type: ignore[no-untyped-def]
        return self.wheel_velocities(twist)[..., 0]

    def wheel_magnitudes(self, twist: FloatArray) -> FloatArray:
        return np.abs(self.wheel_blocks[:, 0, :] @ twist)

    def forward_kinematics(self, wheel_speeds, steer_angles):  # type: ignore[no-untyped-def]
        return self.twist_from_velocities(wheel_speeds[:, None])

    def commands_from_velocities(self, velocities, steer_angles):  # type: ignore[no-untyped-def]
        return WheelCommands(velocities[:, 0].copy(), None)

    def qp_speed_rows(self, polygon_sides: int) -> SpeedRows:
        return SpeedRows(self.wheel_blocks[:, 0, :].copy(), np.arange(self.n_wheels), 1.0)

    def casadi_limits(self, twist, bounds):  # type: ignore[no-untyped-def]
        return ca.DM(self.wheel_blocks[:, 0, :]) @ twist, -bounds, bounds

    def _with_derating(self, derating: tuple[float, ...]) -> Robot:
        return replace(self, derating=derating)


def two_balls(*, positions: Sequence[Sequence[float]], radius: float = 0.05,
              max_speed: float = 20.0, name: str = "two_balls") -> TwoBallRobot:
    return TwoBallRobot(positions, radius=radius, max_speed=max_speed, name=name)


@pytest.fixture(scope="module")
def robot() -> Robot:
    register("two_balls", two_balls)
    return from_dict({"type": "two_balls", "positions": [[0.2, 0.0], [-0.2, 0.0]]})


def test_the_registered_type_builds_from_a_description(robot: Robot) -> None:
    assert "two_balls" in robot_types()
    assert isinstance(robot, TwoBallRobot) and robot.n_wheels == 4
    np.testing.assert_allclose(robot.wheel_speeds([1.0, 0.0, 0.0]), [0, 20, 0, 20])
    with pytest.raises(RobotError, match=r"unknown key\(s\) \['colour'\]"):
        from_dict({"type": "two_balls", "positions": [[0.2, 0.0], [-0.2, 0.0]], "colour": 1})
    with pytest.raises(RobotError, match=r"missing key\(s\) \['positions'\]"):
        from_dict({"type": "two_balls"})


@pytest.mark.parametrize("solver", ["osqp", "ipopt"])
def test_both_solvers_track_with_the_new_type(robot: Robot, solver: str) -> None:
    reference = Circle(0.5, 12.0, heading="tangent")
    control = Controller(robot, reference, horizon=15, solver=solver)
    result = simulate(control, 8.0)
    metrics = result.metrics(skip=1.0)
    assert metrics["rms_position_error"] < 1e-4  # [m]
    assert metrics["limit_violations"] == 0 and metrics["accel_violations"] == 0
    assert metrics["failures"] == 0
