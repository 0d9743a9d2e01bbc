"""The mean number of wide cells a scan covers, the table gaz_cli.engines.event.sizing.PATH_BLOCKS.

A scan of wide cells (gaz_cli.engines.event.neighbours.wide._path_block) covers the cells that meet
the bounding box of the particle's path to its exit from its cell, widened by the reach.
This script draws paths in a cell of width 1 (isotropic directions; from a uniform point of
the cell, as after a course change, or from a uniform point of a face, moving in, as at a
crossing) and prints the mean number of cells covered against the reach over the width.

    python benchmarks/wide_blocks.py [--paths 200000]
"""

from __future__ import annotations

import argparse

import numpy as np

RHOS = (0.0, 0.01, 0.03, 0.1, 0.2, 0.4, 0.7, 1.0)


def covered(rng: np.random.Generator, D: int, rho: float, at_face: bool, paths: int) -> float:
    """Mean cells covered by the scan of a path to the cell's exit, reach ``rho``."""
    x = rng.uniform(0.0, 1.0, (paths, D))
    v = rng.normal(size=(paths, D))
    if at_face:
        rows = np.arange(paths)
        a = rng.integers(D, size=paths)
        low = rng.uniform(size=paths) < 0.5
        x[rows, a] = np.where(low, 0.0, 1.0)
        va = np.abs(v[rows, a])
        v[rows, a] = np.where(low, va, -va)
    with np.errstate(divide="ignore"):
        times = np.where(v > 0, (1.0 - x) / v, np.where(v < 0, -x / v, np.inf))
    end = x + v * times.min(axis=1)[:, None]
    lo = np.minimum(x, end) - rho <= 0.0
    hi = np.maximum(x, end) + rho >= 1.0
    return float(np.prod(1 + lo + hi, axis=1).mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=200_000)
    args = ap.parse_args()
    rng = np.random.default_rng(1)
    for D in (2, 3):
        course = [covered(rng, D, r, False, args.paths) for r in RHOS]
        cross = [covered(rng, D, r, True, args.paths) for r in RHOS]
        print(f"D = {D}: reach/width {RHOS}")
        print(f"  after a course change: {tuple(round(c, 2) for c in course)}")
        print(f"  at a crossing:         {tuple(round(c, 2) for c in cross)}")


if __name__ == "__main__":
    main()
