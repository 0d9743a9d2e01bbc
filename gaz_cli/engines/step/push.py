"""Kick and drift: what moves the particles between contacts (seed 002's ``push``).

Uniform gravity, linear friction and the Plummer-softened pair attraction (an O(N^2) sum,
on threads from PARALLEL_PAIR_MIN bodies on); the half kick is exact for a constant
acceleration with friction, the drift a straight line.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from gaz_cli.numba_config import njit, pnjit


PARALLEL_PAIR_MIN = 1024
"""Pair-force sums use the parallel kernel from this many bodies on: a sum then takes milliseconds,
so starting the threads costs little; with one thread the parallel kernel runs as fast as the serial
one, with two idle cores twice as fast (on a machine whose cores are busy, threads only add waiting)."""


@njit
def _add_pair(pos, mass, G, eps2, i, j, acc):
    """The Plummer-softened pull between bodies i and j added to their rows of acc (N, D)."""
    r2 = eps2
    for d in range(pos.shape[1]):
        dx = pos[j, d] - pos[i, d]
        r2 += dx * dx
    if r2 <= 0.0:
        return
    inv = G / (r2 * math.sqrt(r2))
    for d in range(pos.shape[1]):
        dx = pos[j, d] - pos[i, d]
        acc[i, d] += mass[j] * inv * dx
        acc[j, d] -= mass[i] * inv * dx


@njit
def _pair_acc_serial(pos, mass, G, eps2, acc):
    """Plummer-softened Newtonian accelerations, O(N^2/2), into acc (N, D) m/s^2."""
    n = pos.shape[0]
    acc[:] = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            _add_pair(pos, mass, G, eps2, i, j, acc)


@pnjit
def _pair_acc_parallel(pos, mass, G, eps2, acc, nthreads):
    """As :func:`_pair_acc_serial`, the N^2/2 pairs shared among ``nthreads`` threads.

    Thread t takes the rows i = t, t + nthreads, ... (balanced over the
    triangle j > i) and accumulates into its own (N, D) buffer; the buffers
    are summed at the end (no races, no atomics).
    """
    n, dim = pos.shape
    buf = np.zeros((nthreads, n, dim))
    for t in prange(nthreads):
        mine = buf[t]
        for i in range(t, n, nthreads):
            for j in range(i + 1, n):
                _add_pair(pos, mass, G, eps2, i, j, mine)
    for i in prange(n):
        for d in range(dim):
            s = 0.0
            for t in range(nthreads):
                s += buf[t, i, d]
            acc[i, d] = s


@njit
def _pair_acc(pos, mass, G, eps2, acc, nthreads):
    """Pair accelerations, serial for few bodies (or one thread), parallel over nthreads for many."""
    if pos.shape[0] >= PARALLEL_PAIR_MIN and nthreads > 1:
        _pair_acc_parallel(pos, mass, G, eps2, acc, nthreads)
    else:
        _pair_acc_serial(pos, mass, G, eps2, acc)


@njit
def _pair_potential(pos, mass, G, eps2):
    """Total pair potential energy -sum_{i<j} G m_i m_j / sqrt(r^2 + eps^2), J."""
    n, dim = pos.shape
    u = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            r2 = eps2
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 > 0.0:
                u -= G * mass[i] * mass[j] / math.sqrt(r2)
    return u


@njit
def _kick(vel, acc, has_pair, g, gamma, h):
    """Half kick over h s: exact for constant acceleration (acc + gravity) with linear friction.

    Separate loops per force set: gravity alone touches only the last column.
    """
    n, dim = vel.shape
    if gamma > 0.0:
        f = math.exp(-gamma * h)
        c = -math.expm1(-gamma * h) / gamma
        for i in range(n):
            for d in range(dim):
                vel[i, d] *= f
    else:
        c = h
    if g > 0.0:
        dv = g * c
        for i in range(n):
            vel[i, dim - 1] -= dv
    if has_pair:
        for i in range(n):
            for d in range(dim):
                vel[i, d] += acc[i, d] * c


@njit
def _drift(pos, vel, dt, age):
    """Straight flight over dt s; every particle's age (time since its path bent) becomes dt."""
    n, dim = pos.shape
    for i in range(n):
        for d in range(dim):
            pos[i, d] += vel[i, d] * dt
        age[i] = dt


@pnjit
def _push_patches(npatch, cap, count, pos, vel, acc, age, has_kick, has_pair, g, gamma, h, dt, drift, last,
                  hold_row, support):
    """Half kick (when ``has_kick``) and, with ``drift``, the drift and the reset of the step's
    wall bookkeeping (last = -1, hold_row = -1, support[:, :D] = 0), one patch a thread (patch p's
    particles are the rows p cap to p cap + count[p])."""
    if npatch == 1:
        _push_patch(0, cap, count, pos, vel, acc, age, has_kick, has_pair, g, gamma, h, dt, drift, last, hold_row,
                    support)
        return
    for p in prange(npatch):
        _push_patch(p, cap, count, pos, vel, acc, age, has_kick, has_pair, g, gamma, h, dt, drift, last, hold_row,
                    support)


@njit
def _push_patch(p, cap, count, pos, vel, acc, age, has_kick, has_pair, g, gamma, h, dt, drift, last, hold_row,
                support):
    """Patch p's part of :func:`_push_patches`."""
    lo = p * cap
    hi = lo + count[p]
    if has_kick:
        _kick(vel[lo:hi], acc[lo:hi], has_pair, g, gamma, h)
    if drift:
        _drift(pos[lo:hi], vel[lo:hi], dt, age[lo:hi])
        for i in range(lo, hi):
            last[i] = -1
            hold_row[i] = -1
            for d in range(support.shape[1] - 1):
                support[i, d] = 0.0
