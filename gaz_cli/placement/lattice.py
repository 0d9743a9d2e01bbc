"""Lattice starts: the densest simple lattice that fits (square or hexagonal rows in 2D,
FCC in 3D), sites chosen at random."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.errors import PlacementError

LATTICE_LIMIT = {1: 1.0, 2: 0.9069, 3: 0.7405}
"""Close packing of the lattices (hexagonal 2D, FCC 3D)."""


def _lattice_sites(dim: int, spacing: float, lo: float, hi: float, periodic: bool,
                   length: float) -> np.ndarray:
    """Sites of the densest simple lattice with nearest-neighbour distance >= spacing."""
    span = hi - lo
    if dim == 1:
        k = int(math.floor(span / spacing + 1e-12)) + (0 if periodic else 1)
        return (lo + spacing * np.arange(k))[:, None]
    if dim == 2:
        best = None
        # hexagonal rows: row spacing spacing*sqrt(3)/2, alternate rows shifted
        for shape in ("hex", "square"):
            dy = spacing * (math.sqrt(3) / 2 if shape == "hex" else 1.0)
            if periodic:
                nx = int(math.floor(length / spacing + 1e-12))
                ny = int(math.floor(length / dy + 1e-12))
                if shape == "hex":
                    ny -= ny % 2
                if nx < 1 or ny < 1:
                    continue
                ax, ay = length / nx, length / ny
                if shape == "hex" and math.hypot(ax / 2, ay) < spacing:
                    continue
                i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
                x = (i + (0.5 * (j % 2) if shape == "hex" else 0.0)) * ax
                y = j * ay
            else:
                nx = int(math.floor(span / spacing + 1e-12)) + 1
                ny = int(math.floor(span / dy + 1e-12)) + 1
                i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
                x = lo + (i + (0.5 * (j % 2) if shape == "hex" else 0.0)) * spacing
                y = lo + j * dy
                keep = x <= hi + 1e-12 * span
                x, y = x[keep], y[keep]
            sites = np.column_stack([x.ravel(), y.ravel()])
            if best is None or len(sites) > len(best):
                best = sites
        return best
    # 3D: FCC (conventional cube of side a = spacing*sqrt(2), 4 sites) or simple cubic
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    best = None
    for shape in ("fcc", "sc"):
        a = spacing * (math.sqrt(2) if shape == "fcc" else 1.0)
        b = basis if shape == "fcc" else basis[:1]
        if periodic:
            k = int(math.floor(length / a + 1e-12))
            if k < 1:
                continue
            a = length / k
            g = np.stack(np.meshgrid(*[np.arange(k)] * 3, indexing="ij"), -1).reshape(-1, 3)
            sites = ((g[:, None, :] + b[None]) * a).reshape(-1, 3)
        else:
            k = int(math.floor(span / a + 1e-12)) + 1
            g = np.stack(np.meshgrid(*[np.arange(k)] * 3, indexing="ij"), -1).reshape(-1, 3)
            sites = lo + ((g[:, None, :] + b[None]) * a).reshape(-1, 3)
            sites = sites[np.all(sites <= hi + 1e-12 * span, axis=1)]
        if best is None or len(sites) > len(best):
            best = sites
    return best


def _closest(dim: int, radii: np.ndarray, length: float, periodic: bool):
    """(lo, hi, the closest spacing, the sites at it): the region of the centres, the
    spacing of touching spheres of the largest radius (points: n + 1 a side leave n sites
    or more) and the lattice's sites at that spacing (None: none fits)."""
    rmax = float(radii.max())
    lo, hi = (0.0, length) if periodic else (rmax, length - rmax)
    closest = 2.0 * rmax if rmax > 0.0 else length / (radii.size + 1)
    return lo, hi, closest, _lattice_sites(dim, closest, lo, hi, periodic, length)


def holds(dim: int, radii: np.ndarray, length: float, periodic: bool = False) -> bool:
    """Whether a lattice start (:func:`lattice`) can place particles of ``radii``: its sites,
    spaced by the largest diameter, are at least as many as the particles."""
    radii = np.asarray(radii, dtype=np.float64)
    sites = _closest(dim, radii, length, periodic)[3]
    return sites is not None and len(sites) >= radii.size


def lattice(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
            periodic: bool = False) -> np.ndarray:
    """Particles on lattice sites (random choice of sites and of who sits where).

    The lattice spacing is the largest that still offers N sites, so the
    particles start as far apart as the lattice allows. Raises
    :class:`PlacementError` when even touching spheres leave too few sites.
    """
    n = radii.size
    rmax = float(radii.max())
    sigma = 2.0 * rmax
    lo, hi, closest, sites = _closest(dim, radii, length, periodic)
    if sites is None or len(sites) < n:
        have = 0 if sites is None else len(sites)
        if float(radii.min()) < rmax:  # a mixture: the sites are as far apart as the largest
            raise PlacementError(
                f"only {have} lattice sites fit for {n} particles in a box of side {length:g} m: a "
                f"lattice spaces every particle by the largest diameter ({sigma:g} m), and this "
                "mixture is denser than random placement reaches (the large particles alone, or the "
                "small ones in the room they leave, above the densest random state); lower --n or "
                "raise --length")
        raise PlacementError(f"only {have} lattice sites fit for {n} particles of diameter {sigma:g} m "
                             f"in a box of side {length:g} m; lower --n or raise --length")
    # grow the spacing while N sites still fit: bisection on the spacing
    good, bad = closest, length
    for _ in range(40):
        mid = 0.5 * (good + bad)
        s = _lattice_sites(dim, mid, lo, hi, periodic, length)
        if s is not None and len(s) >= n:
            good = mid
        else:
            bad = mid
    sites = _lattice_sites(dim, good, lo, hi, periodic, length)
    if not periodic:
        # centre the lattice in the accessible region
        shift = 0.5 * ((hi - sites.max(axis=0)) - (sites.min(axis=0) - lo))
        sites = sites + shift
    chosen = sites[rng.choice(len(sites), size=n, replace=False)]
    return np.ascontiguousarray(chosen, dtype=np.float64)
