"""The step loop of the time-stepped engine (seeds 002 and 003), and the map of its kernels.

Private, plain Numba kernels on contiguous arrays: they never raise, they return
counts and (possibly reallocated) buffers. One module per seam of the step:

* :mod:`.push`: kick and drift, the pair forces;
* :mod:`.wall_contact`: one particle and one flat wall (contact time, bounce, hops, rest);
* :mod:`.walls`: the box walls and extra planes (first wall met, bounce and rows, safety net);
* :mod:`.resting`: particles held at rest by a wall or by a held particle;
* :mod:`.cells`, :mod:`.contacts`: the cell list, the pairs in contact, the collision rule;
* :mod:`.passes`: the contact passes of one step;
* :mod:`.codes`: status codes, counters, clocks, tolerances;
* this module: :func:`_advance`, a block of steps.

:func:`_advance` runs a block of steps; each step is, in order:

1. half kick  ``v <- v e^{-gamma h} + a (1 - e^{-gamma h}) / gamma`` over
   h = dt/2, the exact solution for a constant acceleration a (gravity plus
   pair attraction at the current positions) and linear friction; ``v += a h``
   without friction; skipped entirely when the scene has no force;
2. drift ``x += v dt`` (straight lines, so going back along them is exact);
3. contact passes. Each pass lists the contacts of the *active* particles
   (all of them in the first pass): the first crossing of a box wall or an
   extra plane (one it ends beyond, or one a path bending away from it went
   beyond and came back from: :func:`_earliest_wall`), and pairs in contact
   found with a cell list (never O(N^2)). They
   are sorted by contact time, earliest first, and applied in that order, a
   particle taking part in at most one contact per pass: a pair is taken back
   to its contact time along its straight segment, its velocities are changed
   along the line of centres (any masses, restitution e, TC model; the
   impulse of the velocities at the contact time, see :func:`_collide`), and
   it is moved forward to the end of the step; a wall contact does the same
   with the wall (restitution, exact under uniform gravity, the pair
   attraction taken constant over the step, see :func:`_wall_contact`); a particle that comes
   to rest on a floor is *held* by it until the step's end (:func:`_hold`), a particle resting
   on a held one is held by it in turn, its weight passed on to the floor
   (:func:`_rest_on`), and a collision that takes one off releases it there: it flies freely
   from the contact (:func:`_release`). The particles that moved are the next pass's
   active set; passes repeat until a pass finds nothing or the pass limit
   is hit (then every particle still beyond a box wall bounces until it is
   inside, and off the planes once: :func:`_walls_sweep`);
4. pair accelerations at the new positions (when pair gravity is on);
5. half kick.

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
from gaz_cli.engines.step.cells import _cell_list
from gaz_cli.engines.step.codes import (C_MAX_PASSES, C_PAIR_EVALS, C_PASSES, C_STEPS, DONE, FLUSH, PAUSE,
                                       T_COLLISIONS, T_PUSH, T_WALLS, _now)
from gaz_cli.engines.step.passes import _contact_passes
from gaz_cli.engines.step.push import _drift, _kick, _pair_acc
from gaz_cli.numba_config import njit


def sources_digest(root: pathlib.Path | None = None) -> int:
    """A number that changes with the source of any module the step loop's kernels may hold
    (:func:`gaz_cli.engines.event.intrinsics.kernel_sources` from this module: its module-level
    imports, followed), for the ``gaz_cli`` package under ``root`` (default: this one's).

    Numba's disk cache keys a function on its own file only: an edit of walls.py would leave
    a stale :func:`_advance` (which holds the walls' code) in the cache. :func:`build` gives
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
    """The step loop :func:`_advance`, keyed in Numba's cache on :func:`sources_digest`."""
    SOURCES = sources_digest()

    @njit
    def _advance(nsteps, t0, k0, dt, pos, vel, acc, mass, radius, age, tlast, planes,
                 length, g, gamma, G, eps2, e, ew, tc, max_passes, swept,
                 want_b, want_c, bf, bi, nb, cf, ci, ncoll, flush_at,
                 counters, clocks, virial, overlap, clock_id, nthreads, deadline):
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
        than (1 - OVERLAP_TOL) sigma and not resolved: see :func:`_detect`) are counted in the
        C_OVERLAP_* counters; overlap (2,) keeps the smallest |dr| / sigma seen and the time of
        the first step with one. clock_id: the clock_gettime
        clock (-1: no phase timing); nthreads: threads for the pair forces. Stops early (status FLUSH) once
        either buffer holds ``flush_at`` rows.

        Returns (status, steps_done, bf, bi, nb, cf, ci, ncoll).
        """
        if SOURCES < 0:  # never (the digest is >= 0): keys Numba's cache on every module
            return DONE, 0, bf, bi, nb, cf, ci, ncoll
        n, dim = pos.shape
        has_pair = G > 0.0
        has_kick = has_pair or g > 0.0 or gamma > 0.0
        h = 0.5 * dt
        hr = math.expm1(gamma * h) / gamma if gamma > 0.0 else h  # (see _wall_contact)
        tbuf = np.zeros(2, np.int64)
        rmax, nc_max, start, cell_of, order = _cell_list(radius, length, dim)
        active = np.zeros(n, np.uint8)
        last = np.full(n, -1, np.int64)  # the wall each particle's path last bent at in this step (-1: none)
        support = np.zeros((n, dim + 1))  # a wall's push on the particles it holds at rest in this step, m/s^2, and
        # its restitution (_hold)
        hold_row = np.full(n, -1, np.int64)  # the bounce row of that rest (-1: none)
        done = np.zeros(n, np.uint8)
        speed = np.zeros(n)
        cand_i = np.empty(64, np.int64)
        cand_j = np.empty(64, np.int64)
        cand_tau = np.empty(64, np.float64)
        left = np.zeros(2)
        steps = 0
        status = DONE
        for s in range(nsteps):
            if nb >= flush_at or ncoll >= flush_at:
                status = FLUSH
                break
            t_end = t0 + (k0 + s + 1) * dt
            # --- push: half kick, drift
            c0 = _now(clock_id, tbuf)
            if has_kick:
                _kick(vel, acc, has_pair, g, gamma, h)
            _drift(pos, vel, dt, age)
            c1 = _now(clock_id, tbuf)
            clocks[T_PUSH] += c1 - c0
            # --- contact passes: walls, planes and pairs, earliest first
            for i in range(n):
                active[i] = 1
                last[i] = -1
                hold_row[i] = -1
                for d in range(dim):
                    support[i, d] = 0.0
            passes, wall_time, bf, bi, nb, cf, ci, ncoll, cand_i, cand_j, cand_tau = _contact_passes(
                t_end, dt, pos, vel, acc, mass, radius, age, tlast, planes, length, g, gamma, e, ew, tc,
                has_pair, h, hr, max_passes, swept, want_b, want_c, bf, bi, nb, cf, ci, ncoll,
                counters, virial, overlap, clock_id, tbuf, rmax, nc_max, start, cell_of, order, active, last,
                support, hold_row, done, speed, cand_i, cand_j, cand_tau, left)
            counters[C_PASSES] += passes
            if passes > counters[C_MAX_PASSES]:
                counters[C_MAX_PASSES] = passes
            c3 = _now(clock_id, tbuf)
            clocks[T_COLLISIONS] += c3 - c1 - wall_time
            clocks[T_WALLS] += wall_time
            # --- forces at the new positions, second half kick
            if has_pair:
                _pair_acc(pos, mass, G, eps2, acc, nthreads)
                counters[C_PAIR_EVALS] += 1
            if has_kick:
                _kick(vel, acc, has_pair, g, gamma, h)
            clocks[T_PUSH] += _now(clock_id, tbuf) - c3
            steps += 1
            if clock_id >= 0 and steps < nsteps and _now(clock_id, tbuf) >= deadline:
                status = PAUSE
                break
        counters[C_STEPS] += steps
        return status, steps, bf, bi, nb, cf, ci, ncoll

    return _advance


_advance = build()
