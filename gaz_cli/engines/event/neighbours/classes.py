"""Cells per size class (2D/3D mixtures of very different sizes): a fine grid for the small
particles, a coarse one for the large, each pair found in the grid that fits it.

With one grid, cells are as wide as the largest pair reach, so a 1:100 mixture scans
thousands of small particles at every event (4,414 pair tests per event in 2D, issue 15).
Here (a two-level hierarchical grid, after Ogarko & Luding, Comput. Phys. Commun. 183, 931,
2012, made exact for event-driven dynamics):

* every particle has fine cell coordinates (columns C0.. of I) and crosses the fine cells'
  faces: the fine grid is sized for the small particles (cells at least one small-small
  reach wide, at most CELLS_PER_PARTICLE per small particle, as :mod:`.sizing` does);
* the small particles sit in the fine cell table (``cells``); the large ones in a coarse
  table (``CL``) whose cells are ``f`` fine cells an axis, at least one large-large reach
  wide; for a large particle, I[CELL] and I[SLOT] are its coarse cell and slot;
* small-small pairs are found as with one grid (3^D fine cells, the layer entered at a
  crossing); large-large pairs likewise on the coarse grid (the coarse layer entered when
  a fine crossing changes the coarse cell);
* a small and a large particle are *adjacent* when their fine cells could hold two centres
  within reach: sum over the axes of max(0, |dc| - 1)^2 <= RINT (dc the difference of fine
  coordinates, RINT = floor((reach / a)^2), reach = r_small,max + r_large,max). A pair in
  contact is adjacent, and adjacency changes only when one of the two crosses a fine face.
  So each finds the other (a) at its full scans (after a collision or a bounce: every
  partner adjacent now) and (b) at its crossings (the partners that just became adjacent):
  a small particle looks up the few large ones in the coarse cells around it; a large one
  scans the fine cells of a rounded ball of radius ~reach around it (full), or only the
  ball's front (crossing: one cell per column along the axis crossed). Every pair that can
  meet is thus predicted by one of the two, or one of them looks again before (the
  invariant of :mod:`.loop`);
* each fine cell counts the large particles whose ball holds it (``CV``, moved with their
  crossings): a small particle looks up the coarse cells only where that count is not 0;
* a periodic box of fewer than four coarse cells an axis (narrower than four large reaches)
  is taken as one grid of so few cells is: every gathered particle carries the image its
  cell has in the block scanned (the loop's IMG), for the nearest image need not be it (two
  large spheres 16 apart in the block of a box 30 wide are 14 apart the other way); with two
  coarse cells an axis, the block holds the same cell at two images, each scanned (one
  coarse cell an axis keeps one grid); far faster than one grid of so few cells (measurements:
  docs/explanation/engine_measurements.md#event-engine-size-classes).

A large particle's full scan costs the fine cells of its ball, ~(2 reach / a)^D, instead of
the small particles of 3^D coarse cells; its crossings, ~(2 reach / a)^(D-1) cells; a small
particle's events add a look at the large ones of at most 3^D coarse cells.

:func:`plan` decides (sizing's door for mixtures) and sizes; :func:`fill` fills the two
tables (and the counts, :func:`.ball._cover_fill`). The ball's geometry is in :mod:`.ball`,
the steps of the event loop (a scan's gather, a crossing) in :mod:`.classes_events`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from gaz_cli.engines.event.memory import _alloc
from gaz_cli.engines.event.layout import C0, CELL_FULL, DONE, GATHER_SLOTS, PR
from gaz_cli.engines.event.neighbours.ball import _cover_fill, ball_cells
from gaz_cli.engines.event.neighbours.cells import _coord, _put, wider
from gaz_cli.numba_config import njit

MIN_RATIO = 8.0
"""Size classes from this ratio of the largest radius to the largest small radius on
(a particle is small when its radius is at most rmax / MIN_RATIO). Below it the coarse grid
holds few small particles a cell and one grid costs less than two (the 1:5 mixture of the
engine's tests keeps one grid)."""

Plan = namedtuple("Plan", ["nc", "ncl", "f", "rint", "bcl", "rcut", "n_small", "n_large"])
"""Two size classes: fine cells an axis nc, coarse cells an axis ncl of f fine cells each,
the adjacency bound RINT and the ball's half-width bcl = 1 + isqrt(RINT) (fine cells), the
largest small radius rcut (m), the particles of each class."""


def plan(radii: np.ndarray, D: int, L: float, periodic: bool, pairs: bool, use_nl: bool,
         reach, cells_per_axis) -> Plan | None:
    """The two size classes of a scene, or None when one grid fits it.

    radii (N,) m; ``reach(r)`` the pair reach of two particles of radius r
    (:func:`.interactions.pair_reach`); ``cells_per_axis`` sizing's rule for one grid. None
    in 1D, with neighbour lists, without pairs, when the radii span less than MIN_RATIO,
    or when a periodic box is too small for the fine ball or for two coarse cells.
    """
    if not pairs or D == 1 or use_nl:
        return None
    radii = np.asarray(radii, dtype=np.float64)
    rmax = float(radii.max())
    small = radii <= rmax / MIN_RATIO
    n_small = int(small.sum())
    if n_small == 0 or n_small == radii.size:
        return None
    rs = float(radii[small].max())
    if rs <= 0.0:
        return None
    reach_ss, reach_ll = reach(rs), reach(rmax)
    reach_sl = 0.5 * (reach_ss + reach_ll)
    nc = cells_per_axis(D, n_small, L, True, periodic, reach_ss, 0.0, False)

    def bounds(nc):
        a = L / nc
        rint = int(math.floor((reach_sl / a * (1.0 + 1e-9)) ** 2))
        bcl = 1 + math.isqrt(rint)
        f = max(int(math.ceil(reach_ll / a * (1.0 + 1e-9))), bcl)
        return rint, bcl, f

    rint, bcl, f = bounds(nc)
    if periodic:
        ncl = nc // f
        if ncl < 2:  # (one: untested, keeps one grid)
            return None
        nc = ncl * f  # whole coarse cells around the box (wider fine cells: f, B hold)
        rint, bcl, _ = bounds(nc)
        if nc < 2 * bcl + 3:
            return None
    else:
        ncl = -(-nc // f)
    return Plan(nc, ncl, f, rint, bcl, rs, n_small, radii.size - n_small)


# --- kernels ----------------------------------------------------------------
@njit
def _assign_classes(P, I, cells, CL, nc, a, f, ncl, rcut, D):
    """Every particle's fine coordinates (cells of side a, nc an axis); the small ones into
    their fine cell, the large ones into their coarse cell (f fine cells an axis, ncl an
    axis). Status CELL_FULL if a cell overflows."""
    n = P.shape[0]
    cap = cells.shape[1] - 1
    capl = CL.shape[1] - 1
    cells[:, 0] = 0
    CL[:, 0] = 0
    for k in range(n):
        cell = 0
        coarse = 0
        for d in range(D):
            c = _coord(P[k, d], a, nc)
            I[k, C0 + d] = c
            cell = cell * nc + c
            coarse = coarse * ncl + c // f
        if not (_put(I, cells, k, cell, cap) if P[k, PR] <= rcut else _put(I, CL, k, coarse, capl)):
            return CELL_FULL
    return DONE


# --- the Python side: tables and buffers -------------------------------------
def fill(rows, P, I) -> None:
    """The fine and coarse tables of ``rows`` (:class:`.rows.Rows` with ``mix`` a
    :class:`Plan`) for its rows P, I: rows.cells, rows.CL, rows.cap, grown until all fit."""
    from gaz_cli.engines.event import sizing

    mx = rows.mix
    D, nc = rows.D, mx.nc
    small = P[:, PR] <= mx.rcut
    c = rows._cell_coords(P[:, :D])
    key = c[:, 0]
    keyl = c[:, 0] // mx.f
    for d in range(1, D):
        key = key * nc + c[:, d]
        keyl = keyl * mx.ncl + c[:, d] // mx.f
    full_s = int(np.bincount(key[small], minlength=1).max()) if small.any() else 0
    full_l = int(np.bincount(keyl[~small], minlength=1).max()) if (~small).any() else 0
    cap = max(rows.cap, sizing._cell_capacity(mx.n_small / nc ** D), full_s)
    capl = max(getattr(rows, "capl", 0), sizing._cell_capacity(mx.n_large / mx.ncl ** D),
               full_l)
    while True:
        rows.cells = _alloc((nc ** D, sizing._cell_width(cap)), np.int32)
        rows.CL = _alloc((mx.ncl ** D, sizing._cell_width(capl)), np.int32)
        if _assign_classes(P, I, rows.cells, rows.CL, nc, rows.L / nc, mx.f, mx.ncl, mx.rcut,
                           D) == DONE:
            break
        cap *= 2
        capl *= 2
    rows.cap = rows.cells.shape[1] - 1
    rows.capl = rows.CL.shape[1] - 1
    rows.CV = _alloc(nc ** D, np.int32)
    _cover_fill(P, I, rows.CV, nc, mx.bcl, mx.rint, mx.rcut, D, rows.periodic)


def grow(rows) -> None:
    """A full cell: the coarse table with twice the room (rows._grow_cells grows the fine one)."""
    rows.CL = wider(rows.CL)
    rows.capl = rows.CL.shape[1] - 1


def gather_room(rows) -> int:
    """Room in GB for one scan: a small particle's 3^D fine cells and 3^D coarse ones, or a
    large one's 3^D coarse cells and its ball; plus the slots a gather copies beyond."""
    mx = rows.mix
    caps = rows.cells.shape[1] - 1
    capl = rows.CL.shape[1] - 1
    near = 3 ** rows.D
    return (max(near * (caps + capl), near * capl + ball_cells(rows.D, mx.rint) * caps)
            + GATHER_SLOTS + 1)
