"""Initial positions (gaz_cli/placement.py): valid, reproducible, dense when asked, clear when not."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from gaz_cli import placement
from gaz_cli.errors import PlacementError, SceneError

UNIT = {1: 2.0, 2: math.pi, 3: 4.0 * math.pi / 3.0}


def box_for(dim, n, radius, packing):
    return (n * UNIT[dim] * radius ** dim / packing) ** (1.0 / dim)


def assert_valid(x, radii, length, periodic, rtol=1e-9):
    """Inside the box (walls: a radius from each wall) and no two particles overlapping."""
    n, dim = x.shape
    assert np.all(np.isfinite(x))
    if periodic:
        assert np.all((x >= 0) & (x < length))
    else:
        assert np.all(x >= radii[:, None] * (1 - rtol))
        assert np.all(x <= length - radii[:, None] * (1 - rtol))
    tree = cKDTree(x, boxsize=length if periodic else None)
    pairs = tree.query_pairs(2 * radii.max(), output_type="ndarray")
    if len(pairs):
        d = x[pairs[:, 0]] - x[pairs[:, 1]]
        if periodic:
            d -= length * np.rint(d / length)
        gap = np.sqrt(np.sum(d * d, axis=1)) - (radii[pairs[:, 0]] + radii[pairs[:, 1]]) * (1 - rtol)
        assert gap.min() >= 0.0, "two particles overlap"


@pytest.mark.parametrize("dim,packing,method,periodic", [
    (3, 0.30, "rejection", False), (3, 0.30, "rejection", True), (2, 0.45, "rejection", True),
    (3, 0.50, "grow", False), (3, 0.50, "grow", True), (2, 0.70, "grow", False),
    (2, 0.70, "grow", True), (3, 0.70, "lattice", True), (2, 0.85, "lattice", True),
    (3, 0.60, "lattice", False), (1, 0.90, "rapid", False)])
def test_positions_are_inside_and_apart(dim, packing, method, periodic):
    n = 2000 if dim > 1 else 500
    r = np.full(n, 0.5)
    L = box_for(dim, n, 0.5, packing)
    x = placement.place(dim, r, L, np.random.default_rng(3), method=method, periodic=periodic)
    assert x.shape == (n, dim)
    assert_valid(x, r, L, periodic)


@pytest.mark.parametrize("packing", [0.05, 0.3, 0.45, 0.6, 0.72])
def test_auto_reaches_every_packing_up_to_the_lattice(packing):
    n = 500
    r = np.full(n, 0.5)
    L = box_for(3, n, 0.5, packing)
    x = placement.place(3, r, L, np.random.default_rng(1), method="auto", periodic=True)
    assert_valid(x, r, L, True)


def test_growth_gives_a_dense_random_mixture():
    rng = np.random.default_rng(5)
    radii = np.where(rng.random(1200) < 0.5, 0.5, 0.35)
    L = (np.sum(UNIT[3] * radii ** 3) / 0.48) ** (1 / 3)
    x = placement.grow(3, radii, L, np.random.default_rng(2), periodic=False)
    assert_valid(x, radii, L, False)
    # random, not a lattice: the nearest-neighbour distances are spread out
    d, _ = cKDTree(x).query(x, k=2)
    assert np.std(d[:, 1]) > 0.02


@pytest.mark.parametrize("method", ["rejection", "grow", "lattice", "auto"])
def test_the_seed_fixes_the_positions(method):
    r = np.full(300, 0.5)
    L = box_for(2, 300, 0.5, 0.4)
    a = placement.place(2, r, L, np.random.default_rng(9), method=method)
    b = placement.place(2, r, L, np.random.default_rng(9), method=method)
    c = placement.place(2, r, L, np.random.default_rng(10), method=method)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("method", ["lattice", "rejection", "auto"])
def test_points_are_placed_inside_and_distinct(dim, periodic, method):
    """Zero radius (an ideal gas of points): every method places them, inside the box,
    no two on one site (a lattice of points used to divide by its zero spacing)."""
    n, length = 27, 1e-7
    x = placement.place(dim, np.zeros(n), length, np.random.default_rng(3), method, periodic)
    assert x.shape == (n, dim) and np.all((x >= 0.0) & (x <= length))
    assert len(np.unique(x, axis=0)) == n


def test_rejection_places_many_particles():
    """N = 20 000 at 3D packing 0.3 through the cell grid (the O(N) path)."""
    n = 20_000
    r = np.full(n, 0.5)
    L = box_for(3, n, 0.5, 0.3)
    x = placement.place(3, r, L, np.random.default_rng(4), method="rejection", periodic=True)
    assert_valid(x, r, L, True)


def test_beyond_reach_is_a_clear_error():
    r = np.full(400, 0.5)
    with pytest.raises(PlacementError, match="densest random state"):
        placement.place(3, r, box_for(3, 400, 0.5, 0.55), np.random.default_rng(1), method="grow")
    with pytest.raises(PlacementError, match="densest random state"):
        placement.place(2, r, box_for(2, 400, 0.5, 0.75), np.random.default_rng(1), method="grow")
    with pytest.raises(PlacementError, match="close packing"):
        placement.place(3, r, box_for(3, 400, 0.5, 0.76), np.random.default_rng(1), method="lattice")
    with pytest.raises(PlacementError, match="stuck"):
        placement.place(3, r, box_for(3, 400, 0.5, 0.60), np.random.default_rng(1), method="rejection")
    with pytest.raises(SceneError, match="1D only"):
        placement.place(2, r, 100.0, np.random.default_rng(1), method="rapid")
    with pytest.raises(SceneError, match="not one of"):
        placement.place(2, r, 100.0, np.random.default_rng(1), method="magic")


@pytest.mark.parametrize("periodic, holds", [(True, True), (False, False)])
def test_the_lattice_is_named_as_a_way_out_only_when_it_holds_every_particle(periodic, holds):
    """400 spheres at 0.55 in 3D, past random placement: a periodic box holds an FCC lattice
    of 500 sites, a box with walls only 365 (its centres keep a radius from each wall), where
    ``--method lattice`` fails too and is not offered."""
    r = np.full(400, 0.5)
    L = box_for(3, 400, 0.5, 0.55)
    assert placement.holds(3, r, L, periodic) is holds
    for method in ("grow", "rejection"):
        with pytest.raises(PlacementError) as refused:
            placement.place(3, r, L, np.random.default_rng(1), method=method, periodic=periodic)
        assert ("--method lattice" in str(refused.value)) is holds
        assert "lower --n or raise --length" in str(refused.value)
    if holds:
        assert_valid(placement.place(3, r, L, np.random.default_rng(1), "lattice", periodic), r, L,
                     periodic)
    else:
        with pytest.raises(PlacementError, match="only 365 lattice sites"):
            placement.place(3, r, L, np.random.default_rng(1), "lattice", periodic)


def test_growth_that_jams_reports_instead_of_hanging():
    """A tiny event budget stands for a box that jams before the target."""
    r = np.full(300, 0.5)
    with pytest.raises(PlacementError, match="jammed"):
        placement.grow(3, r, box_for(3, 300, 0.5, 0.5), np.random.default_rng(1), max_events=1000)


def _overlapping(x, radii, length, periodic):
    """The particles that overlap another beyond 1e-9 relative: every pair's distance (N^2)."""
    d = x[:, None, :] - x[None, :, :]
    if periodic:
        d -= length * np.rint(d / length)
    s = (radii[:, None] + radii[None, :]) * (1.0 - 1e-9)
    hit = np.sum(d * d, axis=2) < s * s
    np.fill_diagonal(hit, False)
    return np.flatnonzero(hit.any(axis=1))


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("periodic", [False, True])
def test_first_overlap_finds_an_overlap_exactly_when_every_pair_does(dim, periodic):
    """first_overlap (the engine's cells; in 1D the line order) against every pair: -1 when no
    pair overlaps, else a particle that overlaps. Configurations valid or not: lattices and
    random placements jiggled by a random fraction of a diameter, of mixed radii, with boxes
    of one cell to many, an overlap across a periodic face included."""
    rng = np.random.default_rng(11)
    found = clean = 0
    for n, length in [(3, 1.0), (40, 1.0), (300, 1.0), (300, 3.0)]:
        for method in ("lattice", "rejection"):
            radii = rng.uniform(0.5, 1.0, n) * 0.3 * length / n ** (1.0 / dim)
            x = placement.place(dim, radii, length, rng, method, periodic)
            for jiggle in (0.0, 0.05, 0.5, 1.0):
                y = x + jiggle * radii.max() * rng.standard_normal(x.shape)
                y = np.mod(y, length) if periodic else np.clip(y, 0.0, length)
                k = placement.first_overlap(y, radii, length, periodic)
                bad = _overlapping(y, radii, length, periodic)
                assert (k in bad) if bad.size else k == -1, (n, length, method, jiggle, k, bad)
                found += bad.size > 0
                clean += bad.size == 0
    # across a periodic face, or against the far wall's neighbour
    x = np.full((2, dim), 0.5)
    x[0, 0], x[1, 0] = 0.001, 0.999
    assert (placement.first_overlap(x, np.full(2, 0.002), 1.0, periodic) >= 0) == periodic
    assert found >= 10 and clean >= 10, (found, clean)
