"""Every ```python block in README.md, docs/getting-started.md and docs/guide/*.md
runs, so the docs cannot rot.

A page's blocks run in order in one namespace, in a temporary folder that holds the files
the pages name (``path.traj``: a Choreo file). A block right after a marker in
:data:`RUN_ELSEWHERE` is run by the test named there instead (it needs a harness, such
as a simulated ROS 2 robot). Blocks that are not meant to run are fenced ``text`` or
``console``.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", ROOT / "docs" / "getting-started.md",
         *sorted((ROOT / "docs" / "guide").glob("*.md"))]
#: marker -> the test file that runs the block after it.
RUN_ELSEWHERE = {"<!-- jetauto-node -->": "tests/test_seed_robots.py"}
#: Modules of the optional extras a page may import: the page is skipped without them.
EXTRAS = ("rosbags", "wpimath")
FENCE = re.compile(r"^```python\n(.*?)^```", re.MULTILINE | re.DOTALL)


def blocks(text: str) -> list[str]:
    """The page's python blocks in order, without those another test runs."""
    out = []
    for match in FENCE.finditer(text):
        before = text[:match.start()].rstrip().rsplit("\n", 1)[-1].strip()
        if before not in RUN_ELSEWHERE:
            out.append(match.group(1))
    return out


def test_fences_are_found_and_markers_have_their_test() -> None:
    assert blocks("a\n```python\nx = 1\n```\n<!-- jetauto-node -->\n```python\ny\n```\n") == [
        "x = 1\n"]
    for marker, test in RUN_ELSEWHERE.items():
        assert marker in (ROOT / test).read_text("utf-8")
        assert any(marker in page.read_text("utf-8") for page in PAGES), marker


@pytest.mark.parametrize("page", PAGES, ids=lambda page: str(page.relative_to(ROOT)))
def test_page_blocks_run(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = page.read_text("utf-8")
    code = blocks(text)
    if not code:
        pytest.skip("no python block")
    for module in EXTRAS:
        if re.search(rf"^\s*(from|import) {module}\b", "".join(code), re.MULTILINE) or (
                module == "rosbags" and "bag" in "".join(code)):
            pytest.importorskip(module)
    shutil.copy(ROOT / "tests" / "data" / "minimal.traj", tmp_path / "path.traj")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "__docs__"}
    for index, block in enumerate(code):
        exec(compile(block, f"{page.name}[block {index + 1}]", "exec"), namespace)
