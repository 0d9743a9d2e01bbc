"""Issue 15's targets (items 2-6) in one run, side by side with an older tree.

Not a test: it prints numbers. Run from the repository root, after ``pip install -e .``:

    git archive 8b6e7d9 | (mkdir -p /tmp/old && tar -x -C /tmp/old)
    ln -s ../sql /tmp/old/gaz_cli/sql
    python benchmarks/issue15.py --old /tmp/old --edmd PATH_TO_EDMD --pairs 7

``--old`` is the code the targets are stated against (a copy of a commit: the issue's
"today's code"); ``--edmd`` a copy of F. Smallenburg's EDMD (see benchmarks/smallenburg.py;
without it item 5 is skipped). One command, one host state, in this order:

* item 2, the engine side by side: for each scene, ``--pairs`` pairs of child processes,
  one on each tree (PYTHONPATH on it, a Numba cache of its own), the tree that runs first
  alternating from pair to pair; each child compiles with a short run, then times
  ``engine.run`` (record none) in CPU seconds of its own process (``time.process_time``:
  what a shared host disturbs least; compilation excluded). Printed per pair: CPU
  seconds, physical events (collisions + wall bounces; the same count on both trees when
  the trajectory is), new/old speed; then the median ratio and the work per physical event
  (queue events, cell crossings, pair tests). Scenes: the README example's engine (1000
  argon atoms, 300 K, 34 nm box with walls, 10 ns; target >= 3x), scene (b) of
  benchmarks/engine.py (argon, N = 10^4, packing 0.01, walls, 10 mean free times;
  target >= 3x events per second) and scene (a) (3D periodic, N = 4000, packing 0.30,
  lattice start, t = 20; target: not slower); with ``--edmd``, also scene (b)'s gas
  (N = 10^4, packing 0.01) against the C code's "Cell" variant, periodic, and gaz in a box
  with walls beside it (``benchmarks/smallenburg.py --variant Cell --walled``): the
  restatement of (b) suggested in the closing notes, ">= 1.0x the best C code on the same
  gas";
* item 3: ``benchmarks/recording.py --in-process`` (recording / engine on the README
  example, this tree; target < 25 %), then ``--insert``: gaz's insert of the example's
  REBOND rows beside SQLite's own cost for the same rows (the floor of any writer);
* item 4: ``benchmarks/startup.py --against OLD`` (tiny scene, process start to exit
  against ``python -c "import numpy, numba"``; targets 1.15 with --no-db, 1.35 with a
  new SQLite file);
* item 5: ``benchmarks/smallenburg.py`` (neighbour lists, 3D periodic, packing 0.45,
  N = 10^4, against the C code's "Single" variant; target gaz/C >= 1.0);
* item 6: ``benchmarks/mixtures.py`` (1:100 mixtures with 1 % large particles against
  the small ones alone, this tree; target <= 2).

Each child script's own output is passed through whole (its pairs, its medians); the host
load is printed before each section.

Figures of 2026-11-23 (``--old`` a copy of 8b6e7d9, ``--pairs 5``, new = 402ccc5; 2 cores,
load 2-3: a test suite ran beside it), medians of the pairs' ratios:

| item | target | this run |
| --- | --- | --- |
| 2, README example engine | >= 3x | 3.07 (3.38, 3.01, 3.62, 2.86, 3.07); 0 crossings, 1.02 queue events per physical event |
| 2, scene (b) | >= 3x | 0.78 (0.78, 1.15, 0.99, 0.76, 0.77); 7.96 crossings per physical event (cells) |
| 2, scene (a) | not slower | 1.02 (0.92, 1.08, 0.98, 1.02, 1.16) |
| 3, recording / engine | < 25 % | 62.7 %; SQLite's own insert of the rows 105.7 ms, 28 % of the 0.376 s engine |
| 4, start-up | <= 1.15 / 1.35 | 1.01 no database, 0.99 new SQLite file (CPU) |
| 5, gaz / C, lists | >= 1.0 | 0.905 CPU (0.953, 0.833, 0.996, 0.768, 0.905) |
| 6, mixture / small alone | <= 2 | 2D 1.29 per queue event, 1.41 per simulated second; 3D 2.53 per simulated second (its small-alone scene now takes the dilute scan) |

Figures of 2026-11-23, second session (``--pairs 3``, new = 93e5f2b: wide cells on (b)):
run A with a test suite beside it (load 1.3-2.1), run B ``--only 2,5`` on a quiet host
(load 0.1-1.0):

| item | target | run A | run B |
| --- | --- | --- | --- |
| 2, README example engine | >= 3x | 2.74 (3.19, 2.74, 2.46) | 2.98 (2.98, 3.11, 2.09) |
| 2, scene (b) | >= 3x | 1.17 (1.17, 1.25, 1.06) | 1.12 (0.73, 1.29, 1.12); 9 wide cells an axis, 2.36 crossings, 3.62 queue events per physical event |
| 2, scene (a) | not slower | 1.08 | 1.01 |
| 3, recording / engine | < 25 % | 66.0 %; SQLite's own insert into REBOND 112 ms (35 %), into a keyless table 67 ms (21 %) | |
| 4, start-up | <= 1.15 / 1.35 | 1.13 / 1.11 wall (1.14 / 1.14 CPU) | |
| 5, gaz / C, lists | >= 1.0 | 0.899 | 0.842 |
| 6, mixture / small alone | <= 2 | per physical event 2D 0.97, 3D 1.19 (per simulated second 2.27, 3.39: 2.34x, 2.86x the physical events) | |

Figures of 2026-11-23, third session (``--pairs 3``, new = 6b23c39: the calendar inlined,
the dilute pass rewritten, the early insert with chunks of 16384 rows, no Numba in a tiny
run; quiet host, load 0.1-1.0, nothing beside it):

| item | target | this run |
| --- | --- | --- |
| 2, README example engine | >= 3x | 6.08 (6.06, 6.08, 6.25); 1.02 queue events, 0 crossings per physical event |
| 2, scene (b) | >= 3x | 1.43 (1.28, 1.43, 1.56); 9 wide cells an axis, 3.62 queue events, 2.36 crossings per physical event |
| 2, scene (a) | not slower | 1.15 (1.14, 1.15, 1.19) |
| 3, recording / engine | < 25 % | wall added 44.6 % (rounds 44.4-47.3 %) of a 0.089 s engine; recording CPU 110 %; gaz's insert 72.2 ms against SQLite's own INSERT ... SELECT into REBOND 54.2 ms (61 % of the engine) and into a keyless table 34.5 ms (39 %) |
| 4, start-up | <= 1.15 / 1.35 | 0.64 / 0.69 wall (0.75 / 0.76 CPU); the old tree 1.28 / 1.38 wall |
| 5, gaz / C, lists | >= 1.0 | 1.134 CPU (1.143, 1.115, 1.134), 1.151 wall |
| 6, mixture / small alone | <= 2 | per physical event 2D 1.59, 3D 1.42 (per simulated second 3.73, 4.05: 2.34x, 2.86x the physical events) |

Figures of 2026-11-23, fourth session (``--pairs 3``, new = 3653bb9: 'auto' weighing the
three walled searches, wide blocks of 16 slots, wide cells below packing 0.02, the cell
path's root only for a hit, crossing by selects, unsigned gather; load 1.0-1.2, 3 min):

| item | target | this run |
| --- | --- | --- |
| 2, README example engine | >= 3x | 6.69 (6.50, 6.72, 6.69) |
| 2, scene (b) | >= 3x | 1.41 (1.65, 1.41, 1.41); 3.62 queue events, 2.36 crossings per physical event |
| 2, scene (a) | not slower | 1.44 (1.43, 1.44, 1.52) |
| 3, recording / engine | < 25 % | wall added 64.4 % (rounds 61.6-96.3 %, 3 rounds) of a 0.078 s engine; CPU 137 %; gaz's insert 73.6 ms, SQLite's own 53.2 ms (68 % of the engine) |
| 4, start-up | <= 1.15 / 1.35 | 0.57 / 0.60 wall; the old tree 1.19 / 1.18 |
| 5, gaz / C, lists | >= 1.0 | 1.116 CPU (1.088, 1.116, 1.125), 1.132 wall |
| 6, mixture / small alone | <= 2 | per physical event 2D 1.17, 3D 2.29: the small spheres alone now take wide cells (2.0 us a physical event, the dilute scan's 13.1 before), the mixture keeps its size classes (4.5 us) |

Figures of 2026-11-24 (``--pairs 3``, new = b1f948b: mixtures with walls take the cheapest
of size classes, wide cells and the dilute scan by engine/mixture_cost.py; load 0.6-1.0,
02:09-02:12 UTC, nothing beside it):

| item | target | this run |
| --- | --- | --- |
| 2, README example engine | >= 3x | 6.76 (6.76, 6.71, 6.78) |
| 2, scene (b) | >= 3x | 1.54 (1.54, 1.59, 1.52); 2.36 crossings per physical event |
| 2, scene (a) | not slower | 1.47 (1.46, 1.47, 1.48) |
| 3, recording / engine | < 25 % | wall added 52.6 % (rounds 48.5-53.8 %) of a 0.074 s engine; CPU 125 %; gaz's insert 69.8 ms, SQLite's own 50.9 ms (69 % of the engine) |
| 4, start-up | <= 1.15 / 1.35 | 0.55 / 0.65 wall; the old tree 1.20 / 1.19 |
| 5, gaz / C, lists | >= 1.0 | 1.117 CPU (1.117, 1.142, 1.109), 1.132 wall |
| 6, mixture / small alone | <= 2 | per physical event 2D 1.50, 3D 1.48: the 3D mixture now takes wide cells (6 an axis), 3.0 us a physical event against 4.5 with size classes |

Figures of 2026-11-25 (``--pairs 3``, new = 83b0102: wide cells scan the cells along each
particle's path; 'auto' takes them below packing 0.08 in 3D, 0.05 in 2D; load 0.5-1.1,
02:33-02:39 UTC, nothing beside it):

| item | target | this run |
| --- | --- | --- |
| 2, README example engine | >= 3x | 4.17 (4.17, 4.18, 4.08) |
| 2, scene (b) | >= 3x | 2.72 (2.72, 2.67, 3.35); 7 wide cells an axis, 1.76 crossings per physical event (``--only 2 --pairs 5`` at 064178c: 2.76) |
| 2, (b)'s gas against the C code's Cell variant | | gaz/C 2.42 CPU (2.40, 2.53, 2.42), 2.72 with walls |
| 2, scene (a) | not slower | 1.40 (1.39, 1.40, 1.40) |
| 3, recording / engine | < 25 % | waited 12.3 % (rounds 11.1-12.7 %), wall added 28.4 %; gaz's insert 82.4 ms, SQLite's own 63.0 ms |
| 4, start-up | <= 1.15 / 1.35 | 0.57 / 0.66 wall; the old tree 1.18 / 1.25 |
| 5, gaz / C, lists | >= 1.0 | 1.232 CPU (1.290, 1.232, 1.214), 1.251 wall |
| 6, mixture / small alone | <= 2 | per physical event 2D 1.67, 3D 1.75: both mixtures on wide cells (15 and 6 an axis) |

Figures of 2026-11-25, later (``--pairs 5``, new = cba5283: less Python around the loop, the
next events' rows requested in every run, wide cells' survivors gathered with their rows
requested; load 0.7-1.3, 05:50-06:00 UTC, nothing beside it):

| item | target | this run |
| --- | --- | --- |
| 2, README example engine | >= 3x | 4.28 (4.40, 4.28, 4.61, 4.28, 4.09) |
| 2, scene (b) | >= 3x | 2.99 (3.13, 2.99, 3.28, 2.95, 2.98); ``--only 2 --pairs 5`` just before, same code: 3.04 (3.04, 3.13, 2.95, 3.07, 2.98) |
| 2, (b)'s gas against the C code's Cell variant | | gaz/C 2.60 CPU (2.68, 2.60, 2.55, 2.56, 2.70), 2.99 with walls |
| 2, scene (a) | not slower | 1.41 (1.40, 1.43, 1.41, 1.41, 1.41) |
| 3, recording / engine | < 25 % | waited 9.9 % (rounds 9.4-13.7 %), wall added 16.6 %; gaz's insert 78.4 ms, SQLite's own 58.5 ms |
| 4, start-up | <= 1.15 / 1.35 | 0.60 / 0.67 wall; the old tree 1.23 / 1.30 |
| 5, gaz / C, lists | >= 1.0 | 1.222 CPU, 1.241 wall (medians of 5 pairs) |
| 6, mixture / small alone | <= 2 | per physical event 2D 1.61, 3D 1.85 (the small particles alone got faster) |

Figures of 2026-11-25, latest (``--pairs 5``, new = 1d93762: the rejection pass's verdicts read
eight at a time, ``intrinsics._kept8``; load 0.3-1.1, 09:18-09:26 UTC, nothing beside it;
the same command on 64433ff at 08:30 gave (b) 2.95 (3.00, 2.93, 2.95, 2.95, 3.00)):

| item | target | this run |
| --- | --- | --- |
| 2, README example engine | >= 3x | 4.67 (4.35, 4.95, 4.97, 4.58, 4.67) |
| 2, scene (b) | >= 3x | 3.03 (3.00, 3.04, 3.03, 3.20, 3.00); ``--only 2 --pairs 5`` twice after it, same code: 3.14 (3.08, 3.15, 3.24, 3.08, 3.14) and 3.05 (3.02, 3.12, 3.10, 3.05, 3.03) |
| 2, (b)'s gas against the C code's Cell variant | | gaz/C 2.69 CPU (2.65, 2.70, 2.66, 2.78, 2.69), 2.94 with walls |
| 2, scene (a) | not slower | 1.42 (1.42, 1.51, 1.42, 1.44, 1.41) |
| 3, recording / engine | < 25 % | waited 13.8 % (rounds 12.5-15.8 %), wall added 14.3 %; gaz's insert 83.2 ms, SQLite's own 61.8 ms |
| 4, start-up | <= 1.15 / 1.35 | 0.55 / 0.60 wall; the old tree 1.15 / 1.19 |
| 5, gaz / C, lists | >= 1.0 | 1.234 CPU (1.234, 1.229, 1.257, 1.238, 1.214), 1.252 wall |
| 6, mixture / small alone | <= 2 | per physical event 2D 1.58, 3D 1.62 |
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

SCENES = ("readme", "b", "a")
TARGET = {"readme": "new/old >= 3", "b": "new/old >= 3", "a": "new/old >= 1 (not slower)"}


def _scene(name: str):
    """The scene of one item-2 case (built in the child, on its tree's API)."""
    from gaz_cli.constants import K_B
    from gaz_cli.model.scene import Scene
    from gaz_cli.model.species import Species, lookup

    ar = lookup("Ar")
    if name == "readme":
        return Scene(dim=3, length=3.4e-8, duration=1e-8, components=((ar, 1000),), seed=1,
                     record="none")
    if name == "b":  # as benchmarks/engine.py's fig_b, 10 mean free times
        n, eta = 10_000, 0.01
        length = (n * 4.0 / 3.0 * math.pi * ar.radius ** 3 / eta) ** (1 / 3)
        speed = math.sqrt(8 * K_B * 300 / (math.pi * ar.mass))
        free_time = 1.0 / (math.sqrt(2) * math.pi * n / length ** 3 * (2 * ar.radius) ** 2 * speed)
        return Scene(dim=3, length=length, duration=10 * free_time, components=((ar, n),),
                     seed=2, record="none")
    if name == "a":  # as benchmarks/engine.py's fig_a, lattice start, t = 20
        n, eta = 4000, 0.30
        length = (n * math.pi / 6.0 / eta) ** (1 / 3)
        return Scene(dim=3, length=length, duration=20.0, components=((Species("X", 1.0, 0.5), n),),
                     temperature=1.0 / K_B, seed=1, boundary="periodic", placement="lattice",
                     record="none")
    raise ValueError(name)


def child(name: str) -> None:
    """Time one scene's engine on the tree gaz_cli is imported from; print one JSON line."""
    import dataclasses

    from gaz_cli.engines import event as engine
    from gaz_cli.model.recording import Recorder
    from gaz_cli.placement.initial import initial_state

    sc = _scene(name)
    st = initial_state(sc)
    engine.run(dataclasses.replace(sc, duration=sc.duration * 1e-3), st, Recorder())  # compile or load
    c0 = time.process_time()
    rs = engine.run(sc, st, Recorder())
    cpu = time.process_time() - c0 - rs.extras.get("compile_s", 0.0)
    ex = rs.extras
    print(json.dumps({"cpu": cpu, "events": rs.events, "queue_events": ex.get("queue_events", 0),
                      "crossings": ex.get("cell_crossings", 0) + ex.get("list_rebuilds", 0),
                      "pair_tests": ex.get("pair_tests", 0),
                      "search": ("dilute scan" if ex.get("dilute_scan") else
                                 "lists" if ex.get("neighbour_lists") else
                                 f"{ex.get('cells_per_axis')} cells an axis")}))


def _run_child(tree: Path, name: str, cache: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", name],
                         env=env, cwd=tempfile.gettempdir(), capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"issue15.py: the child on {tree} ({name}) failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _load() -> str:
    return os.getloadavg()[0].__format__(".2f")


def item2(old: Path, pairs: int, caches: Path) -> list[str]:
    trees = {"old": old, "new": ROOT}
    summary = []
    for name in SCENES:
        print(f"\n[item 2] scene {name}: {pairs} alternating pairs, CPU s of engine.run "
              f"(load {_load()})", flush=True)
        for tag, tree in trees.items():  # warm the caches (compile) outside the pairs
            _run_child(tree, name, caches / tag)
        ratios, last = [], {}
        for i in range(pairs):
            order = list(trees) if i % 2 == 0 else list(reversed(trees))
            got = {tag: _run_child(trees[tag], name, caches / tag) for tag in order}
            r = (got["new"]["events"] / got["new"]["cpu"]) / (got["old"]["events"] / got["old"]["cpu"])
            ratios.append(r)
            last = got
            print(f"  pair {i + 1} ({order[0]} first): old {got['old']['cpu']:.3f} s "
                  f"{got['old']['events']:,} events | new {got['new']['cpu']:.3f} s "
                  f"{got['new']['events']:,} events | new/old speed {r:.2f} (load {_load()})",
                  flush=True)
        for tag in trees:
            g = last[tag]
            ev = g["events"]
            print(f"  {tag}: {g['search']}; per physical event {g['queue_events'] / ev:.2f} queue "
                  f"events, {g['crossings'] / ev:.2f} crossings, {g['pair_tests'] / ev:.1f} pair tests")
        med = statistics.median(ratios)
        line = (f"item 2, {name}: new/old events per CPU s median {med:.2f} "
                f"(pairs {', '.join(f'{r:.2f}' for r in ratios)}); target {TARGET[name]}; "
                f"crossings per physical event {last['new']['crossings'] / last['new']['events']:.2f}")
        print("  " + line)
        summary.append(line)
    return summary


def script(title: str, argv: list[str]) -> None:
    print(f"\n[{title}] python {' '.join(argv)} (load {_load()})", flush=True)
    done = subprocess.run([sys.executable, *argv], cwd=ROOT)
    if done.returncode:
        print(f"  ({argv[0]} exited with {done.returncode})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, help="a copy of the commit the targets are stated against")
    ap.add_argument("--edmd", type=Path, help="a copy of F. Smallenburg's EDMD (item 5)")
    ap.add_argument("--pairs", type=int, default=5, help="alternating pairs per comparison")
    ap.add_argument("--only", help="comma-separated items among 2,3,4,5,6 (default all)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child)
        return
    only = set((args.only or "2,3,4,5,6").split(","))
    if {"2", "4"} & only and not args.old:
        ap.error("--old is needed for items 2 and 4 (a copy of the commit the targets are stated against)")
    print(f"issue 15 in one run: {time.strftime('%Y-%m-%d %H:%M:%S')}, {os.cpu_count()} cores, "
          f"old = {args.old}, new = {ROOT}", flush=True)
    summary = []
    with tempfile.TemporaryDirectory(prefix="issue15-") as tmp:
        if "2" in only:
            summary += item2(args.old.resolve(), args.pairs, Path(tmp))
    if "2" in only and args.edmd:
        # the restatement suggested for (b) since 2026-11-23: against the best C code on the
        # same gas, not against gaz's own past
        script("item 2, scene (b)'s gas against the C code's Cell variant",
               ["benchmarks/smallenburg.py", "--edmd", str(args.edmd), "--variant", "Cell",
                "--gaz-search", "auto", "--walled", "--packing", "0.01", "--per-particle", "12",
                "--equilibrate", "3", "--pairs", str(args.pairs)])
    if "3" in only:
        script("item 3", ["benchmarks/recording.py", "--in-process", "--rounds", str(args.pairs)])
        script("item 3, the insert against SQLite's own cost",
               ["benchmarks/recording.py", "--insert", "--rounds", str(args.pairs)])
    if "4" in only:
        script("item 4", ["benchmarks/startup.py", "--rounds", "7", "--against", str(args.old)])
    if "5" in only:
        if args.edmd:
            script("item 5", ["benchmarks/smallenburg.py", "--edmd", str(args.edmd),
                              "--pairs", str(args.pairs)])
        else:
            print("\n[item 5] skipped: no --edmd")
    if "6" in only:
        script("item 6", ["benchmarks/mixtures.py", "--repeat", str(max(2, args.pairs // 2))])
    if summary:
        print("\nitem 2 in short:")
        for line in summary:
            print("  " + line)


if __name__ == "__main__":
    main()
