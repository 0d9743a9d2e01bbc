"""PostgreSQL's REBOND and CHOC, partitioned by SI_NUM (schemas 4 and 5): one partition
per run and table, attached whole at its commit; the foreign keys still refuse every row that names a SIMULATION or
a PARTICULE that does not exist; concurrent runs commit without waiting on each other
for ever; a database of schema 3 is converted, its rows kept."""

import threading
from dataclasses import replace

import numpy as np
import pytest
import sqlalchemy as sa

from backends import postgres_db, postgres_url  # noqa: F401 - fixtures
from gaz_cli.results import postgres as pg
from gaz_cli.results import store as st
from gaz_cli.errors import StoreError
from gaz_cli.model.recording import RunStats
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import BUILTIN, Species

pytestmark = pytest.mark.postgres


def write(store, scene, k, seed=0, pa_of_particle=None, collisions=0):
    """One run of ``k`` random bounces and ``collisions`` collisions (each in 2 chunks)
    through the store's writer; its SI_NUM."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.random(k)) * scene.duration
    particle = rng.integers(0, scene.n, k)
    wall = (rng.integers(0, scene.dim, k) + 1) * rng.choice([-1, 1], k)
    vperp = rng.random(k) * 500
    with store.simulation(scene) as w:
        if pa_of_particle is not None:
            w._pa_of_particle = pa_of_particle
        for part in np.array_split(np.arange(k), 2):
            if part.size:
                w.add_bounces(t[part], particle[part], wall[part], vperp[part] * 1.5, vperp[part])
        for part in np.array_split(np.arange(collisions), 2):
            if part.size:
                w.add_collisions(part * scene.duration / collisions, part % scene.n, (part + 1) % scene.n,
                                 np.full(part.size, 1e-23))
        w.finish(RunStats(k, k, 0, 0.1, initial_state(scene)), 1.0, 1.0)
    return w.si_num


def partitions(conn, table="rebond") -> set[str]:
    return set(conn.exec_driver_sql(
        f"SELECT inhrelid::regclass::text FROM pg_inherits WHERE inhparent = '{table}'::regclass").scalars())


def test_one_partition_per_run_with_bounces(postgres_db, argon_scene):
    """A run's rows are its own partition of REBOND and of CHOC; a run without bounces or
    collisions adds none; Q35 and the collision bins read them all."""
    with st.Store(postgres_db) as store:
        scene = replace(argon_scene(dim=3, n=20), record="all")
        counts = {write(store, scene, k, seed=k, collisions=k // 2): k for k in (1000, 0, 37)}
        with store.engine.connect() as conn:
            for table in st.PARTITIONED:
                assert partitions(conn, table) == {f"{table}_default"} | {f"{table}_{si}" for si, k in counts.items() if k}
                assert conn.exec_driver_sql(f"SELECT count(*) FROM {table}_default").scalar() == 0
        per_run = store.query("q35_bounces_per_simulation").set_index("SI_NUM").iloc[:, 0].to_dict()
        assert per_run == counts
        for si, k in counts.items():
            bins = store.query("collision_bins", si_num=si, bins=4, duration=scene.duration)
            assert bins.NB_CHOCS.sum() == k // 2


def test_rows_with_unknown_keys_are_refused(postgres_db, argon_scene):
    """Whatever way a row comes in -- the writer's attached partition, an INSERT into
    REBOND (its default partition), a partition attached by hand -- a PA_NUM or an SI_NUM
    with no row of its own is refused; a refused run leaves nothing behind."""
    scene = argon_scene(dim=3, n=20)
    with st.Store(postgres_db) as store:
        good, empty = write(store, scene, 100), write(store, scene, 0)
        with pytest.raises(StoreError, match="foreign key"):
            write(store, scene, 100, pa_of_particle=np.full(scene.n, 9999))
        with store.engine.connect() as conn:
            assert store.simulation_numbers() == [good, empty]
            assert partitions(conn) == {"rebond_default", f"rebond_{good}"}
        row = "(%s, 1000000, %s, 0.5, 1, 2.0, 1.0)"
        with store.engine.begin() as conn, pytest.raises(sa.exc.IntegrityError, match="foreign key"):
            conn.exec_driver_sql(f"INSERT INTO rebond VALUES {row % (good, 9999)}")  # into the run's partition
        for si, pa in ((empty + 100, 1), (empty, 9999)):  # no SIMULATION row; no PARTICULE row
            with store.engine.begin() as conn, pytest.raises(sa.exc.IntegrityError, match="foreign key"):
                conn.exec_driver_sql(f"INSERT INTO rebond VALUES {row % (si, pa)}")  # the default partition
            with store.engine.begin() as conn, pytest.raises(sa.exc.IntegrityError, match="foreign key"):
                conn.exec_driver_sql("CREATE TABLE rebond_by_hand (LIKE rebond)")
                conn.exec_driver_sql(f"INSERT INTO rebond_by_hand VALUES {row % (si, pa)}")
                conn.exec_driver_sql(f"ALTER TABLE rebond ATTACH PARTITION rebond_by_hand "
                                     f"FOR VALUES FROM ({si}) TO ({si + 1})")


def test_concurrent_runs_all_commit(postgres_db, argon_scene):
    """Five writers at once (each run's transaction open while the others commit, two
    with the same new species) all commit, with distinct SI_NUM and all their rows;
    the new species has one PARTICULE row, which both its runs name."""
    custom = Species("custom", 3e-26, 1e-10)
    scenes = [argon_scene(dim=3, n=20, seed=s) for s in range(3)]
    scenes += [replace(scenes[k], components=((custom, 20),)) for k in (0, 1)]
    stores = [st.Store(postgres_db) for _ in scenes]
    barrier, done, errors = threading.Barrier(len(scenes)), {}, []

    def run(k):
        try:
            with stores[k].simulation(scenes[k]) as w:
                w.add_bounces(np.arange(500) * 1e-13, np.arange(500) % 20, np.ones(500, int),
                              np.ones(500), np.ones(500))
                barrier.wait(timeout=60)  # every run's transaction is open here
                w.add_bounces(np.arange(500, 600) * 1e-13, np.arange(100) % 20, np.ones(100, int),
                              np.ones(100), np.ones(100))
                w.finish(RunStats(600, 600, 0, 0.1, initial_state(scenes[k])), 1.0, 1.0)
            done[k] = w.si_num
        except Exception as err:  # noqa: BLE001 - reported below
            errors.append(err)

    try:
        threads = [threading.Thread(target=run, args=(k,)) for k in range(len(scenes))]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=120)
        assert not errors and len(set(done.values())) == len(scenes)
        counts = stores[0].query("q35_bounces_per_simulation").set_index("SI_NUM").iloc[:, 0].to_dict()
        assert counts == {si: 600 for si in done.values()}
        particles = stores[0].table(st.particule)
        (custom_num,) = particles[particles.PA_NOM == "custom"].PA_NUM
        for k in (3, 4):
            assert set(stores[0].table(st.rebond, done[k]).PA_NUM) == {custom_num}
    finally:  # a failed writer must not leave the schema locked for the teardown
        for s in stores:
            s.close()


def _version_3(db: str) -> None:
    """A PostgreSQL database as gaz wrote it at schema 3: REBOND and CHOC plain tables, one
    run's rows."""
    old = sa.MetaData()
    for table in st.metadata.sorted_tables:
        table.to_metadata(old)
    for name in st.PARTITIONED:
        old.tables[name].dialect_options["postgresql"]["partition_by"] = None
    for name, column in (("rebond", "re_num"), ("choc", "ch_num")):
        old.tables[name].c[column].type = sa.Integer()  # 32-bit until schema 6
    engine = sa.create_engine(st.url_for(db))
    with engine.begin() as conn:
        old.create_all(conn)
        conn.execute(st.particule.insert(), [{"pa_nom": s.name, "pa_m": s.mass_g, "pa_r": s.radius}
                                             for s in BUILTIN.values()])
        conn.execute(st.schema_version.insert().values(sv_version=3))
        conn.execute(st.simulation.insert().values(si_num=1, si_deb=sa.func.current_timestamp(),
                                                   si_dur=1.0, si_dim=3, si_n=3, si_l=1.0))
        conn.execute(sa.select(sa.func.setval(sa.func.pg_get_serial_sequence("simulation", "si_num"), 1)))
        conn.execute(st.rebond.insert(), [dict(si_num=1, re_num=k, pa_num=1, re_t=k * 0.1, re_dir=1,
                                               re_vit=2.0, re_vp=1.0) for k in range(1, 11)])
        conn.execute(st.choc.insert(), [dict(si_num=1, ch_num=k, ch_t=k * 0.1, ch_i=0, ch_j=1, ch_imp=1.0)
                                         for k in range(1, 6)])
        assert partitions(conn) == partitions(conn, "choc") == set()
    engine.dispose()


def test_version_3_becomes_partitioned_with_its_rows(postgres_db, argon_scene):
    _version_3(postgres_db)
    with st.Store(postgres_db) as store:
        assert store.schema_version() == st.POSTGRES_SCHEMA_VERSION == 7
        with store.engine.connect() as conn:  # schema 7: the density profile's table, empty
            assert sa.inspect(conn).has_table("profil")
        with store.engine.connect() as conn:  # its rows keep their 32-bit numbers (not rewritten)
            assert pg.narrow_row_numbers(conn) == ("REBOND", "CHOC")
        si = write(store, argon_scene(dim=3, n=20), 50, collisions=20)
        with store.engine.connect() as conn:
            assert partitions(conn) == {"rebond_v3", "rebond_default", f"rebond_{si}"}
            assert partitions(conn, "choc") == {"choc_v4", "choc_default", f"choc_{si}"}
            assert conn.exec_driver_sql("SELECT count(*) FROM rebond_v3").scalar() == 10
            assert conn.exec_driver_sql("SELECT count(*) FROM choc_v4").scalar() == 5
            assert {fk["referred_table"] for fk in sa.inspect(conn).get_foreign_keys("rebond")} \
                == {"simulation", "particule"}
        assert store.table(st.rebond, 1).RE_NUM.tolist() == list(range(1, 11))
        assert len(store.table(st.rebond, si)) == 50
        with store.engine.begin() as conn, pytest.raises(sa.exc.IntegrityError, match="foreign key"):
            conn.exec_driver_sql("UPDATE rebond SET pa_num = 9999 WHERE si_num = 1 AND re_num = 1")


def test_a_role_that_does_not_own_rebond_writes_row_by_row(postgres_db, postgres_url, argon_scene):
    """A role granted INSERT on gaz's tables, but not owning REBOND, may not attach
    partitions: its rows go into REBOND's default partition, checked by the key triggers."""
    import uuid

    role = f"gaz_guest_{uuid.uuid4().hex[:12]}"
    schema = sa.make_url(postgres_db).query["options"].split("=", 1)[1]
    st.Store(postgres_db).close()
    admin = sa.create_engine(postgres_url)
    with admin.begin() as conn:
        conn.exec_driver_sql(f"CREATE ROLE {role} LOGIN NOSUPERUSER")
        conn.exec_driver_sql(f"GRANT USAGE ON SCHEMA {schema} TO {role}")
        conn.exec_driver_sql(f"GRANT SELECT, INSERT ON ALL TABLES IN SCHEMA {schema} TO {role}")
        conn.exec_driver_sql(f"GRANT USAGE ON ALL SEQUENCES IN SCHEMA {schema} TO {role}")
    guest = sa.make_url(postgres_db).set(username=role, password=None).render_as_string(hide_password=False)
    try:
        with st.Store(guest) as store:
            with store.engine.connect() as conn:
                assert not pg._may_attach(conn)
            si = write(store, argon_scene(dim=3, n=20), 300, collisions=40)
            with pytest.raises(StoreError, match="foreign key"):
                write(store, argon_scene(dim=3, n=20), 10, pa_of_particle=np.full(20, 9999))
            assert len(store.table(st.rebond, si)) == 300 and len(store.table(st.choc, si)) == 40
        with admin.connect() as conn:
            conn.exec_driver_sql(f"SET search_path = {schema}")
            assert partitions(conn) == {"rebond_default"} and partitions(conn, "choc") == {"choc_default"}
            assert conn.exec_driver_sql("SELECT count(*) FROM rebond_default").scalar() == 300
    finally:
        with admin.begin() as conn:
            conn.exec_driver_sql(f"DROP OWNED BY {role}")
            conn.exec_driver_sql(f"DROP ROLE {role}")
        admin.dispose()


def test_a_server_timeout_on_idle_transactions_does_not_end_a_run(postgres_db, argon_scene):
    """The run's transaction stays open, idle between chunks, while the engine runs (no chunk
    at all with --record none): a server that ends transactions idle for longer than
    idle_in_transaction_session_timeout (a common policy of managed servers) killed the run's
    session, and the run was lost at its commit ('lost the connection ... (terminating
    connection due to idle-in-transaction timeout)'). The writer lifts the timeout for its
    own transaction; the run is stored."""
    import time

    url = sa.make_url(postgres_db)
    url = url.update_query_dict({"options": f"{url.query['options']} -cidle_in_transaction_session_timeout=200"})
    scene = argon_scene(dim=3, n=20)
    with st.Store(url.render_as_string(hide_password=False)) as store:
        with store.simulation(scene) as w:
            time.sleep(1.0)  # an engine between two chunks: 5 times the server's 0.2 s
            w.add_bounces(np.array([1e-11]), np.array([0]), np.array([1]), np.array([400.0]), np.array([300.0]))
            time.sleep(1.0)
            w.finish(RunStats(1, 1, 0, 0.1, initial_state(scene)), 1.0, 1.0)
        assert store.simulation_numbers() == [w.si_num] and len(store.table(st.rebond, w.si_num)) == 1


def test_row_numbers_past_int32_are_stored(postgres_db, argon_scene):
    """RE_NUM and CH_NUM count a run's bounces and collisions: the README example's gas passes
    2^31 - 1 of them after ~1.2e-4 s simulated (minutes of engine). They were INTEGER (int4) on
    PostgreSQL: such a run failed at that row, after all its computation. Now they are BIGINT
    in a new database; a writer handed row numbers across 2^31 (the run's counters set just
    below it: no 2e9 events) stores them, exact."""
    scene = replace(argon_scene(dim=3, n=20), record="all")
    with st.Store(postgres_db) as store:
        with store.simulation(scene) as w:
            w._n = {"rebond": 2 ** 31 - 2, "choc": 2 ** 32 - 2}  # the rows before, as counted
            w.add_bounces([1e-12, 2e-12, 3e-12], [0, 1, 2], [1, -2, 3], [300.0, 310.0, 320.0],
                          [200.0, 100.0, 50.0])
            w.add_collisions([1e-12, 2e-12], [0, 1], [1, 2], [1e-23, 2e-23])
            w.finish(RunStats(5, 3, 2, 0.1, initial_state(scene)), 1.0, 1.0)
        with store.engine.connect() as conn:
            assert conn.exec_driver_sql("SELECT re_num FROM rebond ORDER BY re_num").scalars().all() == [
                2 ** 31 - 1, 2 ** 31, 2 ** 31 + 1]
            assert conn.exec_driver_sql("SELECT ch_num FROM choc ORDER BY ch_num").scalars().all() == [
                2 ** 32 - 1, 2 ** 32]


def test_a_database_with_32_bit_row_numbers_refuses_a_run_past_them_then_widens(postgres_db, argon_scene):
    """A database made before schema 6 keeps its 32-bit RE_NUM (widening rewrites every row): a
    run estimated past 2^31 - 1 bounces (the README example's gas for 2e-4 s, ~3.6e9) is
    refused at its start, one line naming the ALTER TABLE that widens it, nothing written; a
    short run is stored as before (binary COPY in the database's own int4); once widened as
    the message says, row numbers past 2^31 are stored."""
    from gaz_cli.errors import SceneError

    small = argon_scene(dim=3, n=20)
    with st.Store(postgres_db) as store:
        write(store, small, 10)
        with store.engine.begin() as conn:  # as made by gaz before schema 6
            conn.exec_driver_sql("ALTER TABLE rebond ALTER COLUMN re_num TYPE integer")
        big = argon_scene(dim=3, n=1000, duration=2e-4)
        with pytest.raises(SceneError) as refused:
            with store.simulation(big):
                raise AssertionError("the run was not refused at its start")
        message = str(refused.value)
        assert "\n" not in message and "32-bit" in message and "3.56e+09 wall bounces" in message, message
        with pytest.raises(SceneError, match="ALTER TABLE rebond ALTER COLUMN re_num TYPE bigint"):
            store.check_row_numbers([big])  # what a sweep asks before its cluster starts
        assert write(store, small, 10) == 2
        with store.engine.begin() as conn:
            conn.exec_driver_sql("ALTER TABLE rebond ALTER COLUMN re_num TYPE bigint")
        store.check_row_numbers([big])
        with store.simulation(small) as w:
            w._n["rebond"] = 2 ** 31 - 1
            w.add_bounces([1e-12], [0], [1], [300.0], [200.0])
            w.finish(RunStats(1, 1, 0, 0.1, initial_state(small)), 1.0, 1.0)
        assert store.read_sql("SELECT max(re_num) AS m FROM rebond")["M"][0] == 2 ** 31
        assert store.simulation_numbers() == [1, 2, 3]
