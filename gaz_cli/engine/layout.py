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

INF = math.inf

# --- row layouts ------------------------------------------------------------
# P (N, 8) float64
PV = 3  # velocity columns 3..5 (positions 0..2)
PT = 6  # time stamp of the row
PR = 7  # radius
P_WIDTH = 8
# I (N, 12) int32
CNT, PART, PCNT, CODE, CELL, SLOT, C0, RANK, PART2, PCNT2, SURE = 0, 1, 2, 3, 4, 5, 6, 9, 10, 11, 12
I_WIDTH = 13
# EV (N, 4) float64: predictions (first and second collision, crossing, queue key)
TCOL, TX, KEY, TCOL2 = 0, 1, 2, 3
EV_WIDTH = 4
# Q (N, 4) int32: queue links. QB: bucket slot (>= 0), or HEAP / OVER / NONE
QB, QN, QP, HP = 0, 1, 2, 3
HEAP, OVER, NONE = -1, -2, -3

# IS int64 state vector
(S_CUR, S_HSIZE, S_OHEAD, S_NBK, S_EVENTS, S_COLL, S_BOUNCE, S_CROSS, S_STALE,
 S_NBB, S_NCB, S_BUFCAP, S_RECB, S_RECC, S_NC, S_REBUILD, S_STEPS, S_N, S_SECOND, S_PF,
 S_OVERLAP, S_PAIRS) = range(22)
IS_SIZE = 22
# FS float64 state vector
F_W, F_IW, F_VIRIAL, F_L, F_G, F_E, F_TC, F_H, F_TNOW = range(9)
FS_SIZE = 9

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
    "NB", "NN", "SCR",  # neighbour lists (N, width), their lengths, a rebuild's scratch
    "order", "edges", "ID",  # 1D line order, cell faces along an axis, the caller's numbers
    "bt", "bp", "bw", "bs", "bv",  # bounce buffers: time, particle, wall, speed, |v_perp|
    "ct", "ci", "cj", "cimp",  # collision buffers: time, particles, impulse
])
"""The event loop's arrays under their names (one argument instead of 28; Numba types it as
a named tuple of arrays and reads the fields at compile time). The loop's scalars stay in
the IS / FS vectors."""
