"""Random placement of mixtures: the largest particles go first, whatever the species order."""

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
