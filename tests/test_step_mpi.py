"""The step engine over MPI (engines/step/mpi.py and ranks.py, issue 40 item 3): ``mpiexec -n 2
gaz simulate ... --engine step`` writes the same rows, bit for bit, as one process; rank 0
alone writes and prints; an error is one line and a non-zero exit on every rank, no hang.

Runs the ``mpiexec`` next to this Python (the mpich wheel of the ``mpi`` and ``test`` extras
puts it there); skipped without it or without mpi4py.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from cli_helpers import invoke

pytest.importorskip("mpi4py")
BIN = Path(sys.executable).parent
MPIEXEC = shutil.which("mpiexec", path=str(BIN)) or shutil.which("mpiexec")
GAZ = shutil.which("gaz", path=str(BIN))
pytestmark = pytest.mark.skipif(MPIEXEC is None or GAZ is None, reason="no mpiexec (pip install 'gaz[mpi]')")

TIMEOUT_S = 120
"""A hang guard: each run takes a few seconds."""

BASE = ["simulate", "--engine", "step", "--record", "all", "--seed", "3", "--quiet", "--threads", "1"]
ARGON = ["--species", "Ar", "--temperature", "300", "--dt", "2e-14", "--duration", "4e-12"]
SCENES = {
    # box side about 1.2e-8 m in 2D, 1.3e-8 m in 3D; argon at 300 K runs about 400 m/s
    "walls": ARGON + ["--dim", "3", "--n", "400", "--packing", "0.15"],
    "gravity": ARGON + ["--dim", "2", "--n", "300", "--packing", "0.25", "--gravity", "2e13", "--restitution",
                        "0.8", "--tc", "1e-14"],
    "drag": ARGON + ["--dim", "2", "--n", "300", "--packing", "0.25", "--drag", "2e11", "--gravity", "1e13",
                     "--wall-restitution", "0.8", "--restitution", "0.7"],
    # attraction between the atoms (the kinetic energy grows by a fifth): every rank sums it
    "pair": ARGON + ["--dim", "2", "--n", "300", "--packing", "0.25", "--pair-gravity", "1e20", "--softening",
                     "1e-10"],
    # 300 marbles falling on a ramp (a plane), friction, inelastic walls and collisions
    "planes": ["--preset", "marbles", "--duration", "0.5", "--print-every", "0"],
}
TIMED = {"simulation": ("si_deb",), "resultat": ("rs_wall_time",)}
"""Columns that hold the clock (start date, run time), not the run's numbers."""


def rows(db: Path) -> dict:
    """Every table's rows, the clock's columns left out."""
    con = sqlite3.connect(db)
    try:
        out = {}
        for (table,) in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'"):
            cur = con.execute(f"SELECT * FROM {table}")  # noqa: S608 - the file's own table names
            cols = [d[0] for d in cur.description]
            keep = [k for k, c in enumerate(cols) if c not in TIMED.get(table, ())]
            out[table] = sorted(tuple(r[k] for k in keep) for r in cur.fetchall())
        return out
    finally:
        con.close()


def mpirun(np_: int, args: list, cwd: Path, timeout: float = TIMEOUT_S) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}
    env.pop("GAZ_MPI", None)
    return subprocess.run([MPIEXEC, "-n", str(np_), GAZ, *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)


def one_process(args: list, cwd: Path):
    old = os.getcwd()
    os.chdir(cwd)
    try:
        return invoke(args)
    finally:
        os.chdir(old)


@pytest.mark.filterwarnings("ignore::gaz_cli.errors.GazWarning")
@pytest.mark.parametrize("name", sorted(SCENES))
def test_two_processes_write_the_rows_of_one(name, tmp_path):
    """Every row of every table (bounces, collisions, particles, the summary), and the final
    state, the same bit for bit on 2 processes as on one."""
    one, two = tmp_path / "one", tmp_path / "two"
    one.mkdir()
    two.mkdir()
    args = BASE + SCENES[name] + ["--db", "run.db", "--save-state", "end.csv"]
    res = one_process(args, one)
    assert res.exit_code == 0, res.stderr
    proc = mpirun(2, args, two)
    assert proc.returncode == 0, proc.stderr
    a, b = rows(one / "run.db"), rows(two / "run.db")
    assert len(a["rebond"]) > 20 and len(a["choc"]) > 50, {k: len(v) for k, v in a.items()}
    for table in a:
        assert a[table] == b[table], table
    assert proc.stderr == ""
    assert (one / "end.csv").read_bytes() == (two / "end.csv").read_bytes()
    assert sorted(p.name for p in two.iterdir()) == ["end.csv", "run.db"]


def test_three_processes_on_two_cores_split_unevenly_and_agree(tmp_path):
    """3 processes (patches 3 x 1 in 3D: a slab each, the oversubscribed cores waiting in
    turn): the same rows and final state as one process."""
    one, three = tmp_path / "one", tmp_path / "three"
    one.mkdir()
    three.mkdir()
    args = BASE + SCENES["walls"] + ["--db", "run.db", "--save-state", "end.csv"]
    assert one_process(args, one).exit_code == 0
    proc = mpirun(3, args, three)
    assert proc.returncode == 0, proc.stderr
    assert rows(one / "run.db") == rows(three / "run.db")
    assert (one / "end.csv").read_bytes() == (three / "end.csv").read_bytes()


def test_rank_0_alone_prints_and_writes_the_trajectory_and_diagnostics(tmp_path):
    """Diagnostics, summary and trajectory once (rank 0's), the same as one process's;
    ``mpiexec -n 1`` is one process."""
    args = BASE + SCENES["gravity"] + ["--no-db", "--json", "--print-every", "50", "--trajectory", "t.h5md",
                                      "--every", "1e-12"]
    outs = {}
    for n in (1, 2):
        cwd = tmp_path / str(n)
        cwd.mkdir()
        proc = mpirun(n, args, cwd)
        assert proc.returncode == 0, proc.stderr
        assert sorted(p.name for p in cwd.iterdir()) == ["t.h5md"]
        lines = proc.stderr.splitlines()
        assert len(lines) == 200 // 50 + 1 and all(x.startswith("time=") for x in lines), lines
        assert len(proc.stdout.splitlines()) == 1  # one JSON summary
        outs[n] = (lines, (cwd / "t.h5md").stat().st_size)
    assert outs[1][0] == outs[2][0]


def test_an_error_is_one_line_and_ends_every_rank(tmp_path):
    """A bad option under mpiexec: rank 0's one line, a non-zero exit, the other rank not left
    waiting (the timeout would fail the test)."""
    proc = mpirun(2, BASE + SCENES["walls"] + ["--no-db", "--wall-restitution", "1.5"], tmp_path, timeout=60)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "wall" in lines[0] and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_without_mpi4py_one_line_names_the_extra(tmp_path):
    """Started by mpiexec where mpi4py is missing: one line naming the extra, exit 1 everywhere."""
    (tmp_path / "mpi4py.py").write_text("raise ImportError('no mpi4py here')\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    proc = subprocess.run([MPIEXEC, "-n", "2", GAZ, *BASE, *SCENES["walls"], "--no-db"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "pip install 'gaz[mpi]'" in lines[0], proc.stderr


def test_an_mpi_launch_is_known_by_its_environment():
    from gaz_cli.engines.step.mpi import launched

    assert launched({"PMI_SIZE": "2", "PMI_RANK": "1"})
    assert launched({"OMPI_COMM_WORLD_SIZE": "4"})
    assert not launched({"PMI_SIZE": "1"})  # mpiexec -n 1: one ordinary process
    assert not launched({})
    assert launched({"GAZ_MPI": "1"}) and not launched({"GAZ_MPI": "0", "PMI_SIZE": "2"})


def test_ctrl_c_ends_every_rank_inside_a_run(tmp_path):
    """SIGINT to mpiexec (a Ctrl-C) in the middle of a run: rank 0's line, every rank ends
    (mpiexec returns only when all have), nothing written."""
    import signal

    from cli_helpers import wait_for_diagnostics

    args = [*BASE, "--dim", "2", "--n", "2000", "--packing", "0.2", "--species", "Ar", "--dt", "2e-14",
            "--duration", "1e-8", "--print-every", "20", "--db", "run.db"]
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}
    proc = subprocess.Popen([MPIEXEC, "-n", "2", GAZ, *args], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        wait_for_diagnostics(proc, 2)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode != 0
    assert "gaz: interrupted by SIGINT" in err, err
    assert "Traceback" not in err
    assert not (tmp_path / "run.db").exists()
