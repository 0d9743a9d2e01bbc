"""The engine's data layout: row columns, state-vector slots and codes every kernel shares.

Each particle's data sits in one row of each table: ``P`` float64 (N, 8): x0 x1 x2
v0 v1 v2 t_stamp radius; ``I`` int32 (N, 13): counter, partner, partner's counter,
crossing code, cell, slot in its cell, cell coordinates c0 c1 c2, rank in 1D, second
partner and its counter, whether that second is sure; ``EV`` float64 (N, 4): the
predictions; ``Q`` int32 (N, 4): the calendar links. ``cells`` int32 (cells, width):
the count in column 0, then the particles (width at least GATHER_SLOTS + 1). The
loop's scalars live in two small vectors, ``IS`` (int64) and ``FS`` (float64), so that
a call resumes exactly where the last one stopped. Plain module constants: Numba
freezes them into the kernels.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

INF = math.inf

WIDE_LANES = 16
"""The float32 pass over a wide cell's block (:mod:`.neighbours.wide`) covers its count
rounded up to this many slots. LLVM's vector loop of the pass steps 16 slots at a time (8
lanes, unrolled twice) and leaves the rest to a scalar loop: rounded to 8, a block of 8
particles or fewer ran all scalar, and a dilute scene slowed sharply as its cells thinned;
groups of exactly 8 slots, a loop each, ran slower still (measurements:
docs/explanation/engine_measurements.md#event-engine-layout)."""


# --- row layouts ------------------------------------------------------------
# P (N, 8) float64
PV = 3  # velocity columns 3..5 (positions 0..2)
PT = 6  # time stamp of the row
PR = 7  # radius
P_WIDTH = 8
# I (N, 12) int32
CNT, PART, PCNT, CODE, CELL, SLOT, C0, RANK, PART2, PCNT2, SURE = 0, 1, 2, 3, 4, 5, 6, 9, 10, 11, 12
I_WIDTH = 13  # 16, a row a cache line: no faster (3D N = 10^4, 0.05, cells: 0.99-1.07; 2026-11-23)
# EV (N, 4) float64: predictions (first and second collision, crossing, queue key)
TCOL, TX, KEY, TCOL2 = 0, 1, 2, 3
EV_WIDTH = 4
# Q (N, 4) int32: queue links. QB: bucket slot (>= 0), or HEAP / OVER / NONE
QB, QN, QP, HP = 0, 1, 2, 3
HEAP, OVER, NONE = -1, -2, -3

# the loop's scalars: one record (np.zeros(1, STATE)), read at the loop's entry, written back
# at its exit, so that a call resumes exactly where the last one stopped
STATE = np.dtype([
    # calendar: current bucket, heap size, overflow list's head, buckets
    ("cur", np.int64), ("hsize", np.int64), ("ohead", np.int64), ("nbk", np.int64),
    # counts: queue events, collisions, wall bounces, cell crossings, stale predictions,
    # list rebuilds, calendar steps, second predictions used, overlapping collisions, pair times,
    # particles the dilute scans' rejection pass went through
    ("events", np.int64), ("coll", np.int64), ("bounce", np.int64), ("cross", np.int64),
    ("stale", np.int64), ("rebuild", np.int64), ("steps", np.int64), ("second", np.int64),
    ("overlap", np.int64), ("pairs", np.int64), ("scanned", np.int64),
    # record buffers: rows held (bounces, collisions), room, whether each is recorded
    ("nbb", np.int64), ("ncb", np.int64), ("bufcap", np.int64), ("recb", np.int64),
    ("recc", np.int64),
    # cells an axis, particles, whether to prefetch (large systems)
    ("nc", np.int64), ("n", np.int64), ("pf", np.int64),
    # bucket width and its inverse; collision virial; box, gravity, neighbour-list skin h;
    # the time reached (the interaction's parameters: interactions.pair_params)
    ("w", np.float64), ("iw", np.float64), ("virial", np.float64), ("L", np.float64),
    ("g", np.float64), ("h", np.float64), ("tnow", np.float64),
    # size classes (neighbours/classes.py): coarse cells an axis, fine cells a coarse one,
    # the adjacency bound and the ball's half-width (fine cells), the largest small radius
    ("ncl", np.int64), ("fcl", np.int64), ("rint", np.int64), ("bcl", np.int64),
    ("rcut", np.float64),
])
"""The loop's state and settings under their names (a numpy record: named fields of both
types in one argument, no compiled accessor; the loop keeps them in registers)."""

OVERLAP_TOL = 1.0 - 1e-9
"""A colliding pair closer than sqrt(OVERLAP_TOL) (R_i + R_j) counts as found overlapping."""

KEPT1, KEPT2, NEW = 1, 2, 0
"""Where a cell scan's result comes from: the first or second prediction given in, or the scan."""

GATHER_SLOTS = 4
"""Slots copied from every cell, whatever its count, when a scan gathers particles
(the count is rarely above it; the rest are copied one by one)."""

NLCODE = 1 << 10
"""Crossing code of a neighbour-list rebuild (leaving the sphere of radius h)."""

# kernel status codes
DONE, BUFFER_FULL, CELL_FULL, PAUSE, NL_FULL = 0, 1, 2, 3, 4


Tables = namedtuple("Tables", [
    "P", "M", "TL", "XN", "I", "EV", "Q",  # particle rows: (N, 8), masses, last collision
    #   times (TL, inelastic runs), list centres (N, 3), (N, 13), predictions (N, 4),
    #   calendar links (N, 4)
    "HK", "HI", "BH",  # calendar: heap keys and particles, bucket heads
    "cells", "GB", "GS",  # cell table, a scan's gathered particles and their image shifts
    "XS", "XC",  # dilute scans: the rows as float32 structure of arrays, its units
    #   (neighbours.dilute)
    "XB",  # wide cells: each cell's rows as a float32 block (neighbours.wide)
    "NB", "NN", "SCR",  # neighbour lists (N, width), their lengths, a rebuild's scratch
    "order", "edges", "ID",  # 1D line order, cell faces along an axis, the caller's numbers
    "bt", "bp", "bw", "bs", "bv",  # bounce buffers: time, particle, wall, speed, |v_perp|
    "ct", "ci", "cj", "cimp",  # collision buffers: time, particles, impulse
    "CL", "CV",  # size classes: the coarse cell table of the large particles; how many large
    #   particles have each fine cell in their ball
    "IM",  # periodic box: each row's box crossings per axis (N, 3) int64, counted where the
    #   loop wraps it (boundaries._wrap, _count_wrap); rows.Rows folds them into images
])
"""The event loop's arrays under their names (one argument instead of 30; Numba types it as
a named tuple of arrays and reads the fields at compile time). The loop's scalars are in
one ``STATE`` record."""
