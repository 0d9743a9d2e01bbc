"""One simulation, described and validated: the scene.

A :class:`Scene` holds everything needed to reproduce a run (dimension, box,
species and counts, temperature, boundary, forces, duration, seed, engine,
what to record). :func:`initial_state` turns a scene into positions and
velocities; it depends on the scene and its seed only, never on the engine.
"""

from __future__ import annotations

import inspect
import math
import os
import sys
from dataclasses import dataclass, field, replace

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.species import Species

BOUNDARIES = ("walls", "periodic")
RECORD_LEVELS = ("none", "bounces", "all")

DENSEST = {1: 1.0, 2: math.pi / math.sqrt(12.0), 3: math.pi / math.sqrt(18.0)}
"""Close-packing fraction per dimension (rods, hexagonal disks, FCC spheres)."""

# --- what double precision carries through the formulas --------------------------------------
HEADROOM = 1e16
"""Margin kept below overflow and above underflow: sums over up to 10^16 terms (energies,
momenta) and a product or two beyond the ones checked stay finite and normal."""
HUGE = sys.float_info.max / HEADROOM
"""Largest value (about 1.8e292) a checked square or product may reach."""
TINY = sys.float_info.min * HEADROOM
"""Smallest nonzero value (about 2.2e-292) a checked square or product may reach: below
sys.float_info.min numbers lose precision (subnormal), then round to 0."""
SPEED_TAIL = 10.0
"""Largest speed considered, in units of sqrt(k_B T / m): a Maxwell sample of 10^20
particles stays below it."""
MAX_COUNT = 2 ** 63 - 1
"""Largest particle count: the engines index particles with int64."""

# --- work and memory -------------------------------------------------------------------------
MAX_EVENTS = 1e11
"""Largest estimated number of events (collisions + wall bounces) run without --force:
about a day at a million events a second."""
MAX_STEP_WORK = 1e11
"""Step engine: largest steps x particles (x N/2 more with pair gravity) run without --force."""
MAX_REFERENCE_WORK = 1e10
"""Reference engine (pure Python, every event shifts every particle's catalogue): largest
events x particles run without --force."""
MAX_SNAPSHOTS = 1e6
"""Largest number of trajectory snapshots written without --force."""
BYTES_PER_PARTICLE = {"event": 480, "step": 370, "reference": 700, "place": 90}
"""Peak memory per particle of a run (placement, state and the engine's arrays), bytes.

Measured as the growth of the peak resident memory between two runs (3D, packing 0.05,
walls, --record none; one process each): event engine 473 B (N = 2e5 -> 1e6: 230.5 ->
591.3 MiB), step engine 369 B (208.7 -> 490.1 MiB), placement alone 85 B (184.9 -> 249.7
MiB); reference engine about 700 B (N = 100 -> 1000: 126.8 -> 127.4 MiB). 1D and 2D need
less."""


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
    force: bool = False
    """Run even when the estimated work (events, steps, snapshots) is beyond its bound."""
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
    """Check a scene; raise :class:`SceneError` naming the problem and the fix.

    In order: dimension; counts, box, duration, temperature, masses and radii positive and
    within what double precision carries through the formulas (:func:`check_magnitudes`);
    boundary, recording, restitutions, gravity; packing fraction below close packing; the
    memory the run needs against this machine's (:func:`memory_needed`); unless
    ``scene.force``, the run's work (:func:`work_estimate`) below MAX_EVENTS (or the step
    and reference engines' bounds).
    """
    if scene.dim not in (1, 2, 3):
        raise SceneError(f"--dim {scene.dim} is not 1, 2 or 3")
    for sp, k in scene.components:
        check_count(k)
    _positive("--length", scene.length)
    _positive("--duration", scene.duration, " (simulated seconds)")
    _positive("--temperature", scene.temperature, " (kelvin)")
    if not scene.components:
        raise SceneError("no particles: give --n and --species (or --radius and --mass)")
    for sp, k in scene.components:
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
    check_magnitudes(scene)
    eta = scene.packing_fraction
    densest = DENSEST[scene.dim]
    if eta >= densest:
        what = {1: "the segment is full", 2: "the densest disk packing", 3: "the densest sphere packing"}
        raise SceneError(f"packing fraction {eta:.3g} is at or above {densest:.4g}, {what[scene.dim]}; "
                         "lower --n or raise --length")
    check_memory(scene.n, scene.engine, scene.dim)
    if not scene.force:
        check_work(scene)
    return scene


# --- the checks validate() composes --------------------------------------------------------------
def check_count(n) -> None:
    """A particle count is an integer in [1, MAX_COUNT]."""
    if n < 1:
        raise SceneError(f"--n must be at least 1, got {n}")
    if n > MAX_COUNT:
        raise SceneError(f"--n {n} is above {MAX_COUNT:.3g} (2^63 - 1), the largest count the "
                         "engines' int64 indices hold; lower --n")


def _outside(what: str, value: float, lo: float, hi: float, unit: str, why: str, fix: str) -> None:
    if not lo <= value <= hi:
        side = "below" if value < lo else "above"
        raise SceneError(f"{what} {value:.3g} {unit} is {side} the range [{lo:.2g}, {hi:.2g}] {unit} {why}; {fix}")


def length_range(dim: int) -> tuple[float, float]:
    """(lo, hi) box side, m: L^D and |dr|^2 within [TINY, HUGE]."""
    p = 1.0 / max(dim, 2)
    return TINY ** p, HUGE ** p


def radius_range() -> tuple[float, float]:
    """(lo, hi) nonzero radius, m: sigma^2 = (2R)^2 within [TINY, HUGE]."""
    return math.sqrt(TINY) / 2.0, math.sqrt(HUGE) / 2.0


def mass_range() -> tuple[float, float]:
    """(lo, hi) mass, kg: m_i m_j (the reduced mass m_i m_j / (m_i + m_j)) within [TINY, HUGE]."""
    return math.sqrt(TINY), math.sqrt(HUGE)


def speed_range(length: float, radii) -> tuple[float, float]:
    """(lo, hi) particle speed, m/s, that the pair and wall times carry in double precision.

    hi: v^2 and (L v)^2 (the |dr.dv|^2 of the pair-time discriminant) at most HUGE;
    lo: v^2 and (sigma v)^2 at least TINY, sigma the smallest nonzero diameter (else L).
    """
    sizes = [2.0 * r for r in radii if r > 0] or [length]
    return math.sqrt(TINY) / min(1.0, min(sizes)), math.sqrt(HUGE) / max(1.0, length)


def check_magnitudes(scene: Scene) -> None:
    """Box, radii, masses, temperature and gravity within what double precision carries.

    The ranges come from the formulas' squares and products: L^D, |dr|^2, sigma^2, m_i m_j,
    v^2, |dr.dv|^2 (see :data:`HUGE`, :data:`TINY`); speeds are the Maxwell tail
    SPEED_TAIL sqrt(k_B T / m) plus a fall across the box sqrt(2 g L).
    """
    lo, hi = length_range(scene.dim)
    _outside("--length", scene.length, lo, hi, "m",
             f"where L^{scene.dim} and |dr|^2 stay within double precision", "change --length")
    rlo, rhi = radius_range()
    mlo, mhi = mass_range()
    for sp, _ in scene.components:
        if sp.radius > 0:
            _outside(f"radius of {sp.name}", sp.radius, rlo, rhi, "m",
                     "where the contact distance squared stays within double precision",
                     "change the radius (or use 0 for point particles)")
        _outside(f"mass of {sp.name}", sp.mass, mlo, mhi, "kg",
                 "where m_i m_j (the reduced mass of a collision) stays within double precision",
                 "change the mass")
    vlo, vhi = speed_range(scene.length, [sp.radius for sp, _ in scene.components])
    masses = [sp.mass for sp, _ in scene.components]
    # k_B T / m between vlo^2 (heaviest) and (vhi / SPEED_TAIL)^2 (lightest)
    tlo, thi = max(masses) * vlo ** 2 / K_B, min(masses) * (vhi / SPEED_TAIL) ** 2 / K_B
    _outside("--temperature", scene.temperature, tlo, thi, "K",
             f"where the particles' speeds (times the box, {scene.length:.3g} m) stay within double "
             "precision", "change --temperature")
    ghi = (vhi / SPEED_TAIL) ** 2 / (2.0 * scene.length)
    if scene.gravity > ghi:
        _outside("--gravity", scene.gravity, 0.0, ghi, "m/s^2",
                 "where the speed of a fall across the box stays within double precision", "lower --gravity")


def physical_memory() -> int | None:
    """This machine's memory, bytes (None when the system does not say)."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def memory_needed(n: int, engine: str, dim: int = 3) -> float:
    """Peak memory, bytes, of placing and running ``n`` particles with ``engine`` ('place': placement only).

    BYTES_PER_PARTICLE[engine] x n, measured in 3D (the largest).
    """
    return BYTES_PER_PARTICLE.get(engine, BYTES_PER_PARTICLE["event"]) * float(n)


def _bytes(x: float) -> str:
    for unit, size in (("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if x >= size:
            return f"{x / size:.3g} {unit}"
    return f"{x:.0f} bytes"


def check_memory(n: int, engine: str, dim: int = 3) -> None:
    """Refuse, before any allocation, a run that needs more memory than this machine has."""
    have = physical_memory()
    need = memory_needed(n, engine, dim)
    if have is not None and need > have:
        raise SceneError(f"N = {n:.3g} needs about {_bytes(need)} of memory ({engine} engine); this "
                         f"machine has {_bytes(have)}; lower --n" if engine != "place" else
                         f"placing N = {n:.3g} particles needs about {_bytes(need)} of memory; this "
                         f"machine has {_bytes(have)}; lower --n")


def work_estimate(scene: Scene) -> dict:
    """The run's expected work: events per second and in all, steps, work units and their bound.

    Events: collisions N omega / 2 (Enskog, at the mean diameter and mass), wall bounces
    (theory.wall_hit_rate over the 2D walls; under gravity the floor is hit every 2 v / g,
    v = sqrt(k_B T / m)). Step engine: work = steps x N (x N / 2 with pair gravity);
    reference engine: events x N + N^2 (its initCat). Returns a dict: events_per_s, events,
    work, limit, what (the estimate in words), fix.

    Measured against the event engine (one run each): argon 3D, N = 1000, the README's scene
    0.99 of the events counted; reduced units 3D eta 0.3 walls 0.83, 2D 0.5 0.97, 1D 0.8 0.96,
    3D periodic 0.45 0.96; 2D eta 0.1 under gravity (g = 30, m = k_B T = 1, L = 1) 0.38.
    """
    from gaz_cli import theory

    n, dim, length = scene.n, scene.dim, scene.length
    radii, masses = scene.radii(), scene.masses()
    sigma, mass = 2.0 * float(radii.mean()), float(masses.mean())
    density = n / scene.volume
    rate = 0.0
    if n > 1 and sigma > 0:
        eta = min(scene.packing_fraction, 0.99 * DENSEST[dim])
        closed_form = {1: "tonks", 2: "henderson", 3: "carnahan-starling"}[dim]
        omega = float(theory.enskog_collision_frequency(dim, density * eta / scene.packing_fraction,
                                                        sigma, scene.temperature, mass, model=closed_form))
        rate += n * omega / 2.0
    if scene.boundary == "walls":
        rate += float(theory.wall_hit_rate(density, scene.temperature, mass)) * 2 * dim * length ** (dim - 1)
        if scene.gravity > 0:
            rate += n * scene.gravity / (2.0 * math.sqrt(K_B * scene.temperature / mass))
    events = rate * scene.duration
    if scene.engine == "step":
        steps = scene.duration / scene.dt if scene.dt else 0.0
        work = steps * n * (n / 2.0 if scene.pair_gravity > 0 else 1.0)
        pairs = scene.pair_gravity > 0
        return {"events_per_s": rate, "events": events, "steps": steps, "work": work, "limit": MAX_STEP_WORK,
                "what": f"{steps:.3g} steps x {n} particles" + (f" x {n / 2:g} pairs" if pairs else ""),
                "fix": "raise --dt, or lower --duration or --n"}
    if scene.engine == "reference":
        return {"events_per_s": rate, "events": events, "work": events * n + n * n, "limit": MAX_REFERENCE_WORK,
                "what": f"{events:.3g} events x {n} particles + {n}^2 for the initial catalogue (the "
                        "reference engine updates every particle's catalogue entry at each event)",
                "fix": "use --engine event, or lower --duration or --n"}
    return {"events_per_s": rate, "events": events, "work": events, "limit": MAX_EVENTS,
            "what": f"{events:.3g} events ({rate:.3g} per simulated second over {scene.duration:.3g} s)",
            "fix": "lower --duration, --n, --temperature" + (" or --gravity" if scene.gravity > 0 else "")}


def check_work(scene: Scene) -> None:
    """Refuse a run whose estimated work is beyond its bound (unless scene.force)."""
    est = work_estimate(scene)
    if not est["work"] <= est["limit"]:
        raise SceneError(f"this run would take about {est['what']}, beyond the {est['limit']:.0e} allowed "
                         f"without --force; {est['fix']}, or add --force to run it anyway")


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
                 print_every=0, planes=(), preset=None, force=False):
    """Build and validate a Scene from command-line options; returns (scene, state or None).

    With ``preset`` the scene and its initial state come from
    :mod:`gaz_cli.stepper.presets`, made with the given seed (and count, for presets that take
    one); duration, dt, print_every and force override the preset's; options that a preset
    fixes (dimension, box, species) are refused, never silently ignored. ``force``: run even when the estimated work is beyond
    its bound (see :func:`check_work`).
    """
    from gaz_cli.species import DEFAULT_SPECIES, Species, lookup, parse_mixture

    if preset is not None:
        from gaz_cli.stepper.presets import PRESETS

        if preset not in PRESETS:
            raise SceneError(f"--preset {preset!r} is not one of {', '.join(PRESETS)}")
        fixed = [flag for flag, value in (("--dim", dim), ("--length", length), ("--species", species),
                                          ("--radius", radius), ("--mass", mass)) if value is not None]
        factory = PRESETS[preset]
        takes = inspect.signature(factory).parameters
        if n is not None and "n" not in takes:
            fixed.insert(0, "--n")
        if fixed:
            raise SceneError(f"--preset {preset} sets {', '.join(fixed)} itself; drop "
                             f"{'it' if len(fixed) == 1 else 'them'}, or describe the scene "
                             "with options instead of a preset")
        made = {k: v for k, v in (("n", n), ("seed", seed)) if v is not None}
        scene, state = factory(**made)  # placed with the seed the database records
        changes = {k: v for k, v in (("duration", duration), ("dt", dt)) if v is not None}
        changes["force"] = bool(force)
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
                  planes=plane_tuples, print_every=int(print_every), force=bool(force))
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


def check_outputs(scene: Scene, trajectory=None, every=None) -> None:
    """Check a run's trajectory request against its scene; raise SceneError naming the fix.

    The engine must write snapshots (the reference engine does not); ``every`` must be a
    positive number of simulated seconds; unless ``scene.force``, at most MAX_SNAPSHOTS
    snapshots and a file smaller than the free space of its disk.
    """
    if not trajectory:
        return
    from gaz_cli.trajectory import FORMATS

    suffix = os.path.splitext(str(trajectory))[1].lower()
    if suffix not in FORMATS:
        raise SceneError(f"--trajectory {str(trajectory)!r}: unknown extension {suffix!r}; "
                         "use .h5 (HDF5/H5MD) or .pvd (VTK for ParaView)")
    if scene.engine == "reference":
        raise SceneError("--engine reference (the exam's algorithm) writes no trajectory; "
                         "use --engine event with --trajectory")
    if every is None:
        raise SceneError("--trajectory needs --every DT, the simulated time between snapshots (s)")
    if not (math.isfinite(every) and every > 0):
        raise SceneError(f"--every must be a positive number of simulated seconds, got {every}")
    snapshots = math.floor(scene.duration / every) + 1
    if scene.force:
        return
    if snapshots > MAX_SNAPSHOTS:
        raise SceneError(f"--every {every:g} s over --duration {scene.duration:g} s makes {snapshots:.3g} "
                         f"snapshots, more than the {MAX_SNAPSHOTS:.0e} allowed without --force; raise "
                         "--every, or add --force to write them anyway")
    size = snapshots * scene.n * scene.dim * 16.0
    try:
        import shutil

        free = shutil.disk_usage(os.path.dirname(os.path.abspath(str(trajectory)))).free
    except OSError:
        return
    if size > free:
        raise SceneError(f"--trajectory {str(trajectory)!r} would take about {_bytes(size)} "
                         f"({snapshots:.3g} snapshots of {scene.n} particles); its disk has {_bytes(free)} "
                         "free; raise --every or free some space (or add --force)")


def check_placement(dim: int, n: int, radius: float, length: float) -> None:
    """The door of ``gaz place``: count, radius and box in range, memory, before any allocation."""
    if dim not in (1, 2, 3):
        raise SceneError(f"--dim {dim} is not 1, 2 or 3")
    check_count(n)
    _positive("--radius", radius, " (m)")
    _positive("--length", length, " (m)")
    lo, hi = length_range(dim)
    _outside("--length", length, lo, hi, "m", f"where L^{dim} and |dr|^2 stay within double precision",
             "change --length")
    rlo, rhi = radius_range()
    _outside("--radius", radius, rlo, rhi, "m", "where the contact distance squared stays within double "
             "precision", "change --radius")
    check_memory(n, "place", dim)
