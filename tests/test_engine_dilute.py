"""The dilute scan (gaz_cli.engine.neighbours.dilute): every particle scans all the others,
no cells; and when 'auto' takes it (gaz_cli.engine.sizing.use_dilute_scan)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from test_event_engine import assert_inside, assert_same_events_as_the_exam, min_gap, unit_scene

from gaz_cli import engine
from gaz_cli.recording import Recorder
from gaz_cli.scene import Scene, initial_state
from gaz_cli.species import lookup

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
    n = 300
    unit = {2: np.pi, 3: 4 * np.pi / 3}[dim]
    radius = (packing / (n * unit)) ** (1 / dim)
    total = 0
    for seed in (5, 6, 7):
        scene = unit_scene(dim, n, radius, duration=1.0, seed=seed, extras=DILUTE)
        state = initial_state(scene)
        stats = engine.run(scene, state, Recorder())
        assert stats.extras["dilute_scan"]
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


def scene_b(**kw) -> Scene:
    """benchmarks/engine.py's scene (b): 10^4 argon atoms, packing 0.01, shortened."""
    ar = lookup("Ar")
    length = (1e4 * 4.0 / 3.0 * math.pi * ar.radius ** 3 / 0.01) ** (1 / 3)
    return Scene(dim=3, length=length, duration=1e-13, components=((ar, 10_000),), seed=2, **kw)


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


def test_unknown_neighbour_search_is_refused():
    scene = readme_scene(extras={"neighbours": "sparse"})
    with pytest.raises(ValueError, match="dilute"):
        engine.run(scene, initial_state(scene), Recorder())


