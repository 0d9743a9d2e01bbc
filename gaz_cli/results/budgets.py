"""What a run's rows need of the database before it starts: disk space for a SQLite file
(its growth, its WAL copy, the staging scratch file) and row numbers that fit PostgreSQL's
32-bit ``integer`` in a database made before schema 6.
"""

from __future__ import annotations

import os

from gaz_cli.model.checks import field_error
from gaz_cli.model.estimates import format_bytes, recorded_rows
from gaz_cli.model.scene import Scene

BYTES_PER_ROW = {"bounces": 47, "collisions": 53}
"""Growth of a SQLite database per recorded row, bytes: a REBOND row 46.6 (1,026,501 bounces
of one argon rod, 1D, L = 3.6e-10 m: 45 kB -> 47.8 MB), a CHOC row 53.1 (798,800
collisions, 2000 argon atoms, 3D periodic, packing 0.22: 45 kB -> 42.5 MB). The disk holds
more than that while a run commits: see :func:`database_peak`."""

STAGED_BYTES_PER_ROW = {"bounces": 71, "collisions": 62}
"""Size of a row in the scratch file a run of more than :data:`gaz_cli.results.staging.MEMORY_ROWS`
rows stages beside the database until its commit, bytes: a REBOND row 70.7 (256,694 bounces,
20 argon disks, L = 1e-7 m, 3e-6 s: 18.2 MB), a CHOC row 61.3 (67,187 collisions, 2000 argon
atoms, 3D periodic, packing 0.2: 4.1 MB); staging.MEMORY_ROWS lowered to 1000 for both."""


def database_peak(scene: Scene) -> tuple[float, float, float] | None:
    """(rows, growth, staged) of a run into a SQLite file: the rows it records
    (:func:`gaz_cli.model.estimates.work_estimate`'s wall bounces, and collisions with ``record`` all), the file's
    growth (times :data:`BYTES_PER_ROW`) and the scratch file that stages them when they are
    more than :data:`gaz_cli.results.staging.MEMORY_ROWS` (times :data:`STAGED_BYTES_PER_ROW`; else 0),
    bytes. None when not estimated: ``record`` none, ``force``, the step engine (its bounces
    against damped walls and planes), a preset's state (its speeds are not ``temperature``'s).

    While the run commits, the disk holds the scratch file, the rows in the database's WAL
    file, and (a checkpoint at the commit) the same rows copied into the database: the peak is
    2 growth + staged (measured, 256,694 bounces: 11.7 MB of growth, a peak of 41.7 MB staged,
    23.5 MB in memory)."""
    counts = recorded_rows(scene)
    if counts is None:
        return None
    from gaz_cli.results.staging import MEMORY_ROWS

    rows = sum(counts.values())
    growth = sum(k * BYTES_PER_ROW[kind] for kind, k in counts.items())
    staged = sum(k * STAGED_BYTES_PER_ROW[kind] for kind, k in counts.items()) if rows > MEMORY_ROWS else 0.0
    return rows, growth, staged


def _free_space(path) -> float | None:
    """Free bytes of the disk of the file ``path`` (None when its folder cannot be asked)."""
    import shutil

    try:
        return shutil.disk_usage(os.path.dirname(os.path.abspath(os.path.expanduser(str(path))))).free
    except OSError:
        return None


def check_database_space(scenes: list[Scene], path, fix: str = "shorten `duration`") -> None:
    """Refuse the runs of ``scenes`` (one run's, or a sweep's, committed one after the other)
    when their peak on the disk of SQLite file ``path`` would not fit in its free space: every
    run's growth, plus the largest run's WAL copy and scratch file (:func:`database_peak`).
    Runs not estimated are left out (``force`` among them). ``fix``: the first fix named."""
    peaks = [(s, p) for s in scenes if (p := database_peak(s)) is not None]
    if not peaks:
        return
    rows = sum(p[0] for _, p in peaks)
    growth = sum(p[1] for _, p in peaks)
    need = growth + max(p[1] for _, p in peaks) + max(p[2] for _, p in peaks)
    free = _free_space(path)
    if free is None or need <= free:
        return
    runs = f"{len(peaks)} runs, " if len(peaks) > 1 else ""
    record = " and ".join(sorted({s.record for s, _ in peaks}))
    staged = " (and a scratch file beside it before)" if any(p[2] for _, p in peaks) else ""
    raise field_error(f"database {str(path)!r} would grow by about {format_bytes(growth)} ({runs}{rows:.3g} rows "
                      f"recorded with `record` {record}) and needs about {format_bytes(need)} free while committing "
                      f"(the rows go through its WAL file{staged}); its disk has {format_bytes(free)} free; {fix}, "
                      "use `record` none, or give --db a file on another disk (or add `force`)")


INT4_MAX = 2 ** 31 - 1
"""The largest number PostgreSQL's ``integer`` holds: a run's REBOND and CHOC rows were numbered
in such columns (RE_NUM, CH_NUM) in a database made before PostgreSQL schema 6, which has
``bigint`` (SQLite's integers are 64-bit)."""


def check_row_numbers(scenes: list[Scene], narrow: tuple[str, ...], fix: str = "shorten `duration`") -> None:
    """Refuse, before any run, the runs of ``scenes`` whose rows of one kind would number past
    INT4_MAX in a table of ``narrow`` (those of "REBOND", "CHOC" whose row number is a 32-bit
    ``integer`` in the PostgreSQL database written: one made before schema 6) (:func:`recorded_rows`;
    runs not estimated, ``force`` among them, are left out): such a run failed at that row,
    after all its computation."""
    kinds = {"REBOND": ("wall bounces", "bounces", "re_num"), "CHOC": ("collisions", "collisions", "ch_num")}
    for scene in scenes:
        counts = recorded_rows(scene)
        if counts is None:
            continue
        for table in narrow:
            what, kind, column = kinds[table]
            if counts[kind] > INT4_MAX:
                raise field_error(f"this PostgreSQL database numbers its {table} rows with a 32-bit integer "
                                  f"(at most {INT4_MAX:,} a run); this run would record about {counts[kind]:.3g} "
                                  f"{what}; {fix}, use `record` none, widen the column once (ALTER TABLE "
                                  f"{table.lower()} ALTER COLUMN {column} TYPE bigint), or give --db a new "
                                  "database (or add `force`)")
