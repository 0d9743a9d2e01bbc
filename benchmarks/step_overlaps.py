"""Step engine: the cost of counting the overlaps each step leaves, and what it finds.

Prints, for two scenes, the median run time of ``stepper.run`` over REPEATS runs (kernels
compiled first) and the overlap counters. For the cost, run this file against two versions
of the package, alternately (the machine is shared and noisy: compare ratios)::

    python benchmarks/step_overlaps.py                    # this checkout
    PYTHONPATH=/path/to/other/checkout python benchmarks/step_overlaps.py

Scenes (reduced units, m = k_B T = 1, unit box, tau = Enskog mean free time):
2D, 1000 disks, area fraction 0.5, dt = 0.05 tau, 2000 steps; 3D, 4000 spheres, packing
0.05, dt = 0.05 tau, 500 steps.
"""

from __future__ import annotations

import math
import os
import statistics
import time

from gaz_cli import theory
from gaz_cli.engines import step as stepper
from gaz_cli.constants import K_B
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species

REPEATS = 5


def scene(dim, n, eta, steps, dt_tau):
    unit = {2: math.pi, 3: 4.0 * math.pi / 3.0}[dim]
    r = (eta / (n * unit)) ** (1.0 / dim)
    model = {2: "henderson", 3: "carnahan-starling"}[dim]
    tau = 1.0 / float(theory.enskog_collision_frequency(dim, n, 2 * r, 1 / K_B, 1.0, model=model))
    dt = dt_tau * tau
    return Scene(dim=dim, length=1.0, duration=steps * dt, components=((Species("X", 1.0, r), n),),
                 temperature=1 / K_B, seed=1, engine="step", dt=dt)


def main():
    print(f"{os.cpu_count()} cores; package at {os.path.dirname(stepper.__file__)}")
    for args in ((2, 1000, 0.5, 2000, 0.05), (3, 4000, 0.05, 500, 0.05)):
        sc = scene(*args)
        st = initial_state(sc)
        stepper.run(sc, st, Recorder())  # compile
        times = []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            rs = stepper.run(sc, st, Recorder())
            times.append(time.perf_counter() - t0)
        extra = {k: rs.extras.get(k) for k in ("overlap_steps", "overlapping_pairs_max", "closest_pair")}
        print(f"{args[0]}D N={args[1]} eta={args[2]} steps={args[3]} dt={args[4]} tau: "
              f"median {statistics.median(times):.3f} s (min {min(times):.3f}, max {max(times):.3f}) {extra}")


if __name__ == "__main__":
    import warnings

    warnings.simplefilter("ignore")
    main()
