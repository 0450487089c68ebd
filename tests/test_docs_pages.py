"""The README's front page and the generated docs pages: what the results give now."""

from __future__ import annotations

import csv
import re
from pathlib import Path

from benchmarks import docs_pages

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text("utf-8")
TEST_COMMAND = ('python3 -m venv .venv && . .venv/bin/activate && pip install -e ".[test]" '
                "&& python -m pytest -q")


def test_generated_pages_and_readme_block_match_the_results() -> None:
    """`mpc-bench docs-pages` was run after the last change of benchmarks/results/."""
    assert docs_pages.stale(ROOT) == [], "run: mpc-bench docs-pages"


def test_readme_is_short_and_opens_with_figure_and_commands() -> None:
    lines = README.splitlines()
    assert len(lines) <= 200
    first_screen = "\n".join(lines[:40])
    assert "![" in first_screen and "benchmarks/results/headline.png" in first_screen
    assert (ROOT / "benchmarks/results/headline.png").is_file()
    assert "pip install . && mpc-bench" in first_screen
    assert TEST_COMMAND in first_screen


def test_ci_runs_the_readme_test_command_in_a_fresh_environment() -> None:
    """.ci/run's steps are the README's command, spelled for a script, then the docs."""
    ci = (ROOT / ".ci" / "run").read_text("utf-8")
    assert 'python3 -m venv "$venv"' in ci and 'source "$venv/bin/activate"' in ci
    assert 'python -m pip install --quiet -e ".[test]"' in ci
    steps = [line.strip() for line in ci.splitlines()]
    assert steps.index("python -m pytest -q") < steps.index("mkdocs build --strict")


def test_readme_numbers_come_from_the_results() -> None:
    """Every number in the README's results table is one the generator computes from
    results.csv (checked by hand on one cell: omni3's lowest MPC error beyond the limits)."""
    block = README.split(docs_pages.BEGIN)[1].split(docs_pages.END)[0]
    rows = list(csv.DictReader((ROOT / "benchmarks/results/results.csv").open()))
    omni3 = [float(row["rms_position_error"]) for row in rows
             if row["layout"] == "omni3" and row["speed"] == "beyond"
             and row["controller"].startswith("mpc-") and row["controller"] != "mpc-path"]
    per_scenario: dict[tuple[str, str], float] = {}
    for row in rows:
        if (row["layout"] == "omni3" and row["speed"] == "beyond"
                and row["controller"] in ("mpc-daqp", "mpc-tuned", "mpc-ipopt")):
            key = (row["trajectory"], row["heading"])
            per_scenario[key] = min(per_scenario.get(key, 1e9), float(row["rms_position_error"]))
    assert len(omni3) == 12 and len(per_scenario) == 4
    values = sorted(per_scenario.values())
    median = 1e3 * (values[1] + values[2]) / 2
    assert re.search(rf"\| omni3 \| [^|]+ \| {median:.3g} \|", block), (median, block)


def test_block_replacement_keeps_the_rest() -> None:
    text = f"a\n{docs_pages.BEGIN}\nold\n{docs_pages.END}\nb\n"
    expected = f"a\n{docs_pages.BEGIN}\nnew\n{docs_pages.END}\nb\n"
    assert docs_pages.replace_block(text, "new") == expected


def _table(page: str, header_start: str) -> list[list[str]]:
    """The rows of the Markdown table whose header starts with ``header_start``."""
    lines = (ROOT / page).read_text("utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header_start))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip().strip("*") for cell in line.strip("|").split("|")])
    return rows


def _close(shown: str, value: float) -> bool:
    """``shown`` (a page's rounded number) is ``value`` to the digits shown."""
    digits = shown.split(".")[1] if "." in shown else ""
    return abs(float(shown) - value) <= 0.5 * 10 ** -len(digits) * 1.0001


def test_benchmark_page_quotes_the_results_file() -> None:
    """Each position error on the Benchmarks page is that run's in results.csv [mm]."""
    rows = list(csv.DictReader((ROOT / "benchmarks/results/results.csv").open()))
    table = _table("docs/benchmarks/index.md", "| scenario | `mpc-daqp`")
    header = ["mpc-daqp", "mpc-tuned", "mpc-ipopt", "ff-p-clip", "ff-p-desat", "ff-p-setpoint"]
    assert len(table) == 20
    checked = 0
    for cells in table:
        layout, shape, heading = cells[0].split()
        trajectory = {"figure-eight": "figure8"}.get(shape, shape)
        for name, cell in zip(header, cells[1:], strict=True):
            if cell == "-":
                continue
            run = next(row for row in rows if (row["layout"], row["trajectory"], row["heading"],
                                               row["speed"], row["controller"]) ==
                       (layout, trajectory, heading, "beyond", name))
            position = cell.split("/")[0].strip().strip("*")
            assert _close(position, 1e3 * float(run["rms_position_error"])), (cells[0], name)
            checked += 1
    assert checked == 20 * 5 + 4


def test_motors_page_quotes_the_results_file() -> None:
    """Each cell of the Motors page is that run's error [mm] and violation counts."""
    import json

    document = json.loads((ROOT / "benchmarks/results/motors.json").read_text("utf-8"))
    table = _table("docs/benchmarks/motors.md", "| scenario | period")
    names = ["mpc-motors", "mpc-kinematic", "ff-p-clip", "ff-p-desat", "ff-p-setpoint"]
    for cells in table:
        layout, shape = cells[0].split()
        trajectory = {"figure-eight": "figure8"}.get(shape, shape)
        for name, cell in zip(names, cells[2:], strict=True):
            if cell == "-":
                continue
            key = (layout, trajectory, name)
            row = next(r for r in document["rows"]
                       if (r["layout"], r["trajectory"], r["controller"]) == key)
            error, voltage, current, slip = (part.strip().strip("*") for part in
                                             cell.split("(")[0].split("/"))
            assert _close(error, 1e3 * row["rms_position_error"])
            assert (int(voltage), int(current), int(slip)) == (
                row["voltage_violations"], row["current_violations"], row["slip_events"])


def test_the_compiled_tick_table_has_a_row_a_layout_from_the_run() -> None:
    """The README's performance table from a hand-made run: a layout's p50 range, its worst
    CPU p99, the Python tick's ratio range and the least IPOPT ratio; a refused scenario
    counted, a layout with none compiled shown empty."""
    from benchmarks import compiled_pages

    def row(solver: str, mode: str, p50: float, cpu99: float, ipopt: float) -> dict:
        return {"section": "compiled", "solver": solver, "plant": "ideal", "run": 1,
                "layout": "mecanum", "mode": mode, "speed": "inside", "tick_p50": p50,
                "cpu_p99": cpu99, "ipopt_over_compiled_tick": ipopt,
                "rms_position_error": 0.001}

    perf = {"command": "mpc-bench perf", "commit": "abc", "machine": {"cpu_count": 2},
            "settings": {"plants": ["ideal"], "ticks": 10, "ipopt_ticks": 5},
            "wall_time": 60.0, "summary": {"issue37_plants": {"ideal": {}}},
            "compiled": {"unsupported": [
                {"layout": "mecanum", "mode": "path", "speed": "beyond", "reason": "no"},
                {"layout": "caster4", "mode": "time", "speed": "inside", "reason": "no"}]},
            "rows": [row("compiled", "time", 1e-4, 4e-4, 300.0),
                     row("python", "time", 3e-4, 9e-4, 0.0),
                     row("compiled", "path", 5e-4, 1.2e-3, 90.0),
                     row("python", "path", 7.5e-4, 2e-3, 0.0)]}
    lines = compiled_pages.readme_block(perf).splitlines()
    assert lines[2] == "| mecanum | 2 of 3 | 0.100-0.500 | 1.200 | 1.50-3.00 | 90.0 |"
    assert lines[3] == "| caster4 | 0 of 1 |  |  |  |  |"
    assert "# The compiled tick" in compiled_pages.page(perf, "output", "")
