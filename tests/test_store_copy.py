"""PostgreSQL's bulk path: rows built as binary COPY blocks by numpy reach the tables
bit for bit, for a role that may skip the key triggers and for an ordinary role that
may not (its rows are then checked by the foreign keys, which stay in place)."""

import uuid
from dataclasses import replace

import numpy as np
import pytest
import sqlalchemy as sa

from backends import postgres_url  # noqa: F401 - fixture
from gaz_cli.results import postgres as pg
from gaz_cli.results import store as st
from gaz_cli.errors import StoreError
from gaz_cli.model.recording import RunStats
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import BUILTIN

@pytest.fixture(params=["may skip triggers", "ordinary role"])
def role_db(request, postgres_url):
    """A URL into a fresh schema: as the test server's own role (a superuser), or as a
    new ordinary role owning that schema; both dropped after."""
    tag = uuid.uuid4().hex[:12]
    schema, role = f"gaz_copy_{tag}", f"gaz_plain_{tag}"
    admin = sa.create_engine(postgres_url)
    url = sa.make_url(postgres_url)
    with admin.begin() as conn:
        if request.param == "ordinary role":
            conn.exec_driver_sql(f"CREATE ROLE {role} LOGIN NOSUPERUSER")
            conn.exec_driver_sql(f"GRANT CREATE, CONNECT ON DATABASE {url.database} TO {role}")
            conn.exec_driver_sql(f"CREATE SCHEMA {schema} AUTHORIZATION {role}")
            url = url.set(username=role, password=None)
        else:
            conn.exec_driver_sql(f"CREATE SCHEMA {schema}")
    url = url.update_query_dict({"options": f"-csearch_path={schema}"})
    try:
        yield request.param, url.render_as_string(hide_password=False)
    finally:
        with admin.begin() as conn:
            conn.exec_driver_sql(f"DROP SCHEMA {schema} CASCADE")
            if request.param == "ordinary role":
                conn.exec_driver_sql(f"REVOKE ALL ON DATABASE {url.database} FROM {role}")
                conn.exec_driver_sql(f"DROP ROLE {role}")
        admin.dispose()


@pytest.mark.postgres
def test_rows_and_collisions_arrive_bit_for_bit(role_db, argon_scene):
    """Bounces and collisions of three chunks read back equal to the last bit; the key
    triggers run or not as the role allows; the foreign keys are still there."""
    kind, db = role_db
    rng = np.random.default_rng(7)
    scene = replace(argon_scene(dim=3, n=50), record="all")
    k = 3000
    t = np.sort(rng.random(k)) * scene.duration
    particle = rng.integers(0, scene.n, k)
    wall = (rng.integers(0, 3, k) + 1) * rng.choice([-1, 1], k)
    vperp = rng.random(k) * 500 + 1e-300  # subnormal-free, but far from round numbers
    speed = vperp * (1 + rng.random(k))
    ci, cj = rng.integers(0, scene.n, k), rng.integers(0, scene.n, k)
    impulse = rng.random(k) * 1e-23
    with st.Store(db) as store:
        with store.engine.connect() as conn:
            assert pg._may_skip_key_triggers(conn) == (kind == "may skip triggers")
        with store.simulation(scene) as w:
            for part in np.array_split(np.arange(k), 3):
                w.add_bounces(t[part], particle[part], wall[part], speed[part], vperp[part])
                w.add_collisions(t[part], ci[part], cj[part], impulse[part])
            w.finish(RunStats(2 * k, k, k, 0.1, initial_state(scene)), 1.0, 1.0)
        rows = store.table(st.rebond, w.si_num).sort_values("RE_NUM")
        chocs = store.table(st.choc, w.si_num).sort_values("CH_NUM")
        with store.engine.connect() as conn:
            keys = {fk["referred_table"] for fk in sa.inspect(conn).get_foreign_keys("rebond")}
    assert rows.RE_NUM.tolist() == list(range(1, k + 1))
    for column, expected in (("RE_T", t), ("RE_DIR", wall), ("RE_VIT", speed), ("RE_VP", vperp)):
        assert np.array_equal(rows[column].to_numpy(), expected), column
    assert set(rows.PA_NUM) == {list(BUILTIN).index("Ar") + 1}
    assert np.array_equal(chocs.CH_I.to_numpy(), ci) and np.array_equal(chocs.CH_J.to_numpy(), cj)
    assert np.array_equal(chocs.CH_IMP.to_numpy(), impulse)
    assert keys == {"simulation", "particule"}


def test_a_value_beyond_int4_is_refused_not_wrapped():
    """A COPY block never wraps an integer silently (numpy's cast would)."""
    with pytest.raises(StoreError, match="does not fit PostgreSQL's int4"):
        pg._copy_block([np.array([1, 2 ** 31])], ["int4"])
