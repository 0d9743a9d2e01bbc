"""One simulation, described and validated: the scene.

A :class:`Scene` holds everything needed to reproduce a run (dimension, box,
species and counts, temperature, boundary, forces, duration, seed, engine,
what to record). :func:`initial_state` turns a scene into positions and
velocities; it depends on the scene and its seed only, never on the engine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.species import Species

BOUNDARIES = ("walls", "periodic")
RECORD_LEVELS = ("none", "bounces", "all")

DENSEST = {1: 1.0, 2: math.pi / math.sqrt(12.0), 3: math.pi / math.sqrt(18.0)}
"""Close-packing fraction per dimension (rods, hexagonal disks, FCC spheres)."""


def ball_volume(dim: int, radius):
    """Volume of a D-ball of ``radius`` (length in 1D, area in 2D)."""
    return {1: 2.0, 2: math.pi, 3: 4.0 * math.pi / 3.0}[dim] * np.asarray(radius) ** dim


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
    engine: str = "event"
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
    extras: dict = field(default_factory=dict, compare=False)

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

    @property
    def volume(self) -> float:
        """Box volume L^D (length in 1D, area in 2D), m^D."""
        return self.length ** self.dim

    @property
    def packing_fraction(self) -> float:
        """Fraction of the box covered by the particles (eta)."""
        return float(sum(k * ball_volume(self.dim, s.radius) for s, k in self.components)
                     / self.volume)

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


def _positive(name: str, value, hint: str = "") -> None:
    if value is None or not np.isfinite(value) or value <= 0:
        raise SceneError(f"{name} must be a positive number, got {value}{hint}")


def validate(scene: Scene) -> Scene:
    """Check a scene; raise :class:`SceneError` naming the problem and the fix."""
    if scene.dim not in (1, 2, 3):
        raise SceneError(f"--dim {scene.dim} is not 1, 2 or 3")
    _positive("--length", scene.length)
    _positive("--duration", scene.duration, " (simulated seconds)")
    _positive("--temperature", scene.temperature, " (kelvin)")
    if not scene.components:
        raise SceneError("no particles: give --n and --species (or --radius and --mass)")
    for sp, k in scene.components:
        if k <= 0:
            raise SceneError(f"--n must be at least 1, got {k}")
        _positive(f"mass of {sp.name}", sp.mass, " (kg)")
        if not np.isfinite(sp.radius) or sp.radius < 0:
            raise SceneError(f"radius of {sp.name} must be >= 0, got {sp.radius}")
        if 2 * sp.radius >= scene.length:
            raise SceneError(f"a {sp.name} particle (diameter {2 * sp.radius:g} m) does not fit in "
                             f"the box of side {scene.length:g} m; raise --length")
    if scene.boundary not in BOUNDARIES:
        raise SceneError(f"--boundary {scene.boundary!r} is not one of {', '.join(BOUNDARIES)}")
    if scene.record not in RECORD_LEVELS:
        raise SceneError(f"--record {scene.record!r} is not one of {', '.join(RECORD_LEVELS)}")
    if not 0.0 <= scene.restitution <= 1.0:
        raise SceneError(f"--restitution {scene.restitution} is outside [0, 1]")
    if not 0.0 <= scene.wall_restitution <= 1.0:
        raise SceneError(f"--wall-restitution {scene.wall_restitution} is outside [0, 1]")
    if not np.isfinite(scene.gravity) or scene.gravity < 0:
        raise SceneError(f"--gravity {scene.gravity} must be >= 0 (m/s^2, pulling towards -axis {scene.dim - 1})")
    if scene.gravity > 0 and scene.boundary == "periodic":
        raise SceneError("--gravity needs hard walls; drop --boundary periodic")
    if scene.seed is not None and not 0 <= scene.seed < 2 ** 63:
        raise SceneError(f"--seed {scene.seed} must be between 0 and 2^63 - 1")
    eta = scene.packing_fraction
    densest = DENSEST[scene.dim]
    if eta >= densest:
        what = {1: "the segment is full", 2: "the densest disk packing", 3: "the densest sphere packing"}
        raise SceneError(f"packing fraction {eta:.3g} is at or above {densest:.4g}, {what[scene.dim]}; "
                         "lower --n or raise --length")
    return scene


def maxwell_velocities(rng: np.random.Generator, masses: np.ndarray, dim: int,
                       temperature: float) -> np.ndarray:
    """(N, D) Maxwell-Boltzmann velocities: each component normal, variance k_B T / m."""
    sigma = np.sqrt(K_B * temperature / masses)
    return rng.standard_normal((masses.size, dim)) * sigma[:, None]


def initial_state(scene: Scene) -> State:
    """Positions and velocities of a scene; a function of the scene and its seed only.

    Positions come from :func:`gaz_cli.placement.place`, then velocities are
    drawn from the same generator. With periodic boundaries the total
    momentum is removed.
    """
    from gaz_cli import placement

    if scene.seed is None:
        raise SceneError("initial_state needs a seed; Scene.seed is None")
    rng = np.random.default_rng(scene.seed)
    positions = placement.place(scene.dim, scene.radii(), scene.length, rng,
                                method=scene.placement, periodic=scene.boundary == "periodic")
    masses = scene.masses()
    velocities = maxwell_velocities(rng, masses, scene.dim, scene.temperature)
    if scene.boundary == "periodic" and scene.n > 1:
        velocities -= (masses[:, None] * velocities).sum(axis=0) / masses.sum()
    return State(positions, velocities, scene.kinds())


def fresh_seed() -> int:
    """A random seed from the operating system, to be recorded so the run can be repeated."""
    return int(np.random.SeedSequence().generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


def parse_plane(text: str, dim: int) -> tuple:
    """Parse ``--plane X,Y[,Z]:NX,NY[,NZ][:E]`` into (point, unit inward normal, restitution)."""
    parts = text.split(":")
    try:
        point = tuple(float(v) for v in parts[0].split(","))
        normal = tuple(float(v) for v in parts[1].split(","))
        restitution = float(parts[2]) if len(parts) > 2 else 1.0
    except (IndexError, ValueError):
        raise SceneError(f"--plane {text!r} is not X,Y[,Z]:NX,NY[,NZ][:E]") from None
    if len(point) != dim or len(normal) != dim or len(parts) > 3:
        raise SceneError(f"--plane {text!r} needs {dim} coordinates for the point and the normal")
    norm = math.sqrt(sum(c * c for c in normal))
    if norm == 0 or not math.isfinite(norm):
        raise SceneError(f"--plane {text!r} has a zero normal")
    if not 0.0 <= restitution <= 1.0:
        raise SceneError(f"--plane {text!r}: restitution {restitution} is outside [0, 1]")
    return point, tuple(c / norm for c in normal), restitution


def from_options(*, dim=None, n=None, length=None, duration=None, species=None, radius=None,
                 mass=None, temperature=300.0, seed=None, engine="event", boundary="walls",
                 gravity=0.0, restitution=1.0, tc=None, record="bounces", placement="auto",
                 dt=None, drag=0.0, pair_gravity=0.0, softening=0.0, wall_restitution=1.0,
                 print_every=0, planes=(), preset=None):
    """Build and validate a Scene from command-line options; returns (scene, state or None).

    With ``preset`` the scene and its initial state come from
    :mod:`gaz_cli.stepper.presets`; the options given override the preset's duration, dt,
    seed, and print_every only.
    """
    from gaz_cli.species import DEFAULT_SPECIES, Species, lookup, parse_mixture

    if preset is not None:
        from gaz_cli.stepper.presets import PRESETS

        if preset not in PRESETS:
            raise SceneError(f"--preset {preset!r} is not one of {', '.join(PRESETS)}")
        scene, state = PRESETS[preset]()
        changes = {k: v for k, v in (("duration", duration), ("dt", dt), ("seed", seed)) if v is not None}
        if print_every:
            changes["print_every"] = print_every
        return validate(replace(scene, **changes)), state
    missing = [name for name, value in (("--dim", dim), ("--length", length), ("--duration", duration))
               if value is None]
    if missing:
        raise SceneError(f"missing {', '.join(missing)}; e.g. gaz simulate --dim 3 --n 1000 "
                         "--length 1e-7 --duration 1e-9")
    if (radius is None) != (mass is None):
        raise SceneError("--radius and --mass go together (a custom particle); or use --species")
    if radius is not None:
        if species is not None:
            raise SceneError("give either --species or --radius with --mass, not both")
        if n is None:
            raise SceneError("--n is required with --radius and --mass")
        components = ((Species("custom", float(mass), float(radius)), int(n)),)
    else:
        if species is None:
            if n is None:
                raise SceneError("--n is required (or give counts, e.g. --species Ar:500,He:500)")
            components = ((lookup(DEFAULT_SPECIES), int(n)),)
        else:
            components = tuple(parse_mixture(species, n))
    if dim not in (1, 2, 3):
        raise SceneError(f"--dim {dim} is not 1, 2 or 3")
    if engine == "step" and dt is None:
        raise SceneError("--engine step needs a time step --dt (seconds)")
    if engine != "step":
        used = [name for name, value, default in (("--dt", dt, None), ("--drag", drag, 0.0),
                                                   ("--pair-gravity", pair_gravity, 0.0),
                                                   ("--plane", planes, ()), ("--wall-restitution", wall_restitution, 1.0))
                if value not in (default, None) and value != default]
        if used:
            raise SceneError(f"{used[0]} applies to --engine step only; add --engine step")
    plane_tuples = tuple(parse_plane(p, dim) for p in planes)
    scene = Scene(dim=int(dim), length=float(length), duration=float(duration),
                  components=components, temperature=float(temperature), seed=seed,
                  boundary=boundary, gravity=float(gravity), restitution=float(restitution),
                  tc=0.0 if tc is None else float(tc), engine=engine, placement=placement,
                  record=record, dt=dt, drag=float(drag), pair_gravity=float(pair_gravity),
                  softening=float(softening), wall_restitution=float(wall_restitution),
                  planes=plane_tuples, print_every=int(print_every))
    scene = validate(scene)
    if tc is None and scene.restitution < 1.0:
        scene = replace(scene, tc=default_tc(scene))
    if scene.dt is not None and not (math.isfinite(scene.dt) and scene.dt > 0):
        raise SceneError(f"--dt must be a positive number of seconds, got {scene.dt}")
    for name, value in (("--drag", scene.drag), ("--pair-gravity", scene.pair_gravity),
                        ("--softening", scene.softening), ("--tc", scene.tc)):
        if not math.isfinite(value) or value < 0:
            raise SceneError(f"{name} must be >= 0, got {value}")
    return scene, None


def default_tc(scene: Scene) -> float:
    """TC-model contact time: 1e-4 of the mean free time 1/omega (Enskog, closed-form EOS)."""
    from gaz_cli import theory

    sigma = 2.0 * float(scene.radii().mean())
    if sigma == 0:
        return 0.0
    closed_form = {1: "tonks", 2: "henderson", 3: "carnahan-starling"}[scene.dim]
    omega = theory.enskog_collision_frequency(scene.dim, scene.n / scene.volume, sigma, scene.temperature,
                                              float(scene.masses().mean()), model=closed_form)
    return 1e-4 / float(omega)
