"""One simulation, described and validated: the scene.

A :class:`Scene` holds everything needed to reproduce a run (dimension, box,
species and counts, temperature, boundary, forces, duration, seed, engine,
what to record). :func:`initial_state` turns a scene into positions and
velocities; it depends on the scene and its seed only, never on the engine.
"""

from __future__ import annotations

import math
import numbers
import os
import re
import sys
from dataclasses import MISSING, dataclass, field, fields, replace

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.engines.registry import CHOICES as ENGINES  # what `engine` may say; validate resolves "auto"
from gaz_cli.errors import SceneError
from gaz_cli.geometry import DENSEST, DENSEST_NAME, ball_volume, packing_fraction  # noqa: F401 (re-exported)
from gaz_cli.model.species import NAME_MAX, NAME_SEPARATORS, Species, builtin_named

BOUNDARIES = ("walls", "periodic")
RECORD_LEVELS = ("none", "bounces", "all")
PLACEMENTS = ("auto", "rejection", "rapid", "lattice", "grow")
"""Placement methods (gaz_cli.placement.METHODS; placement is not imported here)."""
INITIAL_KINDS = ("explicit", "upper-half")
"""Initial states other than placement + Maxwell velocities (Scene.initial['kind'])."""
STEP_ONLY = {"dt": None, "drag": 0.0, "pair_gravity": 0.0, "softening": 0.0, "wall_restitution": 1.0,
             "planes": (), "print_every": 0}
"""The step engine's options and their values when they do not apply (other engines)."""

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
NARROW_BOX = 0.1
"""A box is narrow when a particle's centre moves in less than this fraction of it (L - 2R < 0.1 L):
its wall bounces come L / (L - 2R) > 10 times as often as a point's, and a box 10 % longer
more than doubles the free length, halving them. The work refusal then says to raise `length`."""
MAX_STEP_WORK = 1e11
"""Step engine: largest steps x particles (x N/2 more with pair gravity) run without --force."""
MAX_REFERENCE_WORK = 1e10
"""Reference engine (pure Python, every event shifts every particle's catalogue): largest
events x particles run without --force."""
BYTES_PER_ROW = {"bounces": 47, "collisions": 53}
"""Growth of a SQLite database per recorded row, bytes: a REBOND row 46.6 (1,026,501 bounces
of one argon rod, 1D, L = 3.6e-10 m: 45 kB -> 47.8 MB), a CHOC row 53.1 (798,800
collisions, 2000 argon atoms, 3D periodic, packing 0.22: 45 kB -> 42.5 MB). The disk holds
more than that while a run commits: see :func:`database_peak`."""
STAGED_BYTES_PER_ROW = {"bounces": 71, "collisions": 62}
"""Size of a row in the scratch file a run of more than :data:`gaz_cli.results.staging.MEMORY_ROWS`
rows stages beside the database until its commit, bytes: a REBOND row 70.7 (256,694 bounces,
20 argon disks, L = 1e-7 m, 3e-6 s: 18.2 MB), a CHOC row 61.3 (67,187 collisions, 2000 argon
atoms, 3D periodic, packing 0.2: 4.1 MB); staging.MEMORY_ROWS lowered to 1000 for both."""
MAX_SNAPSHOTS = 10_000
"""Most trajectory snapshots written without `force` (a run of 10^6 particles at that
is 0.5 TB of H5MD)."""
BYTES_PER_PARTICLE = {"event": 480, "step": 370, "reference": 700, "ideal": 200, "place": 90}
"""Peak memory per particle of a run (placement, state and the engine's arrays), bytes.

Measured as the growth of the peak resident memory between two runs (3D, packing 0.05,
walls, --record none; one process each): event engine 473 B (N = 2e5 -> 1e6: 230.5 ->
591.3 MiB), step engine 369 B (208.7 -> 490.1 MiB), placement alone 85 B (184.9 -> 249.7
MiB); reference engine about 700 B (N = 100 -> 1000: 126.8 -> 127.4 MiB). 1D and 2D need
less."""


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

    def __repr__(self) -> str:
        """One line: the fields that differ from their defaults, the species as ``name x count``,
        an initial state by its kind and size (never its arrays), the planes counted, no extras."""
        parts = []
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "extras" or (f.default is not MISSING and value is f.default) \
                    or (f.default is not MISSING and not isinstance(value, (dict, tuple)) and value == f.default):
                continue
            if f.name == "components":
                text = " + ".join(f"{s.name} x {k}" for s, k in value)
            elif f.name == "initial":
                kind = value.get("kind")
                text = f"{kind} ({len(value['positions'])} positions)" if "positions" in value else repr(kind)
            elif f.name == "planes":
                text = f"{len(value)} plane{'s' if len(value) != 1 else ''}"
            else:
                text = repr(value)
            parts.append(f"{f.name}={text}")
        return f"Scene({', '.join(parts)})"

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


_MARK = re.compile(r"`([^`]+)`")


def field_error(marked: str) -> SceneError:
    """A SceneError whose message names scene fields between backquotes: `drag`.

    ``str()`` shows the field names as they are (the keys of a scene file, the arguments of
    :class:`Scene`); ``err.marked`` keeps the marks, so that the CLI can show its flags
    instead (gaz_cli.scenes.options.FLAGS, in one place).
    """
    err = SceneError(_MARK.sub(r"\1", marked))
    err.marked = marked
    return err


def render(err: BaseException, names: dict) -> str:
    """The message of ``err`` with each marked field renamed through ``names`` (others kept)."""
    marked = getattr(err, "marked", None)
    if marked is None:
        return str(err)
    return _MARK.sub(lambda m: names.get(m.group(1), m.group(1)), marked)


def _real(name: str, value) -> bool:
    """A real number (int or float, not bool)?"""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _number(name: str, value, unit: str = "") -> None:
    if not _real(name, value):
        raise field_error(f"`{name}` {value!r} is not a number" + (f" ({unit})" if unit else ""))


def _positive(name: str, value, hint: str = "") -> None:
    _number(name, value)
    if not np.isfinite(value) or value <= 0:
        raise field_error(f"`{name}` must be a positive number, got {value}{hint}")


def _at_least_zero(name: str, value, unit: str) -> None:
    _number(name, value, unit)
    if not math.isfinite(value) or value < 0:
        raise field_error(f"`{name}` {value} is outside [0, inf) {unit}; give a finite number >= 0")


def _unit_interval(name: str, value, what: str) -> None:
    _number(name, value)
    if not 0.0 <= value <= 1.0:
        raise field_error(f"`{name}` {value} is outside [0, 1] ({what}: 1 elastic, 0 fully damped)")


def _one_of(name: str, value, allowed) -> None:
    if value not in allowed:
        raise field_error(f"`{name}` {value!r} is not one of {', '.join(allowed)}")


SEARCH = {
    "neighbours": ("auto", "cells", "lists", "dilute", "wide"),
    "classes": ("auto", "off"),
    "skin": "neighbour-list skin, in largest diameters, > 0",
}
"""The event engine's search settings a scene may hold in ``extras`` (absent: 'auto' and
:data:`gaz_cli.engines.event.sizing.NEIGHBOUR_SKIN`): cell lists, neighbour lists or, with walls,
the dilute scan of every particle; size classes or one cell grid; the lists' skin."""


STRAIGHT_SEARCHES = ("dilute", "wide")
"""Searches built for straight flights, without gravity (their float32 pass bounds a flight up
to its horizon: the next wall bounce, or for wide cells in a periodic box the next wrap; see
gaz_cli.engines.event.neighbours.dilute and .wide). The dilute scan needs walls too; wide cells in a
periodic box need it 3 diameters wide or more (PERIODIC_WIDE_CELLS cells an axis). Forced on
another scene they used to give way to cells in silence; they are refused instead. (A 1D
run ignores ``[search]`` whatever it holds: rods only meet their two neighbours.)"""

PERIODIC_WIDE_CELLS = 3
"""Wide cells in a periodic box: at least this many an axis, each a diameter wide or more, so
that each of the 3^D cells around a particle is a different cell (gaz_cli.engines.event.sizing)."""


def search_given(extras: dict) -> list[str]:
    """The search settings of ``extras`` (:data:`SEARCH`) set to something other than 'auto'."""
    return [key for key in SEARCH if key in extras and extras[key] != "auto"]


def _check_search(scene: Scene) -> None:
    """The event engine's search settings (a scene file's ``[search]`` table): each in its range,
    and only with ``engine`` event, the one engine that searches for partners (``auto`` takes
    it when one is set, :func:`gaz_cli.engines.registry.choose`)."""
    extras = scene.extras
    for key, allowed in SEARCH.items():
        if key not in extras:
            continue
        value = extras[key]
        if key == "skin":
            if not _real("skin", value) or not math.isfinite(value) or value <= 0:
                raise field_error(f"[search] `skin` {value!r} must be a positive number ({allowed})")
        elif value not in allowed:
            raise field_error(f"[search] `{key}` {value!r} is not one of {', '.join(allowed)}")
    given = search_given(extras)
    if given and scene.engine != "event":
        key = given[0]
        raise field_error(f"[search] `{key}` {extras[key]!r} applies to `engine` event only (the {scene.engine} "
                          f"engine does not search for partners and would ignore it); set `engine` event, "
                          f"or drop `{key}` from [search]")
    chosen = extras.get("neighbours")
    if chosen in STRAIGHT_SEARCHES:
        periodic = scene.boundary == "periodic" and chosen == "dilute"
        unfit = [why for why, bad in (("periodic", periodic),
                                      ("under gravity", scene.gravity != 0)) if bad]
        if unfit:
            where = "a box with walls" if chosen == "dilute" else "straight flights"
            raise field_error(f"`neighbours` {chosen!r} searches {where} and without gravity; "
                              f"this scene is {' and '.join(unfit)}: "
                              "use 'auto', 'cells' or 'lists'")
        rmax = float(np.max(scene.radii()))
        # (the sizing's count of cells a diameter wide or more: engine.sizing._most_wide_cells)
        diameters = scene.length / (2.0 * rmax * (1.0 + 1e-9)) if rmax > 0.0 else math.inf
        if chosen == "wide" and scene.boundary == "periodic" and diameters < PERIODIC_WIDE_CELLS:
            raise field_error(f"`neighbours` 'wide' needs a periodic box {PERIODIC_WIDE_CELLS} "
                              f"particle diameters wide or more (a cell a diameter wide or more, "
                              f"{PERIODIC_WIDE_CELLS} an axis); this one is {diameters:.3g}: "
                              "use 'auto' or 'cells', or raise `length`")


def validate(scene: Scene) -> Scene:
    """Check everything a scene holds; raise :class:`SceneError` naming the field, the value,
    the allowed range and the fix. The one door: the CLI, scene files, presets and Python
    callers all come through here, and the engines assume a valid scene.

    In order: dimension, engine, placement; counts, species, box, duration, temperature;
    boundary, recording, restitutions, gravity, seed, tc; the step engine's options (dt,
    drag, pair_gravity, softening, wall_restitution, planes, print_every: checked with
    ``engine = "step"``, refused with any other engine, where they would be ignored); the
    event engine's search settings in ``extras`` (:data:`SEARCH`); what the
    reference engine handles; the initial state; the magnitudes double precision carries
    (:func:`check_magnitudes`); packing fraction below close packing; the memory the run
    needs (:func:`memory_needed`); unless ``scene.force``, the run's work
    (:func:`work_estimate`) below its bound.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"expected a Scene, got {type(scene).__name__}")
    if isinstance(scene.dim, bool) or scene.dim not in (1, 2, 3):
        raise field_error(f"`dim` {scene.dim!r} is not 1, 2 or 3")
    _one_of("engine", scene.engine, ENGINES)
    _one_of("placement", scene.placement, PLACEMENTS)
    if scene.placement == "rapid" and scene.dim != 1:
        raise field_error("`placement` rapid works in 1D only (the exam's Q10); use rejection, grow or lattice")
    if not isinstance(scene.components, (tuple, list)) or not scene.components:
        raise field_error("no particles: give `n` and `species` (or `radius` and `mass`)")
    for item in scene.components:
        if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], Species)):
            raise field_error(f"`species` entry {item!r} is not a (Species, count) pair")
    for sp, k in scene.components:
        check_count(k, None if len(scene.components) == 1 else sp.name)
    _positive("length", scene.length, " (m)")
    _positive("duration", scene.duration, " (simulated seconds)")
    _positive("temperature", scene.temperature, " (kelvin)")
    for sp, k in scene.components:
        check_species_name(sp.name)
        if not _real("mass", sp.mass) or not np.isfinite(sp.mass) or sp.mass <= 0:
            raise field_error(f"`mass` of {sp.name} must be a positive number, got {sp.mass!r} (kg)")
        _number("radius", sp.radius, "m")
        if not np.isfinite(sp.radius) or sp.radius < 0:
            raise field_error(f"`radius` of {sp.name} must be >= 0, got {sp.radius}")
        check_builtin_clash(sp)
        if 2 * sp.radius >= scene.length:
            raise field_error(f"a {sp.name} particle (diameter {2 * sp.radius:g} m) does not fit in "
                              f"the box of side {scene.length:g} m; raise `length`")
    _one_of("boundary", scene.boundary, BOUNDARIES)
    _one_of("record", scene.record, RECORD_LEVELS)
    _unit_interval("restitution", scene.restitution, "particle collisions")
    _number("gravity", scene.gravity, "m/s^2")
    if not np.isfinite(scene.gravity) or scene.gravity < 0:
        raise field_error(f"`gravity` {scene.gravity} must be >= 0 (m/s^2, pulling towards -axis {scene.dim - 1})")
    if scene.gravity > 0 and scene.boundary == "periodic":
        raise field_error("`gravity` needs hard walls; drop `boundary` periodic")
    if scene.seed is not None:
        if not isinstance(scene.seed, numbers.Integral) or isinstance(scene.seed, bool):
            raise field_error(f"`seed` {scene.seed!r} is not a whole number")
        if not 0 <= scene.seed < 2 ** 63:
            raise field_error(f"`seed` {scene.seed} must be between 0 and 2^63 - 1")
    _at_least_zero("tc", scene.tc, "s")
    if not isinstance(scene.force, bool):
        raise field_error(f"`force` {scene.force!r} is not true or false")
    scene = _resolve_engine(scene)
    _check_engine_options(scene)
    _check_search(scene)
    _check_initial(scene)
    check_magnitudes(scene)
    eta = scene.packing_fraction
    densest = DENSEST[scene.dim]
    if eta >= densest:
        raise field_error(f"packing fraction {eta:.3g} is at or above {densest:.4g}, {DENSEST_NAME[scene.dim]}; "
                          "lower `n` or raise `length`")
    check_memory(scene.n, scene.engine, scene.dim)
    if not scene.force:
        check_work(scene)
    return scene


def _resolve_engine(scene: Scene) -> Scene:
    """``engine = "auto"`` replaced by the path the scene needs (:func:`gaz_cli.engines.registry.choose`);
    the reason, in one line, goes to ``extras['engine_reason']`` for the run's summary."""
    from gaz_cli.engines import registry as engines

    if scene.extras.get("engine_reason") and scene.engine != "auto":
        return scene  # resolved before (validate is idempotent)
    chosen, reason = engines.choose(scene)
    if chosen.engine == "ideal" and scene.engine == "ideal":
        from gaz_cli.engines import ideal

        why = ideal.reason_not(scene)
        if why is not None:
            raise field_error(f"`engine` ideal (closed-form bounces) cannot run this scene: {why}; "
                              "use `engine` event or auto")
    return replace(chosen, extras={**scene.extras, "engine_reason": reason,
                                   "engine_auto": scene.engine == "auto"})


def reference_refusal(scene: Scene) -> str | None:
    """What the reference engine (the exam's algorithm: hard elastic walls, no gravity) cannot
    take in ``scene``, as a marked field and value (`boundary` periodic), or None."""
    if scene.boundary != "walls":
        return f"`boundary` {scene.boundary}"
    if scene.gravity != 0.0:
        return f"`gravity` {scene.gravity:g}"
    if scene.restitution != 1.0:
        return f"`restitution` {scene.restitution:g}"
    return None


def check_reference_scene(scene: Scene) -> None:
    """SceneError (fields named) unless the reference engine can run ``scene``."""
    why = reference_refusal(scene)
    if why is not None:
        raise field_error(f"`engine` reference (the exam's algorithm) handles hard elastic walls "
                          f"without gravity only, not {why}; use `engine` event")


def _check_engine_options(scene: Scene) -> None:
    """The step engine's options: in range with ``engine = "step"``, absent otherwise."""
    if scene.engine != "step":
        for name, unused in STEP_ONLY.items():
            value = getattr(scene, name)
            if value is not unused and value != unused:
                raise field_error(f"`{name}` {value!r} applies to `engine` step only (the {scene.engine} "
                                  f"engine would ignore it); set `engine` step, or drop `{name}`")
    else:
        if scene.dt is None:
            raise field_error("`engine` step needs a time step `dt` (seconds)")
        _positive("dt", scene.dt, " (seconds)")
        if scene.dt > scene.duration:
            raise field_error(f"`dt` {scene.dt:g} s is longer than `duration` {scene.duration:g} s; "
                              "lower `dt` or raise `duration`")
        if scene.boundary != "walls":
            raise field_error("`engine` step works with hard walls only; drop `boundary` periodic "
                              "or use `engine` event")
        _at_least_zero("drag", scene.drag, "1/s")
        _at_least_zero("pair_gravity", scene.pair_gravity, "m^3/(kg s^2)")
        _at_least_zero("softening", scene.softening, "m")
        _unit_interval("wall_restitution", scene.wall_restitution, "the walls")
        if isinstance(scene.print_every, bool) or not isinstance(scene.print_every, numbers.Integral) \
                or scene.print_every < 0:
            raise field_error(f"`print_every` {scene.print_every!r} is not a whole number >= 0 (steps)")
        rmax = max(float(sp.radius) for sp, _ in scene.components)
        for plane in scene.planes:
            check_plane(plane, scene.dim)
            check_plane_room(plane, scene.length, rmax)
    if scene.engine == "reference":
        check_reference_scene(scene)
    if scene.engine == "event" and scene.boundary == "periodic" and scene.n > 1:
        rmax = max(sp.radius for sp, _ in scene.components)
        if rmax > 0 and 4.0 * rmax >= scene.length:
            raise field_error(f"a periodic box must be wider than two particle diameters "
                              f"({4 * rmax:g} m), got `length` {scene.length:g}; raise `length`")


def check_plane(plane, dim: int) -> None:
    """One extra wall of the step engine: (point (D,), inward normal (D,) not zero, restitution in [0, 1])."""
    try:
        point, normal, e = plane
        point, normal = [float(c) for c in point], [float(c) for c in normal]
    except (TypeError, ValueError):
        raise field_error(f"`planes` entry {plane!r} is not (point, normal, restitution)") from None
    if len(point) != dim or len(normal) != dim:
        raise field_error(f"`planes` entry {plane!r} needs {dim} coordinates for its point and its normal")
    if not all(math.isfinite(c) for c in point + normal):
        raise field_error(f"`planes` entry {plane!r} holds a non-finite coordinate")
    if not any(normal):
        raise field_error(f"`planes` entry {plane!r} has a zero normal; give the inward normal of the wall")
    if not _real("restitution", e) or not 0.0 <= e <= 1.0:
        raise field_error(f"`planes` entry {plane!r}: restitution {e!r} is outside [0, 1] (1 elastic, 0 fully damped)")


def plane_room(plane, length: float, radius: float) -> float:
    """How far in front of extra ``plane`` (along its inward normal, beyond ``radius``) the centre
    of a particle of ``radius`` can be while inside the box [radius, length - radius]^D, m: the
    largest (c - point).n - radius over the corners c of that box; < 0 when no centre fits."""
    point, normal, _ = plane
    nrm = np.asarray(normal, dtype=float)
    nrm = nrm / np.linalg.norm(nrm)
    lo, hi = radius, length - radius
    return float(sum(max((lo - p) * n, (hi - p) * n) for p, n in zip(point, nrm))) - radius


def check_plane_room(plane, length: float, radius: float) -> None:
    """An extra plane must leave room in the box for the largest particle on its inner side
    (else the engine would push every particle to the plane's side, out of the box)."""
    if plane_room(plane, length, radius) < 0:
        raise field_error(f"`planes` entry {plane!r} leaves no room in the box for a particle of radius "
                          f"{radius:g} m on its inner side (the side its normal points to); move its point "
                          "or turn its normal towards the box")


def check_in_front_of_planes(scene: Scene, positions) -> None:
    """SceneError when a particle of ``positions`` (N, D) m starts behind one of the scene's extra
    planes or closer to it than its radius: the step engine would put it back on the plane's
    inner side in one step, through the others. Round-off allowed: 1e-9 of the box side."""
    if not scene.planes:
        return
    pos, radii = np.asarray(positions, dtype=float), scene.radii()
    for k, plane in enumerate(scene.planes):
        point, normal, _ = plane
        nrm = np.asarray(normal, dtype=float)
        nrm = nrm / np.linalg.norm(nrm)
        gap = (pos - np.asarray(point, dtype=float)) @ nrm - radii
        i = int(np.argmin(gap))
        if gap[i] < -1e-9 * scene.length:
            raise field_error(f"particle {i} starts behind `planes` entry {plane!r} (its centre "
                              f"{np.array2string(pos[i], precision=4)} m, {-gap[i]:.3g} m too far behind); "
                              + ("move it in front of the plane, or move the plane"
                                 if scene.initial is not None and scene.initial.get("kind") == "explicit" else
                                 "the placement fills the whole box, planes aside: give an `initial` state "
                                 "with every particle in front of the planes, or move the plane"))


def _check_initial(scene: Scene) -> None:
    """Scene.initial: its kind and arrays (an explicit state must match the scene's N and D)."""
    init = scene.initial
    if init is None:
        return
    if not isinstance(init, dict) or init.get("kind") not in INITIAL_KINDS:
        kind = init.get("kind") if isinstance(init, dict) else init
        raise field_error(f"`initial` kind {kind!r} is not one of {', '.join(INITIAL_KINDS)}")
    if scene.placement != "auto":
        raise field_error(f"`placement` {scene.placement} does not apply with an `initial` state "
                          f"({init['kind']}), which places the particles itself; drop `placement`")
    allowed = {"explicit": {"kind", "positions", "velocities"}, "upper-half": {"kind", "velocity_sd"}}[init["kind"]]
    extra = sorted(set(init) - allowed)
    if extra:
        raise field_error(f"`initial` key {extra[0]!r} does not belong to kind {init['kind']!r}; "
                          f"its keys: {', '.join(sorted(allowed))}")
    if init["kind"] == "explicit":
        for key in ("positions", "velocities"):
            try:
                arr = np.asarray(init.get(key), dtype=float)
            except (TypeError, ValueError):
                raise field_error(f"`initial` {key} is not an array of numbers") from None
            if arr.shape != (scene.n, scene.dim):
                raise field_error(f"`initial` {key} has shape {arr.shape}, the scene needs "
                                  f"({scene.n}, {scene.dim}) (n particles, dim coordinates)")
            if not np.all(np.isfinite(arr)):
                raise field_error(f"`initial` {key} holds a non-finite number")
        pos, r = np.asarray(init["positions"], dtype=float), scene.radii()[:, None]
        if np.any(pos < r) or np.any(pos > scene.length - r):
            raise field_error("`initial` positions put a particle outside the box [R, L - R]")
        check_in_front_of_planes(scene, pos)
        pair = _overlapping_pair(pos, scene.radii(), scene.length, scene.boundary == "periodic")
        if pair is not None:
            raise field_error(f"`initial` positions overlap: particles {pair[0]} and {pair[1]} are closer "
                              "than the sum of their radii; move them apart")
        # the largest speed bounded without squaring (|v| <= sqrt(D) max |v_k|): no overflow
        fastest = float(np.max(np.abs(np.asarray(init["velocities"], dtype=float)))) * math.sqrt(scene.dim)
        scale = "velocities"
    else:
        sd = init.get("velocity_sd")
        if not _real("velocity_sd", sd) or not math.isfinite(sd) or sd < 0:
            raise field_error(f"`initial` velocity_sd {sd!r} is outside [0, inf) m/s")
        fastest, scale = SPEED_TAIL * sd * math.sqrt(scene.dim), "velocity_sd"
    vhi = speed_range(scene.length, [sp.radius for sp, _ in scene.components])[1]
    if fastest > vhi:
        raise field_error(f"`initial` {scale} reach {fastest:.3g} m/s, above the {vhi:.2g} m/s where the "
                          f"particles' speeds (times the box, {scene.length:.3g} m) stay within double "
                          f"precision; lower the `initial` {scale}")


def _overlapping_pair(pos: np.ndarray, radii: np.ndarray, length: float, periodic: bool):
    """Two particles of an explicit state that overlap (beyond 1e-9 relative), or None: all
    pairs in numpy up to 1000 particles (no compiled code to load), else the placement's
    cell scan (:func:`gaz_cli.placement.first_overlap`)."""
    n = len(pos)
    if n < 2 or not np.any(radii > 0):
        return None
    if n > 1000:
        from gaz_cli.placement import first_overlap

        k = first_overlap(pos, radii, length, periodic)
        return None if k < 0 else (k, "another")
    d = pos[:, None, :] - pos[None, :, :]
    if periodic:
        d -= length * np.round(d / length)
    contact = (radii[:, None] + radii[None, :]) * (1.0 - 1e-9)
    close = np.sum(d * d, axis=2) < contact * contact
    np.fill_diagonal(close, False)
    i, j = np.unravel_index(int(np.argmax(close)), close.shape)
    return (int(min(i, j)), int(max(i, j))) if close[i, j] else None


# --- the checks validate() composes --------------------------------------------------------------
def check_count(n, species: str | None = None) -> None:
    """A particle count is an integer in [1, MAX_COUNT]. ``species``: the name of the species
    counted, one of a mixture (None: the scene's one count, `n`)."""
    what = "`n`" if species is None else f"the `n` of {species}"
    if isinstance(n, bool) or not isinstance(n, numbers.Integral):
        raise field_error(f"{what} {n!r} is not a whole number")
    if n < 1:
        raise field_error(f"{what} must be at least 1, got {n}")
    if n > MAX_COUNT:
        raise field_error(f"{what} {n} is above {MAX_COUNT:.3g} (2^63 - 1), the largest count the "
                          f"engines' int64 indices hold; lower {what}")


def check_species_name(name) -> None:
    """A species name is 1 to NAME_MAX printable characters: what PARTICULE.PA_NOM holds on
    both backends (PostgreSQL refuses a longer one, and any NUL, at the end of the run)."""
    shown = repr(name) if len(repr(name)) <= 40 else repr(name)[:37] + "..."
    if not isinstance(name, str):
        raise field_error(f"species name {shown} is not text")
    if not name.strip():
        raise field_error(f"species name {shown} is empty; give the species a name")
    if len(name) > NAME_MAX:
        raise field_error(f"species name {shown} has {len(name)} characters, more than the {NAME_MAX} "
                          "the database's PARTICULE.PA_NOM holds; shorten it")
    if not name.isprintable():
        raise field_error(f"species name {shown} holds a control character (newline, tab, NUL...); "
                          "use printable characters only")
    if any(c in name for c in NAME_SEPARATORS):
        raise field_error(f"species name {shown} holds ',' or ':', which separate the entries of a mixture "
                          "(Ar:500,He:500); use another character, such as '-' or '_'")


def check_builtin_clash(sp: Species) -> None:
    """A custom species may not take a built-in species' name (PARTICULE would hold two rows of
    that name, and 'Ar' in a query or --species would be ambiguous) unless it is that species:
    the same mass and radius to the 1e-12 the stores match PARTICULE rows with."""
    builtin = builtin_named(sp.name)
    if builtin is None or (math.isclose(sp.mass, builtin.mass, rel_tol=1e-12, abs_tol=0)
                           and math.isclose(sp.radius, builtin.radius, rel_tol=1e-12, abs_tol=0)):
        return
    raise field_error(f"species name {sp.name!r} is the built-in {builtin.name} ({builtin.mass:.4g} kg, radius "
                      f"{builtin.radius:.3g} m), but this one has mass {sp.mass:.4g} kg and radius "
                      f"{sp.radius:.3g} m; give it another name, e.g. '{builtin.name}-custom', or drop "
                      "its mass and radius to use the built-in one")


def _outside(what: str, value: float, lo: float, hi: float, unit: str, why: str, fix: str) -> None:
    if not lo <= value <= hi:
        side = "below" if value < lo else "above"
        raise field_error(f"{what} {value:.3g} {unit} is {side} the range [{lo:.2g}, {hi:.2g}] {unit} {why}; {fix}")


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
    _outside("`length`", scene.length, lo, hi, "m",
             f"where L^{scene.dim} and |dr|^2 stay within double precision", "change `length`")
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
    _outside("`temperature`", scene.temperature, tlo, thi, "K",
             f"where the particles' speeds (times the box, {scene.length:.3g} m) stay within double "
             "precision", "change `temperature`")
    ghi = (vhi / SPEED_TAIL) ** 2 / (2.0 * scene.length)
    if scene.gravity > ghi:
        _outside("`gravity`", scene.gravity, 0.0, ghi, "m/s^2",
                 "where the speed of a fall across the box stays within double precision", "lower `gravity`")


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
        raise field_error(f"N = {n:.3g} needs about {_bytes(need)} of memory ({engine} engine); this "
                         f"machine has {_bytes(have)}; lower `n`" if engine != "place" else
                         f"placing N = {n:.3g} particles needs about {_bytes(need)} of memory; this "
                         f"machine has {_bytes(have)}; lower `n`")


def work_estimate(scene: Scene) -> dict:
    """The run's expected work: events per second and in all, steps, work units and their bound.

    Events: collisions N omega / 2 (Enskog, at the mean diameter and mass), wall bounces
    (theory.wall_hit_rate over the 2D walls of the box a species' centres reach, side
    L - 2R: a box barely wider than its particle is crossed most often; under gravity the
    floor is hit every 2 v / g, v = sqrt(k_B T / m)). Step engine: work = steps x N (x N / 2 with pair gravity);
    reference engine: events x N + N^2 (its initCat). Returns a dict: events_per_s, events
    (of which bounces and collisions), work, limit, what (the estimate in words), fix.

    Measured against the event engine (one run each): argon 3D, N = 1000, the README's scene
    0.99 of the events counted; reduced units 3D eta 0.3 walls 0.83, 2D 0.5 0.97, 1D 0.8 0.96,
    3D periodic 0.45 0.96; 2D eta 0.1 under gravity (g = 30, m = k_B T = 1, L = 1) 0.38.
    """
    from gaz_cli import theory

    n, dim, length = scene.n, scene.dim, scene.length
    sigma, mass = 2.0 * scene.mean_radius(), scene.mean_mass()
    density = n / scene.volume
    rate = collision_rate = 0.0
    if n > 1 and sigma > 0:
        # Tonks (1D) is exact up to a full segment, which validate refuses; 2D and 3D closed
        # forms diverge at a packing placement cannot reach
        eta = scene.packing_fraction if dim == 1 else min(scene.packing_fraction, 0.99 * DENSEST[dim])
        closed_form = {1: "tonks", 2: "henderson", 3: "carnahan-starling"}[dim]
        omega = float(theory.enskog_collision_frequency(dim, density * eta / scene.packing_fraction,
                                                        sigma, scene.temperature, mass, model=closed_form))
        rate += n * omega / 2.0
    collision_rate = rate
    if scene.boundary == "walls":
        for species, count in scene.components:
            # a centre moves in the free length L - 2R: a box barely wider than its particle
            # is crossed, and its walls hit, at |v| / (L - 2R)
            free = max(length - 2.0 * species.radius, length * sys.float_info.epsilon)
            rate += (float(theory.wall_hit_rate(count / free ** dim, scene.temperature, species.mass))
                     * 2 * dim * free ** (dim - 1))
        if scene.gravity > 0:
            rate += n * scene.gravity / (2.0 * math.sqrt(K_B * scene.temperature / mass))
    events = rate * scene.duration
    # a centre with under NARROW_BOX of the box to move in hits the walls L / (L - 2R) times as
    # often as a point would: there, a slightly longer box is the cheapest fix
    free = min(length - 2.0 * species.radius for species, _ in scene.components) / length
    wider = (f" or raise `length` (a centre has {100 * free:.2g} % of the box's side to move in)"
             if scene.boundary == "walls" and free < NARROW_BOX else "")
    rows = {"bounces": (rate - collision_rate) * scene.duration, "collisions": collision_rate * scene.duration}
    if scene.engine == "step":
        steps = scene.duration / scene.dt if scene.dt else 0.0
        work = steps * n * (n / 2.0 if scene.pair_gravity > 0 else 1.0)
        pairs = scene.pair_gravity > 0
        return {"events_per_s": rate, "events": events, **rows, "steps": steps, "work": work, "limit": MAX_STEP_WORK,
                "what": f"{steps:.3g} steps x {n} particles" + (f" x {n / 2:g} pairs" if pairs else ""),
                "fix": "raise `dt`, or lower `duration` or `n`"}
    if scene.engine == "reference":
        return {"events_per_s": rate, "events": events, **rows, "work": events * n + n * n, "limit": MAX_REFERENCE_WORK,
                "what": f"{events:.3g} events x {n} particles + {n}^2 for the initial catalogue (the "
                        "reference engine updates every particle's catalogue entry at each event)",
                "fix": "use `engine` event, or lower `duration` or `n`" + wider}
    return {"events_per_s": rate, "events": events, **rows, "work": events, "limit": MAX_EVENTS,
            "what": f"{events:.3g} events ({rate:.3g} per simulated second over {scene.duration:.3g} s)",
            "fix": "lower `duration`, `n`, `temperature`" + (" or `gravity`" if scene.gravity > 0 else "")
                   + wider}


def check_work(scene: Scene) -> None:
    """Refuse a run whose estimated work is beyond its bound (unless scene.force)."""
    est = work_estimate(scene)
    if not est["work"] <= est["limit"]:
        raise field_error(f"this run would take about {est['what']}, beyond the {est['limit']:.0e} allowed "
                         f"without `force`; {est['fix']}, or add `force` to run it anyway")


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
    from gaz_cli.errors import PlacementError

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


def fresh_seed() -> int:
    """A random seed from the operating system, to be recorded so the run can be repeated."""
    return int(np.random.SeedSequence().generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


def default_tc(scene: Scene) -> float:
    """TC-model contact time: 1e-4 of the mean free time 1/omega (Enskog, closed-form EOS)."""
    from gaz_cli import theory

    sigma = 2.0 * scene.mean_radius()
    if sigma == 0:
        return 0.0
    closed_form = {1: "tonks", 2: "henderson", 3: "carnahan-starling"}[scene.dim]
    omega = theory.enskog_collision_frequency(scene.dim, scene.n / scene.volume, sigma, scene.temperature,
                                              scene.mean_mass(), model=closed_form)
    return 1e-4 / float(omega)


def check_diagnostics(scene: Scene, diagnostics) -> None:
    """Check the ``diagnostics`` callable given to a run (Python API); raise SceneError naming the fix.

    The step engine alone reports diagnostics (energies, largest speed, counts), every
    ``print_every`` steps: with another engine, or with ``print_every`` 0, the callable would
    never be called; the event engine's driver is not asked for them (its state between
    events is not at one time, and the exact engine conserves energy to round-off).
    """
    if diagnostics is None:
        return
    if not callable(diagnostics):
        raise SceneError(f"diagnostics {diagnostics!r} is not callable: give a function taking one dict "
                         "(time, step, kinetic, potential, energy...), or None")
    if scene.engine != "step":
        raise SceneError(f"diagnostics are written by the step engine; this scene runs the {scene.engine} "
                         "engine: use engine='step' with print_every (steps between reports), or drop diagnostics")
    if not scene.print_every:
        raise SceneError("diagnostics given, but print_every is 0: the step engine would report nothing; "
                         "set print_every (steps between reports), or drop diagnostics")


def check_outputs(scene: Scene, trajectory=None, every=None) -> None:
    """Check a run's trajectory request against its scene; raise SceneError naming the fix.

    The engine must write snapshots (the reference engine does not); ``every`` must be a
    positive number of simulated seconds, at most the duration (else the start alone would
    be written); unless ``scene.force``, at most MAX_SNAPSHOTS
    snapshots and a file smaller than the free space of its disk.
    """
    if not trajectory:
        if every is not None:
            raise field_error(f"`every` {every!r} applies to `trajectory` only (no snapshot would be "
                              "written); add `trajectory` FILE, or drop `every`")
        return
    from gaz_cli.outputs.trajectory import FORMATS

    suffix = os.path.splitext(str(trajectory))[1].lower()
    if suffix not in FORMATS:
        known = ", ".join(sorted(FORMATS))
        raise field_error(f"`trajectory` {str(trajectory)!r}: unknown extension {suffix!r}; "
                          f"use one of {known} (.h5: HDF5/H5MD, .gsd: HOOMD, .pvd: VTK for ParaView)")
    if FORMATS[suffix] == "gsd":
        from gaz_cli.outputs.trajectory import gsd_hoomd_module

        gsd_hoomd_module()  # the optional gsd package, asked for before any database is created
    if scene.engine == "reference":
        raise field_error("`engine` reference (the exam's algorithm) writes no trajectory; "
                          "use `engine` event with `trajectory`")
    if every is None:
        raise field_error("`trajectory` needs `every` DT, the simulated time between snapshots (s)")
    if not (_real("every", every) and math.isfinite(every) and every > 0):
        raise field_error(f"`every` must be a positive number of simulated seconds, got {every}")
    if every > scene.duration:
        raise field_error(f"`every` {every:g} s is longer than `duration` {scene.duration:g} s: the trajectory "
                          f"would hold the start alone; use `every` {scene.duration:g} or less")
    snapshots = math.floor(scene.duration / every) + 1
    if scene.force:
        return
    if snapshots > MAX_SNAPSHOTS:
        least = scene.duration / (MAX_SNAPSHOTS - 1)
        raise field_error(f"`every` {every:g} s over `duration` {scene.duration:g} s makes {snapshots:,} "
                          f"snapshots, more than {MAX_SNAPSHOTS:,}; use `every` {least:.3g} or more, "
                          "or add `force` to write them all")
    size = snapshots * scene.n * scene.dim * 16.0
    try:
        import shutil

        free = shutil.disk_usage(os.path.dirname(os.path.abspath(str(trajectory)))).free
    except OSError:
        return
    if size > free:
        raise field_error(f"`trajectory` {str(trajectory)!r} would take about {_bytes(size)} "
                         f"({snapshots:.3g} snapshots of {scene.n} particles); its disk has {_bytes(free)} "
                         "free; raise `every` or free some space (or add `force`)")


def recorded_rows(scene: Scene) -> dict[str, float] | None:
    """The rows a run records, by kind ({"bounces": ..., "collisions": ...}, the latter 0 unless
    ``record`` all), from :func:`work_estimate`; None when not estimated: ``record`` none,
    ``force``, the step engine (its bounces against damped walls and planes), a preset's state
    (its speeds are not ``temperature``'s)."""
    if scene.record == "none" or scene.force or scene.engine == "step" or scene.initial is not None:
        return None
    est = work_estimate(scene)
    return {"bounces": est["bounces"], "collisions": est["collisions"] if scene.record == "all" else 0.0}


def database_peak(scene: Scene) -> tuple[float, float, float] | None:
    """(rows, growth, staged) of a run into a SQLite file: the rows it records
    (:func:`work_estimate`'s wall bounces, and collisions with ``record`` all), the file's
    growth (times :data:`BYTES_PER_ROW`) and the scratch file that stages them when they are
    more than :data:`gaz_cli.results.staging.MEMORY_ROWS` (times :data:`STAGED_BYTES_PER_ROW`; else 0),
    bytes. None when not estimated: ``record`` none, ``force``, the step engine (its bounces
    against damped walls and planes), a preset's state (its speeds are not ``temperature``'s).

    While the run commits, the disk holds the scratch file, the rows in the database's WAL
    file, and (a checkpoint at the commit) the same rows copied into the database: the peak is
    2 growth + staged (measured, 256,694 bounces: 11.7 MB of growth, a peak of 41.7 MB staged,
    23.5 MB in memory)."""
    counts = recorded_rows(scene)
    if counts is None:
        return None
    from gaz_cli.results.staging import MEMORY_ROWS

    rows = sum(counts.values())
    growth = sum(k * BYTES_PER_ROW[kind] for kind, k in counts.items())
    staged = sum(k * STAGED_BYTES_PER_ROW[kind] for kind, k in counts.items()) if rows > MEMORY_ROWS else 0.0
    return rows, growth, staged


def _free_space(path) -> float | None:
    """Free bytes of the disk of the file ``path`` (None when its folder cannot be asked)."""
    import shutil

    try:
        return shutil.disk_usage(os.path.dirname(os.path.abspath(os.path.expanduser(str(path))))).free
    except OSError:
        return None


def check_database_space(scenes: list[Scene], path, fix: str = "shorten `duration`") -> None:
    """Refuse the runs of ``scenes`` (one run's, or a sweep's, committed one after the other)
    when their peak on the disk of SQLite file ``path`` would not fit in its free space: every
    run's growth, plus the largest run's WAL copy and scratch file (:func:`database_peak`).
    Runs not estimated are left out (``force`` among them). ``fix``: the first fix named."""
    peaks = [(s, p) for s in scenes if (p := database_peak(s)) is not None]
    if not peaks:
        return
    rows = sum(p[0] for _, p in peaks)
    growth = sum(p[1] for _, p in peaks)
    need = growth + max(p[1] for _, p in peaks) + max(p[2] for _, p in peaks)
    free = _free_space(path)
    if free is None or need <= free:
        return
    runs = f"{len(peaks)} runs, " if len(peaks) > 1 else ""
    record = " and ".join(sorted({s.record for s, _ in peaks}))
    staged = " (and a scratch file beside it before)" if any(p[2] for _, p in peaks) else ""
    raise field_error(f"database {str(path)!r} would grow by about {_bytes(growth)} ({runs}{rows:.3g} rows "
                      f"recorded with `record` {record}) and needs about {_bytes(need)} free while committing "
                      f"(the rows go through its WAL file{staged}); its disk has {_bytes(free)} free; {fix}, "
                      "use `record` none, or give --db a file on another disk (or add `force`)")


INT4_MAX = 2 ** 31 - 1
"""The largest number PostgreSQL's ``integer`` holds: a run's REBOND and CHOC rows were numbered
in such columns (RE_NUM, CH_NUM) in a database made before PostgreSQL schema 6, which has
``bigint`` (SQLite's integers are 64-bit)."""


def check_row_numbers(scenes: list[Scene], narrow: tuple[str, ...], fix: str = "shorten `duration`") -> None:
    """Refuse, before any run, the runs of ``scenes`` whose rows of one kind would number past
    INT4_MAX in a table of ``narrow`` (those of "REBOND", "CHOC" whose row number is a 32-bit
    ``integer`` in the PostgreSQL database written: one made before schema 6) (:func:`recorded_rows`;
    runs not estimated, ``force`` among them, are left out): such a run failed at that row,
    after all its computation."""
    kinds = {"REBOND": ("wall bounces", "bounces", "re_num"), "CHOC": ("collisions", "collisions", "ch_num")}
    for scene in scenes:
        counts = recorded_rows(scene)
        if counts is None:
            continue
        for table in narrow:
            what, kind, column = kinds[table]
            if counts[kind] > INT4_MAX:
                raise field_error(f"this PostgreSQL database numbers its {table} rows with a 32-bit integer "
                                  f"(at most {INT4_MAX:,} a run); this run would record about {counts[kind]:.3g} "
                                  f"{what}; {fix}, use `record` none, widen the column once (ALTER TABLE "
                                  f"{table.lower()} ALTER COLUMN {column} TYPE bigint), or give --db a new "
                                  "database (or add `force`)")


def check_placement(dim: int, n: int, radius: float, length: float) -> None:
    """The door of ``gaz place``: count, radius and box in range, memory, before any allocation."""
    if dim not in (1, 2, 3):
        raise field_error(f"`dim` {dim} is not 1, 2 or 3")
    check_count(n)
    _positive("radius", radius, " (m)")
    _positive("length", length, " (m)")
    lo, hi = length_range(dim)
    _outside("`length`", length, lo, hi, "m", f"where L^{dim} and |dr|^2 stay within double precision",
             "change `length`")
    rlo, rhi = radius_range()
    _outside("`radius`", radius, rlo, rhi, "m", "where the contact distance squared stays within double "
             "precision", "change `radius`")
    check_memory(n, "place", dim)
