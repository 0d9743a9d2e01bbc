"""Does 'auto' take the fastest search for a mixture of very different sizes? Boxes with walls.

Not a test: it prints numbers. Each mixture (benchmarks/fingerprint.py's ``mixture``: small
spheres or disks of radius 1/2 and a few large ones, radius ratio 10-100, masses in
proportion to the volume, seed 3, walls, no gravity) runs with each search forced -- size
classes ('classes': neighbours 'cells'), wide cells ('wide': neighbours 'wide', classes
'off'), the scan of every particle ('dilute') -- and with 'auto', in turn (``--rounds``
rounds, the order reversed every other round; the first also compiles), and the script prints the median CPU time per physical event
(collisions and wall bounces) of each, the search 'auto' took, and its cost over the
fastest's. The work counts of each forced search (queue events, crossings, pair tests,
slots of the float32 pass, per physical event) are printed under it: what the model of
:mod:`gaz_cli.engines.event.mixture_cost` predicts. Run from the repository root:

    python benchmarks/mixture_choice.py                  # the 28 mixtures, 2 rounds
    python benchmarks/mixture_choice.py --only 3A,2B --rounds 3
    python benchmarks/mixture_choice.py --only FIT --fit      # refit mixture_cost.COST

``--fit``: after the runs, the constants of :data:`gaz_cli.engines.event.mixture_cost.COST` fitted
to them (non-negative least squares on the relative error of each search's CPU time per
physical event against the model's work counts, :func:`gaz_cli.engines.event.mixture_cost.work`),
and how often the refit model would take the fastest search; ``--only FIT`` (or CHECK,
RANDOM) names a set. Each run lasts about ``--events`` physical events (the duration scaled
from a short probe). The mixtures: FIT, the 16 :data:`gaz_cli.engines.event.mixture_cost.COST` was
fitted on; CHECK, 12 more it was checked on (names V...); RANDOM, 10 drawn at random after
the model was written (names R...); the tests' (T...), the mixtures of the tests that say
which search 'auto' takes.

Figures (2026-11-24, 2 cores, load 0-1, 2 rounds each, one session): the fastest search
forced over the one 'auto' took, CPU per physical event.

* Before the mixture model (1c2ec1f: size classes for every mixture with walls, neighbour
  lists for V3f at packing 0.4, the dilute scan for T3000), 14 of the 30 ran slower than
  they could: 3A 1.38, 3C 1.84, 3D 1.63, 3E 1.43, 3H 1.27, 3I 1.41, 2F 1.19, V3b 1.81,
  V3d 1.65, V3e 1.16, V3f 7.46, V2c 1.88, T20000 2.27, T3000 1.12 (the forced searches of
  the run below, except V3f: 'auto' on 1c2ec1f, 24.9 us against size classes' 3.34).
* With the model (its constants fitted on FIT only), ``python benchmarks/mixture_choice.py``
  on d037ef2: 'auto' within 8 % of the fastest in 28 of the 30, the misses 2F 1.24 and
  V2a 1.27 (2D; the model rates wide cells and size classes within 11 % of each other there); on
  the 12 of CHECK, 11 within 8 %.
* RANDOM (``--only RANDOM``, on e923943, load 0.1): 'auto' within 2 % of the fastest in 9
  of 10; the miss R2c 1.15 (2D, packing 0.04: wide cells faster, as in 2F at 0.05). Size
  classes everywhere would have run R3b 1.45, R3d 1.31, R3e 1.42 and R2c 1.13 slower.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time

from fingerprint import mixture  # (this directory: the script's own)

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species

SEARCHES = {"classes": {"neighbours": "cells"}, "wide": {"neighbours": "wide", "classes": "off"},
            "dilute": {"neighbours": "dilute"}, "auto": {}}

FIT = {  # name: (dim, small, large, radius ratio, packing fraction of all)
    "3A": (3, 9900, 100, 100, 0.2), "3B": (3, 20000, 10, 100, 0.05), "3C": (3, 3000, 10, 100, 0.05),
    "3D": (3, 3000, 30, 30, 0.1), "3E": (3, 10000, 100, 20, 0.1), "3F": (3, 10000, 100, 10, 0.2),
    "3G": (3, 10000, 10, 100, 0.3), "3H": (3, 5000, 50, 50, 0.3), "3I": (3, 10000, 100, 10, 0.05),
    "2A": (2, 9900, 100, 100, 0.3), "2B": (2, 5000, 5, 100, 0.1), "2C": (2, 20000, 20, 100, 0.2),
    "2D": (2, 10000, 100, 30, 0.3), "2E": (2, 3000, 30, 10, 0.2), "2F": (2, 10000, 10, 100, 0.05),
    "2G": (2, 10000, 100, 20, 0.5),
}
CHECK = {
    "V3a": (3, 3000, 10, 100, 0.02), "V3b": (3, 6000, 60, 20, 0.05), "V3c": (3, 15000, 15, 50, 0.15),
    "V3d": (3, 2000, 200, 10, 0.3), "V3e": (3, 8000, 20, 40, 0.1), "V3f": (3, 4000, 40, 100, 0.4),
    "V2a": (2, 4000, 40, 50, 0.1), "V2b": (2, 15000, 150, 10, 0.1), "V2c": (2, 6000, 6, 100, 0.02),
    "V2d": (2, 8000, 80, 30, 0.15), "V2e": (2, 2000, 20, 10, 0.2), "V2f": (2, 20000, 200, 50, 0.4),
}
RANDOM = {  # drawn with random.Random(2026): ratio 10-100 and packing 0.02-0.4 log-uniform,
    # 2000-15000 small, 0.1-2 % large by number (log-uniform); R3d's packing 0.4 lowered to
    # 0.3 (157 large spheres at 0.4 is beyond random placement's reach)
    "R3a": (3, 8500, 39, 13, 0.263), "R2a": (2, 4900, 30, 13, 0.106), "R3b": (3, 9100, 81, 61, 0.2),
    "R2b": (2, 9600, 20, 56, 0.126), "R3c": (3, 12600, 48, 13, 0.23), "R2c": (2, 10800, 20, 48, 0.042),
    "R3d": (3, 14100, 157, 95, 0.3), "R2d": (2, 3000, 8, 33, 0.106), "R3e": (3, 7900, 109, 20, 0.165),
    "R2e": (2, 2300, 19, 38, 0.059),
}


def test_scenes() -> dict[str, Scene]:
    """The mixtures of the tests on 'auto''s choice (tests/test_engine_wide.py,
    tests/test_engine_dilute.py)."""
    def two(large, n_large, small, n_small):
        return Scene(dim=3, length=1.0, duration=1.0, temperature=1.0 / K_B, seed=3,
                     components=((large, n_large), (small, n_small)))
    return {"T20000": two(Species("L", 1.0, 0.02), 10, Species("S", 1e-6, 0.0003), 20000),
            "T3000": two(Species("L", 1.0, 0.1), 10, Species("S", 1e-6, 0.001), 3000)}


def model_work(scene: Scene) -> dict:
    """:func:`gaz_cli.engines.event.mixture_cost.work` for ``scene`` (walls, hard spheres), with the
    plan and the wide cells the driver would size."""
    from gaz_cli.engines.event import mixture_cost, sizing
    from gaz_cli.engines.event.interactions import pair_reach
    from gaz_cli.engines.event.neighbours import classes

    radii = scene.radii()

    def reach(r):
        return pair_reach(r, ())

    plan = classes.plan(radii, scene.dim, scene.length, False, True, False, reach,
                        sizing.cells_per_axis)
    wide_nc = sizing.wide_cells_per_axis(scene.dim, scene.n, scene.length, reach(radii.max()),
                                         scene.packing_fraction)
    return mixture_cost.work(scene.dim, scene.length, *mixture_cost.species_of(scene), reach,
                             plan, wide_nc)


def fit(names: list[str], every: dict, measured: dict) -> None:
    """Print COST refitted to the measured CPU times (us per physical event), and the choices
    of the refit model against the fastest search measured."""
    import numpy as np
    from scipy.optimize import nnls

    from gaz_cli.engines.event import mixture_cost

    work = {k: model_work(every[k]) for k in names}
    const = {}
    for s, units in mixture_cost.COST.items():
        A = np.array([[work[k][s][u] for u in units] for k in names])
        y = np.array([measured[k][s] * 1e3 for k in names])  # ns
        c, _ = nnls(A / y[:, None], np.ones(len(y)))
        const[s] = dict(zip(units, c))
        err = np.sqrt(np.mean(np.log(A @ c / y) ** 2))
        print(f"COST[{s!r}] = {{{', '.join(f'{u!r}: {v:.3g}' for u, v in const[s].items())}}}"
              f"  (rms error of log time {err:.2f})")
    hits = 0
    for k in names:
        pred = {s: sum(const[s][u] * work[k][s][u] for u in const[s]) for s in const}
        pick = min(pred, key=pred.get)
        best = min(const, key=lambda s: measured[k][s])
        loss = measured[k][pick] / measured[k][best]
        hits += loss < 1.05
        print(f"  {k}: refit model takes {pick}, fastest {best}: {loss:.2f}")
    print(f"refit model within 5 % of the fastest in {hits} of {len(names)}")


def took(ex: dict) -> str:
    return ("classes" if ex.get("size_classes") else "wide" if ex.get("wide_cells")
            else "dilute" if ex.get("dilute_scan") else "lists" if ex.get("neighbour_lists")
            else "cells")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--events", type=float, default=6e4, help="physical events a run")
    ap.add_argument("--only", help="comma-separated names, or FIT, CHECK or RANDOM")
    ap.add_argument("--fit", action="store_true", help="refit mixture_cost.COST to the runs")
    a = ap.parse_args()
    every = {**{k: mixture(*v, 1.0) for k, v in {**FIT, **CHECK, **RANDOM}.items()},
             **test_scenes()}
    sets = {"FIT": list(FIT), "CHECK": list(CHECK), "RANDOM": list(RANDOM)}
    wanted = None if a.only is None else [x for w in a.only.split(",") for x in sets.get(w, [w])]
    names = [k for k in every if wanted is None or k in wanted]
    print(f"# cores: {os.cpu_count()}, load at start: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}, rounds {a.rounds}", flush=True)
    scenes = {}
    for name in names:
        sc = every[name]
        st = initial_state(sc)
        probe = engine.run(dataclasses.replace(sc, duration=sc.duration * 1e-2, extras=SEARCHES["wide"]), st)
        scale = 1e-2 * a.events / max(probe.events, 1)
        scenes[name] = (dataclasses.replace(sc, duration=sc.duration * scale), st)
    res: dict[tuple[str, str], list[dict]] = {}
    for r in range(a.rounds):
        for name in names:
            sc, st = scenes[name]
            for s in (list(SEARCHES) if r % 2 == 0 else list(SEARCHES)[::-1]):
                x = dataclasses.replace(sc, extras=SEARCHES[s])
                if r == 0:  # compile or load the kernels of this search
                    engine.run(dataclasses.replace(x, duration=x.duration * 1e-2), st)
                c0 = time.process_time()
                rs = engine.run(x, st)
                cpu = time.process_time() - c0
                ex, ev = rs.extras, max(rs.events, 1)
                res.setdefault((name, s), []).append({
                    "us": 1e6 * cpu / ev, "queue": ex["queue_events"] / ev,
                    "crossings": ex["cell_crossings"] / ev, "pairs": ex["pair_tests"] / ev,
                    "slots": ex.get("dilute_scanned", 0) / ev, "nc": ex["cells_per_axis"],
                    "took": took(ex)})
    for name in names:
        row = {s: statistics.median(o["us"] for o in res[(name, s)]) for s in SEARCHES}
        best = min((v, s) for s, v in row.items() if s != "auto")
        auto = res[(name, "auto")][0]["took"]
        print(f"{name}: " + ", ".join(f"{s} {row[s]:.2f} us" for s in SEARCHES)
              + f" | auto took {auto}, fastest {best[1]}: auto / fastest {row['auto'] / best[0]:.2f}")
        for s in ("classes", "wide", "dilute"):
            o = res[(name, s)][0]
            print(f"    {s:8s} took {o['took']:7s} cells/axis {o['nc']:3d}, per physical event: "
                  f"queue {o['queue']:.2f}, crossings {o['crossings']:.2f}, pairs {o['pairs']:.1f}, "
                  f"slots {o['slots']:.0f}")
        sys.stdout.flush()
    if a.fit:
        fit(names, every, {k: {s: statistics.median(o["us"] for o in res[(k, s)])
                               for s in SEARCHES} for k in names})


if __name__ == "__main__":
    main()
