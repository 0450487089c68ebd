"""mpc-bench qp-replay: the recorded QPs are the ones daqp solved, the replay solves them
as a cold solve does, and missing solvers are said to be missing."""

from __future__ import annotations

import json
from pathlib import Path

import daqp
import numpy as np
import pytest

from benchmarks import qp_replay
from benchmarks.scenarios import SPEEDS, ScenarioError, reference
from mpc import Controller
from mpc.robots import preset
from mpc.sim import simulate

#: Warm and cold daqp solves of one QP may stop at points apart by its own tolerance
#: (``primal_tol`` 1e-6 on its scaled rows): measured up to 6e-7 here.
AGREE = 1e-5


def _cold(qp: qp_replay.WhitenedQp) -> np.ndarray:
    """The QP solved from scratch (a new daqp problem, no warm start)."""
    n = qp.rows.shape[1]
    step, _, flag, _ = daqp.solve(np.eye(n), qp.gradient, qp.rows, qp.upper, qp.lower,
                                  np.zeros(qp.upper.size, dtype=np.intc))
    assert flag > 0
    return np.asarray(step)


@pytest.fixture(scope="module")
def swerve_qps() -> list[qp_replay.WhitenedQp]:
    return qp_replay.record("swerve", "figure8", "fixed", SPEEDS["beyond"], "time", 15)


def test_the_solver_records_nothing_unless_asked() -> None:
    robot = preset("mecanum")
    control = Controller(robot, reference("figure8", "fixed", robot, 0.8))
    assert control.solver.record is None  # type: ignore[attr-defined]


def test_a_recorded_qp_is_the_one_daqp_solved() -> None:
    """The last tick's QP, solved cold, is the controller's own step (in the solver's
    steps: unwhitened)."""
    robot = preset("swerve")
    control = Controller(robot, reference("figure8", "fixed", robot, SPEEDS["beyond"]))
    solver = control.solver
    solver.record = []  # type: ignore[attr-defined]
    simulate(control, 12 * control.dt)
    qps = solver.record  # type: ignore[attr-defined]
    assert len(qps) == 12
    assert all(qp.rows.shape == (560, 60) and qp.lower.shape == qp.upper.shape == (560,)
               and qp.gradient.shape == (60,) for qp in qps)
    assert solver.guarded_solves == 0  # type: ignore[attr-defined]
    step = solver._unwhiten @ _cold(qps[-1])  # type: ignore[attr-defined]
    np.testing.assert_allclose(step, solver._step, atol=AGREE)  # type: ignore[attr-defined]
    # copies, not views of buffers the next tick overwrites
    assert not np.shares_memory(qps[-1].rows, qps[-2].rows)


def test_the_daqp_replay_solves_each_tick_as_a_cold_solve_does(
        swerve_qps: list[qp_replay.WhitenedQp]) -> None:
    times, steps, failed = qp_replay.replay_daqp(swerve_qps)
    assert failed == 0 and len(times) == len(steps) == len(swerve_qps)
    for qp, step in zip(swerve_qps, steps, strict=True):
        np.testing.assert_allclose(step, _cold(qp), atol=AGREE)
        # within daqp's primal tolerance on rows it scales to unit length
        slack = 2e-6 * np.linalg.norm(qp.rows, axis=1)
        values = qp.rows @ step
        assert np.all(values <= qp.upper + slack) and np.all(values >= qp.lower - slack)


def test_missing_solvers_are_listed_not_run(swerve_qps: list[qp_replay.WhitenedQp],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(qp_replay, "installed", lambda name: name == "daqp")
    rows = qp_replay.replay(swerve_qps, ["daqp", "piqp"])
    assert rows[0]["solver"] == "daqp" and rows[0]["max_step_distance"] == 0.0
    assert rows[0]["failed"] == 0 and 0.0 < rows[0]["tick_p50"] <= rows[0]["tick_p99"]
    assert rows[1] == {"solver": "piqp", "missing": True}
    assert "piqp       not installed (pip install piqp)" in qp_replay.table(rows)


def test_a_solver_that_raises_is_listed_with_its_error(
        swerve_qps: list[qp_replay.WhitenedQp], monkeypatch: pytest.MonkeyPatch) -> None:
    def newer_release(qps: list[qp_replay.WhitenedQp]) -> None:
        raise TypeError("setup() takes 7 positional arguments but 10 were given")

    monkeypatch.setattr(qp_replay, "installed", lambda name: True)
    monkeypatch.setitem(qp_replay.REPLAYS, "piqp", newer_release)
    rows = qp_replay.replay(swerve_qps, ["daqp", "piqp"])
    assert rows[1]["error"].startswith("TypeError: setup() takes 7")
    assert "piqp       failed to run: TypeError" in qp_replay.table(rows)


def test_too_few_ticks_or_qps_of_many_sizes_are_errors(
        swerve_qps: list[qp_replay.WhitenedQp]) -> None:
    with pytest.raises(ScenarioError, match="more than 5 recorded ticks"):
        qp_replay.replay(swerve_qps[:3], ["daqp"])
    smaller = swerve_qps[0]._replace(rows=swerve_qps[0].rows[:-1],
                                     lower=swerve_qps[0].lower[:-1],
                                     upper=swerve_qps[0].upper[:-1])
    with pytest.raises(ScenarioError, match="QPs of one size"):
        qp_replay.replay([smaller, *swerve_qps], ["daqp"])


def test_the_command_writes_its_table_and_document(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert qp_replay.main(["--layouts", "mecanum", "--ticks", "10", "--solvers", "daqp",
                           "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert "10 QPs of 160 rows and 60 columns" in printed and "daqp " in printed
    document = json.loads((tmp_path / "qp_replay.json").read_text())
    assert document["scenario"]["layout"] == "mecanum"
    assert document["scenario"]["rows"] == 160
    assert [row["solver"] for row in document["solvers"]] == ["daqp"]
    with pytest.raises(ScenarioError, match="already holds results"):
        qp_replay.main(["--layouts", "mecanum", "--ticks", "10", "--out", str(tmp_path)])


@pytest.mark.parametrize("argv, message", [
    (["--ticks", "3"], "--ticks must be in"),
    (["--ticks", "501"], "--ticks must be in 6..500"),
    (["--layouts", "swerve,mecanum"], "--layouts takes one layout"),
    (["--solvers", "cplex"], "unknown solver"),
    (["--speeds", "fast"], "unknown speed"),
])
def test_bad_options_are_one_line_errors(tmp_path: Path, argv: list[str],
                                         message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        qp_replay.main([*argv, "--out", str(tmp_path)])
