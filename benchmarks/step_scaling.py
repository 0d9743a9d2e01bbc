"""Step engine on threads and processes: strong and weak scaling, per phase (seed 002's study).

The scene is issue 40's: argon in a 3D box at packing fraction 0.1, dt = 2e-14 s (``gaz
simulate --engine step --dim 3 --n N --packing 0.1 --species Ar --dt 2e-14``), with the box
cut into one patch per thread (:mod:`gaz_cli.engines.step.patches`). For each row the
median over ``--repeat`` runs (kernels compiled first, placement outside the clock) of the
run's wall time and of the seed's timers (push, collisions, walls, exchange, output: the
engine's ``phase_times``), the particle-steps per second, and the parallel efficiency:

* strong scaling (N fixed): T(1) / (c T(c)) on c cores (threads x processes);
* weak scaling (N / c fixed): T(1) / T(c).

Thread rows run in this process (one patch a thread); process rows (``--processes P``) run
``mpiexec -n p gaz simulate ... --threads 1 --no-db --json`` for p = 1..P with the mpiexec
next to this Python (``pip install -e '.[mpi]'``), reading the summary's ``wall_time_s`` and
``phase_times``, whose ``share`` is the allgather of the first pass's candidates between
ranks (engines/step/ranks.py), waiting for the slowest rank included. A process row's time
holds no start-up (imports, MPI start, placement, compilation: the summary's clock starts
after them).

The rows are the same bit for bit on every number of threads and processes
(tests/test_step_patches.py, tests/test_step_mpi.py); this file checks that the event counts
agree. Never assert a time in a test: this file prints, it does not judge. On a shared
machine, run it when the load is low and quote the load average it prints
(``os.getloadavg``).

    python benchmarks/step_scaling.py                       # N = 1e5, 100 steps, 1..cores
    python benchmarks/step_scaling.py --n 20000 --steps 1000 --repeat 5 --markdown
    python benchmarks/step_scaling.py --n 20000 --steps 200 --processes 2 --markdown
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time

import numba

from gaz_cli.api import make_scene
from gaz_cli.engines import step as stepper
from gaz_cli.model.recording import Recorder
from gaz_cli.placement.initial import initial_state

PHASES = ("push", "collisions", "walls", "exchange", "share", "output")


def scene_and_state(n: int, steps: int, dt: float = 2e-14):
    sc = make_scene(species=f"Ar:{n}", dim=3, packing=0.1, duration=steps * dt, dt=dt, seed=1, engine="step")
    return sc, initial_state(sc)


def measure(sc, st, threads: int, repeat: int) -> dict:
    """Median wall time and phase times of ``repeat`` runs on ``threads`` threads (one patch each)."""
    numba.set_num_threads(threads)
    walls, phases, counts = [], {k: [] for k in PHASES}, set()
    for _ in range(repeat):
        rs = stepper.run(sc, st, Recorder(), patches=threads)
        walls.append(rs.wall_time_s)
        for k in PHASES:
            phases[k].append(rs.extras["phase_times"].get(k, 0.0))
        counts.add((rs.collisions, rs.wall_bounces))
    if len(counts) != 1:
        raise RuntimeError(f"runs disagree: {counts}")
    steps = rs.extras["steps"]
    t = statistics.median(walls)
    return {"threads": threads, "procs": 1, "n": sc.n, "steps": steps, "wall": t,
            "phases": {k: statistics.median(v) for k, v in phases.items()},
            "rate": sc.n * steps / t, "counts": counts.pop(), "runs": walls}


def measure_processes(n: int, steps: int, procs: int, repeat: int, dt: float = 2e-14) -> dict:
    """Median wall time and phase times of ``repeat`` runs of ``mpiexec -n procs gaz simulate`` (one
    thread a process) on the scene of :func:`scene_and_state`."""
    bindir = os.path.dirname(sys.executable)
    mpiexec = shutil.which("mpiexec", path=bindir) or shutil.which("mpiexec")
    if mpiexec is None:
        raise SystemExit("no mpiexec: pip install -e '.[mpi]'")
    cmd = [mpiexec, "-n", str(procs), os.path.join(bindir, "gaz"), "simulate", "--engine", "step", "--dim", "3",
           "--species", f"Ar:{n}", "--packing", "0.1", "--duration", repr(steps * dt), "--dt", repr(dt), "--seed",
           "1", "--threads", "1", "--no-db", "--json", "--quiet"]
    walls, phases, counts = [], {k: [] for k in PHASES}, set()
    for _ in range(repeat):
        out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
        summary = json.loads(out)
        walls.append(summary["wall_time_s"])
        for k in PHASES:
            phases[k].append(summary["phase_times"].get(k, 0.0))
        counts.add((summary["collisions"], summary["wall_bounces"]))
    if len(counts) != 1:
        raise RuntimeError(f"runs disagree: {counts}")
    t = statistics.median(walls)
    return {"threads": 1, "procs": procs, "n": n, "steps": steps, "wall": t,
            "phases": {k: statistics.median(v) for k, v in phases.items()},
            "rate": n * steps / t, "counts": counts.pop(), "runs": walls}


def table(title: str, rows: list, weak: bool, markdown: bool) -> str:
    base = rows[0]["wall"]
    head = ["threads", "processes", "N", "wall s"] + [f"{k} s" for k in PHASES] + ["particle-steps/s", "efficiency"]
    lines = [title]
    if markdown:
        lines += ["", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    else:
        lines.append("  ".join(f"{h:>10}" for h in head))
    for r in rows:
        eff = base / r["wall"] if weak else base / (r["threads"] * r["procs"] * r["wall"])
        cells = [str(r["threads"]), str(r["procs"]), str(r["n"]), f"{r['wall']:.3f}"] + [f"{r['phases'][k]:.3f}" for k in PHASES] \
            + [f"{r['rate']:.3g}", f"{eff:.2f}"]
        lines.append("| " + " | ".join(cells) + " |" if markdown else "  ".join(f"{c:>10}" for c in cells))
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=100_000, help="particles of the strong scaling (default 1e5)")
    ap.add_argument("--per-thread", type=int, default=None, help="particles per thread of the weak scaling "
                    "(default N / cores)")
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=numba.config.NUMBA_NUM_THREADS, help="up to this many")
    ap.add_argument("--processes", type=int, default=0, help="also 1..this many MPI processes of one thread")
    ap.add_argument("--markdown", action="store_true")
    a = ap.parse_args()
    counts = list(range(1, a.threads + 1))
    print(f"# step engine scaling, {time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores, "
          f"NUMBA_NUM_THREADS {numba.config.NUMBA_NUM_THREADS}, threading layer after the runs below; "
          f"load average before {os.getloadavg()[0]:.1f}")
    sc, st = scene_and_state(a.n, a.steps)
    stepper.run(scene_and_state(1000, 2)[0], scene_and_state(1000, 2)[1], Recorder())  # compile
    strong = [measure(sc, st, t, a.repeat) for t in counts]
    strong += [measure_processes(a.n, a.steps, p, a.repeat) for p in range(1, a.processes + 1)]
    if len({r["counts"] for r in strong}) != 1:
        raise RuntimeError(f"threads or processes changed the events: {[r['counts'] for r in strong]}")
    print(table(f"\nStrong scaling: N = {a.n}, {a.steps} steps of 2e-14 s", strong, False, a.markdown))
    per = a.per_thread or a.n // a.threads
    weak = []
    for t in counts:
        sct, stt = scene_and_state(per * t, a.steps)
        weak.append(measure(sct, stt, t, a.repeat))
    weak += [measure_processes(per * p, a.steps, p, a.repeat) for p in range(1, a.processes + 1)]
    print(table(f"\nWeak scaling: N = {per} per thread, {a.steps} steps", weak, True, a.markdown))
    print(f"\nthreading layer {numba.threading_layer()}; load average after {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
