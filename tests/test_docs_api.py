"""Every public name (each package's ``__all__``) has an entry in the API reference."""

from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

import mpc
import trajectories

ROOT = Path(__file__).resolve().parents[1]


def public_names() -> set[str]:
    """``package.name`` for every name in the ``__all__`` of mpc, trajectories and every
    subpackage of theirs that declares one."""
    names: set[str] = set()
    for root in (mpc, trajectories):
        packages = [root.__name__] + [info.name for info in pkgutil.walk_packages(
            root.__path__, f"{root.__name__}.") if info.ispkg]
        for name in packages:
            module = importlib.import_module(name)
            names.update(f"{name}.{item}" for item in getattr(module, "__all__", ()))
    return names


def test_every_public_name_has_a_reference_entry() -> None:
    entries = set()
    for page in (ROOT / "docs" / "reference").glob("*.md"):
        entries.update(re.findall(r"^::: ([\w.]+)\s*$", page.read_text("utf-8"), re.MULTILINE))
    names = public_names()
    assert len(names) > 150  # mpc, mpc.robots, trajectories ... all found
    assert sorted(names - entries) == []


def test_reference_pages_are_in_the_nav() -> None:
    nav = (ROOT / "mkdocs.yml").read_text("utf-8")
    for page in (ROOT / "docs" / "reference").glob("*.md"):
        assert f"reference/{page.name}" in nav, page.name


def test_sphinx_roles_render_as_plain_code() -> None:
    from mkdocs_hooks import plain_roles

    html = (":class:<code>Controller</code> and :func:<code>~mpc.robots.preset</code>, "
            ":py:meth:<code>Robot.twist</code>; <code>:keep:</code>")
    assert plain_roles(html) == ("<code>Controller</code> and <code>preset</code>, "
                                 "<code>Robot.twist</code>; <code>:keep:</code>")
