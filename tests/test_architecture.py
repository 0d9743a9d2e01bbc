"""The house's shape (docs/architecture.md): one folder per job, no import circle, modules a
reader can hold, and one table of scene options that every layer reads."""

from __future__ import annotations

import ast
import dataclasses
import math
from pathlib import Path

import click
import pytest

from gaz_cli import cli
from gaz_cli.engines import registry
from gaz_cli.errors import SceneError
from gaz_cli.model.scene import ENGINES, OPTIONS, STEP_ONLY, Scene
from gaz_cli.model.species import BUILTIN
from gaz_cli.scenes import files as scenefile
from gaz_cli.scenes import options as opts
from gaz_cli.scenes.validate import validate

PACKAGE = Path(cli.__file__).resolve().parent

MAX_TOP_LEVEL = 14
"""Modules at gaz_cli's top level (the faces and the ground floor; the rest lives in folders)."""

ALLOWED_CIRCLES = [{"gaz_cli.placement", "gaz_cli.placement.growth", "gaz_cli.placement.mixture",
                    "gaz_cli.placement.overlaps"}]
"""Placement's own recursion: a mixture places its large particles, then the small among them."""


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def import_graph() -> dict[str, set[str]]:
    """Module -> the gaz_cli modules it imports, at module level or inside functions, and the
    packages whose ``__init__`` those imports run."""
    modules = _modules()

    def owner(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {m: set() for m in modules}
    for module, path in modules.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = package.split(".")
                    base = ".".join(parts[:len(parts) - node.level + 1] + ([node.module] if node.module else []))
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            for target in targets:
                found = owner(target)
                if found and found not in ("gaz_cli", module):
                    graph[module].add(found)  # the module imported...
                while found and found != "gaz_cli":  # ...and the packages its import runs first
                    found = found.rpartition(".")[0]
                    if found not in ("", "gaz_cli") and not module.startswith(found + "."):
                        graph[module].add(found)
    return graph


def circles(graph: dict[str, set[str]]) -> list[set[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = set()
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        component.add(w)
                        if w == v:
                            break
                    if len(component) > 1:
                        out.append(component)
    return out


# --- the tree ----------------------------------------------------------------------------------
def test_no_import_circle_but_placements_own():
    found = [c for c in circles(import_graph()) if c not in ALLOWED_CIRCLES]
    assert not found, found


def test_the_circle_finder_finds_a_circle():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [{"a", "b", "c"}]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_few_modules_at_the_top_level():
    top = [p for p in PACKAGE.glob("*.py") if p.name != "__init__.py"]
    assert len(top) <= MAX_TOP_LEVEL, sorted(p.name for p in top)


def test_the_scene_imports_no_engine_store_output_placement_or_theory():
    graph = import_graph()
    for module in ("gaz_cli.model.scene", "gaz_cli.model.species"):
        reached, todo = set(), [module]
        while todo:
            for nxt in graph[todo.pop()] - reached:
                reached.add(nxt)
                todo.append(nxt)
        assert not {m for m in reached if m.split(".")[1] in ("engines", "results", "outputs", "placement",
                                                               "theory", "run", "analysis", "scenes")}, reached


# --- one table of scene options ----------------------------------------------------------------
def test_every_option_with_a_flag_is_a_simulate_option_with_its_help():
    params = {p.name: p for p in cli.simulate.params if isinstance(p, click.Option)}
    for name, row in OPTIONS.items():
        if name == "seed":  # seed_option, shared with gaz place
            assert "--seed" in params["seed"].opts
            continue
        assert name in params, name
        assert params[name].opts == [row.flag] and params[name].help == row.help, name


def test_scene_file_keys_and_flags_come_from_the_table():
    assert set(scenefile.SCALARS) - {"packing"} == {n for n, o in OPTIONS.items() if o.kind != "planes"}
    assert set(scenefile.STEP_KEYS) == {n for n in STEP_ONLY if n != "planes"}
    assert all(opts.FLAGS[name] == row.flag for name, row in OPTIONS.items())
    assert {f.name for f in dataclasses.fields(Scene)} - set(OPTIONS) == {"components", "initial", "extras"}


def test_step_only_options_keep_their_defaults_elsewhere():
    defaults = {f.name: f.default for f in dataclasses.fields(Scene)}
    assert STEP_ONLY == {n: defaults[n] for n, o in OPTIONS.items() if o.engines == ("step",)}
    assert set(registry.ENGINES) == set(ENGINES) - {"auto"}


def _scene(**keys) -> Scene:
    base = dict(dim=3, length=1e-7, duration=1e-12, components=((BUILTIN["Ar"], 10),), seed=1)
    return Scene(**{**base, **keys})


BAD = {"positive": -1.0, "at least zero": -1.0, "unit interval": 1.5, "one of": "nonsense",
       "whole at least zero": -1, "bool": "yes"}


@pytest.mark.parametrize("name", [n for n, o in OPTIONS.items() if o.rule])
def test_each_rule_refuses_its_out_of_range_value_naming_the_field(name):
    row = OPTIONS[name]
    keys = {name: BAD[row.rule[0]]}
    if row.engines == ("step",):
        keys.update(engine="step", dt=1e-14)
        keys[name] = BAD[row.rule[0]]
    with pytest.raises(SceneError, match=f"`?{name}`?"):
        validate(_scene(**keys))


def test_a_valid_scene_passes_every_rule():
    scene = validate(_scene(engine="step", dt=1e-14, drag=0.5, wall_restitution=0.9, print_every=2))
    assert scene.engine == "step" and math.isclose(scene.drag, 0.5)


def test_the_scene_rows_columns_are_the_tables_stored_options():
    from gaz_cli.results.schema import scene_table

    columns = {c.name for c in scene_table.columns} - {"si_num", "sc_version", "sc_file"}
    assert columns == {f"sc_{name}" for name, row in OPTIONS.items() if row.column}


MAX_LINES = 1000
"""A module a reader can hold; the exam's own functions (engines/reference.py) are exempt."""


def test_no_module_over_a_thousand_lines_but_the_exams():
    long = {m: n for m, p in _modules().items()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES and m != "gaz_cli.engines.reference"}
    assert not long, long


def test_one_name_per_concept():
    """No two engines' kernels, classes or initial states share a name with different meanings."""
    defined: dict[str, list[str]] = {}
    for module, path in _modules().items():
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            names = [node.name] if isinstance(node, (ast.FunctionDef, ast.ClassDef)) else \
                [t.id for t in node.targets if isinstance(t, ast.Name)] if isinstance(node, ast.Assign) else []
            for name in names:
                if name in CLASHED:
                    defined.setdefault(name, []).append(module)
    assert all(len(where) == 1 for where in defined.values()), defined


CLASHED = ("Run", "_advance", "_collide", "initial_state", "FORMATS")
"""Names that once meant two things (issue 37): each now defined once."""


def test_the_door_reads_no_database():
    """scenes/ admits a scene without the store: nothing of results/ is imported there."""
    graph = import_graph()
    reads = {m: sorted(d for d in deps if d.startswith("gaz_cli.results"))
             for m, deps in graph.items() if m.startswith("gaz_cli.scenes")}
    assert not any(reads.values()), reads


def test_every_folders_init_imports_nothing():
    """Importing gaz_cli.x.y runs gaz_cli/x/__init__.py first: an import there would load more
    than the module asked for, and join every circle through the folder. Two faces are their
    names: theory/ (``theory.NAME`` for every formula) and placement/ (``place``)."""
    folders = [p for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()]
    graph = import_graph()
    assert {f"gaz_cli.{p.name}": sorted(graph[f"gaz_cli.{p.name}"]) for p in folders
            if p.name not in ("placement", "theory") and graph[f"gaz_cli.{p.name}"]} == {}
