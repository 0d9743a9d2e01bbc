"""Initial positions: fast, reproducible, with bounded effort.

Methods
-------
rapid      1D only: the exam's Q10 algorithm vectorised; exactly uniform over
           non-overlapping configurations, O(N log N), any packing below 1.
rejection  random sequential addition with a cell grid (2D/3D, or 1D): each
           candidate is tested against the particles of the neighbouring cells
           only, O(N) on average. Gives up after a bounded number of
           candidates (the exam's Q7 situation) with a PlacementError.
lattice    particles on the densest simple lattice that fits (square or
           hexagonal rows in 2D, FCC in 3D), sites chosen at random; reaches
           2D area fraction 0.70 and 3D packing 0.50 and more.
auto       rapid in 1D; rejection while the packing is comfortably below the
           random-sequential-addition jamming limit; lattice above it.

Candidates are drawn in batches from the caller's numpy Generator, so a seed
gives the same positions on every machine and for every engine.
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.errors import PlacementError, SceneError
from gaz_cli.numba_config import njit

METHODS = ("auto", "rejection", "rapid", "lattice")

RSA_COMFORT = {1: 0.60, 2: 0.45, 3: 0.30}
"""Packing below which 'auto' uses rejection (RSA jamming: 0.7476, 0.547, 0.384)."""


def place(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
          method: str = "auto", periodic: bool = False) -> np.ndarray:
    """(N, D) float64 centres, m, of particles of ``radii`` in [0, length]^D.

    With hard walls every centre is at least its radius from each wall; with
    ``periodic`` the box wraps and distances are minimum-image.
    """
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    n = radii.size
    if method not in METHODS:
        raise SceneError(f"--method {method!r} is not one of {', '.join(METHODS)}")
    if method == "rapid" and dim != 1:
        raise SceneError("--method rapid works in 1D only (the exam's Q10); use rejection or lattice")
    eta = float(np.sum({1: 2.0, 2: math.pi, 3: 4 * math.pi / 3}[dim] * radii ** dim) / length ** dim)
    if method == "auto":
        if dim == 1:
            method = "rapid"
        elif eta <= RSA_COMFORT[dim]:
            method = "rejection"
        else:
            method = "lattice"
    if method == "rapid":
        return rapid_1d(radii, length, rng, periodic)
    if method == "lattice":
        return lattice(dim, radii, length, rng, periodic)
    return rejection(dim, radii, length, rng, periodic)


def rapid_1d(radii: np.ndarray, length: float, rng: np.random.Generator,
             periodic: bool = False) -> np.ndarray:
    """The exam's placement1Drapide (Q10), vectorised, for rods of any radii.

    Draw N points uniformly in the free length, sort them, and push the k-th
    one right by the room taken by the k rods before it. Uniform over the
    valid configurations; O(N log N). Rods keep a random order of species.
    """
    n = radii.size
    free = length - 2.0 * radii.sum()
    if free <= 0:
        raise PlacementError(f"{n} rods of total length {2 * radii.sum():g} m do not fit in {length:g} m; "
                             "lower --n or raise --length")
    order = rng.permutation(n)  # which rod comes k-th along the line
    points = np.sort(rng.random(n) * free)
    r = radii[order]
    before = np.concatenate(([0.0], np.cumsum(2.0 * r)[:-1]))
    x = np.empty(n)
    x[order] = points + before + r
    if periodic:
        x = (x + rng.random() * length) % length
    return x[:, None]


@njit
def _rsa(cand, radii, length, periodic, pos, placed, cell_size, ncell, head, nxt,
         max_tries):
    """Place particles ``placed..N-1`` from candidate points ``cand`` (M, D) in [0,1)^D.

    Returns (placed, consumed, status): status 0 done, 1 candidates exhausted,
    2 a particle failed ``max_tries`` times in a row.
    """
    n, dim = pos.shape
    m = cand.shape[0]
    c = 0
    tries = 0
    cell = np.zeros(3, dtype=np.int64)
    while placed < n:
        if c >= m:
            return placed, c, 1
        r = radii[placed]
        x = np.empty(dim)
        for d in range(dim):
            if periodic:
                x[d] = cand[c, d] * length
            else:
                x[d] = r + cand[c, d] * (length - 2.0 * r)
        c += 1
        tries += 1
        for d in range(dim):
            k = int(x[d] / cell_size)
            cell[d] = min(max(k, 0), ncell - 1)
        ok = True
        # neighbouring cells, -1..+1 on each axis
        for a in range(-1, 2):
            for b in range(-1, 2) if dim > 1 else range(0, 1):
                for e in range(-1, 2) if dim > 2 else range(0, 1):
                    i0 = cell[0] + a
                    i1 = cell[1] + b if dim > 1 else 0
                    i2 = cell[2] + e if dim > 2 else 0
                    if periodic:
                        i0 %= ncell
                        i1 %= ncell
                        i2 %= ncell
                    elif i0 < 0 or i0 >= ncell or i1 < 0 or i1 >= ncell or i2 < 0 or i2 >= ncell:
                        continue
                    j = head[(i0 * ncell + i1) * ncell + i2 if dim == 3 else
                             (i0 * ncell + i1 if dim == 2 else i0)]
                    while j >= 0 and ok:
                        d2 = 0.0
                        for d in range(dim):
                            dx = x[d] - pos[j, d]
                            if periodic:
                                dx -= length * np.rint(dx / length)
                            d2 += dx * dx
                        s = r + radii[j]
                        if d2 < s * s:
                            ok = False
                        j = nxt[j]
                    if not ok:
                        break
                if not ok:
                    break
            if not ok:
                break
        if ok:
            for d in range(dim):
                pos[placed, d] = x[d]
            key = cell[0]
            for d in range(1, dim):
                key = key * ncell + cell[d]
            nxt[placed] = head[key]
            head[key] = placed
            placed += 1
            tries = 0
        elif tries >= max_tries:
            return placed, c, 2
    return placed, c, 0


def rejection(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
              periodic: bool = False, max_tries: int = 100_000,
              budget: int | None = None) -> np.ndarray:
    """Random sequential addition on a cell grid. O(N) expected below jamming.

    Gives up with :class:`PlacementError` when one particle is refused
    ``max_tries`` times in a row or ``budget`` candidates (default 1000 N +
    10^6) are spent: the exam's Q7 situation ends with an error, never a hang.
    """
    n = radii.size
    rmax = float(radii.max())
    # cells at least one diameter wide, and about one particle per cell
    by_size = int(length / (2.0 * rmax)) if rmax > 0 else n
    ncell = max(1, min(by_size, int(math.ceil(n ** (1.0 / dim)))))
    if periodic and ncell < 3:
        ncell = 1  # minimum image against everybody
    cell_size = length / ncell
    head = -np.ones(ncell ** dim, dtype=np.int64)
    nxt = -np.ones(n, dtype=np.int64)
    pos = np.zeros((n, dim))
    budget = budget if budget is not None else 1000 * n + 1_000_000
    placed, spent = 0, 0
    batch = max(1024, min(4 * n, 1 << 20))
    while placed < n:
        cand = rng.random((batch, dim))
        placed, used, status = _rsa(cand, radii, float(length), bool(periodic), pos, placed,
                                    float(cell_size), ncell, head, nxt, max_tries)
        spent += used
        if status == 2 or spent >= budget:
            eta = float(np.sum({1: 2.0, 2: math.pi, 3: 4 * math.pi / 3}[dim] * radii ** dim) / length ** dim)
            raise PlacementError(
                f"random placement stuck after {spent} candidates with {placed} of {n} particles "
                f"placed (packing fraction {eta:.3g}); use --method lattice, lower --n or raise --length")
    return pos


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
    lo, hi = (0.0, length) if periodic else (rmax, length - rmax)
    sites = _lattice_sites(dim, sigma, lo, hi, periodic, length)
    if sites is None or len(sites) < n:
        have = 0 if sites is None else len(sites)
        raise PlacementError(f"only {have} lattice sites fit for {n} particles of diameter {sigma:g} m "
                             f"in a box of side {length:g} m; lower --n or raise --length")
    # grow the spacing while N sites still fit: bisection on the spacing
    good, bad = sigma, length
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
