"""The store: schema of the exam, bulk writes, atomic simulations, packaged SQL,
schema versions, foreign databases and one-line errors -- on SQLite and on a real
PostgreSQL server (see backends.py)."""

import re
import shutil
import sqlite3
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np
import pytest
import sqlalchemy as sa

from backends import BACKENDS, backend, postgres_db, postgres_url  # noqa: F401 - fixtures
from gaz_cli.results import store as st
from gaz_cli.errors import StoreError
from gaz_cli.model.recording import RunStats
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import BUILTIN, Species

both = pytest.mark.parametrize("backend", BACKENDS, indirect=True)


def fake_bounces(rng, n_particles, dim, k, duration):
    t = np.sort(rng.random(k) * duration)
    particle = rng.integers(0, n_particles, k)
    axis = rng.integers(0, dim, k)
    wall = (axis + 1) * rng.choice([-1, 1], k)
    vperp = rng.random(k) * 500
    speed = vperp + rng.random(k) * 100
    return t, particle, wall, speed, vperp


def write_fake(store, scene, rng, k=5000, chunks=3):
    state = initial_state(scene)
    arrays = fake_bounces(rng, scene.n, scene.dim, k, scene.duration)
    with store.simulation(scene) as w:
        for part in np.array_split(np.arange(k), chunks):
            w.add_bounces(*(a[part] for a in arrays))
        w.finish(RunStats(k, k, 0, 0.1, state), 1.0, 1.0)
    return w.si_num, arrays


@both
def test_exam_tables_exactly(backend):
    store = st.Store(backend)
    insp = sa.inspect(store.engine)
    cols = {t: [c["name"].upper() for c in insp.get_columns(t)] for t in st.EXAM_TABLES}
    assert cols["simulation"] == ["SI_NUM", "SI_DEB", "SI_DUR", "SI_DIM", "SI_N", "SI_L"]
    assert cols["particule"] == ["PA_NUM", "PA_NOM", "PA_M", "PA_R"]
    assert cols["rebond"] == ["SI_NUM", "RE_NUM", "PA_NUM", "RE_T", "RE_DIR", "RE_VIT", "RE_VP"]
    assert insp.get_pk_constraint("rebond")["constrained_columns"] == ["si_num", "re_num"]
    fks = {fk["referred_table"] for fk in insp.get_foreign_keys("rebond")}
    assert fks == {"simulation", "particule"}
    particles = store.table(st.particule)
    assert list(particles.PA_NOM) == list(BUILTIN)
    ar = particles[particles.PA_NOM == "Ar"].iloc[0]
    assert ar.PA_M == pytest.approx(6.6338e-23, rel=1e-4, abs=0)  # grams


@both
def test_rows_written_and_q36_matches_python(backend, argon_scene, rng):
    store = st.Store(backend)
    scene = argon_scene(dim=3, n=50)
    si, (t, particle, wall, speed, vperp) = write_fake(store, scene, rng)
    rows = store.table(st.rebond, si)
    assert len(rows) == len(t)
    assert list(rows.RE_NUM) == list(range(1, len(t) + 1))
    assert np.allclose(rows.RE_T, t, rtol=1e-15, atol=0) and np.array_equal(rows.RE_DIR, wall)
    q36 = store.query("q36_momentum_per_wall", si_num=si)
    m = BUILTIN["Ar"].mass
    for code, value in zip(q36.RE_DIR, q36.QUANTITE_MOUVEMENT):
        expected = np.sum(2 * m * vperp[wall == code])
        assert value == pytest.approx(expected, rel=1e-12, abs=0)
    pressure = store.query("pressure_per_wall", si_num=si)
    area = scene.length ** 2
    assert np.allclose(pressure.PRESSION, pressure.QUANTITE_MOUVEMENT / (scene.duration * area), rtol=1e-12, atol=0)


@both
def test_failed_run_leaves_nothing(backend, argon_scene, rng):
    store = st.Store(backend)
    scene = argon_scene(dim=2, n=20, length=1e-7)
    write_fake(store, scene, rng)
    with pytest.raises(KeyboardInterrupt):
        with store.simulation(scene) as w:
            w.add_bounces(*fake_bounces(rng, 20, 2, 100, 1.0))
            raise KeyboardInterrupt
    assert store.simulation_numbers() == [1]
    assert len(store.table(st.rebond)) == 5000
    assert len(store.table(st.composition)) == 1


@both
def test_custom_species_gets_one_row(backend, argon_scene):
    """On a fresh database too: the PARTICULE ids come from the database (issue 13: seeding
    with explicit ids left PostgreSQL's sequence at 1, and this run hit a duplicate key)."""
    store = st.Store(backend)
    custom = Species("custom", 2e-26, 1e-10)
    scene = replace(argon_scene(dim=2, n=10, length=1e-7), components=((custom, 10),))
    for _ in range(2):
        with store.simulation(scene) as w:
            w.finish(RunStats(0, 0, 0, 0.0, initial_state(scene)), 0.0, 0.0)
    particles = store.table(st.particule)
    assert (particles.PA_NOM == "custom").sum() == 1


def test_open_errors(tmp_path):
    with pytest.raises(StoreError, match="does not exist"):
        st.Store(str(tmp_path / "missing.db"), create=False)
    junk = tmp_path / "junk.db"
    junk.write_text("hello")
    with pytest.raises(StoreError, match="not a database"):
        st.Store(str(junk), create=False)
    other = tmp_path / "other.db"
    sqlite3.connect(other).execute("CREATE TABLE t (x)").connection.commit()
    with pytest.raises(StoreError, match="not a gaz database"):
        st.Store(str(other), create=False)
    with pytest.raises(StoreError):
        st.Store("nosuchdialect://x/y")


def test_sql_files_are_packaged():
    names = st.query_names()
    assert {"q34_simulations_per_dimension.sql", "q35_bounces_per_simulation.sql",
            "q36_momentum_per_wall.sql", "pressure_per_wall.sql"} <= set(names)


@pytest.mark.skipif(shutil.which("sqlite3") is None, reason="the sqlite3 shell is not installed")
def test_sqlite3_shell_runs_every_file(tmp_path, argon_scene, rng):
    db = tmp_path / "a.db"
    store = st.Store(str(db))
    si, _ = write_fake(store, argon_scene(dim=3, n=50), rng, k=300)
    for name in st.query_names():
        sql_path = tmp_path / name
        sql_path.write_text(st.query_text(name))
        params = [f".param set :{k} {v}" for k, v in dict(si_num=si, re_num=1, lo=1, hi=10**9, pa_num=3, t_lo=0,
                                                           t_hi=1, bins=16, duration=1e-10).items()]
        out = subprocess.run(["sqlite3", "-csv", str(db), *params, f".read {sql_path}"],
                             capture_output=True, text=True, timeout=60)
        assert out.returncode == 0 and not out.stderr, (name, out.stderr)
        assert out.stdout.strip(), name
    q36 = subprocess.run(["sqlite3", "-csv", str(db), f".param set :si_num {si}",
                          f".read {tmp_path / 'q36_momentum_per_wall.sql'}"], capture_output=True, text=True)
    assert len(q36.stdout.strip().splitlines()) == 6  # six walls in 3D


@both
def test_every_packaged_query_runs(backend, argon_scene, rng):
    """The SQL files are valid on both backends and return rows on a database with one run."""
    store = st.Store(backend)
    scene = argon_scene(dim=3, n=50)
    si, _ = write_fake(store, scene, rng, k=300)
    # CAST truncates on SQLite and rounds on PostgreSQL: the binned queries take the shift
    params = {"si_num": si, "duration": scene.duration, "bins": 16,
              "half": 0.5 if store.engine.dialect.name == "postgresql" else 0.0,
              "re_num": 1, "lo": 1, "hi": 10**9, "pa_num": 3, "t_lo": 0.0, "t_hi": scene.duration}
    for name in st.query_names():
        text = st.query_text(name)
        frame = store.read_sql(text, **{k: v for k, v in params.items() if f":{k}" in text})
        assert len(frame) > 0, name
    store.close()


@both
def test_same_rows_on_both_backends(backend, argon_scene, rng, tmp_path):
    """The rows read back are the rows written, to the last bit, whichever the backend."""
    store = st.Store(backend)
    si, (t, particle, wall, speed, vperp) = write_fake(store, argon_scene(dim=2, n=30, length=1e-7), rng, k=2000)
    rows = store.table(st.rebond, si).sort_values("RE_NUM")
    assert np.array_equal(rows.RE_T.to_numpy(), t) and np.array_equal(rows.RE_VP.to_numpy(), vperp)
    assert np.array_equal(rows.RE_VIT.to_numpy(), speed) and np.array_equal(rows.RE_DIR.to_numpy(), wall)
    assert set(rows.PA_NUM) == {list(BUILTIN).index("Ar") + 1}
    store.close()


def test_readers_read_while_a_writer_writes(tmp_path, argon_scene, rng, monkeypatch):
    """WAL: a reader is not blocked by a writer, even one whose transaction has spilled to
    the file (in the rollback journal mode, that writer holds an exclusive lock)."""
    db = tmp_path / "a.db"
    store = st.Store(str(db))
    write_fake(store, argon_scene(dim=2, n=20, length=1e-7), rng)
    store.close()
    st.Store(str(db)).close()  # the next writer puts it in WAL (its first run was in the rollback journal)
    writer = sqlite3.connect(db, isolation_level=None)
    writer.execute("PRAGMA cache_size = 1")
    writer.execute("BEGIN IMMEDIATE")
    writer.executemany("INSERT INTO rebond VALUES (1, ?, 1, 0.0, 1, 1.0, 1.0)",
                       [(k,) for k in range(10_000, 60_000)])
    monkeypatch.setattr(st, "BUSY_TIMEOUT_S", 0.1)
    try:
        reader = st.Store(str(db), create=False)
        assert len(reader.table(st.rebond)) == 5000  # the committed rows, not the writer's
        reader.close()
    finally:
        writer.execute("ROLLBACK")
        writer.close()


# --- schema versions ----------------------------------------------------------------
def _version_1(db: str) -> None:
    """A database as gaz wrote it before schema versions: the same tables but SCHEMA_VERSION,
    PARTICULE seeded with explicit ids (so PostgreSQL's sequence stays at 1), one simulation."""
    engine = sa.create_engine(st.url_for(db))
    old = sa.MetaData()  # the layout of version 1: no column added since
    with engine.begin() as conn:
        for table in st.metadata.sorted_tables:
            if table is not st.schema_version:
                sa.Table(table.name, old, *[
                    sa.Column(c.name, c.type, *[sa.ForeignKey(fk.target_fullname) for fk in c.foreign_keys],
                              primary_key=c.primary_key, nullable=c.nullable, autoincrement=c.autoincrement)
                    for c in table.columns if c.info.get("since", 1) == 1]).create(conn)
        conn.execute(st.particule.insert(), [
            {"pa_num": k + 1, "pa_nom": s.name, "pa_m": s.mass_g, "pa_r": s.radius}
            for k, s in enumerate(BUILTIN.values())])
        conn.execute(st.simulation.insert().values(si_num=1, si_deb=sa.func.current_timestamp(),
                                                   si_dur=1.0, si_dim=2, si_n=3, si_l=1.0))
    engine.dispose()


@both
def test_version_1_is_migrated_forward(backend, argon_scene):
    _version_1(backend)
    reader = st.Store(backend, create=False)
    assert reader.schema_version() == 1  # reading does not migrate
    reader.close()
    store = st.Store(backend)
    assert store.schema_version() == st.latest_version(store.engine.dialect.name)
    custom = Species("custom", 2e-26, 1e-10)
    scene = replace(argon_scene(dim=2, n=10, length=1e-7), components=((custom, 10),))
    with store.simulation(scene) as w:  # PostgreSQL: needs the sequences moved past the rows
        w.finish(RunStats(0, 0, 0, 0.0, initial_state(scene)), 0.0, 0.0)
    assert w.si_num == 2 and store.simulation_numbers() == [1, 2]
    particles = store.table(st.particule)
    assert int(particles[particles.PA_NOM == "custom"].PA_NUM.iloc[0]) == len(BUILTIN) + 1
    # the columns of version 3 were added: the new run fills them
    assert store.table(st.composition, 2).CO_RANK.tolist() == [0]
    assert store.table(st.profil).empty  # the table of version 7, empty (this run records no profile)
    store.close()


@both
def test_species_rank_maps_particles_to_species(backend, argon_scene):
    """COMPOSITION.CO_RANK is the species' block in the scene, whatever its PA_NUM."""
    store = st.Store(backend)
    helium, argon = BUILTIN["He"], BUILTIN["Ar"]
    scene = replace(argon_scene(dim=2, n=10, length=1e-7), components=((argon, 3), (helium, 7)))
    with store.simulation(scene) as w:
        w.finish(RunStats(0, 0, 0, 0.0, initial_state(scene)), 0.0, 0.0)
    comp = store.table(st.composition, w.si_num).sort_values("CO_RANK")
    names = store.table(st.particule).set_index("PA_NUM").PA_NOM
    assert [names[k] for k in comp.PA_NUM] == ["Ar", "He"] and comp.CO_N.tolist() == [3, 7]
    store.close()


@both
def test_newer_version_is_refused(backend):
    st.Store(backend).close()
    engine = sa.create_engine(st.url_for(backend))
    newer = st.latest_version(engine.dialect.name) + 1
    with engine.begin() as conn:
        conn.execute(st.schema_version.update().values(sv_version=newer))
    engine.dispose()
    for create in (True, False):
        with pytest.raises(StoreError, match=f"schema version {newer}, newer than"):
            st.Store(backend, create=create)


# --- foreign databases --------------------------------------------------------------
FOREIGN = ["CREATE TABLE simulation (id INTEGER PRIMARY KEY, name TEXT)",
           "CREATE TABLE particule (id INTEGER PRIMARY KEY, label TEXT)",
           "CREATE TABLE rebond (id INTEGER PRIMARY KEY, t REAL)",
           "INSERT INTO simulation VALUES (1, 'theirs')"]


@pytest.mark.parametrize("db", [":memory:", "sqlite://", "sqlite:///:memory:"])
def test_a_sqlite_database_in_memory_is_refused_for_writing(db):
    """gaz simulate --db :memory: (or sqlite://) took the PostgreSQL writer and ended in
    "database ':memory:': no such function: current_setting", naming no fix."""
    with pytest.raises(StoreError) as err:
        st.Store(db)
    assert "in memory" in str(err.value) and "--no-db" in str(err.value) and "\n" not in str(err.value)


def test_foreign_sqlite_file_is_refused_and_untouched(tmp_path):
    path = tmp_path / "theirs.db"
    con = sqlite3.connect(path)
    for sql in FOREIGN:
        con.execute(sql)
    con.commit()
    con.close()
    before = path.read_bytes()
    with pytest.raises(StoreError) as err:
        st.Store(str(path))
    assert "not a gaz database: its table SIMULATION has columns (ID, NAME)" in str(err.value)
    assert "\n" not in str(err.value) and "nothing was written" in str(err.value)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["theirs.db"]  # no journal, no scratch file


@pytest.mark.postgres
def test_foreign_postgres_schema_is_refused_and_untouched(postgres_db):
    engine = sa.create_engine(postgres_db)
    with engine.begin() as conn:
        for sql in FOREIGN:
            conn.exec_driver_sql(sql)
    with pytest.raises(StoreError, match="not a gaz database: its table SIMULATION has columns"):
        st.Store(postgres_db)
    assert sorted(sa.inspect(engine).get_table_names()) == ["particule", "rebond", "simulation"]
    engine.dispose()


# --- concurrent creation ------------------------------------------------------------
@both
def test_concurrent_first_opens_create_one_schema(backend):
    """Processes opening the same new database at once all succeed, and the database
    gets one schema: one version row, the built-in species once. (Eight: on a loaded host
    8 processes failed in 2 rounds of 30 before sqlite_writer.use_wal waited, in 0 of 40 after.)"""
    # each process imports first, then all open at the same instant
    code = ("import sys, time; from gaz_cli.results.store import Store; "
            "time.sleep(max(0.0, float(sys.argv[2]) - time.time())); Store(sys.argv[1]).close()")
    start = str(time.time() + 4.0)
    procs = [subprocess.Popen([sys.executable, "-c", code, backend, start], stderr=subprocess.PIPE, text=True)
             for _ in range(8)]
    errors = [p.communicate(timeout=120)[1] for p in procs]
    assert [p.returncode for p in procs] == [0] * 8, errors
    store = st.Store(backend, create=False)
    assert len(store.table(st.schema_version)) == 1
    assert list(store.table(st.particule).PA_NOM) == list(BUILTIN)
    store.close()


# --- one-line errors ------------------------------------------------------------------
def test_unreachable_server_is_one_line_without_password():
    with pytest.raises(StoreError) as err:
        st.Store("postgresql://gaz:s3cret@127.0.0.1:1/gaz")
    message = str(err.value)
    assert message.startswith("cannot connect to database 'postgresql://gaz:***@127.0.0.1:1/gaz'")
    assert "s3cret" not in message and "\n" not in message


def test_missing_driver_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "psycopg", None)  # import psycopg -> ImportError
    with pytest.raises(StoreError, match=r"needs the psycopg driver; pip install 'gaz\[postgres\]'"):
        st.Store("postgresql://gaz:s3cret@127.0.0.1:1/gaz")


@pytest.mark.parametrize("url, says", [
    ("mysql://gaz:s3cret@127.0.0.1:1/gaz", "SQLite files and PostgreSQL servers, not mysql"),
    ("postgresql+pg8000://gaz:s3cret@127.0.0.1:1/gaz", "through psycopg 3 (binary COPY), not pg8000")])
def test_other_backends_and_drivers_are_refused_before_connecting(url, says):
    """Only SQLite and PostgreSQL through psycopg: what the schema, the SQL files and the
    writers are made and tested for; refused in one line, nothing touched."""
    with pytest.raises(StoreError, match=re.escape(says)) as err:
        st.Store(url)
    assert "s3cret" not in str(err.value) and "\n" not in str(err.value)


def test_read_only_database_is_one_line(tmp_path, argon_scene, rng):
    path = tmp_path / "a.db"
    store = st.Store(str(path))
    write_fake(store, argon_scene(dim=2, n=20, length=1e-7), rng, k=100)
    store.close()
    read_only = f"sqlite:///file:{path}?mode=ro&uri=true"
    with pytest.raises(StoreError, match="is read-only .*; make it and its folder writable"):
        writer = st.Store(read_only)
        write_fake(writer, argon_scene(dim=2, n=20, length=1e-7), rng, k=100)
    assert st.Store(str(path), create=False).simulation_numbers() == [1]


def test_a_failing_query_is_one_line_without_its_sql(tmp_path, argon_scene, rng):
    """pandas wraps a driver's error in a message quoting the whole SQL text over many lines;
    the store's error is the driver's own reason, on one line."""
    store = st.Store(str(tmp_path / "gaz.db"))
    with pytest.raises(StoreError) as info:
        store.read_sql("-- a comment line\nSELECT no_such_column FROM simulation")
    store.close()
    message = str(info.value)
    assert "\n" not in message and "SELECT" not in message and "no_such_column" in message


@pytest.mark.postgres
def test_a_connection_lost_mid_run_is_one_store_error(postgres_db, postgres_url, argon_scene, rng):
    """The server drops a run's connection while its rows stream in (restarted, stopped, an
    administrator's pg_terminate_backend): the run fails with one StoreError line, not the
    driver's error from rolling back on a connection that is gone (which the CLI printed as
    'internal error: OperationalError ... the connection is lost'); the run leaves nothing."""
    scene = argon_scene(dim=3, n=20)
    tag = f"gaz_lost_{rng.integers(1 << 30)}"  # this test's connections, and no one else's
    db = sa.make_url(postgres_db).update_query_dict({"application_name": tag}).render_as_string(False)
    admin = sa.create_engine(postgres_url)
    st.Store(postgres_db).close()  # a gaz database (a new one is left without a table)
    store = st.Store(db)
    try:
        with pytest.raises(StoreError, match="^lost the connection to database '") as err:
            with store.simulation(scene) as w:
                w.add_bounces(*fake_bounces(rng, scene.n, scene.dim, 100, scene.duration))
                with admin.begin() as conn:
                    killed = conn.exec_driver_sql(
                        "SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity "
                        f"WHERE application_name = '{tag}'").scalar()
                assert killed >= 1
                w.add_bounces(*fake_bounces(rng, scene.n, scene.dim, 100, scene.duration))
                w.finish(RunStats(200, 200, 0, 0.1, initial_state(scene)), 1.0, 1.0)
        assert "\n" not in str(err.value)
    finally:
        store.close()
        admin.dispose()
    with st.Store(postgres_db, create=False) as reader:
        assert reader.simulation_numbers() == []
        with reader.engine.connect() as conn:  # the run's own REBOND table went with its transaction
            assert sa.inspect(conn).get_table_names().count("rebond_1") == 0


@pytest.mark.postgres
def test_a_postgres_url_is_postgresql(postgres_db, argon_scene, rng):
    """``postgres://``, libpq's other spelling of ``postgresql://`` (psql, Heroku, many hosts'
    DATABASE_URL), opens the server (it was refused: 'gaz writes to SQLite files and PostgreSQL
    servers, not postgres')."""
    url = sa.make_url(postgres_db).set(drivername="postgres").render_as_string(hide_password=False)
    assert url.startswith("postgres://")
    with st.Store(url) as store:
        si, _ = write_fake(store, argon_scene(dim=2, n=20, length=1e-7), rng, k=100)
    with st.Store(postgres_db, create=False) as reader:
        assert reader.simulation_numbers() == [si] and len(reader.table(st.rebond, si)) == 100


@pytest.mark.postgres
@pytest.mark.parametrize("how, says", [
    ("role", r"refuses this role \(permission denied for table \w+\); ask the database's owner"),
    ("read-only", r"takes no writes \(.*read-only transaction\): a standby, or default_transaction_read_only")],
    ids=["select-only role", "read-only session"])
def test_a_server_that_refuses_writes_says_why_in_its_terms(postgres_db, postgres_url, argon_scene, rng,
                                                            how, says):
    """A role granted SELECT alone, a read-only session: the refusal names the server's reason
    and its fix, not a file's (it said 'cannot open database ... (permission denied for table
    simulation); check that its folder exists and is writable'); nothing is written."""
    import uuid

    st.Store(postgres_db).close()
    url = sa.make_url(postgres_db)
    schema = url.query["options"].split("=", 1)[1]
    role = f"gaz_reader_{uuid.uuid4().hex[:12]}"
    admin = sa.create_engine(postgres_url)
    if how == "role":
        with admin.begin() as conn:
            conn.exec_driver_sql(f"CREATE ROLE {role} LOGIN NOSUPERUSER")
            conn.exec_driver_sql(f"GRANT USAGE ON SCHEMA {schema} TO {role}")
            conn.exec_driver_sql(f"GRANT SELECT ON ALL TABLES IN SCHEMA {schema} TO {role}")
        url = url.set(username=role, password=None)
    else:
        url = url.update_query_dict({"options": f"{url.query['options']} -cdefault_transaction_read_only=on"})
    try:
        with pytest.raises(StoreError, match=says) as err:
            with st.Store(url.render_as_string(hide_password=False)) as store:
                write_fake(store, argon_scene(dim=2, n=20, length=1e-7), rng, k=100)
        assert "folder" not in str(err.value) and "\n" not in str(err.value)
        with st.Store(postgres_db, create=False) as reader:
            assert reader.simulation_numbers() == []
    finally:
        if how == "role":
            with admin.begin() as conn:
                conn.exec_driver_sql(f"DROP OWNED BY {role}")
                conn.exec_driver_sql(f"DROP ROLE {role}")
        admin.dispose()


@pytest.mark.postgres
def test_a_signal_stops_a_commit_waiting_for_a_lock(postgres_db, postgres_url, argon_scene, rng):
    """Another session holds a lock the run's commit needs (an administrator's LOCK TABLE, a
    long migration): SIGINT stops the waiting commit at once and stores nothing. (The whole
    commit was held against signals: the run waited for the lock however long, and was then
    stored; only the COMMIT itself needs holding, what comes before is inside the run's
    transaction and rolls back whole.)"""
    import os
    import signal
    import threading

    from gaz_cli import interrupts
    from gaz_cli.errors import Interrupted

    scene = argon_scene(dim=3, n=20)
    tag = f"gaz_wait_{rng.integers(1 << 30)}"
    db = sa.make_url(postgres_db).update_query_dict({"application_name": tag}).render_as_string(False)
    locker = sa.create_engine(postgres_db).connect()
    admin = sa.create_engine(postgres_url)
    released, signalled, done = threading.Event(), threading.Event(), threading.Event()

    def interrupt_the_wait():
        # SIGINT once the writer's session waits for a lock; the lock is given back only
        # after a bound, which only a commit that ignores the signal reaches
        with admin.connect() as conn:
            while not signalled.is_set() and not done.is_set():
                if conn.exec_driver_sql("SELECT count(*) FROM pg_stat_activity WHERE application_name = "
                                        f"'{tag}' AND wait_event_type = 'Lock'").scalar():
                    os.kill(os.getpid(), signal.SIGINT)
                    signalled.set()
                conn.rollback()
        if not done.wait(30):
            released.set()
            locker.rollback()

    helper = threading.Thread(target=interrupt_the_wait, daemon=True)
    st.Store(postgres_db).close()  # a gaz database (a new one is left without a table)
    store = st.Store(db)
    try:
        with interrupts.catching(), pytest.raises(Interrupted):
            try:
                with store.simulation(scene) as w:
                    w.add_bounces(*fake_bounces(rng, scene.n, scene.dim, 100, scene.duration))
                    w.finish(RunStats(100, 100, 0, 0.1, initial_state(scene)), 1.0, 1.0)
                    locker.exec_driver_sql("LOCK TABLE simulation IN ACCESS EXCLUSIVE MODE")
                    helper.start()
            finally:
                done.set()
                helper.join()
        assert signalled.is_set() and not released.is_set()  # stopped while the lock was held
    finally:
        locker.rollback()
        locker.close()
        store.close()
        admin.dispose()
    with st.Store(postgres_db, create=False) as reader:
        assert reader.simulation_numbers() == []
        with reader.engine.connect() as conn:
            assert [t for t in sa.inspect(conn).get_table_names() if t.startswith("rebond_")] == ["rebond_default"]


def test_a_password_given_as_a_url_parameter_is_hidden_too():
    """libpq takes the password as ``?password=`` too: it was printed whole ('cannot connect to
    database 'postgresql://gaz@127.0.0.1:1/gaz?password=s3cret': ...'); and the query is shown
    as written, not percent-encoded (host=%2Ftmp%2Fpg)."""
    for url in ("postgresql://gaz@127.0.0.1:1/gaz?password=s3cret&connect_timeout=3",
                "postgresql://gaz@/gaz?host=/nonexistent/gaz-socket&PASSWORD=s3cret",
                "postgresql://gaz@/gaz?host=/nonexistent/gaz-socket&sslpassword=s3cret"):
        with pytest.raises(StoreError) as err:
            st.Store(url)
        message = str(err.value)
        assert "s3cret" not in message and "\n" not in message, message
        assert "password=***" in message.lower(), message
    assert "host=/nonexistent/gaz-socket" in message


@pytest.mark.postgres
def test_a_postgres_schema_of_another_application_is_refused_and_untouched(postgres_db):
    """A schema holding another application's tables and none of gaz's is refused, as such a
    SQLite file is (gaz added its nine tables and their rows beside the others' own); a
    schema of its own (search_path) is the fix the message gives."""
    engine = sa.create_engine(postgres_db)
    with engine.begin() as conn:
        conn.exec_driver_sql("CREATE TABLE orders (id INTEGER PRIMARY KEY, item TEXT)")
        conn.exec_driver_sql("INSERT INTO orders VALUES (1, 'theirs')")
    with pytest.raises(StoreError, match=r"is not a gaz database: its schema gaz_test_\w+ holds other tables "
                                         r"\(orders\) and none of gaz's; nothing was written") as err:
        st.Store(postgres_db)
    assert "search_path" in str(err.value) and "\n" not in str(err.value)
    assert sa.inspect(engine).get_table_names() == ["orders"]
    with engine.connect() as conn:
        assert conn.exec_driver_sql("SELECT item FROM orders").all() == [("theirs",)]
    engine.dispose()


def test_a_url_is_shown_as_written():
    """A URL's query in messages reads as the user wrote it: spaces, '=' and '/' in values
    (a server's options, a socket folder), not SQLAlchemy's encoding of them ('options=-csearch_path%3Dx+-cy%3D1')."""
    url = "postgresql://gaz@/gaz?host=/nonexistent/gaz-socket&options=-csearch_path%3Dx%20-cstatement_timeout%3D5"
    with pytest.raises(StoreError) as err:
        st.Store(url)
    assert "'postgresql://gaz@/gaz?host=/nonexistent/gaz-socket&options=-csearch_path=x -cstatement_timeout=5'" \
        in str(err.value), str(err.value)


@pytest.mark.postgres
def test_a_server_error_is_its_message_without_the_sql_it_quotes(postgres_db, postgres_url):
    """A role that may not create tables in the schema (PostgreSQL 15's default for the public
    schema) on a new database: one line with the server's message, without the lines of SQL
    PostgreSQL quotes after it ('permission denied for schema public LINE 2: CREATE TABLE
    simulation ( ^')."""
    import uuid

    schema = sa.make_url(postgres_db).query["options"].split("=", 1)[1]
    role = f"gaz_guest_{uuid.uuid4().hex[:12]}"
    admin = sa.create_engine(postgres_url)
    with admin.begin() as conn:
        conn.exec_driver_sql(f"CREATE ROLE {role} LOGIN NOSUPERUSER")
        conn.exec_driver_sql(f"GRANT USAGE ON SCHEMA {schema} TO {role}")
    guest = sa.make_url(postgres_db).set(username=role, password=None).render_as_string(hide_password=False)
    try:
        with pytest.raises(StoreError, match=rf"refuses this role \(permission denied for schema {schema}\); ") as err:
            st.Store(guest)
        assert "LINE" not in str(err.value) and "CREATE" not in str(err.value)
    finally:
        with admin.begin() as conn:
            conn.exec_driver_sql(f"DROP OWNED BY {role}")
            conn.exec_driver_sql(f"DROP ROLE {role}")
        admin.dispose()
