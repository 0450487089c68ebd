"""The controller's acceptance criteria, in closed loop with the simulated plant.

The plant (:mod:`mpc.sim`) integrates wheel speeds through forward kinematics
with RK4 at 10 substeps per tick: a different integrator from the
controller's closed-form model. Robots start 0.2 m and 0.3 rad off the
reference. Tolerances are a few times what was measured (the docstrings say
what), so a regression shows.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from closed_loop import (
    DT,
    JOINT_FREE_PRESETS,
    SETTLE,
    Loop,
    assert_within_limits,
    inside_limits,
    off_start,
    statuses_after,
    too_fast_circle,
)

from mpc import Controller
from mpc.robots import preset
from mpc.sim import PlantConfig, simulate
from trajectories import Circle, feasibility

#: [m] RMS position error after SETTLE inside the limits, daqp and IPOPT; measured up to
#: 81 um (swerve figure-eight; 0.1-60 um on the others).
RMS_TOLERANCE = 2e-4
#: [m] the same for OSQP, which stops at its tolerance; measured up to 0.19 mm.
OSQP_RMS_TOLERANCE = 5e-4
#: [rad] RMS heading error after SETTLE inside the limits; measured up to 5.2e-4 rad.
HEADING_TOLERANCE = 1e-3


@pytest.mark.parametrize("trajectory_name", inside_limits().keys())
@pytest.mark.parametrize("robot_name", JOINT_FREE_PRESETS)
@pytest.mark.parametrize("solver", ["daqp", "osqp", "ipopt"])
def test_tracks_inside_the_limits(solver: str, robot_name: str, trajectory_name: str) -> None:
    robot, trajectory = preset(robot_name), inside_limits()[trajectory_name]
    assert feasibility(trajectory, robot).peak_ratio < 1.0
    controller = Controller(robot, trajectory, solver=solver)
    result = simulate(controller, 7.0, initial_pose=off_start(trajectory))
    metrics = result.metrics(skip=SETTLE)
    tolerance = OSQP_RMS_TOLERANCE if solver == "osqp" else RMS_TOLERANCE
    assert metrics["rms_position_error"] < tolerance
    assert metrics["rms_heading_error"] < HEADING_TOLERANCE
    assert_within_limits(result)
    assert statuses_after(result, SETTLE) == {"solved"}


@pytest.mark.parametrize(
    ("solver", "robot_name", "cross_track"),
    [("daqp", "omni3", 0.16), ("daqp", "omni4", 0.15), ("daqp", "mecanum", 0.16),
     ("daqp", "swerve", 0.25), ("osqp", "mecanum", 0.16), ("ipopt", "mecanum", 0.16)],
)
def test_reference_beyond_the_limits_keeps_every_limit(solver: str, robot_name: str,
                                                        cross_track: float) -> None:
    """Never a wheel over its speed or acceleration limit, at full speed, and the robot
    stays near the path once its lag has settled (after 3 s): it cuts inside the circle,
    less than the 0.23 m of a robot at full speed with the reference's angular rate
    (radius 1/1.3), because it looks ahead. ``cross_track`` is the measured max [m]."""
    robot = preset(robot_name)
    trajectory = too_fast_circle(robot)
    assert feasibility(trajectory, robot).peak_ratio == pytest.approx(1.3, rel=1e-3)
    result = simulate(Controller(robot, trajectory, solver=solver), 8.0)
    assert_within_limits(result)
    assert result.metrics()["max_wheel_speed_ratio"] > 0.999  # it did run at the limit
    assert result.metrics(skip=3.0)["max_cross_track_error"] < cross_track + 0.02


@pytest.mark.parametrize("trajectory_name", inside_limits().keys())
def test_swerve_with_rate_limited_steering(trajectory_name: str) -> None:
    """Steer angles are given, wrapped into (-pi, pi]; the steering plant (12 rad/s) keeps
    up with them after the transient, because the cost smooths module velocity changes
    (measured: at most 0.11 rad per tick after 2 s, 0.6 rad allowed); tracking is as good
    as with the ideal plant."""
    robot, trajectory = preset("swerve"), inside_limits()[trajectory_name]
    controller = Controller(robot, trajectory)
    loop = Loop(controller, off_start(trajectory), PlantConfig(steer_rate_limited=True))
    angles, errors = [], []
    for _ in range(140):
        command = loop.step()
        steer = command.steer_angles
        if steer is None:
            raise AssertionError("a swerve command carries steer angles")
        assert steer.shape == (robot.n_wheels,)
        assert np.all(steer > -math.pi) and np.all(steer <= math.pi)
        angles.append(steer)
        errors.append(np.linalg.norm(loop.plant.pose[:2]
                                     - trajectory.sample(loop.tick * DT).pose[:2]))
    settled = int(SETTLE / DT)
    turn = np.abs(np.angle(np.exp(1j * np.diff(angles, axis=0))))[settled:]
    assert turn.max() <= 0.2  # [rad] per tick; the steering rate allows 0.6
    assert float(np.sqrt(np.mean(np.square(errors[settled:])))) < RMS_TOLERANCE


def test_changing_the_trajectory_tracks_the_new_one() -> None:
    """3 s on a 1.0 m circle, then a concentric 1.1 m circle (0.1 m away): after 2 s more
    the robot tracks the new circle as well as any reference (measured 2 um RMS)."""
    robot = preset("omni4")
    old, new = Circle(1.0, 12.0, heading=0.0), Circle(1.1, 12.0, heading=0.0)
    controller = Controller(robot, old)
    loop = Loop(controller, old.sample(0.0).pose)
    for _ in range(60):
        loop.step()
    controller.trajectory = new
    assert controller.trajectory is new
    errors = []
    for _ in range(100):
        loop.step()
        errors.append(np.linalg.norm(loop.plant.pose[:2] - new.sample(loop.tick * DT).pose[:2]))
    assert errors[0] > 0.05  # it did have to move over
    assert float(np.sqrt(np.mean(np.square(errors[40:])))) < 1e-5


def test_delay_compensation_tracks_much_better() -> None:
    """Plant with 2 ticks of command delay. Measured RMS after 2 s: 6.7e-6 m compensated
    against 4.0e-3 m uncompensated (mecanum circle)."""
    robot, trajectory = preset("mecanum"), Circle(1.0, 12.0, heading=0.0)
    plant = PlantConfig(delay_ticks=2)
    rms = {}
    for delay in (0, 2):
        controller = Controller(robot, trajectory, delay_ticks=delay)
        result = simulate(controller, 7.0, initial_pose=off_start(trajectory), plant=plant)
        assert_within_limits(result)
        rms[delay] = result.metrics(skip=SETTLE)["rms_position_error"]
    assert rms[2] < 3e-5
    assert rms[0] > 2e-3  # the delay does hurt without compensation
