"""``gaz place --repeat``'s study: where the centres of random placements land (the exam's Q12)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from gaz_cli import theory
from gaz_cli.errors import SceneError

MAX_BINS = 10 ** 7
"""Most histogram bins of ``gaz place --repeat`` (three arrays of 80 MB)."""
MAX_PLACE_WORK = 1e11
"""Most particle placements of ``gaz place --repeat`` (repeat x (n + PLACE_OVERHEAD)): a few
hours (measured: 10^6 rods in 0.1 s, 10^5 repetitions of 2 rods in 2 s)."""
PLACE_OVERHEAD = 200
"""A repetition's own cost, in particle placements (about 20 us against 0.1 us a rod)."""


def _check_place_args(dim, n, radius, length):
    if dim not in (1, 2, 3):
        raise SceneError(f"--dim {dim} is not 1, 2 or 3")
    if n is None or n < 1:
        raise SceneError(f"--n must be at least 1, got {n}")
    if not (radius > 0 and math.isfinite(radius)):
        raise SceneError(f"--radius must be > 0, got {radius}")
    if not (length > 0 and math.isfinite(length)):
        raise SceneError(f"--length must be > 0, got {length}")
    from gaz_cli.geometry import DENSEST, ball_volume

    eta = n * float(ball_volume(dim, radius)) / length ** dim
    if 2 * radius >= length:
        raise SceneError(f"a particle of radius {radius:g} m (diameter {2 * radius:g} m) does not fit in a box "
                         f"of side {length:g} m; lower --radius or raise --length")
    if eta >= DENSEST[dim]:
        raise SceneError(f"{n} particles of radius {radius:g} m cannot fit in a box of side {length:g} m "
                         f"(packing fraction {eta:.3g}, densest {DENSEST[dim]:.4g}); "
                         "lower --n or --radius, or raise --length")


def place_once(dim: int, n: int, radius: float, length: float, method: str = "auto",
               seed: int | None = None) -> np.ndarray:
    """(N, D) centres of one placement, m."""
    from gaz_cli import placement

    _check_place_args(dim, n, radius, length)
    rng = np.random.default_rng(seed)
    return placement.place(dim, np.full(n, float(radius)), float(length), rng, method=method)


def placement_histogram(dim: int, n: int, radius: float, length: float, method: str,
                        seed: int | None, repeat: int, bins: int,
                        plot: str | None = None) -> pd.DataFrame:
    """The exam's Q12 study: histogram of centre positions along x over ``repeat`` placements.

    Returns a DataFrame bin_start, bin_end, count (bins over [0, L]); with
    ``plot`` also draws it, over the exact density of the uniform placement
    in 1D (:func:`gaz_cli.theory.rod_centre_density`).
    """
    from gaz_cli import placement
    from gaz_cli.analysis import plots

    _check_place_args(dim, n, radius, length)
    if bins > MAX_BINS:
        raise SceneError(f"--bins {bins} is more than the {MAX_BINS:.0e} a histogram holds; lower --bins")
    work = repeat * (n + PLACE_OVERHEAD)
    if work > MAX_PLACE_WORK:
        raise SceneError(f"--repeat {repeat} placements of {n} particles would take about {work:.3g} "
                         f"particle placements, beyond the {MAX_PLACE_WORK:.0e} allowed (hours of work); "
                         "lower --repeat")
    rng = np.random.default_rng(seed)
    radii = np.full(n, float(radius))
    edges = np.linspace(0.0, length, bins + 1)
    counts = np.zeros(bins, dtype=np.int64)
    for _ in range(repeat):
        x = placement.place(dim, radii, float(length), rng, method=method)[:, 0]
        counts += np.histogram(x, bins=edges)[0]
    frame = pd.DataFrame({"bin_start": edges[:-1], "bin_end": edges[1:], "count": counts})
    if plot:
        exact = _exact_centre_density(dim, n, radius, length)
        title = f"Q12: {n} particle(s) of radius {radius:g} m in [0, {length:g}] m, {dim}D, method {method}"
        plots.placement_histogram(plot, edges, counts, exact, repeat, title)
    return frame


def _exact_centre_density(dim, n, radius, length):
    """x -> exact density (1/m) of a centre for the uniform 1D placement, or None where unknown."""
    if dim != 1:
        return None
    return lambda x: theory.rod_centre_density(x, n, radius, length)
