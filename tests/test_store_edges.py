"""The store's edges: what a run that is refused, fails or is interrupted leaves on disk (nothing),
and names SQLite would read otherwise than as written."""

import sqlite3

import pytest

from backends import postgres_db, postgres_url  # noqa: F401 - fixtures

from cli_helpers import invoke, wait_for_diagnostics

# a run of the exam's own engine (no JIT to wait for), a few ms long
QUICK = ["simulate", "--engine", "reference", "--dim", "2", "--n", "20", "--length", "1e-7",
         "--duration", "2e-10", "--seed", "1"]


def simulations(path):
    con = sqlite3.connect(path)
    try:
        return [r[0] for r in con.execute("SELECT si_num FROM simulation ORDER BY si_num")]
    finally:
        con.close()


def test_a_file_uri_as_db_is_refused_and_a_dotted_path_is_that_file(tmp_path, monkeypatch):
    """SQLite reads a name starting with 'file:' as a URI: --db file:x.db wrote x.db, while
    gaz analyse --db file:x.db looked for a file named 'file:x.db' ("does not exist"). Both
    commands refuse it in one line naming the two fixes, creating nothing; ./file:x.db is the file
    of that name, written and read; sqlite:///file:x.db (no ?uri=true) is refused alike."""
    monkeypatch.chdir(tmp_path)
    for command in (QUICK, ["analyse"], ["query", "q34"]):
        for db in ("file:x.db", "sqlite:///file:x.db"):
            res = invoke([*command, "--db", db])
            assert res.exit_code == 1 and res.stdout == "", res.output
            assert res.stderr.count("\n") == 1, res.stderr
            assert "reads a name starting with 'file:' as a URI" in res.stderr and "'x.db'" in res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    res = invoke([*QUICK, "--db", "./file:x.db"])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file:x.db"]
    assert simulations(tmp_path / "file:x.db") == [1]
    res = invoke(["analyse", "--db", "./file:x.db", "--format", "json"])
    assert res.exit_code == 0, res.output


def _interrupted_run(monkeypatch, db):
    """``gaz simulate QUICK --db db`` interrupted by a SIGINT taking effect after the engine,
    before the commit: its result."""
    from gaz_cli.run import runner
    from gaz_cli.errors import Interrupted

    def interrupted(*args, **kwargs):
        raise Interrupted(2)

    with monkeypatch.context() as patch:
        patch.setattr(runner, "run_pressure", interrupted)
        return invoke([*QUICK, "--db", db])


def test_a_run_that_fails_or_is_interrupted_leaves_no_new_database(tmp_path, monkeypatch):
    """A run into a new --db that failed before its commit (--save-state on a full disk), or was
    interrupted, left the file behind: an empty gaz database of 45 kB. Now the folder is as it
    was; the next run creates the file, with simulation 1."""
    db = tmp_path / "new.db"
    res = invoke([*QUICK, "--db", str(db), "--save-state", "/dev/full"])  # ENOSPC
    assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.output
    assert list(tmp_path.iterdir()) == []
    res = _interrupted_run(monkeypatch, str(db))
    assert res.exit_code == 130, res.output
    assert f"nothing was written to '{db}'" in res.stderr, res.stderr
    assert list(tmp_path.iterdir()) == []
    assert invoke([*QUICK, "--db", str(db)]).exit_code == 0
    assert simulations(db) == [1] and [p.name for p in tmp_path.iterdir()] == ["new.db"]


def test_two_runs_into_one_new_file_both_land(tmp_path):
    """Two writers open one new file; the second to commit finds it made by the first (its own
    private file cannot take the name) and commits into it: SI_NUM 1 and 2, no file left over."""
    from gaz_cli.results import sqlite as sqlite_writer
    from gaz_cli.model.recording import RunStats
    from gaz_cli.model.scene import Scene
    from gaz_cli.placement.initial import initial_state
    from gaz_cli.model.species import BUILTIN

    db = tmp_path / "new.db"
    scene = Scene(dim=2, length=1e-7, duration=2e-10, components=((BUILTIN["Ar"], 20),), seed=1)
    state = initial_state(scene)
    first, second = sqlite_writer.SqliteFile(str(db)), sqlite_writer.SqliteFile(str(db))
    assert not db.exists()  # nothing under the real name before a commit
    stored = []
    for file in (first, second):
        with file, file.simulation(scene) as run:
            run.add_bounces([1e-11, 2e-11], [0, 1], [1, -2], [300.0, 310.0], [200.0, 100.0])
            run.finish(RunStats(2, 2, 0, 0.01, state), 1.0, 1.0)
        stored.append(run.si_num)
    assert stored == [1, 2] and simulations(db) == [1, 2]
    con = sqlite3.connect(db)
    assert con.execute("SELECT si_num, COUNT(*) FROM rebond GROUP BY si_num").fetchall() == [(1, 2), (2, 2)]
    con.close()
    assert [p.name for p in tmp_path.iterdir()] == ["new.db"]


def test_two_processes_started_together_into_one_new_file_both_land(tmp_path):
    """gaz simulate --db new.db twice at once: both exit 0, with distinct simulation numbers."""
    import json
    import subprocess
    import sys

    db = tmp_path / "new.db"
    procs = [subprocess.Popen([sys.executable, "-m", "gaz_cli", *QUICK[:-1], str(seed), "--db", str(db),
                               "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for seed in (1, 2)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    assert sorted(json.loads(out)["si_num"] for out, _ in outs) == [1, 2]
    assert simulations(db) == [1, 2] and [p.name for p in tmp_path.iterdir()] == ["new.db"]


def test_a_failing_run_into_a_new_sqlite_url_leaves_no_file(tmp_path):
    """--db sqlite:///PATH went through SQLAlchemy's store, which created the file on opening: a
    run failing before its commit left it behind, empty. A URL without options is now written as
    the file path is (its name taken at the first commit); the next run is simulation 1."""
    db = tmp_path / "new.db"
    res = invoke([*QUICK, "--db", f"sqlite:///{db}", "--save-state", "/dev/full"])  # ENOSPC
    assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.output
    assert list(tmp_path.iterdir()) == []
    assert invoke([*QUICK, "--db", f"sqlite:///{db}"]).exit_code == 0
    assert simulations(db) == [1] and [p.name for p in tmp_path.iterdir()] == ["new.db"]


def test_a_new_file_that_cannot_be_completed_stores_nothing_and_says_so(tmp_path, monkeypatch):
    """The new file's WAL not emptied into it (here: said so by a stub) fails the run in one line:
    exit 1, no file, no simulation number in the summary (the run, committed in the private
    file, was counted as stored). Without hard links the run goes into the file made anew."""
    import errno
    import os

    from gaz_cli.results import sqlite as sqlite_writer

    import pytest

    from gaz_cli.errors import StoreError
    from gaz_cli.model.recording import RunStats
    from gaz_cli.model.scene import Scene
    from gaz_cli.placement.initial import initial_state
    from gaz_cli.model.species import BUILTIN

    db = tmp_path / "new.db"
    real_exists = os.path.exists
    with monkeypatch.context() as patch:
        patch.setattr(sqlite_writer.os.path, "exists", lambda p: str(p).endswith("-wal") or real_exists(p))
        res = invoke([*QUICK, "--db", str(db)])
        assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.output
        assert "could not be completed" in res.stderr, res.output
        scene = Scene(dim=2, length=1e-7, duration=2e-10, components=((BUILTIN["Ar"], 20),), seed=1)
        with pytest.raises(StoreError, match="could not be completed"):
            with sqlite_writer.SqliteFile(str(db)) as file, file.simulation(scene) as run:
                run.finish(RunStats(0, 0, 0, 0.01, initial_state(scene)), 1.0, 1.0)
        assert run.si_num is None  # not stored (it said 1)
    assert list(tmp_path.iterdir()) == []

    def no_links(*args):
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(sqlite_writer.os, "link", no_links)
    res = invoke([*QUICK, "--db", str(db), "--json"])
    assert res.exit_code == 0, res.output
    assert simulations(db) == [1] and [p.name for p in tmp_path.iterdir()] == ["new.db"]


def test_a_new_files_first_run_lands_whole_and_later_writers_use_wal(tmp_path):
    """A new database's first run is written into its private file with SQLite's rollback
    journal (nobody else can read that file, so WAL's readers-beside-a-writer buys nothing there,
    and its commit copies every row twice), its pages flushed to the disk by the early insert's
    thread while the engine runs. The run lands whole (every bounce, integrity_check ok), no file
    descriptor is left open, nothing but the database is left beside it, and the next writer puts
    the file in WAL mode, as every gaz database, so that readers read while gaz writes."""
    import os

    from gaz_cli.run import runner
    from gaz_cli.model.scene import Scene
    from gaz_cli.model.species import lookup

    # the README example's gas for 1 ns: ~18,000 bounces, several chunks of the early insert
    scene = Scene(dim=3, length=3.4e-8, duration=1e-9, components=((lookup("Ar"), 1000),), seed=1)
    db = tmp_path / "new.db"
    fds = os.listdir("/proc/self/fd") if os.path.isdir("/proc/self/fd") else None
    first = runner.simulate(scene, db=str(db))
    if fds is not None:
        assert sorted(os.listdir("/proc/self/fd")) == sorted(fds)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.db"]
    con = sqlite3.connect(db)
    try:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        assert con.execute("SELECT COUNT(*) FROM rebond WHERE si_num = 1").fetchone()[0] == first["wall_bounces"] > 16384
    finally:
        con.close()
    runner.simulate(scene, db=str(db))
    con = sqlite3.connect(db)
    try:
        assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        assert [r[0] for r in con.execute("SELECT si_num FROM simulation ORDER BY si_num")] == [1, 2]
    finally:
        con.close()


def _pg_read(url, read):
    """``read(conn)`` on a fresh connection to the PostgreSQL database at ``url``."""
    import sqlalchemy as sa

    engine = sa.create_engine(url)
    try:
        with engine.connect() as conn:
            return read(conn)
    finally:
        engine.dispose()


def _pg_tables(url):
    import sqlalchemy as sa

    return _pg_read(url, lambda conn: sorted(sa.inspect(conn).get_table_names()))


def _pg_simulations(url):
    return _pg_read(url, lambda conn: conn.exec_driver_sql(
        "SELECT si_num FROM simulation ORDER BY si_num").scalars().all())


@pytest.mark.postgres
def test_a_failed_first_run_leaves_a_new_postgresql_database_empty(postgres_db, monkeypatch):
    """A run into a new PostgreSQL database that failed (--save-state on a full disk), was
    interrupted, or failed through the Python API left gaz's ten tables behind, empty. Now
    the database is as it was (no table); a database with runs keeps them, and its tables."""
    from gaz_cli.run import runner
    from gaz_cli.results import store as st
    from gaz_cli.errors import Interrupted
    from gaz_cli.model.scene import Scene
    from gaz_cli.model.species import BUILTIN

    res = invoke([*QUICK, "--db", postgres_db, "--save-state", "/dev/full"])  # ENOSPC
    assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.output
    assert _pg_tables(postgres_db) == []

    def interrupted(*args, **kwargs):  # a SIGINT taking effect after the engine, before the commit
        raise Interrupted(2)

    with monkeypatch.context() as patch:
        patch.setattr(runner, "run_pressure", interrupted)
        res = invoke([*QUICK, "--db", postgres_db])
    assert res.exit_code == 130, res.output
    assert _pg_tables(postgres_db) == []
    scene = Scene(dim=2, length=1e-7, duration=2e-10, components=((BUILTIN["Ar"], 20),), seed=1)
    with pytest.raises(RuntimeError, match="finish"):
        with st.Store(postgres_db) as store, store.simulation(scene):
            pass  # finish() not called: the run fails
    assert _pg_tables(postgres_db) == []
    assert invoke([*QUICK, "--db", postgres_db]).exit_code == 0
    tables = _pg_tables(postgres_db)
    assert "simulation" in tables and _pg_simulations(postgres_db) == [1]
    res = invoke([*QUICK, "--db", postgres_db, "--save-state", "/dev/full"])
    assert res.exit_code == 1 and _pg_tables(postgres_db) == tables and _pg_simulations(postgres_db) == [1]


@pytest.mark.postgres
def test_two_processes_started_together_into_a_new_postgresql_database_both_land(postgres_db):
    """gaz simulate into one new PostgreSQL database twice at once, and beside them a third run
    that fails: the two exit 0, with distinct simulation numbers, both stored; the failed one
    drops nothing of theirs."""
    import json
    import subprocess
    import sys

    procs = [subprocess.Popen([sys.executable, "-m", "gaz_cli", *QUICK[:-1], str(seed), "--db", postgres_db,
                               "--json", *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for seed, extra in ((1, []), (2, []), (3, ["--save-state", "/dev/full"]))]
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 1], outs
    stored = sorted(json.loads(out)["si_num"] for out, _ in outs[:2])
    assert len(set(stored)) == 2 and _pg_simulations(postgres_db) == stored


def test_a_failed_first_run_through_the_store_or_a_url_with_options_leaves_no_file(tmp_path, monkeypatch):
    """Store(db) (the Python API) and SQLite URLs with options (sqlite:///x.db?timeout=5, a
    file: URI with ?uri=true), which go through SQLAlchemy's store, created the file on
    opening: a first run that failed, or was interrupted, left it (45,056 bytes, an empty gaz
    database). Now the new file is made under a private name and takes its own with its first
    run stored: nothing is left by a failed one; a store opened and closed without a run
    still makes the database; two stores opened on one new file both land."""
    from gaz_cli.results import store as st
    from gaz_cli.model.recording import RunStats
    from gaz_cli.model.scene import Scene
    from gaz_cli.placement.initial import initial_state
    from gaz_cli.model.species import BUILTIN

    monkeypatch.chdir(tmp_path)
    urls = ["sqlite:///x.db?timeout=5", f"sqlite:///file:{tmp_path / 'x.db'}?mode=rwc&uri=true"]
    for db in urls:
        res = invoke([*QUICK, "--db", db, "--save-state", "/dev/full"])  # ENOSPC
        assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.output
        assert list(tmp_path.iterdir()) == []

    res = _interrupted_run(monkeypatch, urls[0])
    assert res.exit_code == 130 and list(tmp_path.iterdir()) == [], res.output
    scene = Scene(dim=2, length=1e-7, duration=2e-10, components=((BUILTIN["Ar"], 20),), seed=1)
    for db in ["api.db", urls[1]]:
        with pytest.raises(RuntimeError, match="finish"):
            with st.Store(db) as store, store.simulation(scene):
                assert store.simulation_numbers() == []  # read meanwhile: an empty gaz database
    assert list(tmp_path.iterdir()) == []
    st.Store("made.db").close()
    assert [p.name for p in tmp_path.iterdir()] == ["made.db"] and simulations("made.db") == []

    first, second = st.Store(urls[0]), st.Store(urls[1])  # one new file, twice
    for count, store in enumerate((first, second), start=1):
        with store:
            with store.simulation(scene) as run:
                run.add_bounces([1e-11, 2e-11], [0, 1], [1, -2], [300.0, 310.0], [200.0, 100.0])
                run.finish(RunStats(2, 2, 0, 0.01, initial_state(scene)), 1.0, 1.0)
            assert store.simulation_numbers() == list(range(1, count + 1))  # read under its name
    assert simulations("x.db") == [1, 2]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["made.db", "x.db"]


def test_a_urls_busy_timeout_holds_on_every_path_also_after_a_lost_race(tmp_path, monkeypatch):
    """sqlite:///x.db?timeout=S: how long a writer waits for another one's lock. It was dropped
    everywhere (the store forced its own 60 s over the URL's), and after a new file's lost race
    (another process made the file first: the run is committed again into that one) or a store's
    second run, the file was opened again with none of the URL's options. With the lock held by
    another writer, each path now gives up after the URL's timeout, in one line that says so,
    nothing stored; a timeout that is not a number of seconds is refused before the run."""
    from gaz_cli.results import sqlite as sqlite_writer
    from gaz_cli.results import store as st
    from gaz_cli.errors import StoreError
    from gaz_cli.model.recording import RunStats
    from gaz_cli.model.scene import Scene
    from gaz_cli.placement.initial import initial_state
    from gaz_cli.model.species import BUILTIN

    monkeypatch.chdir(tmp_path)
    # the default made short, so that a writer ignoring the URL fails fast, saying 2 s
    monkeypatch.setattr(sqlite_writer, "BUSY_TIMEOUT_S", 2.0)
    url = "sqlite:///x.db?timeout=0.3"
    locked = "'sqlite:///x.db?timeout=0.3' is locked by another process (waited 0.3 s)"
    scene = Scene(dim=2, length=1e-7, duration=2e-10, components=((BUILTIN["Ar"], 20),), seed=1)
    state = initial_state(scene)

    def one_run(store):
        with store.simulation(scene) as run:
            run.add_bounces([1e-11, 2e-11], [0, 1], [1, -2], [300.0, 310.0], [200.0, 100.0])
            run.finish(RunStats(2, 2, 0, 0.01, state), 1.0, 1.0)
        return run.si_num

    def holding_the_lock():
        holder = sqlite3.connect("x.db", isolation_level=None)
        holder.execute("BEGIN IMMEDIATE")  # another writer in the middle of its commit
        return holder

    loser = st.Store(url)  # a new file: made under a private name until its first run is stored
    st.Store("x.db").close()  # another process makes the database meanwhile
    holder = holding_the_lock()
    try:
        with pytest.raises(StoreError) as lost:
            one_run(loser)  # committed again into x.db, which is locked
    finally:
        holder.execute("ROLLBACK")
        holder.close()
        loser.close()
    assert locked in str(lost.value)

    with st.Store(url) as store:  # x.db exists: the store's first run, then a second one
        assert one_run(store) == 1
        holder = holding_the_lock()
        try:
            with pytest.raises(StoreError) as second:
                one_run(store)
        finally:
            holder.execute("ROLLBACK")
            holder.close()
    assert locked in str(second.value)

    holder = holding_the_lock()
    try:
        res = invoke([*QUICK, "--db", url])
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    assert res.exit_code == 1 and res.stderr == f"gaz: error: database {locked}; try again when it has finished\n"
    assert simulations("x.db") == [1] and sorted(p.name for p in tmp_path.iterdir()) == ["x.db"]
    res = invoke([*QUICK, "--db", "sqlite:///x.db?timeout=soon"])
    assert res.exit_code == 1 and res.stderr == (
        "gaz: error: --db 'sqlite:///x.db?timeout=soon': timeout=soon is not a number of seconds; "
        "write it as e.g. ?timeout=30 (how long to wait for another writer's lock)\n"), res.output


def _missing_table_refusal(db, tables, runs):
    """The one line refusing a gaz database without ``tables`` that holds ``runs`` runs."""
    them = "them" if len(tables) > 1 else "it"
    fix = ("it holds no run: give --db a new database, or drop gaz's tables from it and run again" if not runs
           else f"it holds {runs} run(s): restore {them} from a backup, or give --db a new database")
    return (f"gaz: error: {db!r} is a gaz database without its table{'s' * (len(tables) > 1)} "
            f"{', '.join(tables)}; nothing was written; {fix}\n")


def test_a_gaz_sqlite_file_without_one_of_its_tables_is_refused_before_the_run(tmp_path):
    """A gaz database (schema version 2 or later: it has SCHEMA_VERSION) lacking one of gaz's
    tables, dropped by hand or by another tool, was refused with words for the Python API
    ("open it for writing (Store(db), not create=False) to migrate it first"), which does not
    help: no migration makes a table of the current version. Now one line names the table and
    the fix, before the run (no trajectory file), the database untouched; gaz analyse, which said
    'internal error: NoSuchTableError', one line too."""
    db, traj = tmp_path / "a.db", tmp_path / "run.h5"
    assert invoke([*QUICK, "--db", str(db)]).exit_code == 0
    empty = tmp_path / "empty.db"
    from gaz_cli.results import store as st

    st.Store(str(empty)).close()  # a database made by the API, no run yet
    for path, table in ((db, "resultat"), (empty, "choc")):
        con = sqlite3.connect(path)
        con.execute(f"DROP TABLE {table}")
        con.commit()
        con.close()
    for path, tables, runs in ((db, ["RESULTAT"], 1), (empty, ["CHOC"], 0)):
        res = invoke(["simulate", "--dim", "2", "--n", "20", "--length", "1e-7", "--duration", "2e-10",
                      "--seed", "2", "--db", str(path), "--trajectory", str(traj), "--every", "1e-11"])
        assert res.exit_code == 1 and res.stderr == _missing_table_refusal(str(path), tables, runs), res.output
        assert not traj.exists()  # refused before the run
    assert simulations(db) == [1] and simulations(empty) == []
    res = invoke(["analyse", "--db", str(db)])  # a reader: one line too (it said 'internal error: NoSuchTableError')
    assert res.exit_code == 1 and res.stderr == (
        f"gaz: error: {str(db)!r} is a gaz database without its table RESULTAT; restore it from a backup, "
        "or point --db at another gaz database\n"), res.output


@pytest.mark.postgres
def test_a_first_run_killed_mid_run_leaves_a_whole_schema_that_the_next_run_uses(postgres_db):
    """SIGKILL leaves no time for the cleanup of a failed first run (postgres.unmake): a first run
    into a new PostgreSQL database killed mid-run leaves gaz's tables. All of them (created in one
    transaction at opening, with the version row and PARTICULE's rows; the run's own rows and
    partition in its transaction, rolled back by the server): the next run uses them and is
    stored, also with the version row deleted by hand (read as schema 1 and migrated). Tables dropped by hand from such a database were found only at the commit, after the
    engine ('relation "resultat" does not exist'); now refused before the run, in one line."""
    import json
    import signal
    import subprocess
    import sys

    from gaz_cli.results import store as st

    # the time-stepped engine: its diagnostics on stderr say the run is under way
    child = subprocess.Popen([sys.executable, "-m", "gaz_cli", "simulate", "--engine", "step", "--dt", "1e-12",
                              "--print-every", "200", "--dim", "2", "--n", "100", "--length", "1e-7",
                              "--duration", "1e-6", "--seed", "2", "--db", postgres_db],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_diagnostics(child)
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=60)
    finally:
        child.kill()
    assert child.returncode == -signal.SIGKILL
    left = _pg_tables(postgres_db)
    assert {t.name for t in st.metadata.sorted_tables} <= set(left) and _pg_simulations(postgres_db) == []

    def version(conn):
        return conn.exec_driver_sql("SELECT sv_version FROM schema_version").scalars().all()

    assert _pg_read(postgres_db, version) == [st.POSTGRES_SCHEMA_VERSION]
    # its version row lost too (by hand): read as schema 1, whose migration finds every table there
    _pg_read(postgres_db, lambda conn: (conn.exec_driver_sql("DELETE FROM schema_version"), conn.commit()))
    res = invoke([*QUICK, "--db", postgres_db, "--json"])
    assert res.exit_code == 0, res.output
    assert _pg_simulations(postgres_db) == [json.loads(res.stdout)["si_num"]]
    assert _pg_read(postgres_db, version) == [st.POSTGRES_SCHEMA_VERSION]

    _pg_read(postgres_db, lambda conn: (conn.exec_driver_sql("DROP TABLE resultat"), conn.commit()))
    res = invoke([*QUICK, "--db", postgres_db, "--save-state", "/dev/full"])  # (a run would fail anyway)
    assert res.exit_code == 1 and res.stderr == _missing_table_refusal(st.shown(postgres_db), ["RESULTAT"], 1), res.output
    assert len(_pg_simulations(postgres_db)) == 1
