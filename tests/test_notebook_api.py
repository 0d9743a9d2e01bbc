"""The Python API as a notebook uses it: one table as a DataFrame, short reprs, type
information (annotations, py.typed), and docstrings whose cross-references name real objects."""

from __future__ import annotations

import ast
import importlib
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

import gaz_cli as gaz
from gaz_cli import api
from gaz_cli.errors import QueryError

PACKAGE = Path(gaz.__file__).parent


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    """A database holding one 2D run of 200 argon atoms (sim 1), and that run."""
    db = tmp_path_factory.mktemp("db") / "gaz.db"
    scene = gaz.make_scene(dim=2, species={"Ar": 200}, length=2e-7, duration=2e-10, seed=1)
    return str(db), gaz.simulate(scene, db=str(db), keep_state=True, keep_bounces=True)


def test_analyse_one_table_is_a_dataframe(stored):
    """gaz.analyse(db, sim=1, table="pressure") is the DataFrame the dict holds under that
    table's title; a dict of scalars ("simulation") comes as one row; the dict stays for all."""
    import pandas as pd

    from gaz_cli.analysis.report import TABLES

    db, _ = stored
    frames = gaz.analyse(db, sim=1)
    assert isinstance(frames, dict) and TABLES["pressure"] in frames
    pressure = gaz.analyse(db, sim=1, table="pressure")
    assert isinstance(pressure, pd.DataFrame) and "P_UNIT" in pressure.columns
    pd.testing.assert_frame_equal(pressure, frames[TABLES["pressure"]])
    walls = gaz.analyse(db, sim=1, table="q36")
    assert isinstance(walls, pd.DataFrame) and len(walls) == 4  # four walls of a square
    simulation = gaz.analyse(db, sim=1, table="simulation")
    assert isinstance(simulation, pd.DataFrame) and len(simulation) == 1


def test_analyse_names_the_tables_it_has(stored):
    db, _ = stored
    with pytest.raises(QueryError, match=r"'walls' is not one of q34, q35, q36, overview"):
        gaz.analyse(db, sim=1, table="walls")
    with pytest.raises(QueryError, match=r"no table 'gravity' for this analysis \(not this scene\); it has: "
                                         r"q34, q35, q36, overview, simulation, pressure"):
        gaz.analyse(db, sim=1, table="gravity")


def test_reprs_are_short_and_show_no_array(stored):
    """repr of a run of N = 200 kept state and bounces: its summary and the shapes, at most 20
    lines (it printed about 700, the arrays twice); a scene on one line, even with an explicit
    initial state; a store on one."""
    from dataclasses import replace

    db, run = stored
    text = repr(run)
    assert len(text.splitlines()) <= 20 and "200 particles in 2D" in text, text
    assert "positions (200, 2)" in text and "array(" not in text and "[[" not in text, text
    scene = replace(run.scene, initial={"kind": "explicit", "positions": run.state.positions,
                                        "velocities": run.state.velocities})
    line = repr(scene)
    assert len(line.splitlines()) == 1 and len(line) < 300 and "Ar x 200" in line, line
    assert "initial=explicit (200 positions)" in line and "array(" not in line, line
    with gaz.open_store(db) as store:
        assert len(repr(store).splitlines()) <= 20


def test_py_typed_and_return_types():
    """PEP 561's marker ships with the package, and every public function of the API says
    what it returns."""
    assert (PACKAGE / "py.typed").is_file()
    for name in api.__all__:
        obj = getattr(api, name)
        if inspect.isfunction(obj):
            assert "return" in obj.__annotations__, f"gaz_cli.api.{name} has no return type"


def test_theory_at_the_top_level():
    """gaz.theory: the equations of state, wall models and rates that analyse compares with,
    reachable from a fresh ``import gaz_cli`` (a child process: here other tests import it)."""
    import subprocess
    import sys

    code = "import gaz_cli as gaz; print(gaz.theory.ideal_gas_pressure(100, 300.0, 1e-21))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert float(out.stdout) == pytest.approx(100 * 1.380649e-23 * 300.0 / 1e-21, rel=1e-12)


ROLE = re.compile(r":(func|class|mod):`([^`]+)`")


def _docstrings(tree: ast.Module):
    """Every docstring of a module: its own, its classes' and functions', and the attribute
    docstrings (a string statement after an assignment)."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                yield doc
        elif isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) \
                and isinstance(node.value.value, str):
            yield node.value.value


def _resolve(target: str, module: str) -> bool:
    """Whether the reference ``target`` (Sphinx's: ``~`` shortens the shown name, a leading
    ``.`` searches the current module and the packages above it) names an object."""
    name = target.lstrip("~")
    relative = name.startswith(".")
    name = name.lstrip(".")
    parts = module.split(".")
    candidates = [f"{'.'.join(parts[:k])}.{name}" for k in range(len(parts), 0, -1)]
    candidates = candidates if relative else [name, *candidates]
    for candidate in candidates:
        pieces = candidate.split(".")
        for cut in range(len(pieces), 0, -1):
            try:
                obj = importlib.import_module(".".join(pieces[:cut]))
            except ImportError:
                continue
            try:
                for piece in pieces[cut:]:
                    obj = getattr(obj, piece)
                return True
            except AttributeError:
                break
    return False


def _references():
    for path in sorted(PACKAGE.rglob("*.py")):
        module = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts).removesuffix(".__init__")
        for doc in _docstrings(ast.parse(path.read_text(encoding="utf-8"))):
            for role, target in ROLE.findall(doc):
                yield module, role, target


def test_every_docstring_reference_names_a_real_object():
    """Each :func:, :class: and :mod: of every docstring in gaz_cli imports (help(gaz.sweep)
    named gaz_cli.sweep.Report, a module that does not exist)."""
    refs = sorted(set(_references()))
    assert len(refs) > 300  # the walk found the package's references
    broken = [f"{module}: :{role}:`{target}`" for module, role, target in refs if not _resolve(target, module)]
    assert broken == []


def test_the_reference_check_sees_a_broken_one():
    assert not _resolve("gaz_cli.sweep.Report", "gaz_cli.api")
    assert _resolve("gaz_cli.run.sweeps.Report", "gaz_cli.api")
    assert _resolve(".sizing.use_dilute_scan", "gaz_cli.engines.event.neighbours.dilute")
    assert not _resolve(".engine.calendar", "gaz_cli.placement.growth")
    assert np  # (numpy imported for the fixtures' arrays)
