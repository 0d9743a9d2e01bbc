"""Fingerprints of the event engine's events: one line per scene, to compare two trees.

Not a test: it prints an md5 of every wall bounce and collision (times, particles,
walls, speeds, impulses as float64 bytes) and of the final state, for scenes that
cover every search path (1D rods; cells, neighbour lists, the dilute scan, wide cells,
size classes; walls and periodic boxes; gravity; inelastic collisions; mixtures). An
optimisation that claims to leave the events unchanged must print the same lines, bit
for bit, as the commit before it:

    NUMBA_CACHE_DIR=/tmp/fpA PYTHONPATH=TREE_A python benchmarks/fingerprint.py > a.txt
    NUMBA_CACHE_DIR=/tmp/fpB PYTHONPATH=TREE_B python benchmarks/fingerprint.py > b.txt
    diff a.txt b.txt

(TREE = ``git archive COMMIT | tar -x -C TREE``, then ``ln -s ../sql TREE/gaz_cli/sql``.)
Placement is the lattice start (or a fixed RSA seed), so that only the engine is
compared. A change of search order (a new cost model, a different cell count) changes
events legitimately: that is what the ``search`` column shows. ``--only NAME,...``
runs a few scenes.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import math
import sys

import numpy as np

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species, lookup

UNIT_T = 1.0 / K_B


class Hashing(Recorder):
    """Every bounce and collision into md5s, one per column of each kind, in the order the
    engine hands them: the same digest however the rows are cut into chunks
    (driver.BUFFER_ROWS), as long as each kind's rows come in the same order."""

    want_bounces = True
    want_collisions = True

    def __init__(self):
        self.columns = {}
        self.n = 0

    def _add(self, kind, arrays):
        for k, a in enumerate(arrays):
            self.columns.setdefault((kind, k), hashlib.md5()).update(np.ascontiguousarray(a).tobytes())
        self.n += len(arrays[0])

    def add_bounces(self, t, particle, wall, speed, vperp):
        self._add("bounces", (t, particle, wall, speed, vperp))

    def add_collisions(self, t, i, j, impulse):
        self._add("collisions", (t, i, j, impulse))

    def hexdigest(self) -> str:
        return hashlib.md5("".join(h.hexdigest() for _, h in sorted(self.columns.items())).encode()).hexdigest()


def unit(dim, n, packing, duration, boundary="walls", seed=1, placement="lattice", **kw):
    cell = {1: 1.0, 2: math.pi / 4.0, 3: math.pi / 6.0}[dim]
    length = (n * cell / packing) ** (1.0 / dim)
    return Scene(dim=dim, length=length, duration=duration,
                 components=((Species("X", 1.0, 0.5), n),), temperature=UNIT_T, seed=seed,
                 boundary=boundary, placement=placement, record="none", **kw)


def mixture(dim, n_small, n_large, ratio, packing, duration, boundary="walls"):
    small, large = Species("S", 1.0, 0.5), Species("L", float(ratio) ** dim, 0.5 * ratio)
    cell = {2: math.pi / 4.0, 3: math.pi / 6.0}[dim]
    volume = cell * (n_small + n_large * ratio ** dim)
    length = (volume / packing) ** (1.0 / dim)
    return Scene(dim=dim, length=length, duration=duration,
                 components=((small, n_small), (large, n_large)), temperature=UNIT_T,
                 seed=3, boundary=boundary, placement="auto", record="none")


def argon(n, length, duration, seed=1):
    return Scene(dim=3, length=length, duration=duration,
                 components=((lookup("Ar"), n),), seed=seed, record="none")


def scenes() -> dict[str, Scene]:
    s = {
        "rods_walls": unit(1, 500, 0.5, 50.0),
        "rods_periodic": unit(1, 500, 0.5, 50.0, boundary="periodic"),
        "disks_walls": unit(2, 1000, 0.2, 10.0),
        "disks_periodic": unit(2, 1000, 0.4, 5.0, boundary="periodic"),
        "disks_dense": unit(2, 900, 0.6, 2.0, boundary="periodic"),
        "spheres_walls": unit(3, 1000, 0.1, 10.0),
        "spheres_periodic": unit(3, 4000, 0.3, 2.0, boundary="periodic"),
        "spheres_dense": unit(3, 2000, 0.45, 1.0, boundary="periodic"),
        "spheres_gravity": unit(3, 500, 0.1, 5.0, gravity=1.0),
        "disks_gravity": unit(2, 500, 0.2, 5.0, gravity=1.0),
        "spheres_inelastic": unit(3, 500, 0.2, 5.0, restitution=0.9),
        "argon_readme": argon(1000, 3.4e-8, 2e-9),
        "argon_b": argon(10_000, 2.74e-8, 2e-11),
        "argon_small": argon(50, 3.4e-8, 2e-9),
        "mix2d_1to10": mixture(2, 2000, 20, 10, 0.2, 2.0),
        "mix3d_1to10": mixture(3, 2000, 20, 10, 0.1, 2.0, boundary="periodic"),
        "mix2d_1to100": mixture(2, 5000, 5, 100, 0.1, 1.0),
    }
    forced = {}
    for name in ("spheres_walls", "spheres_periodic", "disks_walls", "argon_readme"):
        for search in ("cells", "lists", "dilute", "wide"):
            sc = s[name]
            if search in ("dilute", "wide") and sc.boundary != "walls":
                continue
            forced[f"{name}+{search}"] = dataclasses.replace(sc, extras={"neighbours": search})
    s.update(forced)
    return s


def search_of(extras: dict) -> str:
    """The search a run took, in words: a changed cost model shows here."""
    for key, word in (("neighbour_lists", "lists"), ("dilute_scan", "dilute"),
                      ("wide_cells", "wide"), ("size_classes", "classes")):
        if extras.get(key):
            return f"{word}/{extras['cells_per_axis']}"
    return f"cells/{extras['cells_per_axis']}"


def fingerprint(sc: Scene) -> str:
    """'events collisions md5(events) md5(final x, v) search' for one run of ``sc``."""
    rec = Hashing()
    rs = engine.run(sc, initial_state(sc), rec)
    final = hashlib.md5(np.ascontiguousarray(rs.final.positions).tobytes()
                        + np.ascontiguousarray(rs.final.velocities).tobytes()).hexdigest()
    return (f"{rs.events} {rs.collisions} {rec.hexdigest()[:16]} {final[:16]} "
            f"{search_of(rs.extras)}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", default="", help="comma-separated scene names")
    p.add_argument("--list", action="store_true", help="print the scene names and exit")
    a = p.parse_args(argv)
    all_scenes = scenes()
    if a.list:
        print("\n".join(all_scenes))
        return 0
    names = [x for x in a.only.split(",") if x] or list(all_scenes)
    for name in names:
        if name not in all_scenes:
            print(f"fingerprint: no scene {name!r}; --list names them", file=sys.stderr)
            return 2
        print(f"{name} {fingerprint(all_scenes[name])}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
