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
