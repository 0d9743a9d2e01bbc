"""Placement of mixtures: the largest particles go first, whatever the species order; sizes far
apart in two steps, the small particles among the large ones held fixed (placement.mixture)."""

import math

import numpy as np
import pytest

from gaz_cli import placement


def _mixture(dim, n_small=990, n_large=10, ratio=10.0, packing=0.15):
    """Small particles first (the order a scene lists them in), 1 % large ones of radius
    ``ratio``; the box edge for the total packing fraction."""
    radii = np.r_[np.ones(n_small), np.full(n_large, ratio)]
    unit = {2: math.pi, 3: 4.0 * math.pi / 3.0}[dim]
    length = (unit * float(np.sum(radii ** dim)) / packing) ** (1.0 / dim)
    return radii, length


@pytest.mark.parametrize("dim, ratio", [(2, 10.0), (3, 6.0)])
def test_a_mixture_listed_small_first_is_placed_without_overlap(dim, ratio):
    # packing 0.15, half of it in 1 % large particles: adding them after the small ones,
    # RSA was refused 10^5 times in a row (PlacementError); large ones first, it is easy
    radii, length = _mixture(dim, ratio=ratio)
    pos = placement.place(dim, radii, length, np.random.default_rng(1), method="rejection")
    assert placement.first_overlap(pos, radii, length, False) < 0
    # every particle inside by its own radius: positions belong to the right particles
    assert np.all(pos - radii[:, None] >= 0.0) and np.all(pos + radii[:, None] <= length)


def test_one_size_keeps_the_index_order():
    # the stable sort leaves one-size scenes as they were: the same seed, the same positions
    # as adding the particles in index order
    radii = np.full(500, 1.0)
    length = 60.0
    got = placement.rejection(2, radii, length, np.random.default_rng(7))
    in_order = placement.rsa._rejection_in_order(2, radii, length, np.random.default_rng(7), False,
                                             100_000, None)
    assert np.array_equal(got, in_order)


# --- sizes far apart: the large particles first, then the small ones among them ---------
from test_placement import _overlapping, assert_valid  # noqa: E402

from gaz_cli.engines.event.layout import P_WIDTH, PR, PV  # noqa: E402
from gaz_cli.errors import PlacementError  # noqa: E402
from gaz_cli.placement import mixture, obstacles  # noqa: E402


@pytest.mark.parametrize("dim, n_small, n_large, ratio, packing, periodic, method", [
    (3, 3000, 30, 10.0, 0.40, False, "auto"),   # the large ones grown alone, small ones added
    (3, 5000, 2, 10.0, 0.40, True, "auto"),     # the small ones grown among two fixed spheres
    (2, 2000, 20, 10.0, 0.60, True, "auto"),    # large added, small grown, images across faces
    (3, 2000, 16, 5.0, 0.45, True, "grow"),     # both grown (a 1:5 mixture, large ones dilute)
    (2, 1500, 15, 8.0, 0.30, False, "rejection"),
])
def test_a_mixture_of_sizes_far_apart_is_placed_inside_and_apart(dim, n_small, n_large, ratio,
                                                                 packing, periodic, method):
    radii, length = _mixture(dim, n_small, n_large, ratio, packing)
    assert mixture.split(dim, radii, length) is not None  # the two-step path
    x = placement.place(dim, radii, length, np.random.default_rng(2), method, periodic)
    assert_valid(x, radii, length, periodic)


def test_three_sizes_are_placed_class_by_class():
    """1:10:100 in 2D: the largest first, then the middle ones among them, then the small."""
    radii = np.r_[np.full(1500, 1.0), np.full(30, 10.0), np.full(2, 100.0)]
    length = (math.pi * float(np.sum(radii ** 2)) / 0.35) ** 0.5
    x = placement.place(2, radii, length, np.random.default_rng(4), "auto", True)
    assert_valid(x, radii, length, True)


@pytest.mark.parametrize("method", ["auto", "grow", "rejection"])
def test_the_seed_fixes_a_mixtures_positions(method):
    radii, length = _mixture(2, 600, 6, 10.0, 0.5 if method != "rejection" else 0.3)
    a, b, c = (placement.place(2, radii, length, np.random.default_rng(s), method, True)
               for s in (9, 9, 10))
    assert np.array_equal(a, b) and not np.array_equal(a, c)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("coarse", [False, True])
def test_the_table_lists_every_sphere_a_ball_in_its_cell_could_touch(dim, periodic, coarse,
                                                                     monkeypatch):
    """obstacles.touching against every sphere and every periodic image (shifts -2..2): the
    same answer for balls anywhere in the box, radii up to the table's reach; spheres of any
    size up to one wider than half the box (two images reach one cell), on grids of one
    cell to many, and, ``coarse``, tables of several fine cells a cell (g > 1)."""
    if coarse:
        monkeypatch.setattr(obstacles, "ENTRIES", 500)
    rng = np.random.default_rng(21)
    reach, length = 0.02, 1.0
    compared = hits = 0
    for nc in (1, 3, 10, 37):
        centres = rng.random((7, dim)) * length
        radii = rng.uniform(0.01, 0.15, 7)
        radii[0] = 0.52  # wider than half the box: two of its images reach some cells
        table = obstacles.table(centres, radii, length, periodic, reach, nc)
        if coarse and nc == 37:
            assert table.g > 1 and nc % table.g  # the last table cell narrower than the others
        x = rng.random((3000, dim)) * length
        r = rng.uniform(0.0, reach, 3000)
        got = obstacles.touching(table, x, r)
        shifts = np.array(np.meshgrid(*[range(-2, 3)] * dim)).reshape(dim, -1).T if periodic \
            else np.zeros((1, dim))
        images = (centres[:, None, :] + length * shifts[None, :, :]).reshape(-1, dim)
        image_radii = np.repeat(radii, len(shifts))
        d2 = np.sum((x[:, None, :] - images[None, :, :]) ** 2, axis=2)
        want = np.any(d2 < ((r[:, None] + image_radii[None, :]) * (1.0 - 1e-9)) ** 2, axis=1)
        assert np.array_equal(got, want), (nc, np.flatnonzero(got != want)[:5])
        compared += got.size
        hits += int(want.sum())
    assert 0.1 * compared < hits < 0.95 * compared, hits / compared  # both answers drawn often


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("periodic", [False, True])
def test_first_overlap_of_a_mixture_finds_an_overlap_exactly_when_every_pair_does(dim, periodic):
    """first_overlap class by class (mixture.first_overlap) against every pair: placements
    of small and large particles (1:10, a few large ones touching several small ones when
    jiggled), jiggled by a random fraction of a small diameter."""
    rng = np.random.default_rng(12)
    found = clean = 0
    for draw in range(6):
        radii, length = _mixture(dim, 300, 4, 10.0, 0.25)
        x = placement.place(dim, radii, length, rng, "auto", periodic)
        for jiggle in (0.0, 0.01, 0.1, 0.3):
            y = x + jiggle * rng.standard_normal(x.shape)
            y = np.mod(y, length) if periodic else np.clip(y, 0.0, length)
            k = placement.first_overlap(y, radii, length, periodic)
            bad = _overlapping(y, radii, length, periodic)
            assert (k in bad) if bad.size else k == -1, (draw, jiggle, k, bad)
            found += bad.size > 0
            clean += bad.size == 0
    assert found >= 5 and clean >= 5, (found, clean)


def test_a_fixed_sphere_bounces_a_growing_particle_elastically_in_its_frame():
    """A particle at the surface of a fixed sphere, closing in slower than its radius grows
    (un < r gamma), leaves with un' = 2 r gamma - un along the normal; tangential kept."""
    rng = np.random.default_rng(5)
    dim, gamma = 3, 0.1
    for _ in range(200):
        r, big = rng.uniform(0.2, 0.5), rng.uniform(1.0, 5.0)
        n = rng.normal(size=dim)
        n /= np.linalg.norm(n)
        sphere = np.zeros((1, 4))
        sphere[0, :dim], sphere[0, 3] = rng.uniform(2.0, 3.0, size=dim), big
        P = np.zeros((1, P_WIDTH))
        P[0, :dim] = sphere[0, :dim] + (big + r * gamma * 4.0) * n  # radius r gamma t at t = 4
        P[0, PV:PV + dim] = v0 = rng.normal(size=dim)
        P[0, PR] = r
        un = v0 @ n
        placement.growth._ls_bounce(P, 0, sphere, 0, gamma, dim)
        v1 = P[0, PV:PV + dim]
        s = r * gamma
        want = 2.0 * s - un if un < s else un
        assert v1 @ n == pytest.approx(want, rel=0, abs=1e-12 * (np.abs(v0).max() + s))
        np.testing.assert_allclose(v1 - (v1 @ n) * n, v0 - un * n, rtol=0, atol=1e-12)


def test_two_steps_that_jam_fall_back_to_one_under_auto_only(monkeypatch):
    radii, length = _mixture(3, 800, 8, 10.0, 0.35)

    def jammed(*args, **kwargs):
        raise PlacementError("growth jammed")

    monkeypatch.setattr(mixture, "place", jammed)
    x = placement.place(3, radii, length, np.random.default_rng(1), "auto", True)
    assert_valid(x, radii, length, True)
    with pytest.raises(PlacementError, match="jammed"):
        placement.place(3, radii, length, np.random.default_rng(1), "grow", True)


@pytest.mark.parametrize("dim, packing", [(3, 0.54), (2, 0.74)])
def test_a_mixture_denser_than_one_random_step_reaches_is_placed_in_two(dim, packing):
    """Beyond the densest random state of one size (3D 0.50, 2D 0.70) a 1:10 mixture is still
    placed at random: the large ones grown alone to ~0.49 (2D ~0.67), the small ones grown in
    the room they leave (it was refused: a lattice of 20-diameter sites holds 32 of 4040)."""
    radii, length = _mixture(dim, 3000, 30, 10.0, packing)
    x = placement.place(dim, radii, length, np.random.default_rng(3), "auto", True)
    assert_valid(x, radii, length, True)
    one_size = np.full(1000, 1.0)
    with pytest.raises(PlacementError, match="densest random state"):
        placement.place(dim, one_size, _box(dim, one_size, packing), np.random.default_rng(3), "grow")


@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize("dim, n_small, n_large, packing", [(3, 10_800, 108, 0.6), (2, 267, 100, 0.7703)])
def test_large_ones_past_the_random_limit_sit_on_a_lattice_that_holds_them(dim, n_small, n_large,
                                                                          packing, periodic):
    """1:10, the large ones alone past the densest random state (3D 0.545, 2D 0.75) but
    held by a lattice (FCC 3^3 cells, 108 sites; hexagonal 10 x 10): under auto they sit on
    it and the small ones are added at random among them (refused before: "only 108 lattice
    sites fit for 10908 particles"). A lattice that does not hold them is refused:
    test_a_mixture_too_dense_for_random_placement_is_refused_naming_why."""
    radii, length = _mixture(dim, n_small, n_large, 10.0, packing)
    large = radii > 1.0
    alone = _box(dim, radii[large], 1.0) ** dim / length ** dim
    assert alone > placement.RANDOM_LIMIT[dim] and placement.holds(dim, radii[large], length, periodic)
    x = placement.place(dim, radii, length, np.random.default_rng(5), "auto", periodic)
    assert_valid(x, radii, length, periodic)


def _box(dim, radii, packing):
    unit = {2: math.pi, 3: 4.0 * math.pi / 3.0}[dim]
    return (unit * float(np.sum(radii ** dim)) / packing) ** (1.0 / dim)


def test_a_mixture_too_dense_for_random_placement_is_refused_naming_why():
    """A 1:10 mixture at 0.6 in 3D: the large ones alone fill 0.545, past the densest random
    state, and a lattice spaced by the largest diameter holds 32 sites: refused, the message
    saying the lattice is spaced by the largest diameter (not only "lower --n")."""
    radii, length = _mixture(3, 4000, 40, 10.0, 0.6)
    with pytest.raises(PlacementError, match="spaces every particle by the largest diameter"):
        placement.place(3, radii, length, np.random.default_rng(1), "auto", True)
    with pytest.raises(PlacementError) as refused:  # and forced growth does not offer the lattice
        placement.place(3, radii, length, np.random.default_rng(1), "grow", True)
    assert "densest random state" in str(refused.value) and "lattice" not in str(refused.value)
