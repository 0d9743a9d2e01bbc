"""The SQLite writer's early insert (gaz_cli.results.sqlite._EarlyInsert): a run's rows inserted
by a thread while its engine runs give the same database as the staged commit; a run holding
the write lock past the bound gives it back (another writer gets in) and still stores every
row; a failure in the thread or an interrupt leaves no row, no lock, no thread, and one error."""

import signal
from dataclasses import replace
import sqlite3
import threading
import time

import numpy as np
import pytest
from conftest import random_rows
from test_sqlite_writer import STARTED, content, runs, write

from gaz_cli.run import runner
from gaz_cli.results import sqlite as sqlite_writer
from gaz_cli.results import writer
from gaz_cli.results import staging
from gaz_cli.engines.event import driver
from gaz_cli.errors import Interrupted, StoreError
from gaz_cli.model.recording import RunStats
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species, lookup


def forbid(monkeypatch, obj, name):
    """Make ``obj.name`` raise: the path that calls it must not be taken."""
    def refused(*args, **kwargs):
        raise AssertionError(f"{name} called")

    monkeypatch.setattr(obj, name, refused)


def existing(path) -> str:
    """A gaz database at ``path``, made before the run (a new one is made under a name of its
    own until its first commit, gaz_cli.results.sqlite.SqliteFile): these tests share its lock."""
    from gaz_cli.results.store import Store

    Store(str(path)).close()
    return str(path)


def lock_is_free(db) -> bool:
    con = sqlite3.connect(db, timeout=0, isolation_level=None)
    try:
        con.execute("BEGIN IMMEDIATE")
        con.execute("ROLLBACK")
        return True
    except sqlite3.OperationalError:
        return False
    finally:
        con.close()


def counts(db):
    con = sqlite3.connect(db)
    try:
        return [con.execute(f"SELECT COUNT(*) FROM {t}").fetchone()[0]
                for t in ("simulation", "scene", "composition", "rebond", "choc", "resultat")]
    finally:
        con.close()


def early_threads():
    return [t for t in threading.enumerate() if t.name == "gaz-early-insert"]


def test_early_and_staged_give_the_same_database(tmp_path, monkeypatch):
    """Two runs (a mixture recording bounces and collisions; a custom species, a new PARTICULE
    row) inserted early by the thread, and the same runs committed the staged way (the bound
    0: no early insert), give the same database: every table's rows and storage classes."""
    early, staged = str(tmp_path / "early.db"), str(tmp_path / "staged.db")
    with monkeypatch.context() as m:
        forbid(m, staging, "move_in")  # the staged commit's insert: not taken
        with writer.open_for_writing(early) as opened:
            assert [write(opened, scene) for scene in runs()] == [1, 2]
    with monkeypatch.context() as m:
        m.setattr(sqlite_writer, "LOCK_BOUND_S", 0)
        forbid(m, sqlite_writer, "_EarlyInsert")
        with writer.open_for_writing(staged) as opened:
            assert [write(opened, scene) for scene in runs()] == [1, 2]
    found, expected = content(early), content(staged)
    assert len(found["rebond"]) == 6000 and len(found["choc"]) == 3000
    assert found.keys() == expected.keys()
    for key in expected:
        assert found[key] == expected[key], key
    assert early_threads() == []


def test_the_readme_example_stores_the_same_rows_either_way(tmp_path, monkeypatch):
    """The README example (~178 thousand bounces: the engine hands eleven chunks, the first ones
    inserted while it runs) stores the same REBOND, SCENE and COMPOSITION rows, early or
    staged, and the same RESULTAT row but for its run time."""
    scene = Scene(dim=3, length=3.4e-8, duration=1e-8, components=((lookup("Ar"), 1000),), seed=1)
    seen = []
    taken = sqlite_writer._EarlyInsert.finish

    def finish(self):
        seen.append(taken(self))
        return seen[-1]

    monkeypatch.setattr(sqlite_writer._EarlyInsert, "finish", finish)
    monkeypatch.setattr(sqlite_writer, "LOCK_BOUND_S", 60.0)  # a loaded host: the engine may be slow
    runner.simulate(scene, db=str(tmp_path / "early.db"))
    monkeypatch.setattr(sqlite_writer, "LOCK_BOUND_S", 0)
    runner.simulate(scene, db=str(tmp_path / "staged.db"))
    assert seen == [True]  # the first run's rows were in when its engine stopped
    a, b = (sqlite3.connect(tmp_path / name) for name in ("early.db", "staged.db"))
    for table, order in (("rebond", "re_num"), ("scene", "si_num"), ("composition", "si_num"),
                         ("simulation", "si_num"), ("resultat", "si_num")):
        rows = [c.execute(f"SELECT * FROM {table} ORDER BY {order}").fetchall() for c in (a, b)]
        if table == "simulation":  # SI_DEB: the start of each run
            rows = [[r[:1] + r[2:] for r in found] for found in rows]
        if table == "resultat":  # RS_WALL_TIME: each run's own
            rows = [[r[:-1] for r in found] for found in rows]
        assert rows[0] == rows[1], table
    assert len(rows[0]) == 1
    assert a.execute("SELECT COUNT(*) FROM rebond").fetchone()[0] > 10 * driver.BUFFER_ROWS  # many chunks
    a.close()
    b.close()


def two_chunks(scene, k=2000):
    (t, particle, wall, speed, vperp), _ = random_rows(scene, k, 5)
    half = k // 2
    return [(t[s], particle[s], wall[s], speed[s], vperp[s]) for s in (slice(0, half), slice(half, k))]


def test_a_run_past_the_bound_gives_the_lock_back_to_another_writer(tmp_path, monkeypatch):
    """A run whose engine outlasts the bound (here 0.3 s) rolls its early insert back: another
    writer, waiting for the lock meanwhile, gets in and commits while the first run's engine
    still runs; the first run then commits the staged way; both runs' rows are all there."""
    monkeypatch.setattr(sqlite_writer, "LOCK_BOUND_S", 0.3)
    db = existing(tmp_path / "g.db")
    slow, other = runs()
    with writer.open_for_writing(db) as opened:
        with opened.simulation(slow, started=STARTED) as w:
            first, second = two_chunks(slow)
            w.add_bounces(*first)
            early = w._early
            deadline = time.monotonic() + 10
            while early.si_num is None and time.monotonic() < deadline:
                time.sleep(0.01)  # the thread has the lock and has inserted SIMULATION
            assert early.si_num == 1 and not lock_is_free(db)
            done = []
            def rival_run():
                with writer.open_for_writing(db) as rival_file:
                    done.append(write(rival_file, other))

            rival = threading.Thread(target=rival_run)
            rival.start()
            rival.join(timeout=20)  # the first run's "engine" still runs meanwhile
            assert done == [1], "the other writer did not get in while the engine ran"
            w.add_bounces(*second)
            w.finish(RunStats(2000, 2000, 0, 0.25, initial_state(slow)), 1.0, 2.0)
        assert early.outcome == "gave up" and w.si_num == 2
    con = sqlite3.connect(db)
    assert con.execute("SELECT si_num, COUNT(*) FROM rebond GROUP BY si_num").fetchall() == [(1, 3000), (2, 2000)]
    assert con.execute("SELECT si_num, sc_seed FROM scene ORDER BY si_num").fetchall() == [(1, 4), (2, 3)]
    con.close()
    assert early_threads() == []


def test_a_held_lock_sends_the_run_the_staged_way(tmp_path, monkeypatch):
    """The write lock held by another writer when the first chunk comes: the early insert
    gives up after TRY_LOCK_S, and the run is committed the staged way once the lock is free."""
    db = existing(tmp_path / "g.db")
    scene = runs()[1]
    with writer.open_for_writing(db) as opened:
        holder = sqlite3.connect(db, isolation_level=None)
        holder.execute("BEGIN IMMEDIATE")
        with opened.simulation(scene, started=STARTED) as w:
            for chunk in two_chunks(scene):
                w.add_bounces(*chunk)
            w._early._thread.join(timeout=10)
            assert w._early.outcome == "gave up"
            holder.execute("ROLLBACK")
            w.finish(RunStats(2000, 2000, 0, 0.25, initial_state(scene)), 1.0, 2.0)
        holder.close()
    assert w.si_num == 1 and counts(db)[:4] == [1, 1, 1, 2000]


class Full(Exception):
    pass


@pytest.mark.parametrize("error, says", [
    (sqlite3.OperationalError("database or disk is full"), "no space left for database"),
    (Full("a bug"), "a bug")])
@pytest.mark.parametrize("when", ["first chunk", "last chunk"])
def test_a_failure_in_the_thread_is_raised_and_leaves_nothing(tmp_path, monkeypatch, error, says, when):
    """A failure in the early insert's thread (a full disk; anything else) is raised in the
    main thread -- at the run's next chunk, or at its end -- as the one StoreError line (a
    driver error) or as itself; no row of the run, no lock, no thread left."""
    db = existing(tmp_path / "g.db")
    scene = runs()[0]
    calls = []
    insert = sqlite_writer._EarlyInsert._insert

    def failing(self, table, columns):
        calls.append(table)
        if when == "first chunk" or len(calls) > 1:
            raise error
        insert(self, table, columns)

    monkeypatch.setattr(sqlite_writer._EarlyInsert, "_insert", failing)
    with writer.open_for_writing(db) as opened:
        with pytest.raises(StoreError if isinstance(error, sqlite3.Error) else Full, match=says):
            with opened.simulation(scene, started=STARTED) as w:
                for chunk in two_chunks(scene):
                    w.add_bounces(*chunk)
                    time.sleep(0.2)  # the thread inserts (and fails) meanwhile
                w.finish(RunStats(2000, 2000, 0, 0.25, initial_state(scene)), 1.0, 2.0)
        assert early_threads() == [] and lock_is_free(db)
        monkeypatch.undo()
        assert write(opened, runs()[1]) == 1  # the connection still writes, early
    assert counts(db) == [1, 1, 1, 3000, 0, 1]
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(staging.SUFFIX)] == []


def test_an_interrupt_mid_run_rolls_back_and_frees_the_lock(tmp_path):
    """Ctrl-C (KeyboardInterrupt) while the early insert holds the lock: the run's block
    unwinds, the thread rolls back and ends, no row is left and the lock is free."""
    db = existing(tmp_path / "g.db")
    scene = runs()[0]
    with writer.open_for_writing(db) as opened:
        with pytest.raises(KeyboardInterrupt):
            with opened.simulation(scene, started=STARTED) as w:
                w.add_bounces(*two_chunks(scene)[0])
                early = w._early
                deadline = time.monotonic() + 10
                while early.si_num is None and time.monotonic() < deadline:
                    time.sleep(0.01)
                assert not lock_is_free(db)
                raise KeyboardInterrupt
        assert early.outcome == "gave up" and early_threads() == [] and lock_is_free(db)
    assert counts(db) == [0] * 6


@pytest.mark.parametrize("when", ["engine", "commit"])
def test_ctrl_c_through_the_runner(tmp_path, monkeypatch, when):
    """A real SIGINT in a run of the README example (``runner.simulate``, its signal handlers):
    while the engine runs and the early insert holds the lock, the run stops with nothing
    written, the lock free, no thread left; during the early commit (the RESULTAT row), the
    commit is done whole and the interrupt takes effect after it."""
    scene = Scene(dim=3, length=3.4e-8, duration=1e-8, components=((lookup("Ar"), 1000),), seed=1)
    db = existing(tmp_path / "g.db")
    monkeypatch.setattr(sqlite_writer, "LOCK_BOUND_S", 60.0)
    if when == "engine":
        insert = sqlite_writer._EarlyInsert._insert

        def interrupting(self, table, columns):
            insert(self, table, columns)
            if not self._done.is_set():
                signal.raise_signal(signal.SIGINT)  # (from this thread: Python runs it in the main one)

        monkeypatch.setattr(sqlite_writer._EarlyInsert, "_insert", interrupting)
    else:
        result_row = sqlite_writer._result_row

        def interrupting(*args):
            signal.raise_signal(signal.SIGINT)
            result_row(*args)

        monkeypatch.setattr(sqlite_writer, "_result_row", interrupting)
    with pytest.raises(Interrupted) as caught:
        runner.simulate(scene, db=db)
    assert early_threads() == [] and lock_is_free(db)
    if when == "engine":
        assert "nothing was written to" in str(caught.value)
        assert counts(db) == [0] * 6
    else:
        assert "simulation 1 was stored in" in str(caught.value)
        assert counts(db)[:4] == [1, 1, 1, runner.simulate(scene)["wall_bounces"]]


def test_a_long_run_starts_its_early_insert_near_its_end(tmp_path, monkeypatch):
    """The early insert starts once the engine should stop within EARLY_START_S, from its pace
    since it reported its start: not at a first chunk a quarter of the way after 0.3 s (0.9 s
    to go), but at the next one, 95 % of the way; it then inserts the chunks so far too, and
    the rows are those of the staged commit."""
    scene = runs()[0]
    (t, particle, wall, speed, vperp), _ = random_rows(scene, 2000, 7)
    cut = int(np.searchsorted(t, 0.25 * scene.duration))
    end = int(np.searchsorted(t, 0.95 * scene.duration))
    parts = [slice(0, cut), slice(cut, end)]

    def run(db):
        with writer.open_for_writing(db) as opened:
            with opened.simulation(scene, started=STARTED) as w:
                w.progress(0.0, 0)
                time.sleep(0.3)
                started = []
                for part in parts:
                    w.add_bounces(t[part], particle[part], wall[part], speed[part], vperp[part])
                    started.append(w._early is not None)
                w.finish(RunStats(end, end, 0, 0.3, initial_state(scene)), 1.0, 2.0)
        return started

    # (existing files: a new one's first run inserts from its first chunk, below)
    assert run(existing(tmp_path / "early.db")) == [False, True]
    monkeypatch.setattr(sqlite_writer, "LOCK_BOUND_S", 0)
    assert run(existing(tmp_path / "staged.db")) == [False, False]
    early, staged = content(str(tmp_path / "early.db")), content(str(tmp_path / "staged.db"))
    assert len(early["rebond"]) == end and early == staged


@pytest.mark.parametrize("scene", runs(), ids=["mixture, all", "custom species"])
def test_a_new_files_first_run_goes_in_from_its_first_chunk_and_keeps_no_copy(tmp_path, monkeypatch, scene):
    """A new database's first run (its private file, nobody else's lock): the early insert from
    the first chunk, with no bound; past staging.MEMORY_ROWS the stage drops its copy instead of
    spilling it to a scratch file (no scratch file, no second insert at the commit). The database
    is the one the staged way gives, row for row."""
    monkeypatch.setattr(staging, "MEMORY_ROWS", 700)  # 3000 rows in 3 chunks: dropped at the first
    forbid(monkeypatch, staging, "_ScratchWriter")
    forbid(monkeypatch, staging, "move_in")
    with writer.open_for_writing(str(tmp_path / "direct.db")) as opened:
        assert write(opened, scene) == 1
    monkeypatch.undo()
    monkeypatch.setattr(staging, "MEMORY_ROWS", 700)
    monkeypatch.setattr(sqlite_writer, "LOCK_BOUND_S", 0)  # the staged way: a scratch file, moved in
    with writer.open_for_writing(str(tmp_path / "staged.db")) as opened:
        assert write(opened, scene) == 1
    direct, staged = content(str(tmp_path / "direct.db")), content(str(tmp_path / "staged.db"))
    assert len(direct["rebond"]) == 3000 and direct == staged
    assert sorted(p.name for p in tmp_path.iterdir()) == ["direct.db", "staged.db"]


def test_two_new_files_first_runs_past_the_memory_bound_both_land(tmp_path, monkeypatch):
    """Two writers of one new file, each run's copy dropped past MEMORY_ROWS: the second to commit
    cannot take the name, and copies its run from its private file (a second name of it) into the
    database the first made, under its own SIMULATION number and its species' PA_NUM there (the
    custom species is PARTICULE row 20 in its private file, 21 in the database, after the first
    run's own). Both databases are what the staged way gives."""
    monkeypatch.setattr(staging, "MEMORY_ROWS", 700)
    forbid(monkeypatch, staging, "_ScratchWriter")
    first_scene, second_scene = runs()[1], replace(runs()[1], seed=5, components=((Species("Y", 4e-26, 2e-10), 30),))
    db = tmp_path / "new.db"
    first, second = writer.open_for_writing(str(db)), writer.open_for_writing(str(db))
    with first:
        assert write(first, first_scene) == 1
    with second:
        assert write(second, second_scene) == 2
    monkeypatch.undo()
    with writer.open_for_writing(str(tmp_path / "staged.db")) as opened:
        assert [write(opened, s) for s in (first_scene, second_scene)] == [1, 2]
    found, expected = content(str(db)), content(str(tmp_path / "staged.db"))
    assert len(found["rebond"]) == 6000 and found == expected
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.db", "staged.db"]
