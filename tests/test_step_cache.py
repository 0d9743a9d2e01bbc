"""The key of the step loop's disk cache (engines/step/loop.py, :func:`sources_digest`): it must
change with every source file whose code the cached loop holds (the loop is split over several
modules, and Numba keys a function on its own file only), so that an edit or an upgrade never
runs old machine code. Tested on a copy of the package under tmp_path."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import gaz_cli
from gaz_cli.engines.event.intrinsics import kernel_sources
from gaz_cli.engines.step.loop import sources_digest

PACKAGE = Path(gaz_cli.__file__).parent
START = "gaz_cli.engines.step.loop"


@pytest.fixture
def tree(tmp_path):
    """A copy of the gaz_cli package (sources only) under tmp_path; returns tmp_path."""
    shutil.copytree(PACKAGE, tmp_path / "gaz_cli", ignore=shutil.ignore_patterns("__pycache__"))
    return tmp_path


def _edit(path: Path) -> None:
    path.write_text(path.read_text(encoding="utf-8") + "\n# an edit\n", encoding="utf-8")


@pytest.mark.parametrize("name", ["walls.py", "wall_contact.py", "resting.py", "contacts.py", "cells.py",
                                  "passes.py", "push.py", "codes.py", "patches.py"])
def test_digest_follows_an_edit_of_any_kernel_module(tree, name):
    path = tree / "gaz_cli" / "engines" / "step" / name
    if not path.exists():
        pytest.skip(f"no {name}")
    before = sources_digest(tree)
    _edit(path)
    assert sources_digest(tree) != before


def test_digest_follows_the_numba_options(tree):
    before = sources_digest(tree)
    _edit(tree / "gaz_cli" / "numba_config.py")
    assert sources_digest(tree) != before


def test_digest_ignores_the_python_driver(tree):
    before = sources_digest(tree)
    for name in ("engines/step/__init__.py", "cli.py"):
        _edit(tree / "gaz_cli" / name)
    assert sources_digest(tree) == before


def test_sources_are_the_modules_the_loop_imports():
    """The set read from the import lines holds every gaz module Python loads with the loop
    (a fresh interpreter importing it; package __init__ files aside)."""
    code = (f"import json, sys; import {START}; print(json.dumps(sorted("
            "m.__file__ for n, m in sys.modules.items() if n.startswith('gaz_cli') "
            "and getattr(m, '__file__', None) and not m.__file__.endswith('__init__.py'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = {Path(f).resolve() for f in json.loads(out.stdout)}
    # (accepts.py: the driver's pure-Python checks of a scene, loaded by the package, no kernel)
    step = {f for f in loaded if "engines/step" in f.as_posix() and f.name != "accepts.py"}
    sources = {f.resolve() for f in kernel_sources(start=START)}
    assert step and step <= sources
