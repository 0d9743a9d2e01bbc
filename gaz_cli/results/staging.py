"""Where a run's rows wait until its commit: in memory up to a bound, then a scratch
SQLite file beside the database.

A run into a SQLite database hands its REBOND (and CHOC) rows here while the
engine runs, outside the database's write lock; at the end the SQLite writer moves
them in inside one short transaction (:class:`gaz_cli.results.sqlite.StagedRun`).
Several runs can thus write one file at once, and a run that fails or is
interrupted only drops its rows. (While the engine runs, a thread may also insert
the chunks kept in memory straight into the database, under a bounded hold of the
write lock: :class:`gaz_cli.results.sqlite._EarlyInsert`; the rows stay staged
here all the same, for the commit to take them if it gives up.)

Up to :data:`MEMORY_ROWS` rows the chunks stay as the engine's arrays (not copied: an engine
never touches the arrays it hands again, see :class:`gaz_cli.model.recording.Recorder`):
the commit inserts them straight into the database, one pass, each row
bound once (:func:`insert_rows`). Beyond it (but for a new database's first run, whose rows
are in its private file already: :class:`gaz_cli.results.sqlite.SqliteFile`), everything goes to a scratch
file: in the database's folder (same file system), named
``.NAME.PID.XXXX.staging``, without journal nor fsync (thrown away on any
failure), a plain table with no index (rows appended in order), written by a thread
of its own while the engine runs (:class:`_ScratchWriter`); the commit
then moves them in by one ``INSERT ... SELECT`` from the attached file. A
scratch file left by a process killed with SIGKILL is removed by the next
writer whose process id differs (:func:`remove_stale`). Memory stays bounded
by MEMORY_ROWS rows plus :data:`SCRATCH_QUEUE` of the engine's chunks.

Why this shape: rows bound many to a statement from one flat row of floats (the binding
is most of a row's cost beyond SQLite's own insert into REBOND's key), the early insert
while the engine runs, a new file's first run in its private file; the measurements that
chose it, and those of the variants left, are in docs/explanation/storage.md.
"""

from __future__ import annotations

import contextlib
import glob
import os
import queue
import sqlite3
import tempfile
import threading
from pathlib import Path

import numpy as np

from gaz_cli import interrupts

SUFFIX = ".staging"

MEMORY_ROWS = 1 << 20
"""Rows (all tables together) kept in memory before the run spills to a scratch file:
~60 MB of arrays for REBOND's seven columns."""

ROWS_PER_STATEMENT = 128
"""Rows per INSERT statement (513 parameters for REBOND, 641 with several species; far
below SQLite's limit, 32766 since 3.32)."""

EXACT_INTEGER = 2 ** 53
"""Integers are bound as float64 (one float64 row per statement, the cheapest to bind); SQLite's
INTEGER affinity stores a whole REAL as an INTEGER, exactly below this bound."""


def insert_rows(conn: sqlite3.Connection, table: str, names: list[str], columns: list,
                constants: dict[str, int] | None = None) -> None:
    """INSERT rows given as column arrays into ``table`` on the driver connection ``conn``.

    ``names``/``columns``: the columns bound, one array of k rows each;
    ``constants``: columns given one value for every row (written in the SQL).
    A column named in :data:`COUNTERS` whose values count up by one (RE_NUM, CH_NUM:
    1, 2, ... in a run) is not bound but written ``?B + j``, row j of a statement, B
    bound once per statement. Every value is bound from float64 (integers too, see
    :data:`EXACT_INTEGER`). Runs in the connection's current transaction.
    """
    k = len(columns[0]) if columns else 0
    if not k:
        return
    constants = constants or {}
    columns = [np.asarray(c) for c in columns]
    for column in columns:
        if column.dtype.kind in "iu" and np.abs(column).max() >= EXACT_INTEGER:
            raise ValueError(f"an integer of table {table} is beyond 2^53")
    counter = next((i for i, (n, c) in enumerate(zip(names, columns))
                    if n in COUNTERS and c.dtype.kind in "iu" and _counts_up(c)), None)
    bound = [c for i, c in enumerate(columns) if i != counter]
    first = None if counter is None else int(columns[counter][0])
    nb, extra = len(bound), int(counter is not None)
    order = [*constants, *(n for i, n in enumerate(names) if i != counter)]
    if counter is not None:
        order.append(names[counter])
    given = [str(int(v)) for v in constants.values()]

    def statement(rows: int) -> str:
        # explicit numbers: the data ?1..?(rows*nb) in row order, then B (the counter's base)
        tuples = []
        for j in range(rows):
            values = given + [f"?{j * nb + m + 1}" for m in range(nb)]
            if extra:
                values.append(f"?{rows * nb + 1} + {j}")
            tuples.append("(" + ", ".join(values) + ")")
        return f"INSERT INTO {table} ({', '.join(order)}) VALUES " + ", ".join(tuples)

    def parameters(start: int, rows: int, count: int) -> np.ndarray:
        """``count`` statements' parameters, one float64 row each: ``rows`` rows from row
        ``start``, row-major, then B (a whole float: INTEGER affinity stores it exactly)."""
        block = np.empty((count, rows * nb + extra))
        for m, column in enumerate(bound):
            block[:, m:rows * nb:nb] = column[start:start + count * rows].reshape(count, rows)
        if extra:
            block[:, -1] = first + start + rows * np.arange(count)
        return block

    per = ROWS_PER_STATEMENT
    count = k // per
    # each statement's parameters bound from a memoryview of its row (a float built per
    # value as it is bound; no list of Python floats)
    if count:
        conn.executemany(statement(per), map(memoryview, parameters(0, per, count)))
    if count * per < k:
        conn.execute(statement(k - count * per), memoryview(parameters(count * per, k - count * per, 1)[0]))


COUNTERS = frozenset({"re_num", "ch_num"})
"""Row-number columns (1, 2, ... in a run) that :func:`insert_rows` writes in the SQL."""


def _counts_up(column: np.ndarray) -> bool:
    """Whether ``column`` is first, first + 1, first + 2, ..."""
    return bool(np.array_equal(column, np.arange(column[0], column[0] + len(column), dtype=column.dtype)))


def move_in(conn: sqlite3.Connection, stage: "Stage", table: str, names: list[str], si_num: int,
            pa_nums: list[int] | None = None) -> None:
    """The rows of ``table`` staged in ``stage`` into the database on ``conn``, in its open
    transaction, under their real SI_NUM (``si_num``) and, with ``pa_nums`` (species index
    -> PA_NUM), their real PA_NUM. ``names``: the table's columns, SI_NUM first.

    In memory: one pass, each row bound once (:func:`insert_rows`); one species: PA_NUM
    written in the SQL. Spilled: one ``INSERT ... SELECT`` from the scratch file, attached
    as ``stage`` (its rows in RE_NUM order, the rowid's: it has no index).
    """
    if not stage.rows[table]:
        return
    if stage.in_memory:
        for staged in stage.chunks(table):
            insert_chunk(conn, table, names, staged, si_num, pa_nums)
        return
    copy_rows(conn, table, names, si_num, pa_nums)


def copy_rows(conn: sqlite3.Connection, table: str, names: list[str], si_num: int,
              pa_nums: list[int] | None = None, source: tuple[int, list[int]] | None = None) -> None:
    """One ``INSERT ... SELECT`` of ``table``'s rows from the database attached as ``stage`` into
    the main one on ``conn``, under SI_NUM ``si_num`` and PA_NUM ``pa_nums[k]`` for species k.
    ``source`` None: a scratch file's rows (PA_NUM the species index, in rowid order);
    ``(si, pa)``: the run SI_NUM ``si`` of a gaz database, PA_NUM ``pa[k]`` for species k (its
    rows in the key's order: RE_NUM, CH_NUM)."""
    keys = range(len(pa_nums or [])) if source is None else source[1]
    values = ["?"]
    for name in names[1:]:
        if name == "pa_num" and pa_nums is not None:
            cases = " ".join(f"WHEN {int(k)} THEN {int(n)}" for k, n in zip(keys, pa_nums))
            values.append(f"CASE pa_num {cases} END")
        else:
            values.append(name)
    where = "ORDER BY rowid" if source is None else f"WHERE si_num = {int(source[0])} ORDER BY {names[1]}"
    conn.execute(f"INSERT INTO {table} ({', '.join(names)}) SELECT {', '.join(values)} "
                 f"FROM stage.{table} {where}", (int(si_num),))


def insert_chunk(conn: sqlite3.Connection, table: str, names: list[str], staged: list, si_num: int,
                 pa_nums: list[int] | None = None) -> None:
    """One chunk kept in memory (column arrays, as :meth:`Stage.add` returns them) into
    ``table`` on ``conn``, in its open transaction, under its real SI_NUM and PA_NUM (see
    :func:`move_in`; the commit and the early insert of :mod:`gaz_cli.results.sqlite` both go
    through here, so their rows are the same). One species: PA_NUM written in the SQL."""
    constants = {"si_num": int(si_num)}
    if pa_nums is not None and len(set(pa_nums)) == 1:
        constants["pa_num"] = int(pa_nums[0])
    staged = dict(zip(names[1:], staged[1:]))
    if "pa_num" in constants:
        del staged["pa_num"]
    elif pa_nums is not None:
        staged["pa_num"] = np.asarray(pa_nums, dtype=np.int64)[staged["pa_num"]]
    insert_rows(conn, table, list(staged), list(staged.values()), constants)


class Stage:
    """Rows of ``tables`` (name -> column names) waiting for the commit; see the module docstring.

    ``database``: path of the SQLite database the rows are meant for (a scratch
    file, if needed, goes to its folder). Raises OSError or sqlite3.Error (the
    store turns them into :class:`~gaz_cli.errors.StoreError`).
    """

    def __init__(self, database: Path, tables: dict[str, list[str]], spill: bool = True):
        self.database = Path(database)
        self.tables = dict(tables)
        self.rows = {name: 0 for name in tables}
        self.path: Path | None = None
        self._chunks: dict[str, list] | None = {name: [] for name in tables}
        self._writer: _ScratchWriter | None = None
        self.spill = spill
        self.dropped = False
        """With ``spill`` False, past MEMORY_ROWS the rows are dropped, not spilled (counted
        only): a run whose rows reach the database by another way (a new database's early
        insert, :class:`gaz_cli.results.sqlite.StagedRun`)."""

    @property
    def in_memory(self) -> bool:
        """True while (and if, at the commit) every row is still in memory."""
        return self._chunks is not None

    def add(self, table: str, columns: list) -> list | None:
        """Append rows given as column arrays (one per column of the table, in order).

        Returns the list of arrays kept in memory (the arrays given, not copied: a
        :class:`gaz_cli.model.recording.Recorder`'s, which nobody modifies; not to be modified; once
        :attr:`dropped`, the arrays given, kept nowhere), or None once the rows go to the
        scratch file (by its thread: :class:`_ScratchWriter`)."""
        k = len(columns[0])
        if self._chunks is not None and sum(self.rows.values()) + k > MEMORY_ROWS:
            if self.spill:
                self._spill()
            else:
                self._chunks, self.dropped = None, True
        kept = [np.asarray(c) for c in columns]
        if self._chunks is not None:
            self._chunks[table].append(kept)
        elif self._writer is not None:
            self._writer.put(table, kept)
            kept = None
        self.rows[table] += k
        return kept

    def chunks(self, table: str):
        """The rows kept in memory for ``table``, as lists of column arrays, in order."""
        return list(self._chunks[table]) if self._chunks is not None else []

    def _spill(self) -> None:
        """Move the rows kept so far to a new scratch file, and the later ones as they come, by
        a thread of its own (:class:`_ScratchWriter`): the engine runs on meanwhile."""
        fd, name = tempfile.mkstemp(prefix=f".{self.database.name}.{os.getpid()}.", suffix=SUFFIX,
                                    dir=self.database.resolve().parent)
        os.close(fd)
        self.path = Path(name)
        chunks, self._chunks = self._chunks, None
        self._writer = _ScratchWriter(self.path, self.tables,
                                      [(table, columns) for table, parts in chunks.items() for columns in parts])

    def seal(self) -> None:
        """Commit the scratch file's rows (if any) so that another connection can ATTACH them:
        wait for its thread's last inserts; raise its failure."""
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.close(keep=True)

    def discard(self) -> None:
        """Drop the rows: stop the scratch file's thread, delete the file, if any; idempotent."""
        self._chunks = None
        writer, self._writer = self._writer, None
        try:
            if writer is not None:
                # (held: raises again a SIGINT or SIGTERM that stopped the run, once joined)
                writer.close(keep=False)
        finally:
            if self.path is not None:  # deleted all the same: nothing left on disk (issue 39)
                with contextlib.suppress(OSError):
                    self.path.unlink(missing_ok=True)


SCRATCH_QUEUE = 16
"""Chunks a run may hand the scratch file's thread ahead of its inserts (16 of the event
engine's 16384 rows: ~15 MB); past them the run waits for the thread: memory stays bounded."""

_KEEP, _DROP = "keep", "drop"


class _ScratchWriter:
    """The inserts into a run's scratch file, in a thread of its own, while the engine computes
    the next chunks (the engine's kernels release the GIL; SQLite's inserts mostly too). Before,
    the main thread inserted each chunk between two kernel calls: on the README scene run ten
    times longer (1.78 million bounces, a 1.0 s engine), 0.7 s of the run's 2.3 s.

    ``first``: (table, columns) chunks to insert before those handed by :meth:`put`. The
    connection is the thread's own. A failure of the thread is raised in the main thread at
    the next :meth:`put` or at :meth:`close` with ``keep``; after it, the thread drops what it
    is handed (a run never waits on a queue that nobody empties).
    """

    def __init__(self, path: Path, tables: dict[str, list[str]], first: list):
        self.path, self.tables = path, tables
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._queue: queue.Queue = queue.Queue(maxsize=SCRATCH_QUEUE)
        self._thread = threading.Thread(target=self._main, args=(first,), name="gaz-scratch", daemon=True)
        self._thread.start()

    def put(self, table: str, columns: list) -> None:
        """One more chunk (column arrays, not modified after); waits while SCRATCH_QUEUE are queued."""
        if self.error is not None:
            raise self.error
        self._queue.put((table, columns))

    def close(self, keep: bool) -> None:
        """``keep``: the rows committed, every chunk inserted (raise the thread's failure);
        else stop at once, the rows dropped. The thread is joined either way."""
        if not keep:
            self._stop.set()
        with interrupts.held():  # never left running: it sees the queue between two chunks
            self._queue.put(_KEEP if keep else _DROP)
            self._thread.join()
        if keep and self.error is not None:
            raise self.error

    def _main(self, first: list) -> None:
        conn = None
        try:
            conn = sqlite3.connect(self.path, isolation_level=None)
            conn.execute("PRAGMA journal_mode = OFF")
            conn.execute("PRAGMA synchronous = OFF")
            conn.execute("BEGIN")
            for table, names in self.tables.items():
                # no key, no index: rows are appended in order (rowid order = RE_NUM order)
                conn.execute(f"CREATE TABLE {table} ({', '.join(names)})")
            for table, columns in first:
                if self._stop.is_set():
                    break
                insert_rows(conn, table, self.tables[table], columns)
            first.clear()
            while True:
                item = self._queue.get()
                if item in (_KEEP, _DROP):
                    if item == _KEEP:
                        conn.execute("COMMIT")
                    return
                if not self._stop.is_set():
                    insert_rows(conn, item[0], self.tables[item[0]], item[1])
        except BaseException as err:  # raised in the main thread
            self.error = err
            self._stop.set()
            while self._queue.get() not in (_KEEP, _DROP):
                pass  # (dropped: the run fails at its next chunk)
        finally:
            if conn is not None:
                conn.close()


NEW_SUFFIX = ".new"
"""The suffix of the private file in which a new database is made until its first commit
(:class:`gaz_cli.results.sqlite.SqliteFile`), named as the scratch files are."""

_LEFT = tuple(f"{suffix}{extra}" for suffix in (SUFFIX, NEW_SUFFIX) for extra in ("", "-wal", "-shm", "-journal"))


def remove_stale(database: Path) -> None:
    """Delete the scratch files, and new databases' private files (with their WAL), left beside
    ``database`` by processes that no longer exist."""
    database = Path(database)
    with contextlib.suppress(OSError):
        # the name escaped: 'run[1].db' is a name, not a pattern ('[1]' matched '1', never itself)
        for path in database.resolve().parent.glob(f".{glob.escape(database.name)}.*"):
            if not path.name.endswith(_LEFT):
                continue
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

