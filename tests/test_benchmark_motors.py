"""``mpc-bench motors``: the reference at 100 % of the motor model, the kinematic stand-in,
and a short run of the command."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks import motors
from benchmarks.cli import main
from benchmarks.motors import kinematic_stand_in, motor_demand, motor_reference
from mpc.robots import motor_preset
from mpc.robots.drive.force_map import force_map


@pytest.mark.parametrize("name", ["omni3", "swerve", "ball3"])
def test_reference_needs_exactly_the_motor_model(name: str) -> None:
    robot = motor_preset(name)
    for shape in ("circle", "figure8"):
        reference = motor_reference(shape, robot)
        assert motor_demand(reference, robot) == pytest.approx(1.0, abs=1e-6)
        assert reference.period is not None and reference.period > 0.5


def test_kinematic_stand_in_by_hand() -> None:
    """Swerve: speed limit the free speed; acceleration limit the traction-limited torque
    (mu m g / 4 r here: below the current limit) over the wheel inertia plus a quarter of
    the mass at the rim."""
    robot = motor_preset("swerve")
    dyn = robot.dynamics
    assert dyn is not None
    stand_in = kinematic_stand_in(robot)
    assert stand_in.dynamics is None
    np.testing.assert_allclose(stand_in.max_wheel_speed, dyn.free_speed)
    traction = force_map(robot).normal_loads[0] * 1.1 * 0.05  # [N m] < 7.85 N m
    accel = traction / (dyn.wheel_inertia + dyn.mass / 4 * 0.05**2)
    assert stand_in.max_wheel_accel is not None
    np.testing.assert_allclose(stand_in.max_wheel_accel, accel, rtol=1e-12)


def test_kinematic_stand_in_mecanum_by_hand() -> None:
    """Mecanum (NEO 550 at 16:1, 8 A, mu 0.7, 15 kg): traction when a wheel pushes alone
    is reached at ``mu N r cos 45 deg`` (its force lies along its rollers), below the
    current-limited torque; the limit is that torque over a quarter of the mass at the rim
    (``m r^2 / 4``, not the roller diagonal's ``m r^2 cos^2 45 / 4``) plus the wheel."""
    robot = motor_preset("mecanum")
    stand_in = kinematic_stand_in(robot)
    traction = 0.7 * 15.0 * 9.81 / 4 * 0.05 * math.cos(math.pi / 4)  # [N m]
    current = 0.97 / 100.0 * 16.0 * 8.0  # kt at the wheel times the limit [N m]
    assert traction < current
    accel = traction / (5e-4 + 15.0 / 4 * 0.05**2)
    assert stand_in.max_wheel_accel is not None
    np.testing.assert_allclose(stand_in.max_wheel_accel, accel, rtol=1e-9)


def test_free_speed_reference_peaks_at_the_ratio() -> None:
    robot = motor_preset("swerve")
    reference = motors.free_speed_reference("figure8", robot, 1.2, 2.0)
    times = np.linspace(0.0, float(reference.period), 4001)
    wheel = np.einsum("ndj,kj->knd", robot.wheel_blocks, reference.body_twist(times))
    peak = np.linalg.norm(wheel, axis=2).max()
    assert peak == pytest.approx(1.2 * robot.max_wheel_speed.max(), rel=1e-4)


def test_traction_command_writes_its_table(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["motors", "--traction", "--layouts", "mecanum", "--sizes", "2",
                 "--speed-ratios", "1.2", "--variants", "default,headroom=0.025+no-sag",
                 "--duration", "1.0", "--skip", "0.5", "--out", str(tmp_path)])
    assert code == 0
    document = json.loads((tmp_path / "motors-traction.json").read_text())
    assert [(r["controller"], r["variant"]) for r in document["rows"]] == [
        ("mpc-kinematic", None), ("mpc-motors", "default"),
        ("mpc-motors", "headroom=0.025+no-sag")]
    for row in document["rows"]:
        assert 0 <= row["unplanned_slip_events"] <= row["slip_events"]
    assert "| mecanum | 2 | 1.2 |" in capsys.readouterr().out
    assert main(["motors", "--traction", "--variants", "headroom=lots"]) == 2
    planner, sides = motors.variant_robot(motor_preset("swerve"), "headroom=0+no-sag+sides=16")
    assert planner.dynamics is not None and planner.dynamics.headroom == 0.0
    assert planner.dynamics.battery_resistance == 0.0 and sides == 16


def test_motors_command_writes_its_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                        ) -> None:
    code = main(["motors", "--layouts", "omni3", "--trajectories", "figure8", "--laps", "0.3",
                 "--skip", "0.3", "--controllers", "mpc-motors,ff-p-clip", "--out",
                 str(tmp_path)])
    assert code == 0
    document = json.loads((tmp_path / "motors.json").read_text())
    assert [row["controller"] for row in document["rows"]] == ["mpc-motors", "ff-p-clip"]
    assert document["rows"][0]["voltage_violations"] == 0
    assert "| omni3 figure8 |" in capsys.readouterr().out
    assert document["settings"]["command_ramp"] is True
    assert main(["motors", "--perf", "--no-command-ramp"]) == 2
    assert main(["motors", "--layouts", "hexapod"]) == 2


def test_perf_times_both_runs_and_counts_the_rows_daqp_kept() -> None:
    """``mpc-bench motors --perf`` on one layout: both runs timed, and the motor rows that
    left daqp's problem after 50 ticks without a plan needing them counted."""
    lines: list[str] = []
    (row,) = motors.perf(["mecanum"], ticks=70, repeats=1, log=lines.append)
    assert row["layout"] == "mecanum" and row["rows"] == 28
    for label in ("kinematic", "motors"):
        assert 0.0 < row[f"{label}_p50"] <= row[f"{label}_p99"]
    (solved,) = row["rows_solved_at_end"]
    assert 0 < solved < row["rows"]
    assert "in daqp's problem at the end" in lines[0]
