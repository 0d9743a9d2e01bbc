"""Migrations: each step takes a gaz database from one schema version to the next.

:data:`MIGRATIONS` maps a version v to the step from v to v + 1; the store runs the steps
from a database's version to :func:`gaz_cli.results.schema.latest_version` of its backend,
inside the transaction that checks the schema (:meth:`gaz_cli.results.store.Store._prepare`:
SQLite's ``BEGIN IMMEDIATE``, PostgreSQL's advisory lock), then writes the new version
row. A step never drops a row; a step of PostgreSQL's layout does nothing on SQLite.
"""

from __future__ import annotations

import sqlalchemy as sa

from gaz_cli.results import postgres
from gaz_cli.results.schema import choc, metadata, particule, profil, rebond, schema_version, simulation


def _v1_to_v2(conn) -> None:
    """1 -> 2: the SCHEMA_VERSION table (and any extra table the database lacks); on
    PostgreSQL, the id sequences moved past the rows seeded with explicit ids (version 1
    left PARTICULE's at 1, so the first custom species collided with PA_NUM 1). SQLite's
    WAL mode is switched on before, outside the transaction."""
    metadata.create_all(conn)
    conn.execute(schema_version.insert().values(sv_version=2))
    if conn.dialect.name == "postgresql":
        for table, column in ((particule, particule.c.pa_num), (simulation, simulation.c.si_num)):
            top = conn.execute(sa.select(sa.func.max(column))).scalar()
            seq = sa.func.pg_get_serial_sequence(table.name, column.name)
            conn.execute(sa.select(sa.func.setval(seq, top or 1, top is not None)))


def _v2_to_v3(conn) -> None:
    """2 -> 3: the columns added in version 3 (SCENE.SC_FILE, COMPOSITION.CO_RANK), NULL
    in the rows already there (their scene file and species order were not stored)."""
    _add_columns(conn, since=3)


def _add_columns(conn, since: int) -> None:
    """ALTER TABLE ... ADD COLUMN for each column of version ``since`` the database lacks."""
    insp = sa.inspect(conn)
    for table in metadata.sorted_tables:
        found = {c["name"].lower() for c in insp.get_columns(table.name)}
        for col in table.columns:
            if col.info.get("since", 1) == since and col.name not in found:
                kind = col.type.compile(dialect=conn.dialect)
                conn.exec_driver_sql(f"ALTER TABLE {table.name} ADD COLUMN {col.name} {kind}")


def _v3_to_v4(conn) -> None:
    """3 -> 4, PostgreSQL only: REBOND becomes partitioned (:func:`gaz_cli.results.postgres._partition`)."""
    postgres._partition(conn, rebond, since=3)


def _v4_to_v5(conn) -> None:
    """4 -> 5, PostgreSQL only: CHOC becomes partitioned (:func:`gaz_cli.results.postgres._partition`)."""
    postgres._partition(conn, choc, since=4)


def _v5_to_v6(conn) -> None:
    """5 -> 6, PostgreSQL only: nothing rewritten; the writer reads each row number's width
    from the database (:func:`gaz_cli.results.postgres._copy_types`)."""


def _v6_to_v7(conn) -> None:
    """6 -> 7 (SQLite from 3: the steps 3 -> 6 do nothing there): the table PROFIL, empty (the
    runs already there recorded no profile)."""
    metadata.create_all(conn, tables=[profil])


MIGRATIONS = {1: _v1_to_v2, 2: _v2_to_v3, 3: _v3_to_v4, 4: _v4_to_v5, 5: _v5_to_v6, 6: _v6_to_v7}
"""Version v -> the step taking a database from v to v + 1, run inside the schema transaction."""
