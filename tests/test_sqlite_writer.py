"""The SQLite writer without SQLAlchemy (gaz_cli.results.sqlite): its schema is SQLAlchemy's,
its database is the store's table by table, it hands older and foreign databases to the
store, and a tiny ``gaz simulate --db FILE`` imports neither SQLAlchemy nor pandas.

(Concurrent writers, interrupts, a full disk, a locked file and foreign databases through
the CLI, which now takes this writer, are tests/test_store_cli.py's.)"""

import datetime as dt
import sqlite3
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
from conftest import random_rows

from gaz_cli.results import sqlite as sqlite_writer
from gaz_cli.results import writer
from gaz_cli.results import staging
from gaz_cli.results import store as st
from gaz_cli.errors import StoreError
from gaz_cli.model.recording import RunStats
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species, lookup

STARTED = dt.datetime(2026, 11, 22, 23, 30, 5)


def test_the_packaged_schema_is_what_sqlalchemy_emits():
    """sql/schema/sqlite.sql is SQLAlchemy's CREATE TABLE of store.metadata on SQLite, and
    the schema version row of store.SCHEMA_VERSION (regenerate it with generated_schema())."""
    assert sqlite_writer.schema_text() == sqlite_writer.generated_schema()
    assert sqlite_writer.layout().version == st.SCHEMA_VERSION
    assert sqlite_writer.layout().columns == {t.name: [c.name for c in t.columns]
                                              for t in st.metadata.sorted_tables}


def runs():
    """Two scenes: a mixture recording everything, and a custom species (a new PARTICULE row)."""
    mixture = Scene(dim=2, length=1e-7, duration=1e-10, seed=3, record="all",
                    components=((lookup("Ar"), 20), (lookup("He"), 10)))
    custom = replace(mixture, seed=4, record="bounces", components=((Species("X", 3e-26, 1e-10), 30),))
    return mixture, custom


def write(opened, scene, k=3000, chunks=3):
    """k random bounces (and collisions) of ``scene`` through ``opened``'s writer."""
    (t, particle, wall, speed, vperp), (i, j, imp) = random_rows(scene, k, scene.seed)
    with opened.simulation(scene, started=STARTED) as w:
        for part in np.array_split(np.arange(k), chunks):
            w.add_bounces(t[part], particle[part], wall[part], speed[part], vperp[part])
            if w.want_collisions:
                w.add_collisions(t[part], i[part], j[part], imp[part])
        w.finish(RunStats(2 * k, k, k, 0.25, initial_state(scene), virial=1.5e-20), 1.0, 2.0)
    return w.si_num


def content(path):
    """Every table's rows with each value's SQLite storage class, its CREATE TABLE, the journal mode."""
    con = sqlite3.connect(path)
    try:
        tables = [r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
        out = {"journal": con.execute("PRAGMA journal_mode").fetchone()}
        for t in tables:
            cols = [r[1] for r in con.execute(f"PRAGMA table_info({t})")]
            typed = ", ".join(f"{c}, typeof({c})" for c in cols)
            out[t] = con.execute(f"SELECT {typed} FROM {t} ORDER BY {', '.join(cols)}").fetchall()
            out[t, "info"] = con.execute(f"PRAGMA table_info({t})").fetchall()
            out[t, "keys"] = con.execute(f"PRAGMA foreign_key_list({t})").fetchall()
            (sql,) = con.execute("SELECT sql FROM sqlite_master WHERE name = ?", (t,)).fetchone()
            out[t, "sql"] = " ".join(sql.split())  # the CREATE TABLE as SQLite keeps it
        return out
    finally:
        con.close()


@pytest.mark.parametrize("where", ["memory", "scratch file"])
def test_both_writers_give_the_same_database(tmp_path, monkeypatch, where):
    """The same two runs through SQLAlchemy's store and through the plain sqlite3 writer give
    the same database: every table's rows and their storage classes, columns, keys, WAL --
    rows staged in memory, or spilled to a scratch file after the first chunk."""
    if where == "scratch file":
        monkeypatch.setattr(staging, "MEMORY_ROWS", 1500)
    a, b = tmp_path / "sqlalchemy.db", tmp_path / "sqlite3.db"
    with st.Store(str(a)) as store:
        assert [write(store, scene) for scene in runs()] == [1, 2]
    with writer.open_for_writing(str(b)) as light:
        assert isinstance(light, sqlite_writer.SqliteFile)
        assert [write(light, scene) for scene in runs()] == [1, 2]
    found, expected = content(b), content(a)
    assert found.keys() == expected.keys() and len(found["rebond"]) == 6000 and len(found["choc"]) == 3000
    for key in expected:
        assert found[key] == expected[key], key
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sqlalchemy.db", "sqlite3.db"]


def test_a_current_file_is_written_in_place_an_older_one_is_migrated_by_the_store(tmp_path):
    """A file at this layout is opened by the light writer; one at schema version 2 goes to
    the store, which migrates it (then the light writer takes it); a newer version and a
    foreign file are refused with the store's words, the foreign file left untouched."""
    db = str(tmp_path / "g.db")
    with st.Store(db):
        pass
    with writer.open_for_writing(db) as opened:
        assert isinstance(opened, sqlite_writer.SqliteFile)
    con = sqlite3.connect(db)
    con.execute("ALTER TABLE scene DROP COLUMN sc_file")  # version 2's layout
    con.execute("ALTER TABLE composition DROP COLUMN co_rank")
    con.execute("UPDATE schema_version SET sv_version = 2")
    con.commit()
    con.close()
    with writer.open_for_writing(db) as opened:
        assert isinstance(opened, st.Store) and opened.schema_version() == st.SCHEMA_VERSION
    with writer.open_for_writing(db) as opened:
        assert isinstance(opened, sqlite_writer.SqliteFile)
        assert write(opened, runs()[0]) == 1
    con = sqlite3.connect(db)
    con.execute("UPDATE schema_version SET sv_version = sv_version + 1")  # a later gaz's file
    con.commit()
    con.close()
    with pytest.raises(StoreError, match="newer than this gaz"):
        writer.open_for_writing(db)
    foreign = tmp_path / "foreign.db"
    con = sqlite3.connect(foreign)
    con.execute("CREATE TABLE rebond (x INTEGER)")
    con.commit()
    con.close()
    before = foreign.read_bytes()
    with pytest.raises(StoreError, match="not a gaz database: its table REBOND has columns"):
        writer.open_for_writing(str(foreign))
    assert foreign.read_bytes() == before


@pytest.mark.parametrize("path", ["staged", "early"])
def test_a_failed_commit_leaves_nothing(tmp_path, monkeypatch, path):
    """A failure at the commit rolls the whole run back: no SIMULATION, SCENE, COMPOSITION or
    REBOND row, the file consistent; one StoreError line -- while the staged rows move in, or
    when the rows inserted early get their RESULTAT row."""
    from gaz_cli.results.store import Store

    db = tmp_path / "g.db"
    Store(str(db)).close()  # a gaz database (a new one is not created for a run that fails)

    def full(*args, **kwargs):
        raise sqlite3.OperationalError("database or disk is full")

    with writer.open_for_writing(str(db)) as opened:
        if path == "staged":
            monkeypatch.setattr(sqlite_writer, "LOCK_BOUND_S", 0)
            monkeypatch.setattr(staging, "move_in", full)
        else:
            monkeypatch.setattr(sqlite_writer, "_result_row", full)
        with pytest.raises(StoreError, match="no space left for database"):
            write(opened, runs()[0])
    con = sqlite3.connect(db)
    counts = [con.execute(f"SELECT COUNT(*) FROM {t}").fetchone()[0]
              for t in ("simulation", "scene", "composition", "rebond", "resultat")]
    assert counts == [0] * 5 and con.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    con.close()


_PROBE = """
import sys
from gaz_cli.cli import main
for seed in ("1", "2"):  # a new file, then a file at the current layout
    try:
        main(["simulate", "--dim", "3", "--n", "100", "--length", "1e-8", "--duration", "1e-12",
              "--seed", seed, "--db", sys.argv[1], "--json"])
    except SystemExit as exit:
        assert not exit.code, exit.code
print(sorted(m for m in ("sqlalchemy", "pandas", "matplotlib", "h5py", "dask", "gaz_cli.engines.event.driver")
             if m in sys.modules), file=sys.stderr)
"""


def test_a_tiny_run_into_a_sqlite_file_imports_no_sqlalchemy(tmp_path):
    """Start-up (issue 15 item 4): a tiny ``gaz simulate --db FILE`` into a new file and into a
    current one imports neither SQLAlchemy nor pandas (nor matplotlib, h5py, dask, nor the
    event engine its exam's engine does not use), and stores both runs."""
    db = tmp_path / "new.db"
    out = subprocess.run([sys.executable, "-c", _PROBE, str(db)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stderr.strip().splitlines()[-1] == "[]", out.stderr
    con = sqlite3.connect(db)
    assert con.execute("SELECT si_num, sc_seed FROM scene ORDER BY si_num").fetchall() == [(1, 1), (2, 2)]
    assert con.execute("SELECT COUNT(*) FROM rebond").fetchone()[0] > 0
    con.close()


@pytest.mark.parametrize("k", [1, staging.ROWS_PER_STATEMENT, 2 * staging.ROWS_PER_STATEMENT + 3])
def test_insert_rows_writes_the_row_numbers_in_the_sql_and_every_value_exactly(k):
    """staging.insert_rows (both writers' insert): a row number counting up (RE_NUM, from 5
    here, as a later chunk of a run) is written in the SQL, not bound, and comes back as the
    same integers; one that does not count up is bound as it is; the other values come back
    bit for bit (floats bound as float64, integers below 2^53 exact), with SQLite's storage
    classes -- whole statements and a shorter last one."""
    con = sqlite3.connect(":memory:", isolation_level=None)
    con.execute("CREATE TABLE rebond (si_num INTEGER NOT NULL, re_num INTEGER NOT NULL, re_t FLOAT, "
                "re_dir INTEGER, PRIMARY KEY (si_num, re_num)) WITHOUT ROWID")
    rng = np.random.default_rng(k)
    t, wall = rng.random(k) * 1e-8, rng.integers(-3, 4, k)
    counted = np.arange(5, 5 + k)
    shuffled = counted[::-1].copy() if k > 1 else counted + 1  # not counting up (or another start)
    staging.insert_rows(con, "rebond", ["re_num", "re_t", "re_dir"], [counted, t, wall], {"si_num": 1})
    staging.insert_rows(con, "rebond", ["re_t", "re_num", "re_dir"], [t, shuffled, wall], {"si_num": 2})
    for si, numbers in ((1, counted), (2, shuffled)):
        rows = con.execute("SELECT re_num, re_t, re_dir, typeof(re_num), typeof(re_t), typeof(re_dir) "
                           "FROM rebond WHERE si_num = ?", (si,)).fetchall()
        got = sorted(rows)
        want = sorted(zip(numbers.tolist(), t.tolist(), wall.tolist()))
        assert [r[:3] for r in got] == want
        assert {r[3:] for r in got} == {("integer", "real", "integer")}


class _RefusingOnce:
    """A sqlite3 connection whose ``PRAGMA journal_mode = WAL`` is refused ``refusals`` times
    with SQLite's immediate "database is locked" (what several processes opening one new
    file at once meet, without the busy handler)."""

    def __init__(self, path, refusals):
        self.conn = sqlite3.connect(path, isolation_level=None)
        self.refusals = refusals

    def execute(self, sql):
        if sql == "PRAGMA journal_mode = WAL" and self.refusals:
            self.refusals -= 1
            raise sqlite3.OperationalError("database is locked")
        return self.conn.execute(sql)


def test_the_switch_to_wal_waits_for_other_processes_instead_of_failing(tmp_path):
    conn = _RefusingOnce(tmp_path / "gaz.db", refusals=3)
    sqlite_writer.use_wal(conn)
    assert conn.refusals == 0
    assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_the_switch_to_wal_gives_up_after_the_busy_timeout(tmp_path, monkeypatch):
    monkeypatch.setattr(sqlite_writer, "BUSY_TIMEOUT_S", 0.05)
    conn = _RefusingOnce(tmp_path / "gaz.db", refusals=10**6)
    with pytest.raises(sqlite3.OperationalError, match="locked"):
        sqlite_writer.use_wal(conn)
    assert conn.refusals > 0


@pytest.mark.parametrize("phase", ["open", "commit"])
def test_a_signal_stops_the_wait_for_another_writers_lock(tmp_path, phase):
    """Another process holds the write lock; a run waits for it, at its opening or at its
    commit, and gets SIGINT: it stops at once, nothing written, while the lock is still held
    (SQLite's wait runs in C, where Python's handlers do not: the run went on waiting until
    the lock came free, up to BUSY_TIMEOUT_S, 60 s, whatever the user pressed)."""
    import os
    import signal
    import threading
    import time

    from gaz_cli import interrupts
    from gaz_cli.errors import Interrupted

    db = tmp_path / "gaz.db"
    scene = runs()[0]
    from gaz_cli.results.store import Store

    Store(str(db)).close()  # a gaz database, at the current schema
    holder = sqlite3.connect(db, isolation_level=None, check_same_thread=False)
    main = threading.main_thread().ident
    released, signalled = threading.Event(), threading.Event()

    def interrupt_the_wait():
        # once the main thread waits for the lock (its stack shows it), SIGINT; the lock is
        # given back only after a bound, which only a wait that ignores the signal reaches
        while not signalled.is_set():
            frame = sys._current_frames().get(main)
            while frame is not None:
                if frame.f_code.co_name in ("begin_immediate", "_transaction"):
                    os.kill(os.getpid(), signal.SIGINT)
                    signalled.set()
                    break
                frame = frame.f_back
            time.sleep(0.001)
        if not done.wait(2 * sqlite_writer.BUSY_TIMEOUT_S / 3):
            released.set()
            holder.execute("ROLLBACK")

    done = threading.Event()
    helper = threading.Thread(target=interrupt_the_wait, daemon=True)
    with interrupts.catching(), pytest.raises(Interrupted):
        try:
            if phase == "open":
                holder.execute("BEGIN IMMEDIATE")
                helper.start()
            file = sqlite_writer.SqliteFile(str(db))
            with file, file.simulation(scene, STARTED) as w:
                bounces, _ = random_rows(scene, 100, seed=1)
                w.add_bounces(*bounces)
                w.finish(RunStats(100, 100, 0, 0.1, initial_state(scene)), 1.0, 1.0)
                holder.execute("BEGIN IMMEDIATE")
                helper.start()
        finally:
            done.set()
            helper.join()
    assert not released.is_set()  # stopped while the lock was held
    if holder.in_transaction:
        holder.execute("ROLLBACK")
    holder.close()
    con = sqlite3.connect(db)
    assert con.execute("SELECT COUNT(*) FROM simulation").fetchone() == (0,)
    con.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gaz.db"]
