"""A periodic mixture in a box narrower than four large reaches: size classes (three coarse
cells an axis, the scans carrying image codes) against one grid (three cells an axis: every
event scans every particle), on the same start.

Not a test: it prints numbers. Run from the repository root:

    python benchmarks/periodic_mixture.py            # 3 alternating rounds
    python benchmarks/periodic_mixture.py --rounds 5 --n-small 8000 --n-large 80

The scene: small spheres of radius 1/2 and 1 % large ones of radius 5 (1:10), as heavy per
volume, packing 0.4, periodic, kT = 1, t = 5 (benchmarks/fingerprint.py's ``mixture``).
Each round runs ``engine.run`` with size classes off (``extras["classes"] = "off"``) and on
(auto), alternating, after a short run of each that compiles; printed: the events (the same
count both ways: the same trajectory, up to round-off), CPU seconds (``time.process_time``),
CPU per event, the grids. Measured 2026-11-24 (4000 + 40, load 0.4): 66.6 us an event on one
grid of 3 cells, 4.17 us with size classes (18 fine and 3 coarse cells an axis), 14,577
events both ways.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import time

from fingerprint import mixture

from gaz_cli import engine, runner
from gaz_cli.recording import Recorder
from gaz_cli.scene import initial_state


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--n-small", type=int, default=4000)
    ap.add_argument("--n-large", type=int, default=40)
    ap.add_argument("--duration", type=float, default=5.0)
    args = ap.parse_args()
    scene = runner.prepare(mixture(3, args.n_small, args.n_large, 10, 0.4, args.duration,
                                   boundary="periodic"))
    state = initial_state(scene)
    print(f"3D periodic mixture 1:10, {args.n_small} + {args.n_large}, packing 0.4, L = "
          f"{scene.length:.3g}; {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}")
    per = {"off": [], "auto": []}
    for r in range(args.rounds):
        for mode in (("off", "auto") if r % 2 == 0 else ("auto", "off")):
            sc = dataclasses.replace(scene, extras={**scene.extras, "classes": mode})
            if r == 0:
                engine.run(dataclasses.replace(sc, duration=sc.duration * 1e-3), state, Recorder())
            c = time.process_time()
            rs = engine.run(sc, state, Recorder())
            c = time.process_time() - c
            per[mode].append(c / rs.events)
            print(f"  round {r + 1}, classes {mode:4s}: {rs.events:,} events, {c:.3f} s CPU, "
                  f"{c / rs.events * 1e6:.2f} us an event; cells {rs.extras.get('cells_per_axis')} "
                  f"an axis, coarse {rs.extras.get('coarse_cells_per_axis')}", flush=True)
    off, on = statistics.median(per["off"]), statistics.median(per["auto"])
    print(f"median CPU per event: one grid {off * 1e6:.2f} us, size classes {on * 1e6:.2f} us "
          f"({off / on:.1f}x)")


if __name__ == "__main__":
    main()
