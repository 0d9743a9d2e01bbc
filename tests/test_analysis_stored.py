"""gaz analyse on rows no run can have (written by hand or by another program): one line, exit 1."""

from __future__ import annotations

import shutil
import sqlite3

import pytest

from cli_helpers import invoke
from gaz_cli.run import runner
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import lookup


@pytest.fixture(scope="module")
def good_db(tmp_path_factory):
    """One run of the exam's own engine (no JIT to wait for), a few ms long."""
    path = tmp_path_factory.mktemp("stored") / "g.db"
    runner.simulate(Scene(dim=2, length=1e-7, duration=2e-10, components=((lookup("Ar"), 20),), seed=1,
                          engine="reference"), db=str(path))
    return path


@pytest.mark.parametrize("update, column", [
    # before: 'gaz: internal error: ZeroDivisionError: float division by zero', exit 3
    ("UPDATE SIMULATION SET SI_DUR = 0", "SI_DUR"),
    # before: two RuntimeWarning lines with their source line on stderr, then tables of inf and NaN
    ("UPDATE SIMULATION SET SI_L = 0", "SI_L"),
    ("UPDATE SIMULATION SET SI_L = 'abc'", "SI_L"),
    # before: 'kinetic temperature needs at least 1 particle, got 0' and 'dimension must be the
    # integer 1, 2 or 3, got 4', which named no row to correct
    ("UPDATE SIMULATION SET SI_N = 0", "SI_N"),
    ("UPDATE SIMULATION SET SI_DIM = 4", "SI_DIM"),
    ("UPDATE PARTICULE SET PA_M = 0", "PA_M"),
    ("UPDATE PARTICULE SET PA_R = -1", "PA_R"),
    ("UPDATE COMPOSITION SET CO_N = 0", "CO_N"),
    # huge finite values. Before: a bounce at RE_T = 1e300 printed numpy's 'RuntimeWarning:
    # invalid value encountered in cast' and its source line, then the tables (exit 0); RE_VIT,
    # RE_VP = 1e300 'overflow encountered in square', then 'internal error: LinAlgError', exit 3;
    # SI_L, SI_DUR = 1e300 'internal error: OverflowError', exit 3; PA_M, PA_R = 1e300 overflow
    # warnings, then tables of inf and NaN
    ("UPDATE REBOND SET RE_T = 1e300 WHERE RE_NUM = 1", "RE_T"),       # out of time order: GROUP BY
    ("UPDATE REBOND SET RE_T = 1e300 WHERE RE_NUM = (SELECT MAX(RE_NUM) FROM REBOND)", "RE_T"),  # in order
    ("UPDATE REBOND SET RE_T = -1 WHERE RE_NUM = 1", "RE_T"),
    ("UPDATE REBOND SET RE_VIT = 1e300 WHERE RE_NUM = 2", "RE_VIT"),
    ("UPDATE REBOND SET RE_VP = 1e300 WHERE RE_NUM = 2", "RE_VP"),
    ("UPDATE SIMULATION SET SI_L = 1e300", "SI_L"),
    ("UPDATE SIMULATION SET SI_DUR = 1e300", "SI_DUR"),
    ("UPDATE PARTICULE SET PA_M = 1e300", "PA_M"),
    ("UPDATE PARTICULE SET PA_R = 1e300", "PA_R"),
])
@pytest.mark.parametrize("sim", [["--sim", "1"], []], ids=["sim", "all"])
def test_a_row_no_run_can_have_is_one_line_naming_it(good_db, tmp_path, update, column, sim):
    db = tmp_path / "bad.db"
    shutil.copy(good_db, db)
    with sqlite3.connect(db) as con:
        con.execute(update)
    con.close()
    res = invoke(["analyse", "--db", str(db), *sim])
    assert res.exit_code == 1 and res.stdout == "", res.output
    assert res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(f"gaz: error: simulation 1 cannot be analysed: ") and column in res.stderr, res.stderr
