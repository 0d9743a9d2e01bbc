"""What one run is: the :class:`Scene` (everything that defines it) and the :class:`State`
(positions and velocities). A description with no engine, no disk and no check beyond its
types: the scene is admitted by the one door, :func:`gaz_cli.scenes.validate.validate`, and
turned into a state by :func:`gaz_cli.placement.initial.initial_state`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from gaz_cli.geometry import packing_fraction
from gaz_cli.model.species import Species

ENGINES = ("auto", "event", "ideal", "reference", "step")
"""What a scene's ``engine`` may say (the registry, :mod:`gaz_cli.engines.registry`, runs each
name but 'auto', which the door resolves)."""

BOUNDARIES = ("walls", "periodic")

RECORD_LEVELS = ("none", "bounces", "all")

PLACEMENTS = ("auto", "rejection", "rapid", "lattice", "grow")
"""Placement methods (gaz_cli.placement.METHODS; placement is not imported here)."""

INITIAL_KINDS = ("explicit", "upper-half")
"""Initial states other than placement + Maxwell velocities (Scene.initial['kind'])."""

STEP_ONLY = {"dt": None, "drag": 0.0, "pair_gravity": 0.0, "softening": 0.0, "wall_restitution": 1.0,
             "planes": (), "print_every": 0}
"""The step engine's options and their values when they do not apply (other engines)."""


@dataclass(frozen=True)


class Scene:
    """Everything that defines one run. SI units throughout.

    ``components`` is a tuple of (Species, count); particle i belongs to the
    component whose block contains i (blocks in the order given).
    """

    dim: int
    length: float
    duration: float
    components: tuple
    temperature: float = 300.0
    seed: int | None = None
    boundary: str = "walls"
    gravity: float = 0.0
    restitution: float = 1.0
    tc: float = 0.0
    engine: str = "auto"
    placement: str = "auto"
    record: str = "bounces"
    # time-stepped engine only
    dt: float | None = None
    drag: float = 0.0
    pair_gravity: float = 0.0
    softening: float = 0.0
    wall_restitution: float = 1.0
    planes: tuple = ()
    """Extra walls for the step engine: tuples (point (D,), inward normal (D,), restitution)."""
    print_every: int = 0
    """Step engine: diagnostics every this many steps (0: none)."""
    force: bool = False
    """Run even when the estimated work (events, steps, snapshots) is beyond its bound."""
    initial: dict | None = field(default=None, hash=False)
    """An initial state other than placement + Maxwell velocities: {'kind': 'explicit',
    'positions': (N, D), 'velocities': (N, D)} or {'kind': 'upper-half', 'velocity_sd': s}
    (random sequential addition in the upper half of the box along the last axis, velocity
    components normal with standard deviation s m/s, the marbles of seed 002)."""
    extras: dict = field(default_factory=dict, compare=False)
    """Settings beside the physics. What a caller may set: how the event engine searches for
    partners (:data:`SEARCH`: 'neighbours', 'skin', 'classes'). Every search is exact, but
    each rounds differently and a gas is chaotic: with the same seed, cells and neighbour
    lists give the same numbers of events and different rows (times, speeds in the last
    digits, then the events themselves), so the scene file keeps the search the run took (its
    ``[search]`` table: the ones set, and the ones left on 'auto' as the runner resolved them,
    :func:`gaz_cli.run.runner.with_search`) and reproduces the run. What :func:`validate` adds
    ('engine_reason', 'engine_auto') is derived and not stored."""

    # --- derived quantities -------------------------------------------------
    @property
    def n(self) -> int:
        """Total number of particles."""
        return sum(k for _, k in self.components)

    @property
    def species(self) -> list[Species]:
        """The species in component order."""
        return [s for s, _ in self.components]

    def kinds(self) -> np.ndarray:
        """(N,) int64: index of each particle's species in :attr:`species`."""
        return np.repeat(np.arange(len(self.components)), [k for _, k in self.components])

    def masses(self) -> np.ndarray:
        """(N,) float64, kg."""
        return np.array([s.mass for s in self.species])[self.kinds()]

    def radii(self) -> np.ndarray:
        """(N,) float64, m."""
        return np.array([s.radius for s in self.species])[self.kinds()]

    def mean_mass(self) -> float:
        """Mean mass of a particle, kg: from the species and their counts, no (N,) array (the
        checks at the door of a run of 10^9 particles allocate nothing per particle)."""
        return sum(s.mass * k for s, k in self.components) / self.n

    def mean_radius(self) -> float:
        """Mean radius of a particle, m (as :meth:`mean_mass`)."""
        return sum(s.radius * k for s, k in self.components) / self.n

    @property
    def volume(self) -> float:
        """Box volume L^D (length in 1D, area in 2D), m^D."""
        return self.length ** self.dim

    @property
    def packing_fraction(self) -> float:
        """Fraction of the box covered by the particles (eta)."""
        return packing_fraction(self.dim, [s.radius for s, _ in self.components], self.length,
                                [k for _, k in self.components])

    def with_seed(self, seed: int) -> "Scene":
        return replace(self, seed=seed)


@dataclass


class State:
    """Positions (N, D) m, velocities (N, D) m/s and species index (N,) of every particle."""

    positions: np.ndarray
    velocities: np.ndarray
    kinds: np.ndarray

    def kinetic_energy(self, masses: np.ndarray) -> float:
        """Total kinetic energy, J."""
        return float(0.5 * np.sum(masses * np.sum(self.velocities ** 2, axis=1)))

    def copy(self) -> "State":
        return State(self.positions.copy(), self.velocities.copy(), self.kinds.copy())


def fresh_seed() -> int:
    """A random seed from the operating system, to be recorded so the run can be repeated."""
    return int(np.random.SeedSequence().generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))
