"""A periodic mixture in a box narrower than four large reaches: size classes (three coarse
cells an axis, the scans carrying image codes) against one grid (three cells an axis: every
event scans every particle), on the same start.

Not a test: it prints numbers. Run from the repository root:

    python benchmarks/periodic_mixture.py            # 3 alternating rounds
    python benchmarks/periodic_mixture.py --rounds 5 --n-small 8000 --n-large 80
    python benchmarks/periodic_mixture.py --survey     # eight periodic mixtures, 2D and 3D

The scene: small spheres of radius 1/2 and 1 % large ones of radius 5 (1:10), as heavy per
volume, packing 0.4, periodic, kT = 1, t = 5 (benchmarks/fingerprint.py's ``mixture``).
Each round runs ``engine.run`` with size classes off (``extras["classes"] = "off"``) and on
(auto), alternating, after a short run of each that compiles; printed: the events (the same
count both ways: the same trajectory, up to round-off), CPU seconds (``time.process_time``),
CPU per event, the grids. Measured 2026-11-24 (4000 + 40, load 0.4): 66.6 us an event on one
grid of 3 cells, 4.17 us with size classes (18 fine and 3 coarse cells an axis), 14,577
events both ways.

``--survey``: the same comparison on eight periodic mixtures (:data:`SURVEY`: 2D and 3D, 1:8
and 1:10, 0.1 % to 10 % large ones, packing 0.2 to 0.7), each run for about 30 events a
particle (its duration from a short probe): the search 'auto' takes for a periodic mixture
is size classes whenever their plan exists (:mod:`gaz_cli.engines.event.mixture_cost` weighs
boxes with walls only). Measured 2026-11-24 (3 alternating rounds, load 1-2, a second
process beside it): size classes faster in all eight, 1.12x to 85x (3D 4000 + 400 1:8 at
0.3: 1.12x; 2D 8000 + 800 1:8 at 0.6: 1.31x; 3D 20000 + 20 1:10 at 0.2: 85x). A box too
narrow for three coarse cells has no plan and keeps one grid: 3D 8000 + 8 1:10 at 0.45, a
box 2.65 large diameters wide, two cells an axis, ~160 us an event.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import time

from fingerprint import mixture

from gaz_cli.engines import event as engine
from gaz_cli.run import runner
from gaz_cli.model.recording import Recorder
from gaz_cli.placement.initial import initial_state


SURVEY = [  # dim, small, large, radius ratio, packing
    (3, 8000, 80, 8, 0.2), (3, 8000, 80, 8, 0.45), (3, 4000, 400, 8, 0.3), (3, 2000, 200, 10, 0.4),
    (3, 20000, 20, 10, 0.2), (2, 8000, 80, 10, 0.4), (2, 8000, 800, 8, 0.6), (2, 4000, 40, 10, 0.7),
]


def compare(scene, rounds: int, say=print) -> tuple[float, float]:
    """Median CPU seconds per event of ``scene`` with size classes off and on (auto),
    ``rounds`` alternating rounds after a short run of each that compiles; each run said."""
    state = initial_state(scene)
    per = {"off": [], "auto": []}
    for r in range(rounds):
        for mode in (("off", "auto") if r % 2 == 0 else ("auto", "off")):
            sc = dataclasses.replace(scene, extras={**scene.extras, "classes": mode})
            if r == 0:
                engine.run(dataclasses.replace(sc, duration=sc.duration * 1e-3), state, Recorder())
            c = time.process_time()
            rs = engine.run(sc, state, Recorder())
            c = time.process_time() - c
            per[mode].append(c / rs.events)
            say(f"  round {r + 1}, classes {mode:4s}: {rs.events:,} events, {c:.3f} s CPU, "
                f"{c / rs.events * 1e6:.2f} us an event; cells {rs.extras.get('cells_per_axis')} "
                f"an axis, coarse {rs.extras.get('coarse_cells_per_axis')}")
    return statistics.median(per["off"]), statistics.median(per["auto"])


def survey(rounds: int) -> None:
    """:func:`compare` on each mixture of SURVEY, about 30 events a particle."""
    for dim, ns, nl, ratio, packing in SURVEY:
        scene = runner.prepare(mixture(dim, ns, nl, ratio, packing, 1.0, boundary="periodic"))
        probe = engine.run(dataclasses.replace(scene, duration=0.05), initial_state(scene),
                           Recorder())
        scene = dataclasses.replace(scene, duration=0.05 * 30 * (ns + nl) / max(probe.events, 1))
        off, on = compare(scene, rounds, say=lambda line: None)
        print(f"{dim}D {ns} + {nl}, 1:{ratio}, packing {packing}: one grid {off * 1e6:.2f} us an "
              f"event, size classes {on * 1e6:.2f} us ({off / on:.2f}x)", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--n-small", type=int, default=4000)
    ap.add_argument("--n-large", type=int, default=40)
    ap.add_argument("--duration", type=float, default=5.0)
    ap.add_argument("--survey", action="store_true", help="the eight mixtures of SURVEY instead")
    args = ap.parse_args()
    print(f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}")
    if args.survey:
        survey(args.rounds)
        return
    scene = runner.prepare(mixture(3, args.n_small, args.n_large, 10, 0.4, args.duration,
                                   boundary="periodic"))
    print(f"3D periodic mixture 1:10, {args.n_small} + {args.n_large}, packing 0.4, L = "
          f"{scene.length:.3g}")
    off, on = compare(scene, args.rounds, say=lambda line: print(line, flush=True))
    print(f"median CPU per event: one grid {off * 1e6:.2f} us, size classes {on * 1e6:.2f} us "
          f"({off / on:.1f}x)")


if __name__ == "__main__":
    main()
