"""Random placements: the exam's 1D draw (:func:`rapid_1d`, Q10) and random sequential
addition on a cell grid (:func:`rejection`), interpreted for small dilute scenes."""

from __future__ import annotations

import functools
import math

import numpy as np

from gaz_cli.errors import PlacementError
from gaz_cli.geometry import packing_fraction

INTERPRETED_MAX = 256
"""Up to this many particles, random sequential addition runs as plain Python (the kernel's
``py_func``: the same statements, the same float operations -- no fastmath -- so the same
positions) instead of loading compiled code: loading the first cached kernel of a process
costs Numba about a second (its context refresh), placing 256 particles in Python 30 ms.
A run whose engine needs no compiled code (``ideal``, a tiny ``reference`` run) then starts
in the time of its imports: Numba itself is imported at the first compiled placement
(:func:`_compiled_rsa`), not before."""

INTERPRETED_PACKING = 0.1
"""... and at most this packing fraction, where a few candidates per particle suffice (a
placement near jamming may try millions: compiled, not interpreted)."""


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


def _rsa(cand, radii, length, periodic, pos, placed, cell_size, ncell, head, nxt,
         max_tries, cell, x, oh, osp, oa, onc, og, oncg):
    """Place particles ``placed..N-1`` from candidate points ``cand`` (M, D) in [0,1)^D.

    ``oh``, ``osp``, ``oa``, ``onc``, ``og``, ``oncg``: a table of fixed spheres a
    candidate must not overlap either (:class:`.obstacles.Table`; ``osp`` None: none, and
    the interpreted kernel calls no compiled code).
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
        if osp is not None:  # (None: no fixed sphere; Numba compiles this block out)
            if ok:
                key = _key(x[0], x[1] if dim > 1 else 0.0, x[2] if dim > 2 else 0.0, oa, onc, og,
                           oncg, dim)
                ok = not _touches(oh, osp, key, x[0], x[1] if dim > 1 else 0.0,
                                  x[2] if dim > 2 else 0.0, r, dim)
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


def _no_spheres():
    """No table of fixed spheres (in place of :class:`.obstacles.Table`'s fields)."""
    return None, None, 1.0, 1, 1, 1


def _key(*args):
    """:func:`.obstacles._key` (the interpreted kernel looks at a table only when there is
    one, which a run placed interpreted never has; the compiled one takes the compiled
    function: :func:`_compiled_rsa`)."""
    from gaz_cli.placement.obstacles import _key as key

    return key(*args)


def _touches(*args):
    """:func:`.obstacles._touches` (see :func:`_key`)."""
    from gaz_cli.placement.obstacles import _touches as touches

    return touches(*args)


@functools.cache
def _compiled_rsa():
    """:func:`_rsa` compiled (Numba's disk cache: loaded, not compiled, after the first run),
    its table lookups the compiled ones of :mod:`.obstacles` (Numba reads a kernel's globals
    when it compiles it)."""
    from gaz_cli.numba_config import njit
    from gaz_cli.placement import obstacles

    globals().update(_key=obstacles._key, _touches=obstacles._touches)
    return njit(_rsa)


def rejection(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
              periodic: bool = False, max_tries: int = 100_000,
              budget: int | None = None, fixed: "Table | None" = None) -> np.ndarray:
    """Random sequential addition on a cell grid. O(N) expected below jamming.

    The largest particles go first (a stable sort of the radii, so that one size keeps
    the index order): a large sphere added after thousands of small ones finds almost no
    free room (a 1:10 mixture at packing 0.15, small ones first, was refused 10^5 times in
    a row), while small ones fill the gaps between large ones easily.
    Gives up with :class:`PlacementError` when one particle is refused
    ``max_tries`` times in a row or ``budget`` candidates (default 1000 N +
    10^6) are spent: the exam's Q7 situation ends with an error, never a hang.
    ``fixed``: spheres already in the box (:func:`.obstacles.table`, for radii up to these
    particles' largest), which no particle may overlap either.
    """
    order = np.argsort(-np.asarray(radii, dtype=np.float64), kind="stable")
    placed_sorted = _rejection_in_order(dim, radii[order], length, rng, periodic, max_tries, budget,
                                        fixed)
    pos = np.empty_like(placed_sorted)
    pos[order] = placed_sorted
    return pos


def _rejection_in_order(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
                        periodic: bool, max_tries: int, budget: int | None,
                        fixed: "Table | None" = None) -> np.ndarray:
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
    small = (n <= INTERPRETED_MAX and packing_fraction(dim, radii, length) <= INTERPRETED_PACKING
             and fixed is None)
    rsa = _rsa if small else _compiled_rsa()
    if fixed is None:
        fixed = _no_spheres()
    while placed < n:
        cand = rng.random((batch, dim))
        placed, used, status = rsa(cand, radii, float(length), bool(periodic), pos, placed,
                                    float(cell_size), ncell, head, nxt, max_tries,
                                    np.zeros(3, dtype=np.int64), np.empty(dim), *fixed)
        spent += used
        if status == 2 or spent >= budget:
            eta = packing_fraction(dim, radii, length)
            raise PlacementError(
                f"random placement stuck after {spent} candidates with {placed} of {n} particles "
                f"placed (packing fraction {eta:.3g}); lower --n or raise --length")
    return pos
