"""The two backends the store's tests run on: a SQLite file and a real PostgreSQL server.

PostgreSQL's URL comes from ``GAZ_TEST_POSTGRES_URL`` (``.ci/run`` starts a
throw-away server and sets it). Without it those tests skip, saying why;
with it set but the server unreachable they skip too, except under ``CI``,
where they fail: CI must not pass by silently testing one backend. Each
PostgreSQL test gets a schema of its own (``search_path``), dropped after.
Deselect them with ``pytest -m "not postgres"``.
"""

from __future__ import annotations

import contextlib
import os
import uuid

import pytest
import sqlalchemy as sa

ENV = "GAZ_TEST_POSTGRES_URL"

BACKENDS = ["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)]
"""For ``@pytest.mark.parametrize("backend", BACKENDS, indirect=True)``."""


@pytest.fixture(scope="session")
def postgres_url():
    """The server's URL, once checked reachable."""
    url = os.environ.get(ENV)
    if not url:
        pytest.skip(f"{ENV} is not set: no PostgreSQL server to test against (.ci/run starts one)")
    try:
        engine = sa.create_engine(url, connect_args={"connect_timeout": 5})
        with engine.connect() as conn:
            conn.exec_driver_sql("SELECT 1")
        engine.dispose()
    except Exception as err:  # noqa: BLE001 - any failure to reach it
        message = f"{ENV} is set but its server does not answer: {' '.join(str(err).split())[:300]}"
        if os.environ.get("CI"):
            pytest.fail(f"CI: {message}", pytrace=False)
        pytest.skip(message)
    return url


@pytest.fixture
def postgres_db(postgres_url):
    """A URL whose tables live in a fresh schema of their own; the schema is dropped after."""
    with fresh_schema(postgres_url) as url:
        yield url


@contextlib.contextmanager
def fresh_schema(postgres_url, prefix: str = "gaz_test"):
    """A URL into a new schema of the server at ``postgres_url`` (``search_path``), dropped after."""
    schema = f"{prefix}_{uuid.uuid4().hex[:12]}"
    admin = sa.create_engine(postgres_url)
    with admin.begin() as conn:
        conn.exec_driver_sql(f"CREATE SCHEMA {schema}")
    url = sa.make_url(postgres_url).update_query_dict({"options": f"-csearch_path={schema}"})
    try:
        yield url.render_as_string(hide_password=False)
    finally:
        with admin.begin() as conn:
            conn.exec_driver_sql(f"DROP SCHEMA {schema} CASCADE")
        admin.dispose()


@pytest.fixture
def backend(request, tmp_path):
    """A ``--db`` value for a new, empty database of the parametrized backend."""
    if request.param == "sqlite":
        return str(tmp_path / "gaz.db")
    return request.getfixturevalue("postgres_db")
