"""gaz_cli.engines.event.neighbours.lists and .line: a neighbour list holds exactly the particles
within R_k + R_m + 2h of its centre, its scan finds the exam's ``tc`` earliest among them,
and a rod's scan the earliest of its two neighbours on the line."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import KERNEL_RTOL

from gaz_cli.engines import reference
from gaz_cli.engines.event.layout import CNT, DONE, GATHER_SLOTS, I_WIDTH, INF, P_WIDTH, PR, PT, PV
from gaz_cli.engines.event.neighbours.cells import _assign_cells
from gaz_cli.engines.event.neighbours.line import _scan_1d
from gaz_cli.engines.event.neighbours.lists import _build_nl, _nl_exit, _scan_nl

L = 10.0


def _tc(P, k, m, t, dim, shift=0.0):
    pk = [P[k, :dim] + P[k, PV:PV + dim] * (t - P[k, PT]), P[k, PV:PV + dim].copy()]
    pm = [P[m, :dim] + P[m, PV:PV + dim] * (t - P[m, PT]) + shift, P[m, PV:PV + dim].copy()]
    dt = reference.tc(pk, pm, 0.5 * (P[k, PR] + P[m, PR]))
    return INF if dt is None else t + dt


def _built_lists(P, I, n, dim, nc, h, periodic):
    """Cells and neighbour lists (skin h) of the rows P, centred where the particles are."""
    cells = np.zeros((nc ** dim, n + GATHER_SLOTS + 1), dtype=np.int32)
    assert _assign_cells(P, I, cells, nc, L / nc, dim) == DONE
    XN = np.zeros((n, 3))
    XN[:, :dim] = P[:, :dim]
    NB = np.zeros((n, 64), dtype=np.int32)
    NN = np.zeros(n, dtype=np.int32)
    SCR = np.zeros(64, dtype=np.int32)
    assert _build_nl(P, XN, I, cells, NB, NN, SCR, nc, L, h, dim, periodic) == DONE
    return cells, XN, NB, NN


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
    cells, XN, NB, NN = _built_lists(P, I, n, dim, nc, h, periodic)
    for k in range(n):
        sep = P[:, :dim] - P[k, :dim]
        if periodic:
            sep -= L * np.round(sep / L)
        near = np.flatnonzero(np.linalg.norm(sep, axis=1) < 2 * r + 2 * h)
        assert sorted(NB[k, :NN[k]]) == sorted(set(near) - {k})
    for k in range(n):
        best, bj, bc = _scan_nl(P, I, NB, NN, k, 0.0, L, 0.5 * L, 0.0, INF, -1, nc, (1.0, 0.0), dim,
                                periodic, False, False)
        want = INF
        for m in NB[k, :NN[k]]:
            sep = P[m, :dim] - P[k, :dim]
            shift = -L * np.round(sep / L) if periodic else 0.0
            want = min(want, _tc(P, k, m, 0.0, dim, shift))
        assert best == pytest.approx(want, rel=KERNEL_RTOL) if want < INF else best == INF
        te = _nl_exit(P, XN, k, h, 0.0, dim, False)
        assert np.linalg.norm(P[k, PV:PV + dim] * te) == pytest.approx(h, rel=KERNEL_RTOL)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("nc", [3, 4, 5])
def test_lists_of_few_wide_cells_take_nearest_images_only_where_they_must(dim, nc):
    """Periodic boxes of 3 to 5 list-sized cells an axis (lists take nearest images only
    for a centre in a cell on a face of the box; in 3 cells an axis every cell but the
    middle one is on a face and the middle one's block spans the box): every list holds
    exactly the particles within R_k + R_m + 2h of its centre by the nearest image,
    across the faces too."""
    rng = np.random.default_rng(70 + 10 * dim + nc)
    h = 0.3
    r = 0.5 * (L / (nc + 0.5)) - h  # 2 r + 2 h: L / nc > reach > L / (nc + 1)
    assert int(L // (2 * r + 2 * h)) == nc
    n = {2: 120, 3: 400}[dim]
    P = np.zeros((n, P_WIDTH))
    P[:, :dim] = rng.uniform(0.0, L, size=(n, dim))
    P[:, PR] = r
    I = np.zeros((n, I_WIDTH), dtype=np.int32)
    cells, XN, NB, NN = _built_lists(P, I, n, dim, nc, h, True)
    across = 0
    for k in range(n):
        sep = P[:, :dim] - P[k, :dim]
        img = sep - L * np.round(sep / L)
        near = set(np.flatnonzero(np.linalg.norm(img, axis=1) < 2 * r + 2 * h)) - {k}
        assert sorted(NB[k, :NN[k]]) == sorted(near)
        across += sum(bool(np.any(img[m] != sep[m])) for m in near)
    assert across > 0  # some lists reach across a face


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
        best, bj = _scan_1d(P, order, k, k, n, 0.0, L, 0.0, (1.0, 0.0), periodic, False)
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


@pytest.mark.parametrize("dim", [2, 3])
def test_a_scan_bounded_by_best_finds_the_earliest_before_it_from_moved_unwrapped_rows(dim):
    """Periodic lists scanned after the particles moved (rows at their own stamps, up to h
    from their centres, some outside the box, as between rebuilds): with no bound the scan
    gives the earliest tc over the nearest images and the partner's counter; bounded by a
    time between the earliest and the next it still finds the earliest; bounded below the
    earliest it finds nothing and keeps what it was given."""
    rng = np.random.default_rng(60 + dim)
    n, r, h = {2: 150, 3: 1200}[dim], 0.25, 0.15
    move = 0.3 * h  # no pair overlaps after the moves: centres 2 r + 2 move apart at least
    nc = int(L // (2 * r + 2 * h))
    x = []
    while len(x) < n:
        c = rng.uniform(0.0, L, size=dim)
        sep = np.array(x).reshape(-1, dim) - c
        sep -= L * np.round(sep / L)
        if not x or np.min(np.linalg.norm(sep, axis=1)) > 2 * r + 2 * move:
            x.append(c)
    P = np.zeros((n, P_WIDTH))
    P[:, :dim] = x
    P[:, PV:PV + dim] = rng.normal(size=(n, dim))
    P[:, PR] = r
    I = np.zeros((n, I_WIDTH), dtype=np.int32)
    I[:, CNT] = rng.integers(0, 1000, size=n)
    cells, XN, NB, NN = _built_lists(P, I, n, dim, nc, h, True)
    # at time t each particle is up to `move` from its centre (not wrapped), its row
    # stamped at its own time before t
    t = 1.0
    speed = np.linalg.norm(P[:, PV:PV + dim], axis=1)
    tau = rng.uniform(0.0, move / speed)
    stamp = rng.uniform(0.0, tau)
    P[:, :dim] += P[:, PV:PV + dim] * (tau - stamp)[:, None]
    P[:, PT] = t - stamp
    at_t = P[:, :dim] + P[:, PV:PV + dim] * stamp[:, None]
    assert np.any((at_t < 0.0) | (at_t >= L))  # some have left the box
    seen = crossed = 0
    stamped = P.copy()
    for k in range(n):
        P[:] = stamped
        P[k, :dim] += P[k, PV:PV + dim] * (t - P[k, PT])  # the scanning row at t, as the
        P[k, PT] = t  # loop advances it
        times = []
        for m in NB[k, :NN[k]]:
            pk = P[k, :dim] + P[k, PV:PV + dim] * (t - P[k, PT])
            pm = P[m, :dim] + P[m, PV:PV + dim] * (t - P[m, PT])
            shift = -L * np.round((pm - pk) / L)
            tc = _tc(P, k, m, t, dim, shift)
            if tc < INF:
                times.append((tc, m))
                crossed += bool(np.any(shift != 0.0))
        times.sort()
        best, bj, bc = _scan_nl(P, I, NB, NN, k, t, L, 0.5 * L, 0.0, INF, -1, nc, (1.0, 0.0), dim, True,
                                False, False)
        if not times:
            assert (best, bj, bc) == (INF, -1, 0)
            continue
        seen += 1
        assert best == pytest.approx(times[0][0], rel=KERNEL_RTOL)
        assert bj == times[0][1] and bc == I[bj, CNT]
        if len(times) > 1 and times[1][0] > times[0][0] * (1 + 1e-9):
            bound = 0.5 * (times[0][0] + times[1][0])
            got = _scan_nl(P, I, NB, NN, k, t, L, 0.5 * L, 0.0, bound, -1, nc, (1.0, 0.0), dim, True,
                           False, False)
            assert got[1] == times[0][1] and got[0] == pytest.approx(times[0][0], rel=KERNEL_RTOL)
        low = t + 0.5 * (times[0][0] - t)
        assert _scan_nl(P, I, NB, NN, k, t, L, 0.5 * L, 0.0, low, 7, nc, (1.0, 0.0), dim, True, False,
                        False) == (low, 7, I[7, CNT])
    assert seen > n // 4 and crossed > 0  # partners found, some across a face
