"""Progress of long commands: plain lines off a terminal, a bar with an ETA on one."""

from __future__ import annotations

import io
import subprocess
import sys

import pytest

from benchmarks.progress import Progress, is_terminal


def test_plain_lines_when_not_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    assert not is_terminal()  # pytest captures stdout
    with Progress(3, "runs") as progress:
        assert not progress.live
        progress.print("header")
        progress.advance("[1/3] first")
        progress.advance()
        progress.update(3, 3, "[3/3] last")
    assert capsys.readouterr().out == "header\n[1/3] first\n[3/3] last\n"
    assert progress.completed == 3


def test_live_bar_on_a_terminal_shows_count_and_eta() -> None:
    console = pytest.importorskip("rich.console")
    screen = io.StringIO()
    terminal = console.Console(file=screen, force_terminal=True, width=120)
    with Progress(4, "runs", live=True, console=terminal) as progress:
        assert progress.live
        progress.advance("[1/4] mecanum figure8 fixed inside a-very-long-controller-name")
        progress.advance("[2/4] done")
        progress._bar.refresh()  # what the bar's own thread does 10 times a second
        drawn = screen.getvalue()
    assert "[1/4] mecanum figure8 fixed inside a-very-long-controller-name" in drawn
    assert "2/4" in drawn and "eta" in drawn and "elapsed" in drawn


def test_class_is_a_context_manager_that_survives_an_error() -> None:
    console = pytest.importorskip("rich.console")
    terminal = console.Console(file=io.StringIO(), force_terminal=True)
    progress = Progress(2, "runs", live=True, console=terminal)
    with pytest.raises(RuntimeError), progress:
        raise RuntimeError("a run crashed")
    assert progress._bar is None  # stopped: the terminal is left clean


def test_the_control_path_never_imports_rich() -> None:
    code = ("import sys, mpc, mpc.sim, trajectories, benchmarks.progress\n"
            "import benchmarks.cli\n"
            "assert not any(name.split('.')[0] == 'rich' for name in sys.modules), 'rich'\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
