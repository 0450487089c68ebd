"""The executor: the same numbers in this process, on local processes and on a Dask
cluster; failed runs reported; a tiny tuning study; tuned weights round-trip."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from benchmarks.executor import RunPool, RunSpec, comparable, optimal_lap
from benchmarks.runner import describe_robot
from benchmarks.scenarios import ScenarioError
from benchmarks.sweep import sample_cases, summarise
from mpc import Controller
from mpc.errors import ControllerError
from mpc.model.weights import load_weights
from mpc.robots import PRESETS, from_dict, preset
from trajectories import Circle


def _specs() -> list[RunSpec]:
    """A small sweep (random robots, faults, starts) plus a benchmark-style run with its
    time series and yardstick, short runs."""
    specs = sample_cases(4, ["omni", "mecanum", "swerve", "ball"], ["mpc-daqp"], seed=3,
                         duration=2.0, skip=0.5)
    shape = {"shape": "figure8", "heading": "tangent", "period": 6.0}
    bench = RunSpec(robot="omni3", trajectory=shape, controller="mpc-path", duration=2.0,
                    skip=0.5, optimal_lap=optimal_lap("omni3", shape), series=True,
                    labels={"layout": "omni3", "trajectory": "figure8", "heading": "tangent",
                            "speed": "x1.3"})
    return [*specs, bench, RunSpec(robot="mecanum", trajectory=shape, controller="ff-p-clip",
                                   duration=2.0, skip=0.5, plant="realistic", seed=7)]


def _json(results: list[dict[str, Any]]) -> list[str]:
    return [json.dumps(comparable(result), sort_keys=True) for result in results]


@pytest.fixture(scope="module")
def sequential() -> list[dict[str, Any]]:
    return RunPool(workers=1).run(_specs())


@pytest.fixture(scope="module")
def dask_cluster() -> Iterator[str]:
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None)
    try:
        yield str(cluster.scheduler_address)
    finally:
        cluster.close()


def test_sequential_runs_are_complete(sequential: list[dict[str, Any]]) -> None:
    assert [r.get("error") for r in sequential] == [None] * len(sequential)
    assert {r["layout"] for r in sequential[:4]} <= {"omni", "mecanum", "swerve", "ball"}
    assert len(sequential[4]["series"]["time"]) == 40  # 2 s at 0.05 s, with its series
    assert sequential[4]["optimal_lap"] > 0
    for result in sequential[:5]:
        assert result["metrics"]["limit_violations"] == result["metrics"]["accel_violations"] == 0


def test_local_processes_give_the_same_numbers(sequential: list[dict[str, Any]]) -> None:
    lines: list[str] = []
    with RunPool(workers=2) as pool:
        results = pool.run(_specs(), log=lines.append)
    assert _json(results) == _json(sequential)
    assert len(lines) == len(sequential) and lines[-1].startswith(f"[{len(lines)}/")
    assert lines[0].endswith(" s)")  # its seconds; the ETA is the progress display's


def test_dask_cluster_gives_the_same_numbers(sequential: list[dict[str, Any]],
                                             dask_cluster: str) -> None:
    with RunPool(scheduler=dask_cluster) as pool:
        assert pool.workers == 2 and pool.notes == []  # the nanny's single-threaded BLAS
        results = pool.run(_specs())
        laps = pool.map(optimal_lap, [("omni3", {"shape": "circle", "heading": "fixed",
                                                 "period": 5.0})])
    assert _json(results) == _json(sequential)
    assert laps[0] == optimal_lap("omni3", {"shape": "circle", "heading": "fixed",
                                            "period": 5.0})


def test_a_failed_run_is_reported_not_raised() -> None:
    good = _specs()[-1]
    bad_robot = RunSpec(robot={"type": "omni", "n_wheels": 2, "base_radius": 0.2,
                               "wheel_radius": 0.05, "max_wheel_speed": 20.0},
                        trajectory=good.trajectory, controller="mpc-daqp", duration=1.0,
                        labels={"layout": "broken"})
    bad_name = RunSpec(robot="omni3", trajectory=good.trajectory, controller="mpc-daqp",
                       weights={"heading": 1.0}, duration=1.0)
    for workers in (1, 2):
        with RunPool(workers=workers) as pool:
            results = pool.run([bad_robot, good, bad_name])
        assert "n_wheels" in results[0]["error"] and results[0]["layout"] == "broken"
        assert "error" not in results[1] and results[1]["metrics"]["rms_position_error"] > 0
        assert results[2]["error"].startswith("ControllerError: unknown weight name")
        assert summarise(results)[-1]["errors"] == 2


def test_pool_options_are_checked() -> None:
    with pytest.raises(ScenarioError, match="--workers must be an integer >= 1"):
        RunPool(workers=0)
    with pytest.raises(ScenarioError, match="not both"):
        RunPool(workers=2, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(ScenarioError, match="cannot reach the Dask scheduler"):
        pytest.importorskip("distributed")
        RunPool(scheduler="tcp://127.0.0.1:9", timeout=1.0).__enter__()


@pytest.mark.parametrize("name", PRESETS)
def test_presets_are_described_exactly(name: str) -> None:
    robot = preset(name)
    again = from_dict(describe_robot(robot))
    assert np.array_equal(again.wheel_blocks, robot.wheel_blocks)
    assert np.array_equal(again.max_wheel_speed, robot.max_wheel_speed)
    assert np.array_equal(np.asarray(again.max_wheel_accel), np.asarray(robot.max_wheel_accel))


def test_tiny_study_beats_the_defaults_and_its_weights_load(tmp_path: Path) -> None:
    """omni3, circle, tangent heading, 1.3 x beyond the limits, against the best baseline:
    the defaults win on position but give up more heading than per-wheel clipping (4.3 vs
    2.8 deg RMS over the default benchmark's run; the objective penalises more than 1 deg);
    a short study finds weights with a lower objective."""
    pytest.importorskip("optuna")
    from benchmarks.cli import main

    out = tmp_path / "tune"
    assert main(["tune", "--robot", "omni3", "--trajectories", "circle", "--headings",
                 "tangent", "--speeds", "beyond", "--trials", "6", "--duration", "5",
                 "--objective", "baseline", "--workers", "1", "--out", str(out)]) == 0
    study = json.loads((out / "study.json").read_text())
    assert study["best"]["J"] < study["defaults"]["J"]
    assert (out / "history.png").read_bytes()[:4] == b"\x89PNG"
    weights = load_weights(out / "weights.toml")
    assert np.allclose(weights.pose, study["best"]["weights"]["pose"], rtol=0, atol=0)
    robot = preset("omni3")
    control = Controller(robot, Circle(1.0, 8.0), weights=weights)
    assert control.weights is weights
    (tmp_path / "bad.toml").write_text("pose = 1.0\nheading = 2.0\n")
    with pytest.raises(ControllerError, match=r"bad.toml.*unknown weight name\(s\) \['heading'\]"):
        load_weights(tmp_path / "bad.toml")


def test_tuned_presets_load_and_drive_the_mpc_tuned_controller() -> None:
    """Every shipped preset loads, differs from the defaults and names its command; the
    benchmark's ``mpc-tuned`` uses it and applies only to robots that have one."""
    from benchmarks.scenarios import Settings, applies, mpc_controller
    from mpc.model import weights as weights_module
    from mpc.model.weights import Weights, tuned_layouts, tuned_weights

    assert set(tuned_layouts()) <= set(PRESETS)
    assert {"ball3", "mecanum", "omni3", "omni4", "swerve"} <= set(tuned_layouts())
    defaults = Weights()
    for name in tuned_layouts():
        weights = tuned_weights(name)
        assert not np.array_equal(weights.pose, defaults.pose) or not np.array_equal(
            weights.twist, defaults.twist)
        head = (Path(weights_module.__file__).with_name("tuned") / f"{name}.toml"
                ).read_text().splitlines()[1]
        assert head.startswith("#   mpc-bench tune --robot " + name)
    robot = preset("swerve")
    control = mpc_controller("mpc-tuned", robot, Circle(1.0, 8.0), Settings())
    assert np.array_equal(control.weights.twist, tuned_weights("swerve").twist)
    assert applies("mpc-tuned", robot)
    assert not applies("mpc-tuned", preset("caster4"))
    with pytest.raises(ControllerError, match="no tuned weights for robot 'caster4'; tuned "
                                              "presets: ball3, mecanum"):
        tuned_weights("caster4")


def test_motor_presets_are_described_for_other_processes() -> None:
    """``--plant motor`` runs the motor presets on worker processes: each is described as
    its preset and rebuilt identical; a motor model that is not a shipped preset is refused
    with a message naming the way out."""
    from dataclasses import replace

    from benchmarks.executor import build_robot
    from mpc.robots import MOTOR_ROBOT_PRESETS, motor_preset

    for name in MOTOR_ROBOT_PRESETS:
        robot = motor_preset(name)
        spec = describe_robot(robot)
        assert spec == {"motor_preset": name}
        again = build_robot(spec)
        assert again.dynamics == robot.dynamics
        assert np.array_equal(again.wheel_blocks, robot.wheel_blocks)
    robot = motor_preset("mecanum")
    assert robot.dynamics is not None
    heavier = robot.with_dynamics(replace(robot.dynamics, mass=robot.dynamics.mass + 1.0))
    with pytest.raises(ScenarioError, match="not a shipped motor preset.*--workers 1"):
        describe_robot(heavier)


def test_out_and_back_runs_on_worker_processes() -> None:
    """Every benchmark shape travels as plain data, out-and-back too (it did not: the caster
    benchmark of the README failed on worker processes)."""
    from benchmarks.executor import execute

    spec = RunSpec(robot="caster4", controller="mpc-daqp", duration=2.0, skip=0.5,
                   trajectory={"shape": "out-and-back", "heading": "fixed", "period": 8.0})
    result, _ = execute(spec)
    assert "error" not in result, result.get("error")
    assert result["metrics"]["limit_violations"] == 0


def test_mpcs_on_the_motor_plant_are_told_the_wheel_loops_ramp() -> None:
    """The motor plant ramps each command over the tick: a benchmark MPC there plans for
    it (``command_ramp``); on the other plants it does not."""
    from benchmarks.executor import build_controller, build_robot, build_trajectory

    shape = {"shape": "circle", "heading": "fixed", "period": 8.0}
    for plant, ramp in (("motor", True), ("ideal", False), ("realistic", False),
                        ({"motor_lag": 0.03}, False)):
        spec = RunSpec(robot={"motor_preset": "omni3"}, trajectory=shape,
                       controller="mpc-daqp", plant=plant)
        robot = build_robot(spec.robot)
        control = build_controller(spec, robot, build_trajectory(shape, robot))
        assert isinstance(control, Controller) and control.command_ramp is ramp
    # --no-command-ramp (RunSpec.command_ramp=False): not told even on the motor plant; a
    # baseline is not an MPC and takes no such setting.
    spec = RunSpec(robot={"motor_preset": "omni3"}, trajectory=shape, controller="mpc-daqp",
                   plant="motor", command_ramp=False)
    robot = build_robot(spec.robot)
    control = build_controller(spec, robot, build_trajectory(shape, robot))
    assert isinstance(control, Controller) and control.command_ramp is False
    with pytest.raises(ScenarioError, match="apply to MPC controllers, not ff-p-clip"):
        build_controller(replace(spec, controller="ff-p-clip"), robot,
                         build_trajectory(shape, robot))


def test_no_command_ramp_reaches_the_runs_and_needs_the_motor_plant(tmp_path: Path) -> None:
    """``mpc-bench --plant motor --no-command-ramp``: the MPC runs as told (its RMS error
    differs from the default run's), recorded in results.json; refused on another plant
    (exit code 2)."""
    from benchmarks.cli import main

    common = ["--layouts", "omni3", "--trajectories", "circle", "--speeds", "inside",
              "--headings", "fixed", "--controllers", "mpc-daqp", "--duration", "3", "--skip", "1",
              "--no-report",
              "--workers", "1", "--force"]
    rms = {}
    for flags in ([], ["--no-command-ramp"]):
        out = tmp_path / ("told" if not flags else "not")
        assert main(["--plant", "motor", *common, *flags, "--out", str(out)]) == 0
        document = json.loads((out / "results.json").read_text())
        assert document["meta"]["settings"]["command_ramp"] is not bool(flags)
        rms[bool(flags)] = document["runs"][0]["metrics"]["rms_position_error"]
    assert rms[True] != rms[False]
    assert main(["--plant", "ideal", *common, "--no-command-ramp",
                 "--out", str(tmp_path / "x")]) == 2
