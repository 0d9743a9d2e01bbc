"""The dilute scan (gaz_cli.engines.event.neighbours.dilute): every particle scans all the others,
no cells; and when 'auto' takes it (gaz_cli.engines.event.sizing.use_dilute_scan)."""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np
import pytest
from test_event_engine import assert_inside, assert_same_events_as_the_exam, min_gap, unit_scene

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.engines.event.dynamics import _relative_at
from gaz_cli.engines.event.interactions import _pair_time
from gaz_cli.engines.event.layout import PR, PT, PV
from gaz_cli.engines.event.neighbours.dilute import KEEP, XC_SIZE, XS_ROWS, _keep, _mirror_all
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species, lookup

DILUTE = {"neighbours": "dilute"}

ENERGY_RTOL = 1e-10
"""Relative change of the kinetic energy over a run: each collision rounds the velocities at
1e-16, and the errors add up as a random walk over ~10^4-10^5 collisions (~1e-13); 1e-10 is
far above that and far below what one wrong collision changes (~1/N of the energy)."""


def energy(scene: Scene, v: np.ndarray) -> float:
    return 0.5 * float(np.sum(scene.masses() * np.sum(v * v, axis=1)))


@pytest.mark.parametrize("dim, n, radius", [(2, 30, 0.02), (3, 30, 0.04), (3, 60, 0.03)])
@pytest.mark.parametrize("seed", [3, 4])
def test_same_events_as_the_exam(dim, n, radius, seed):
    """The dilute scan and the exam's algorithm give the same events in the same order at
    the same times, within test_event_engine's error model, up to its horizon."""
    stats = assert_same_events_as_the_exam(unit_scene(dim, n, radius, duration=6.0, seed=seed,
                                                      extras=DILUTE))
    assert stats.extras["dilute_scan"] and stats.extras["cell_crossings"] == 0


@pytest.mark.parametrize("dim, packing", [(2, 0.2), (3, 0.05), (3, 0.25)])
def test_no_collision_is_missed_energy_is_kept_nobody_leaves(dim, packing):
    """Forced on gases from dilute to dense (where the rejection pass keeps many pairs): no
    pair is ever found overlapping when it collides (a missed collision would be, later),
    the energy stays within ENERGY_RTOL, every particle ends inside the box and apart."""
    assert_exact_runs(dim, packing, DILUTE, lambda extras: extras["dilute_scan"])


def assert_exact_runs(dim, packing, extras, took_the_path, boundary="walls"):
    """300 particles at ``packing``, seeds 5-7, run with the search forced by ``extras``:
    the path taken (``took_the_path(stats.extras)``), no pair found overlapping when it
    collides, energy within ENERGY_RTOL, everyone inside and apart; > 5000 collisions."""
    n = 300
    unit = {2: np.pi, 3: 4 * np.pi / 3}[dim]
    radius = (packing / (n * unit)) ** (1 / dim)
    total = 0
    for seed in (5, 6, 7):
        scene = unit_scene(dim, n, radius, duration=1.0, seed=seed, extras=extras,
                           boundary=boundary)
        state = initial_state(scene)
        stats = engine.run(scene, state, Recorder())
        assert took_the_path(stats.extras)
        assert stats.extras["overlapping_collisions"] == 0, (seed, stats.extras)
        e0, e1 = energy(scene, state.velocities), energy(scene, stats.final.velocities)
        assert abs(e1 - e0) <= ENERGY_RTOL * e0
        assert_inside(scene, stats.final.positions)
        assert min_gap(scene, stats.final.positions) > -1e-9
        total += stats.collisions
    assert total > 5e3, total


def test_collisions_and_bounces_agree_with_cells():
    """The same gas run with cells and with the dilute scan: the two trajectories part by
    chaos, so their counts are compared as Poisson counts (within 5 standard deviations,
    sqrt(2 k) for the difference of two counts near k)."""
    scene = unit_scene(3, 500, 0.012, duration=2.0, seed=2)
    state = initial_state(scene)
    cells = engine.run(dataclasses.replace(scene, extras={"neighbours": "cells"}), state)
    dilute = engine.run(dataclasses.replace(scene, extras=DILUTE), state)
    assert not cells.extras["dilute_scan"] and dilute.extras["dilute_scan"]
    for k in ("collisions", "wall_bounces"):
        a, b = getattr(cells, k), getattr(dilute, k)
        assert a > 1000 and abs(a - b) <= 5 * math.sqrt(a + b), k


def readme_scene(**kw) -> Scene:
    """The README example (1000 argon atoms at 300 K and about 1 atm), shortened."""
    return Scene(dim=3, length=3.4e-8, duration=1e-12, components=((lookup("Ar"), 1000),),
                 seed=1, **kw)


def scene_b(n: int = 10_000, packing: float = 0.01, **kw) -> Scene:
    """benchmarks/engine.py's scene (b): 10^4 argon atoms, packing 0.01 (or n, packing),
    shortened."""
    ar = lookup("Ar")
    length = (n * 4.0 / 3.0 * math.pi * ar.radius ** 3 / packing) ** (1 / 3)
    return Scene(dim=3, length=length, duration=1e-13, components=((ar, n),), seed=2, **kw)


@pytest.mark.parametrize("scene, dilute", [
    (readme_scene(), True),  # mean free path 80 nm > box 34 nm: no cells
    (scene_b(), False),  # 10^4 atoms: scanning all costs more than cells
    (readme_scene(boundary="periodic"), False),  # the scan takes no periodic images
    (readme_scene(gravity=9.81), False),  # nor gravity
    (unit_scene(3, 1000, (0.3 / (1000 * 4 / 3 * math.pi)) ** (1 / 3), duration=1e-3), False),
    (readme_scene(extras={"neighbours": "cells"}), False),  # forced
    (unit_scene(3, 500, 0.05, duration=1e-3, extras=DILUTE), True),  # forced, dense
])
def test_auto_takes_the_dilute_scan_for_dilute_gases_in_boxes_with_walls(scene, dilute):
    stats = engine.run(scene, initial_state(scene), Recorder())
    assert stats.extras["dilute_scan"] is dilute
    assert (stats.extras["cells_per_axis"] == 1) or not dilute


def test_auto_weighs_a_mixture_by_its_own_packing():
    # 10 large spheres (r = 0.1) among 3000 small ones (r = 0.001), walls, packing 0.04: the
    # cost model once took 3010 large spheres (packing 12.6) and the run died on the contact
    # value's refusal; a mixture's run goes on, exact (energy kept, nobody outside)
    scene = Scene(dim=3, length=1.0, duration=0.05, temperature=1.0 / K_B, seed=3,
                  components=((Species("L", 1.0, 0.1), 10), (Species("S", 1e-6, 0.001), 3000)))
    state = initial_state(scene)
    stats = engine.run(scene, state, Recorder())
    assert stats.collisions > 0
    e0, e1 = energy(scene, state.velocities), energy(scene, stats.final.velocities)
    assert abs(e1 - e0) <= ENERGY_RTOL * e0
    assert_inside(scene, stats.final.positions)
    assert min_gap(scene, stats.final.positions) > -1e-9


def test_unknown_neighbour_search_is_refused():
    """At the one door (scene.validate), naming the choices; the engine assumes a valid scene."""
    from gaz_cli.scenes.validate import validate

    scene = readme_scene(extras={"neighbours": "sparse"})
    with pytest.raises(ValueError, match="is not one of auto, cells, lists, dilute"):
        validate(scene)




# --- the float32 rejection pass: it only filters (module docstring of neighbours.dilute) ---

@numba.njit(cache=True)
def _kept_and_found(P, XS, XC, t_mirror, t, tx, L, D):
    """The rejection pass (in D dimensions) of particle 0 (its row at t) up to tx, after the
    rows were mirrored at t_mirror, and which particles the exact float64 root finds in
    contact by tx."""
    n = P.shape[0]
    _mirror_all(P, XS, XC, n, t_mirror, L)
    _keep(P, XS, XC, 0, t, tx, n, D)
    kept = np.zeros(n, np.bool_)
    found = np.zeros(n, np.bool_)
    for m in range(1, n):
        kept[m] = XS[KEEP, m] <= 0.0
        dx0, dx1, dx2, dv0, dv1, dv2 = _relative_at(P, m, t, P[0, 0], P[0, 1], P[0, 2],
                                                    P[0, PV], P[0, PV + 1], P[0, PV + 2],
                                                    0.0, 3, False)
        found[m] = t + _pair_time(dx0, dx1, dx2, dv0, dv1, dv2, P[0, PR], P[m, PR],
                                  (1.0, 0.0), 3) <= tx
    return kept, found


def adversarial_rows(rng, n, dim, L, radius, speed, t, horizon, age, at=None):
    """Rows (n, 8) of particle 0 at time t (inside the box, near the far walls; or ``at``:
    its position and velocity) and n - 1 partners, each set up to touch it at a chosen time
    tc in [0, horizon] (a fifth touching now, tc = 0; a tenth just inside the horizon,
    tc = horizon (1 - 1e-12)),
    closing in along a grazing normal (n.dv = -eta |dv|, eta from 1e-7 to 1), a tenth
    overlapping slightly; each partner's row stamped up to ``age`` before t, its path
    inside the box since (candidates that leave it are drawn again)."""
    d = dim
    P0 = np.zeros(8)
    P0[:d] = L - radius * (1.0 + rng.uniform(0.0, 2.0, d))
    P0[PV:PV + d] = speed * rng.normal(size=d)
    if at is not None:
        P0[:d], P0[PV:PV + d] = at
    P0[PT] = t
    P0[PR] = radius
    rows = [P0[None, :]]
    have = 1
    while have < n:
        k = 4 * n
        dv = speed * rng.normal(size=(k, d))
        u = dv / np.linalg.norm(dv, axis=1)[:, None]
        eta = 10.0 ** rng.uniform(-7, 0, k)
        w = rng.normal(size=(k, d))
        w -= np.sum(w * u, axis=1)[:, None] * u
        w /= np.linalg.norm(w, axis=1)[:, None]
        nrm = -eta[:, None] * u + np.sqrt(1.0 - eta * eta)[:, None] * w
        tc = np.where(rng.uniform(size=k) < 0.2, 0.0, rng.uniform(0.0, horizon, k))
        tc = np.where(rng.uniform(size=k) < 0.1, horizon * (1.0 - 1e-12), tc)
        r = radius * rng.uniform(0.5, 1.5, k)
        reach = (P0[PR] + r) * np.where(rng.uniform(size=k) < 0.1, 1.0 - 1e-3, 1.0)
        x_t = P0[:d] + reach[:, None] * nrm - dv * tc[:, None]
        v = P0[PV:PV + d] + dv
        age_m = rng.uniform(0.0, age, k)
        x_s = x_t - v * age_m[:, None]
        inside = np.all((x_t > r[:, None]) & (x_t < L - r[:, None]) & (x_s > r[:, None])
                        & (x_s < L - r[:, None]), axis=1)
        Q = np.zeros((int(inside.sum()), 8))
        Q[:, :d], Q[:, PV:PV + d] = x_s[inside], v[inside]
        Q[:, PT], Q[:, PR] = t - age_m[inside], r[inside]
        rows.append(Q)
        have += len(Q)
    return np.concatenate(rows)[:n]


@pytest.mark.parametrize("case, dim, L, radius, speed, t, t_mirror, horizon, age", [
    ("unit box", 3, 1.0, 0.01, 1.0, 0.3, 0.0, 0.5, 0.5),
    ("2D", 2, 1.0, 0.01, 1.0, 0.3, 0.0, 0.5, 0.5),
    ("box 10^4 diameters wide", 3, 1.0, 5e-5, 1.0, 0.3, 0.0, 1.0, 1.0),
    ("argon in SI units, late in the run (stamps rebased)", 3, 3.4e-8, 1.7e-10, 400.0, 7.3e-9,
     0.0, 4e-11, 4e-11),
    ("a long horizon (a slow particle)", 3, 1.0, 0.01, 1.0, 0.3, 0.25, 5e3, 0.5),
])
@pytest.mark.parametrize("seed", [1, 2])
def test_rejection_pass_keeps_every_pair_the_exact_root_finds(case, dim, L, radius, speed, t,
                                                              t_mirror, horizon, age, seed):
    """Partners set up to touch particle 0 within its horizon, grazing, touching now,
    overlapping, just inside the horizon, near the walls, in boxes 10^4 diameters wide and
    in SI units: every one the exact float64 root finds in contact by the horizon is kept
    by the float32 pass (its error model: the module docstring)."""
    rng = np.random.default_rng(seed)
    P = adversarial_rows(rng, 3000, dim, L, radius, speed, t, horizon, age)
    XS = np.zeros((XS_ROWS, len(P)), np.float32)
    XC = np.zeros(XC_SIZE)
    kept, found = _kept_and_found(P, XS, XC, t_mirror, t, t + horizon, L, dim)
    assert found.sum() > 1000, found.sum()  # (most partners do touch by the horizon)
    missed = np.flatnonzero(found & ~kept)
    assert missed.size == 0, (missed[:5], P[missed[:5]])


def test_pair_tests_count_exact_roots_on_every_path():
    """--json's pair_tests counts the pair times computed exactly, whichever search ran: on
    the README example the dilute scan computes a fraction of one a queue event (its
    rejection pass goes through all 1000 particles, counted apart as dilute_scanned),
    cells a few; cells scan nobody."""
    scene = dataclasses.replace(readme_scene(), duration=2e-11)
    state = initial_state(scene)
    dil = engine.run(scene, state, Recorder()).extras
    cells = engine.run(dataclasses.replace(scene, extras={"neighbours": "cells"}), state).extras
    assert dil["dilute_scan"] and not cells["dilute_scan"]
    assert dil["dilute_scanned"] >= 1000 * dil["queue_events"]
    assert 0 < dil["pair_tests"] < dil["queue_events"]
    assert cells["dilute_scanned"] == 0 and cells["pair_tests"] > cells["queue_events"]
