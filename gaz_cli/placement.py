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

from gaz_cli.engine.boundaries import _nearest
from gaz_cli.engine.calendar import _heap_push, _heap_remove
from gaz_cli.engine.dynamics import _advance, _relative_at
from gaz_cli.engine.interactions import _contact_dt
from gaz_cli.engine.layout import (C0, CELL, CELL_FULL, CNT, CODE, DONE, GATHER_SLOTS, HP,
                                   I_WIDTH, INF, P_WIDTH, PART, PCNT, PR, PT, PV)
from gaz_cli.engine.neighbours.cells import (_assign_cells, _cell_entered, _cross_face, _gather_cells,
                                             wider)
from gaz_cli.engine.sizing import _cell_width
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
def _first_overlap(pos, radii, length, periodic, I, cells, GB, GS, nc):
    """Index of a particle overlapping another (beyond 1e-9 relative), or -1 (2D/3D): each
    particle against the later ones in the 3^D cells around its own (the engine's cells,
    assigned in ``I`` and ``cells``: :func:`_cell_table`; one cell: that cell). O(N)."""
    n, dim = pos.shape
    b = 1 if nc > 1 else 0
    for i in range(n):
        ng = _gather_cells(pos, I, cells, GB, GS, 0, I[i, C0], I[i, C0 + 1],
                           I[i, C0 + 2] if dim > 2 else 0, -b, b, -b, b, -b, b, nc, dim, periodic,
                           False, False)
        for u in range(ng):
            j = GB[u]
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
    return -1


def _cell_table(P, I, nc: int, a: float, dim: int) -> np.ndarray:
    """The engine's cell table (:mod:`.engine.neighbours.cells`) of the centres P[:, :dim]:
    cells of side a, nc an axis, each particle's cell in I; wide enough for the fullest."""
    cap = GATHER_SLOTS
    while True:
        cells = np.zeros((nc ** dim, _cell_width(cap)), dtype=np.int32)
        if _assign_cells(P, I, cells, nc, a, dim) == DONE:
            return cells
        cap *= 2


def first_overlap(positions: np.ndarray, radii: np.ndarray, length: float,
                  periodic: bool = False) -> int:
    """Index of a particle that overlaps another (beyond 1e-9 relative), or -1; O(N) (1D: the
    rods in line order, O(N log N))."""
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    n, dim = positions.shape
    if n < 2:
        return -1
    if dim == 1:
        # rods that overlap nobody next to them in line order overlap nobody
        order = np.argsort(positions[:, 0], kind="stable")
        x, r = positions[order, 0], radii[order]
        gap = np.diff(x, append=x[0] + length if periodic else np.inf)
        bad = np.flatnonzero(gap < (r + np.roll(r, -1)) * (1.0 - 1e-9))
        return int(order[bad[0]]) if bad.size else -1
    rmax = float(np.max(radii))
    by_size = int(length / (2.0 * rmax)) if rmax > 0 else n
    nc = max(1, min(by_size, int(math.ceil(n ** (1.0 / dim)))))
    if periodic and nc < 3:
        nc = 1
    I = np.zeros((n, I_WIDTH), dtype=np.int32)
    cells = _cell_table(positions, I, nc, length / nc, dim)
    return int(_first_overlap(positions, radii, float(length), bool(periodic), I, cells,
                              *_gather_buffers(cells, dim), nc))


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
    Its cells are linked lists of its own (``head``, ``nxt``), not the engine's table: this
    kernel also runs interpreted (INTERPRETED_MAX), where the engine's compiled helpers
    would load compiled code, and in 1D; a list takes any number of particles a cell.
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

    The largest particles go first (a stable sort of the radii, so that one size keeps
    the index order): a large sphere added after thousands of small ones finds almost no
    free room (a 1:10 mixture at packing 0.15, small ones first, was refused 10^5 times in
    a row), while small ones fill the gaps between large ones easily.
    Gives up with :class:`PlacementError` when one particle is refused
    ``max_tries`` times in a row or ``budget`` candidates (default 1000 N +
    10^6) are spent: the exam's Q7 situation ends with an error, never a hang.
    """
    order = np.argsort(-np.asarray(radii, dtype=np.float64), kind="stable")
    placed_sorted = _rejection_in_order(dim, radii[order], length, rng, periodic, max_tries, budget)
    pos = np.empty_like(placed_sorted)
    pos[order] = placed_sorted
    return pos


def _rejection_in_order(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
                        periodic: bool, max_tries: int, budget: int | None) -> np.ndarray:
    """:func:`rejection`'s addition, the particles taken in the order given."""
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
    # the closest spacing allowed: touching spheres; points: n + 1 a side leave n sites or more
    closest = sigma if sigma > 0.0 else length / (n + 1)
    sites = _lattice_sites(dim, closest, lo, hi, periodic, length)
    if sites is None or len(sites) < n:
        have = 0 if sites is None else len(sites)
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


# --- Lubachevsky-Stillinger growth -------------------------------------------
GROWTH_RATE = 0.1
"""LS growth: final diameters grow from 0 at this rate per unit time (speeds ~1 diameter/time)."""

RANDOM_LIMIT = {2: 0.70, 3: 0.50}
"""Densest random (grown) packing offered: beyond, a lattice start (2D liquid ends near 0.70,
3D freezing at 0.494; growth goes further only by jamming into a glass)."""

LATTICE_LIMIT = {1: 1.0, 2: 0.9069, 3: 0.7405}
"""Close packing of the lattices (hexagonal 2D, FCC 3D)."""


@njit
def _ls_next(P, I, cells, GB, GS, edges, k, t, nc, L, periodic, gamma, D):
    """Particle k's next event (its row at time t) under growth r_m(t) = R_m gamma t: its time,
    written to k's row of I as the engine writes a prediction (PART: the partner, PCNT: the
    partner's counter; -1 and CODE: a wall or cell face, coded as the engine's crossings).

    A wall meets the growing surface, a face the centre; the partners are the particles of
    the 3^D cells around (the engine's gather, each with its image), each pair's time the
    engine's contact root with the sum of radii growing (interactions._contact_dt): a pair
    touching and closing in collides now, one parting faster than it grows is left alone.
    """
    f = gamma * t
    rk = P[k, PR]
    rg = rk * gamma
    best = INF
    code = -1
    for d in range(D):
        c = I[k, C0 + d]
        x = P[k, d]
        v = P[k, PV + d]
        if not periodic and c == 0:
            if rg - v > 0.0:
                dt = max((x - rk * f) / (rg - v), 0.0)
                if t + dt < best:
                    best, code = t + dt, 4 * d + 1
        elif v < 0.0:
            dt = max((edges[c] - x) / v, 0.0)
            if t + dt < best:
                best, code = t + dt, 4 * d
        if not periodic and c == nc - 1:
            if v + rg > 0.0:
                dt = max((L - rk * f - x) / (v + rg), 0.0)
                if t + dt < best:
                    best, code = t + dt, 4 * d + 3
        elif v > 0.0:
            dt = max((edges[c + 1] - x) / v, 0.0)
            if t + dt < best:
                best, code = t + dt, 4 * d + 2
    c1 = I[k, C0 + 1] if D > 1 else 0
    c2 = I[k, C0 + 2] if D > 2 else 0
    ng = _gather_cells(P, I, cells, GB, GS, 0, I[k, C0], c1, c2, -1, 1, -1, 1, -1, 1, nc, D,
                       periodic, True, False)
    xk0 = P[k, 0]
    xk1 = P[k, 1] if D > 1 else 0.0
    xk2 = P[k, 2] if D > 2 else 0.0
    vk0 = P[k, PV]
    vk1 = P[k, PV + 1] if D > 1 else 0.0
    vk2 = P[k, PV + 2] if D > 2 else 0.0
    part = -1
    for u in range(ng):
        m = GB[u]
        if m == k:
            continue
        dx0, dx1, dx2, dv0, dv1, dv2 = _relative_at(P, m, t, xk0, xk1, xk2, vk0, vk1, vk2, 0.0,
                                                    D, False)
        w = GS[u]  # the image: 9 w0 + 3 w1 + w2, w = 0, 1, 2 for a shift of -L, 0, +L
        dx0 += L * (w // 9 - 1)
        dx1 += L * ((w // 3) % 3 - 1)
        dx2 += L * (w % 3 - 1)
        sr = rk + P[m, PR]
        tm = t + _contact_dt(dx0, dx1, dx2, dv0, dv1, dv2, sr * f, sr * gamma, D)
        if tm < best:
            best = tm
            part = m
    I[k, PART] = part
    I[k, PCNT] = I[part, CNT] if part >= 0 else 0
    I[k, CODE] = code
    return best


@njit
def _ls_collide(P, i, j, L, periodic, gamma, D):
    """Particles i and j, rows at their contact, leave with their normal relative velocity
    mirrored about the speed at which the sum of their radii grows (elastic in the growing
    frame; equal masses)."""
    n0, n1, n2, dv0, dv1, dv2 = _relative_at(P, j, P[i, PT], P[i, 0], P[i, 1] if D > 1 else 0.0,
                                             P[i, 2] if D > 2 else 0.0, P[i, PV],
                                             P[i, PV + 1] if D > 1 else 0.0,
                                             P[i, PV + 2] if D > 2 else 0.0, 0.0, D, False)
    if periodic:
        n0, n1, n2 = _nearest(n0, L), _nearest(n1, L), _nearest(n2, L)
    rr = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if rr > 0.0:
        n0, n1, n2 = n0 / rr, n1 / rr, n2 / rr
        du = (P[i, PR] + P[j, PR]) * gamma - (dv0 * n0 + dv1 * n1 + dv2 * n2)
        if du > 0.0:
            for d in range(D):
                nd = n0 if d == 0 else (n1 if d == 1 else n2)
                P[j, PV + d] += du * nd
                P[i, PV + d] -= du * nd


def _gather_buffers(cells, dim: int) -> tuple:
    """The gather buffers (GB, GS) of a scan of the 3^dim cells of ``cells``' width."""
    room = 3 ** dim * (cells.shape[1] - 1) + GATHER_SLOTS + 1
    return np.empty(room, dtype=np.int32), np.empty(room, dtype=np.int32)


@njit
def _ls_grow(P, I, cells, GB, GS, edges, HK, HI, Q, C, D, L, periodic, gamma, f_end, nc,
             max_events, rescale_every):
    """Lubachevsky-Stillinger growth, event by event, on the engine's rows, cells and heap.

    P (N, P_WIDTH) rows at time 0: start positions (points: f = 0 at t = 0), velocities,
    final radii R, in units where the box is L wide; I (N, I_WIDTH) with the cells
    assigned (cells of side >= the final largest diameter; ``cells`` and the gather
    buffers GB, GS as the engine's). The engine's heap (:mod:`.engine.calendar`: keys HK
    (N,), particles HI (N,), links Q (N, 4)) holds every particle under its next event;
    C (3,) float64 is where the growth stands: time, events, heap size (-1 before the first
    call: every event predicted then).
    Radii grow as R gamma t; a colliding pair leaves with its normal relative velocity
    mirrored about the growth speed (elastic in the growing frame), a wall likewise;
    every ``rescale_every`` events the speeds are scaled back to unit mean square per
    component and every event predicted afresh. The rows are moved to time f_end / gamma.
    Returns (status, f reached, events): status DONE, 1 event budget spent (jammed
    below f_end) or CELL_FULL: the next event, a crossing, would overflow a cell; nothing of
    it is done: widen the table (:func:`.engine.neighbours.cells.wider`), take gather
    buffers for it and call again, which goes on from there.
    """
    n = P.shape[0]
    t_end = f_end / gamma
    t = C[0]
    events = int(C[1])
    hsize = int(C[2])
    fresh = hsize < 0
    while True:
        if fresh:
            # (re)start: every row at time t, every event predicted
            hsize = 0
            for k in range(n):
                _advance(P, k, t, 0.0, D, False)
            for k in range(n):
                tk = _ls_next(P, I, cells, GB, GS, edges, k, t, nc, L, periodic, gamma, D)
                hsize = _heap_push(HK, HI, Q, hsize, tk, k)
            fresh = False
        te = HK[0]
        if te >= t_end:
            t = t_end
            break
        if events >= max_events:
            return 1, gamma * t, events
        i = HI[0]
        if I[i, PART] < 0 and not I[i, CODE] & 1:  # a crossing: room in the cell entered?
            into = _cell_entered(I, i, I[i, CODE], nc, D)
            if into != I[i, CELL] and cells[into, 0] + 1 >= cells.shape[1]:
                C[0], C[1], C[2] = t, events, hsize
                return CELL_FULL, gamma * t, events
        t = te
        events += 1
        j = -1
        _advance(P, i, t, 0.0, D, False)
        m = I[i, PART]
        if m >= 0:
            if I[m, CNT] == I[i, PCNT]:
                j = m
                _advance(P, j, t, 0.0, D, False)
                _ls_collide(P, i, j, L, periodic, gamma, D)
                I[i, CNT] += 1
                I[j, CNT] += 1
        else:
            code = I[i, CODE]
            d = code >> 2
            up = (code & 2) != 0
            if code & 1:
                # a wall: the centre a growing radius from it, the velocity mirrored about
                # the growth speed
                rg = P[i, PR] * gamma
                if up:
                    P[i, d] = L - P[i, PR] * (gamma * t)
                    P[i, PV + d] = -2.0 * rg - P[i, PV + d]
                else:
                    P[i, d] = P[i, PR] * (gamma * t)
                    P[i, PV + d] = 2.0 * rg - P[i, PV + d]
                I[i, CNT] += 1
            else:
                _cross_face(P, I, cells, edges, i, d, up, nc, L, D)
        if rescale_every > 0 and events % rescale_every == 0:
            # everybody to now at the old speeds, then the new speeds
            for k in range(n):
                _advance(P, k, t, 0.0, D, False)
            s2 = 0.0
            for k in range(n):
                for d in range(D):
                    s2 += P[k, PV + d] * P[k, PV + d]
            scale = math.sqrt(n * D / s2) if s2 > 0.0 else 1.0
            for k in range(n):
                for d in range(D):
                    P[k, PV + d] *= scale
                I[k, CNT] += 1
            fresh = True
            continue
        for p in (i, j):
            if p >= 0:
                tk = _ls_next(P, I, cells, GB, GS, edges, p, t, nc, L, periodic, gamma, D)
                hsize = _heap_remove(HK, HI, Q, hsize, Q[p, HP])
                hsize = _heap_push(HK, HI, Q, hsize, tk, p)
    for k in range(n):
        _advance(P, k, t, 0.0, D, False)
    return DONE, gamma * t, events


def grow(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
         periodic: bool = False, rate: float = GROWTH_RATE,
         max_events: int | None = None) -> np.ndarray:
    """Lubachevsky-Stillinger growth (Lubachevsky & Stillinger, J. Stat. Phys. 60, 561, 1990).

    Points scattered at random grow into spheres of ``radii`` while moving
    (event-driven on the engine's rows, cells one final diameter wide, heap and
    contact root; see docs/architecture.md): a random, dense,
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
    if dim == 1:
        return rapid_1d(radii, length, rng, periodic)
    # units of the largest diameter; velocities of unit mean square
    Ls = length / sigma
    R = radii / sigma
    x = rng.random((n, dim)) * Ls
    v = rng.standard_normal((n, dim))
    v -= v.mean(axis=0)
    nc = max(1, int(math.floor(Ls / (1.0 + 1e-9))))
    P = np.zeros((n, P_WIDTH))
    P[:, :dim] = x
    P[:, PV:PV + dim] = v
    P[:, PR] = R
    I = np.zeros((n, I_WIDTH), dtype=np.int32)
    edges = np.arange(nc + 1) * (Ls / nc)
    edges[nc] = Ls
    cells = _cell_table(P, I, nc, Ls / nc, dim)
    budget = max_events if max_events is not None else 4000 * n + 1_000_000
    HK, HI, Q = np.empty(n), np.empty(n, dtype=np.int64), np.zeros((n, 4), dtype=np.int32)
    C = np.array([0.0, 0.0, -1.0])  # where the growth stands: time, events, heap size
    while True:
        status, f, events = _ls_grow(P, I, cells, *_gather_buffers(cells, dim), edges, HK, HI, Q,
                                     C, dim, float(Ls), bool(periodic), float(rate), 1.0, nc,
                                     int(budget), int(2 * n))
        if status != CELL_FULL:
            break
        cells = wider(cells)  # a crossing into a full cell: room, and on
    if status != DONE:
        eta = packing_fraction(dim, radii, length)
        raise PlacementError(
            f"growth jammed at {f ** dim * eta:.3g} of packing fraction {eta:.3g} after {events} "
            f"events; use --method lattice, lower --n or raise --length")
    x = P[:, :dim] * sigma
    if periodic:
        x -= length * np.floor(x / length)
        x[x >= length] = 0.0
    else:
        np.clip(x, radii[:, None], length - radii[:, None], out=x)
    return x
