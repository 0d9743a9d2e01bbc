"""The step loop of the time-stepped engine (seeds 002 and 003), and the map of its kernels.

Private, plain Numba kernels on contiguous arrays: they never raise, they return
counts and (possibly reallocated) buffers. One module per seam of the step:

* :mod:`.push`: kick and drift, the pair forces;
* :mod:`.wall_contact`: one particle and one flat wall (contact time, bounce, hops, rest);
* :mod:`.walls`: the box walls and extra planes (first wall met, bounce and rows, safety net);
* :mod:`.resting`: particles held at rest by a wall or by a held particle;
* :mod:`.cells`, :mod:`.contacts`: the cells, the pairs in contact, the collision rule;
* :mod:`.patches`: the box cut into patches, the seed's exchange, the sort by cell;
* :mod:`.passes`: the contact passes of one step;
* :mod:`.ranks`: an MPI run's processes (the patches each scans, the allgather of the
  candidates; :mod:`.mpi` starts them);
* :mod:`.codes`: status codes, counters, clocks, tolerances;
* this module: :func:`_run_steps`, a block of steps.

:func:`_run_steps` lays the caller's arrays out in patches (:mod:`.patches`), runs a block
of steps, and puts them back in the caller's order; each step is, in order:

1. half kick  ``v <- v e^{-gamma h} + a (1 - e^{-gamma h}) / gamma`` over
   h = dt/2, the exact solution for a constant acceleration a (gravity plus
   pair attraction at the current positions) and linear friction; ``v += a h``
   without friction; skipped entirely when the scene has no force;
2. drift ``x += v dt`` (straight lines, so going back along them is exact);
   1 and 2 one patch a thread;
3. exchange: the particles that left their patch move to their new one, and each patch
   sorts its particles by cell (:func:`.patches._exchange`, one patch a thread);
4. contact passes (:mod:`.passes`; the first one patch a thread, and in an MPI run the
   patches of this process only, their candidates then shared: :mod:`.ranks`). Each pass
   lists the contacts of the *active* particles
   (all of them in the first pass): the first crossing of a box wall or an
   extra plane (one it ends beyond, or one a path bending away from it went
   beyond and came back from: :func:`gaz_cli.engines.step.walls._earliest_wall`), and pairs in contact
   found with the cells (never O(N^2)). They are sorted by contact time,
   earliest first, ties by particle identity, and applied in that order, a
   particle taking part in at most one contact per pass: a pair is taken back
   to its contact time along its straight segment, its velocities are changed
   along the line of centres (any masses, restitution e, TC model; the
   impulse of the velocities at the contact time, see :func:`gaz_cli.engines.step.contacts._resolve_contact`), and
   it is moved forward to the end of the step; a wall contact does the same
   with the wall (restitution, exact under uniform gravity, the pair
   attraction taken constant over the step, see :func:`gaz_cli.engines.step.wall_contact._wall_contact`); a particle that comes
   to rest on a floor is *held* by it until the step's end (:func:`gaz_cli.engines.step.resting._hold`), a particle resting
   on a held one is held by it in turn, its weight passed on to the floor
   (:func:`gaz_cli.engines.step.resting._rest_on`), and a collision that takes one off releases it there: it flies freely
   from the contact (:func:`gaz_cli.engines.step.resting._release`). The particles that moved are the next pass's
   active set; passes repeat until a pass finds nothing or the pass limit
   is hit (then every particle still beyond a box wall bounces until it is
   inside, and off the planes once: :func:`gaz_cli.engines.step.walls._walls_sweep`);
5. pair accelerations at the new positions (when pair gravity is on; the sum taken in the
   caller's order);
6. half kick (one patch a thread).

Nothing a step computes depends on the layout: per-particle work is the same whatever
the row, contacts are resolved in an order of their own, and sums over particles
(the virial, the counters) follow that order; so the numbers are the same bit for bit
whatever the number of patches and threads. (One exception: pair forces of 1024 bodies
or more on several threads, whose per-thread partial sums are added in another order.)

Contact rule (physics.md section 9): with dr = r_j - r_i, dv = v_j - v_i at the
end of the step, a = |dv|^2, b = dr.dv, c = |dr|^2 - sigma^2, going back by tau
gives |dr - dv tau|^2 = a tau^2 - 2 b tau + c. ``overlap`` detection (seed
002): a pair collides when c < 0 and b < 0, at tau = -c / (sqrt(b^2 - a c) - b)
(the cancellation-free root). ``swept`` detection also catches the pairs that
touched during the step and no longer approach at its end (grazing contacts):
tau = (b + sqrt(b^2 - a c)) / a when b >= 0. In both, tau is limited by the
particles' *age*, the time since their trajectory last bent in this step, so
going back never leaves the real straight segment.

Times of the phases are read with clock_gettime(CLOCK_MONOTONIC) from inside
the kernel (about 30 ns a call).
"""

from __future__ import annotations

import functools
import hashlib
import math
import pathlib

import numpy as np

from gaz_cli.engines.event.intrinsics import kernel_sources
from gaz_cli.engines.step.cells import _cells_per_axis
from gaz_cli.engines.step.codes import (C_MAX_PASSES, C_PAIR_EVALS, C_PASSES, C_STEPS, DONE, FLUSH, PAUSE,
                                        T_COLLISIONS, T_EXCHANGE, T_PUSH, T_WALLS, _now)
from gaz_cli.engines.step.passes import _contact_passes
from gaz_cli.engines.step.patches import _exchange, _layout_in, _layout_out, _patch_grid, _sort_all
from gaz_cli.engines.step.push import _pair_acc, _push_patches
from gaz_cli.numba_config import njit


def sources_digest(root: pathlib.Path | None = None) -> int:
    """A number that changes with the source of any module the step loop's kernels may hold
    (:func:`gaz_cli.engines.event.intrinsics.kernel_sources` from this module: its module-level
    imports, followed), for the ``gaz_cli`` package under ``root`` (default: this one's).

    Numba's disk cache keys a function on its own file only: an edit of walls.py would leave
    a stale :func:`_run_steps` (which holds the walls' code) in the cache. :func:`build` gives
    the loop this number as a closure constant, which Numba's cache key includes.
    """
    root = pathlib.Path(__file__).parents[3] if root is None else pathlib.Path(root)
    h = hashlib.sha256()
    for f in kernel_sources(root, start=__name__):
        h.update(f.relative_to(root).as_posix().encode())
        h.update(f.read_bytes())
    return int(h.hexdigest()[:15], 16)


@functools.lru_cache(maxsize=None)
def build():
    """The step loop :func:`_run_steps`, keyed in Numba's cache on :func:`sources_digest`."""
    SOURCES = sources_digest()

    @njit
    def _run_steps(nsteps, t0, k0, dt, pos, vel, acc, mass, radius, age, tlast, planes,
                 length, g, gamma, G, eps2, e, ew, tc, max_passes, swept,
                 want_b, want_c, bf, bi, nb, cf, ci, ncoll, flush_at,
                 counters, clocks, virial, overlap, clock_id, nthreads, deadline, patches, ws, rank,
                 nranks):
        """Run up to ``nsteps`` steps of dt s (see the module docstring).

        Step s of the call ends at t0 + (k0 + s + 1) dt s: with t0 = 0 and k0 the index of the
        call's first step, every step's end time is the same whatever the calls' lengths, so a
        run cut into calls gives the same numbers bit for bit.

        pos, vel, acc (N, D) float64 are updated in place (acc holds the pair
        accelerations at the current positions); age, tlast (N,) scratch and TC
        times. Bounces go to bf (k, 3: t, |v|, |v_perp|) / bi (k, 2: particle,
        RE_DIR) from row nb, collisions to cf (k, 2: t, |J|) / ci (k, 2: i, j)
        from row ncoll; buffers grow as needed. counters (int64), clocks
        (float64, s) and virial (1,) accumulate. The pairs each step leaves overlapping (closer
        than (1 - OVERLAP_TOL) sigma and not resolved: see :func:`gaz_cli.engines.step.contacts._search_rows`) are
        counted in the C_OVERLAP_* counters; overlap (2,) keeps the smallest |dr| / sigma seen
        and the time of the first step with one. clock_id: the clock_gettime
        clock (-1: no phase timing); nthreads: threads for the pair forces; patches: about
        how many patches the box is cut into (:mod:`.patches`; the numbers do not depend on
        it). Stops early (status FLUSH) once either buffer holds ``flush_at`` rows.

        ws: the workspace (:func:`workspace`), kept by the caller from call to call so that
        its arrays are allocated once (a call lays the particles out again in them).

        rank, nranks: this process and the number of processes of an MPI run (0, 1 otherwise:
        :mod:`.ranks`); every rank runs the same steps on every particle, the first contact
        pass scanning its own patches only, so the calls of the ranks must end at the same
        steps (the caller gives ``deadline`` = inf and a fixed number of steps).

        Returns (status, steps_done, bf, bi, nb, cf, ci, ncoll, ws).
        """
        if SOURCES < 0:  # never (the digest is >= 0): keys Numba's cache on every module
            return DONE, 0, bf, bi, nb, cf, ci, ncoll, ws
        n, dim = pos.shape
        has_pair = G > 0.0
        has_kick = has_pair or g > 0.0 or gamma > 0.0
        h = 0.5 * dt
        hr = math.expm1(gamma * h) / gamma if gamma > 0.0 else h  # (see _wall_contact)
        tbuf = np.zeros(2, np.int64)
        if nsteps <= 0 or n == 0:
            return DONE, 0, bf, bi, nb, cf, ci, ncoll, ws
        # cells as wide as the reach of a particle at twice the rms speed (nearly all of them);
        # the few faster ones search further
        rmax = 0.0
        vsum2 = 0.0
        for i in range(n):
            rmax = max(rmax, radius[i])
            for d in range(dim):
                vsum2 += vel[i, d] * vel[i, d]
        nc = _cells_per_axis(length, (2.0 * rmax + 4.0 * math.sqrt(vsum2 / n) * dt) * 1.00001, n, dim)
        p1, p2 = _patch_grid(patches, dim, nc)
        npatch = p1 * p2
        cap = n if npatch == 1 else min(n, 2 * (n // npatch) + 64)
        while True:  # the caller's arrays laid out in patches (the workspace kept from call to call)
            ws = _fit(ws, npatch * cap, dim, npatch, n, nc ** dim)
            if _layout_in(pos, vel, acc, mass, radius, age, tlast, length, nc, p1, p2, cap, ws[0]):
                break
            cap *= 2
        L, S, xb, cellof, cstart, cend, W = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5], ws[6]
        pci, pcj, pct, cand_i, cand_j, cand_tau = ws[7]
        _sort_all(L, S, cap, length, nc, p1, p2, cstart, cend, cellof, xb)
        L, S = S, L
        act, done, last, support, hold_row, speed, touched, sendid, dest = W[0], W[1], W[2], W[3], W[4], W[5], W[6], \
            W[7], W[8]
        sendbuf, pmax, pk, pleft, sendcount, byident = W[9], W[10], W[11], W[12], W[13], W[14]
        act[:] = 0  # stamps of the passes (tick starts again at 0)
        done[:] = 0
        ipos = np.empty((n, dim)) if has_pair else np.empty((0, dim))
        iacc = np.empty((n, dim)) if has_pair else np.empty((0, dim))
        tick = 0
        steps = 0
        status = DONE
        for s in range(nsteps):
            if nb >= flush_at or ncoll >= flush_at:
                status = FLUSH
                break
            t_end = t0 + (k0 + s + 1) * dt
            lpos, lvel, lacc, ident, count = L[0], L[1], L[2], L[7], L[8]
            # --- push: half kick, drift (one patch a thread)
            c0 = _now(clock_id, tbuf)
            _push_patches(npatch, cap, count, lpos, lvel, lacc, L[5], has_kick, has_pair, g, gamma, h, dt, True, last,
                          hold_row, support)
            c1 = _now(clock_id, tbuf)
            clocks[T_PUSH] += c1 - c0
            # --- exchange between patches, sort by cell (one patch a thread)
            if not _exchange(L, S, cap, length, nc, p1, p2, sendbuf, sendid, sendcount, dest, cstart, cend, cellof,
                             xb):
                # a patch overflowed: all back in the caller's arrays, laid out again with more room
                _layout_out(L, cap, npatch, pos, vel, acc, age, tlast)
                while True:
                    cap *= 2
                    ws = _fit(ws, npatch * cap, dim, npatch, n, nc ** dim)
                    if _layout_in(pos, vel, acc, mass, radius, age, tlast, length, nc, p1, p2, cap, ws[0]):
                        break
                L, S, xb, cellof, cstart, cend, W = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5], ws[6]
                _sort_all(L, S, cap, length, nc, p1, p2, cstart, cend, cellof, xb)
                act, done, last, support, hold_row, speed, touched, sendid, dest = W[0], W[1], W[2], W[3], W[4], \
                    W[5], W[6], W[7], W[8]
                sendbuf, pmax, pk, pleft, sendcount, byident = W[9], W[10], W[11], W[12], W[13], W[14]
                act[:] = 0
                done[:] = 0
                tick = 0
            L, S = S, L  # sorted by cell: S holds the rows now
            c2 = _now(clock_id, tbuf)
            clocks[T_EXCHANGE] += c2 - c1
            # --- contact passes: walls, planes and pairs, earliest first
            nb0 = nb
            nc0 = ncoll
            (passes, wall_time, tick, bf, bi, nb, cf, ci, ncoll, cand_i, cand_j, cand_tau, pci, pcj,
             pct) = _contact_passes(t_end, dt, L, cap, p1, p2, L[2], planes, length, g, gamma, e, ew, tc, has_pair,
                                    h, hr, max_passes, swept, want_b, want_c, bf, bi, nb, cf, ci, ncoll, counters,
                                    virial, overlap, clock_id, tbuf, 2.0 * rmax, nc, cstart, cend, xb, act, done,
                                    tick, last, support, hold_row, speed, pmax, touched, cand_i, cand_j, cand_tau,
                                    pci, pcj, pct, pk, pleft, byident, rank, nranks)
            ident = L[7]
            for r in range(nb0, nb):  # rows name the particles by the caller's numbers
                bi[r, 0] = ident[bi[r, 0]]
            for r in range(nc0, ncoll):
                ci[r, 0] = ident[ci[r, 0]]
                ci[r, 1] = ident[ci[r, 1]]
            counters[C_PASSES] += passes
            if passes > counters[C_MAX_PASSES]:
                counters[C_MAX_PASSES] = passes
            c3 = _now(clock_id, tbuf)
            clocks[T_COLLISIONS] += c3 - c2 - wall_time
            clocks[T_WALLS] += wall_time
            # --- forces at the new positions (in the caller's order: the sums' order is fixed), second half kick
            lpos, lacc, count = L[0], L[2], L[8]
            if has_pair:
                for p in range(npatch):
                    for r in range(p * cap, p * cap + count[p]):
                        for d in range(dim):
                            ipos[ident[r], d] = lpos[r, d]
                _pair_acc(ipos, mass, G, eps2, iacc, nthreads)
                for p in range(npatch):
                    for r in range(p * cap, p * cap + count[p]):
                        for d in range(dim):
                            lacc[r, d] = iacc[ident[r], d]
                counters[C_PAIR_EVALS] += 1
            if has_kick:
                _push_patches(npatch, cap, count, lpos, L[1], lacc, L[5], has_kick, has_pair, g, gamma, h, dt, False,
                              last, hold_row, support)
            clocks[T_PUSH] += _now(clock_id, tbuf) - c3
            steps += 1
            if clock_id >= 0 and steps < nsteps and _now(clock_id, tbuf) >= deadline:
                status = PAUSE
                break
        _layout_out(L, cap, npatch, pos, vel, acc, age, tlast)
        counters[C_STEPS] += steps
        ws = (ws[0], ws[1], ws[2], ws[3], ws[4], ws[5], ws[6], (pci, pcj, pct, cand_i, cand_j, cand_tau))
        return status, steps, bf, bi, nb, cf, ci, ncoll, ws

    return _run_steps


@njit
def _layout_arrays(rows, dim, npatch):
    """(L, S): the particle arrays of the layout (:mod:`.patches`) and the other half of its double
    buffer, ``rows`` rows each, sharing ``count`` (npatch,)."""
    L = (np.empty((rows, dim)), np.empty((rows, dim)), np.empty((rows, dim)), np.empty(rows), np.empty(rows),
         np.empty(rows), np.empty(rows), np.empty(rows, np.int64), np.zeros(npatch, np.int64))
    S = (np.empty((rows, dim)), np.empty((rows, dim)), np.empty((rows, dim)), np.empty(rows), np.empty(rows),
         np.empty(rows), np.empty(rows), np.empty(rows, np.int64), L[8])
    return L, S


@njit
def workspace(dim, n):
    """An empty workspace for :func:`_run_steps` (its arrays are sized at the first call)."""
    L, S = _layout_arrays(0, dim, 0)
    return (L, S, np.empty((0, dim)), np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0, np.int64),
            _work(0, dim, 0, n), (np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0), np.empty(64, np.int64),
                                  np.empty(64, np.int64), np.empty(64)))


@njit
def _fit(ws, rows, dim, npatch, n, ncells):
    """The workspace ws with room for ``rows`` rows in ``npatch`` patches and ``ncells`` cells:
    its own arrays where they are large enough, new ones otherwise."""
    L, S, xb, cellof, cstart, cend, W, C = ws
    if L[0].shape[0] < rows or L[8].shape[0] != npatch:
        L, S = _layout_arrays(rows, dim, npatch)
        xb = np.empty((rows, dim))
        cellof = np.empty(rows, np.int64)
        W = _work(rows, dim, npatch, n)
    if cstart.shape[0] < ncells:
        cstart = np.zeros(ncells, np.int64)
        cend = np.zeros(ncells, np.int64)
    pci = C[0]
    if pci.shape[0] < 64 * npatch or pci.shape[0] % npatch != 0:
        C = (np.empty(64 * npatch, np.int64), np.empty(64 * npatch, np.int64), np.empty(64 * npatch), C[3], C[4],
             C[5])
    return L, S, xb, cellof, cstart, cend, W, C


@njit
def _work(rows, dim, npatch, n):
    """The scratch arrays of the steps (see :func:`.passes._contact_passes` and :mod:`.patches`)."""
    return (np.zeros(rows, np.int64), np.zeros(rows, np.int64), np.full(rows, -1, np.int64), np.zeros((rows, dim + 1)),
            np.full(rows, -1, np.int64), np.zeros(rows), np.empty(rows, np.int64), np.empty(rows, np.int64),
            np.empty(rows, np.int64), np.empty((rows, 3 * dim + 4)), np.zeros(npatch), np.zeros(npatch, np.int64),
            np.zeros((npatch, 2)), np.zeros((npatch, npatch), np.int64), np.empty(n, np.int64))


_run_steps = build()
