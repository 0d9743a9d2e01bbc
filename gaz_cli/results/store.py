"""The results database, through SQLAlchemy Core.

The exam's three tables (figure 4) exactly, never changed:

- SIMULATION(SI_NUM pk, SI_DEB, SI_DUR s, SI_DIM, SI_N, SI_L m)
- PARTICULE(PA_NUM pk, PA_NOM, PA_M g, PA_R m)
- REBOND(SI_NUM fk, RE_NUM, PA_NUM fk, RE_T s, RE_DIR, RE_VIT m/s, RE_VP m/s),
  primary key (SI_NUM, RE_NUM)

and extra tables keyed by SI_NUM for everything else:

- SCENE: seed, temperature, engine, boundary, forces, restitution, placement...
- COMPOSITION(SI_NUM, PA_NUM, CO_N): the mixture.
- RESULTAT: events, collisions, kinetic energy at start and end, virial,
  wall time, events per second.
- CHOC(SI_NUM, CH_NUM, CH_T, CH_I, CH_J, CH_J_IMP): particle-particle
  collisions, written only with ``--record all``.
- SCHEMA_VERSION(SV_VERSION): one row, the version of this layout
  (:data:`SCHEMA_VERSION`); a database without it is version 1.

Table and column names are created in lower case, so that the SQL files,
written in upper case as in the exam, run unchanged on SQLite and on
PostgreSQL (which folds unquoted names to lower case).

Opening a database for writing checks it before writing anything: tables
with gaz's names but other columns are refused (a foreign database), so is a gaz
database without one of its tables (dropped by hand), a newer schema version is
refused, an older one is migrated forward (:data:`MIGRATIONS`), a new one is created. Creation is safe when several
processes create the same database at once (SQLite: ``BEGIN IMMEDIATE`` and
``IF NOT EXISTS``; PostgreSQL: an advisory lock, and DDL inside the
transaction). A new PostgreSQL database whose store's runs all failed is left as
it was found, without a table (:meth:`Store._unmake`), unless another store is
open for writing on it. A process killed (SIGKILL) cannot do that: it leaves the
whole schema, created in one transaction at opening, which the next run uses. (Not
the schema created in the first run's own transaction instead: any other first run
would wait for that one's end to see or create a table, as long as the run lasts.)

A simulation is committed whole or not at all, in one short transaction at
its end (:meth:`Store.simulation`):

- SQLite (WAL mode, a busy timeout): the run's rows wait in memory, or beyond
  a bound in a scratch file (:mod:`gaz_cli.results.staging`), while the engine runs,
  and move in at the end (many rows per INSERT, or one ``INSERT ... SELECT``
  from the scratch file); the database's write lock is held for that only, so
  several runs write one file at once and readers read while they do.
- PostgreSQL (psycopg 3): REBOND is partitioned by RANGE (SI_NUM) (schema 4,
  :data:`POSTGRES_SCHEMA_VERSION`); a run's rows stream by ``COPY`` into a table of
  its own inside the run's open transaction, attached whole as REBOND's partition
  at the commit, which checks the foreign keys in bulk (:class:`_DirectRun`);
  concurrent runs take turns only for their commits.

SIGINT and SIGTERM arriving during the commit itself are held until it ends
(the run is then stored, and the interrupt takes effect just after). Every
database or file-system failure becomes one :class:`StoreError` line, with
any password hidden.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import os
import re
import sqlite3
import sys
import urllib.parse
from importlib import resources
from pathlib import Path

import numpy as np
import sqlalchemy as sa
from sqlalchemy import exc as sa_exc

from gaz_cli import __version__, interrupts
from gaz_cli.results import rows
from gaz_cli.results import sqlite as sqlite_writer
from gaz_cli.errors import StoreError
from gaz_cli.results.rows import RunStore, TableRecorder
from gaz_cli.model.scene import Scene, check_row_numbers
from gaz_cli.model.species import NAME_MAX, Species

metadata = sa.MetaData()

ROW_NUMBER = sa.Integer().with_variant(sa.BigInteger(), "postgresql")
"""RE_NUM, CH_NUM: a run's rows numbered 1, 2, ...; past 2^31 - 1 in a long run (the README
example's gas records ~1.8e13 wall bounces a second of simulated time: 2^31 after 1.2e-4 s, minutes
of engine), so BIGINT on PostgreSQL (schema 6); INTEGER on SQLite, whose integers are 64-bit (and
the SQLite schema stays as it was)."""

simulation = sa.Table(
    "simulation", metadata,
    sa.Column("si_num", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("si_deb", sa.DateTime, nullable=False),
    sa.Column("si_dur", sa.Float, nullable=False),
    sa.Column("si_dim", sa.Integer, nullable=False),
    sa.Column("si_n", sa.Integer, nullable=False),
    sa.Column("si_l", sa.Float, nullable=False),
)

particule = sa.Table(
    "particule", metadata,
    sa.Column("pa_num", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("pa_nom", sa.String(NAME_MAX), nullable=False),
    sa.Column("pa_m", sa.Float, nullable=False),
    sa.Column("pa_r", sa.Float, nullable=False),
)

rebond = sa.Table(
    "rebond", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("re_num", ROW_NUMBER, primary_key=True, autoincrement=False),
    sa.Column("pa_num", sa.Integer, sa.ForeignKey("particule.pa_num"), nullable=False),
    sa.Column("re_t", sa.Float, nullable=False),
    sa.Column("re_dir", sa.Integer, nullable=False),
    sa.Column("re_vit", sa.Float, nullable=False),
    sa.Column("re_vp", sa.Float, nullable=False),
    sqlite_with_rowid=False,  # the primary key is the storage order: one B-tree, not two
    # PostgreSQL (schema 4): one partition per run, attached whole at its commit (_DirectRun);
    # the same columns and keys, the exam's queries unchanged
    postgresql_partition_by="RANGE (si_num)",
)

scene_table = sa.Table(
    "scene", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("sc_seed", sa.BigInteger, nullable=False),
    sa.Column("sc_temperature", sa.Float, nullable=False),
    sa.Column("sc_engine", sa.String(32), nullable=False),
    sa.Column("sc_boundary", sa.String(16), nullable=False),
    sa.Column("sc_gravity", sa.Float, nullable=False),
    sa.Column("sc_restitution", sa.Float, nullable=False),
    sa.Column("sc_tc", sa.Float, nullable=False),
    sa.Column("sc_wall_restitution", sa.Float, nullable=False),
    sa.Column("sc_dt", sa.Float),
    sa.Column("sc_drag", sa.Float, nullable=False),
    sa.Column("sc_pair_gravity", sa.Float, nullable=False),
    sa.Column("sc_placement", sa.String(16), nullable=False),
    sa.Column("sc_record", sa.String(16), nullable=False),
    sa.Column("sc_version", sa.String(16), nullable=False),
    sa.Column("sc_file", sa.Text, info={"since": 3}),
)

composition = sa.Table(
    "composition", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("pa_num", sa.Integer, sa.ForeignKey("particule.pa_num"), primary_key=True),
    sa.Column("co_n", sa.Integer, nullable=False),
    sa.Column("co_rank", sa.Integer, info={"since": 3}),
)

resultat = sa.Table(
    "resultat", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("rs_events", sa.BigInteger, nullable=False),
    sa.Column("rs_bounces", sa.BigInteger, nullable=False),
    sa.Column("rs_collisions", sa.BigInteger, nullable=False),
    sa.Column("rs_ke_start", sa.Float, nullable=False),
    sa.Column("rs_ke_end", sa.Float, nullable=False),
    sa.Column("rs_virial", sa.Float, nullable=False),
    sa.Column("rs_wall_time", sa.Float, nullable=False),
)

choc = sa.Table(
    "choc", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("ch_num", ROW_NUMBER, primary_key=True, autoincrement=False),
    sa.Column("ch_t", sa.Float, nullable=False),
    sa.Column("ch_i", sa.Integer, nullable=False),
    sa.Column("ch_j", sa.Integer, nullable=False),
    sa.Column("ch_imp", sa.Float, nullable=False),
    postgresql_partition_by="RANGE (si_num)",  # as REBOND (schema 5)
)


schema_version = sa.Table(
    "schema_version", metadata,
    sa.Column("sv_version", sa.Integer, nullable=False),
)

EXAM_TABLES = ("simulation", "particule", "rebond")

SCHEMA_VERSION = 3
"""Version of the layout this gaz writes into SQLite. 1: the tables above but SCHEMA_VERSION
(rollback journal, PostgreSQL's PARTICULE sequence left at 1 by seeding); 2: adds
SCHEMA_VERSION, WAL mode, PARTICULE's sequence past its rows; 3: adds SCENE.SC_FILE
(the scene file that re-runs the simulation) and COMPOSITION.CO_RANK (the species'
place in the scene: particles come in blocks, rank 0 first, so CHOC's particle
indices map to species). A column added in version v carries ``info={"since": v}``."""

BUSY_TIMEOUT_S = sqlite_writer.BUSY_TIMEOUT_S
"""How long a SQLite writer waits for another one's commit before giving up, s, unless the URL
says otherwise (``?timeout=30``; the one figure is sqlite_writer's, which its messages quote)."""

POSTGRES_SCHEMA_VERSION = 6
"""Version of the layout this gaz writes into PostgreSQL. 4: 3, and REBOND partitioned by
RANGE (SI_NUM), one partition per run (``rebond_<SI_NUM>``) plus a default partition
(``rebond_default``) for rows written any other way; same columns, same keys. 5: CHOC
partitioned the same way (``choc_<SI_NUM>``, ``choc_default``). 6: RE_NUM and CH_NUM
BIGINT (:data:`ROW_NUMBER`) in a new database; one migrated from 5 keeps its 32-bit
columns (widening them rewrites every row), and a run whose rows would number past them is
refused at its start (:meth:`Store.check_row_numbers`), the ALTER TABLE that widens them
named. SQLite has no version 4 to 6 (nothing changed there)."""

PARTITIONED = ("rebond", "choc")
"""PostgreSQL: the tables of one row per event, partitioned by run (schema 4 and 5)."""


def latest_version(dialect_name: str) -> int:
    """The schema version this gaz writes for a backend ('sqlite', 'postgresql', ...)."""
    return POSTGRES_SCHEMA_VERSION if dialect_name == "postgresql" else SCHEMA_VERSION


CONNECT_TIMEOUT_S = 10
"""How long to wait for a database server to answer, s (psycopg's connect_timeout)."""

_PG_SCHEMA_LOCK = 0x67617A  # 'gaz': the advisory lock held while creating or migrating
_PG_WRITER_LOCK = 0x67617A57  # 'gazW': held shared by every writing store while open (see Store._unmake)


def _pandas():
    """pandas, imported when a read needs it: a run that only writes does not pay its import
    (a third of a tiny run's start-up, issue 15)."""
    import pandas

    return pandas




def _unwrapped(err: BaseException) -> BaseException:
    """The driver's error inside pandas' DatabaseError (an OSError quoting the whole SQL);
    any other error as it is. pandas is looked up, not imported: loaded only if a read ran."""
    pandas = sys.modules.get("pandas")
    if pandas is None or not isinstance(err, pandas.errors.DatabaseError):
        return err
    orig = err.__cause__
    if isinstance(orig, sa_exc.DBAPIError) and orig.orig is not None:
        orig = orig.orig
    return orig if orig is not None else err


# --- URLs -----------------------------------------------------------------------
def url_for(db: str) -> sa.URL:
    """A SQLAlchemy URL from ``--db``: a URL is kept (``postgresql://``, and libpq's
    ``postgres://``, use psycopg 3), anything else is a SQLite file path. Raises StoreError for a malformed URL or a
    backend other than SQLite and PostgreSQL (the two gaz's schema, SQL files and
    writers are made and tested for)."""
    if "://" not in db:  # (absolute: never read as a URI, sqlite_writer.file_name)
        return sa.URL.create("sqlite", database=db if db == ":memory:" else sqlite_writer.file_name(db))
    try:
        url = sa.make_url(db)
    except (sa_exc.ArgumentError, ValueError) as err:
        raise StoreError(f"--db {shown(db)!r} is not a valid path or SQLAlchemy URL ({err})") from None
    if url.drivername in ("postgresql", "postgres"):  # postgres://: libpq's other spelling (SQLAlchemy has none)
        url = url.set(drivername="postgresql+psycopg")
    if url.get_backend_name() not in ("sqlite", "postgresql"):
        raise StoreError(f"--db {shown(db)!r}: gaz writes to SQLite files and PostgreSQL servers, "
                         f"not {url.get_backend_name()}; give a file path or a postgresql:// URL")
    if url.get_backend_name() == "sqlite" and url.database and url.query.get("uri") not in ("true", "1"):
        sqlite_writer.refuse_a_uri(url.database, db)  # (a SQLite URL has no password to hide)
    if url.get_backend_name() == "sqlite" and "timeout" in url.query:
        _timeout(url, db)
    if url.get_backend_name() == "postgresql" and url.get_driver_name() != "psycopg":
        raise StoreError(f"--db {shown(db)!r}: gaz talks to PostgreSQL through psycopg 3 (binary COPY), "
                         f"not {url.get_driver_name()}; write the URL as postgresql://...")
    return url


def _timeout(url: sa.URL, db: str) -> float:
    """A SQLite URL's busy timeout (``?timeout=S``, seconds, sqlite3.connect's), else
    :data:`BUSY_TIMEOUT_S`; StoreError for one that is not a number of seconds."""
    given = url.query.get("timeout")
    if given is None:
        return sqlite_writer.BUSY_TIMEOUT_S
    try:
        seconds = float(given if isinstance(given, str) else given[-1])
    except ValueError:
        seconds = float("nan")
    if not 0 <= seconds < float("inf"):
        raise StoreError(f"--db {db!r}: timeout={given} is not a number of seconds; write it as e.g. "
                         "?timeout=30 (how long to wait for another writer's lock)")
    return seconds


_SECRET_PARAMETERS = ("password", "sslpassword")
"""Query parameters of a URL that libpq (psycopg) takes as passwords: hidden as the URL's own."""


def shown(db: str) -> str:
    """``db`` as it may be printed: a URL's password, in its place or as a ``?password=``
    parameter, replaced by ***; its query as written (``host=/tmp``, not ``host=%2Ftmp``)."""
    if "://" not in db:
        return db
    try:
        url = sa.make_url(db)
    except (sa_exc.ArgumentError, ValueError):
        db = re.sub(r"([?&](?:ssl)?password=)[^&]*", r"\1***", db, flags=re.IGNORECASE)
        return re.sub(r"(://[^:/@]*:)[^@]*@", r"\1***@", db)
    hidden = {k: "***" for k in url.query if k.lower() in _SECRET_PARAMETERS}
    text = url.update_query_dict(hidden).render_as_string(hide_password=True)
    base, sep, query = text.partition("?")
    return base + sep + urllib.parse.unquote_plus(query)  # (SQLAlchemy writes a space as +)


# --- packaged SQL ---------------------------------------------------------------
def query_text(name: str) -> str:
    """The text of the packaged SQL file ``name`` (with or without '.sql')."""
    if not name.endswith(".sql"):
        name += ".sql"
    return resources.files("gaz_cli.sql").joinpath(name).read_text(encoding="utf-8")


def query_names() -> list[str]:
    """Names of the packaged SQL files, sorted."""
    return sorted(p.name for p in resources.files("gaz_cli.sql").iterdir()
                  if p.name.endswith(".sql"))


# --- the store ------------------------------------------------------------------
class Store(RunStore):
    """A results database. ``create=False`` refuses to make a new one (for readers); with
    ``empty_ok`` too, an existing database without any table (an empty file, a new PostgreSQL
    database) is read as holding no run, and left as it is.

    Opening checks (and for a writer creates or migrates) the schema; see the
    module docstring. Every failure is a :class:`StoreError`. ``close()``
    releases the connections (SQLite then removes its WAL file).

    A SQLite file that does not exist yet is made under a private name
    (:class:`gaz_cli.results.sqlite.SqliteFile`, read there meanwhile) and takes its name
    when its first run is stored, or at ``close()`` if no run was begun (a store
    opened to make a database): a first run that fails or is interrupted leaves no
    file, as ``gaz simulate --db FILE``.
    """

    def __init__(self, db: str, create: bool = True, empty_ok: bool = False):
        db = sqlite_writer.database_name(db)
        self.db = db
        self.shown = shown(db)
        url = url_for(db)
        self.is_sqlite = url.get_backend_name() == "sqlite"
        self.path = _sqlite_path(url) if self.is_sqlite else None
        sqlite_writer.refuse_a_folder(self.path, self.shown)
        if self.is_sqlite and not create and not (self.path and self.path.is_file()):
            raise StoreError(f"database {db!r} does not exist; run 'gaz simulate --db {db}' first")
        if self.is_sqlite and self.path is None:
            raise StoreError(f"--db {self.shown!r} is a SQLite database in memory, gone when gaz exits; "
                             "give a file path, or --no-db to store nothing")
        if self.is_sqlite and not create and "uri" not in url.query and _unwritable_folder(self.path):
            url = _immutable(url, self.path)
        self._url = url
        self._engine = None
        self._reading = None  # a new SQLite file's private name, where the engine reads it until published
        self._opened = False
        self._file = None  # the SQLite file's writer (sqlite_writer.SqliteFile), opened at the first run
        self._made = False  # PostgreSQL: this store created gaz's tables (see _unmake)
        self._tried = self._stored = False  # a run was begun, committed through this store
        self._writing = None  # PostgreSQL: the connection holding _PG_WRITER_LOCK while open for writing
        try:
            with self._errors():
                self.engine = _make_engine(url, self.shown)
                if create and self.is_sqlite and not os.path.lexists(self.path):
                    self._open_new_file()
                elif create:
                    self._prepare()
                else:
                    with self.engine.connect() as conn:
                        version = self._schema_state(conn)
                    if version == 0 and not empty_ok:
                        raise StoreError(f"{self.shown!r} is not a gaz database (no table SIMULATION); "
                                         "point --db at a file written by 'gaz simulate'")
        except BaseException:
            self.close()
            raise
        self._opened = True

    @property
    def engine(self) -> sa.Engine:
        """The SQLAlchemy engine reading (and, but for SQLite runs, writing) the database; a new
        SQLite file's is on its private name until the file has its real one."""
        if self._reading is not None and (self._file is None or self._file.private != self._reading):
            self._reading = None  # published (or gone): read it under its name
            self._engine.dispose()
            self._engine = _make_engine(self._url, self.shown)
        return self._engine

    @engine.setter
    def engine(self, engine: sa.Engine) -> None:
        self._engine = engine

    def _open_new_file(self) -> None:
        """A new SQLite file: its schema made in a private file (sqlite_writer.SqliteFile), which
        the engine reads until the file takes its name."""
        url = self._url
        self._file = sqlite_writer.SqliteFile(self.db, self.path, self.engine.dialect.create_connect_args(url))
        private = self._file.private
        uri = url.query.get("uri") in ("true", "1")
        self._engine.dispose()
        self._engine = _make_engine(url.set(database=sqlite_writer.renamed(url.database, private, uri)),
                                    self.shown)
        self._reading = private

    def close(self) -> None:
        """Release every connection; idempotent. A PostgreSQL database this store created, into
        which it began runs and stored none, is left as it was found (:meth:`_unmake`); so is a
        new SQLite file (never named); a new SQLite file into which no run was begun takes its
        name (the store made a database)."""
        try:
            if self._opened and not self._tried and self._file is not None and self._file.private is not None:
                self._opened = False
                self._engine.dispose()  # (its connections on the private file)
                with self._errors(), interrupts.held():
                    sqlite_writer.use_wal(self._file.conn)  # as every database the store opens
                    self._file.publish()
            if self._writing is not None:
                writing, self._writing = self._writing, None
                with writing, contextlib.suppress(sa_exc.DBAPIError):  # (best effort: the run's error is the one to tell)
                    if self._made and self._tried and not self._stored:
                        self._unmake(writing)
        finally:
            if self._file is not None:
                self._file.close()
            if self._engine is not None:
                self._engine.dispose()

    def _unmake(self, conn) -> None:
        """PostgreSQL: drop the tables this store created (a new database) when none of its runs
        was stored (refused, failed, interrupted): the database is left as it was found.

        Unless another process may use them: another store open for writing (it holds
        :data:`_PG_WRITER_LOCK` shared from before it looks at the schema until it closes: the
        try-lock fails), a reader's transaction holding them past a short lock timeout, or
        a run stored meanwhile (a SIMULATION row). ``conn``: this store's connection holding
        the lock. Interrupts are held over it (a short transaction)."""
        with interrupts.held():
            conn.execute(sa.select(sa.func.pg_advisory_unlock_shared(_PG_WRITER_LOCK)))
            conn.commit()
            with conn.begin():
                conn.execute(sa.select(sa.func.pg_advisory_xact_lock(_PG_SCHEMA_LOCK)))
                if not conn.execute(sa.select(sa.func.pg_try_advisory_xact_lock(_PG_WRITER_LOCK))).scalar():
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

    # --- errors -----------------------------------------------------------------
    @contextlib.contextmanager
    def _errors(self):
        """Turn database and file-system failures into one StoreError line."""
        try:
            yield
        except StoreError:
            raise
        except sa_exc.NoSuchModuleError as err:
            raise StoreError(f"--db {self.shown!r}: no SQLAlchemy dialect for it ({err}); "
                             "use a file path or a postgresql:// URL") from None
        except sa_exc.ArgumentError as err:
            raise StoreError(f"--db {self.shown!r} is not a valid path or SQLAlchemy URL ({err})") from None
        except sa_exc.NoSuchTableError as err:  # (a reader's: a writer refuses such a database on opening)
            raise StoreError(f"{self.shown!r} is a gaz database without its table {str(err).upper()}; restore it "
                             "from a backup, or point --db at another gaz database") from None
        except sa_exc.DBAPIError as err:
            raise StoreError(self._explain(err.orig if err.orig is not None else err)) from None
        except (sqlite3.Error, OSError) as err:
            raise StoreError(self._explain(_unwrapped(err))) from None
        except Exception as err:
            if type(err).__module__.startswith("psycopg"):
                raise StoreError(self._explain(err)) from None
            raise

    def _explain(self, err: BaseException) -> str:
        """One line for a driver or OS error, naming the database and the fix."""
        timeout = _timeout(self._url, self.db) if self.is_sqlite else None
        return sqlite_writer.explain(err, self.db, self.shown, timeout)

    # --- schema -----------------------------------------------------------------
    def _prepare(self) -> None:
        """Check the schema; create or migrate it; nothing is written to a refused database."""
        if self.is_sqlite:
            with self.engine.connect() as conn:
                self._writable_state(conn)  # read only: refusals leave the file as it was
                conn.rollback()
                # outside any transaction, on the driver's connection
                sqlite_writer.use_wal(conn.connection.driver_connection)
            # also when there is nothing to create: a read-only or locked file fails here,
            # before the run, not at its commit
            with _write_transaction(self.engine) as conn:
                self._create_or_migrate(conn, self._writable_state(conn))
            return
        if self.engine.dialect.name == "postgresql" and self._writing is None:
            # before the schema is looked at: while this store is open, a first run failing
            # elsewhere does not drop the tables (_unmake); released by close()
            self._writing = self.engine.connect()
            self._writing.execute(sa.select(sa.func.pg_advisory_lock_shared(_PG_WRITER_LOCK)))
            self._writing.commit()
        with self.engine.begin() as conn:
            if self.engine.dialect.name == "postgresql":
                conn.execute(sa.select(sa.func.pg_advisory_xact_lock(_PG_SCHEMA_LOCK)))
            version = self._writable_state(conn)
            self._create_or_migrate(conn, version)
            self._made = self._made or (version == 0 and self.engine.dialect.name == "postgresql")

    def _schema_state(self, conn) -> int:
        """The schema version found: 0 for none of gaz's tables (and, in SQLite, no other);
        StoreError for a foreign or newer layout, or a SQLite file of another application."""
        insp = sa.inspect(conn)
        names = {n.lower() for n in insp.get_table_names()}
        tables = [metadata.tables[t] for t in EXAM_TABLES]
        for table in tables + [t for t in metadata.sorted_tables if t not in tables]:
            if table.name not in names:
                continue
            found = [c["name"].lower() for c in insp.get_columns(table.name)]
            later = {c.name for c in table.columns if c.info.get("since", 1) > 1}
            if not ({c.name for c in table.columns} - later <= set(found) <= {c.name for c in table.columns}):
                raise StoreError(
                    f"{self.shown!r} is not a gaz database: its table {table.name.upper()} has columns "
                    f"({', '.join(c.upper() for c in found)}), not gaz's "
                    f"({', '.join(c.name.upper() for c in table.columns)}); nothing was written; "
                    "point --db at a new file or a gaz database")
        present = [t for t in EXAM_TABLES if t in names]
        if not present:
            others = sorted(n for n in names if not n.startswith("sqlite_"))
            if others:  # another application's file, or schema (PostgreSQL: the one gaz would write into)
                shown = ", ".join(others[:3]) + (f" and {len(others) - 3} more" if len(others) > 3 else "")
                if self.is_sqlite:
                    raise StoreError(f"{self.shown!r} is not a gaz database: it holds other tables ({shown}) "
                                     "and none of gaz's; nothing was written; give --db a new file or a gaz "
                                     "database")
                schemas = conn.exec_driver_sql("SELECT current_schemas(false)").scalar()  # the search path's
                where = (f"its schema {schemas[0]} holds" if len(schemas) == 1 else
                         f"its schemas {', '.join(schemas)} (the search path) hold")
                raise StoreError(f"{self.shown!r} is not a gaz database: {where} other tables "
                                 f"({shown}) and none of gaz's; nothing was written; give gaz a database of its "
                                 "own (createdb), or a schema of its own (CREATE SCHEMA gaz, then add "
                                 "?options=-csearch_path%3Dgaz to the URL)")
            return 0
        if len(present) < len(EXAM_TABLES):
            missing = next(t for t in EXAM_TABLES if t not in names)
            raise StoreError(f"{self.shown!r} is not a gaz database: it has table {present[0].upper()} "
                             f"but no {missing.upper()}; point --db at a new file or a gaz database")
        if schema_version.name not in names:
            return 1
        version = conn.execute(sa.select(sa.func.max(schema_version.c.sv_version))).scalar() or 1
        latest = latest_version(conn.dialect.name)
        if version > latest:
            raise StoreError(f"{self.shown!r} has schema version {version}, newer than this gaz "
                             f"({__version__}, schema {latest}) knows; upgrade gaz to use it")
        return int(version)

    def _writable_state(self, conn) -> int:
        """:meth:`_schema_state` for a writer, which also refuses a gaz database of version 2 or
        later (it has SCHEMA_VERSION) lacking one of gaz's tables: every such database has had
        all of them since it was made (in one transaction: PostgreSQL's DDL is transactional,
        SQLite's in ``BEGIN IMMEDIATE``), so one was dropped by hand or by another tool. A run
        into it failed at its commit, after its engine (PostgreSQL: 'relation "resultat" does
        not exist'), or was refused with words about migrating (SQLite)."""
        version = self._schema_state(conn)
        if version < 2:
            return version  # (none, or version 1: the migration makes what is missing)
        names = {n.lower() for n in sa.inspect(conn).get_table_names()}
        missing = [t.name.upper() for t in metadata.sorted_tables if t.name not in names]
        if not missing:
            return version
        runs = conn.execute(sa.select(sa.func.count()).select_from(simulation)).scalar()
        them = "them" if len(missing) > 1 else "it"
        fix = ("it holds no run: give --db a new database, or drop gaz's tables from it and run again"
               if not runs else f"it holds {runs} run(s): restore {them} from a backup, or give --db "
               "a new database")
        raise StoreError(f"{self.shown!r} is a gaz database without its table{'s' * (len(missing) > 1)} "
                         f"{', '.join(missing)}; nothing was written; {fix}")

    def _create_or_migrate(self, conn, version: int) -> None:
        latest = latest_version(conn.dialect.name)
        if version == latest:
            return
        if version == 0:
            metadata.create_all(conn)  # checkfirst: IF NOT EXISTS
            if conn.dialect.name == "postgresql":
                _pg_default_partition(conn)
            if not conn.execute(sa.select(sa.func.count()).select_from(particule)).scalar():
                # no explicit ids: the database numbers them, so its sequence stays in step
                conn.execute(particule.insert(), rows.builtin_particule_rows())
            conn.execute(schema_version.insert().values(sv_version=latest))
            return
        for step in range(version, latest):
            MIGRATIONS[step](conn)
        conn.execute(schema_version.update().values(sv_version=latest))

    # --- writing ------------------------------------------------------------
    def _writer(self, scene: Scene, started: _dt.datetime):
        """The run's writer: a SQLite file's runs go through the one SQLite writer
        (:mod:`gaz_cli.results.sqlite`; the schema was created or migrated on opening), a
        server's through COPY (:class:`_DirectRun`)."""
        self._tried = True
        if self.path is None:
            return _DirectRun(self, scene, started)
        if self._file is None:
            try:
                url = url_for(self.db)
                self._file = sqlite_writer.SqliteFile(self.db, self.path,
                                                      self.engine.dialect.create_connect_args(url))
            except sqlite_writer.ForTheStore:
                raise StoreError(f"{self.shown!r} is not at this gaz's schema; open it for writing "
                                 "(Store(db), not create=False) to migrate it first") from None
        return self._file._writer(scene, started)  # (after the file's first run, on its real name)

    # --- reading ------------------------------------------------------------
    def read_sql(self, sql: str, **params) -> "pd.DataFrame":
        """Run one SQL statement (text with :named parameters) into a DataFrame."""
        with self._errors(), self.engine.connect() as conn:
            frame = _pandas().read_sql_query(sa.text(sql), conn, params=params or None)
        frame.columns = [c.upper() for c in frame.columns]
        return frame

    def query(self, name: str, **params) -> "pd.DataFrame":
        """Run a packaged SQL file by name."""
        return self.read_sql(query_text(name), **params)

    @contextlib.contextmanager
    def session(self):
        """One connection for many small reads: yields ``run(name, **params)``, which runs a
        packaged SQL file and returns its rows as tuples (no DataFrame: ~50 us a query on SQLite)."""
        with self._errors(), self.engine.connect() as conn:
            texts = {}

            def run(name: str, **params) -> list[tuple]:
                if name not in texts:
                    texts[name] = sa.text(query_text(name))
                return [tuple(row) for row in conn.execute(texts[name], params)]

            yield run

    def scene_files(self) -> dict[str, int]:
        """The scene file text of every stored simulation that has one (SCENE.SC_FILE) -> its
        SI_NUM (the first, if the same text was stored twice); none in a database without it
        (schema 1 and 2, read without migrating; an empty one)."""
        with self._errors(), self.engine.connect() as conn:
            insp = sa.inspect(conn)
            if not (insp.has_table(scene_table.name) and scene_table.c.sc_file.name in
                    {c["name"].lower() for c in insp.get_columns(scene_table.name)}):
                return {}
            rows = conn.execute(sa.select(scene_table.c.sc_file, scene_table.c.si_num)
                                .where(scene_table.c.sc_file.is_not(None)).order_by(scene_table.c.si_num.desc()))
            return {text: int(si_num) for text, si_num in rows}

    def simulation_numbers(self) -> list[int]:
        with self._errors(), self.engine.connect() as conn:
            return [int(r[0]) for r in conn.execute(sa.select(simulation.c.si_num).order_by(simulation.c.si_num))]

    def table(self, table: sa.Table, si_num: int | None = None) -> "pd.DataFrame":
        """A whole table (optionally one simulation's rows) as a DataFrame, upper-case columns.

        Columns a later schema version added (``info['since']``) and an older
        database lacks are left out: readers do not migrate.
        """
        with self._errors(), self.engine.connect() as conn:
            found = {c["name"].lower() for c in sa.inspect(conn).get_columns(table.name)}
            stmt = sa.select(*[c for c in table.columns if c.info.get("since", 1) == 1 or c.name in found])
            if si_num is not None and "si_num" in table.c:
                stmt = stmt.where(table.c.si_num == si_num)
            frame = _pandas().read_sql_query(stmt, conn)
        frame.columns = [c.upper() for c in frame.columns]
        return frame

    def check_row_numbers(self, scenes: list[Scene], fix: str = "shorten `duration`") -> None:
        """Refuse, before they run, the runs of ``scenes`` whose rows would number past this
        database's 32-bit row numbers (a PostgreSQL database made before schema 6;
        :func:`gaz_cli.model.scene.check_row_numbers`); nothing elsewhere (64-bit)."""
        if self.is_sqlite:
            return
        with self._errors(), self.engine.connect() as conn:
            narrow = narrow_row_numbers(conn)
        check_row_numbers(scenes, narrow, fix)

    def schema_version(self) -> int:
        """The database's schema version (1 for a database written before versions existed)."""
        with self._errors(), self.engine.connect() as conn:
            return self._schema_state(conn)


# --- migrations -----------------------------------------------------------------
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
    """3 -> 4, PostgreSQL only: REBOND becomes partitioned (:func:`_partition`)."""
    _partition(conn, rebond, since=3)


def _v4_to_v5(conn) -> None:
    """4 -> 5, PostgreSQL only: CHOC becomes partitioned (:func:`_partition`)."""
    _partition(conn, choc, since=4)


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
    _pg_default_partition(conn)


def _pg_default_partition(conn) -> None:
    """PostgreSQL: the partitioned tables' default partitions, where rows land that no run's
    partition holds (an INSERT by hand, a role that may not attach partitions: see _DirectRun)."""
    for name in PARTITIONED:
        if conn.exec_driver_sql(f"SELECT relkind = 'p' FROM pg_class WHERE oid = '{name}'::regclass").scalar():
            conn.exec_driver_sql(f"CREATE TABLE IF NOT EXISTS {name}_default PARTITION OF {name} DEFAULT")


def _v5_to_v6(conn) -> None:
    """5 -> 6, PostgreSQL only: nothing rewritten; the writer reads each row number's width
    from the database (:func:`_copy_types`)."""


MIGRATIONS = {1: _v1_to_v2, 2: _v2_to_v3, 3: _v3_to_v4, 4: _v4_to_v5, 5: _v5_to_v6}
"""Version v -> the step taking a database from v to v + 1, run inside the schema transaction."""


# --- connections ----------------------------------------------------------------
def _sqlite_path(url: sa.URL) -> Path | None:
    """The file of a SQLite URL (``file:PATH?...`` with ``uri=true`` too); None in memory."""
    name = url.database or ""
    if url.query.get("uri") in ("true", "1") and name.startswith("file:"):
        name = name[len("file:"):].split("?", 1)[0]
    return Path(name) if name and name != ":memory:" else None


def _unwritable_folder(path: Path) -> bool:
    """Whether ``path`` lies on a read-only file system (a read-only medium or share, a volume
    mounted :ro) with no -wal or -shm beside it. SQLite creates the -shm there to read a WAL
    database, so it cannot open one; and no writer can be at work on it. (A folder others may
    write, but not we, is not one: their writer could be at work.)"""
    try:
        read_only = bool(os.statvfs(path.parent).f_flag & os.ST_RDONLY)
    except (OSError, AttributeError):  # no statvfs (Windows), or the folder is not there
        return False
    return read_only and not any(Path(f"{path}{suffix}").exists() for suffix in ("-wal", "-shm"))


def _immutable(url: sa.URL, path: Path) -> sa.URL:
    """``url`` opened as an immutable file: read without the -shm SQLite cannot create."""
    return url.set(database=path.resolve().as_uri(), query={**url.query, "immutable": "1", "uri": "true"})


def _make_engine(url: sa.URL, display: str) -> sa.Engine:
    backend = url.get_backend_name()
    connect_args = {}
    if backend == "sqlite" and "timeout" not in url.query:  # (connect_args would override the URL's)
        connect_args["timeout"] = sqlite_writer.BUSY_TIMEOUT_S
    elif backend == "postgresql" and "connect_timeout" not in url.query:
        connect_args["connect_timeout"] = CONNECT_TIMEOUT_S
    try:
        engine = sa.create_engine(url, connect_args=connect_args)
    except ImportError as err:
        if backend == "postgresql":
            raise StoreError(f"--db {display!r}: PostgreSQL needs the psycopg driver; "
                             "pip install 'gaz[postgres]' (or pip install 'psycopg[binary]')") from None
        raise StoreError(f"--db {display!r}: its database driver is not installed "
                         f"(no module {getattr(err, 'name', None) or err}); install it with pip") from None
    if backend == "sqlite":
        sa.event.listen(engine, "connect", _sqlite_connect)
        sa.event.listen(engine, "begin", _sqlite_begin)
    return engine


def _sqlite_connect(dbapi_conn, _record) -> None:
    # SQLAlchemy emits BEGIN itself (_sqlite_begin): the driver's own transaction
    # handling would not let a writer ask for BEGIN IMMEDIATE
    dbapi_conn.isolation_level = None
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA foreign_keys = ON")  # (the busy timeout is the driver's timeout argument)
    cur.close()


def _sqlite_begin(conn) -> None:
    # a writer takes the write lock at BEGIN (waiting up to the busy timeout), never in
    # the middle of its transaction, where SQLite cannot wait and fails at once
    if conn.get_execution_options().get("gaz_write", False):
        sqlite_writer.begin_immediate(conn.connection.dbapi_connection)  # a signal stops its wait
    else:
        conn.exec_driver_sql("BEGIN")


@contextlib.contextmanager
def _write_transaction(engine: sa.Engine):
    """A connection in a write transaction (SQLite: BEGIN IMMEDIATE), committed at the end."""
    with engine.connect() as conn:
        conn = conn.execution_options(gaz_write=True)
        with conn.begin():
            yield conn


# --- one simulation's rows --------------------------------------------------------
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


class _Run(TableRecorder):
    """Both SQLAlchemy writers: the store whose failures are turned into one line."""

    def __init__(self, store: Store, scene: Scene, started: _dt.datetime):
        super().__init__(scene, started)
        self.store = store

    def _errors(self):
        return self.store._errors()


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
    of fixed width, so numpy fills all of them at once (~3 M rows/s, against
    ~0.5 M for psycopg's ``write_row`` over Python tuples).
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
    sends: ``benchmarks/store.py --explain`` measured 16 us per row for each of the
    two triggers on a loaded 2-core host (an INSERT ... SELECT of 200,000 rows: 27
    thousand rows/s into REBOND, 212 thousand into a copy without the keys); a bulk
    INSERT ... SELECT from a staging table runs the same per-row triggers, so it does
    not help. A database owner can grant an ordinary role the fast path without
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


class _DirectRun(_Run):
    """PostgreSQL: rows go straight into the run's open transaction,
    by binary COPY (psycopg); the commit adds the results row.

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

    def __init__(self, store, scene, started):
        super().__init__(store, scene, started)
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
