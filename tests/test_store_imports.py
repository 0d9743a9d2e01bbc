"""The shape of gaz_cli/results/: its modules import one another one way (no circle, lazy
imports inside functions included), scenes/ imports nothing of it, and no module of it
passes 1,000 lines. Read from the source with ast: nothing is imported."""

from __future__ import annotations

import ast
from pathlib import Path

import gaz_cli

PACKAGE = Path(gaz_cli.__file__).resolve().parent
MAX_LINES = 1000


def _modules() -> dict[str, Path]:
    """Every module of gaz_cli by dotted name (a package by its own name)."""
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def _imports(name: str, path: Path, modules: dict) -> set[str]:
    """The gaz_cli modules ``name`` imports, anywhere in its file (a function's lazy import too);
    importing ``a.b.c`` imports ``a`` and ``a.b`` (their __init__) as well."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                kept = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(kept + ([base] if base else []))
            targets = [base] + [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        for target in targets:
            parts = target.split(".")
            found |= {".".join(parts[:k]) for k in range(1, len(parts) + 1)} & modules.keys()
    return found - {name}


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter[0]
                    counter[0] += 1
                    stack.append(child)
                    on.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    top = stack.pop()
                    on.discard(top)
                    component.append(top)
                    if top == node:
                        break
                if len(component) > 1:
                    out.append(sorted(component))
    return out


def test_no_circle_through_results():
    circles = [c for c in _circles(_graph()) if any(m.startswith("gaz_cli.results") for m in c)]
    assert circles == []


def test_scenes_import_nothing_of_results():
    graph = _graph()
    assert {m: sorted(d for d in deps if d.startswith("gaz_cli.results"))
            for m, deps in graph.items() if m.startswith("gaz_cli.scenes")
            and any(d.startswith("gaz_cli.results") for d in deps)} == {}


def test_results_package_imports_nothing():
    """Every import of gaz_cli.results.x runs results/__init__.py: an import there would put it
    in every circle."""
    assert _graph()["gaz_cli.results"] == set()


def test_results_modules_are_short():
    long = {p.name: n for p in (PACKAGE / "results").glob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert long == {}


def test_the_circle_finder_finds_one():
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
