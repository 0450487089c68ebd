"""Output folders are not silently overwritten."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.outdir import claim
from benchmarks.scenarios import ScenarioError


def test_a_new_folder_is_made(tmp_path: Path) -> None:
    out = claim(tmp_path / "a" / "b", ("results.json",), force=False)
    assert out.is_dir()
    assert claim(out, ("results.json",), force=False) == out  # empty: still free


def test_a_folder_with_results_is_refused_without_force(tmp_path: Path) -> None:
    (tmp_path / "results.json").write_text("{}")
    (tmp_path / "report").mkdir()
    (tmp_path / "report" / "index.html").write_text("")
    with pytest.raises(ScenarioError) as error:
        claim(tmp_path, ("results.json", "results.csv", "report/index.html"), force=False)
    assert str(error.value) == (f"--out {str(tmp_path)!r} already holds results (results.json, "
                                "report/index.html); add --force to overwrite them, or choose "
                                "another --out")
    assert claim(tmp_path, ("results.json",), force=True) == tmp_path
    assert (tmp_path / "results.json").read_text() == "{}"  # claiming deletes nothing


def test_other_files_do_not_count_and_a_file_is_not_a_folder(tmp_path: Path) -> None:
    (tmp_path / "perf.json").write_text("{}")
    assert claim(tmp_path, ("results.json",), force=False) == tmp_path
    with pytest.raises(ScenarioError, match="--out must be a folder, .* is a file"):
        claim(tmp_path / "perf.json", ("results.json",), force=True)
