"""The package's shape: stages import downwards only, and keep their private names.

The import graph is read from the sources (every ``import`` and ``from … import``,
at module level or inside a function), module by module; a name imported from a
package resolves to the submodule that defines it when there is one.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import unseeable

ROOT = Path(unseeable.__file__).parent


def _module_name(path: Path) -> str:
    parts = ["unseeable", *path.relative_to(ROOT).with_suffix("").parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in ROOT.rglob("*.py")}


def _resolve(name: str, imported: str | None) -> str | None:
    """The project module ``from name import imported`` (or ``import name``) reaches."""
    if imported is not None and f"{name}.{imported}" in MODULES:
        return f"{name}.{imported}"
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _imports(module: str) -> list[tuple[str, str | None, int]]:
    """(imported module, imported name or None, line) for every project import of
    ``module``."""
    path = MODULES[module]
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("unseeable"):
                    found.append((alias.name, None, node.lineno))
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[:len(anchor) - node.level + 1]
                base = ".".join([*anchor, *([base] if base else [])])
            if base.startswith("unseeable"):
                for alias in node.names:
                    found.append((base, alias.name, node.lineno))
    return found


def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for module in MODULES:
        for base, name, _ in _imports(module):
            target = _resolve(base, name)
            if target is not None and target != module:
                graph[module].add(target)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_import_graph_has_no_cycle():
    assert _cycles(_graph()) == []


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


@pytest.mark.parametrize("stage, forbidden", [
    ("unseeable.vision", ("unseeable.render", "unseeable.pipeline", "unseeable.training",
                          "unseeable.evaluate", "unseeable.cli")),
    ("unseeable.grammar", ("unseeable.solve", "unseeable.vision", "unseeable.pipeline")),
    ("unseeable.domain", ("unseeable.grammar", "unseeable.solve", "unseeable.vision",
                          "unseeable.pipeline")),
])
def test_a_stage_does_not_import_the_stages_built_on_it(stage, forbidden):
    bad = [(m, base, line) for m in MODULES if m == stage or m.startswith(stage + ".")
           for base, _, line in _imports(m) if base.startswith(forbidden)]
    assert bad == []


def test_no_private_name_is_imported_from_another_module():
    bad = [(m, f"{base}.{name}", line) for m in MODULES for base, name, line in _imports(m)
           if name is not None and name.startswith("_") and not name.startswith("__")]
    assert bad == []


def test_no_module_of_the_package_reaches_into_benchmarks_or_tests():
    bad = []
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            bad += [(module, n) for n in names if n.split(".")[0] in ("benchmarks", "tests")]
    assert bad == []
