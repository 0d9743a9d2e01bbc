"""Where a run's rows wait until its commit: a scratch SQLite file beside the database.

A run into a SQLite database streams its REBOND (and CHOC) rows here while
the engine runs, outside the database's write lock; at the end the store
moves them in with one ``INSERT ... SELECT`` inside one short transaction
(:meth:`gaz_cli.store.Store.simulation`). Several runs can thus write one
file at once, and a run that fails or is interrupted only deletes its
scratch file.

The scratch file sits in the database's folder (same file system: a full
disk or a read-only folder shows up at once, not after the run), is named
``.NAME.PID.XXXX.staging`` and has no journal and no fsync (it is thrown away
on any failure). One killed by SIGKILL is left behind; the next writer whose
process id differs removes those of dead processes (:func:`remove_stale`).
Memory stays bounded by the engine's chunk: nothing accumulates in Python.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import tempfile
from pathlib import Path

import numpy as np
import sqlalchemy as sa
from sqlalchemy.dialects import sqlite as sqlite_dialect

SUFFIX = ".staging"


class Stage:
    """A scratch SQLite file holding copies of ``tables`` (same columns, same DDL).

    ``database``: path of the SQLite database the rows are meant for; the
    scratch file is created in its folder. Raises OSError or sqlite3.Error
    (the store turns them into :class:`~gaz_cli.errors.StoreError`).
    """

    def __init__(self, database: Path, tables: list[sa.Table]):
        database = Path(database)
        fd, name = tempfile.mkstemp(prefix=f".{database.name}.{os.getpid()}.", suffix=SUFFIX,
                                    dir=database.resolve().parent)
        os.close(fd)
        self.path = Path(name)
        self.rows = {t.name: 0 for t in tables}
        self._sql = {}
        try:
            self._conn = sqlite3.connect(self.path, isolation_level=None)
            self._conn.execute("PRAGMA journal_mode = OFF")
            self._conn.execute("PRAGMA synchronous = OFF")
            self._conn.execute("BEGIN")
            dialect = sqlite_dialect.dialect()
            for table in tables:
                self._conn.execute(str(sa.schema.CreateTable(table).compile(dialect=dialect)))
                names = [c.name for c in table.columns]
                self._sql[table.name] = (f"INSERT INTO {table.name} ({', '.join(names)}) "
                                         f"VALUES ({', '.join('?' * len(names))})")
        except BaseException:
            self.discard()
            raise

    def add(self, table: str, columns: list) -> None:
        """Append rows given as column arrays (one per column of the table, in order)."""
        rows = zip(*[np.asarray(c).tolist() for c in columns])
        self._conn.executemany(self._sql[table], rows)
        self.rows[table] += len(columns[0])

    def seal(self) -> None:
        """Commit the scratch file's rows so that another connection can ATTACH and read them."""
        self._conn.execute("COMMIT")
        self._conn.close()
        self._conn = None

    def discard(self) -> None:
        """Close and delete the scratch file; idempotent."""
        conn, self._conn = getattr(self, "_conn", None), None
        if conn is not None:
            conn.close()
        with contextlib.suppress(OSError):
            self.path.unlink(missing_ok=True)


def remove_stale(database: Path) -> None:
    """Delete the scratch files left beside ``database`` by processes that no longer exist."""
    database = Path(database)
    with contextlib.suppress(OSError):
        for path in database.resolve().parent.glob(f".{database.name}.*{SUFFIX}"):
            pid = path.name[len(database.name) + 2:].split(".", 1)[0]
            if pid.isdigit() and int(pid) != os.getpid() and not _alive(int(pid)):
                path.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True

