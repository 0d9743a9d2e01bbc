"""Placement of mixtures of very different sizes: the large particles first, then the small
ones around them, held fixed.

Random sequential addition and growth test a particle against those of the 3^D cells
around it, cells at least one largest diameter wide: with large particles ten times wider
than the small ones, each test of a small particle scans the small particles of cells a
thousand times too large (3D; measurements before this module:
docs/explanation/engine_measurements.md#placement-mixtures). Here:

1. :func:`split`: a particle is small when its radius is at most rmax / :data:`SPLIT_RATIO`
   (or :data:`CLOSE_RATIO`, when the large ones are not dense);
2. the large ones are placed alone (:func:`gaz_cli.placement.place`, by the method their
   own packing needs, or the one asked for: a lattice, under ``auto``, when they alone are
   denser than random placement reaches);
3. the small ones are placed among them on a grid sized for the small ones, the large ones
   held fixed: each cell lists the large spheres a small particle in it could touch
   (:mod:`.obstacles`), which random sequential addition (:func:`.rsa.rejection`) and
   growth (:func:`.growth.grow`) test besides the small particles around.

With ``auto`` the small ones are added at random while their packing in the room the large
ones leave is comfortably below jamming (:data:`gaz_cli.placement.RSA_COMFORT`), else grown.
:func:`first_overlap` checks a mixture the same way, class by class.
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.geometry import ball_volume

SPLIT_RATIO = 8.0
"""Sizes this far apart (the largest radius over the largest small one) are always placed in
two steps: the large ones leave pockets many small diameters wide."""

CLOSE_RATIO = 3.0
"""From this ratio on, two steps when the large particles alone fill at most the packing
below which they would be added at random (:data:`gaz_cli.placement.RSA_COMFORT`): denser,
their pockets are too narrow for small particles only a few times smaller, which, grown
from points in them, jam (measurements:
docs/explanation/engine_measurements.md#placement-mixtures); all grow together then, on one
grid (cells ~3^D times too large, a cost that stays moderate)."""


def split(dim: int, radii: np.ndarray, length: float) -> np.ndarray | None:
    """(N,) bool, True for the small particles, when a mixture is placed in two steps (see
    :data:`SPLIT_RATIO`, :data:`CLOSE_RATIO`); None for one step."""
    from gaz_cli.placement import RSA_COMFORT

    radii = np.asarray(radii, dtype=np.float64)
    if radii.size < 2 or dim < 2:
        return None
    rmax = float(radii.max())
    for ratio in (SPLIT_RATIO, CLOSE_RATIO):
        small = radii <= rmax / ratio
        if not small.any() or small.all() or float(radii[small].max()) <= 0.0:
            continue
        if ratio == SPLIT_RATIO:
            return small
        if float(np.sum(ball_volume(dim, radii[~small]))) / length ** dim <= RSA_COMFORT[dim]:
            return small
    return None


def _fine_cells(length: float, r_small: float) -> int:
    """Cells an axis of the small particles' grid: at least one small diameter wide."""
    return max(1, int(math.floor(length / (2.0 * r_small * (1.0 + 1e-9)))))


def room_packing(dim: int, radii: np.ndarray, small: np.ndarray, length: float) -> float:
    """The small particles' packing fraction in the room the large ones leave their centres
    (the box less a ball of radius R + r_small around each large one, overlaps of these balls
    ignored; at least 1 % of the box)."""
    rs = float(radii[small].max())
    closed = float(np.sum(ball_volume(dim, radii[~small] + rs))) / length ** dim
    return float(np.sum(ball_volume(dim, radii[small]))) / length ** dim / max(1.0 - closed, 0.01)


def two_steps_fit(dim: int, radii: np.ndarray, small: np.ndarray, length: float, method: str,
                  periodic: bool = False) -> bool:
    """Whether two steps can reach a packing one random step cannot: the small ones in the
    room the large ones leave (:func:`room_packing`) within the densest random state, and
    the large ones alone within it too, or, under ``auto``, beyond it on a lattice that holds
    them (what ``auto`` gives one size there; a lattice of few large ones in a small box holds
    fewer sites than its packing promises: 32 for 40 spheres at 0.55 in a box 3.4 diameters
    wide, and such a mixture stays refused)."""
    from gaz_cli.placement import RANDOM_LIMIT
    from gaz_cli.placement.lattice import holds

    if method not in ("auto", "grow"):
        return False
    if room_packing(dim, radii, small, length) > RANDOM_LIMIT[dim]:
        return False
    alone = float(np.sum(ball_volume(dim, radii[~small]))) / length ** dim
    if alone <= RANDOM_LIMIT[dim]:
        return True
    return method == "auto" and holds(dim, radii[~small], length, periodic)


def place(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator, method: str,
          periodic: bool, small: np.ndarray, auto: bool) -> np.ndarray:
    """(N, D) centres of a mixture split by :func:`split` (``small``): the large particles
    placed alone, then the small ones around them. ``method``: rejection or grow (what
    ``auto`` chose for the whole, when ``auto``)."""
    from gaz_cli import placement
    from gaz_cli.placement import obstacles
    from gaz_cli.placement.growth import grow
    from gaz_cli.placement.rsa import rejection

    pos = np.empty((radii.size, dim))
    large_radii = radii[~small]
    pos[~small] = placement.place_unhinted(dim, large_radii, length, rng, "auto" if auto else method,
                                           periodic)
    small_radii = radii[small]
    if auto:
        method = ("rejection" if room_packing(dim, radii, small, length) <= placement.RSA_COMFORT[dim]
                  else "grow")
    if method == "rejection":
        table = obstacles.table(pos[~small], large_radii, length, periodic, float(small_radii.max()),
                                _fine_cells(length, float(small_radii.max())))
        pos[small] = rejection(dim, small_radii, length, rng, periodic, fixed=table)
    else:
        pos[small] = grow(dim, small_radii, length, rng, periodic, fixed=(pos[~small], large_radii))
    return pos


def first_overlap(positions: np.ndarray, radii: np.ndarray, length: float, periodic: bool,
                  small: np.ndarray, one_grid) -> int:
    """Index of a particle that overlaps another, or -1: the small ones among themselves and
    the large ones among themselves by ``one_grid`` (:func:`.overlaps.first_overlap`), then
    each small one against the large ones (:mod:`.obstacles`)."""
    from gaz_cli.placement import obstacles

    for part in (small, ~small):
        k = one_grid(positions[part], radii[part], length, periodic)
        if k >= 0:
            return int(np.flatnonzero(part)[k])
    rs = float(radii[small].max())
    table = obstacles.table(positions[~small], radii[~small], length, periodic, rs,
                            _fine_cells(length, rs))
    hit = np.flatnonzero(obstacles.touching(table, positions[small], radii[small]))
    return int(np.flatnonzero(small)[hit[0]]) if hit.size else -1
