"""The packages' import graph: no cycles (imports for type checking and imports inside
functions included) and no module importing from a layer above its own."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).parents[1]
PACKAGES = ("mpc", "trajectories", "benchmarks")

#: Layers from the bottom: a module may import from its own layer and those below. A
#: module belongs to the first layer one of whose prefixes it starts with.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("mpc.errors", "mpc.arrays", "mpc.angles", "mpc.validation", "mpc.plausibility",
     "mpc.buffered", "mpc.profiling"),
    ("mpc.robots",),
    ("mpc.model", "trajectories"),
    ("mpc.solvers",),
    ("mpc.control", "mpc.tick"),
    ("mpc.sim", "mpc.adapters"),
    ("mpc.simulation", "mpc.plot"),
    ("mpc",),
    ("benchmarks",),
)


def _modules() -> dict[str, Path]:
    modules = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            modules[".".join(parts)] = path
    return modules


MODULES = _modules()


def _resolve(name: str) -> str | None:
    """The project module ``name`` names, or its nearest enclosing package module."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _imports(module: str) -> Iterator[str]:
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text("utf-8"))):
        if isinstance(node, ast.Import):
            targets = [_resolve(alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(parts + ([node.module] if node.module else []))
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES
                       else _resolve(base) for alias in node.names]
        else:
            continue
        yield from (target for target in targets if target and target != module)


GRAPH = {module: set(_imports(module)) for module in MODULES}


def _layer(module: str) -> int:
    for index, prefixes in enumerate(LAYERS):
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return index
    raise AssertionError(f"{module} is in no layer: add it to LAYERS")


def test_no_import_cycles() -> None:
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(node: str) -> None:  # Tarjan's strongly connected components
        index[node] = low[node] = len(index)
        stack.append(node)
        for target in GRAPH[node]:
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for module in sorted(GRAPH):
        if module not in index:
            visit(module)
    assert not cycles, f"import cycles: {cycles}"


def test_no_import_from_a_layer_above() -> None:
    upward = sorted(f"{module} -> {target}" for module, targets in GRAPH.items()
                    for target in targets if _layer(target) > _layer(module))
    assert not upward, f"imports from a layer above: {upward}"


def test_the_graph_is_read() -> None:
    assert "mpc.robots.base" in GRAPH["mpc.robots.wheels.swedish"] or any(
        target.startswith("mpc.robots.") for target in GRAPH["mpc.robots.wheels.swedish"])
    assert "mpc.control.controller" in GRAPH["mpc.control"]
