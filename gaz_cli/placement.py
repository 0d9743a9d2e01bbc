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
           hexagonal rows in 2D, FCC in 3D), sites chosen at random; up to
           close packing (2D 0.9069, 3D 0.7405, less in a small box).
grow       Lubachevsky-Stillinger: random points grow into the particles
           while moving, event by event; a random dense state up to the
           liquid's limit (2D area fraction 0.70, 3D packing 0.50). 1D: rapid.
auto       rapid in 1D; rejection while the packing is comfortably below the
           random-sequential-addition jamming limit; grow up to the random
           limit; lattice above it.

Beyond what a method can reach the answer is an error naming the way out,
after a bounded effort, never a hang.

Candidates are drawn in batches from the caller's numpy Generator, so a seed
gives the same positions on every machine and for every engine.
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.engine.calendar import _heap_push, _heap_remove
from gaz_cli.engine.layout import HP
from gaz_cli.errors import PlacementError, SceneError
from gaz_cli.numba_config import njit
from gaz_cli.geometry import packing_fraction

METHODS = ("auto", "rejection", "rapid", "lattice", "grow")

INTERPRETED_MAX = 256
"""Up to this many particles, random sequential addition runs as plain Python (the kernel's
``py_func``: the same statements, the same float operations -- no fastmath -- so the same
positions) instead of loading compiled code: loading the first cached kernel of a process
costs Numba about a second (its context refresh), placing 256 particles in Python 30 ms.
A run whose engine needs no compiled code (``ideal``, a tiny ``reference`` run) then starts
in the time of its imports."""

INTERPRETED_PACKING = 0.1
"""... and at most this packing fraction, where a few candidates per particle suffice (a
placement near jamming may try millions: compiled, not interpreted)."""

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
    if dim not in (1, 2, 3):
        raise SceneError(f"--dim {dim} is not 1, 2 or 3")
    if not (length > 0 and math.isfinite(length)):
        raise SceneError(f"--length must be a positive number, got {length}")
    if n == 0:
        return np.zeros((0, dim))
    if method == "rapid" and dim != 1:
        raise SceneError("--method rapid works in 1D only (the exam's Q10); use rejection, grow or lattice")
    eta = packing_fraction(dim, radii, length)
    if dim == 1 and method in ("auto", "grow"):
        method = "rapid"
    chosen_by_auto = method == "auto"
    if method == "auto":
        if eta <= RSA_COMFORT[dim]:
            method = "rejection"
        elif eta <= RANDOM_LIMIT[dim] * (1 + 1e-9):
            method = "grow"
        else:
            method = "lattice"
    if method == "grow" and eta > RANDOM_LIMIT[dim] * (1 + 1e-9):
        raise PlacementError(
            f"packing fraction {eta:.3g} is above {RANDOM_LIMIT[dim]}, the densest random state "
            f"offered in {dim}D; use --method lattice (up to {LATTICE_LIMIT[dim]}), lower --n or "
            "raise --length")
    if method == "lattice" and eta > LATTICE_LIMIT[dim] * (1 + 1e-9):
        raise PlacementError(
            f"packing fraction {eta:.3g} is above {LATTICE_LIMIT[dim]}, close packing in {dim}D; "
            "lower --n or raise --length")
    if method == "rapid":
        return rapid_1d(radii, length, rng, periodic)
    if method == "lattice":
        return lattice(dim, radii, length, rng, periodic)
    if method == "grow":
        positions = grow(dim, radii, length, rng, periodic)
        if first_overlap(positions, radii, length, periodic) < 0:
            return positions
        if chosen_by_auto:
            # a rare growth failure must not reach an engine: a lattice start is always valid
            return lattice(dim, radii, length, rng, periodic)
        raise PlacementError("growth left overlapping particles (a known rare failure of --method "
                             "grow); use another --seed or --method lattice")
    return rejection(dim, radii, length, rng, periodic)


@njit
def _first_overlap(pos, radii, length, periodic, ncell, head, nxt):
    """Index of a particle overlapping another (beyond 1e-9 relative), or -1. Cell grid, O(N)."""
    n, dim = pos.shape
    cell_size = length / ncell
    keys = np.empty(n, dtype=np.int64)
    for i in range(n):
        key = 0
        for d in range(dim):
            k = min(max(int(pos[i, d] / cell_size), 0), ncell - 1)
            key = key * ncell + k
        keys[i] = key
        nxt[i] = head[key]
        head[key] = i
    idx = np.zeros(3, dtype=np.int64)
    for i in range(n):
        key = keys[i]
        for d in range(dim - 1, -1, -1):
            idx[d] = key % ncell
            key //= ncell
        for a in range(-1, 2):
            for b in range(-1, 2) if dim > 1 else range(0, 1):
                for e in range(-1, 2) if dim > 2 else range(0, 1):
                    c0, c1, c2 = idx[0] + a, idx[1] + b, idx[2] + e
                    if periodic:
                        c0, c1, c2 = c0 % ncell, c1 % ncell, c2 % ncell
                    elif c0 < 0 or c0 >= ncell or c1 < 0 or c1 >= ncell or c2 < 0 or c2 >= ncell:
                        continue
                    k = c0
                    if dim > 1:
                        k = k * ncell + c1
                    if dim > 2:
                        k = k * ncell + c2
                    j = head[k]
                    while j >= 0:
                        if j > i:
                            d2 = 0.0
                            for d in range(dim):
                                dx = pos[i, d] - pos[j, d]
                                if periodic:
                                    dx -= length * np.rint(dx / length)
                                d2 += dx * dx
                            s = (radii[i] + radii[j]) * (1.0 - 1e-9)
                            if d2 < s * s:
                                return i
                        j = nxt[j]
    return -1


def first_overlap(positions: np.ndarray, radii: np.ndarray, length: float,
                  periodic: bool = False) -> int:
    """Index of a particle that overlaps another (beyond 1e-9 relative), or -1; O(N)."""
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    n, dim = positions.shape
    if n < 2:
        return -1
    rmax = float(np.max(radii))
    by_size = int(length / (2.0 * rmax)) if rmax > 0 else n
    ncell = max(1, min(by_size, int(math.ceil(n ** (1.0 / dim)))))
    if periodic and ncell < 3:
        ncell = 1
    head = -np.ones(ncell ** dim, dtype=np.int64)
    nxt = -np.ones(n, dtype=np.int64)
    return int(_first_overlap(positions, np.ascontiguousarray(radii, dtype=np.float64), float(length),
                              bool(periodic), ncell, head, nxt))


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
         max_tries, cell, x):
    """Place particles ``placed..N-1`` from candidate points ``cand`` (M, D) in [0,1)^D.

    ``cell`` (3,) int64 and ``x`` (D,) are scratch (a kernel that allocates
    makes Numba import its array-allocation modules at every start, ~10 ms).
    Returns (placed, consumed, status): status 0 done, 1 candidates exhausted,
    2 a particle failed ``max_tries`` times in a row.
    """
    n, dim = pos.shape
    m = cand.shape[0]
    c = 0
    tries = 0
    cell[:] = 0
    while placed < n:
        if c >= m:
            return placed, c, 1
        r = radii[placed]
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
    # dilute and small: interpreted (no compiled code to load); else, or if it is slow going, compiled
    rsa = _rsa.py_func if n <= INTERPRETED_MAX and packing_fraction(dim, radii, length) <= INTERPRETED_PACKING else _rsa
    while placed < n:
        cand = rng.random((batch, dim))
        placed, used, status = rsa(cand, radii, float(length), bool(periodic), pos, placed,
                                    float(cell_size), ncell, head, nxt, max_tries,
                                    np.zeros(3, dtype=np.int64), np.empty(dim))
        spent += used
        if status == 2 or spent >= budget:
            eta = packing_fraction(dim, radii, length)
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


# --- Lubachevsky-Stillinger growth -------------------------------------------
GROWTH_RATE = 0.1
"""LS growth: final diameters grow from 0 at this rate per unit time (speeds ~1 diameter/time)."""

RANDOM_LIMIT = {2: 0.70, 3: 0.50}
"""Densest random (grown) packing offered: beyond, a lattice start (2D liquid ends near 0.70,
3D freezing at 0.494; growth goes further only by jamming into a glass)."""

LATTICE_LIMIT = {1: 1.0, 2: 0.9069, 3: 0.7405}
"""Close packing of the lattices (hexagonal 2D, FCC 3D)."""


@njit
def _ls_predict(i, t, x, v, ts, R, cnt, cc, head, nxt, edges, nc, L, periodic, gamma):
    """Next event of particle i (row at time t) under growth r_k(t) = R_k gamma t.

    Returns (time, kind, partner or crossing code, partner counter): kind 0
    collision, 1 wall or cell crossing. A pair touching and approaching in
    the growing sense collides now; one separating faster than it grows is
    left alone.
    """
    n, dim = x.shape
    f = gamma * t
    best = np.inf
    kind = -1
    what = -1
    pc = 0
    # walls and cell faces
    for d in range(dim):
        c = cc[i, d]
        xd = x[i, d]
        vd = v[i, d]
        rg = R[i] * gamma
        if not periodic and c == 0:
            if rg - vd > 0.0:
                dt = (xd - R[i] * f) / (rg - vd)
                dt = max(dt, 0.0)
                if t + dt < best:
                    best, kind, what = t + dt, 1, 4 * d + 1
        elif vd < 0.0:
            dt = max((edges[c] - xd) / vd, 0.0)
            if t + dt < best:
                best, kind, what = t + dt, 1, 4 * d
        if not periodic and c == nc - 1:
            if vd + rg > 0.0:
                dt = (L - R[i] * f - xd) / (vd + rg)
                dt = max(dt, 0.0)
                if t + dt < best:
                    best, kind, what = t + dt, 1, 4 * d + 3
        elif vd > 0.0:
            dt = max((edges[c + 1] - xd) / vd, 0.0)
            if t + dt < best:
                best, kind, what = t + dt, 1, 4 * d + 2
    # neighbours in the 3^D block of cells
    lo1 = -1 if dim > 1 else 0
    hi1 = 1 if dim > 1 else 0
    lo2 = -1 if dim > 2 else 0
    hi2 = 1 if dim > 2 else 0
    sh = np.zeros(3)
    nn = np.zeros(3, dtype=np.int64)
    for o0 in range(-1, 2):
        for o1 in range(lo1, hi1 + 1):
            for o2 in range(lo2, hi2 + 1):
                ok = True
                cell = 0
                for d in range(dim):
                    o = o0 if d == 0 else (o1 if d == 1 else o2)
                    cn = cc[i, d] + o
                    sh[d] = 0.0
                    if cn < 0:
                        if not periodic:
                            ok = False
                        cn += nc
                        sh[d] = -L
                    elif cn >= nc:
                        if not periodic:
                            ok = False
                        cn -= nc
                        sh[d] = L
                    nn[d] = cn
                    cell = cell * nc + cn
                if not ok:
                    continue
                m = head[cell]
                while m >= 0:
                    if m != i:
                        dtm = t - ts[m]
                        b = 0.0
                        c2 = 0.0
                        a2 = 0.0
                        for d in range(dim):
                            dx = x[m, d] + v[m, d] * dtm + sh[d] - x[i, d]
                            dv = v[m, d] - v[i, d]
                            b += dx * dv
                            c2 += dx * dx
                            a2 += dv * dv
                        sig = (R[i] + R[m]) * f
                        ag = (R[i] + R[m]) * gamma
                        A = a2 - ag * ag
                        B = b - sig * ag
                        C = c2 - sig * sig
                        dt = np.inf
                        if C < 0.0:
                            # touching (round-off) or overlapping: collide now if
                            # closing in; if separating but outgrown (A < 0), at
                            # the second root, when the pair touches again
                            if B < 0.0:
                                dt = 0.0
                            elif A < 0.0:
                                disc = B * B - A * C
                                dt = (-B - math.sqrt(disc)) / A if disc > 0.0 else 0.0
                        else:
                            disc = B * B - A * C
                            if disc >= 0.0:
                                den = -B + math.sqrt(disc)
                                if den > 0.0:
                                    dt = C / den
                        if t + dt < best:
                            best, kind, what, pc = t + dt, 0, m, cnt[m]
                    m = nxt[m]
    return best, kind, what, pc


@njit
def _ls_to(x, v, ts, k, t):
    """Particle k moved along its straight path from its stamp ts[k] to time t."""
    dt = t - ts[k]
    for d in range(x.shape[1]):
        x[k, d] += v[k, d] * dt
    ts[k] = t


@njit
def _ls_all_to(x, v, ts, t):
    """Every particle moved along its straight path to time t."""
    for k in range(x.shape[0]):
        _ls_to(x, v, ts, k, t)


@njit
def _ls_grow(x, v, R, L, periodic, gamma, f_end, nc, max_events, rescale_every):
    """Lubachevsky-Stillinger growth, event by event (cells of side >= the final largest diameter).

    x (N, D) start positions (points: f = 0 at t = 0), v (N, D) velocities,
    R (N,) final radii, all in units where the box is L wide. Radii grow as
    R gamma t; a colliding pair leaves with its normal relative velocity
    mirrored about the growth speed (elastic in the growing frame), a wall
    likewise; every ``rescale_every`` events the speeds are scaled back to
    unit mean square per component and every event predicted afresh.
    x is updated in place to time f_end / gamma. Returns (status, f reached,
    events): status 0 done, 1 event budget spent (jammed below f_end).
    """
    n, dim = x.shape
    edges = np.arange(nc + 1) * (L / nc)
    edges[nc] = L
    ncell = nc ** dim
    head = -np.ones(ncell, dtype=np.int64)
    nxt = -np.ones(n, dtype=np.int64)
    prv = -np.ones(n, dtype=np.int64)
    cell_of = np.zeros(n, dtype=np.int64)
    cc = np.zeros((n, 3), dtype=np.int64)
    ts = np.zeros(n)
    cnt = np.zeros(n, dtype=np.int64)
    ekind = np.zeros(n, dtype=np.int64)
    ewhat = np.zeros(n, dtype=np.int64)
    epc = np.zeros(n, dtype=np.int64)
    # the engine's heap (gaz_cli.engine.calendar) holds every particle under its next event
    hk = np.empty(n)
    hi = np.empty(n, dtype=np.int64)
    hq = np.zeros((n, 4), dtype=np.int32)  # its links: the position of k in the heap at HP
    a = L / nc
    for k in range(n):
        cell = 0
        for d in range(dim):
            c = min(max(int(x[k, d] / a), 0), nc - 1)
            cc[k, d] = c
            cell = cell * nc + c
        cell_of[k] = cell
        nxt[k] = head[cell]
        if head[cell] >= 0:
            prv[head[cell]] = k
        head[cell] = k
    t_end = f_end / gamma
    t = 0.0
    events = 0
    fresh = True
    while True:
        if fresh:
            # (re)start: every row at time t, every event predicted
            _ls_all_to(x, v, ts, t)
            hsize = 0
            for k in range(n):
                tk, kind, what, pc = _ls_predict(k, t, x, v, ts, R, cnt, cc, head, nxt, edges,
                                                 nc, L, periodic, gamma)
                hsize = _heap_push(hk, hi, hq, hsize, tk, k)
                ekind[k] = kind
                ewhat[k] = what
                epc[k] = pc
            fresh = False
        te = hk[0]
        if te >= t_end:
            t = t_end
            break
        if events >= max_events:
            return 1, gamma * t, events
        i = hi[0]
        t = te
        events += 1
        f = gamma * t
        movers = 1
        j = -1
        # advance i
        _ls_to(x, v, ts, i, t)
        if ekind[i] == 0:
            j = ewhat[i]
            if cnt[j] != epc[i]:
                j = -1
            else:
                movers = 2
                _ls_to(x, v, ts, j, t)
                r2 = 0.0
                un = 0.0
                dxs = np.empty(3)
                for d in range(dim):
                    dx = x[j, d] - x[i, d]
                    if periodic:
                        dx -= L * np.rint(dx / L)
                    dxs[d] = dx
                    r2 += dx * dx
                rr = math.sqrt(r2)
                if rr > 0.0:
                    for d in range(dim):
                        un += (v[j, d] - v[i, d]) * dxs[d] / rr
                    ag = (R[i] + R[j]) * gamma
                    if un < ag:
                        du = 2.0 * (ag - un)
                        for d in range(dim):
                            v[j, d] += 0.5 * du * dxs[d] / rr
                            v[i, d] -= 0.5 * du * dxs[d] / rr
                cnt[i] += 1
                cnt[j] += 1
        else:
            code = ewhat[i]
            d = code >> 2
            up = (code & 2) != 0
            if code & 1:
                rg = R[i] * gamma
                if up:
                    x[i, d] = L - R[i] * f
                    v[i, d] = -2.0 * rg - v[i, d]
                else:
                    x[i, d] = R[i] * f
                    v[i, d] = 2.0 * rg - v[i, d]
                cnt[i] += 1
            else:
                c = cc[i, d]
                if up:
                    cn = c + 1
                    x[i, d] = edges[cn]
                    if cn == nc:
                        cn = 0
                        x[i, d] = 0.0
                else:
                    cn = c - 1
                    x[i, d] = edges[c]
                    if cn < 0:
                        cn = nc - 1
                        x[i, d] = L
                if cn != c:
                    old = cell_of[i]
                    if prv[i] >= 0:
                        nxt[prv[i]] = nxt[i]
                    else:
                        head[old] = nxt[i]
                    if nxt[i] >= 0:
                        prv[nxt[i]] = prv[i]
                    cc[i, d] = cn
                    cell = 0
                    for e in range(dim):
                        cell = cell * nc + cc[i, e]
                    cell_of[i] = cell
                    prv[i] = -1
                    nxt[i] = head[cell]
                    if head[cell] >= 0:
                        prv[head[cell]] = i
                    head[cell] = i
        if rescale_every > 0 and events % rescale_every == 0:
            # everybody to now at the old speeds, then the new speeds
            _ls_all_to(x, v, ts, t)
            s2 = 0.0
            for k in range(n):
                for d in range(dim):
                    s2 += v[k, d] * v[k, d]
            scale = math.sqrt(n * dim / s2) if s2 > 0.0 else 1.0
            for k in range(n):
                for d in range(dim):
                    v[k, d] *= scale
                cnt[k] += 1
            fresh = True
            continue
        for s in range(movers):
            p = i if s == 0 else j
            tk, kind, what, pc = _ls_predict(p, t, x, v, ts, R, cnt, cc, head, nxt, edges,
                                             nc, L, periodic, gamma)
            ekind[p] = kind
            ewhat[p] = what
            epc[p] = pc
            hsize = _heap_remove(hk, hi, hq, hsize, hq[p, HP])
            hsize = _heap_push(hk, hi, hq, hsize, tk, p)
    _ls_all_to(x, v, ts, t)
    return 0, gamma * t, events


def grow(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
         periodic: bool = False, rate: float = GROWTH_RATE,
         max_events: int | None = None) -> np.ndarray:
    """Lubachevsky-Stillinger growth (Lubachevsky & Stillinger, J. Stat. Phys. 60, 561, 1990).

    Points scattered at random grow into spheres of ``radii`` while moving
    (event-driven, cells one final diameter wide): a random, dense,
    non-overlapping state, up to the liquid's limit (2D 0.70, 3D 0.50; a
    lattice goes further). The event budget (default 4000 N + 10^6) bounds
    the effort; a box that jams first raises :class:`PlacementError`.
    Deterministic from ``rng``.
    """
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    n = radii.size
    sigma = 2.0 * float(radii.max())
    if sigma <= 0.0 or n < 2:
        return rejection(dim, radii, length, rng, periodic)
    # units of the largest diameter; velocities of unit mean square
    Ls = length / sigma
    R = radii / sigma
    x = rng.random((n, dim)) * Ls
    v = rng.standard_normal((n, dim))
    v -= v.mean(axis=0)
    nc = max(1, int(math.floor(Ls / (1.0 + 1e-9))))
    budget = max_events if max_events is not None else 4000 * n + 1_000_000
    status, f, events = _ls_grow(x, v, R, float(Ls), bool(periodic), float(rate), 1.0, nc,
                                 int(budget), int(2 * n))
    if status != 0:
        eta = packing_fraction(dim, radii, length)
        raise PlacementError(
            f"growth jammed at {f ** dim * eta:.3g} of packing fraction {eta:.3g} after {events} "
            f"events; use --method lattice, lower --n or raise --length")
    x *= sigma
    if periodic:
        x -= length * np.floor(x / length)
        x[x >= length] = 0.0
    else:
        np.clip(x, radii[:, None], length - radii[:, None], out=x)
    return x
