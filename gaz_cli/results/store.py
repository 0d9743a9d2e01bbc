"""The results database, through SQLAlchemy Core: open one by path or URL, check, create or
migrate its schema, hand out a run's writer, read it back.

The layout is :mod:`gaz_cli.results.schema`'s (the exam's three tables, exactly, and the
extra tables keyed by SI_NUM); a run's rows are :mod:`gaz_cli.results.rows`'s. A SQLite
file's runs are written by :mod:`gaz_cli.results.sqlite` (the standard library's sqlite3, no
SQLAlchemy), a PostgreSQL server's by :mod:`gaz_cli.results.postgres` (binary COPY);
``gaz simulate`` opens its writer through :func:`gaz_cli.results.writer.open_for_writing`,
which takes the first for a SQLite file it can write as it is and this store otherwise.
The store's readers return DataFrames with upper-case columns (pandas imported on the
first read).

Opening a database for writing checks it before writing anything: tables
with gaz's names but other columns are refused (a foreign database), so is a gaz
database without one of its tables (dropped by hand), a newer schema version is
refused, an older one is migrated forward (:mod:`gaz_cli.results.migrations`), a new
one is created. Creation is safe when several processes create the same database at
once (SQLite: ``BEGIN IMMEDIATE`` and ``IF NOT EXISTS``; PostgreSQL: an advisory lock,
and DDL inside the transaction). A new PostgreSQL database whose store's runs all failed
is left as it was found, without a table (:func:`gaz_cli.results.postgres.unmake`),
unless another store is open for writing on it. A process killed (SIGKILL) cannot do that: it leaves the
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
  :data:`gaz_cli.results.schema.POSTGRES_SCHEMA_VERSION`); a run's rows stream by ``COPY``
  into a table of its own inside the run's open transaction, attached whole as REBOND's
  partition at the commit, which checks the foreign keys in bulk
  (:class:`gaz_cli.results.postgres.PostgresRun`);
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

import sqlalchemy as sa
from sqlalchemy import exc as sa_exc

from gaz_cli import __version__, interrupts
from gaz_cli.errors import StoreError
from gaz_cli.model.scene import Scene
from gaz_cli.results import postgres, rows
from gaz_cli.results.budgets import check_row_numbers
from gaz_cli.results import sqlite as sqlite_writer
from gaz_cli.results.migrations import MIGRATIONS
from gaz_cli.results.postgres import narrow_row_numbers
from gaz_cli.results.rows import RunStore
from gaz_cli.results.schema import (  # noqa: F401 - the tables and versions, read through the store too
    EXAM_TABLES, PARTITIONED, POSTGRES_SCHEMA_VERSION, SCHEMA_VERSION, choc, composition, latest_version,
    metadata, particule, profil, rebond, resultat, scene_table, schema_version, simulation)

BUSY_TIMEOUT_S = sqlite_writer.BUSY_TIMEOUT_S
"""How long a SQLite writer waits for another one's commit before giving up, s, unless the URL
says otherwise (``?timeout=30``; the one figure is sqlite_writer's, which its messages quote)."""

CONNECT_TIMEOUT_S = 10
"""How long to wait for a database server to answer, s (psycopg's connect_timeout)."""

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
    if url.get_backend_name() == "sqlite":
        check_sqlite_query(db)
    if url.get_backend_name() == "sqlite" and url.database and url.query.get("uri") not in ("true", "1"):
        sqlite_writer.refuse_a_uri(url.database, db)  # (a SQLite URL has no password to hide)
    if url.get_backend_name() == "sqlite" and "timeout" in url.query:
        _timeout(url, db)
    if url.get_backend_name() == "postgresql" and url.get_driver_name() != "psycopg":
        raise StoreError(f"--db {shown(db)!r}: gaz talks to PostgreSQL through psycopg 3 (binary COPY), "
                         f"not {url.get_driver_name()}; write the URL as postgresql://...")
    return url


SQLITE_URL_KEYS = ("timeout", "uri")
"""The parameters of a ``sqlite:///`` URL gaz reads without ``uri=true`` (with it, SQLite's own
URI parameters, ``mode``, ``cache``...)."""


def check_sqlite_query(db: str) -> None:
    """Refuse a ``sqlite:///`` URL whose parameters would be ignored or ambiguous: one given
    twice, one without a name, or one SQLAlchemy drops with a SAWarning on stderr (``?mode=ro``
    without ``uri=true``: ignored, and the run written all the same; ``?foo=1``). StoreError."""
    if "?" not in db:
        return
    query = db.split("?", 1)[1]
    pairs = urllib.parse.parse_qsl(query, keep_blank_values=True)
    names = [k for k, _ in pairs]
    if any(not k for k in names) or ("&&" in query or query.startswith("&") or query.endswith("&")):
        raise StoreError(f"--db {db!r} holds an empty parameter; write 'sqlite:///FILE?name=value&...', "
                         "or leave the '?' out")
    twice = sorted({k for k in names if names.count(k) > 1})
    if twice:
        raise StoreError(f"--db {db!r} gives {twice[0]} twice; give each parameter once")
    uri = dict(pairs).get("uri", "").lower() in ("true", "1", "yes", "on")
    unknown = [k for k in names if k not in SQLITE_URL_KEYS]
    if unknown and not uri:
        raise StoreError(f"--db {db!r}: parameter {unknown[0]!r} is not one gaz gives SQLite without "
                         f"uri=true (it takes {' and '.join(SQLITE_URL_KEYS)}; SQLAlchemy would ignore it); "
                         "for SQLite's URI parameters (mode, cache...) write "
                         "'sqlite:///file:FILE?mode=ro&uri=true', or drop it")


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
        self._made = False  # PostgreSQL: this store created gaz's tables (see postgres.unmake)
        self._tried = self._stored = False  # a run was begun, committed through this store
        self._writing = None  # PostgreSQL: the connection holding postgres.WRITER_LOCK while open for writing
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
        which it began runs and stored none, is left as it was found
        (:func:`gaz_cli.results.postgres.unmake`); so is a
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
                        postgres.unmake(writing)
        finally:
            if self._file is not None:
                self._file.close()
            if self._engine is not None:
                self._engine.dispose()

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
            # elsewhere does not drop the tables (postgres.unmake); released by close()
            self._writing = self.engine.connect()
            self._writing.execute(sa.select(sa.func.pg_advisory_lock_shared(postgres.WRITER_LOCK)))
            self._writing.commit()
        with self.engine.begin() as conn:
            if self.engine.dialect.name == "postgresql":
                conn.execute(sa.select(sa.func.pg_advisory_xact_lock(postgres.SCHEMA_LOCK)))
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
            key = [c.lower() for c in insp.get_pk_constraint(table.name).get("constrained_columns") or []]
            if set(key) != {c.name for c in table.primary_key.columns}:
                raise StoreError(
                    f"{self.shown!r} is not a gaz database: its table {table.name.upper()} has primary key "
                    f"({', '.join(c.upper() for c in key) or 'none'}), not gaz's "
                    f"({', '.join(c.name.upper() for c in table.primary_key.columns)}); nothing was "
                    "written; point --db at a new file or a gaz database")
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
        return self._version(conn)

    def _version(self, conn) -> int:
        """The one row of SCHEMA_VERSION, as gaz writes it (a whole number from 2 to this gaz's
        version); StoreError for a newer one, and for one gaz did not write (several rows, NULL,
        text, a fraction, below 2: a table edited by hand), nothing written. No row at all is
        version 1, as no table (its row deleted by hand: the migration finds every table there
        and writes the row again, tests/test_store_edges.py)."""
        found = [v for (v,) in conn.execute(sa.select(schema_version.c.sv_version))]
        if not found:
            return 1
        latest = latest_version(conn.dialect.name)
        if (len(found) == 1 and isinstance(found[0], int) and not isinstance(found[0], bool)
                and found[0] > latest):
            raise StoreError(f"{self.shown!r} has schema version {found[0]}, newer than this gaz "
                             f"({__version__}, schema {latest}) knows; upgrade gaz to use it")
        if len(found) == 1 and isinstance(found[0], int) and 2 <= found[0] <= latest:
            return found[0]
        held = f"{len(found)} rows" if len(found) > 1 else f"SV_VERSION = {found[0]!r}"
        raise StoreError(f"{self.shown!r}: its table SCHEMA_VERSION holds {held}, not the one whole number "
                         f"from 2 to {latest} that gaz writes there (edited by hand?); nothing was written; "
                         "restore the database from a backup, or give --db a new database")

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
                postgres.default_partitions(conn)
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
        server's through COPY (:class:`gaz_cli.results.postgres.PostgresRun`)."""
        self._tried = True
        if self.path is None:
            return postgres.PostgresRun(self, scene, started)
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
        packaged SQL file and returns its rows as tuples (no DataFrame: docs/explanation/storage.md)."""
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
            found = conn.execute(sa.select(scene_table.c.sc_file, scene_table.c.si_num)
                                 .where(scene_table.c.sc_file.is_not(None)).order_by(scene_table.c.si_num.desc()))
            return {text: int(si_num) for text, si_num in found}

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
            try:
                frame = _pandas().read_sql_query(stmt, conn)
            except (ValueError, TypeError) as err:  # a DATETIME that is no date (SQLAlchemy's parser)
                raise StoreError(self._not_ours(table, f"a value gaz cannot read ({' '.join(str(err).split())})"))
        self._check_types(table, frame)
        frame.columns = [c.upper() for c in frame.columns]
        return frame

    ROWS_CHECKED_BY_THE_ANALYSIS = ("simulation", "particule", "composition")
    """Tables whose rows the analysis checks itself, value by value, naming the run and the
    fix of analysing the others (gaz_cli.analysis.stored._check_stored): left to it."""

    def _check_types(self, table: sa.Table, frame) -> None:
        """StoreError for a number column read back holding something else (SQLite keeps what
        it is given: a value edited by hand, 'hot' in SCENE.SC_TEMPERATURE), before the analysis
        trips on it ('internal error: ValueError')."""
        if table.name in self.ROWS_CHECKED_BY_THE_ANALYSIS:
            return
        for column in table.columns:
            if column.name not in frame or not isinstance(column.type, (sa.Integer, sa.Float)):
                continue
            values = frame[column.name]
            if not _pandas().api.types.is_numeric_dtype(values):  # (object, or pandas' str dtype)
                bad = next((v for v in values if v is not None and not isinstance(v, (int, float))), None)
                if bad is not None:
                    raise StoreError(self._not_ours(table, f"{column.name.upper()} = {bad!r} where gaz writes a number"))

    def check_number_columns(self, table: sa.Table, si_num: int) -> None:
        """StoreError if a number column of run ``si_num``'s rows of ``table`` holds text or
        bytes: SQLite keeps what it is given ('x' in REBOND.RE_T, edited by hand), which the
        analysis' SQL would sum as 0 or compare with a number. One pass over the run's rows
        (its key's range), SQLite only: PostgreSQL keeps each column's type."""
        if self.engine.dialect.name != "sqlite":
            return
        numbers = [c for c in table.columns if isinstance(c.type, (sa.Integer, sa.Float))]
        odd = sa.or_(*(sa.func.typeof(c).in_(("text", "blob")) for c in numbers))
        with self._errors(), self.engine.connect() as conn:
            row = conn.execute(sa.select(*numbers).where(table.c.si_num == si_num, odd).limit(1)).first()
        if row is not None:
            column, bad = next((c, v) for c, v in zip(numbers, row) if isinstance(v, (str, bytes)))
            raise StoreError(self._not_ours(table, f"{column.name.upper()} = {bad!r} where gaz writes a number"))

    def _not_ours(self, table: sa.Table, what: str) -> str:
        return (f"{self.shown!r}: its table {table.name.upper()} holds {what} (edited by hand?); restore "
                "the database from a backup, or give --db another database")

    def check_row_numbers(self, scenes: list[Scene], fix: str = "shorten `duration`") -> None:
        """Refuse, before they run, the runs of ``scenes`` whose rows would number past this
        database's 32-bit row numbers (a PostgreSQL database made before schema 6;
        :func:`gaz_cli.results.budgets.check_row_numbers`); nothing elsewhere (64-bit)."""
        if self.is_sqlite:
            return
        with self._errors(), self.engine.connect() as conn:
            narrow = narrow_row_numbers(conn)
        check_row_numbers(scenes, narrow, fix)

    def schema_version(self) -> int:
        """The database's schema version (1 for a database written before versions existed)."""
        with self._errors(), self.engine.connect() as conn:
            return self._schema_state(conn)


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


