"""Initial positions: fast, reproducible, with bounded effort.

Methods
-------
rapid      1D only: the exam's Q10 algorithm vectorised; exactly uniform over
           non-overlapping configurations, O(N log N), any packing below 1.
rejection  random sequential addition with a cell grid (2D/3D, or 1D): each
           candidate is tested against the particles of the neighbouring cells
           only, O(N) on average. Gives up after a bounded number of
           candidates (the exam's Q7 situation) with a PlacementError.
lattice    particles on the densest simple lattice that fits (square or
           hexagonal rows in 2D, FCC in 3D), sites chosen at random; up to
           close packing (2D 0.9069, 3D 0.7405, less in a small box).
grow       Lubachevsky-Stillinger: random points grow into the particles
           while moving, event by event; a random dense state up to the
           liquid's limit (2D area fraction 0.70, 3D packing 0.50). 1D: rapid.
auto       rapid in 1D; rejection while the packing is comfortably below the
           random-sequential-addition jamming limit; grow up to the random
           limit; lattice above it.

A mixture of sizes far apart (2D/3D, radii at least 8 times apart, or 3 when the large
ones are not dense: :mod:`.mixture`) is placed in two steps, by rejection or growth: the
large particles alone, then the small ones around them, held fixed, on a grid sized for the
small ones; ``auto`` (and ``grow``) then also go past RANDOM_LIMIT when each step stays
within it, and ``auto`` when the large ones alone, past it, fit a lattice (the small ones
then placed at random among the lattice's large ones).

Beyond what a method can reach the answer is an error naming the way out,
after a bounded effort, never a hang.

Candidates are drawn in batches from the caller's numpy Generator, so a seed
gives the same positions on every machine and for every engine.
"""

from __future__ import annotations

import importlib
import math

import numpy as np

from gaz_cli.errors import PlacementError, SceneError
from gaz_cli.geometry import packing_fraction
from gaz_cli.placement import mixture
from gaz_cli.placement.lattice import LATTICE_LIMIT, holds, lattice
from gaz_cli.placement.rsa import INTERPRETED_MAX, INTERPRETED_PACKING, rapid_1d, rejection

_COMPILED = {"GROWTH_RATE": "growth", "grow": "growth", "first_overlap": "overlaps",
             "growth": "growth", "overlaps": "overlaps"}
"""Names from the modules of compiled methods, imported at their first use: these modules
import Numba and the engine's kernels, which a tiny run placed by the interpreted addition
never needs (Numba's import is most of ``import numpy, numba``: issue 15's start-up)."""


def __getattr__(name: str):
    if name not in _COMPILED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module = importlib.import_module(f"{__name__}.{_COMPILED[name]}")
    return module if name == _COMPILED[name] else getattr(module, name)


__all__ = ["METHODS", "RSA_COMFORT", "RANDOM_LIMIT", "LATTICE_LIMIT", "GROWTH_RATE",
           "INTERPRETED_MAX", "INTERPRETED_PACKING", "place", "place_unhinted", "first_overlap",
           "rapid_1d", "rejection", "lattice", "holds", "grow"]

METHODS = ("auto", "rejection", "rapid", "lattice", "grow")

RSA_COMFORT = {1: 0.60, 2: 0.45, 3: 0.30}
"""Packing below which 'auto' uses rejection (RSA jamming: 0.7476, 0.547, 0.384)."""

RANDOM_LIMIT = {2: 0.70, 3: 0.50}
"""Densest random (grown) packing offered: beyond, a lattice start (2D liquid ends near 0.70,
3D freezing at 0.494; growth goes further only by jamming into a glass)."""


def place(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
          method: str = "auto", periodic: bool = False) -> np.ndarray:
    """(N, D) float64 centres, m, of particles of ``radii`` in [0, length]^D.

    With hard walls every centre is at least its radius from each wall; with
    ``periodic`` the box wraps and distances are minimum-image. A
    :class:`PlacementError` names ``--method lattice`` as a way out only when a lattice
    holds every particle (:func:`.lattice.holds`: a mixture's lattice is spaced by its
    largest diameter, and often holds too few sites).
    """
    try:
        return place_unhinted(dim, radii, length, rng, method, periodic)
    except PlacementError as e:
        radii = np.asarray(radii, dtype=np.float64)
        if method == "lattice" or not holds(dim, radii, length, periodic):
            raise
        raise PlacementError(f"{e}, or use --method lattice (its sites hold all {radii.size})") from None


def place_unhinted(dim: int, radii: np.ndarray, length: float, rng: np.random.Generator,
                   method: str = "auto", periodic: bool = False) -> np.ndarray:
    """:func:`place`, its errors without the lattice's way out (for a mixture's large
    particles, whose lattice says nothing of the whole mixture's)."""
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    n = radii.size
    if method not in METHODS:
        raise SceneError(f"--method {method!r} is not one of {', '.join(METHODS)}")
    if dim not in (1, 2, 3):
        raise SceneError(f"--dim {dim} is not 1, 2 or 3")
    if not (length > 0 and math.isfinite(length)):
        raise SceneError(f"--length must be a positive number, got {length}")
    if n == 0:
        return np.zeros((0, dim))
    if method == "rapid" and dim != 1:
        raise SceneError("--method rapid works in 1D only (the exam's Q10); use rejection, grow or lattice")
    eta = packing_fraction(dim, radii, length)
    if dim == 1 and method in ("auto", "grow"):
        method = "rapid"
    chosen_by_auto = method == "auto"
    small = mixture.split(dim, radii, length)
    # two steps reach further than one when the large ones pack alone and the small ones
    # grow in the room they leave (a 1:10 mixture at 0.55 in 3D)
    in_two = small is not None and mixture.two_steps_fit(dim, radii, small, length, method, periodic)
    if method == "auto":
        if eta <= RSA_COMFORT[dim]:
            method = "rejection"
        elif eta <= RANDOM_LIMIT[dim] * (1 + 1e-9) or in_two:
            method = "grow"
        else:
            method = "lattice"
    if method == "grow" and eta > RANDOM_LIMIT[dim] * (1 + 1e-9) and not in_two:
        raise PlacementError(
            f"packing fraction {eta:.3g} is above {RANDOM_LIMIT[dim]}, the densest random state "
            f"offered in {dim}D; lower --n or raise --length")
    if method == "lattice" and eta > LATTICE_LIMIT[dim] * (1 + 1e-9):
        raise PlacementError(
            f"packing fraction {eta:.3g} is above {LATTICE_LIMIT[dim]}, close packing in {dim}D; "
            "lower --n or raise --length")
    if method == "rapid":
        return rapid_1d(radii, length, rng, periodic)
    if method == "lattice":
        return lattice(dim, radii, length, rng, periodic)
    if method == "rejection" and n <= INTERPRETED_MAX and eta <= INTERPRETED_PACKING:
        small = None  # a tiny dilute scene: one grid, interpreted, no compiled code to load
    if small is not None or method == "grow":
        from gaz_cli.placement.overlaps import first_overlap

        positions = None
        if small is not None:  # sizes far apart: the large ones first, then the small ones
            try:
                positions = mixture.place(dim, radii, length, rng, method, periodic, small,
                                          chosen_by_auto)
            except PlacementError:
                if not chosen_by_auto:
                    raise
                method = "grow" if eta > RSA_COMFORT[dim] else "rejection"  # all in one step
        if positions is None and method == "rejection":
            return rejection(dim, radii, length, rng, periodic)
        if positions is None:
            from gaz_cli.placement.growth import grow

            positions = grow(dim, radii, length, rng, periodic)
        if first_overlap(positions, radii, length, periodic) < 0:
            return positions
        if chosen_by_auto:
            # a rare growth failure must not reach an engine: a lattice start is always valid
            return lattice(dim, radii, length, rng, periodic)
        raise PlacementError("growth left overlapping particles (a known rare failure of --method "
                             "grow); use another --seed")
    return rejection(dim, radii, length, rng, periodic)
