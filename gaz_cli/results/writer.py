"""Open the results database ``--db`` for writing: the one door of ``gaz simulate`` and sweeps.

A SQLite file that is new, or exactly at this gaz's layout and version, is written by
:mod:`gaz_cli.results.sqlite` alone (the standard library's sqlite3: a tiny run does not pay
SQLAlchemy's import, docs/explanation/storage.md); anything else -- an older gaz database to migrate, a foreign
one to refuse, a PostgreSQL URL, a SQLite URL with options -- by
:class:`gaz_cli.results.store.Store`, imported only then. Both are
:class:`gaz_cli.results.rows.RunStore`: ``simulation(scene)`` hands out a run's writer and
commits it whole; ``shown`` is ``--db`` as it may be printed; each closes as a context manager.
"""

from __future__ import annotations

from pathlib import Path

from gaz_cli.results.sqlite import ForTheStore, SqliteFile, is_file_path


def open_for_writing(db: str):
    """The writer of ``--db`` (a path or URL, as :func:`gaz_cli.results.sqlite.database_name`
    gives it): a :class:`gaz_cli.results.sqlite.SqliteFile` for a new or current SQLite file (a
    path, or a ``sqlite:///PATH`` URL without options), else a
    :class:`gaz_cli.results.store.Store` (which migrates an older database, refuses a foreign
    one, and writes PostgreSQL). Raises StoreError, with nothing written, for a database it
    refuses or cannot open."""
    path = db if is_file_path(db) else _plain_sqlite_url_path(db)
    if path is not None:
        try:
            return SqliteFile(db, Path(path).expanduser())
        except ForTheStore:
            pass
    from gaz_cli.results.store import Store

    return Store(db)


def _plain_sqlite_url_path(db: str) -> str | None:
    """The file of a ``sqlite:///PATH`` URL without options (written as a file path is); None
    for anything else (options such as ``?mode=ro`` are SQLAlchemy's to read: the store's)."""
    if not db.startswith("sqlite:///") or any(c in db for c in "?#%"):  # (%XX: SQLAlchemy's to decode)
        return None
    path = db[len("sqlite:///"):]
    return path if path and path != ":memory:" and not path.startswith("file:") else None
