"""Geometry of balls in a box: one copy of each formula.

A leaf module (numpy and math only): the scene, placement, the engines, theory and the
analysis all take their ball volume, densest packing and packing fraction from here.
"""

from __future__ import annotations

import math

import numpy as np

UNIT_BALL = {1: 2.0, 2: math.pi, 3: 4.0 * math.pi / 3.0}
"""Volume of the unit D-ball (length in 1D, area in 2D)."""

DENSEST = {1: 1.0, 2: math.pi / math.sqrt(12.0), 3: math.pi / math.sqrt(18.0)}
"""Close-packing fraction per dimension (rods, hexagonal disks, FCC spheres)."""

DENSEST_NAME = {1: "the segment is full", 2: "the densest disk packing", 3: "the densest sphere packing"}
"""What reaching :data:`DENSEST` means, per dimension (for messages)."""


def ball_volume(dim: int, radius):
    """Volume of a D-ball of ``radius`` (length in 1D, area in 2D); an array for an array."""
    return UNIT_BALL[dim] * np.asarray(radius) ** dim


def packing_fraction(dim: int, radii, length: float, counts=1) -> float:
    """Fraction of the box [0, length]^dim covered by balls of ``radii``, ``counts`` of each.

    ``radii`` and ``counts`` broadcast: per-particle radii with counts 1, or one radius per
    species with its count.
    """
    return float(np.sum(np.asarray(counts) * ball_volume(dim, radii)) / length ** dim)
