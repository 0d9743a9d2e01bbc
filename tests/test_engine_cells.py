"""gaz_cli.engines.event.neighbours.cells: cell assignment and moves keep the cell table exact, and
a scan (gather, then pair times) finds the earliest collision the exam's ``tc`` finds among
the particles of the 3^D cells around."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import KERNEL_RTOL

from gaz_cli.engines import reference
from gaz_cli.engines.event.layout import (C0, CELL, DONE, GATHER_SLOTS, I_WIDTH, INF, NEW, P_WIDTH,
                                          PR, PT, PV, SLOT)
from gaz_cli.engines.event.neighbours.cells import (_assign_cells, _cell_of, _gather_cells, _move,
                                                    _scan_gathered)

L = 10.0


def _gas(rng, n, dim, nc, r=0.3):
    P = np.zeros((n, P_WIDTH))
    P[:, :dim] = rng.uniform(0.0, L, size=(n, dim))
    P[:, PV:PV + dim] = rng.normal(size=(n, dim))
    P[:, PR] = r
    I = np.zeros((n, I_WIDTH), dtype=np.int32)
    cells = np.zeros((nc ** dim, 4 * n + GATHER_SLOTS + 1), dtype=np.int32)
    assert _assign_cells(P, I, cells, nc, L / nc, dim) == DONE
    return P, I, cells


def _check_table(P, I, cells, nc, dim):
    """Every particle is in the cell of its coordinates, once, at its slot."""
    n = P.shape[0]
    seen = np.zeros(n, dtype=int)
    for c in range(cells.shape[0]):
        for s in range(1, cells[c, 0] + 1):
            k = cells[c, s]
            seen[k] += 1
            assert I[k, CELL] == c and I[k, SLOT] == s
            assert c == np.ravel_multi_index(tuple(I[k, C0:C0 + dim]), (nc,) * dim)
    assert np.all(seen == 1)


@pytest.mark.parametrize("dim", [2, 3])
def test_assign_cell_of_and_move_keep_the_table_exact(dim):
    """Cells of side a = L / nc hold the particles whose floor(x / a) is theirs (_cell_of
    agrees); moving particles between cells at random keeps every slot right."""
    rng = np.random.default_rng(dim)
    nc, n = 5, 200
    P, I, cells = _gas(rng, n, dim, nc)
    _check_table(P, I, cells, nc, dim)
    for k in range(n):
        c = np.minimum(np.floor(P[k, :dim] / (L / nc)).astype(int), nc - 1)
        assert np.array_equal(I[k, C0:C0 + dim], c)
        nn0, nn1, nn2, cell = _cell_of(P, k, nc / L, nc, dim)
        assert cell == I[k, CELL] and (nn0, nn1) == tuple(c[:2])
    for _ in range(500):
        k = int(rng.integers(n))
        c = rng.integers(nc, size=dim)
        _move(cells, I, k, int(np.ravel_multi_index(tuple(c), (nc,) * dim)))
        I[k, C0:C0 + dim] = c
    _check_table(P, I, cells, nc, dim)


def _tc(P, k, m, t, dim, shift):
    """The exam's tc for rows k and m (m's image shifted by ``shift``), both taken to t."""
    pk = [P[k, :dim] + P[k, PV:PV + dim] * (t - P[k, PT]), P[k, PV:PV + dim].copy()]
    pm = [P[m, :dim] + P[m, PV:PV + dim] * (t - P[m, PT]) + shift, P[m, PV:PV + dim].copy()]
    dt = reference.tc(pk, pm, 0.5 * (P[k, PR] + P[m, PR]))
    return INF if dt is None else t + dt


@pytest.mark.parametrize("dim, periodic", [(2, False), (3, False), (2, True), (3, True)])
def test_a_scan_finds_the_exams_two_earliest_collisions_around(dim, periodic):
    """For 40 particles, the scan of its 3^D cells (rows stamped at various times, taken to
    t) (the scanning one at t, as in the loop) gives the two earliest of tc over every particle
    of those cells (nearest image when
    periodic), within KERNEL_RTOL, with the right partners."""
    rng = np.random.default_rng(30 + dim + 2 * periodic)
    nc, n, t = 6, 150 if dim == 2 else 400, 1.0
    P, I, cells = _gas(rng, n, dim, nc)
    P[:, PT] = rng.uniform(0.8, 1.0, size=n)  # stamps before t; positions are at the stamps
    GB = np.zeros(2 * 3 ** dim * cells.shape[1], dtype=np.int32)
    GS = np.zeros_like(GB)
    stamped = P.copy()
    for k in rng.choice(n, 40, replace=False):
        P[:] = stamped
        P[k, :dim] += P[k, PV:PV + dim] * (t - P[k, PT])  # the scanning particle is at t
        P[k, PT] = t
        c = I[k, C0:C0 + 3] if dim == 3 else np.append(I[k, C0:C0 + 2], 0)
        ng = _gather_cells(P, I, cells, GB, GS, 0, c[0], c[1], c[2], -1, 1, -1, 1, -1, 1, nc,
                           dim, periodic, False, False)
        best, bj, src1, best2, bj2, src2 = _scan_gathered(P, GB, GS, 0, ng, k, t, L, 0.0, INF,
                                                          -1, INF, -1, (1.0, 0.0), dim,
                                                          periodic, False, False)
        want = []
        for m in range(n):
            off = I[m, C0:C0 + dim] - I[k, C0:C0 + dim]
            if periodic:
                off = (off + 1) % nc - 1
            if m == k or np.any(np.abs(off) > 1):
                continue
            shift = 0.0
            if periodic:
                sep = P[m, :dim] - P[k, :dim]
                shift = -L * np.round(sep / L)
            want.append((_tc(P, k, m, t, dim, shift), m))
        want.sort()
        assert ng == len(want) + 1  # k itself is gathered too
        for (tb, jb, src), (tw, jw) in zip(((best, bj, src1), (best2, bj2, src2)), want[:2]):
            if tw == INF:
                assert tb == INF
                continue
            assert tb == pytest.approx(tw, rel=KERNEL_RTOL) and src == NEW
            assert jb == jw or math.isclose(tb, tw, rel_tol=KERNEL_RTOL)
