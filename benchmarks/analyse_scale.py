"""Time and peak memory of ``gaz analyse --sim N`` on a database of 10^7 REBOND rows.

Builds (once, into --db) one 3D simulation of --rows synthetic wall bounces
(uniform times, Rayleigh normal speeds; written through Store's public
writer) plus a small second simulation, then runs ``gaz analyse --db DB
--sim 1`` --repeat times in a fresh process and prints the median and fastest
wall time, the child's CPU time (what the wall time would be on an idle
core: the host is shared) and its peak resident memory (ru_maxrss).

    python benchmarks/analyse_scale.py                       # 10^7 rows into /tmp/gaz_scale.db
    python benchmarks/analyse_scale.py --rows 1000000 --repeat 5
    python benchmarks/analyse_scale.py --old /tmp/base      # interleaved with an older tree (git archive)
    python benchmarks/analyse_scale.py --db postgresql://gaz@/scale?host=/tmp/pg   # the same on PostgreSQL

CPU time and peak RSS are each child's own (os.wait4's resource usage:
user + system seconds, ru_maxrss); the median of the runs is printed.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def build(db: str, rows: int) -> None:
    from gaz_cli.model.recording import RunStats
    from gaz_cli.model.scene import Scene, State
    from gaz_cli.model.species import lookup
    from gaz_cli.results.store import Store

    ar = lookup("Ar")
    store = Store(db)
    for k, (n, count) in enumerate(((10000, rows), (100, 1000))):
        scene = Scene(dim=3, length=1e-6, duration=1e-6, components=((ar, n),), seed=k + 1)
        rng = np.random.default_rng(k)
        with store.simulation(scene) as writer:
            chunk = 1_000_000
            for start in range(0, count, chunk):
                m = min(chunk, count - start)
                t = np.sort(rng.random(m)) * 1e-6 / (count / m) + start / count * 1e-6
                vp = rng.rayleigh(250.0, m)
                speed = np.hypot(vp, rng.rayleigh(250.0, m))
                wall = rng.choice([-3, -2, -1, 1, 2, 3], m)
                writer.add_bounces(t, rng.integers(0, n, m), wall, speed, vp)
            ke = 1.5 * n * 1.380649e-23 * 300
            writer.finish(RunStats(events=count, wall_bounces=count, collisions=0, wall_time_s=1.0,
                                   final=State(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, int))), ke, ke)


def built(db: str) -> bool:
    """Whether ``db`` (a path or URL) already holds the simulations."""
    if "://" not in db:
        return Path(db).exists()
    from gaz_cli.results.store import Store

    with Store(db) as store:
        return len(store.simulation_numbers()) >= 2


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--db", default="/tmp/gaz_scale.db")
    ap.add_argument("--rows", type=int, default=10_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--build-only", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--old", metavar="SRC", help="also time the gaz_cli found in the source tree SRC (e.g. a "
                    "'git archive' of an older commit), interleaved with this one")
    args = ap.parse_args()
    if args.build_only:
        build(args.db, args.rows)
        return
    if not built(args.db):
        t0 = time.perf_counter()
        # in a child: a child forked from a parent holding 10^7 rows reports that parent's memory as its peak
        subprocess.run([sys.executable, __file__, "--db", args.db, "--rows", str(args.rows), "--build-only"],
                       check=True)
        print(f"built {args.db}: {args.rows} + 1000 REBOND rows in {time.perf_counter() - t0:.0f} s "
              + (f"({Path(args.db).stat().st_size / 1e6:.0f} MB)" if "://" not in args.db else ""))
    runs = {"new": None} if not args.old else {"old": args.old, "new": None}
    figures = {k: ([], [], []) for k in runs}
    for _ in range(args.repeat):
        for name, src in runs.items():          # interleaved: the shared host's load hits both alike
            env = dict(os.environ)
            if src:
                env["PYTHONPATH"] = os.pathsep.join([src, env.get("PYTHONPATH", "")])
            t0 = time.perf_counter()
            proc = subprocess.Popen([sys.executable, "-m", "gaz_cli", "analyse", "--db", args.db, "--sim", "1"],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env,
                                    cwd=src or Path(__file__).resolve().parent.parent)  # -m puts the cwd first
            err = proc.stderr.read()
            _, status, usage = os.wait4(proc.pid, 0)   # this child's own CPU time and peak memory
            took = time.perf_counter() - t0
            if os.waitstatus_to_exitcode(status):
                sys.exit(err)
            times, cpus, peaks = figures[name]
            times.append(took)
            cpus.append(usage.ru_utime + usage.ru_stime)
            peaks.append(usage.ru_maxrss / 1024)
    for name, (times, cpus, peaks) in figures.items():
        print(f"{os.cpu_count()} cores; {name}{' (' + runs[name] + ')' if runs[name] else ''}: gaz analyse --sim 1 on "
              f"{args.rows} rows: wall median {statistics.median(times):.2f} s, fastest {min(times):.2f} s over "
              f"{args.repeat} runs; CPU time (user + sys) median {statistics.median(cpus):.2f} s (the wall time on "
              f"an idle core); peak RSS median {statistics.median(peaks):.0f} MB; load average {os.getloadavg()[0]:.1f}")
        print(f"  every run: wall {', '.join(f'{t:.2f}' for t in times)} s; CPU {', '.join(f'{c:.2f}' for c in cpus)} s; "
              f"peak RSS {', '.join(f'{p:.0f}' for p in peaks)} MB")


if __name__ == "__main__":
    main()
