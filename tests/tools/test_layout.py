"""The command-line tools (cart2d/tools/) sit on top of the library: nothing in the library
imports them, and no import circle runs through them (the camera calibration's command and its
simulator part imported each other). Every import counts, those inside functions too."""

from __future__ import annotations

import ast
from pathlib import Path

import cart2d

PACKAGE = Path(cart2d.__file__).parent


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """Each cart2d module and the cart2d modules it imports (a name imported from a package
    counts as its submodule when there is one, else as the package)."""
    files = {module_name(f): f for f in PACKAGE.rglob("*.py")}

    def known(name: str) -> str:
        while name not in files:
            name = name.rpartition(".")[0]
        return name

    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        imported: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                imported |= {known(a.name) for a in node.names if a.name.startswith("cart2d.")}
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("cart2d"):
                assert node.level == 0, f"{name}: relative import"
                base = node.module or ""
                imported |= {known(f"{base}.{a.name}") for a in node.names}
        graph[name] = imported - {name}
    return graph


def circles(graph: dict[str, set[str]]) -> list[set[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[set[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(component)

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_the_library_does_not_import_the_tools() -> None:
    graph = import_graph()
    outside = {
        name: sorted(m for m in imported if m.startswith("cart2d.tools"))
        for name, imported in graph.items()
        if not name.startswith("cart2d.tools") and name != "cart2d.entry"
    }
    assert {name: tools for name, tools in outside.items() if tools} == {}


def test_no_import_circle_runs_through_the_tools() -> None:
    through_tools = [c for c in circles(import_graph()) if any(m.startswith("cart2d.tools") for m in c)]
    assert through_tools == []


def test_the_circle_finder_finds_a_circle() -> None:
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [{"a", "b", "c"}]
