"""The event engine's memory layout changes nothing in the physics.

Large systems get their rows renumbered along a Z-order curve (restarts),
their arrays on huge pages, their cell scans prefetched, and their cells
grown when full; none of this may change an event. Each test forces the
mechanism on a small system and compares with the plain run.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from gaz_cli.engines import event as engine
from gaz_cli.engines.event import driver, memory, sizing
from gaz_cli.engines.event import layout as K
from gaz_cli.engines.event.rows import Rows
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.placement.initial import initial_state


def _run(scene, state):
    rec = MemoryRecorder(collisions=True)
    rs = engine.run(scene, state, rec)
    return rs, rec.collisions(), rec.bounces()


def _energy(scene, v):
    return 0.5 * float(np.sum(scene.masses() * np.sum(v * v, axis=1)))


@pytest.mark.parametrize("dim, n, boundary, gravity, packing, search", [
    (3, 400, "periodic", 0.0, 0.3, "cells"),
    (3, 400, "walls", 30.0, 0.3, "cells"),
    (2, 300, "walls", 0.0, 0.4, "cells"),
    (2, 300, "periodic", 0.0, 0.4, "cells"),
    (3, 20, "periodic", 0.0, 0.3, "cells"),  # three cells an axis: scans carry the cells' images
    (3, 400, "periodic", 0.0, 0.4, "lists"),
    (3, 400, "walls", 30.0, 0.4, "lists"),
    (2, 300, "periodic", 0.0, 0.6, "lists"),
])
def test_prefetching_and_gathering_ahead_change_no_event(make_scene, monkeypatch, dim, n,
                                                          boundary, gravity, packing, search):
    """Large systems prefetch, walk the calendar ahead and gather a collision's two scans before
    either scans (cells), or request the rows of a list before its scan or rebuild (lists):
    forced on small systems of every kind, the run is bit for bit the same."""
    scene = make_scene(dim=dim, n=n, packing=packing, duration=0.2 if n > 100 else 5.0, seed=3,
                       boundary=boundary, gravity=gravity, extras={"neighbours": search})
    state = initial_state(scene)
    plain, cp, bp = _run(scene, state)
    monkeypatch.setattr(driver, "PREFETCH_FROM_N", 0)
    hinted, ch, bh = _run(scene, state)
    assert not plain.extras["prefetch"] and hinted.extras["prefetch"]
    assert plain.extras["neighbour_lists"] == (search == "lists")
    assert search == "cells" or plain.extras["list_rebuilds"] > 100
    assert plain.collisions > 1000
    assert plain.extras["overlapping_collisions"] == 0
    assert n > 100 or plain.extras["cells_per_axis"] == 3
    assert np.array_equal(plain.final.positions, hinted.final.positions)
    assert np.array_equal(plain.final.velocities, hinted.final.velocities)
    for key in ("t", "i", "j", "impulse"):
        assert np.array_equal(cp[key], ch[key])
    for key in bp:
        assert np.array_equal(bp[key], bh[key])
    assert plain.extras["pair_tests"] == hinted.extras["pair_tests"]


@pytest.mark.parametrize("buckets, per_bucket", [(16, 64.0), (1 << 20, 0.25)])
def test_the_calendar_shape_changes_no_event(make_scene, monkeypatch, buckets, per_bucket):
    """A calendar of 16 buckets (about 90 events in each, against 3: a bigger heap) or of four
    times as many buckets as the tuning wants gives the same run: the queue only orders the
    events."""
    scene = make_scene(dim=3, n=400, packing=0.3, duration=0.2, seed=7, boundary="walls")
    state = initial_state(scene)
    plain, cp, bp = _run(scene, state)
    monkeypatch.setattr(sizing, "MAX_BUCKETS", buckets)
    monkeypatch.setattr(sizing, "EVENTS_PER_BUCKET", per_bucket)
    other, co, bo = _run(scene, state)
    assert (other.extras["buckets"] < plain.extras["buckets"]) == (buckets == 16)
    assert other.extras["buckets"] != plain.extras["buckets"]
    assert plain.collisions > 2000 and bp["t"].size > 500
    assert np.array_equal(plain.final.positions, other.final.positions)
    assert np.array_equal(plain.final.velocities, other.final.velocities)
    # (which partner comes out of the queue first, when both predicted the collision, may change)
    assert np.array_equal(np.sort(np.stack([cp["i"], cp["j"]]), axis=0),
                          np.sort(np.stack([co["i"], co["j"]]), axis=0))
    for key in ("t", "impulse"):
        assert np.array_equal(cp[key], co[key])
    for key in bp:
        assert np.array_equal(bp[key], bo[key])


@pytest.mark.parametrize("forced", ["restarts walls", "restarts periodic", "full cells"])
def test_restarts_and_full_cells_keep_the_events(make_scene, monkeypatch, forced):
    """Renumbering every event a particle, or big cells with no spare room (grown as gravity
    piles the gas up on the floor), give the same first collisions and wall bounces, conserve
    energy and keep everyone apart and inside."""
    boundary = "periodic" if "periodic" in forced else "walls"
    g = 30.0 if forced == "full cells" else 0.0
    scene = make_scene(dim=3, n=400, packing=0.3, duration=0.2, seed=5, boundary=boundary,
                       gravity=g)
    state = initial_state(scene)
    plain, cp, bp = _run(scene, state)
    if forced.startswith("restarts"):
        monkeypatch.setattr(driver, "RESTART_FROM_N", 0)
        monkeypatch.setattr(driver, "RESTART_EVERY", 1)
    else:
        # big cells (about 6 particles each) with no room to spare
        monkeypatch.setattr(sizing, "CELLS_PER_PARTICLE", 0.1)
        monkeypatch.setattr(sizing, "_cell_capacity", lambda per_cell: 1)
        monkeypatch.setattr(sizing, "_cell_width", lambda cap: max(cap + 1, K.GATHER_SLOTS + 1))
    forced_run, cf, bf = _run(scene, state)
    assert plain.extras["restarts"] == 0 and plain.extras["cell_growths"] == 0
    if forced.startswith("restarts"):
        assert forced_run.extras["restarts"] >= 5
    else:
        assert forced_run.extras["cell_growths"] >= 1

    # the same events, up to round-off, until chaos takes over
    k = 300
    assert min(cp["t"].size, cf["t"].size) > k
    # (which of the two partners made the prediction may change with the numbering)
    pair_p = np.sort(np.stack([cp["i"][:k], cp["j"][:k]]), axis=0)
    pair_f = np.sort(np.stack([cf["i"][:k], cf["j"][:k]]), axis=0)
    assert np.array_equal(pair_p, pair_f)
    np.testing.assert_allclose(cf["t"][:k], cp["t"][:k], rtol=1e-9, atol=0)
    if boundary == "walls":
        kb = min(100, bp["t"].size)
        assert kb > 20
        assert np.array_equal(bp["particle"][:kb], bf["particle"][:kb])
        np.testing.assert_allclose(bf["t"][:kb], bp["t"][:kb], rtol=1e-9, atol=0)

    # and the physics of the whole forced run
    x, L, r = forced_run.final.positions, scene.length, scene.radii()
    m = scene.masses()
    e0 = _energy(scene, state.velocities) + g * float(np.sum(m * state.positions[:, -1]))
    e1 = _energy(scene, forced_run.final.velocities) + g * float(np.sum(m * x[:, -1]))
    assert abs(e1 - e0) <= 1e-11 * e0
    if boundary == "walls":
        assert np.all(x >= r[:, None] * (1 - 1e-12)) and np.all(x <= L - r[:, None] * (1 - 1e-12))
    d = x[:, None, :] - x[None, :, :]
    if boundary == "periodic":
        d -= L * np.rint(d / L)
    dist = np.sqrt(np.sum(d * d, axis=2)) + np.eye(len(x)) * L
    assert dist.min() >= 2 * r.max() * (1 - 1e-9)


def test_large_arrays_sit_on_huge_page_boundaries():
    small = memory._alloc((10, 3), np.int32, fill=7)
    big = memory._alloc((40_000, 8), fill=-1.5)
    assert small.shape == (10, 3) and small.dtype == np.int32 and np.all(small == 7)
    assert big.shape == (40_000, 8) and big.dtype == np.float64 and np.all(big == -1.5)
    assert big.flags.c_contiguous and big.ctypes.data % memory.HUGE_PAGE == 0


def test_z_order_keeps_blocks_of_cells_together():
    c = np.array([[i, j, k] for i in range(4) for j in range(4) for k in range(4)])
    key = memory._morton(c)
    assert np.array_equal(np.sort(key), np.arange(64))
    # every aligned 2x2x2 block of cells is a run of 8 consecutive keys
    block = (c // 2) @ np.array([4, 2, 1])
    for b in range(8):
        ks = np.sort(key[block == b])
        assert ks[-1] - ks[0] == 7


@pytest.mark.parametrize("size", [1, 2, 3, 10, 11, 1001])
def test_the_calendar_takes_numpys_median_and_90th_percentile(size):
    """sizing._median_and_q90 (one partial sort for both) gives np.median exactly and
    np.quantile(a, 0.9) to the rounding of one interpolation (a few ulps), ties included."""
    rng = np.random.default_rng(size)
    for a in (rng.exponential(1.0, size), np.round(rng.exponential(1.0, size), 1)):
        med, q90 = sizing._median_and_q90(a.copy())
        assert med == np.median(a)
        assert abs(q90 - np.quantile(a, 0.9)) <= 4 * np.spacing(np.max(a))


def test_the_search_interpolates_its_path_blocks_as_np_interp():
    """sizing.path_blocks (plain floats) gives np.interp's values over PATH_BLOCKS, clipped
    to [0, 1] outside it."""
    for dim in (2, 3):
        x, course, cross = sizing.PATH_BLOCKS[dim]
        for rho in np.linspace(-0.2, 1.3, 301):
            r = min(max(float(rho), 0.0), 1.0)
            got = sizing.path_blocks(dim, float(rho))
            assert got == pytest.approx((np.interp(r, x, course), np.interp(r, x, cross)),
                                        rel=1e-14)


def test_space_order_is_the_stable_order_of_the_z_keys():
    """Rows are numbered by a stable sort of their cells' Z keys (keys below 2^16 sorted as
    16-bit numbers: the same order as int64 keys)."""
    rng = np.random.default_rng(3)
    for nc in (3, 7, 40):  # keys below 2^16, and above
        table = Rows()
        table.D, table.pairs, table.n, table.L, table.nc = 3, True, 5000, 1.0, nc
        x = rng.random((5000, 3))
        key = memory._morton(np.clip(np.floor(x * nc).astype(np.int64), 0, nc - 1))
        assert np.array_equal(table._space_order(x), np.argsort(key, kind="stable"))


_PROBE = """
import sys
from gaz_cli.engines import event as engine
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species
sc = Scene(dim=3, length=12.0, duration=1e-9, components=((Species("X", 1.0, 0.5), 500),),
           temperature=1.0 / 1.380649e-23, seed=1, boundary="periodic", record="none")
engine.run(sc, initial_state(sc), Recorder())
print(int("sqlalchemy" in sys.modules), int("pandas" in sys.modules))
"""


def test_a_warm_start_loads_no_more_than_the_engine_needs():
    """A run of the engine imports neither the database layer nor pandas (the engine knows
    nothing of the store). The first call may compile (cold cache)."""
    env = dict(os.environ)
    out = ""
    for _ in range(2):
        out = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True,
                             text=True, check=True).stdout.split()
    assert out == ["0", "0"]
