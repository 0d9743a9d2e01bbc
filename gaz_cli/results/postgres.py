"""PostgreSQL's side of the store: a run's rows by binary COPY into a partition of its own,
the advisory locks of creation and of writers, the partitions of schemas 4 and 5.

:class:`PostgresRun` is the PostgreSQL writer of one run (its contract in its docstring);
the SIMULATION, COMPOSITION, SCENE, RESULTAT and PARTICULE rows it writes are those of
:mod:`gaz_cli.results.rows`, as the SQLite writer's are. :class:`gaz_cli.results.store.Store`
opens it (``Store.simulation``), creates or migrates the schema under :data:`SCHEMA_LOCK`,
holds :data:`WRITER_LOCK` shared while open for writing, and calls :func:`unmake` at its
close. Nothing here is used for SQLite.
"""

from __future__ import annotations

import datetime as _dt

import numpy as np
import sqlalchemy as sa
from sqlalchemy import exc as sa_exc

from gaz_cli import interrupts
from gaz_cli.errors import StoreError
from gaz_cli.model.scene import Scene
from gaz_cli.results.budgets import check_row_numbers
from gaz_cli.model.species import Species
from gaz_cli.results import rows
from gaz_cli.results.rows import TableRecorder
from gaz_cli.results.schema import (PARTITIONED, composition, metadata, particule, profil, rebond, resultat,
                                    scene_table, simulation)

SCHEMA_LOCK = 0x67617A  # 'gaz': the advisory lock held while creating or migrating
WRITER_LOCK = 0x67617A57  # 'gazW': held shared by every writing store while open (see unmake)


def unmake(conn) -> None:
    """Drop the tables a store created (a new database) when none of its runs was stored
    (refused, failed, interrupted): the database is left as it was found (Store.close).

    Unless another process may use them: another store open for writing (it holds
    :data:`WRITER_LOCK` shared from before it looks at the schema until it closes: the
    try-lock fails), a reader's transaction holding them past a short lock timeout, or
    a run stored meanwhile (a SIMULATION row). ``conn``: this store's connection holding
    the lock. Interrupts are held over it (a short transaction)."""
    with interrupts.held():
        conn.execute(sa.select(sa.func.pg_advisory_unlock_shared(WRITER_LOCK)))
        conn.commit()
        with conn.begin():
            conn.execute(sa.select(sa.func.pg_advisory_xact_lock(SCHEMA_LOCK)))
            if not conn.execute(sa.select(sa.func.pg_try_advisory_xact_lock(WRITER_LOCK))).scalar():
                return  # another store is open for writing: the tables are its too
            conn.exec_driver_sql("SET LOCAL lock_timeout = '2s'")
            names = [t.name for t in metadata.sorted_tables]
            try:
                with conn.begin_nested():
                    conn.exec_driver_sql(f"LOCK TABLE {', '.join(names)} IN ACCESS EXCLUSIVE MODE")
            except sa_exc.OperationalError:
                return  # a reader's transaction holds them
            if conn.execute(sa.select(sa.func.count()).select_from(simulation)).scalar():
                return
            conn.exec_driver_sql(f"DROP TABLE {', '.join(names)} CASCADE")


def _write_simulation_rows(conn, scene: Scene, started: _dt.datetime, si_num: int | None = None,
                           nums: list[int] | None = None) -> tuple[int, list[int]]:
    """SIMULATION, COMPOSITION and SCENE rows of one run (:mod:`gaz_cli.results.rows`); returns
    SI_NUM and each species' PA_NUM.

    ``si_num``, ``nums``: numbers drawn before (PostgreSQL's attach path); by default the
    database numbers the run, and species are looked up (or added) here."""
    res = conn.execute(simulation.insert().values(
        **rows.simulation_row(scene, started), **({} if si_num is None else {"si_num": si_num})))
    si_num = int(res.inserted_primary_key[0])
    nums = [_pa_num(conn, sp) for sp in scene.species] if nums is None else nums
    conn.execute(composition.insert(), rows.composition_rows(si_num, nums, scene))
    conn.execute(scene_table.insert().values(rows.scene_row(si_num, scene)))
    return si_num, nums


def _pa_num(conn, sp: Species, insert: bool = True) -> int | None:
    """PA_NUM of a species (:func:`gaz_cli.results.rows.species_number`); custom species get a
    row of their own on first use (None instead if not ``insert``)."""
    found = conn.execute(sa.select(particule.c.pa_num, particule.c.pa_m, particule.c.pa_r)
                         .where(particule.c.pa_nom == sp.name).order_by(particule.c.pa_num)).all()
    num = rows.species_number(sp, found)
    if num is not None or not insert:
        return num
    res = conn.execute(particule.insert().values(rows.particule_row(sp)))
    return int(res.inserted_primary_key[0])


def _register_species(engine: sa.Engine, species: list[Species]) -> None:
    """PostgreSQL: give each new species its PARTICULE row before the run, in a short
    transaction of its own, one such transaction at a time (an advisory lock).

    Inside the run's transaction, two runs started together with the same new species
    would each see no row and each add one (READ COMMITTED): two PA_NUM for one
    species. Committed first and in turn, the second finds the first's row. A run that
    fails afterwards leaves its species in the catalogue, as the built-in ones are."""
    with engine.connect() as conn:
        if all(_pa_num(conn, sp, insert=False) is not None for sp in species):
            return
    with engine.begin() as conn:
        conn.exec_driver_sql("SELECT pg_advisory_xact_lock(hashtext('gaz: new species'))")
        for sp in species:
            _pa_num(conn, sp)


_COPY_TYPES = {"int4": ">i4", "int8": ">i8", "float8": ">f8"}
"""PostgreSQL type -> its binary COPY representation (big-endian, fixed width), numpy dtype."""

_COPY_SIGNATURE = b"PGCOPY\n\xff\r\n\0" + bytes(8)  # signature, flags 0, no header extension
_COPY_TRAILER = b"\xff\xff"


def _copy_types(conn, table: sa.Table) -> list[str]:
    """The PostgreSQL types of ``table``'s columns in the database, in the metadata's order, for
    binary COPY (which needs them exact): a database migrated from schema 5 keeps 32-bit row
    numbers where a new one has 64-bit ones (:data:`POSTGRES_SCHEMA_VERSION`)."""
    found = _pg_types(conn, table.name)
    return [found[c.name] for c in table.columns]


def _pg_types(conn, name: str) -> dict[str, str]:
    """PostgreSQL: column name -> type name (int4, int8, float8...) of the table ``name``."""
    return dict(conn.exec_driver_sql(
        "SELECT a.attname, t.typname FROM pg_attribute a JOIN pg_type t ON t.oid = a.atttypid "
        f"WHERE a.attrelid = '{name}'::regclass AND a.attnum > 0 AND NOT a.attisdropped").all())


def narrow_row_numbers(conn) -> tuple[str, ...]:
    """PostgreSQL: the tables among REBOND and CHOC whose row number (RE_NUM, CH_NUM) is a 32-bit
    integer in this database (one made before schema 6); () where they do not exist yet."""
    tables = {n.lower() for n in sa.inspect(conn).get_table_names()}
    return tuple(t.upper() for t, c in (("rebond", "re_num"), ("choc", "ch_num"))
                 if t in tables and _pg_types(conn, t)[c] == "int4")


def _copy_block(columns: list, types: list[str]) -> bytes:
    """Rows in PostgreSQL's binary COPY format, whole: signature, tuples, trailer.

    ``columns``: one array per column (k rows each, no NULL); ``types``: their
    PostgreSQL types (:data:`_COPY_TYPES`). Each tuple is its field count (int16)
    then, per field, its byte length (int32) and its big-endian value: a record
    of fixed width, so numpy fills all of them at once (several times psycopg's
    ``write_row`` over Python tuples: docs/explanation/storage.md). StoreError for a
    value beyond an int4 column.
    """
    fields = [("count", ">i2")]
    for j, kind in enumerate(types):
        fields += [(f"size{j}", ">i4"), (f"value{j}", _COPY_TYPES[kind])]
    block = np.empty(len(columns[0]), dtype=np.dtype(fields))
    block["count"] = len(types)
    for j, (column, kind) in enumerate(zip(columns, types)):
        column = np.asarray(column)
        if kind == "int4" and column.size and not (-2**31 <= column.min() and column.max() < 2**31):
            raise StoreError(f"a value of column {j + 1} does not fit PostgreSQL's int4")
        block[f"size{j}"] = np.dtype(_COPY_TYPES[kind]).itemsize
        block[f"value{j}"] = column
    return b"".join((_COPY_SIGNATURE, block.tobytes(), _COPY_TRAILER))


def _may_skip_key_triggers(conn) -> bool:
    """Whether this PostgreSQL role may set session_replication_role (a superuser, or
    since PostgreSQL 15 a role granted SET ON PARAMETER session_replication_role).

    With it, COPY runs without the foreign-key triggers, which check each REBOND row
    with a query of their own; the writer gives the same guarantee by construction:
    the PA_NUM it writes are the species rows it has locked, SI_NUM is its own row.
    Without it (an ordinary role) those checks bound the rate, whatever the client
    sends (``benchmarks/store.py --explain``; figures in docs/explanation/storage.md); a
    bulk INSERT ... SELECT from a staging table runs the same per-row triggers, so it
    does not help. A database owner can grant an ordinary role the fast path without
    making it a superuser (PostgreSQL 15+):
    ``GRANT SET ON PARAMETER session_replication_role TO role``.
    """
    if conn.exec_driver_sql("SELECT current_setting('is_superuser')").scalar() == "on":
        return True
    if (conn.dialect.server_version_info or (0,)) < (15,):
        return False
    return bool(conn.exec_driver_sql(
        "SELECT has_parameter_privilege('session_replication_role', 'SET')").scalar())


def _keep_open(conn) -> None:
    """Lift, for this transaction only, the server's limits on how long a transaction may stay
    open or idle (idle_in_transaction_session_timeout; transaction_timeout, PostgreSQL 17+),
    which a managed server often sets: a run's transaction is open for the whole run, idle
    while its engine computes (with --record none, from start to commit), and such a limit
    ended it, losing the run at its commit. Both are settings any role may change for itself."""
    conn.exec_driver_sql("SET LOCAL idle_in_transaction_session_timeout = 0")
    if (conn.dialect.server_version_info or (0,)) >= (17,):
        conn.exec_driver_sql("SET LOCAL transaction_timeout = 0")


def _may_attach(conn) -> bool:
    """Whether REBOND and CHOC are partitioned (PostgreSQL schema 5) and this role may
    attach partitions to them: it owns them, or is a member of the role that does (a
    superuser)."""
    return bool(conn.exec_driver_sql(
        "SELECT count(*) = 2 AND bool_and(c.relkind = 'p' AND pg_has_role(c.relowner, 'USAGE')) "
        "FROM pg_class c WHERE c.oid IN (to_regclass('rebond'), to_regclass('choc'))").scalar())


class PostgresRun(TableRecorder):
    """The PostgreSQL writer of one run (``store``: the :class:`gaz_cli.results.store.Store`
    that opened it, whose ``engine`` it writes through and whose ``_errors()`` turns its
    failures into one line): rows go straight into the run's open transaction, by binary
    COPY (psycopg); the commit adds the results row and sets ``si_num``.

    PostgreSQL, REBOND and CHOC partitioned (schema 5) and a role that may attach
    partitions (:func:`_may_attach`), the usual case: the run's REBOND rows go into a
    table of their own, ``rebond_<SI_NUM>`` (created in the run's transaction: no key,
    no trigger, seen by nobody), its CHOC rows (``--record all``) into ``choc_<SI_NUM>``,
    and the commit attaches each whole (``ALTER TABLE ... ATTACH PARTITION``), which
    builds its primary key index in one pass and checks each foreign key in one query
    over all its rows (as ``ALTER TABLE ... ADD FOREIGN KEY`` does; PostgreSQL's
    RI_Initial_Check), rather than one trigger query per row: a row naming a SIMULATION
    or PARTICULE that does not exist fails the commit as it would fail an INSERT.
    Attaching locks SIMULATION and PARTICULE in SHARE ROW EXCLUSIVE mode, which waits
    for every transaction that has written to them; so such a run writes nothing to
    them before its commit: SI_NUM is drawn from its sequence at the start, the rows
    written at the commit (a new species' PARTICULE row is written before the run, see
    :func:`_register_species`), and commits take REBOND's SHARE UPDATE EXCLUSIVE lock
    (what attaching takes) first, one at a time, so that two commits never wait on each
    other (a deadlock otherwise).

    Otherwise (a role that may not attach, a database of schema 3 being read by an
    older gaz...): rows go into REBOND and CHOC themselves (their default partitions),
    each checked by the key triggers unless the role may skip them
    (:func:`_may_skip_key_triggers`).
    """

    def __init__(self, store, scene: Scene, started: _dt.datetime):
        super().__init__(scene, started)
        self.store = store
        if store.engine.dialect.name == "postgresql":
            _register_species(store.engine, scene.species)
        self.conn = store.engine.connect()
        self._targets = {}  # table name -> where its rows go until the commit (attach path)
        try:
            self.trans = self.conn.begin()
            if self.conn.dialect.name == "postgresql":
                _keep_open(self.conn)
                # before the engine: a run numbering its rows past a 32-bit column failed at that row
                check_row_numbers([scene], narrow_row_numbers(self.conn))
            self._types = {}  # table name -> its columns' types in the database (_copy_types)
            self._attach = self.conn.dialect.name == "postgresql" and _may_attach(self.conn)
            if self._attach:
                self._si = self._next("simulation", "si_num")
                nums = [_pa_num(self.conn, sp, insert=False) for sp in scene.species]
            else:
                self._si, nums = _write_simulation_rows(self.conn, scene, started)
            self._keys_by_hand = _may_skip_key_triggers(self.conn)
            if self._keys_by_hand and not self._attach:
                # what the key triggers would do row by row, once: lock the species rows
                # against deletion (our SIMULATION row is not visible to anyone else yet)
                self.conn.execute(sa.select(particule.c.pa_num).where(particule.c.pa_num.in_(nums))
                                  .with_for_update(key_share=True))
            self._nums = nums
            self._pa_of_particle = np.array(nums, dtype=np.int64)[scene.kinds()]
        except BaseException:
            self.conn.close()
            raise

    def _errors(self):
        return self.store._errors()

    def _next(self, table: str, column: str) -> int:
        return int(self.conn.exec_driver_sql(
            f"SELECT nextval(pg_get_serial_sequence('{table}', '{column}'))").scalar())

    def _target(self, table: sa.Table) -> str:
        """The table this run's rows of ``table`` go into now."""
        if not self._attach:
            return table.name
        if table.name not in self._targets:
            name = f"{table.name}_{self._si}"
            self.conn.exec_driver_sql(f"CREATE TABLE {name} (LIKE {table.name})")
            self._targets[table.name] = name
        return self._targets[table.name]

    def _add(self, table: str, columns):
        table = metadata.tables[table]
        names = [c.name for c in table.columns]
        target = self._target(table)
        replica = self._keys_by_hand and target == table.name
        # one binary COPY block per chunk, built by numpy (benchmarks/store.py)
        if table.name not in self._types:
            self._types[table.name] = _copy_types(self.conn, table)
        block = _copy_block(columns, self._types[table.name])
        raw = self.conn.connection.driver_connection
        sql = f"COPY {target} ({', '.join(names)}) FROM STDIN (FORMAT BINARY)"
        with raw.cursor() as cur:
            if replica:
                cur.execute("SET LOCAL session_replication_role = replica")
            with cur.copy(sql) as copy:
                copy.write(block)
            if replica:
                cur.execute("SET LOCAL session_replication_role = origin")

    def commit(self) -> None:
        # what comes before COMMIT is inside the run's transaction: a signal there (a commit
        # waiting for another session's lock, however long) rolls it all back; the COMMIT
        # alone is held, so that the run is known stored or not
        if self._attach:
            self._attach_rows()
        self.conn.execute(resultat.insert().values(rows.result_row(self._si, *self._result)))
        profile_rows = rows.profile_rows(self._si, self.profile)
        if profile_rows:
            self.conn.execute(profil.insert(), profile_rows)
        with interrupts.held():
            self.trans.commit()
            self.si_num = self._si
            self.store._stored = True
        self.conn.close()

    def _attach_rows(self) -> None:
        """The attach path's commit (see the class docstring), in this order."""
        conn, si = self.conn, self._si
        conn.exec_driver_sql("LOCK TABLE rebond IN SHARE UPDATE EXCLUSIVE MODE")
        _write_simulation_rows(conn, self.scene, self.started, si_num=si, nums=self._nums)
        for name, partition in self._targets.items():
            conn.exec_driver_sql(f"ALTER TABLE {name} ATTACH PARTITION {partition} "
                                 f"FOR VALUES FROM ({si}) TO ({si + 1})")

    def abort(self) -> None:
        try:
            if self.trans.is_active:
                self.trans.rollback()
        except sa_exc.DBAPIError as err:
            # the connection is gone (the server stopped, the backend terminated): the server
            # dropped the transaction with it, and the error that ended the run is the one to tell
            if not err.connection_invalidated:
                raise
        finally:
            self.conn.close()


# --- partitions (schemas 4 and 5) ---------------------------------------------------
def _partition(conn, table: sa.Table, since: int) -> None:
    """PostgreSQL: ``table`` becomes a table partitioned by RANGE (SI_NUM); the rows already
    there stay where they are, as its partition ``<table>_v<since>`` for every SI_NUM up to
    the largest in SIMULATION (attaching it checks them against that range once); a
    default partition takes rows written any other way. Nothing on other backends."""
    if conn.dialect.name != "postgresql":
        return
    name = table.name
    conn.exec_driver_sql(f"LOCK TABLE {name} IN ACCESS EXCLUSIVE MODE")  # older writers wait
    kind, pkey = conn.exec_driver_sql(
        "SELECT c.relkind, i.relname FROM pg_class c "
        "JOIN pg_constraint k ON k.conrelid = c.oid AND k.contype = 'p' "
        f"JOIN pg_class i ON i.oid = k.conindid WHERE c.oid = '{name}'::regclass").one()
    if kind == "p":
        return
    old = f"{name}_v{since}"
    conn.exec_driver_sql(f"ALTER TABLE {name} RENAME TO {old}")
    conn.exec_driver_sql(f'ALTER INDEX "{pkey}" RENAME TO {old}_pkey')  # index names are the schema's
    table.create(conn)
    for column, kind in _pg_types(conn, old).items():
        if kind == "int4" and _pg_types(conn, name)[column] == "int8":
            # the row number as wide as in the rows it partitions (a partition has its table's columns)
            conn.exec_driver_sql(f"ALTER TABLE {name} ALTER COLUMN {column} TYPE integer")
    top = conn.exec_driver_sql(
        f"SELECT greatest((SELECT max(si_num) FROM simulation), (SELECT max(si_num) FROM {old}))").scalar()
    conn.exec_driver_sql(f"ALTER TABLE {name} ATTACH PARTITION {old} "
                         f"FOR VALUES FROM (MINVALUE) TO ({int(top or 0) + 1})")
    default_partitions(conn)


def default_partitions(conn) -> None:
    """PostgreSQL: the partitioned tables' default partitions, where rows land that no run's
    partition holds (an INSERT by hand, a role that may not attach partitions: see PostgresRun)."""
    for name in PARTITIONED:
        if conn.exec_driver_sql(f"SELECT relkind = 'p' FROM pg_class WHERE oid = '{name}'::regclass").scalar():
            conn.exec_driver_sql(f"CREATE TABLE IF NOT EXISTS {name}_default PARTITION OF {name} DEFAULT")
