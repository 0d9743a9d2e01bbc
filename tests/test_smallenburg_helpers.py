"""The pure helpers of benchmarks/smallenburg.py (no C compiler, no EDMD copy needed)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parent.parent / "benchmarks" / "smallenburg.py"
_spec = importlib.util.spec_from_file_location("smallenburg_bench", _PATH)
sb = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(sb)

GLOBALS = """double maxtime = 10;           //Simulation stops at this time
int makesnapshots = 0;
double writeinterval = 1;
double snapshotinterval = 1;
int initialconfig = 0;
const int usethermostat = 0;
"""


def test_check_args_complains_in_one_line():
    assert sb.check_args("Single", "lists") is None
    assert sb.check_args("Cell", "auto") is None
    for bad in (sb.check_args("Multi", "lists"), sb.check_args("Cell", "wide")):
        assert bad and "\n" not in bad


def test_cell_patterns_are_single_ones_less_the_shell():
    assert set(sb.VARIANTS["Single"][2]) == set(sb.PARAMS)
    assert set(sb.PARAMS) - set(sb.VARIANTS["Cell"][2]) == {r"const double shellsize = [^;]*;"}


def test_patch_params_writes_the_run_and_refuses_a_missing_global(capsys):
    cell = sb.VARIANTS["Cell"][2]
    out = sb.patch_params(GLOBALS, "mdCell.c", cell, 172.5, 17.25)
    assert "double maxtime = 172.5;" in out and "double writeinterval = 17.25;" in out
    assert "double snapshotinterval = 17.25;" in out
    with pytest.raises(SystemExit) as exc:  # Single's patterns want the shell too
        sb.patch_params(GLOBALS, "mdCell.c", sb.VARIANTS["Single"][2], 1.0, 0.1)
    assert "\n" not in str(exc.value) and "shellsize" in str(exc.value)
