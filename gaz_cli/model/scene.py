"""What one run is: the :class:`Scene` (everything that defines it) and the :class:`State`
(positions and velocities). A description with no engine, no disk and no check beyond its
types: the scene is admitted by the one door, :func:`gaz_cli.scenes.validate.validate`, and
turned into a state by :func:`gaz_cli.placement.initial.initial_state`. It imports no NumPy
(its methods do, when called): the CLI reads the table of options before any command runs,
and a signal in those first tenths of a second must already find gaz's handlers in place.
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields, replace
from typing import TYPE_CHECKING

from gaz_cli.model.species import Species

if TYPE_CHECKING:
    import numpy as np

ENGINES = ("auto", "event", "ideal", "reference", "step")
"""What a scene's ``engine`` may say (the registry, :mod:`gaz_cli.engines.registry`, runs each
name but 'auto', which the door resolves)."""

BOUNDARIES = ("walls", "periodic")

RECORD_LEVELS = ("none", "bounces", "all")

PLACEMENTS = ("auto", "rejection", "rapid", "lattice", "grow")
"""Placement methods (gaz_cli.placement.METHODS; placement is not imported here)."""

INITIAL_KINDS = ("explicit", "upper-half")
"""Initial states other than placement + Maxwell velocities (Scene.initial['kind'])."""

ALL = ("event", "ideal", "reference", "step")
"""The engines an option applies to when it applies to every engine."""


@dataclass(frozen=True)
class Option:
    """One row of the table of scene options: a field of :class:`Scene` as every layer sees it.

    ``gaz simulate``'s flags (:func:`gaz_cli.cli.scene_option`), the scene file's
    keys and their comments (:mod:`gaz_cli.scenes.files`), the range checks
    (:func:`gaz_cli.model.checks.check_option`), the step engine's own options
    (:data:`STEP_ONLY`) and the SCENE row (:mod:`gaz_cli.results`) read it: adding an option
    is one row here plus its physics.
    """

    kind: str
    """'real', 'int', 'str', 'bool' or 'planes': the scene file's type and the CLI's."""
    unit: str
    """SI unit, or what the value means: the scene file's comment beside the key."""
    rule: tuple | None
    """The range check (:func:`gaz_cli.model.checks.check_option`): ('positive', hint),
    ('at least zero', unit), ('unit interval', what), ('one of', choices), ('whole at least
    zero', unit), ('bool',); None when the field has a check of its own (dim, seed, gravity,
    planes)."""
    engines: tuple = ALL
    """The engines that use it; with any other engine it must keep its default."""
    flag: str | None = None
    """``gaz simulate``'s flag."""
    help: str = ""
    """The flag's help (--help)."""
    column: bool = False
    """Stored in its own column ``sc_<name>`` of the SCENE table (every field is in ``sc_file``)."""
    name: str = ""
    """The field's name: a Scene attribute and the scene file's key (set by :data:`OPTIONS`)."""


def option(default=MISSING, **row):
    """A Scene field carrying its :class:`Option` row as dataclass field metadata."""
    meta = {"option": Option(**row)}
    return field(metadata=meta) if default is MISSING else field(default=default, metadata=meta)


@dataclass(frozen=True)
class Scene:
    """Everything that defines one run. SI units throughout.

    ``components`` is a tuple of (Species, count); particle i belongs to the
    component whose block contains i (blocks in the order given). Every other field but
    ``initial`` and ``extras`` is a scene option, its :class:`Option` row (unit, range,
    engines, flag, help) in its metadata: :data:`OPTIONS` collects them.
    """

    dim: int = option(kind="int", unit="1, 2 or 3", rule=None, flag="--dim", help="Dimension of space: 1, 2 or 3.")
    length: float = option(kind="real", unit="m, box side", rule=("positive", " (m)"), flag="--length",
                           help="Box side L, m.")
    duration: float = option(kind="real", unit="simulated s", rule=("positive", " (simulated seconds)"),
                             flag="--duration", help="Simulated time T, s (not the run time).")
    components: tuple
    temperature: float = option(300.0, kind="real", unit="K", rule=("positive", " (kelvin)"), flag="--temperature",
                                help="Temperature of the Maxwell-Boltzmann velocities, K.  [default: 300]",
                                column=True)
    seed: int | None = option(None, kind="int", unit="same seed, same rows", rule=None, flag="--seed", column=True)
    boundary: str = option("walls", kind="str", unit="walls | periodic", rule=("one of", BOUNDARIES),
                           flag="--boundary", column=True,
                           help="Hard walls (the exam) or a periodic box (pressure from the collision virial).  "
                                "[default: walls]")
    gravity: float = option(0.0, kind="real", unit="m/s^2, towards 0 along the last axis", rule=None,
                            flag="--gravity", column=True,
                            help="Uniform gravity g, m/s^2, pulling towards 0 along the last axis.  [default: 0]")
    restitution: float = option(1.0, kind="real", unit="particle collisions, 1 = elastic",
                                rule=("unit interval", "particle collisions"), flag="--restitution", column=True,
                                help="Coefficient of restitution of particle collisions (1 = elastic).  [default: 1]")
    tc: float = option(0.0, kind="real", unit="s, TC-model contact time", rule=("at least zero", "s"), flag="--tc",
                       column=True,
                       help="TC model contact time, s: collisions within tc of a previous one are elastic "
                            "(guards against inelastic collapse). Default: 1e-4 of the mean free time when "
                            "--restitution < 1.")
    engine: str = option("auto", kind="str", unit=" | ".join(ENGINES), rule=("one of", ENGINES), flag="--engine",
                         column=True,
                         help="auto: the cheapest exact path for the scene, named with its reason in the summary "
                              "(ideal when no two particles can meet, step for drag, pair gravity, planes or damped "
                              "walls, event otherwise); event: fast exact event-driven engine; ideal: closed-form "
                              "wall bounces, no queue (point particles, or one); reference: the exam's algorithm "
                              "(slow, the specification); step: fixed time step (--dt, or auto picks one).  "
                              "[default: auto]")
    placement: str = option("auto", kind="str", unit=" | ".join(PLACEMENTS), rule=("one of", PLACEMENTS),
                            flag="--method", column=True,
                            help="Placement method (see gaz place --help); a mixture of sizes far apart places its "
                                 "large particles first, then the small ones among them.  [default: auto]")
    record: str = option("bounces", kind="str", unit=" | ".join(RECORD_LEVELS), rule=("one of", RECORD_LEVELS),
                         flag="--record", column=True,
                         help="What goes to the database: nothing but the summary, wall bounces (REBOND), "
                              "or also particle collisions (table CHOC).  [default: bounces]")
    # time-stepped engine only
    dt: float | None = option(None, kind="real", unit="s, time step (step engine)", rule=("positive", " (seconds)"),
                              engines=("step",), flag="--dt", help="Time step, s (--engine step).", column=True)
    drag: float = option(0.0, kind="real", unit="1/s, linear friction (step engine)", rule=("at least zero", "1/s"),
                         engines=("step",), flag="--drag", column=True,
                         help="Linear friction gamma, 1/s (--engine step).  [default: 0]")
    pair_gravity: float = option(0.0, kind="real", unit="m^3/(kg s^2), G between bodies (step engine)",
                                 rule=("at least zero", "m^3/(kg s^2)"), engines=("step",), flag="--pair-gravity",
                                 column=True,
                                 help="Newtonian attraction between bodies with this G, m^3/(kg s^2) "
                                      "(--engine step).  [default: 0]")
    softening: float = option(0.0, kind="real", unit="m, Plummer softening (step engine)", rule=("at least zero", "m"),
                              engines=("step",), flag="--softening",
                              help="Plummer softening length, m (--engine step).  [default: 0]")
    wall_restitution: float = option(1.0, kind="real", unit="walls, 1 = elastic (step engine)",
                                     rule=("unit interval", "the walls"), engines=("step",), flag="--wall-restitution",
                                     column=True,
                                     help="Restitution of the walls (1 = elastic; --engine step).  [default: 1]")
    planes: tuple = option((), kind="planes", unit="point, inward normal, restitution (step engine)", rule=None,
                           engines=("step",), flag="--plane",
                           help="Extra plane wall: a point, its inward normal, optional restitution "
                                "(--engine step). Repeatable.")
    """Extra walls for the step engine: tuples (point (D,), inward normal (D,), restitution)."""
    print_every: int = option(0, kind="int", unit="steps between diagnostics (step engine)",
                              rule=("whole at least zero", "steps"), engines=("step",), flag="--print-every",
                              help="Diagnostics on stderr every this many steps (--engine step).  [default: 0]")
    """Step engine: diagnostics every this many steps (0: none)."""
    force: bool = option(False, kind="bool", unit="run beyond the work bounds", rule=("bool",), flag="--force",
                         help="Run even when the estimated work is beyond its bound: more than 1e11 events "
                              "(event engine), 1e11 steps x particles (step engine), 1e10 events x particles "
                              "(reference engine), 1e4 snapshots, or a trajectory or a SQLite file's rows larger "
                              "than their disk's free space. The refusal prints the estimate. Memory and "
                              "double-precision ranges are never overridden.")
    """Run even when the estimated work (events, steps, snapshots) is beyond its bound."""
    initial: dict | None = field(default=None, hash=False)
    """An initial state other than placement + Maxwell velocities: {'kind': 'explicit',
    'positions': (N, D), 'velocities': (N, D)} or {'kind': 'upper-half', 'velocity_sd': s}
    (random sequential addition in the upper half of the box along the last axis, velocity
    components normal with standard deviation s m/s, the marbles of seed 002)."""
    extras: dict = field(default_factory=dict, compare=False)
    """Settings beside the physics. What a caller may set: how the event engine searches for
    partners (:data:`gaz_cli.engines.event.search.SEARCH`: 'neighbours', 'skin', 'classes'). Every search is exact, but
    each rounds differently and a gas is chaotic: with the same seed, cells and neighbour
    lists give the same numbers of events and different rows (times, speeds in the last
    digits, then the events themselves), so the scene file keeps the search the run took (its
    ``[search]`` table: the ones set, and the ones left on 'auto' as the runner resolved them,
    :func:`gaz_cli.run.runner.with_search`) and reproduces the run. What the door (:func:`gaz_cli.scenes.validate.validate`) adds
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
        import numpy as np

        return np.repeat(np.arange(len(self.components)), [k for _, k in self.components])

    def masses(self) -> np.ndarray:
        """(N,) float64, kg."""
        import numpy as np

        return np.array([s.mass for s in self.species])[self.kinds()]

    def radii(self) -> np.ndarray:
        """(N,) float64, m."""
        import numpy as np

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
        from gaz_cli.geometry import packing_fraction

        return packing_fraction(self.dim, [s.radius for s, _ in self.components], self.length,
                                [k for _, k in self.components])

    def with_seed(self, seed: int) -> "Scene":
        return replace(self, seed=seed)



OPTIONS = {f.name: replace(f.metadata["option"], name=f.name) for f in fields(Scene) if "option" in f.metadata}
"""Scene option name -> its :class:`Option` row, in the order of the Scene's fields."""

STEP_ONLY = {f.name: f.default for f in fields(Scene) if f.name in OPTIONS and OPTIONS[f.name].engines == ("step",)}
"""The step engine's options and their values when they do not apply (other engines)."""

@dataclass
class State:
    """Positions (N, D) m, velocities (N, D) m/s and species index (N,) of every particle."""

    positions: np.ndarray
    velocities: np.ndarray
    kinds: np.ndarray

    def kinetic_energy(self, masses: np.ndarray) -> float:
        """Total kinetic energy, J."""
        import numpy as np

        return float(0.5 * np.sum(masses * np.sum(self.velocities ** 2, axis=1)))

    def copy(self) -> "State":
        return State(self.positions.copy(), self.velocities.copy(), self.kinds.copy())


def fresh_seed() -> int:
    """A random seed from the operating system, to be recorded so the run can be repeated."""
    import numpy as np

    return int(np.random.SeedSequence().generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))
