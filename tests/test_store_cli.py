"""The store under real use, through ``gaz`` itself: many writers on one SQLite file,
readers while they write, SIGKILL / SIGINT / SIGTERM, foreign databases, failures before
the commit, and the round trip on PostgreSQL."""

import json
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time

import numpy as np
import pandas as pd
import pytest
import sqlalchemy as sa

from backends import BACKENDS, backend, postgres_db, postgres_url  # noqa: F401 - fixtures
from cli_helpers import invoke, wait_for_diagnostics
from gaz_cli.results import sqlite as sqlite_writer
from gaz_cli.results import staging
from gaz_cli.results import store as st

# a run of the exam's own engine (no JIT to wait for), a few ms long
QUICK = ["simulate", "--engine", "reference", "--dim", "2", "--n", "20", "--length", "1e-7",
         "--duration", "2e-10"]


def gaz(*args):
    """``gaz ARGS`` in a process of its own (its real signal handling and exit code)."""
    return subprocess.Popen([sys.executable, "-m", "gaz_cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def leftovers(folder, keep):
    """Files in ``folder`` other than ``keep``: journals, WAL files, scratch files."""
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


def check_consistent(path):
    """PRAGMA integrity_check and foreign_key_check clean; every stored run complete."""
    con = sqlite3.connect(path)
    try:
        assert con.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
        assert con.execute("PRAGMA foreign_key_check").fetchall() == []
        counts = con.execute("SELECT S.SI_NUM, R.RS_BOUNCES, (SELECT COUNT(*) FROM REBOND B "
                             "WHERE B.SI_NUM = S.SI_NUM) FROM SIMULATION S "
                             "LEFT JOIN RESULTAT R ON R.SI_NUM = S.SI_NUM").fetchall()
    finally:
        con.close()
    for si, expected, found in counts:
        assert expected == found, f"simulation {si}: {found} REBOND rows, RESULTAT says {expected}"
    return [c[0] for c in counts]


def test_eight_writers_one_file_and_a_reader(tmp_path):
    """8 ``gaz simulate`` at once into one SQLite file all succeed with distinct SI_NUM and
    all their rows; ``gaz analyse`` reads the file while they write."""
    db = tmp_path / "gaz.db"
    assert invoke([*QUICK, "--seed", "100", "--db", str(db)]).exit_code == 0
    # runs of ~18 000 bounces each: the commits (moving rows in) take long enough to collide
    runs = ["simulate", "--dim", "3", "--n", "1000", "--length", "3.4e-8", "--duration", "1e-9"]
    procs = [gaz(*runs, "--seed", str(seed), "--db", str(db), "--json") for seed in range(8)]
    reads = []
    while any(p.poll() is None for p in procs) or not reads:
        res = invoke(["analyse", "--db", str(db), "--format", "json"])
        assert res.exit_code == 0, res.stderr
        reads.append(len(json.loads(res.stdout)))
        time.sleep(0.2)
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0] * 8, [err for _, err in outs]
    summaries = [json.loads(out) for out, _ in outs]
    assert sorted(s["si_num"] for s in summaries) == list(range(2, 10))
    con = sqlite3.connect(db)
    for s in summaries:
        (rows,) = con.execute("SELECT COUNT(*) FROM REBOND WHERE SI_NUM = ?", (s["si_num"],)).fetchone()
        (seed,) = con.execute("SELECT SC_SEED FROM SCENE WHERE SI_NUM = ?", (s["si_num"],)).fetchone()
        assert rows == s["wall_bounces"] > 0 and seed == s["seed"]
    con.close()
    assert check_consistent(db) == list(range(1, 10))


CHILD = textwrap.dedent("""
    import sys
    import numpy as np
    from gaz_cli.results import store as st
    from gaz_cli.model.recording import RunStats
    from gaz_cli.model.scene import Scene
    from gaz_cli.placement.initial import initial_state
    from gaz_cli.model.species import lookup

    from gaz_cli.results import staging
    staging.MEMORY_ROWS = 100_000  # this run's 400 000 rows spill to a scratch file
    import time
    move_in = staging.move_in
    moves = []
    def announced(conn, stage, table, *args, **kw):
        if table == "rebond":
            moves.append(1)
            if len(moves) == 2:  # the second run's INSERT slowed down (1 ms every 10^4 SQLite
                # instructions, ~4 s in all), so that the parent's kill lands inside it
                conn.set_progress_handler(lambda: time.sleep(0.001), 10_000)
            print("moving", flush=True)
        return move_in(conn, stage, table, *args, **kw)
    staging.move_in = announced

    scene = Scene(dim=3, length=3.4e-8, duration=1e-8, components=((lookup("Ar"), 100),), seed=1)
    rng = np.random.default_rng(1)
    k = 400_000
    store = st.Store(sys.argv[1])
    while True:
        with store.simulation(scene) as w:
            for part in np.array_split(np.arange(k), 8):
                m = len(part)
                w.add_bounces(np.sort(rng.random(m)), rng.integers(0, 100, m),
                              rng.integers(1, 4, m), rng.random(m) + 1, rng.random(m))
            w.finish(RunStats(k, k, 0, 1.0, initial_state(scene)), 1.0, 1.0)
""")


def test_sigkill_mid_insert_leaves_the_file_consistent(tmp_path):
    """A writer killed (SIGKILL) while moving its rows in leaves a consistent file: integrity
    and foreign keys clean, the runs committed before it whole, its own absent."""
    db = tmp_path / "gaz.db"
    st.Store(str(db)).close()  # an existing file: a new one's first run goes in without a move (0295d95)
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(db)], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline() == "moving\n"  # first run: let it commit
        assert child.stdout.readline() == "moving\n"  # second run: kill it inside its INSERT
        time.sleep(0.2)
        assert child.poll() is None
        child.send_signal(signal.SIGKILL)
    finally:
        child.kill()
        child.wait(timeout=60)
    assert check_consistent(db) == [1]
    stale = [p for p in tmp_path.iterdir() if p.name.endswith(staging.SUFFIX)]
    assert len(stale) == 1  # its scratch file; the next writer removes it
    store = st.Store(str(db))
    assert store.simulation_numbers() == [1]
    store.close()
    st.Store(str(db)).close()
    sim = subprocess.run([sys.executable, "-m", "gaz_cli", *QUICK, "--seed", "1", "--db", str(db)],
                         capture_output=True, text=True, timeout=120)
    assert sim.returncode == 0, sim.stderr
    assert check_consistent(db) == [1, 2]
    assert leftovers(tmp_path, {"gaz.db"}) == []


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupt_rolls_back_and_says_what_is_left(tmp_path, signum):
    """SIGINT and SIGTERM during a run: exit 128 + signal, one line saying that nothing
    went to the database nor to the trajectory; no journal, WAL, scratch file or half-written
    trajectory left."""
    pytest.importorskip("h5py")
    db, traj = tmp_path / "gaz.db", tmp_path / "run.h5"
    assert invoke([*QUICK, "--seed", "1", "--db", str(db)]).exit_code == 0
    # the time-stepped engine: its diagnostics on stderr say the run is under way
    proc = gaz("simulate", "--engine", "step", "--dt", "1e-12", "--print-every", "200", "--dim", "2",
               "--n", "100", "--length", "1e-7", "--duration", "1e-6", "--seed", "2", "--db", str(db),
               "--trajectory", str(traj), "--every", "1e-9")
    try:
        wait_for_diagnostics(proc)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 128 + signum, err
    # one line (the step engine's diagnostics and warnings aside); no empty line before it,
    # which click wrote for a terminal's ^C, also into a pipe and after a SIGTERM
    lines = [line for line in err.splitlines() if not line.startswith(("time=", "gaz: warning:"))]
    assert len(lines) == 1, err
    name = signal.Signals(signum).name
    assert lines[0] == (f"gaz: interrupted by {name}; nothing was written to '{db}'; "
                        f"no trajectory was written to '{traj}'")
    # the trajectory went to a temporary name, removed: nothing half-written is left (issue 39)
    assert not traj.exists()
    assert leftovers(tmp_path, {"gaz.db"}) == []
    assert check_consistent(db) == [1]


def test_foreign_database_is_refused_untouched(tmp_path):
    db = tmp_path / "theirs.db"
    con = sqlite3.connect(db)
    con.execute("CREATE TABLE REBOND (ID INTEGER PRIMARY KEY, WHEN_ TEXT)")
    con.execute("CREATE TABLE PARTICULE (PA_NUM INTEGER PRIMARY KEY, PA_NOM TEXT)")
    con.execute("INSERT INTO PARTICULE VALUES (1, 'theirs')")
    con.commit()
    con.close()
    before = db.read_bytes()
    res = invoke([*QUICK, "--seed", "1", "--db", str(db)])
    assert res.exit_code == 1 and res.stdout == ""
    assert res.stderr.count("\n") == 1 and "is not a gaz database: its table PARTICULE has columns" in res.stderr
    assert db.read_bytes() == before
    assert leftovers(tmp_path, {"theirs.db"}) == []


def test_a_refused_placement_creates_no_database(tmp_path):
    """A placement that gives up (100 disks of radius 0.05 m in a 1.2 m box by rejection, packing
    0.55) exited 1 with 'random placement stuck...' but left --db new.db behind, an empty gaz
    database: the store was opened, and created, before placing. Now nothing is created, and an
    existing database is left byte for byte."""
    args = ["simulate", "--dim", "2", "--n", "100", "--radius", "0.05", "--mass", "1", "--length", "1.2",
            "--duration", "1e-3", "--seed", "1", "--method", "rejection"]
    res = invoke([*args, "--db", str(tmp_path / "new.db")])
    assert res.exit_code == 1 and res.stdout == "", res.output
    assert res.stderr.count("\n") == 1 and "random placement stuck" in res.stderr, res.stderr
    assert leftovers(tmp_path, set()) == []
    db = tmp_path / "gaz.db"
    assert invoke([*QUICK, "--seed", "1", "--db", str(db)]).exit_code == 0
    before = db.read_bytes()
    res = invoke([*args, "--db", str(db)])
    assert res.exit_code == 1 and "random placement stuck" in res.stderr, res.stderr
    assert db.read_bytes() == before and leftovers(tmp_path, {"gaz.db"}) == []


@pytest.mark.parametrize("key, option", [("save_state", "--save-state"), ("trajectory", "--trajectory")])
def test_an_output_that_is_a_folder_is_refused_before_the_database(tmp_path, key, option):
    """A scene file's [output] save_state (or trajectory) naming a folder: the run created its
    database, ran (save_state: the whole simulation), then failed, 'cannot write --save-state
    'out.h5': Is a directory', exit 1, with gaz.db left behind; gaz.simulate(..., save_state=)
    the same. (The command line's flags refuse a folder themselves.) Now one line before the
    database: nothing created."""
    import gaz_cli as gaz

    (tmp_path / "out.h5").mkdir()
    scene = tmp_path / "s.toml"
    every = "every = 1e-12\n" if key == "trajectory" else ""
    scene.write_text('dim = 2\nlength = 1e-7\nduration = 1e-11\nseed = 1\n[[species]]\nname = "Ar"\n'
                     f'count = 5\n[output]\ndb = "{tmp_path / "gaz.db"}"\n{key} = "{tmp_path / "out.h5"}"\n{every}')
    res = invoke(["simulate", str(scene)])
    assert res.exit_code == 1 and res.stdout == "" and res.stderr.count("\n") == 1, res.output
    assert f"{option} '{tmp_path / 'out.h5'}' is a folder, not a file; give a file path" in res.stderr, res.stderr
    assert leftovers(tmp_path, {"out.h5", "s.toml"}) == []
    extra = {"every": 1e-12} if key == "trajectory" else {}
    with pytest.raises(gaz.SceneError, match="is a folder, not a file"):
        gaz.simulate(gaz.load_scene(scene), db=str(tmp_path / "gaz.db"), **{key: str(tmp_path / "out.h5")}, **extra)
    assert leftovers(tmp_path, {"out.h5", "s.toml"}) == []


@pytest.mark.parametrize("db, trajectory", [("run.pvd", "run.vtu"), ("run_00001.vtu", "run.pvd"),
                                             ("run_00001.vtu", "run.vtu")])
def test_a_vtk_trajectory_whose_files_would_overwrite_the_database_is_refused(tmp_path, db, trajectory):
    """--db run.pvd --trajectory run.vtu: the run's collection run.pvd was written over the
    database, exit 1 ('database disk image is malformed'), the database lost; --db run_00001.vtu
    was lost to a snapshot the same way. Only the paths themselves were compared. Now one line
    naming the files a VTK trajectory writes; the database byte for byte."""
    db = tmp_path / db
    assert invoke([*QUICK, "--seed", "1", "--db", str(db)]).exit_code == 0
    before = db.read_bytes()
    res = invoke(["simulate", "--dim", "2", "--n", "5", "--length", "1e-7", "--duration", "1e-11", "--seed", "1",
                  "--db", str(db), "--trajectory", str(tmp_path / trajectory), "--every", "5e-12"])
    assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.output
    assert (f"--trajectory '{tmp_path / trajectory}' is also --db '{db}' (a VTK trajectory writes STEM.pvd and "
            "STEM_00000.vtu, STEM_00001.vtu... beside it): writing it would destroy the database") in res.stderr
    assert db.read_bytes() == before and leftovers(tmp_path, {db.name}) == []
    res = invoke(["simulate", "--dim", "2", "--n", "5", "--length", "1e-7", "--duration", "1e-11", "--seed", "1",
                  "--db", str(db), "--trajectory", str(tmp_path / "other.pvd"), "--every", "5e-12"])
    assert res.exit_code == 0, res.output  # another stem: no clash


@pytest.mark.parametrize("url", [False, True])
def test_another_applications_sqlite_file_is_refused_untouched(tmp_path, url):
    """A SQLite file holding other tables and none of gaz's got gaz's nine tables added beside
    them, exit 0 (--db path and sqlite:/// URL alike); now one line naming the file and the fix,
    the file byte for byte as it was, for simulate, sweep and analyse. An empty file (0 bytes)
    and a gaz database stay accepted."""
    db = tmp_path / "theirs.db"
    con = sqlite3.connect(db)
    con.execute("CREATE TABLE users (id INTEGER PRIMARY KEY, name TEXT)")
    con.execute("INSERT INTO users VALUES (1, 'bob')")
    con.commit()
    con.close()
    before = db.read_bytes()
    given = f"sqlite:///{db}" if url else str(db)
    (tmp_path / "s.toml").write_text('dim = 2\nlength = 1e-7\nduration = 1e-11\n[[species]]\nname = "Ar"\n'
                                     'count = 10\n')
    for args in ([*QUICK, "--seed", "1"], ["sweep", str(tmp_path / "s.toml"), "--vary", "temperature=100,200",
                                          "--quiet"], ["analyse"]):
        res = invoke([*args, "--db", given])
        assert res.exit_code == 1 and res.stdout == "", res.output
        assert res.stderr.count("\n") == 1, res.stderr
        assert f"{given!r} is not a gaz database: it holds other tables (users) and none of gaz's" in res.stderr
        assert "give --db a new file or a gaz database" in res.stderr
        assert db.read_bytes() == before
        assert leftovers(tmp_path, {"theirs.db", "s.toml"}) == []
    empty = tmp_path / "empty.db"
    empty.touch()
    for _ in range(2):  # a 0-byte file becomes a gaz database, then takes a second run
        res = invoke([*QUICK, "--seed", "1", "--db", f"sqlite:///{empty}" if url else str(empty)])
        assert res.exit_code == 0, res.stderr


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (a disk always full)")
def test_a_failing_state_file_commits_nothing(tmp_path):
    """--save-state that cannot be written fails the run before its commit (it used to
    exit 1 with the simulation committed)."""
    db = tmp_path / "gaz.db"
    res = invoke([*QUICK, "--seed", "1", "--db", str(db), "--save-state", "/dev/full"])  # ENOSPC
    assert res.exit_code == 1
    assert res.stderr == "gaz: error: cannot write --save-state '/dev/full': No space left on device\n"
    assert not db.exists()  # a new database: not created for a run that failed
    assert os.path.exists("/dev/full")  # only regular files of the failed run are removed


def test_a_failing_summary_commits_nothing(tmp_path, monkeypatch):
    """The summary comes before the commit: when it fails, nothing is committed (it used to
    exit 1 with the simulation committed). It failed for one particle in a periodic box, which
    now runs; a pressure that cannot be computed stands in for it."""
    from gaz_cli.run import runner
    from gaz_cli.errors import SceneError

    def fails(*args, **kwargs):
        raise SceneError("no pressure")

    monkeypatch.setattr(runner, "run_pressure", fails)
    db = tmp_path / "gaz.db"
    res = invoke(["simulate", "--dim", "2", "--n", "1", "--length", "1e-7", "--duration", "1e-11",
                  "--boundary", "periodic", "--seed", "1", "--db", str(db)])
    assert res.exit_code == 1 and res.stderr == "gaz: error: no pressure\n"
    assert not db.exists()  # a new database: not created for a run that failed


def test_full_disk_at_the_commit_removes_the_state_file(tmp_path, monkeypatch):
    """A commit that fails (here: the disk full while moving the rows in) leaves no
    simulation and no state file of the failed run; one line, exit 1."""
    def full(*args, **kwargs):
        raise sqlite3.OperationalError("database or disk is full")

    db, state = tmp_path / "gaz.db", tmp_path / "final.csv"
    monkeypatch.setattr(staging, "insert_rows", full)  # both SQLite writers insert through it, early or not
    res = invoke([*QUICK, "--seed", "1", "--db", str(db), "--save-state", str(state)])
    assert res.exit_code == 1, res.output
    assert res.stderr == f"gaz: error: no space left for database '{db}' (database or disk is full); " \
                         "free some space or choose another --db\n"
    assert not state.exists()
    assert not db.exists()  # a new database: not created for a run that failed
    assert leftovers(tmp_path, {"gaz.db"}) == []


def test_locked_database_is_one_line_before_the_run(tmp_path, monkeypatch):
    db = tmp_path / "gaz.db"
    assert invoke([*QUICK, "--seed", "1", "--db", str(db)]).exit_code == 0
    monkeypatch.setattr(sqlite_writer, "BUSY_TIMEOUT_S", 0.2)  # the one figure both SQLite writers use
    holder = sqlite3.connect(db, isolation_level=None)
    holder.execute("BEGIN IMMEDIATE")  # another writer in the middle of its commit
    traj = tmp_path / "run.h5"
    try:
        res = invoke(["simulate", "--dim", "2", "--n", "20", "--length", "1e-7", "--duration", "2e-10",
                      "--seed", "2", "--db", str(db), "--trajectory", str(traj), "--every", "1e-11"])
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    assert res.exit_code == 1
    assert not traj.exists()  # refused before the run began
    assert res.stderr == f"gaz: error: database '{db}' is locked by another process (waited 0.2 s); " \
                         "try again when it has finished\n"
    assert check_consistent(db) == [1]


@pytest.mark.postgres
def test_round_trip_on_postgres_same_rows_as_sqlite(tmp_path, postgres_db):
    """simulate / analyse / query on PostgreSQL; the same seed gives the same REBOND rows
    in PostgreSQL as in SQLite, bit for bit; a custom species on a fresh database works."""
    sqlite_db = str(tmp_path / "gaz.db")
    for db in (sqlite_db, postgres_db):
        res = invoke(["simulate", "--dim", "2", "--n", "30", "--length", "1e-7", "--duration", "1e-10",
                      "--seed", "7", "--db", db, "--json"])
        assert res.exit_code == 0, res.stderr
        assert json.loads(res.stdout)["si_num"] == 1
    frames = []
    for db in (sqlite_db, postgres_db):
        engine = sa.create_engine(st.url_for(db))
        with engine.connect() as conn:
            frames.append(pd.read_sql("SELECT * FROM rebond ORDER BY re_num", conn))
        engine.dispose()
    assert len(frames[0]) > 0
    pd.testing.assert_frame_equal(frames[0], frames[1], check_exact=True)
    res = invoke(["simulate", "--dim", "2", "--n", "10", "--radius", "1e-10", "--mass", "1e-26",
                  "--length", "1e-7", "--duration", "1e-10", "--seed", "1", "--db", postgres_db, "--json"])
    assert res.exit_code == 0, res.stderr
    assert invoke(["analyse", "--db", postgres_db, "--sim", "1"]).exit_code == 0
    res = invoke(["query", "q36", "--param", "si_num=1", "--db", postgres_db, "--format", "csv"])
    assert res.exit_code == 0 and len(pd.read_csv(pd.io.common.StringIO(res.stdout))) == 4
    assert np.isfinite(pd.read_csv(pd.io.common.StringIO(res.stdout)).QUANTITE_MOUVEMENT).all()
    assert os.environ.get("GAZ_TEST_POSTGRES_URL")


def test_a_url_scheme_in_capitals_is_the_same_url(tmp_path):
    """URL schemes are case-insensitive (RFC 3986): --db SQLITE:///x.db was refused, "gaz writes
    to SQLite files and PostgreSQL servers, not SQLITE"; it writes x.db as sqlite:/// does."""
    db = tmp_path / "x.db"
    res = invoke([*QUICK, "--seed", "1", "--db", f"SQLite:///{db}"])
    assert res.exit_code == 0, res.stderr
    assert check_consistent(db) == [1]


@pytest.mark.postgres
def test_a_postgresql_scheme_in_capitals_is_the_same_url(postgres_db):
    """POSTGRESQL:// is postgresql:// (the URL the test server gives, scheme in capitals)."""
    scheme, rest = postgres_db.split("://", 1)
    res = invoke([*QUICK, "--seed", "1", "--db", "POSTGRESQL+PSYCOPG://" + rest, "--json"])
    assert res.exit_code == 0, res.stderr
    assert json.loads(res.stdout)["si_num"] == 1


@pytest.mark.postgres
def test_a_run_past_32_bit_row_numbers_is_refused_before_its_engine(postgres_db):
    """A PostgreSQL database made before schema 6 numbers its REBOND rows in a 32-bit integer:
    the README example run for 2e-4 s, about 3.6e9 wall bounces, ran to the end and failed at
    row 2^31. It is refused at its start, one line naming the fixes (the ALTER TABLE that
    widens the column among them), nothing written. (A new database numbers them in 64 bits:
    test_store_partitions.py.)"""
    import sqlalchemy as sa

    assert invoke([*QUICK, "--seed", "1", "--db", postgres_db]).exit_code == 0
    engine = sa.create_engine(postgres_db)
    try:
        with engine.begin() as conn:  # as made by gaz before schema 6
            conn.exec_driver_sql("ALTER TABLE rebond ALTER COLUMN re_num TYPE integer")
        run = ["simulate", "--dim", "3", "--n", "1000", "--length", "3.4e-8", "--duration", "2e-4",
               "--seed", "1", "--db", postgres_db]
        res = invoke(run)
        assert res.exit_code == 1 and len(res.stderr.strip().splitlines()) == 1, res.stderr
        for words in ("numbers its REBOND rows with a 32-bit integer", "2,147,483,647", "3.56e+09 wall bounces",
                      "--record none", "ALTER TABLE rebond ALTER COLUMN re_num TYPE bigint"):
            assert words in res.stderr, res.stderr
        with engine.connect() as conn:
            assert conn.exec_driver_sql("SELECT si_num FROM simulation").scalars().all() == [1]
    finally:
        engine.dispose()


@pytest.fixture
def read_only_folder(tmp_path):
    """A small tmpfs under tmp_path, remounted read-only once ``fill(folder)`` has written it
    (root only; skipped where mounting is not permitted)."""
    from conftest import mounted_tmpfs

    with mounted_tmpfs(tmp_path / "ro", "4M") as folder:
        def seal():
            subprocess.run(["mount", "-o", "remount,ro", str(folder)], check=True, capture_output=True)

        yield folder, seal


def test_a_database_in_a_read_only_folder_is_read(tmp_path, read_only_folder):
    """gaz analyse, query and scene on a database on a read-only medium (a share, a volume
    mounted :ro) ended in "cannot open database ... (unable to open database file); check that
    its folder exists and is writable": SQLite cannot create the -shm it reads a WAL file
    with. Readers now open it immutable there; a writer is still refused in one line."""
    folder, seal = read_only_folder
    db = folder / "gaz.db"
    assert invoke([*QUICK, "--seed", "1", "--db", str(db)]).exit_code == 0
    expected = {args[0]: invoke([*args, "--db", str(db)]).stdout
                for args in (["analyse"], ["query", "q35"], ["scene", "1"])}
    assert sorted(p.name for p in folder.iterdir()) == ["gaz.db"]
    seal()
    for command, out in expected.items():
        args = {"analyse": ["analyse"], "query": ["query", "q35"], "scene": ["scene", "1"]}[command]
        res = invoke([*args, "--db", str(db)])
        assert (res.exit_code, res.stderr) == (0, ""), (command, res.stderr)
        assert res.stdout == out, command
    res = invoke([*QUICK, "--seed", "2", "--db", str(db)])
    assert res.exit_code == 1 and len(res.stderr.splitlines()) == 1 and "writable" in res.stderr
