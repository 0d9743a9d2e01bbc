"""What recording costs (issue 15 item 3): the README example split into start-up,
engine and recording.

Not a test: it prints numbers. Run from the repository root:

    python benchmarks/recording.py                 # 5 rounds
    python benchmarks/recording.py --rounds 7 --record none
    python benchmarks/recording.py --rounds 7 --in-process   # recording / engine only
    python benchmarks/recording.py --rounds 7 --in-process --staged   # the same, no early insert
    python benchmarks/recording.py --rounds 7 --insert       # the INSERT alone
    python benchmarks/recording.py --rounds 3 --in-process --longer 10 --existing   # spilled rows

The scene is the README's first command (``gaz simulate --dim 3 --n 1000
--length 3.4e-8 --duration 1e-8 --seed 1 --db gaz.db``: 1000 argon atoms,
~178 thousand wall bounces). Each round, alternating:

- in process, ``runner.simulate`` into a new SQLite file (the writer,
  :mod:`gaz_cli.results.sqlite`, inserting the rows early from a thread while the engine
  runs; ``--staged``: not, the rows moved in after the engine), then the same scene with
  no database (``--no-db``): the engine alone. Since the writer works in a thread of its
  own, CPU time (``time.process_time``, every thread) no longer splits into engine and
  recording; the figures are:

  * *waited*: the main thread's wall seconds in the writer (every ``add_bounces`` call,
    the commit -- the last chunks' insert and the COMMIT -- and the close that checkpoints
    the rows into the file): what the user waits for, on a host with a core free for the
    thread;
  * *wall added*: the pair's difference of wall seconds (into a file minus no database,
    opening the store excluded): what the user waits for on this host, which also counts
    the engine slowed by the thread when no core is free;
  * *recording CPU*: the pair's difference of CPU seconds, every thread;
  * *critical path*: the main thread's extra CPU (``time.thread_time``: copies, the
    commit, the close) plus the writer thread's CPU after the engine stopped: the wall
    added on an idle host, fsync waits not counted;

  each over the engine's figure (the run with no database: wall, or the main thread's
  CPU for the critical path);
- ``python -m gaz_cli simulate ... --json`` with and without the database, as
  processes: start-up (process start to exit minus the run time it reports)
  and the end-to-end wall time (not with ``--in-process``).

Medians over the rounds are printed, with the issue's bound: recording under 25 % of
the engine's run time. Measured 2026-11-23 at load 3.5-4 on 2 cores (no core free):
gaz_cli.results.staging's docstring. ``--buffer-rows N``: an experiment, the event engine's
chunk of bounces (gaz_cli.engines.event.driver.BUFFER_ROWS) set to N.

``--insert`` also times, in wall seconds, the COMMIT and close of those rows (WAL, the
writer's synchronous FULL, and OFF for comparison): what the user waits for after the
engine however early the rows go in. Measured 2026-11-24 (``/tmp/s27/commit.py``, load
0.3): 24 ms with FULL (commit 21, close 3), 11 ms with OFF (no fsync), against a 75 ms
engine.

``--insert``: only :func:`gaz_cli.results.staging.insert_rows` of the example's REBOND rows (the
engine's chunks of 65536) into a new file, in one transaction, CPU per round (run it with PYTHONPATH at an older tree, alternating, to compare commits), and
beside it SQLite's own cost for the same rows: one ``INSERT ... SELECT`` from a TEMP copy
of them into the same file's REBOND (no Python, no binding: the floor of any writer
going through SQLite's B-tree, which holds REBOND's key (SI_NUM, RE_NUM)), and into a plain
table (a rowid, no key, no index, no journal; not the exam's schema): the floor of any
layout. Measured 2026-11-23 (5 rounds at load 2-3, then 3 rounds at load 2 in
benchmarks/issue15.py): insert_rows 198 / 148 ms, INSERT ... SELECT into REBOND 147 / 112
ms (0.63-0.83 us a row: 35-40 % of the example's 0.32-0.38 s engine), into the plain table
97 / 67 ms (21-27 %): only a table without the exam's key and without a journal comes near
the issue's 25 %, and no SQLite writer that runs after the engine reaches it with REBOND's
key. ``--record none``: the runs say
whether anything was staged (a scratch file, a row).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from gaz_cli.run import runner
from gaz_cli.results import sqlite as sqlite_writer
from gaz_cli.results.rows import TableRecorder
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import lookup

ARGS = ["--dim", "3", "--n", "1000", "--length", "3.4e-8", "--duration", "1e-8", "--seed", "1"]


LONGER = 1.0
"""``--longer K``: the scene run K times longer (K >= 6: past staging.MEMORY_ROWS, the rows
spill to a scratch file)."""
EXISTING = False
"""``--existing``: each round's run goes into a database that already holds one (in WAL;
the early insert bounded by the write lock), not into a new file."""


def scene(record: str, duration: float = 1e-8) -> Scene:
    return Scene(dim=3, length=3.4e-8, duration=duration * LONGER, components=((lookup("Ar"), 1000),),
                 seed=1, record=record)


class Clock:
    """CPU and wall seconds spent in the wrapped methods."""

    def __init__(self):
        self.cpu = self.wall = 0.0

    def wrap(self, cls, name):
        inner = getattr(cls, name)

        def timed(*args, **kw):
            c, w = time.process_time(), time.perf_counter()
            try:
                return inner(*args, **kw)
            finally:
                self.cpu += time.process_time() - c
                self.wall += time.perf_counter() - w

        setattr(cls, name, timed)


class Tail:
    """CPU seconds the early insert's thread spends after the engine has stopped (the inserts
    the user waits for): each chunk's thread CPU, the share of it after ``finish`` was called
    (prorated by wall time for a chunk under way then)."""

    def __init__(self):
        self.cpu = 0.0
        self.stopped = None

    def wrap(self):
        insert, finish = sqlite_writer._EarlyInsert._insert, sqlite_writer._EarlyInsert.finish

        def timed_insert(*args, **kw):
            c, w = time.thread_time(), time.perf_counter()
            try:
                return insert(*args, **kw)
            finally:
                cpu, end = time.thread_time() - c, time.perf_counter()
                stopped = self.stopped
                if stopped is not None and end > w:
                    self.cpu += cpu * (end - max(w, stopped)) / (end - w) if end > stopped else 0.0

        def timed_finish(*args, **kw):
            self.stopped = time.perf_counter()
            return finish(*args, **kw)

        sqlite_writer._EarlyInsert._insert = timed_insert
        sqlite_writer._EarlyInsert.finish = timed_finish


def in_process(db: str | None, record: str, recording: Clock, opening: Clock, tail: Tail) -> dict:
    recording.cpu = recording.wall = opening.cpu = opening.wall = tail.cpu = 0.0
    tail.stopped = None
    c, w, m = time.process_time(), time.perf_counter(), time.thread_time()
    out = runner.simulate(scene(record), db=db)
    cpu, wall, main = time.process_time() - c, time.perf_counter() - w, time.thread_time() - m
    return {"cpu": cpu, "wall": wall, "main_cpu": main, "tail_cpu": tail.cpu, "rec_cpu": recording.cpu,
            "rec_wall": recording.wall, "open_cpu": opening.cpu, "open_wall": opening.wall,
            "bounces": out["wall_bounces"]}


def as_process(extra: list[str]) -> tuple[float, float]:
    """(wall seconds from start to exit, the run time the summary reports)."""
    w = time.perf_counter()
    # the gaz this process imported (python -m puts its working folder first on sys.path:
    # from a checkout, a PYTHONPATH at an older tree would time the checkout)
    tree = str(Path(runner.__file__).resolve().parents[2])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([tree, os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
    res = subprocess.run([sys.executable, "-m", "gaz_cli", "simulate", *ARGS, *extra, "--json"],
                         capture_output=True, text=True, check=True, env=env, cwd=tempfile.gettempdir())
    return time.perf_counter() - w, json.loads(res.stdout)["wall_time_s"]


def measure(rounds: int = 5, record: str = "bounces", log=print, processes: bool = True) -> dict:
    """Alternating rounds (see the module docstring); returns the medians (seconds, and the
    ratios to the engine: ``ratio_wall`` waited, ``ratio_added`` wall added, ``ratio_cpu``
    recording CPU, ``ratio_path`` critical path) and ``rounds``: the per-round figures.
    ``rec_wall`` is the time waited, ``rec_cpu`` the pair's CPU difference. ``log`` gets one
    line per round (None: silent). ``processes=False``: no process runs (start-up and end to end
    not measured, NaN). benchmarks/engine.py's figure (j) calls this."""
    recording, opening, tail = Clock(), Clock(), Tail()
    saved = {(cls, name): cls.__dict__[name] for cls, name in WRAPPED + TAIL}
    try:
        for cls, name in WRAPPED:
            (opening if name == "__init__" else recording).wrap(cls, name)
        tail.wrap()
        return _rounds(rounds, record, recording, opening, tail, log, processes)
    finally:
        for (cls, name), inner in saved.items():
            setattr(cls, name, inner)


WRAPPED = [(TableRecorder, "add_bounces"), (TableRecorder, "add_collisions"),
           (sqlite_writer.StagedRun, "commit"), (sqlite_writer.SqliteFile, "close"),
           (sqlite_writer.SqliteFile, "__init__"), (sqlite_writer.StagedRun, "__init__")]
"""What is timed: recording is every chunk handed to the writer, the commit that moves the
rows in, and the close that checkpoints them into the file (SQLite's WAL); opening is
opening the file (schema checked or created) and the run's writer."""

TAIL = [(sqlite_writer._EarlyInsert, "_insert"), (sqlite_writer._EarlyInsert, "finish")]


def _rounds(rounds, record, recording, opening, tail, log, processes=True) -> dict:
    runner.simulate(scene(record), db=None)  # the JIT cache warm, imports done
    keys = ("rec_cpu", "rec_wall", "added_wall", "engine_cpu", "engine_wall", "alone_cpu", "open_cpu",
            "cpu_db", "startup", "e2e_db", "e2e_nodb", "ratio_cpu", "ratio_wall", "ratio_added",
            "path_cpu", "ratio_path")
    rows = {k: [] for k in keys}
    staged_any = []
    with tempfile.TemporaryDirectory(dir=Path.cwd()) as tmp:  # the disk a user's gaz.db is on
        for k in range(rounds):
            db = os.path.join(tmp, f"r{k}.db")
            if EXISTING:  # (not timed: the clocks are reset by in_process)
                runner.simulate(scene(record, 1e-12 / LONGER), db=db)
            r = in_process(db, record, recording, opening, tail)
            staged = [p.name for p in Path(tmp).iterdir() if p.name.endswith(".staging")]
            staged_any += staged
            alone = in_process(None, record, recording, opening, tail)
            if processes:
                wall_db, _ = as_process(["--record", record, "--db", os.path.join(tmp, f"p{k}.db")])
                wall_nodb, run_s = as_process(["--record", record, "--no-db"])
            else:
                wall_db = wall_nodb = float("nan")
                run_s = 0.0
            # the engine: the run with no database; recording's CPU (every thread's): the pair's
            # difference; the wall the user waits for it: the main thread's in the writer, and
            # the pair's difference (which also counts an engine slowed by the writer's thread)
            fig = {"engine_cpu": alone["cpu"], "engine_wall": alone["wall"], "alone_cpu": alone["cpu"],
                   "open_cpu": r["open_cpu"], "cpu_db": r["cpu"], "rec_wall": r["rec_wall"],
                   "rec_cpu": r["cpu"] - r["open_cpu"] - alone["cpu"],
                   "added_wall": r["wall"] - r["open_wall"] - alone["wall"]}
            # the critical path on a host with a core free for the writer's thread: what the main
            # thread spends beyond the run without a database (copies, the commit, the close),
            # and what the thread does after the engine stopped (CPU; fsync waits not counted)
            fig["path_cpu"] = r["main_cpu"] - r["open_cpu"] - alone["main_cpu"] + r["tail_cpu"]
            fig["ratio_path"] = fig["path_cpu"] / alone["main_cpu"]
            fig["ratio_cpu"] = fig["rec_cpu"] / fig["engine_cpu"]
            fig["ratio_wall"] = fig["rec_wall"] / fig["engine_wall"]
            fig["ratio_added"] = fig["added_wall"] / fig["engine_wall"]
            for key, value in fig.items():
                rows[key].append(value)
            rows["startup"].append(wall_nodb - run_s)
            rows["e2e_db"].append(wall_db)
            rows["e2e_nodb"].append(wall_nodb)
            if log:
                log(f"  round {k + 1}: {r['bounces']:,} bounces; no database {alone['wall']:.3f} s wall, "
                    f"{alone['cpu']:.3f} s CPU; into the file {r['wall']:.3f} s wall, {r['cpu']:.3f} s CPU "
                    f"(opening {r['open_wall']:.3f} s wall); recording: waited {r['rec_wall']:.3f} s wall "
                    f"= {fig['ratio_wall']:.1%} of the engine, added {fig['added_wall']:.3f} s wall "
                    f"= {fig['ratio_added']:.1%}, {fig['rec_cpu']:.3f} s CPU = {fig['ratio_cpu']:.1%}; "
                    f"critical path {fig['path_cpu']:.3f} s CPU = {fig['ratio_path']:.1%} of the engine's "
                    f"{alone['main_cpu']:.3f} s"
                    + (f"; processes: start-up {wall_nodb - run_s:.2f} s, end to end {wall_db:.2f} s with "
                       f"the database, {wall_nodb:.2f} s without" if processes else "")
                    + (f"; scratch files {staged}" if staged else ""))
    med = {k: statistics.median(v) for k, v in rows.items()}
    med["rounds"] = rows
    med["bounces"] = r["bounces"]
    med["staged"] = staged_any
    return med


def insert_only(rounds: int) -> None:
    """CPU seconds of staging.insert_rows alone for the example's bounces (see --insert)."""
    import sqlite3

    import numpy as np

    from gaz_cli.results import staging

    b = runner.run_scene(scene("bounces"), keep_bounces=True).bounces
    k = len(b["t"])
    columns = [np.arange(1, k + 1), b["t"], b["wall"], b["speed"], b["vperp"]]
    names = ["re_num", "re_t", "re_dir", "re_vit", "re_vp"]
    cpu, floor, plain = [], [], []
    with tempfile.TemporaryDirectory(dir=Path.cwd()) as tmp:
        for r in range(rounds):
            con = sqlite3.connect(os.path.join(tmp, f"i{r}.db"), isolation_level=None)
            con.execute("PRAGMA journal_mode = WAL")
            for statement in sqlite_writer.layout().statements:
                con.execute(statement)
            con.execute("BEGIN IMMEDIATE")
            con.execute("INSERT INTO simulation (si_num, si_deb, si_dur, si_dim, si_n, si_l) "
                        "VALUES (1, '2026-01-01 00:00:00', 1e-8, 3, 1000, 3.4e-8)")
            c = time.process_time()
            for start in range(0, k, 1 << 16):
                part = slice(start, start + (1 << 16))
                staging.insert_rows(con, "rebond", names, [a[part] for a in columns], {"si_num": 1, "pa_num": 1})
            cpu.append(time.process_time() - c)
            con.execute("COMMIT")
            # SQLite's own share: the same rows moved in by one INSERT ... SELECT from a TEMP
            # copy (no Python, no binding), as a second run of the same file
            con.execute("CREATE TEMP TABLE copy AS SELECT * FROM rebond")
            con.execute("BEGIN IMMEDIATE")
            con.execute("INSERT INTO simulation (si_num, si_deb, si_dur, si_dim, si_n, si_l) "
                        "VALUES (2, '2026-01-01 00:00:00', 1e-8, 3, 1000, 3.4e-8)")
            c = time.process_time()
            con.execute("INSERT INTO rebond SELECT 2, re_num, pa_num, re_t, re_dir, re_vit, re_vp "
                        "FROM copy")  # (in key order: copied from REBOND, read in rowid order)
            floor.append(time.process_time() - c)
            con.execute("COMMIT")
            # the floor of any layout: the same rows into a plain table (a rowid, no key, no
            # index; not the exam's schema), no journal
            con.execute("PRAGMA journal_mode = OFF")
            con.execute("CREATE TABLE plain (si_num, re_num, pa_num, re_t, re_dir, re_vit, re_vp)")
            con.execute("BEGIN IMMEDIATE")
            c = time.process_time()
            con.execute("INSERT INTO plain SELECT * FROM copy")
            con.execute("COMMIT")
            plain.append(time.process_time() - c)
            con.close()
    # what no overlap with the engine can hide: the COMMIT (its WAL frames and, past
    # wal_autocheckpoint, the checkpoint into the file) and the close (the last checkpoint),
    # wall seconds, with the writer's settings (synchronous FULL, SQLite's default) and,
    # for comparison only, with no fsync at all (synchronous OFF, unsafe: not used)
    tail = {"FULL": [], "OFF": []}
    with tempfile.TemporaryDirectory(dir=Path.cwd()) as tmp:
        for r in range(rounds):
            for sync in tail:
                con = sqlite3.connect(os.path.join(tmp, f"c{r}{sync}.db"), isolation_level=None)
                con.execute("PRAGMA journal_mode = WAL")
                con.execute(f"PRAGMA synchronous = {sync}")
                for statement in sqlite_writer.layout().statements:
                    con.execute(statement)
                con.execute("BEGIN IMMEDIATE")
                con.execute("INSERT INTO simulation (si_num, si_deb, si_dur, si_dim, si_n, si_l) "
                            "VALUES (1, '2026-01-01 00:00:00', 1e-8, 3, 1000, 3.4e-8)")
                for start in range(0, k, 1 << 16):
                    part = slice(start, start + (1 << 16))
                    staging.insert_rows(con, "rebond", names, [a[part] for a in columns],
                                        {"si_num": 1, "pa_num": 1})
                w = time.perf_counter()
                con.execute("COMMIT")
                con.close()
                tail[sync].append(time.perf_counter() - w)
    print(f"insert_rows of {k:,} REBOND rows: median {statistics.median(cpu) * 1e3:.1f} ms CPU "
          f"({statistics.median(cpu) / k * 1e6:.2f} us a row); rounds {[round(x * 1e3) for x in cpu]} ms")
    print(f"SQLite alone (INSERT ... SELECT of the same rows from a TEMP copy, no binding): median "
          f"{statistics.median(floor) * 1e3:.1f} ms CPU ({statistics.median(floor) / k * 1e6:.2f} us a "
          f"row); rounds {[round(x * 1e3) for x in floor]} ms")
    print(f"SQLite alone into a plain table (rowid, no key, no journal): median "
          f"{statistics.median(plain) * 1e3:.1f} ms CPU ({statistics.median(plain) / k * 1e6:.2f} us a "
          f"row); rounds {[round(x * 1e3) for x in plain]} ms")
    for sync, walls in tail.items():
        print(f"COMMIT + close of those rows (WAL, synchronous {sync}{', unsafe' if sync == 'OFF' else ''}): "
              f"median {statistics.median(walls) * 1e3:.1f} ms wall; rounds {[round(x * 1e3, 1) for x in walls]} ms")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=5, help="alternating rounds (default 5)")
    ap.add_argument("--record", choices=["bounces", "none", "all"], default="bounces")
    ap.add_argument("--in-process", action="store_true",
                    help="skip the process runs (start-up, end to end): recording / engine only")
    ap.add_argument("--insert", action="store_true", help="time staging.insert_rows alone (see above)")
    ap.add_argument("--staged", action="store_true",
                    help="no early insert (sqlite_writer.LOCK_BOUND_S = 0): the rows moved in after the engine")
    ap.add_argument("--buffer-rows", type=int, default=None,
                    help="an experiment: the event engine's chunk of bounces (driver.BUFFER_ROWS, 16384)")
    ap.add_argument("--longer", type=float, default=1.0,
                    help="the scene run K times longer (6 or more: the rows spill to a scratch file)")
    ap.add_argument("--existing", action="store_true",
                    help="each run into a database that holds one already, not into a new file")
    args = ap.parse_args()
    global LONGER, EXISTING
    LONGER, EXISTING = args.longer, args.existing
    ARGS[ARGS.index("--duration") + 1] = f"{1e-8 * LONGER:g}"
    if args.staged:
        sqlite_writer.LOCK_BOUND_S = 0
    if args.buffer_rows:
        from gaz_cli.engines.event import driver

        driver.BUFFER_ROWS = args.buffer_rows
    if args.insert:
        insert_only(args.rounds)
        return
    print(f"gaz recording benchmark: README example ({' '.join(ARGS)}), --record {args.record}, "
          f"{'staged' if args.staged else 'early insert'}, {'an existing' if EXISTING else 'a new'} file"
          + (f", chunks of {args.buffer_rows}" if args.buffer_rows else "") + "; "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; {args.rounds} rounds")
    med = measure(args.rounds, args.record, processes=not args.in_process)
    r = med["rounds"]

    def spread(key):
        return f"rounds {min(r[key]):.1%}-{max(r[key]):.1%}"

    print(f"median: engine (no database) {med['engine_wall']:.3f} s wall, {med['engine_cpu']:.3f} s CPU; "
          f"into a new file {med['cpu_db']:.3f} s CPU (every thread); recording waited for "
          f"{med['rec_wall']:.3f} s wall = {med['ratio_wall']:.1%} of the engine ({spread('ratio_wall')}); "
          f"wall added {med['added_wall']:.3f} s = {med['ratio_added']:.1%} ({spread('ratio_added')}); "
          f"recording CPU {med['rec_cpu']:.3f} s = {med['ratio_cpu']:.1%} ({spread('ratio_cpu')}); "
          f"critical path {med['path_cpu']:.3f} s CPU = {med['ratio_path']:.1%} ({spread('ratio_path')})")
    if not args.in_process:
        print(f"processes: start-up {med['startup']:.2f} s wall; end to end {med['e2e_db']:.2f} s with the "
              f"database, {med['e2e_nodb']:.2f} s without")


if __name__ == "__main__":
    main()
