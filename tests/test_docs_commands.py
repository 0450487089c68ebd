"""Every shell command the README and the docs show parses: ``mpc-bench`` lines against the
CLI's own argparse tree, ``python examples/...`` against the script's options and
``python -m benchmarks...`` against an importable module. (The python blocks run in
tests/test_docs_blocks.py; these commands take minutes, so they are parsed, not run.)"""

from __future__ import annotations

import importlib.util
import re
import shlex
from pathlib import Path

import pytest

from benchmarks.cli import command_parser

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", ROOT / "CONTRIBUTING.md",
         *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^```(?:console|bash|sh)?\n(.*?)^```", re.MULTILINE | re.DOTALL)
#: A placeholder such as ``mpc-bench COMMAND --help``: not a command to parse.
PLACEHOLDER = re.compile(r"^[A-Z][A-Z_]+$")
ENV = re.compile(r"^[A-Z_]+=\S*$")


def commands(text: str) -> list[list[str]]:
    """The command lines of a page's shell blocks, split at ``&&``, prompts, environment
    assignments and comments removed."""
    found = []
    for block in FENCE.findall(text):
        for line in block.splitlines():
            line = line.strip().removeprefix("$ ")
            for part in line.split("&&"):
                try:
                    words = shlex.split(part, comments=True)
                except ValueError:
                    continue
                while words and ENV.match(words[0]):
                    words = words[1:]
                if any(PLACEHOLDER.match(word) for word in words):
                    continue
                if words[:1] == ["mpc-bench"] or words[:2] in (["python", "-m"], ["python",
                                                                                   "examples"]):
                    found.append(words)
                elif words[:1] == ["python"] and len(words) > 1 and words[1].startswith(
                        "examples/"):
                    found.append(words)
    return found


def test_commands_are_found() -> None:
    text = "```console\n$ OPENBLAS_NUM_THREADS=1 mpc-bench perf --out x  # why\n```\n"
    assert commands(text) == [["mpc-bench", "perf", "--out", "x"]]
    assert commands("```\npip install . && mpc-bench\n```\n") == [["mpc-bench"]]


@pytest.mark.parametrize("page", PAGES, ids=lambda page: str(page.relative_to(ROOT)))
def test_page_commands_parse(page: Path) -> None:
    parser = command_parser()
    for words in commands(page.read_text("utf-8")):
        if words[0] == "mpc-bench":
            try:
                parser.parse_args(words[1:])
            except SystemExit as error:  # argparse's way of refusing (0: --help)
                if error.code == 0:
                    continue
                pytest.fail(f"{page.name}: {' '.join(words)!r} does not parse ({error})")
        elif words[1] == "-m":
            assert importlib.util.find_spec(words[2]) is not None, f"{page.name}: {words}"
        else:
            script = ROOT / words[1]
            assert script.is_file(), f"{page.name}: no {words[1]}"
            source = script.read_text("utf-8")
            for option in (word for word in words[2:] if word.startswith("--")):
                assert f'"{option}"' in source, f"{page.name}: {words[1]} has no {option}"
