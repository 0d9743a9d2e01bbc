"""Placement of mixtures: CPU seconds of ``placement.place`` on this tree and, side by side,
on an older one (the two-step placement of gaz_cli/placement/mixture.py against one grid).

Not a test: it prints numbers. Run from the repository root:

    git archive HEAD | (mkdir -p /tmp/before && tar -x -C /tmp/before)   # before a change
    python benchmarks/placement.py --old /tmp/before --pairs 3
    python benchmarks/placement.py                     # this tree only

Each scene (``--only A,B``) runs in child processes, one per tree (PYTHONPATH on it, a
Numba cache of its own, compiled by a warm-up placement of a tenth of the scene first),
the tree that runs first alternating from pair to pair; printed: the CPU seconds of
``placement.place(..., "auto", ...)`` (``time.process_time``), the smallest ratio of a
pair's centre distance to its contact distance (>= 1: nobody overlaps; checked with
scipy's cKDTree) and old/new. A child that runs past ``--timeout`` is stopped and shown as
"> T s". Scenes: small particles of radius 1 with 1 % (or as listed) large ones, the box
edge for the packing fraction; the last one is a single size, which the change leaves alone.
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

ROOT = Path(__file__).resolve().parents[1]

SCENES = {
    # name: (dim, small, large, ratio, packing, periodic)
    "A": (3, 4000, 40, 10.0, 0.40, False),
    "B": (3, 10_000, 4, 10.0, 0.40, False),
    "C": (3, 8000, 8, 5.0, 0.45, True),
    "D": (2, 4000, 40, 10.0, 0.60, True),
    "E": (3, 4000, 40, 10.0, 0.20, False),
    "F": (3, 2000, 2000, 3.0, 0.50, True),
    "G": (3, 4000, 0, 1.0, 0.45, True),
}


def radii_and_box(dim, small, large, ratio, packing):
    import numpy as np

    radii = np.r_[np.ones(small), np.full(large, ratio)]
    unit = {2: math.pi, 3: 4.0 * math.pi / 3.0}[dim]
    return radii, (unit * float(np.sum(radii ** dim)) / packing) ** (1.0 / dim)


def child(name: str) -> None:
    """Place one scene with the tree gaz_cli is imported from; print one JSON line."""
    import numpy as np
    from scipy.spatial import cKDTree

    from gaz_cli import placement

    dim, small, large, ratio, packing, periodic = SCENES[name]
    radii, length = radii_and_box(dim, max(small // 10, 2), max(large // 10, 1 if large else 0), ratio,
                                  packing)
    placement.place(dim, radii, length, np.random.default_rng(0), "auto", periodic)  # compile
    radii, length = radii_and_box(dim, small, large, ratio, packing)
    c0 = time.process_time()
    x = placement.place(dim, radii, length, np.random.default_rng(1), "auto", periodic)
    cpu = time.process_time() - c0
    pairs = cKDTree(x, boxsize=length if periodic else None).query_pairs(2.5 * radii.max(),
                                                                         output_type="ndarray")
    d = x[pairs[:, 0]] - x[pairs[:, 1]]
    if periodic:
        d -= length * np.rint(d / length)
    ratio_min = float(np.min(np.sqrt(np.sum(d * d, axis=1)) / (radii[pairs[:, 0]] + radii[pairs[:, 1]])))
    print(json.dumps({"cpu": cpu, "closest": ratio_min}))


def run_child(tree: Path, name: str, cache: Path, timeout: float) -> dict | None:
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache))
    try:
        out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", name], env=env,
                             cwd=tempfile.gettempdir(), capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None
    if out.returncode:
        raise SystemExit(f"placement.py: the child on {tree} ({name}) failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def shown(r: dict | None, timeout: float) -> str:
    return f"> {timeout:g} s" if r is None else f"{r['cpu']:.2f} s (closest pair {r['closest']:.6f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, help="a copy of an older tree to compare with")
    ap.add_argument("--pairs", type=int, default=3, help="alternating pairs per scene")
    ap.add_argument("--only", help="comma-separated scene names (default all)")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds before a child is stopped")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child)
        return
    names = args.only.split(",") if args.only else list(SCENES)
    trees = {"new": ROOT} | ({"old": args.old.resolve()} if args.old else {})
    print(f"placement of mixtures, CPU s of placement.place(auto); {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.2f}; trees: " + ", ".join(f"{k} = {v}" for k, v in trees.items()))
    with tempfile.TemporaryDirectory() as caches:
        for name in names:
            dim, small, large, ratio, packing, periodic = SCENES[name]
            print(f"\n{name}: {dim}D, {small} small + {large} large (1:{ratio:g}), packing {packing}, "
                  f"{'periodic' if periodic else 'walls'}", flush=True)
            ratios = []
            for i in range(args.pairs):
                order = list(trees) if i % 2 == 0 else list(reversed(trees))
                got = {tag: run_child(trees[tag], name, Path(caches) / tag, args.timeout) for tag in order}
                line = "; ".join(f"{tag} {shown(got[tag], args.timeout)}" for tag in trees)
                if "old" in got and got["new"] is not None:
                    old = got["old"]["cpu"] if got["old"] is not None else args.timeout
                    ratios.append(old / got["new"]["cpu"])
                    line += f"; old/new {'>= ' if got['old'] is None else ''}{ratios[-1]:.1f}"
                print(f"  pair {i + 1}: {line}", flush=True)
                if got.get("old") is None and "old" in got:
                    break  # one timeout says enough
            if ratios:
                print(f"  median old/new {statistics.median(ratios):.1f}")


if __name__ == "__main__":
    main()
