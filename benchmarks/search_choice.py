"""Does 'auto' take the fastest partner search? Dilute gases in a box with walls, or periodic.

Not a test: it prints numbers. For argon at a given number density (3D or 2D, box with
walls, no gravity), each N of the list runs with every search forced -- the scan of every
particle ('dilute'), wide cells ('wide'), cells ('cells') -- and with 'auto', in turn
(alternating, ``--rounds`` rounds; the first round also compiles), and prints the median
physical events (collisions and wall bounces) per second of CPU time of each, the search
'auto' took and the fastest one's margin over it. Run from the repository root:

    python benchmarks/search_choice.py                       # the 3D densities below
    python benchmarks/search_choice.py --dim 2 --packing 0.01 --n 1000,2000,4000
    python benchmarks/search_choice.py --density 2.5443e25 --n 3000,4000,6000
    python benchmarks/search_choice.py --periodic   # wide cells or cells (no dilute scan)

Densities: the README example's (1000 atoms in (34 nm)^3, 2.5443e25 m^-3, packing
0.0006), scene (b)'s of benchmarks/engine.py (packing 0.01) and packing 0.03 (where cells
beat wide cells). The simulated time is
``--duration`` (default: five mean free times at that density; the runs are short, so their
first predictions weigh in: they are part of what a user waits for).

Figures (2026-11-23, 2 cores, load 0.6-0.7, 3 rounds, the 12 default scenes, one session):
6c625cb ('auto' weighing the dilute scan against cells alone, wide cells up to packing
0.05) missed the fastest search in 6: at the README's density wide cells ran 1.17x and
1.48x its dilute scan (N = 4000, 6000), at packing 0.01 1.16x and 1.55x (N = 1500, 2000),
and at packing 0.03 cells ran 1.07x and 1.19x its wide cells (N = 2000, 10^4). Now 'auto'
takes the fastest in all 12 (the cheapest of the three models; wide cells only below
packing 0.02, sizing.WIDE_BELOW; blocks rounded to 16 slots, layout.WIDE_LANES). See
:func:`gaz_cli.engines.event.sizing.dilute_scan_pays`.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

from gaz_cli import theory
from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.geometry import UNIT_BALL
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import lookup

SEARCHES = ("auto", "dilute", "wide", "cells")

README_DENSITY = 1000 / 3.4e-8 ** 3
"""The README example's number density, m^-3."""


def label(extras: dict) -> str:
    if extras.get("dilute_scan"):
        return "dilute"
    return f"{'wide' if extras.get('wide_cells') else 'cells'} {extras['cells_per_axis']}"


def measure(dim: int, density: float, n: int, duration: float | None, rounds: int,
            searches: tuple = SEARCHES, boundary: str = "walls") -> dict:
    ar = lookup("Ar")
    length = (n / density) ** (1.0 / dim)
    if duration is None:  # five mean free times
        speed = math.sqrt(8 * K_B * 300 / (math.pi * ar.mass))
        duration = 5.0 * float(theory.mean_free_path(dim, density, 2 * ar.radius)) / speed
    rates = {s: [] for s in searches}
    took = {}
    for r in range(rounds + 1):  # round 0 compiles, not counted
        for s in searches:
            scene = Scene(dim=dim, length=length, duration=duration, components=((ar, n),),
                          seed=1, record="none", extras={"neighbours": s}, boundary=boundary)
            state = initial_state(scene)
            c = time.process_time()
            stats = engine.run(scene, state, Recorder())
            cpu = time.process_time() - c - stats.extras["compile_s"]
            if r > 0:
                rates[s].append(stats.events / cpu)
            took[s] = label(stats.extras)
    med = {s: statistics.median(v) for s, v in rates.items()}
    return {"n": n, "length": length, "rates": med, "took": took,
            "packing": n * UNIT_BALL[dim] * ar.radius ** dim / length ** dim}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dim", type=int, choices=(2, 3), default=3)
    where = ap.add_mutually_exclusive_group()
    where.add_argument("--density", type=float, help="particles per m^dim")
    where.add_argument("--packing", type=float, help="packing fraction (sets the density)")
    ap.add_argument("--n", default=None, help="particle counts, comma-separated")
    ap.add_argument("--duration", type=float, default=None, help="simulated s")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--periodic", action="store_true",
                    help="a periodic box (the dilute scan, walls only, left out)")
    args = ap.parse_args()
    searches = tuple(s for s in SEARCHES if not (args.periodic and s == "dilute"))
    boundary = "periodic" if args.periodic else "walls"
    ar = lookup("Ar")
    if args.density is None and args.packing is None:
        plans = [(README_DENSITY, "1000,2000,3000,4000,6000,8000"),
                 (0.01 / (UNIT_BALL[3] * ar.radius ** 3), "1000,1500,2000,3000"),
                 (0.03 / (UNIT_BALL[3] * ar.radius ** 3), "2000,10000")]
        if args.dim != 3:
            ap.error("--dim 2 needs --density or --packing")
    else:
        density = args.density or args.packing / (UNIT_BALL[args.dim] * ar.radius ** args.dim)
        plans = [(density, "1000,2000,4000")]
    print(f"gaz search choice: {args.dim}D argon, {boundary}; {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.2f}; {args.rounds} rounds; M physical events / s of CPU")
    for density, default_n in plans:
        for n in [int(x) for x in (args.n or default_n).split(",")]:
            m = measure(args.dim, density, n, args.duration, args.rounds, searches, boundary)
            rates = m["rates"]
            best = max(searches[1:], key=lambda s: rates[s])
            took = m["took"]
            same = next(s for s in searches[1:] if took[s] == took["auto"])
            verdict = ("auto took the fastest" if took[best] == took["auto"] else
                       f"the fastest, {best}, runs {rates[best] / rates[same]:.2f}x what auto took")
            print(f"  N = {n}, packing {m['packing']:.2g}, L = {m['length']:.3g} m: "
                  + ", ".join(f"{s} {rates[s] / 1e6:.3f} ({took[s]})" for s in searches)
                  + f"; {verdict}", flush=True)


if __name__ == "__main__":
    main()
