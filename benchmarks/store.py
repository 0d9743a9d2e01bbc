"""Figures of the results store (issue 13): REBOND rows per second into each backend.

Not a test: it prints numbers. Run from the repository root:

    python benchmarks/store.py                                  # SQLite, in a temporary folder
    python benchmarks/store.py --db postgresql://gaz@/gaz?host=/tmp/pg --rows 1000000
    python benchmarks/store.py --db URL_1 --db URL_2 --repeat 5
    python benchmarks/store.py --db postgresql://plain@/plaindb?host=/tmp/pg --explain
    python benchmarks/store.py --db postgresql://gaz@/gaz?host=/tmp/pg --rows 0 --planning 500

--planning N (PostgreSQL) fills the database up to N simulations of 10 bounces
each (N partitions of REBOND) and prints the planning and execution time
(EXPLAIN ANALYZE, median of 5) of the queries ``gaz analyse`` runs on REBOND
(sql/bounce_bins.sql, pressure_per_wall.sql, q35_bounces_per_simulation.sql)
for one simulation.

--explain (PostgreSQL) adds the server's side of the cost: EXPLAIN ANALYZE of
one INSERT ... SELECT of --rows rows into REBOND (foreign-key triggers as the
role's own COPY would run them, each trigger's time per row) and into a
key-less copy of it (PRIMARY KEY index only), in a transaction rolled back.

Each round writes one simulation of --rows wall bounces (random rows in the
engine's chunk size, 2^16) through the store's own writer
(``Store.simulation``: what ``gaz simulate`` does), from the first chunk to
the commit, and counts rows per wall-clock second; the median and the
fastest of --repeat rounds are printed (a busy host only ever slows a round
down). The engine is not run: this is the store's cost alone.

SQLite: rows go to the scratch file during the run, and move in at the
commit (both timed; the commit alone is also given, as it is the time the
database's write lock is held). PostgreSQL: binary COPY into the run's
transaction; the line says which path the role takes: into the run's own
table, attached whole to the partitioned REBOND at the commit (schema 4+, a
role owning REBOND: the commit builds its index and checks its keys in bulk,
and is timed), or into REBOND itself, with or without the per-row key
triggers (session_replication_role).

Figures it gave, with their dates and hosts: docs/explanation/storage.md.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from dataclasses import replace

import numpy as np
import sqlalchemy as sa

from gaz_cli.results import postgres as pg
from gaz_cli.results import store as st
from gaz_cli.model.recording import RunStats
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import lookup

CHUNK = 1 << 16


def scene() -> Scene:
    """Argon in 3D, 1000 particles (the README example's size); only its rows matter here."""
    return Scene(dim=3, length=3.4e-8, duration=1e-8, components=((lookup("Ar"), 1000),), seed=1)


def one_round(db: str, rows: int, rng, table: str = "rebond") -> tuple[float, float, int]:
    """Write one simulation of ``rows`` bounces (or collisions, ``table`` "choc"); (seconds
    in all, seconds of the commit, SI_NUM)."""
    sc = replace(scene(), record="all")
    state = initial_state(sc)
    t = np.sort(rng.random(rows) * sc.duration)
    particle = rng.integers(0, sc.n, rows)
    wall = (rng.integers(0, 3, rows) + 1) * rng.choice([-1, 1], rows)
    vperp = rng.random(rows) * 500
    speed = vperp + rng.random(rows) * 100
    with st.Store(db) as store:
        start = time.perf_counter()
        with store.simulation(sc) as writer:
            for lo in range(0, rows, CHUNK):
                part = slice(lo, lo + CHUNK)
                if table == "choc":
                    writer.add_collisions(t[part], particle[part], (particle[part] + 1) % sc.n, speed[part] * 1e-25)
                else:
                    writer.add_bounces(t[part], particle[part], wall[part], speed[part], vperp[part])
            writer.finish(RunStats(rows, rows, 0, 1.0, state), 1.0, 1.0)
            before_commit = time.perf_counter()
        end = time.perf_counter()
        return end - start, end - before_commit, writer.si_num


def describe(db: str) -> str:
    with st.Store(db) as store:
        if store.is_sqlite:
            return "SQLite (WAL; rows staged in a scratch file, moved in at the commit)"
        with store.engine.connect() as conn:
            version = conn.exec_driver_sql("SHOW server_version").scalar()
            superuser = conn.exec_driver_sql("SELECT current_setting('is_superuser')").scalar() == "on"
            attach = pg._may_attach(conn)
            fast = pg._may_skip_key_triggers(conn)
    role = "superuser" if superuser else "ordinary role"
    if attach:
        how = (f"{role}: COPY into the run's own table, attached as REBOND's partition at the commit "
               "(keys checked in bulk)")
    elif fast:
        how = f"{role} that may set session_replication_role: COPY without the per-row key triggers"
    else:
        how = f"{role}, may not attach partitions to REBOND: every row checked by the key triggers"
    return f"PostgreSQL {version} (binary COPY; {how})"


def explain(db: str, rows: int) -> None:
    """Print where the server spends a bulk insert's time (see the module docstring)."""
    import json

    with st.Store(db) as store, store.engine.connect() as conn:
        si = conn.exec_driver_sql("SELECT max(si_num) FROM simulation").scalar()
        pa = conn.exec_driver_sql("SELECT min(pa_num) FROM particule").scalar()
        conn.exec_driver_sql(
            "CREATE TEMP TABLE bench_src AS SELECT si_num, re_num, pa_num, re_t, re_dir, re_vit, re_vp "
            "FROM rebond LIMIT 0")
        conn.exec_driver_sql(
            f"INSERT INTO bench_src SELECT {si}, 1000000000 + g, {pa}, random(), 1 + mod(g, 3), random(), "
            f"random() FROM generate_series(1, {rows}) g")
        conn.exec_driver_sql("CREATE TEMP TABLE bench_keyless (LIKE rebond INCLUDING INDEXES)")
        for target in ("rebond", "bench_keyless"):
            plan = conn.exec_driver_sql(f"EXPLAIN (ANALYZE, FORMAT JSON) INSERT INTO {target} "
                                        "SELECT * FROM bench_src").scalar()
            plan = (json.loads(plan) if isinstance(plan, str) else plan)[0]
            total = plan["Execution Time"] / 1e3
            triggers = "; ".join(f"{t['Trigger Name']} {t['Time'] / t['Calls'] * 1e3:.1f} us/row"
                                 for t in plan.get("Triggers", []))
            print(f"  server, INSERT ... SELECT of {rows:,} rows into {target}: {total:.2f} s, "
                  f"{rows / total:,.0f} rows/s" + (f" (key triggers: {triggers})" if triggers else ""))
        conn.rollback()


def planning(db: str, runs: int) -> None:
    """Print the planning and execution times of analyse's REBOND queries with ``runs`` partitions."""
    import json

    rng = np.random.default_rng(2)
    with st.Store(db) as store:
        while len(store.simulation_numbers()) < runs:
            one_round(db, 10, rng)
        numbers = store.simulation_numbers()
        with store.engine.connect() as conn:
            parts = conn.exec_driver_sql(
                "SELECT count(*) FROM pg_inherits WHERE inhparent = to_regclass('rebond')").scalar()
            si = numbers[len(numbers) // 2]
            params = dict(si_num=si, bins=512, duration=1e-8)
            print(f"  {len(numbers)} simulations, REBOND in {parts} partitions; queries for SI_NUM {si}:")
            for name in ("bounce_bins", "pressure_per_wall", "q35_bounces_per_simulation"):
                plans, runs_ = [], []
                for _ in range(5):
                    plan = conn.execute(sa.text("EXPLAIN (ANALYZE, FORMAT JSON) " + st.query_text(name)),
                                        {k: v for k, v in params.items() if f":{k}" in st.query_text(name)}
                                        ).scalar()
                    plan = (json.loads(plan) if isinstance(plan, str) else plan)[0]
                    plans.append(plan["Planning Time"])
                    runs_.append(plan["Execution Time"])
                print(f"    {name}: planning {statistics.median(plans):.2f} ms, "
                      f"execution {statistics.median(runs_):.2f} ms")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--db", action="append", help="database path or URL (repeatable); default a temporary SQLite file")
    ap.add_argument("--rows", type=int, default=1_000_000, help="rows per round (default 10^6)")
    ap.add_argument("--repeat", type=int, default=3, help="rounds per database (default 3)")
    ap.add_argument("--table", choices=("rebond", "choc"), default="rebond",
                    help="the rows written: REBOND (wall bounces, default) or CHOC (collisions, --record all)")
    ap.add_argument("--planning", type=int, metavar="N",
                    help="PostgreSQL: planning time of analyse's queries with N simulations (partitions)")
    ap.add_argument("--explain", action="store_true",
                    help="PostgreSQL: also time the server's side (key triggers or not) by EXPLAIN ANALYZE")
    args = ap.parse_args()
    load = os.getloadavg()
    print(f"gaz store benchmark: {os.cpu_count()} cores, load average {load[0]:.2f}; "
          f"{args.rows:,} {args.table.upper()} rows per round, chunks of {CHUNK:,}, {args.repeat} rounds")
    with tempfile.TemporaryDirectory() as tmp:
        for db in args.db or [os.path.join(tmp, "bench.db")]:
            rng = np.random.default_rng(1)
            print(f"\n{st.shown(db)}: {describe(db)}")
            rates, commits = [], []
            for _ in range(args.repeat if args.rows else 0):
                total, commit, si = one_round(db, args.rows, rng, args.table)
                rates.append(args.rows / total)
                commits.append(commit)
                print(f"  SI_NUM {si}: {total:.2f} s, {args.rows / total:,.0f} rows/s (commit {commit:.2f} s)")
            if rates:
                print(f"  median {statistics.median(rates):,.0f} rows/s, fastest {max(rates):,.0f} rows/s; "
                      f"commit median {statistics.median(commits):.2f} s")
            if args.explain and "://" in db:
                explain(db, args.rows)
            if args.planning and "://" in db:
                planning(db, args.planning)


if __name__ == "__main__":
    main()
