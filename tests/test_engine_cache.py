"""The key of the event loop's disk cache (engine/intrinsics.py, :func:`sources_digest`):
it must change with every source file whose code the cached loop holds, so that a user who
upgrades gaz never runs old machine code. Tested on a copy of the package under tmp_path."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import gaz_cli
from gaz_cli.engines.event.intrinsics import kernel_sources, sources_digest

PACKAGE = Path(gaz_cli.__file__).parent


@pytest.fixture
def tree(tmp_path):
    """A copy of the gaz_cli package (sources only) under tmp_path; returns tmp_path."""
    shutil.copytree(PACKAGE, tmp_path / "gaz_cli", ignore=shutil.ignore_patterns("__pycache__"))
    return tmp_path


def _edit(path: Path, text: str = "\n# an edit\n") -> None:
    path.write_text(path.read_text(encoding="utf-8") + text, encoding="utf-8")


def test_digest_follows_an_edit_in_a_new_sub_package(tree):
    # a search kind in a sub-package of neighbours/, imported by the loop
    deep = tree / "gaz_cli" / "engines" / "event" / "neighbours" / "deep"
    deep.mkdir()
    (deep / "__init__.py").write_text('"""A nested package."""\n', encoding="utf-8")
    (deep / "helpers.py").write_text("from gaz_cli.engines.event.intrinsics import _inline\n\n\n"
                                     "@_inline\ndef _x(a):\n    return a\n", encoding="utf-8")
    _edit(tree / "gaz_cli" / "engines" / "event" / "loop.py",
          "\nfrom gaz_cli.engines.event.neighbours.deep.helpers import _x  # noqa: E402,F401\n")
    before = sources_digest(tree)
    _edit(deep / "helpers.py", "\n\n@_inline\ndef _y(a):\n    return a + 1\n")
    assert sources_digest(tree) != before


def test_digest_follows_the_numba_options(tree):
    before = sources_digest(tree)
    _edit(tree / "gaz_cli" / "numba_config.py")
    assert sources_digest(tree) != before


def test_digest_ignores_the_python_side(tree):
    # the driver, sizing and the CLI are Python only: editing them needs no recompilation
    before = sources_digest(tree)
    for name in ("engines/event/driver.py", "engines/event/sizing.py", "cli.py"):
        _edit(tree / "gaz_cli" / name)
    assert sources_digest(tree) == before


def test_sources_are_the_modules_the_loop_imports():
    """The set read from the import lines equals the modules Python loads with the loop (a
    fresh interpreter importing gaz_cli.engines.event.loop; package __init__ files aside)."""
    code = ("import json, sys; import gaz_cli.engines.event.loop; print(json.dumps(sorted("
            "m.__file__ for n, m in sys.modules.items() if n.startswith('gaz_cli') "
            "and getattr(m, '__file__', None) and not m.__file__.endswith('__init__.py'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = sorted(Path(f).resolve() for f in json.loads(out.stdout))
    assert sorted(f.resolve() for f in kernel_sources()) == loaded
