"""The fuzz command at a small size: seeded abuse, zero unsafe commands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from benchmarks.fuzz import main
from benchmarks.scenarios import ScenarioError
from mpc import Controller, ControllerError
from mpc.robots import preset
from trajectories import Circle


def test_a_small_fuzz_finds_no_unsafe_command(tmp_path: Path) -> None:
    assert main(["--ticks", "800", "--seed", "1", "--out", str(tmp_path)]) == 0
    document = json.loads((tmp_path / "fuzz.json").read_text())
    assert document["unsafe"] == 0 and document["ticks"] >= 800
    assert {run["robot"] for run in document["runs"]} >= {"mecanum", "swerve"}
    # it did abuse the controller: fallbacks happened
    assert any(set(run["statuses"]) - {"solved"} for run in document["runs"])


def test_bad_fuzz_options_are_refused() -> None:
    with pytest.raises(ScenarioError, match="--ticks"):
        main(["--ticks", "5"])


def test_swerve_reset_points_the_modules_along_the_twist_and_a_new_reference_keeps_them(
) -> None:
    """After reset(last_twist) the controller believes the modules point along that twist
    (flip rule from straight ahead), not straight ahead; swapping the reference keeps the
    angles the modules were commanded to."""
    robot = preset("swerve")
    controller = Controller(robot, Circle(1.0, 12.0))
    controller.reset([0.0, 0.5, 0.0])  # strafing left: every module at +90 deg
    command = controller.step([1.0, 0.0, 0.0], 0.0)
    assert command.steer_angles is not None
    before = command.steer_angles.copy()
    controller.trajectory = Circle(1.2, 10.0)
    after = controller.step([1.0, 0.0, 0.0], 0.05).steer_angles
    assert after is not None
    turn = np.abs(np.mod(after - before + np.pi / 2, np.pi) - np.pi / 2)
    assert robot.max_steer_rates is not None
    assert np.all(turn <= robot.max_steer_rates * 0.05 + 1e-9)


def test_a_reset_at_rest_keeps_the_module_angles_unless_told() -> None:
    """The modules stay where they were commanded when the controller forgets its plan
    (a reset at rest used to assume they point straight ahead: the fuzz caught a command
    turning them faster than their motors); reset(steer_angles=...) overrides."""
    robot = preset("swerve")
    controller = Controller(robot, Circle(1.0, 12.0))
    controller.reset([0.0, 0.5, 0.0])
    pointing = controller.step([1.0, 0.0, 0.0], 0.0).steer_angles
    assert pointing is not None
    controller.reset()  # at rest now
    after = controller.step([1.0, 0.0, 0.0], 0.05).steer_angles
    assert after is not None and robot.max_steer_rates is not None
    turn = np.abs(np.mod(after - pointing + np.pi / 2, np.pi) - np.pi / 2)
    assert np.all(turn <= robot.max_steer_rates * 0.05 + 1e-9)
    controller.reset(steer_angles=np.zeros(4))
    with pytest.raises(ControllerError, match="steer_angles"):
        controller.reset(steer_angles=[0.0, 0.0])
    with pytest.raises(ControllerError, match="swerve robots only"):
        Controller(preset("mecanum"), Circle(1.0, 12.0)).reset(steer_angles=np.zeros(4))
