"""The benchmark's one-line verdict: MPC against the best baseline, per scenario."""

from __future__ import annotations

from typing import Any

from benchmarks.verdict import ratios, verdict


def _run(layout: str, controller: str, rms: float, peak_ratio: float = 1.3) -> dict[str, Any]:
    return {"layout": layout, "trajectory": "figure8", "heading": "fixed",
            "speed": "beyond" if peak_ratio > 1 else "inside", "peak_ratio": peak_ratio,
            "controller": controller, "metrics": {"rms_position_error": rms}}


def test_the_best_mpc_against_the_best_baseline_in_each_scenario_beyond() -> None:
    runs = [_run("mecanum", "mpc-daqp", 0.08), _run("mecanum", "mpc-tuned", 0.06),
            _run("mecanum", "ff-p-clip", 0.10), _run("mecanum", "ff-p-desat", 0.12),
            _run("mecanum", "mpc-path", 0.001),  # path mode: not in the verdict
            _run("swerve", "mpc-daqp", 0.10), _run("swerve", "ff-p-setpoint", 0.05),
            _run("omni3", "mpc-daqp", 0.02), _run("omni3", "ff-p-clip", 0.5),
            _run("omni3", "mpc-daqp", 0.0001, peak_ratio=0.8),  # inside: left out
            _run("omni3", "ff-p-clip", 0.001, peak_ratio=0.8)]
    assert sorted(ratios(runs)) == [0.04, 0.6, 2.0]
    assert verdict(runs) == ("MPC beat the best baseline in 2 of 3 scenarios beyond the "
                             "limits, median RMS position error 0.6x the baseline's")


def test_inside_only_and_no_baseline() -> None:
    inside = [_run("omni3", "mpc-daqp", 0.001, 0.8), _run("omni3", "ff-p-clip", 0.004, 0.8)]
    assert verdict(inside) == ("MPC beat the best baseline in 1 of 1 scenario inside the "
                               "limits, median RMS position error 0.25x the baseline's")
    assert verdict([_run("omni3", "mpc-daqp", 0.001)]).startswith("no verdict")
