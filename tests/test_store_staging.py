"""SQLite staging: rows kept in memory, or spilled to a scratch file past a bound, reach
the database identical either way; ``--record none`` stages nothing."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import random_rows

from gaz_cli.run import runner
from gaz_cli.results import staging
from gaz_cli.results import store as st
from gaz_cli.model.recording import RunStats
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import BUILTIN, lookup


def mixture(record="all"):
    return Scene(dim=2, length=1e-7, duration=1e-10, seed=3, record=record,
                 components=((lookup("Ar"), 20), (lookup("He"), 10)))


def write(db, scene, seen, k=5000, chunks=4):
    """Write k random bounces and collisions in chunks; note whether a scratch file existed."""
    (t, particle, wall, speed, vperp), (i, j, imp) = random_rows(scene, k, 11)
    st.Store(db).close()  # an existing file: a new one's first run is not staged (0295d95)
    with st.Store(db) as store:
        with store.simulation(scene) as w:
            for part in np.array_split(np.arange(k), chunks):
                w.add_bounces(t[part], particle[part], wall[part], speed[part], vperp[part])
                w.add_collisions(t[part], i[part], j[part], imp[part])
            seen.append(w.stage.path is not None and w.stage.path.exists())
            w.finish(RunStats(2 * k, k, k, 0.1, initial_state(scene)), 1.0, 1.0)
        return (store.table(st.rebond, w.si_num).sort_values("RE_NUM").reset_index(drop=True),
                store.table(st.choc, w.si_num).sort_values("CH_NUM").reset_index(drop=True),
                scene.kinds()[particle])


@pytest.mark.parametrize("species", ["mixture", "one species"])
def test_memory_and_scratch_file_give_the_same_rows(tmp_path, monkeypatch, species):
    """The same run staged in memory and spilled to a scratch file (after its first chunk)
    gives the same rows; PA_NUM is each particle's species row in both."""
    scene = mixture() if species == "mixture" else replace(mixture(), components=((lookup("Ar"), 30),))
    seen = []
    in_memory = write(str(tmp_path / "a.db"), scene, seen)
    monkeypatch.setattr(staging, "MEMORY_ROWS", 2000)
    spilled = write(str(tmp_path / "b.db"), scene, seen)
    assert seen == [False, True]
    for a, b in zip(in_memory[:2], spilled[:2]):
        assert len(a) == 5000 and a.equals(b)
    rows, _, kinds = in_memory
    names = [s.name for s in scene.species]
    pa = {n: list(BUILTIN).index(n) + 1 for n in names}
    assert np.array_equal(rows.PA_NUM.to_numpy(), np.array([pa[names[k]] for k in kinds]))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.db", "b.db"]  # no scratch file left


def test_record_none_stages_nothing(tmp_path, monkeypatch):
    """--record none: the engine hands no bounce to the store, nothing is staged, no scratch
    file is made; the run's summary rows are stored."""
    def refuse(*args):
        raise AssertionError("rows staged with --record none")

    monkeypatch.setattr(staging.Stage, "add", refuse)
    monkeypatch.setattr(staging, "MEMORY_ROWS", 0)  # any row would spill to a file
    scene = Scene(dim=3, length=3.4e-8, duration=1e-11, seed=1, components=((lookup("Ar"), 100),),
                  record="none")
    out = runner.simulate(scene, db=str(tmp_path / "g.db"))
    assert out["wall_bounces"] > 0 and out["si_num"] == 1
    with st.Store(str(tmp_path / "g.db")) as store:
        assert len(store.table(st.rebond)) == 0 and len(store.table(st.resultat)) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.db"]


@pytest.mark.parametrize("name, other", [("run[1].db", "run1.db"), ("a?.db", "ab.db")])
def test_stale_scratch_files_of_this_database_are_removed_and_no_other(tmp_path, name, other):
    """remove_stale globbed the database's name as a pattern: beside 'run[1].db' its own scratch
    file left by a dead process was never removed ('[1]' matched '1'), and 'a?.db' matched the
    scratch files of 'ab.db'. Now the name is a name: its dead process's file goes, the other
    database's stays, as does a live process's."""
    import os

    dead = 2 ** 22 + 12345  # beyond Linux's pid_max of 4194304: no such process
    mine = tmp_path / f".{name}.{dead}.x{staging.SUFFIX}"
    theirs = tmp_path / f".{other}.{dead}.x{staging.SUFFIX}"
    alive = tmp_path / f".{name}.{os.getppid()}.x{staging.SUFFIX}"
    for path in (mine, theirs, alive):
        path.write_text("rows")
    staging.remove_stale(tmp_path / name)
    assert not mine.exists() and theirs.exists() and alive.exists()



@pytest.mark.parametrize("fault", ["scratch insert fails", "interrupted"])
def test_a_spilled_run_that_fails_leaves_nothing_and_says_so(tmp_path, monkeypatch, fault):
    """The scratch file is written by a thread of its own (staging._ScratchWriter): its failure
    (a full disk) stops the run with one StoreError line, and an interrupt while it writes
    stops it too; either way nothing is stored, the thread is gone and no scratch file is left,
    and the database takes the next run."""
    import sqlite3
    import threading

    from gaz_cli.errors import Interrupted, StoreError

    db = str(tmp_path / "g.db")
    scene = Scene(dim=3, length=3.4e-8, duration=4e-10, seed=1, components=((lookup("Ar"), 1000),))
    assert runner.simulate(scene, db=db)["si_num"] == 1  # an existing database, in WAL
    monkeypatch.setattr(staging, "MEMORY_ROWS", 1000)  # this run's ~7 thousand bounces spill
    insert_rows = staging.insert_rows

    def failing(conn, table, *args, **kw):  # the scratch file's disk full, not the database's
        if threading.current_thread().name == "gaz-scratch":
            raise sqlite3.OperationalError("database or disk is full")
        return insert_rows(conn, table, *args, **kw)

    if fault == "scratch insert fails":
        monkeypatch.setattr(staging, "insert_rows", failing)
        with pytest.raises(StoreError, match="full"):
            runner.simulate(scene, db=db)
    else:
        def interrupted(*args, **kwargs):  # a SIGINT after the engine, the scratch file written
            raise Interrupted(2)
        monkeypatch.setattr(runner, "run_pressure", interrupted)
        with pytest.raises(Interrupted):
            runner.simulate(scene, db=db)
        monkeypatch.undo()
    assert not any(t.name == "gaz-scratch" for t in threading.enumerate())
    assert sorted(p.name for p in tmp_path.iterdir() if "staging" in p.name) == []
    monkeypatch.setattr(staging, "insert_rows", insert_rows)
    assert runner.simulate(scene, db=db)["si_num"] == 2
