"""gaz_cli.engine.neighbours.lists and .line: a neighbour list holds exactly the particles
within R_k + R_m + 2h of its centre, its scan finds the exam's ``tc`` earliest among them,
and a rod's scan the earliest of its two neighbours on the line."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import KERNEL_RTOL

from gaz_cli import reference
from gaz_cli.engine.layout import DONE, GATHER_SLOTS, I_WIDTH, INF, P_WIDTH, PR, PT, PV
from gaz_cli.engine.neighbours.cells import _assign_cells
from gaz_cli.engine.neighbours.line import _scan_1d
from gaz_cli.engine.neighbours.lists import _build_nl, _nl_exit, _scan_nl

L = 10.0


def _tc(P, k, m, t, dim, shift=0.0):
    pk = [P[k, :dim] + P[k, PV:PV + dim] * (t - P[k, PT]), P[k, PV:PV + dim].copy()]
    pm = [P[m, :dim] + P[m, PV:PV + dim] * (t - P[m, PT]) + shift, P[m, PV:PV + dim].copy()]
    dt = reference.tc(pk, pm, 0.5 * (P[k, PR] + P[m, PR]))
    return INF if dt is None else t + dt


@pytest.mark.parametrize("dim, periodic", [(2, False), (3, True)])
def test_lists_hold_the_neighbours_within_reach_and_their_scan_is_tc(dim, periodic):
    """Lists built around each centre hold exactly the particles within R_k + R_m + 2h (the
    nearest image when periodic); a list's scan gives the earliest tc among them; a
    particle leaves the sphere of radius h around its centre at the time _nl_exit says."""
    rng = np.random.default_rng(40 + dim)
    n, r, h = 300, 0.25, 0.15
    nc = int(L // (2 * r + 2 * h))
    P = np.zeros((n, P_WIDTH))
    P[:, :dim] = rng.uniform(0.0, L, size=(n, dim))
    P[:, PV:PV + dim] = rng.normal(size=(n, dim))
    P[:, PR] = r
    I = np.zeros((n, I_WIDTH), dtype=np.int32)
    cells = np.zeros((nc ** dim, n + GATHER_SLOTS + 1), dtype=np.int32)
    assert _assign_cells(P, I, cells, nc, L / nc, dim) == DONE
    XN = np.zeros((n, 3))
    XN[:, :dim] = P[:, :dim]
    NB = np.zeros((n, 64), dtype=np.int32)
    NN = np.zeros(n, dtype=np.int32)
    SCR = np.zeros(64, dtype=np.int32)
    assert _build_nl(P, XN, I, cells, NB, NN, SCR, nc, L, h, dim, periodic) == DONE
    for k in range(n):
        sep = P[:, :dim] - P[k, :dim]
        if periodic:
            sep -= L * np.round(sep / L)
        near = np.flatnonzero(np.linalg.norm(sep, axis=1) < 2 * r + 2 * h)
        assert sorted(NB[k, :NN[k]]) == sorted(set(near) - {k})
    for k in range(n):
        best, bj, bc = _scan_nl(P, I, NB, NN, k, 0.0, L, 0.5 * L, 0.0, INF, -1, nc, dim,
                                periodic, False, False)
        want = INF
        for m in NB[k, :NN[k]]:
            sep = P[m, :dim] - P[k, :dim]
            shift = -L * np.round(sep / L) if periodic else 0.0
            want = min(want, _tc(P, k, m, 0.0, dim, shift))
        assert best == pytest.approx(want, rel=KERNEL_RTOL) if want < INF else best == INF
        te = _nl_exit(P, XN, k, h, 0.0, dim, False)
        assert np.linalg.norm(P[k, PV:PV + dim] * te) == pytest.approx(h, rel=KERNEL_RTOL)


@pytest.mark.parametrize("periodic", [False, True])
def test_a_rod_scans_its_two_neighbours_on_the_line(periodic):
    """Rods in line order: the scan's earliest collision is the earliest tc with the previous
    and next rods (the first and last are neighbours across a periodic box)."""
    rng = np.random.default_rng(50 + periodic)
    n = 40
    x = np.sort(rng.uniform(0.0, L, size=n))
    P = np.zeros((n, P_WIDTH))
    P[:, 0], P[:, PV], P[:, PR] = x, rng.normal(size=n), 0.01
    order = np.arange(n, dtype=np.int64)
    for k in range(n):
        best, bj = _scan_1d(P, order, k, k, n, 0.0, L, 0.0, periodic, False)
        want = []
        for side in (-1, 1):
            m = k + side
            shift = 0.0
            if m < 0 or m >= n:
                if not periodic:
                    continue
                shift = L * side
                m %= n
            want.append((_tc(P, k, m, 0.0, 1, shift), m))
        tw, jw = min(want)
        if tw == INF:
            assert best == INF
        else:
            assert best == pytest.approx(tw, rel=KERNEL_RTOL) and bj == jw
