"""Lubachevsky-Stillinger growth on the engine's kernels: random points grow into the
particles while moving, event by event (docs/architecture.md)."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.engines.event.boundaries import _nearest
from gaz_cli.engines.event.calendar import _heap_push, _heap_remove
from gaz_cli.engines.event.dynamics import _advance, _relative_at
from gaz_cli.engines.event.interactions import _contact_dt
from gaz_cli.engines.event.layout import (C0, CELL, CELL_FULL, CNT, CODE, DONE, HP, I_WIDTH, INF,
                                          P_WIDTH, PART, PCNT, PR, PT, PV)
from gaz_cli.engines.event.neighbours.cells import _cell_entered, _cross_face, _gather_cells, wider
from gaz_cli.errors import PlacementError
from gaz_cli.geometry import packing_fraction
from gaz_cli.numba_config import njit
from gaz_cli.placement import obstacles
from gaz_cli.placement.overlaps import _cell_table, _gather_buffers
from gaz_cli.placement.rsa import rapid_1d, rejection

GROWTH_RATE = 0.1
"""LS growth: final diameters grow from 0 at this rate per unit time (speeds ~1 diameter/time)."""


@njit
def _ls_next(P, I, cells, GB, GS, edges, k, t, nc, L, periodic, gamma, D, OH, OS, og, oncg):
    """Particle k's next event (its row at time t) under growth r_m(t) = R_m gamma t: its time,
    written to k's row of I as the engine writes a prediction (PART: the partner, PCNT: the
    partner's counter; -1 and CODE: a wall or cell face, coded as the engine's crossings).

    A wall meets the growing surface, a face the centre; the partners are the particles of
    the 3^D cells around (the engine's gather, each with its image), each pair's time the
    engine's contact root with the sum of radii growing (interactions._contact_dt): a pair
    touching and closing in collides now, one parting faster than it grows is left alone.
    The fixed spheres of k's cell in the table OH, OS (:class:`.obstacles.Table` on these
    cells, og of them an axis to its cells, oncg an axis; None: none) likewise, at their
    full radius (partner n + the entry).
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
    if OS is not None:  # (None: no fixed sphere; Numba compiles this block out)
        cell = I[k, C0] // og
        if D > 1:
            cell = cell * oncg + I[k, C0 + 1] // og
        if D > 2:
            cell = cell * oncg + I[k, C0 + 2] // og
        for e in range(OH[cell], OH[cell + 1]):
            tm = t + _contact_dt(OS[e, 0] - xk0, OS[e, 1] - xk1, OS[e, 2] - xk2, -vk0, -vk1, -vk2,
                                 OS[e, 3] + rk * f, rg, D)
            if tm < best:
                best = tm
                part = P.shape[0] + e
    I[k, PART] = part
    I[k, PCNT] = I[part, CNT] if 0 <= part < P.shape[0] else 0
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


@njit
def _ls_bounce(P, i, OS, e, gamma, D):
    """Particle i, its row at its contact with the fixed sphere OS[e], leaves with its normal
    velocity mirrored about its growth speed (the sphere neither moves nor grows)."""
    n0 = P[i, 0] - OS[e, 0]
    n1 = P[i, 1] - OS[e, 1] if D > 1 else 0.0
    n2 = P[i, 2] - OS[e, 2] if D > 2 else 0.0
    rr = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if rr > 0.0:
        n0, n1, n2 = n0 / rr, n1 / rr, n2 / rr
        du = P[i, PR] * gamma - (P[i, PV] * n0 + (P[i, PV + 1] * n1 if D > 1 else 0.0)
                                 + (P[i, PV + 2] * n2 if D > 2 else 0.0))
        if du > 0.0:
            for d in range(D):
                P[i, PV + d] += 2.0 * du * (n0 if d == 0 else (n1 if d == 1 else n2))


SLICE_EVENTS = 1 << 18
"""Growth events per kernel call (a fraction of a second): the placement returns to Python
between calls, so that a signal ends it."""


@njit
def _ls_grow(P, I, cells, GB, GS, edges, HK, HI, Q, C, D, L, periodic, gamma, f_end, nc,
             max_events, rescale_every, OH, OS, og, oncg):
    """Lubachevsky-Stillinger growth, event by event, on the engine's rows, cells and heap.

    P (N, P_WIDTH) rows at time 0: start positions (points: f = 0 at t = 0), velocities,
    final radii R, in units where the box is L wide; I (N, I_WIDTH) with the cells
    assigned (cells of side >= the final largest diameter; ``cells`` and the gather
    buffers GB, GS as the engine's). The engine's heap (:mod:`gaz_cli.engines.event.calendar`: keys HK
    (N,), particles HI (N,), links Q (N, 4)) holds every particle under its next event;
    C (3,) float64 is where the growth stands: time, events, heap size (-1 before the first
    call: every event predicted then).
    Radii grow as R gamma t; a colliding pair leaves with its normal relative velocity
    mirrored about the growth speed (elastic in the growing frame), a wall likewise;
    every ``rescale_every`` events the speeds are scaled back to unit mean square per
    component and every event predicted afresh. OH, OS, og, oncg: fixed spheres
    (:func:`_ls_next`), off which a particle bounces as off a wall. The rows are moved to time f_end / gamma.
    Returns (status, f reached, events): status DONE, 1 event budget spent (jammed
    below f_end) or CELL_FULL: the next event, a crossing, would overflow a cell; nothing of
    it is done: widen the table (:func:`gaz_cli.engines.event.neighbours.cells.wider`), take gather
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
                tk = _ls_next(P, I, cells, GB, GS, edges, k, t, nc, L, periodic, gamma, D, OH, OS, og,
                              oncg)
                hsize = _heap_push(HK, HI, Q, hsize, tk, k)
            fresh = False
        te = HK[0]
        if te >= t_end:
            t = t_end
            break
        if events >= max_events:
            C[0], C[1], C[2] = t, events, hsize  # a call may go on from here
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
        if m >= n:
            if OS is not None:
                _ls_bounce(P, i, OS, m - n, gamma, D)
            I[i, CNT] += 1
        elif m >= 0:
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
                tk = _ls_next(P, I, cells, GB, GS, edges, p, t, nc, L, periodic, gamma, D, OH, OS,
                              og, oncg)
                hsize = _heap_remove(HK, HI, Q, hsize, Q[p, HP])
                hsize = _heap_push(HK, HI, Q, hsize, tk, p)
    for k in range(n):
        _advance(P, k, t, 0.0, D, False)
    return DONE, gamma * t, events


def grow(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
         periodic: bool = False, rate: float = GROWTH_RATE,
         max_events: int | None = None, fixed: tuple | None = None) -> np.ndarray:
    """Lubachevsky-Stillinger growth (Lubachevsky & Stillinger, J. Stat. Phys. 60, 561, 1990).

    Points scattered at random grow into spheres of ``radii`` while moving
    (event-driven on the engine's rows, cells one final diameter wide, heap and
    contact root; see docs/architecture.md): a random, dense,
    non-overlapping state, up to the liquid's limit (2D 0.70, 3D 0.50; a
    lattice goes further). The event budget (default 4000 N + 10^6) bounds
    the effort; a box that jams first raises :class:`PlacementError`.
    Deterministic from ``rng``. ``fixed``: (centres (K, D), radii (K,)) of spheres already in
    the box, which the particles grow around (their points start outside them).
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
    nc = max(1, int(math.floor(Ls / (1.0 + 1e-9))))
    x = rng.random((n, dim)) * Ls
    heads = spheres = None  # no fixed sphere: the kernels' compiled code has no look for one
    og = oncg = 1
    if fixed is not None and len(fixed[1]):
        table = obstacles.table(np.asarray(fixed[0]) / sigma, np.asarray(fixed[1]) / sigma, Ls,
                                periodic, float(R.max()), nc)
        _outside(table, x, Ls, rng)
        heads, spheres, og, oncg = table.heads, table.spheres, table.g, table.ncg
    v = rng.standard_normal((n, dim))
    v -= v.mean(axis=0)
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
        # slices of SLICE_EVENTS: back in Python between them, where a SIGINT or SIGTERM takes
        # effect (one call of the whole budget, 4000 N events, ran minutes deaf to them)
        cap = min(int(budget), int(C[1]) + SLICE_EVENTS)
        status, f, events = _ls_grow(P, I, cells, *_gather_buffers(cells, dim), edges, HK, HI, Q,
                                     C, dim, float(Ls), bool(periodic), float(rate), 1.0, nc,
                                     cap, int(2 * n), heads, spheres, og, oncg)
        if status == 1 and events < budget:
            continue
        if status != CELL_FULL:
            break
        cells = wider(cells)  # a crossing into a full cell: room, and on
    if status != DONE:
        eta = packing_fraction(dim, radii, length)
        raise PlacementError(
            f"growth jammed at {f ** dim * eta:.3g} of packing fraction {eta:.3g} after {events} "
            f"events; lower --n or raise --length")
    x = P[:, :dim] * sigma
    if periodic:
        x -= length * np.floor(x / length)
        x[x >= length] = 0.0
    else:
        np.clip(x, radii[:, None], length - radii[:, None], out=x)
    return x


def _outside(spheres: "obstacles.Table", x: np.ndarray, length: float, rng: np.random.Generator,
             tries: int = 1000) -> None:
    """Draw again, uniformly in the box, the points of ``x`` inside a fixed sphere, until none is
    (the spheres fill at most the densest random packing: a few draws)."""
    for _ in range(tries):
        inside = np.flatnonzero(obstacles.touching(spheres, x, 1e-9))
        if not inside.size:
            return
        x[inside] = rng.random((inside.size, x.shape[1])) * length
    raise PlacementError(f"the large particles leave no room for the small ones ({tries} draws of "
                         "each point fell inside one); lower --n or raise --length")
