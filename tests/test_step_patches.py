"""Patches and threads of the step engine (engines/step/patches.py, issue 40): the same seed
gives the same rows, bit for bit, whatever the number of patches and threads; the seed's
exchange keeps every particle exactly once."""

from __future__ import annotations

import math
import os
from dataclasses import replace

import numba
import numpy as np
import pytest

from gaz_cli.engines import step as stepper
from gaz_cli.engines.step import patches as P
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species
from gaz_cli.scenes.presets import PRESETS


def gas(dim=2, n=150, duration=0.2, dt=2e-3, seed=3, radius=0.01, **kw):
    """n light disks and n/3 heavy ones (twice as wide), speeds about 1 m/s, unit box."""
    light, heavy = Species("light", 1.0, radius), Species("heavy", 3.0, 2 * radius)
    sc = Scene(dim=dim, length=1.0, duration=duration, components=((light, n), (heavy, n // 3)), seed=seed,
               engine="step", dt=dt, **kw)
    st = initial_state(sc)
    rng = np.random.default_rng(seed)
    st.velocities = rng.normal(0.0, 1.0, st.velocities.shape) / np.sqrt(sc.masses())[:, None]
    return sc, st


NRM = (1 / math.sqrt(2), 1 / math.sqrt(2))
SCENES = {
    "walls": lambda: gas(dim=3, n=300, radius=0.03),
    "gravity": lambda: gas(gravity=3.0, restitution=0.8, tc=1e-3),
    "restitution": lambda: gas(restitution=0.7, wall_restitution=0.6),
    "drag": lambda: gas(drag=0.7, gravity=1.0, wall_restitution=0.8),
    "planes": lambda: gas(gravity=2.0, restitution=0.9, planes=(((0.04, 0.0), NRM, 0.8),)),
    "marbles": lambda: (lambda sc_st: (replace(sc_st[0], duration=0.1, print_every=0), sc_st[1]))(
        PRESETS["marbles"]()),
    # steps far too long (pairs left overlapping): many contacts met at the same time back, the
    # age, so ties in time are common and resolved by particle identity
    "ties": lambda: gas(n=400, radius=0.012, dt=0.02, duration=0.4, restitution=0.9),
}


def _run(sc, st, patches, threads, detection="overlap"):
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        rec = MemoryRecorder(collisions=True)
        rs = stepper.run(sc, st, rec, patches=patches, detection=detection)
    finally:
        numba.set_num_threads(before)
    return rs, rec.bounces(), rec.collisions()


def _same(a, b):
    (ra, ba, ca), (rb, bb, cb) = a, b
    assert np.array_equal(ra.final.positions, rb.final.positions)
    assert np.array_equal(ra.final.velocities, rb.final.velocities)
    assert ra.virial == rb.virial
    for x, y in ((ba, bb), (ca, cb)):
        for key in x:
            assert np.array_equal(x[key], y[key]), key
    keep = lambda e: {k: v for k, v in e.items() if k != "phase_times"}  # noqa: E731
    assert keep(ra.extras) == keep(rb.extras)


@pytest.mark.filterwarnings("ignore::gaz_cli.errors.GazWarning")
@pytest.mark.parametrize("name", sorted(SCENES))
def test_same_rows_whatever_the_patches_and_threads(name):
    """1, 2 and 4 patches on one thread, 2 patches on two threads: every row, the final state,
    the counters and the virial are the same bit for bit (contacts are resolved by time, ties
    by particle identity, never by the layout)."""
    sc, st = SCENES[name]()
    runs = [(1, 1), (2, 1), (4, 1)]
    if numba.config.NUMBA_NUM_THREADS >= 2:
        runs += [(2, 2), (4, 2)]
    one = _run(sc, st, 1, 1)
    assert one[0].collisions > 50 and one[0].wall_bounces > 10
    for patches, threads in runs[1:]:
        _same(one, _run(sc, st, patches, threads))


def test_swept_detection_is_the_same_on_patches():
    sc, st = SCENES["gravity"]()
    _same(_run(sc, st, 1, 1, "swept"), _run(sc, st, 4, 1, "swept"))


def test_the_exchange_moves_the_leavers_and_keeps_everyone_once():
    """Particles laid out in 2 x 2 patches, moved across the borders, exchanged: every ident
    once, each in the patch of its cell, each patch sorted by cell."""
    rng = np.random.default_rng(0)
    n, dim, length, nc = 400, 3, 1.0, 8
    pos = rng.uniform(0, length, (n, dim))
    vel = rng.normal(0, 1, (n, dim))
    acc, mass, radius = np.zeros((n, dim)), np.ones(n), np.full(n, 0.01)
    age, tlast = np.zeros(n), np.zeros(n)
    p1, p2 = P._patch_grid(4, dim, nc)
    assert (p1, p2) == (2, 2)
    from gaz_cli.engines.step.loop import _layout_arrays, _work
    cap = 2 * n // 4 + 64
    rows = 4 * cap
    L, S = _layout_arrays(rows, dim, 4)
    assert P._layout_in(pos, vel, acc, mass, radius, age, tlast, length, nc, p1, p2, cap, L)
    xb, cellof = np.empty((rows, dim)), np.empty(rows, np.int64)
    cstart, cend = np.zeros(nc ** dim, np.int64), np.zeros(nc ** dim, np.int64)
    P._sort_all(L, S, cap, length, nc, p1, p2, cstart, cend, cellof, xb)
    L, S = S, L
    W = _work(rows, dim, 4, n)
    moved = 0
    for _ in range(3):
        for p in range(4):  # a big random drift: many leave their patch
            sl = slice(p * cap, p * cap + L[8][p])
            L[0][sl] = np.clip(L[0][sl] + rng.normal(0, 0.2, L[0][sl].shape), 0, length)
        before = {int(k): p for p in range(4) for k in L[7][p * cap: p * cap + L[8][p]]}
        assert P._exchange(L, S, cap, length, nc, p1, p2, W[9], W[7], W[13], W[8], cstart, cend, cellof, xb)
        L, S = S, L
        ids = np.concatenate([L[7][p * cap: p * cap + L[8][p]] for p in range(4)])
        assert np.array_equal(np.sort(ids), np.arange(n))
        for p in range(4):
            sl = slice(p * cap, p * cap + L[8][p])
            assert all(P._patch_of(L[0], r, length, nc, p1, p2) == p for r in range(sl.start, sl.stop))
            cells = [P._cell_of(L[0], r, length, nc) for r in range(sl.start, sl.stop)]
            assert cells == sorted(cells)
            for r in range(sl.start, sl.stop):
                g = cells[r - sl.start]
                assert cstart[g] <= r < cend[g]
                moved += before[int(L[7][r])] != p
    assert moved > 50


def test_the_threads_option_sets_the_threads_and_changes_no_number(monkeypatch):
    """``gaz simulate --threads N``: Numba's threads (and so the patches) are N; the summary is
    the same as on one thread, run time aside."""
    import json

    from cli_helpers import invoke

    monkeypatch.setenv("NUMBA_NUM_THREADS", os.environ.get("NUMBA_NUM_THREADS", ""))  # restored after
    before = numba.get_num_threads()
    args = ["simulate", "--engine", "step", "--dim", "2", "--n", "200", "--packing", "0.2", "--species", "Ar",
            "--duration", "2e-12", "--dt", "2e-14", "--seed", "3", "--no-db", "--json", "--quiet"]
    out = {}
    try:
        for t in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
            code, stdout, stderr = invoke(args + ["--threads", str(t)])
            assert code == 0, stderr
            assert numba.get_num_threads() == t
            out[t] = {k: v for k, v in json.loads(stdout).items() if "time" not in k and "per_second" not in k}
    finally:
        numba.set_num_threads(before)
    assert len({json.dumps(v, sort_keys=True) for v in out.values()}) == 1
