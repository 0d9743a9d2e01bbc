"""A scene's initial state: positions from the placement, velocities from Maxwell-Boltzmann
(or the explicit state, or the marbles' upper half, of a preset); a function of the scene and
its seed only, never of the engine.
"""

from __future__ import annotations

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import PlacementError
from gaz_cli.model.checks import field_error
from gaz_cli.model.scene import Scene, State


def maxwell_velocities(rng: np.random.Generator, masses: np.ndarray, dim: int,
                       temperature: float) -> np.ndarray:
    """(N, D) Maxwell-Boltzmann velocities: each component normal, variance k_B T / m."""
    sigma = np.sqrt(K_B * temperature / masses)
    return rng.standard_normal((masses.size, dim)) * sigma[:, None]


def initial_state(scene: Scene) -> State:
    """Positions and velocities of a scene; a function of the scene and its seed only.

    Positions come from :func:`gaz_cli.placement.place`, then velocities are
    drawn from the same generator. With periodic boundaries the total
    momentum is removed. A scene with ``initial`` (the presets) takes its state from there:
    explicit arrays, or the marbles' upper half (:func:`upper_half`).
    """
    if scene.seed is None:
        raise field_error("initial_state needs a seed; `seed` is None")
    rng = np.random.default_rng(scene.seed)
    if scene.initial is not None:
        if scene.initial["kind"] == "explicit":
            positions = np.array(scene.initial["positions"], dtype=np.float64)
            velocities = np.array(scene.initial["velocities"], dtype=np.float64)
        else:  # upper-half
            positions = upper_half(rng, scene.radii(), scene.length, scene.dim)
            velocities = rng.normal(0.0, scene.initial["velocity_sd"], size=(scene.n, scene.dim))
        return State(positions, velocities, scene.kinds())
    from gaz_cli import placement  # one way: placement imports geometry, never the scene

    positions = placement.place(scene.dim, scene.radii(), scene.length, rng,
                                method=scene.placement, periodic=scene.boundary == "periodic")
    masses = scene.masses()
    velocities = maxwell_velocities(rng, masses, scene.dim, scene.temperature)
    if scene.boundary == "periodic" and scene.n > 1:
        velocities -= (masses[:, None] * velocities).sum(axis=0) / masses.sum()
    return State(positions, velocities, scene.kinds())


def upper_half(rng: np.random.Generator, radii: np.ndarray, length: float, dim: int = 3) -> np.ndarray:
    """(N, D) non-overlapping centres in the upper half of the box (last axis in [L/2, L - R]).

    Random sequential addition with an O(N^2) check: meant for a few hundred dilute marbles
    (seed 002's preset).
    """
    n = radii.size
    out = np.empty((n, dim))
    k = 0
    for _ in range(1000 * n):
        if k == n:
            break
        r = radii[k]
        p = rng.uniform([r] * (dim - 1) + [0.5 * length], [length - r] * dim)
        if k == 0 or np.all(np.sum((out[:k] - p) ** 2, axis=1) >= (radii[:k] + r) ** 2):
            out[k] = p
            k += 1
    if k < n:
        raise PlacementError(f"could place only {k} of {n} particles in the upper half of the box")
    return out
