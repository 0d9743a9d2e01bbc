"""Stress scenes of the event engine and the checks every one of them must pass.

Shared by ``tests/test_stress.py`` (short variants, in the default suite) and
``benchmarks/stress.py`` (long variants, the table of docs/explanation/stability.md): one
builder per scene takes a size ("ci" or "long") and returns a :class:`Case`;
:func:`run_checked` runs it through :func:`gaz_cli.engines.event.run` with a
:class:`Checker` recorder that asserts, while the run goes on,

* event times non-decreasing, within [t0, t0 + duration] (each stream: REBOND
  rows and collisions, across chunks);
* a bounded run: an event budget (generous, never a wall-clock limit), enforced
  when a record buffer is flushed, so a run that loops forever on recorded
  events ends with :class:`BudgetExceeded` instead of a hang;
* at each snapshot and at the end: no pair closer than (1 - GAP_TOL) sigma_ij,
  every centre inside the box, and (elastic scenes) the energy (kinetic, plus
  m g z under gravity) within ENERGY_TOL_PER_MEVENT per 10^6 events;

and after the run: the engine's count of collisions found overlapping is zero.
Byte-identical REBOND rows for the same seed are checked by running a case
twice and comparing :attr:`Result.rebond_sha256` (a digest of every bounce
row's bytes, and of every collision's).

Reduced units throughout: diameter sigma = 1 m, mass 1 kg, k_B T = 1 J
(temperature 1/k_B), so the thermal speed is 1 m/s and times are in units of
sigma / sqrt(k_B T / m); the mean free time 1 / omega comes from the Enskog
collision frequency (gaz_cli.theory).
"""

from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass, field, replace
from fractions import Fraction

import numpy as np
from scipy.spatial import cKDTree

from gaz_cli import theory
from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.engines.event import driver
from gaz_cli.errors import GazError
from gaz_cli.model.recording import Recorder
from gaz_cli.model.estimates import default_tc
from gaz_cli.model.scene import Scene, State
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species

# --- tolerances, one per kind of comparison, each with its error model -------------------

ENERGY_TOL_PER_MEVENT = 1e-12
"""Relative energy drift allowed per 10^6 events (elastic scenes; kinetic + m g z under
gravity). Each collision rounds both new velocities with a relative error of a few ulp
(eps = 2.2e-16) of the energy it moves; these errors are independent, so the drift is a
random walk ~ sqrt(events) * eps: about 2e-13 after 10^6 events, 6e-13 after 10^7. The bound
(issue 12) grows linearly, 1e-12 per 10^6 events, with 1e-12 as the floor."""

GAP_TOL = 1e-10
"""No pair closer than (1 - GAP_TOL) sigma_ij. A contact is computed to a few ulp of the
positions (x + v dt rounds at eps * |x|, with |x| up to L = 100 sigma here, so ~1e-14 sigma);
a missed collision leaves two particles passing through each other by a good fraction of
sigma. 1e-10 separates the two by four orders of magnitude either way."""

INSIDE_TOL = 1e-13
"""A centre may pass its wall plane (R from the wall) by INSIDE_TOL * L: a bounce puts it
exactly on the plane and a flight x + v dt rounds by one ulp of L (2.2e-16 L; a few with
the parabola under gravity). A particle through a wall is out by a mean free path."""

SCALE_TOL = 1e-10
"""Two realisations of one reduced scene at different scales (sigma, speed) compared in
reduced units (times / (sigma / speed), positions / sigma, velocities / speed). Scaling the
inputs rounds each once (relative 1.1e-16); each collision amplifies a difference by a factor
A (mean free path / sigma, more for glancing collisions), so after c collisions per particle
it is about 1e-16 A^c. Measured at packing 0.2 in 3D: A ~ 6-8, 2e-12 (times) and 2e-11
(velocities) after c = 4. The bound for c = 4 is 1e-10; a real scale dependence (a squared
length underflowing, a tolerance in absolute units) gives differences of order 1."""

BUDGET_FACTOR = 4.0
"""Event budget: this many times the events a case expects (collisions from the Enskog
frequency at the starting temperature, plus wall bounces). A run that needs more is looping."""

UNIT_T = 1.0 / K_B
"""Temperature at which k_B T = 1 J."""

UNIT = Species("unit", 1.0, 0.5)
"""Diameter 1 m, mass 1 kg."""

_BALL = {1: 1.0, 2: math.pi / 4.0, 3: math.pi / 6.0}
"""Volume of a ball of unit diameter, per dimension."""


class BudgetExceeded(AssertionError):
    """A run recorded more events than its budget: it is looping (collapse, a zero-time cycle)."""


# --- the checks -------------------------------------------------------------------------

def smallest_gap(x: np.ndarray, radii: np.ndarray, length: float, periodic: bool) -> float:
    """min over pairs of |r_i - r_j| / (R_i + R_j) - 1 (minimum image if periodic); inf if alone.

    A k-d tree finds the pairs within the largest contact distance: O(N log N).
    """
    n = x.shape[0]
    if n < 2:
        return math.inf
    reach = 2.0 * float(radii.max())
    if periodic:
        xs = np.where(x >= length, 0.0, x)
        tree = cKDTree(xs, boxsize=length)
    else:
        xs = x
        tree = cKDTree(xs)
    pairs = tree.query_pairs(reach * 1.25, output_type="ndarray")
    if pairs.size == 0:
        return math.inf
    d = xs[pairs[:, 1]] - xs[pairs[:, 0]]
    if periodic:
        d -= length * np.rint(d / length)
    dist = np.sqrt(np.sum(d * d, axis=1))
    sig = radii[pairs[:, 0]] + radii[pairs[:, 1]]
    return float(np.min(dist / sig - 1.0))


def escapes(x: np.ndarray, radii: np.ndarray, length: float, periodic: bool) -> int:
    """How many centres lie outside the box (walls: closer than R - INSIDE_TOL L to a wall)."""
    if periodic:
        return int(np.sum(np.any((x < 0.0) | (x >= length), axis=1)))
    slack = INSIDE_TOL * length
    lo = radii[:, None] - slack
    hi = length - radii[:, None] + slack
    return int(np.sum(np.any((x < lo) | (x > hi), axis=1)))


def energy(masses: np.ndarray, x: np.ndarray, v: np.ndarray, g: float) -> float:
    """Kinetic energy, plus m g z (z the last axis, from the wall at 0) under gravity; J."""
    e = 0.5 * float(np.sum(masses * np.sum(v * v, axis=1)))
    if g:
        e += g * float(np.sum(masses * x[:, -1]))
    return e


@dataclass
class Case:
    """One stress run: the scene, its initial state, what to expect of it."""

    name: str
    scene: Scene
    state: State
    expected_events: float
    """Events (collisions + bounces) the run should take, for the budget."""
    snapshots: int = 4
    """Geometry and energy checked at this many instants (plus the end)."""
    t0: float = 0.0
    """Clock offset: the run goes from t0 to t0 + duration (see :func:`_run_from`)."""
    conserves_energy: bool = True
    """Elastic: energy must be conserved (inelastic: it may only decrease)."""
    budget: float | None = None
    """Event budget; default BUDGET_FACTOR * expected_events."""

    @property
    def sigma(self) -> float:
        return 2.0 * float(self.scene.radii().max())


@dataclass
class Result:
    """What a checked run measured: a row of docs/explanation/stability.md."""

    name: str
    n: int
    events: int
    collisions: int
    bounces: int
    drift: float
    """Largest |E - E0| / E0 seen (elastic scenes), or the final E / E0 (inelastic)."""
    min_gap: float
    """Smallest gap / sigma_ij over the snapshots and the end."""
    escapes: int
    overlapping: int
    """Collisions the engine found overlapping (a missed collision shows up as one)."""
    run_s: float
    rebond_sha256: str
    final: State = field(repr=False, default=None)
    collision_times: list = field(repr=False, default_factory=list)
    records: dict = field(repr=False, default_factory=dict)


class Checker(Recorder):
    """A recorder that checks a run as it goes (see the module docstring) and keeps digests.

    ``keep`` keeps every bounce and collision row in memory as well (short runs).
    """

    want_bounces = True
    want_collisions = True

    def __init__(self, case: Case, keep: bool = False, strict: bool = True):
        sc = case.scene
        self.strict = strict
        self.violations: list[str] = []
        self.case = case
        self.masses = sc.masses()
        self.radii = sc.radii()
        self.periodic = sc.boundary == "periodic"
        self.t0 = case.t0
        self.t1 = case.t0 + sc.duration
        self.snapshot_every = sc.duration / case.snapshots if case.snapshots else None
        self.budget = case.budget if case.budget is not None else BUDGET_FACTOR * case.expected_events
        st = case.state
        self.e0 = energy(self.masses, st.positions, st.velocities, sc.gravity)
        self.last_b = -math.inf
        self.last_c = -math.inf
        self.n_b = 0
        self.n_c = 0
        self.drift = 0.0
        self.min_gap = math.inf
        self.escapes = 0
        self.snap_times: list[float] = []
        self.hash_b = hashlib.sha256()
        self.hash_c = hashlib.sha256()
        self.keep = keep
        self.kept_b: list[tuple] = []
        self.kept_c: list[tuple] = []

    def _times(self, t: np.ndarray, last: float, what: str) -> float:
        if t.size == 0:
            return last
        self.expect(t[0] >= last and np.all(np.diff(t) >= 0.0), f"{what} times decrease")
        self.expect(t[0] >= self.t0 and t[-1] <= self.t1, f"{what} outside the run's time span")
        return float(t[-1])

    def _spend(self) -> None:
        if self.n_b + self.n_c > self.budget:
            raise BudgetExceeded(f"{self.case.name}: more than {self.budget:.3g} events "
                                 f"(expected {self.case.expected_events:.3g})")

    def add_bounces(self, t, particle, wall, speed, vperp):
        self.last_b = self._times(t, self.last_b, "bounce")
        self.n_b += t.size
        for a in (t, particle, wall, speed, vperp):
            self.hash_b.update(np.ascontiguousarray(a).tobytes())
        if self.keep:
            self.kept_b.append(tuple(np.array(a) for a in (t, particle, wall, speed, vperp)))
        self._spend()

    def add_collisions(self, t, i, j, impulse):
        self.last_c = self._times(t, self.last_c, "collision")
        self.n_c += t.size
        for a in (t, i, j, impulse):
            self.hash_c.update(np.ascontiguousarray(a).tobytes())
        if self.keep:
            self.kept_c.append(tuple(np.array(a) for a in (t, i, j, impulse)))
        self._spend()

    def add_snapshot(self, t, positions, velocities):
        self.snap_times.append(t)
        self.check_state(positions, velocities)

    def check_state(self, x: np.ndarray, v: np.ndarray) -> None:
        """Geometry and energy of one state; raises AssertionError at the first violation."""
        sc = self.case.scene
        gap = smallest_gap(x, self.radii, sc.length, self.periodic)
        self.min_gap = min(self.min_gap, gap)
        out = escapes(x, self.radii, sc.length, self.periodic)
        self.escapes += out
        e = energy(self.masses, x, v, sc.gravity)
        events = self.n_b + self.n_c
        if self.case.conserves_energy:
            rel = abs(e - self.e0) / self.e0
            self.drift = max(self.drift, rel)
            allowed = ENERGY_TOL_PER_MEVENT * max(1.0, events / 1e6)
            self.expect(rel <= allowed, f"energy drift {rel:.3g} > {allowed:.3g} after {events} events")
        else:
            self.drift = e / self.e0
            self.expect(e <= self.e0 * (1.0 + ENERGY_TOL_PER_MEVENT), "an inelastic gas gained energy")
        self.expect(gap >= -GAP_TOL, f"two particles overlap: gap {gap:.3g} sigma")
        self.expect(out == 0, f"{out} particles outside the box")

    def expect(self, ok, message: str) -> None:
        """Strict: AssertionError(message) unless ok. Otherwise note the first violations."""
        if ok:
            return
        if self.strict:
            raise AssertionError(message)
        if len(self.violations) < 3 and message not in self.violations:
            self.violations.append(message)

    def records(self) -> dict:
        names_b = ("t", "particle", "wall", "speed", "vperp")
        names_c = ("t", "i", "j", "impulse")
        out = {}
        for kept, names, key in ((self.kept_b, names_b, "bounces"), (self.kept_c, names_c, "collisions")):
            out[key] = {n: (np.concatenate([c[k] for c in kept]) if kept else np.empty(0))
                        for k, n in enumerate(names)}
        return out


def run_checked(case: Case, keep: bool = False) -> Result:
    """Run ``case`` with a :class:`Checker`: every check of the module docstring, then the Result.

    Raises AssertionError at the first violation (BudgetExceeded for a run out of budget).
    """
    return _run(Checker(case, keep=keep))


def measure(case: Case) -> tuple[Result | None, list[str]]:
    """Run ``case`` and report instead of asserting: (Result, violations) for the table of
    benchmarks/stress.py; (None, [why]) when the run could not finish (budget, an error)."""
    chk = Checker(case, strict=False)
    try:
        res = _run(chk)
    except (AssertionError, GazError) as err:
        return None, [f"{type(err).__name__}: {err}"]
    return res, chk.violations


def _run(chk: Checker) -> Result:
    case = chk.case
    t_start = time.perf_counter()
    if case.t0:
        stats = _run_from(case.scene, case.state, chk, case.t0)
    else:
        stats = engine.run(case.scene, case.state, chk)
    run_s = time.perf_counter() - t_start
    fin = stats.final
    chk.check_state(fin.positions, fin.velocities)
    chk.expect(stats.wall_bounces == chk.n_b and stats.collisions == chk.n_c, "records lost")
    overlapping = int(stats.extras["overlapping_collisions"])
    chk.expect(overlapping == 0, f"{overlapping} collisions found overlapping (missed collisions)")
    digest = hashlib.sha256(chk.hash_b.digest() + chk.hash_c.digest()).hexdigest()
    records = chk.records() if chk.keep else {}
    times = list(records["collisions"]["t"]) if chk.keep else []
    return Result(case.name, case.scene.n, stats.events, stats.collisions, stats.wall_bounces,
                  chk.drift, chk.min_gap, chk.escapes, overlapping, run_s, digest, fin,
                  times, records)


def _run_from(scene: Scene, state: State, recorder: Recorder, t0: float):
    """Run ``scene`` from ``state`` taken to be at absolute time t0, up to t0 + duration
    (a continued run: ``engine.run(..., start_time=t0)``), so that absolute event times are
    large (late times, issue 12). Snapshots are off (the checks run on the final state)."""
    recorder.snapshot_every = None
    return engine.run(scene, state, recorder, start_time=t0)


# --- scene builders -----------------------------------------------------------------------

def reduced(dim, n, packing, boundary="walls", duration=1.0, seed=1, **kw) -> Scene:
    """n particles of diameter 1, mass 1, k_B T = 1 at ``packing`` (box side from it)."""
    length = (n * _BALL[dim] / packing) ** (1.0 / dim)
    return Scene(dim=dim, length=length, duration=duration, components=((UNIT, n),),
                 temperature=UNIT_T, seed=seed, boundary=boundary, **kw)


def omega(scene: Scene) -> float:
    """Enskog collision frequency per particle at the scene's density and temperature (1/s)."""
    sigma = 2.0 * float(scene.radii().mean())
    if scene.dim == 1:
        return float(theory.rods_collision_frequency(scene.n, scene.length, sigma / 2.0,
                                                     scene.temperature, float(scene.masses().mean())))
    model = {2: "henderson", 3: "carnahan-starling"}[scene.dim]
    return float(theory.enskog_collision_frequency(scene.dim, scene.n / scene.volume, sigma,
                                                   scene.temperature, float(scene.masses().mean()),
                                                   model=model))


def _thermal(scene: Scene, per_particle: float) -> Case:
    """A thermal scene run for ``per_particle`` collisions per particle (duration from omega)."""
    w = omega(scene)
    duration = 2.0 * per_particle / w
    scene = replace(scene, duration=duration)
    state = initial_state(scene)
    return scene, state, scene.n * per_particle


def dense(dim, boundary, packing, size, seed=1) -> Case:
    """A dense fluid from a lattice (packing above the random-growth limit) or grown."""
    n = {"ci": {1: 400, 2: 400, 3: 500}, "long": {1: 4000, 2: 4000, 3: 4000}}[size][dim]
    per = {"ci": 150, "long": 500}[size]
    sc = reduced(dim, n, packing, boundary, seed=seed, placement="lattice" if dim > 1 else "auto")
    sc, st, ev = _thermal(sc, per)
    name = f"dense {dim}D {boundary} {packing:g}"
    return Case(name, sc, st, ev * 1.2)


def _state(x, v) -> State:
    x = np.ascontiguousarray(x, dtype=np.float64)
    return State(x, np.ascontiguousarray(v, dtype=np.float64), np.zeros(len(x), dtype=np.int64))


def _scene(dim, n, length, duration, boundary="walls", species=UNIT, **kw) -> Scene:
    return Scene(dim=dim, length=float(length), duration=float(duration),
                 components=((species, n),), temperature=UNIT_T, seed=0, boundary=boundary, **kw)


def lockstep_lattice(dim, size) -> Case:
    """Particles on a square (cubic) lattice of spacing 2 sigma, columns along x moving at
    +1 and -1 in turn, and every particle at the same speed 1/2 (1/4) along y (z): every pair
    of neighbouring columns collides head-on at the same instant, every row reaches its wall
    at the same instant and the rows then collide in turn, all in exact (dyadic) arithmetic."""
    k = {"ci": {2: 16, 3: 8}, "long": {2: 32, 3: 12}}[size][dim]
    duration = {"ci": 600.0, "long": {2: 3000.0, 3: 1500.0}[dim]}[size]
    grid = np.stack(np.meshgrid(*([np.arange(k)] * dim), indexing="ij"), -1).reshape(-1, dim)
    x = 1.0 + 2.0 * grid
    v = np.zeros_like(x)
    v[:, 0] = np.where(grid[:, 0] % 2 == 0, 1.0, -1.0)
    v[:, 1] = 0.5
    if dim == 3:
        v[:, 2] = 0.25
    n = len(x)
    sc = _scene(dim, n, 2.0 * k, duration)
    # every particle: a collision or bounce along x each time unit, fewer along y, z
    # each particle meets a neighbour or a wall along x once a time unit, less often along y, z
    return Case(f"ties: lock-step lattice {dim}D", sc, _state(x, v), n * duration * 0.75)


def head_on_pairs(size) -> Case:
    """3D: pairs on a cubic lattice of spacing 4, each pair 2 sigma apart along a random axis,
    approaching head-on at a random dyadic speed in [1, 2], exactly symmetric about its site
    (all first collisions are over by t = 1/2, before any particle reaches another site)."""
    k = {"ci": 6, "long": 10}[size]
    duration = {"ci": 1000.0, "long": 6000.0}[size]
    rng = np.random.default_rng(7)
    sites = 2.0 + 4.0 * np.stack(np.meshgrid(*([np.arange(k)] * 3), indexing="ij"), -1).reshape(-1, 3)
    axis = rng.integers(0, 3, len(sites))
    speed = rng.integers(8, 17, len(sites)) / 8.0
    e = np.eye(3)[axis]
    x = np.concatenate([sites - e, sites + e])
    v = np.concatenate([e * speed[:, None], -e * speed[:, None]])
    n = len(x)
    sc = _scene(3, n, 4.0 * k, duration)
    # once the first collisions are over: a dilute gas at mean speed ~1, box side 4 k
    return Case("ties: symmetric head-on pairs 3D", sc, _state(x, v), n * duration * 0.5)


def newton_cradle(dim, size) -> Case:
    """Rows of touching particles (centres exactly sigma apart) along x, a striker at speed 1
    into each from the left; in 3D rows side by side 2 sigma apart. Every collision of a row
    after the first is at distance exactly sigma, at the same instant as the one before it."""
    rows = {"ci": {1: 1, 3: 16}, "long": {1: 1, 3: 36}}[size][dim]
    per_row = {"ci": 20, "long": 50}[size]
    duration = {"ci": {1: 1e5, 3: 1e4}, "long": {1: 2e6, 3: 4e4}}[size][dim]
    length = float(2 * per_row + 8) if dim == 1 else float(max(2 * per_row + 8, 64))
    line = np.concatenate([[2.5], 8.0 + np.arange(per_row - 1)])
    if dim == 1:
        x = line[:, None]
        vel = np.zeros_like(x)
        vel[0, 0] = 1.0
    else:
        side = int(math.ceil(math.sqrt(rows)))
        yz = [(2.0 + 2.0 * (r // side), 2.0 + 2.0 * (r % side)) for r in range(rows)]
        x = np.array([[xi, y, z] for y, z in yz for xi in line])
        vel = np.zeros_like(x)
        vel[::per_row, 0] = 1.0
    n = len(x)
    sc = _scene(dim, n, length, duration)
    # each row: the pulse crosses it (per_row collisions) and bounces once per 2 L of travel
    ev = rows * duration / (2.0 * length) * (per_row + 2) * 2.0
    return Case(f"ties: Newton's cradle {dim}D", sc, _state(x, vel), ev)


def converging(dim, size) -> Case:
    """Groups of 2 D particles converging on a point along +-x, +-y (+-z) at equal speeds:
    the four (2D) or twelve (3D) neighbouring pairs of a group touch at the same instant,
    each particle in two (four) collisions at once. Groups on a lattice of spacing 8."""
    k = {"ci": {2: 6, 3: 3}, "long": {2: 8, 3: 4}}[size][dim]
    duration = {"ci": 3000.0, "long": 20000.0}[size]
    sites = 4.0 + 8.0 * np.stack(np.meshgrid(*([np.arange(k)] * dim), indexing="ij"), -1).reshape(-1, dim)
    xs, vs = [], []
    for d in range(dim):
        for s in (1.0, -1.0):
            e = np.zeros(dim)
            e[d] = s
            xs.append(sites + 2.0 * e)
            vs.append(np.tile(-e, (len(sites), 1)))
    x, v = np.concatenate(xs), np.concatenate(vs)
    n = len(x)
    sc = _scene(dim, n, 8.0 * k, duration)
    what = {2: "four", 3: "six"}[dim]
    # after the first collisions: a dilute gas at speed 1 in a box of side 8 k
    return Case(f"ties: symmetric {what}-body collisions {dim}D", sc, _state(x, v), n * duration * 0.5)


def grazing_pair(dim, distance, side, seed) -> tuple[Case, bool]:
    """Two particles (sigma = 1), B launched ``distance`` sigma from A towards it with impact
    parameter (1 + side * 1e-12) sigma, in a random direction; and whether they meet in
    exact arithmetic (rational numbers from the very floats given to the engine)."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(dim)
    u /= np.linalg.norm(u)
    p = rng.standard_normal(dim)
    p -= p.dot(u) * u
    p /= np.linalg.norm(p)
    b = 1.0 + side * 1e-12
    length = 3.0 * distance + 8.0
    xa = np.full(dim, 4.0 + distance)
    xb = xa + distance * u + b * p
    speed = 1.0 + rng.random()
    x = np.array([xa, xb])
    v = np.array([np.zeros(dim), -speed * u])
    # exact: b = dr.dv, disc = b^2 - a c, with c = |dr|^2 - 1 (sigma = 1)
    dr = [Fraction(float(q)) - Fraction(float(r)) for q, r in zip(x[1], x[0])]
    dv = [Fraction(float(q)) - Fraction(float(r)) for q, r in zip(v[1], v[0])]
    bb = sum(q * r for q, r in zip(dr, dv))
    a = sum(q * q for q in dv)
    c = sum(q * q for q in dr) - 1
    meet = bb < 0 and bb * bb - a * c > 0
    duration = (distance + 2.0) / speed
    sc = _scene(dim, 2, length, duration)
    return Case(f"grazing {dim}D at {distance:g} sigma", sc, _state(x, v), 4.0, snapshots=0), meet


def mass_mixture(size, ratio=1e6) -> Case:
    """2D walls, three species of equal diameter and masses 1, sqrt(ratio), ratio; equal temperature."""
    n = {"ci": 300, "long": 3000}[size]
    per = {"ci": 400, "long": 1000}[size]
    third = n // 3
    comps = tuple((Species(f"m{m:g}", float(m), 0.5), third) for m in (1.0, math.sqrt(ratio), ratio))
    length = math.sqrt(3 * third * _BALL[2] / 0.3)
    sc = Scene(dim=2, length=length, duration=1.0, components=comps, temperature=UNIT_T, seed=3)
    # light particles set the rate: omega of a unit-mass gas at this density
    w = omega(replace(sc, components=((UNIT, 3 * third),)))
    sc = replace(sc, duration=2.0 * per / w)
    st = initial_state(sc)
    return Case(f"mixture: masses 1 : 1e{math.log10(ratio):.0f}", sc, st, 3 * third * per * 1.5)


def radius_mixture(dim, size, ratio=100.0) -> Case:
    """Walls; a few big particles of diameter ``ratio`` among many small ones of diameter 1."""
    big_n = {2: 4, 3: 8}[dim]
    small_n = {"ci": {2: 1000, 3: 400}, "long": {2: 3000, 3: 1000}}[size][dim]
    per = {"ci": 60, "long": 200}[size]
    big = Species("big", ratio ** dim, ratio / 2.0)  # same mass density
    small = UNIT
    length = {2: 4.5 * ratio, 3: 3.0 * ratio}[dim]
    sc = Scene(dim=dim, length=length, duration=1.0, components=((big, big_n), (small, small_n)),
               temperature=UNIT_T, seed=5)
    # the small ones' rate: a gas of small particles filling the free volume
    free = length ** dim - big_n * _BALL[dim] * ratio ** dim
    w = omega(replace(sc, length=free ** (1.0 / dim), components=((small, small_n),)))
    w = max(w, 1.0 / length)
    sc = replace(sc, duration=2.0 * per / w)
    st = initial_state(sc)
    # the big ones crowd the small ones: about twice the rate of the free volume's gas
    return Case(f"mixture: radii 1 : {ratio:g} {dim}D", sc, st, small_n * per * 4.0)


SCALES = [(s, u) for s in (1e-10, 1.0, 1e3) for u in (1e-5, 1.0, 1e6)]
"""(sigma in m, speed unit in m/s) of the scale-invariance runs."""


def scaled(sigma: float, speed: float, size="ci") -> Case:
    """One reduced scene (3D walls, packing 0.2, thermal speeds 1, sigma 1) in the units
    sigma m and speed m/s: positions times sigma, velocities times speed, duration times
    sigma / speed, masses 1 kg."""
    n = {"ci": 64, "long": 500}[size]
    base = reduced(3, n, 0.2, "walls", seed=11)
    per = 4  # (beyond, chaos makes the realisations different trajectories: SCALE_TOL)
    base, st, ev = _thermal(base, per)
    sp = Species("scaled", 1.0, 0.5 * sigma)
    sc = replace(base, length=base.length * sigma, duration=base.duration * sigma / speed,
                 components=((sp, n),))
    state = _state(st.positions * sigma, st.velocities * speed)
    return Case(f"scale: sigma {sigma:g} m, speed {speed:g} m/s", sc, state, ev * 2.0 + 10 * n)


def inelastic(dim, restitution, size) -> Case:
    """A dense gas (2D 0.5, 3D 0.4, walls) cooling with restitution e and the default TC
    contact time (1e-4 mean free times): no stall, no overlap, energy only decreasing,
    and (short variant) no more events than the gas at its starting temperature would take
    (it cools, so collisions slow down). Large systems cluster (the clustering instability
    of granular gases: the dense regions collide faster than the mean), so the long variant
    allows ten times that."""
    n = {"ci": 400, "long": 4000}[size]
    per = {"ci": 400, "long": 1000}[size]
    packing = {2: 0.5, 3: 0.4}[dim]
    sc = reduced(dim, n, packing, "walls", seed=2, restitution=restitution, placement="lattice")
    sc, st, ev = _thermal(sc, per)
    sc = replace(sc, tc=default_tc(sc))
    budget = ev * (1.5 if size == "ci" else 10.0)
    return Case(f"inelastic e = {restitution:g} {dim}D", sc, st, ev, conserves_energy=False,
                budget=budget)


def gravity_dense_bottom(dim, size) -> Case:
    """Elastic disks (spheres) under gravity m g sigma = k_B T, starting as a dense layer on
    the floor (a square / cubic lattice of spacing 1.1 sigma, local packing 0.65 in 2D, 0.39
    in 3D) with Maxwell velocities at k_B T = 1: kinetic + potential energy conserved."""
    side, layers = {"ci": {2: (20, 8), 3: (10, 4)}, "long": {2: (60, 20), 3: (20, 8)}}[size][dim]
    per = {"ci": 100, "long": 600}[size]
    length = 1.1 * side
    grid = np.stack(np.meshgrid(*([np.arange(side)] * (dim - 1) + [np.arange(layers)]),
                                indexing="ij"), -1).reshape(-1, dim)
    x = 0.55 + 1.1 * grid
    n = len(x)
    v = np.random.default_rng(4).standard_normal((n, dim))
    sc = _scene(dim, n, length, 1.0, gravity=1.0)
    # the layer's rate: a fluid at about its packing
    w = omega(reduced(dim, n, {2: 0.6, 3: 0.35}[dim]))
    sc = replace(sc, duration=2.0 * per / w)
    return Case(f"gravity: elastic dense bottom layer {dim}D", sc, _state(x, v), n * per * 1.5)


def gravity_settling(size) -> Case:
    """Inelastic disks (e = 0.5, TC model) under gravity come to rest on the floor: 2D walls,
    200 disks, m g sigma = 10 k_B T, for 100 time units (issue 12, item 4 (c))."""
    n = {"ci": 200, "long": 500}[size]
    sc = reduced(2, n, 0.2, "walls", seed=6, gravity=10.0, restitution=0.5, duration=100.0)
    sc = replace(sc, tc=default_tc(sc))
    st = initial_state(sc)
    # settling: the kinetic energy is gone after a few hundred collisions per particle
    # the budget leaves room for the engine's slow-down guard to see the bed settle (about
    # 6000 events a disk with the guard's chunks at 2^16 events in tests/test_stress.py; the
    # long variant runs with the engine's own chunks and bound, 2e9 projected events)
    return Case("gravity: inelastic bed coming to rest", sc, st, n * 1000.0,
                conserves_energy=False, budget={"ci": n * 2e4, "long": 2e8}[size])


def gravity_at_rest(size) -> Case:
    """One disk at rest on the floor under gravity (issue 12, item 4 (b))."""
    sc = _scene(2, 1, 10.0, 10.0, gravity=1.0)
    # the budget leaves room for the engine's stall guard: three chunks of events at one
    # instant (chunks of 2^12 events in tests/test_stress.py, of 2^22 in the engine)
    return Case("gravity: one disk at rest on the floor", sc, _state([[5.0, 0.5]], [[0.0, 0.0]]),
                10.0, conserves_energy=True, budget={"ci": 1e5, "long": 2e7}[size])


def long_run(size) -> Case:
    """The standard scene (3D periodic, packing 0.3, FCC start): 5 10^5 events (ci) or 10^7."""
    n = {"ci": 1000, "long": 4000}[size]
    events = {"ci": 5e5, "long": 1e7}[size]
    sc = reduced(3, n, 0.3, "periodic", seed=1, placement="lattice")
    sc, st, ev = _thermal(sc, events / n)
    return Case(f"long run 3D periodic 0.3", sc, st, ev * 1.2, snapshots=2)


def late_clock(mean_free_times: float, size) -> Case:
    """A 2D periodic fluid (packing 0.5) whose clock starts at ``mean_free_times`` mean free
    times: absolute event times are that large, their differences small."""
    n = {"ci": 400, "long": 2000}[size]
    per = {"ci": 100, "long": 1000}[size]
    sc = reduced(2, n, 0.5, "periodic", seed=8, placement="lattice")
    sc, st, ev = _thermal(sc, per)
    t0 = mean_free_times / omega(sc)
    return Case(f"late clock at {mean_free_times:.0e} mean free times", sc, st, ev * 1.5,
                snapshots=0, t0=t0)


def long_time(mean_free_times: float, size) -> Case:
    """A small 2D periodic fluid (16 disks, packing 0.3) run for ``mean_free_times`` mean
    free times: late absolute times reached by simulating them."""
    sc = reduced(2, 16, 0.3, "periodic", seed=9)
    sc, st, ev = _thermal(sc, mean_free_times)
    return Case(f"late time: {mean_free_times:.0e} mean free times simulated", sc, st, ev * 1.5,
                snapshots=2)


def rods_under_gravity(n, mass_ratio, gravity, length, duration) -> Case:
    """1D rods of diameter 1 bouncing on the floor: n - n // 2 of mass 1, n // 2 of mass
    ``mass_ratio``, k_B T = 1, seed 0 (found by the property tests)."""
    comps = ((Species("s", 1.0, 0.5), n - n // 2), (Species("b", float(mass_ratio), 0.5), n // 2))
    sc = Scene(dim=1, length=float(length), duration=float(duration), components=comps,
               temperature=UNIT_T, seed=0, gravity=float(gravity))
    st = initial_state(sc)
    return Case(f"gravity: {n} rods 1D, masses 1 : {mass_ratio:g}, g = {gravity:g}", sc, st,
                max(2e5, 10.0 * n * duration), snapshots=4)
