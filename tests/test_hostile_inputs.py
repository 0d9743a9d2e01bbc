"""Hostile inputs at the door: each bad command line ends in one line on stderr, a non-zero
exit, no traceback, the database untouched (byte for byte) and no file written.

Each case runs ``gaz`` in-process (click's CliRunner, through the real entry point ``main``)
with ``--db`` on a copy of a database that already holds one simulation; the copy's SHA-256
is compared before and after. The same cases make the table of docs/explanation/stability.md::

    GAZ_WRITE_STABILITY=1 python -m pytest tests/test_hostile_inputs.py -k table

writes it between the markers ``<!-- hostile-inputs:begin -->`` and ``<!-- hostile-inputs:end -->``
(the file is created with a heading and that section if absent). Two faults need a real
process and have their own tests: a full disk under a trajectory (tests/test_trajectory.py)
and Ctrl-C in the step engine (tests/test_stepper.py).
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import pytest
from cli_helpers import invoke

from gaz_cli.errors import SceneError

SIM = ["simulate", "--duration", "1e-10", "--seed", "1"]
"""A simulate command's common part; every case adds --db."""

CASES = [
    # (what is wrong, arguments, expected exit code, a fragment of the message)
    ("N = 10^12 particles", [*SIM, "--dim", "3", "--n", "1000000000000", "--length", "1e-3"], 1, "memory"),
    ("N = 10^20 (beyond int64)", [*SIM, "--dim", "3", "--n", "100000000000000000000", "--length", "1e-3"], 1,
     "2^63 - 1"),
    ("box side 1e300 m in 3D", [*SIM, "--dim", "3", "--n", "10", "--length", "1e300"], 1, "range"),
    ("box side 1e-200 m", [*SIM, "--dim", "2", "--n", "1", "--radius", "1e-210", "--mass", "1e-26",
                            "--length", "1e-200"], 1, "range"),
    ("mass 1e-170 kg", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--radius", "1e-10",
                        "--mass", "1e-170"], 1, "reduced mass"),
    ("mass 1e300 kg", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--radius", "1e-10",
                       "--mass", "1e300"], 1, "reduced mass"),
    ("radius 1e-200 m", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--radius", "1e-200",
                         "--mass", "1e-26"], 1, "range"),
    ("temperature 1e300 K", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--temperature", "1e300"], 1,
     "range"),
    ("temperature 1e-300 K", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--temperature", "1e-300"],
     1, "range"),
    ("temperature 1e100 K (10^49 events)", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                            "--temperature", "1e100"], 1, "--force"),
    ("gravity 1e300 m/s^2", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--gravity", "1e300"], 1,
     "range"),
    ("gravity 1e200 m/s^2 (10^188 bounces)", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                              "--gravity", "1e200"], 1, "--force"),
    ("5.6e11 events (1 s of 1000 argon atoms)", ["simulate", "--dim", "2", "--n", "1000", "--length", "1e-6",
                                                 "--duration", "1", "--seed", "1"], 1, "--force"),
    ("step engine, 10^20 steps", [*SIM, "--dim", "2", "--n", "100", "--length", "1e-7", "--engine", "step",
                                  "--dt", "1e-30"], 1, "--force"),
    ("reference engine, N = 10^5", [*SIM, "--dim", "3", "--n", "100000", "--length", "1e-3",
                                    "--engine", "reference"], 1, "--engine event"),
    ("10^15 snapshots (--every 1e-25)", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                         "--trajectory", "{tmp}/t.h5", "--every", "1e-25"], 1, "snapshots"),
    ("reference engine with --trajectory", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                            "--engine", "reference", "--trajectory", "{tmp}/t.h5",
                                            "--every", "1e-12"], 1, "no trajectory"),
    ("trajectory format .txt", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                "--trajectory", "{tmp}/t.txt", "--every", "1e-12"], 1, ".h5"),
    ("trajectory in a missing folder", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                        "--trajectory", "{tmp}/nowhere/t.h5", "--every", "1e-12"], 1,
     "does not exist"),
    ("--trajectory without --every", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                      "--trajectory", "{tmp}/t.h5"], 1, "--every"),
    ("--every without --trajectory", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--every", "1e-12"],
     1, "--trajectory"),
    ("--no-db with --db", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--no-db"], 2, "--no-db"),
    ("--every -1", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--trajectory", "{tmp}/t.h5",
                    "--every", "-1"], 1, "--every"),
    ("one argon atom in a box 2e-12 m wider than it (1e12 bounces)",
     ["simulate", "--dim", "1", "--n", "1", "--length", "3.6e-10", "--duration", "1e-2", "--seed", "1",
      "--record", "none"], 1, "9.97e+11 events"),
    ("sweep: --vary an unknown key", ["sweep", "{tmp}/range.toml", "--vary", "colour=1,2", "--db", "{tmp}/gaz.db"],
     1, "unknown parameter 'colour'"),
    ("analyse: --db ''", ["analyse", "--db", ""], 2, "names no database"),
    ("analyse: --db a folder", ["analyse", "--db", "{tmp}"], 1, "is a folder, not a database file"),
    ("dimension 4", [*SIM, "--dim", "4", "--n", "10", "--length", "1e-7"], 1, "1, 2 or 3"),
    ("negative box", [*SIM, "--dim", "2", "--n", "10", "--length", "-1"], 1, "--length"),
    ("box side nan", [*SIM, "--dim", "2", "--n", "10", "--length", "nan"], 1, "--length"),
    ("duration inf", ["simulate", "--dim", "2", "--n", "10", "--length", "1e-7", "--duration", "inf"], 1,
     "--duration"),
    ("N = 0", [*SIM, "--dim", "2", "--n", "0", "--length", "1e-7"], 1, "--n"),
    ("packing above close packing", [*SIM, "--dim", "3", "--n", "1000", "--length", "1e-9"], 1, "packing"),
    ("restitution 2", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--restitution", "2"], 1,
     "restitution"),
    ("unknown species", [*SIM, "--dim", "2", "--species", "Zz:5", "--length", "1e-7"], 1, "species"),
    ("gravity in a periodic box", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--gravity", "9.8",
                                   "--boundary", "periodic"], 1, "walls"),
    ("step engine without --dt", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--engine", "step"], 1,
     "--dt"),
    ("negative --dt", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--engine", "step",
                       "--dt", "-1"], 1, "--dt"),
    ("--dim not a number", [*SIM, "--dim", "three", "--n", "10", "--length", "1e-7"], 2, "--dim"),
    ("step option with the event engine", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7", "--engine", "event", "--drag", "0.5"],
     1, "--drag 0.5 applies to --engine step only"),
    ("a preset with a flag its state depends on", ["simulate", "--preset", "marbles", "--n", "10", "--dim", "2"],
     1, "--preset marbles sets --dim itself"),
    ("scene file with an unknown key", ["simulate", "{tmp}/bad.toml"], 1, "unknown key 'colour' (= 3)"),
    ("scene file out of range", ["simulate", "{tmp}/range.toml"], 1, "range.toml: restitution 2.0 is outside [0, 1]"),
    ("scene file that is not TOML", ["simulate", "{tmp}/run.h5"], 1, "not valid TOML"),
    ("scene file missing", ["simulate", "{tmp}/none.toml"], 1, "cannot read scene file"),
    ("place: N = 10^12", ["place", "--dim", "3", "--n", "1000000000000", "--radius", "1e-10",
                          "--length", "1e-3"], 1, "memory"),
    ("place: N = 10^20", ["place", "--dim", "3", "--n", "100000000000000000000", "--radius", "1e-10",
                          "--length", "1e-3"], 1, "2^63 - 1"),
    ("place: box side 1e300 m in 3D", ["place", "--dim", "3", "--n", "10", "--radius", "1",
                                       "--length", "1e300"], 1, "range"),
    ("place: histogram h.txt", ["place", "--dim", "1", "--n", "2", "--radius", "1", "--length", "10",
                                "--repeat", "3", "--histogram", "{tmp}/h.txt"], 2, ".png"),
    ("place: radius 0", ["place", "--dim", "2", "--n", "5", "--radius", "0", "--length", "1"], 2, "--radius"),
    ("place: radius nan", ["place", "--dim", "2", "--n", "5", "--radius", "nan", "--length", "1"], 2,
     "--radius nan is not a number"),
    ("place: --bins 10^14", ["place", "--dim", "1", "--n", "2", "--radius", "1", "--length", "10",
                             "--repeat", "2", "--bins", "100000000000000"], 1, "--bins"),
    ("place: --repeat 10^14", ["place", "--dim", "1", "--n", "2", "--radius", "1", "--length", "10",
                               "--repeat", "100000000000000"], 1, "--repeat"),
    ("animate: -o out.txt", ["animate", "{tmp}/run.h5", "-o", "{tmp}/out.txt"], 1, ".gif"),
    ("animate: -o ''", ["animate", "{tmp}/run.h5", "-o", ""], 1, "names no file"),
    ("animate: not a trajectory", ["animate", "{tmp}/run.h5"], 1, "trajectory"),
    ("animate: a .pvd listing a missing snapshot", ["animate", "{tmp}/gone.pvd"], 1, "gone_00000.vtu"),
    ("scene: SI_NUM beyond int64", ["scene", "99999999999999999999999", "--db", "{tmp}/gaz.db"], 1,
     "64-bit"),
    ("query: a parameter beyond int64", ["query", "q36", "--param", "si_num=99999999999999999999999",
                                         "--db", "{tmp}/gaz.db"], 1, "64-bit"),
    ("query: a parameter not a number", ["query", "q36", "--param", "si_num=abc", "--db", "{tmp}/gaz.db"], 1,
     "whole number"),
    ("species name of 65 characters", ["simulate", "{tmp}/longname.toml"], 1, "PA_NOM"),
    ("sweep: a value given twice", ["sweep", "{tmp}/range.toml", "--vary", "temperature=100,100",
                                    "--db", "{tmp}/gaz.db"], 1, "comes twice"),
    ("sweep: a file no point of which can run", ["sweep", "{tmp}/range.toml", "--vary", "temperature=100,200",
                                                 "--db", "{tmp}/new.db"], 1, "range.toml: restitution 2.0"),
    ("scene file with an unknown species", ["simulate", "{tmp}/zz.toml"], 1, "species[0]: unknown species"),
    ("a custom species named Ar", ["simulate", "{tmp}/customar.toml"], 1,
     "species name 'Ar' is the built-in Ar"),
    ("a species name with a comma", ["simulate", "{tmp}/comma.toml"], 1, "holds ',' or ':'"),
    ("a species name with a colon", ["simulate", "{tmp}/colon.toml"], 1, "holds ',' or ':'"),
    ("scene file nested 5000 deep", ["simulate", "{tmp}/deep.toml"], 1, "nested"),
    ("explicit velocities of 1e300 m/s", ["simulate", "{tmp}/fast.toml"], 1, "initial velocities"),
    ("explicit positions overlapping", ["simulate", "{tmp}/overlap.toml"], 1, "overlap"),
    ("--save-state onto the database", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                        "--save-state", "{tmp}/gaz.db"], 1, "--db"),
    ("--write-scene onto the database", [*SIM, "--dim", "2", "--n", "10", "--length", "1e-7",
                                         "--write-scene", "{tmp}/gaz.db"], 1, "--db"),
]


@pytest.fixture(scope="module")
def populated_db(tmp_path_factory):
    """A database holding one small simulation: what the hostile inputs must leave untouched."""
    path = tmp_path_factory.mktemp("db") / "gaz.db"
    res = invoke(["simulate", "--dim", "2", "--n", "20", "--length", "1e-7", "--duration", "1e-11",
                  "--seed", "1", "--db", str(path)])
    assert res.exit_code == 0, res.output
    return path


def _digest(path: Path) -> str | None:
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else None


def run_case(args, tmp_path: Path, db_source: Path) -> dict:
    """Run one bad command line; returns exit code, stderr lines, stdout, the db before/after."""
    db = tmp_path / "gaz.db"
    shutil.copyfile(db_source, db)
    (tmp_path / "run.h5").write_bytes(b"not an HDF5 file\n")
    scene = 'dim = 2\nlength = 1e-7\nduration = 1e-10\n{}\n[[species]]\nname = "Ar"\ncount = 10\n'
    (tmp_path / "bad.toml").write_text(scene.format("colour = 3"))
    (tmp_path / "range.toml").write_text(scene.format("restitution = 2.0"))
    (tmp_path / "deep.toml").write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    (tmp_path / "fast.toml").write_text(
        'dim = 2\nlength = 1e-7\nduration = 1e-11\nseed = 1\n[[species]]\nname = "Ar"\ncount = 2\n'
        '[initial]\nkind = "explicit"\npositions = [[1e-8, 1e-8], [5e-8, 5e-8]]\n'
        'velocities = [[1e300, 1.0], [1.0, 1.0]]\n')
    (tmp_path / "overlap.toml").write_text(
        'dim = 2\nlength = 1e-7\nduration = 1e-11\nseed = 1\n[[species]]\nname = "Ar"\ncount = 2\n'
        '[initial]\nkind = "explicit"\npositions = [[1e-8, 1e-8], [1e-8, 1.01e-8]]\n'
        'velocities = [[1.0, 1.0], [1.0, 1.0]]\n')
    (tmp_path / "longname.toml").write_text(
        'dim = 2\nlength = 1e-7\nduration = 1e-11\nseed = 1\n[[species]]\nname = "' + "x" * 65 +
        '"\ncount = 5\nmass = 1e-25\nradius = 1e-10\n')
    custom = ('dim = 2\nlength = 1e-7\nduration = 1e-11\nseed = 1\n[[species]]\nname = "{}"\ncount = 5\n'
              'mass = 1e-25\nradius = 1e-10\n')
    for file, name in (("customar", "Ar"), ("comma", "a,b"), ("colon", "a:5")):
        (tmp_path / f"{file}.toml").write_text(custom.format(name))
    (tmp_path / "zz.toml").write_text(scene.format("").replace('"Ar"', '"Zz"'))
    (tmp_path / "gone.pvd").write_text('<VTKFile type="Collection"><Collection>'
                                       '<DataSet timestep="0" file="gone_00000.vtu"/></Collection></VTKFile>\n')
    argv = [a.replace("{tmp}", str(tmp_path)) for a in args]
    if argv[0] == "simulate":
        argv += ["--db", str(db)]
    before, files = _digest(db), set(tmp_path.rglob("*"))
    res = invoke(argv)
    return {"exit": res.exit_code, "stderr": res.stderr, "lines": [ln for ln in res.stderr.splitlines() if ln],
            "stdout": res.stdout, "db_unchanged": _digest(db) == before, "argv": argv,
            "new_files": sorted(str(p) for p in set(tmp_path.rglob("*")) - files)}


@pytest.mark.parametrize("what, args, code, fragment", CASES, ids=[c[0] for c in CASES])
def test_a_hostile_input_is_one_line_and_leaves_the_database(populated_db, tmp_path, what, args, code, fragment):
    out = run_case(args, tmp_path, populated_db)
    assert "Traceback" not in out["stderr"] and "internal error" not in out["stderr"], out["stderr"]
    assert len(out["lines"]) == 1, out["stderr"]
    assert out["exit"] == code, (out["exit"], out["stderr"])
    assert fragment in out["lines"][0], out["lines"][0]
    assert out["stdout"] == ""
    assert out["db_unchanged"]
    assert out["new_files"] == []  # no empty trajectory, no image, no journal left behind


def test_rows_beyond_the_free_space_of_the_database_disk_are_refused(populated_db, tiny_disk):
    """About 80,000 wall bounces (3.7 MB of REBOND rows) into a database on a 1 MiB disk: one line
    naming the estimate and the fixes, the database untouched; with --record none the run goes.
    (It used to run, then end in 'no space left' after the engine's work, or fill the disk.)"""
    db = tiny_disk / "gaz.db"
    shutil.copyfile(populated_db, db)
    before = _digest(db)
    args = ["simulate", "--dim", "2", "--n", "20", "--length", "1e-7", "--duration", "1e-6", "--seed", "2",
            "--db", str(db)]
    res = invoke(args)
    lines = [ln for ln in res.stderr.splitlines() if ln]
    assert res.exit_code == 1 and len(lines) == 1, res.stderr
    assert "would grow by about 3." in lines[0] and "MB" in lines[0] and "free" in lines[0], lines[0]
    assert "--record none" in lines[0] and "--duration" in lines[0] and "--db" in lines[0], lines[0]
    assert _digest(db) == before and sorted(p.name for p in tiny_disk.iterdir()) == ["gaz.db"]
    res = invoke([*args, "--record", "none"])
    assert res.exit_code == 0, res.stderr


def test_the_wal_copy_of_the_rows_counts_in_the_free_space_asked(tmp_path):
    """The rows of a run pass through the database's WAL file before they are copied into it:
    the disk holds them twice. About 80,000 bounces (3.7 MB estimated, 3.9 MB written) into a
    new database on a 6 MiB disk passed the check (3.7 < 6.3 MB), then filled the disk: exit 0,
    gaz.db 2.3 MB, its WAL 3.9 MB left beside it, nothing more could be written there. Now one
    line naming the 7.4 MB needed, nothing created; half the duration runs and leaves the
    database alone (peak 2 x 1.9 MB, inside the 6 MiB by a third: estimate within 10 %)."""
    from conftest import mounted_tmpfs

    with mounted_tmpfs(tmp_path / "disk", "6M") as disk:
        db = disk / "gaz.db"
        args = ["simulate", "--dim", "2", "--n", "20", "--length", "1e-7", "--seed", "2", "--db", str(db)]
        res = invoke([*args, "--duration", "1e-6"])
        lines = [ln for ln in res.stderr.splitlines() if ln]
        assert res.exit_code == 1 and len(lines) == 1, res.output
        assert "would grow by about 3." in lines[0] and "needs about 7." in lines[0], lines[0]
        assert "through its WAL file" in lines[0] and "--record none" in lines[0], lines[0]
        assert list(disk.iterdir()) == []
        res = invoke([*args, "--duration", "5e-7"])
        assert res.exit_code == 0, res.output
        assert sorted(p.name for p in disk.iterdir()) == ["gaz.db"]


def test_a_run_staged_in_a_scratch_file_counts_it_in_the_free_space_asked(tmp_path, monkeypatch):
    """A run of more than staging.MEMORY_ROWS rows stages them in a scratch file beside the
    database until its commit (71 bytes a REBOND row, against 47 in the database): the check
    ignored it. Here ~51,000 bounces on a 6 MiB disk: 2 x 2.4 MB fit in memory; staged (the bound
    lowered to 1000 rows) 2 x 2.4 + 3.6 MB do not, and the line says so."""
    from conftest import mounted_tmpfs
    from gaz_cli.results import staging
    from gaz_cli.model.scene import Scene
    from gaz_cli.results.budgets import check_database_space
    from gaz_cli.model.species import BUILTIN

    scene = Scene(dim=2, length=1e-7, duration=6.5e-7, components=((BUILTIN["Ar"], 20),), seed=2)
    with mounted_tmpfs(tmp_path / "disk", "6M") as disk:
        check_database_space([scene], disk / "gaz.db")
        monkeypatch.setattr(staging, "MEMORY_ROWS", 1000)
        with pytest.raises(SceneError, match=r"would grow by about 2\.\d+ MB .* needs about 8\.\d+ MB free .*"
                                             r"and a scratch file beside it"):
            check_database_space([scene], disk / "gaz.db")


# --- the table of docs/explanation/stability.md -------------------------------------------------------------
BEGIN, END = "<!-- hostile-inputs:begin -->", "<!-- hostile-inputs:end -->"
DOC = Path(__file__).resolve().parent.parent / "docs" / "explanation" / "stability.md"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(rows) -> str:
    lines = [BEGIN, "## Hostile inputs", "",
             "Generated by `GAZ_WRITE_STABILITY=1 python -m pytest tests/test_hostile_inputs.py -k table`: each "
             "bad command line run through `gaz`'s entry point with `--db` on a copy of a database holding one "
             "simulation (paths shortened to `TMP`). Every row: one line on stderr, no traceback, the database "
             "byte-identical (SHA-256). A full disk under a trajectory and Ctrl-C in the step engine need a real "
             "process: `tests/test_trajectory.py::test_a_full_disk_is_one_line_and_exit_1` (a 1 MiB tmpfs: "
             "refused at the door, and with `--force` ENOSPC gives exit 1, was SIGSEGV, exit 139) and "
             "`tests/test_stepper.py::test_ctrl_c_stops_the_step_engine` (exit 130). Two need a file of their "
             "own: rows beyond the free space of the database's disk "
             "(`test_rows_beyond_the_free_space_of_the_database_disk_are_refused`, a 1 MiB tmpfs; the peak "
             "while committing, the rows twice through the WAL file and once more in a scratch file for a long "
             "run: `test_the_wal_copy_of_the_rows_counts_in_the_free_space_asked` and "
             "`test_a_run_staged_in_a_scratch_file_counts_it_in_the_free_space_asked`, a 6 MiB tmpfs) and a SQLite "
             "file of another application (`tests/test_store_cli.py::"
             "test_another_applications_sqlite_file_is_refused_untouched`): one line each, the file untouched.",
             "",
             "| bad input | command | exit | message | database |", "| --- | --- | --- | --- | --- |"]
    for what, out, tmp in rows:
        command = " ".join(["gaz", *(a or "''" for a in out["argv"])]).replace(str(tmp), "TMP")
        message = out["lines"][0].replace(str(tmp), "TMP") if out["lines"] else out["stderr"]
        db = ("unchanged" if out["db_unchanged"] else "CHANGED") if out["argv"][0] == "simulate" else "(not used)"
        lines.append(f"| {_cell(what)} | `{_cell(command)}` | {out['exit']} | {_cell(message)} | {db} |")
    lines.append(END)
    return "\n".join(lines) + "\n"


def write_table(text: str, path: Path = DOC) -> None:
    """Put ``text`` between the markers of ``path`` (created with a heading if absent)."""
    old = path.read_text(encoding="utf-8") if path.exists() else "# Numerical stability and hostile inputs\n\n"
    if BEGIN in old and END in old:
        head, rest = old.split(BEGIN, 1)
        tail = rest.split(END, 1)[1].lstrip("\n")
        new = head + text + tail
    else:
        new = old.rstrip("\n") + "\n\n" + text
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(new, encoding="utf-8")


@pytest.mark.skipif(not os.environ.get("GAZ_WRITE_STABILITY"), reason="set GAZ_WRITE_STABILITY=1 to write the table")
def test_write_the_table(populated_db, tmp_path):
    rows = []
    for k, (what, args, code, fragment) in enumerate(CASES):
        tmp = tmp_path / f"c{k}"
        tmp.mkdir()
        out = run_case(args, tmp, populated_db)
        assert len(out["lines"]) == 1 and out["exit"] == code and out["db_unchanged"], (what, out)
        rows.append((what, out, tmp))
    write_table(table(rows))


def test_write_table_keeps_the_other_sections(tmp_path):
    doc = tmp_path / "stability.md"
    write_table(f"{BEGIN}\nfirst\n{END}\n", doc)
    assert doc.read_text().startswith("# Numerical stability")
    doc.write_text(doc.read_text() + "\n<!-- stress:begin -->\nstress rows\n<!-- stress:end -->\n")
    write_table(f"{BEGIN}\nsecond\n{END}\n", doc)
    text = doc.read_text()
    assert "second" in text and "first" not in text and "stress rows" in text and text.count(BEGIN) == 1
