"""What ``gaz analyse`` and ``gaz place --repeat`` compute from placements and the database.

The store runs the packaged SQL and hands back tables; this module puts the
results beside theory (:mod:`gaz_cli.theory`), with statistical error bars
(:mod:`gaz_cli.analysis.errorbars`), and asks :mod:`gaz_cli.analysis.plots` for figures. It
never prints and never writes SQL.

The database does the summing: bounces per wall, species and time bin
(``sql/bounce_bins.sql``), collisions per time bin (``sql/collision_bins.sql``);
analysis reads those few thousand numbers, not the REBOND rows (figures
excepted), and only for the simulations asked for.

Error bars: every time average (a wall's pressure, the mean over the walls,
the virial pressure, the mean speed of wall hits, the collision rate, the
force balance under gravity, the cooling) is cut into
:data:`gaz_cli.analysis.errorbars.BINS` time bins, reblocked (Flyvbjerg-Petersen),
and, for the quantities an initial draw of few particles fixes for longer
than the run (a wall's share of the kinetic energy, the set of speeds), the
closed-form spread of that draw not yet relaxed by collisions is added. The
error is one standard deviation of the number over repeated runs (seeds) of
the same scene; ``N_EFF`` is the effective number of independent samples.

Each comparison names its theory (``MODEL``) and its caveats (``NOTE``);
where theory cannot give a value for a scene (a fit used beyond its range, a
cooling gas) or does not fit it (a dense fluid at walls, a run that did not
settle), the numeric cell is NaN (empty in csv, null in json) and the reason
is in ``NOTE``: no deviation in sigmas is printed against a theory that does
not apply.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from gaz_cli import interrupts, theory
from gaz_cli.analysis import errorbars
from gaz_cli.constants import K_B
from gaz_cli.errors import GazError, GazWarning, Interrupted, SceneError, StoreError

NA = math.nan
"""What a numeric cell holds when theory or the data cannot give a value (the reason goes in NOTE)."""

BLOCKS = 16
"""Time windows of the block values drawn in the pressure figure, and of :func:`block_sums`' default."""


# --- placement (gaz place) --------------------------------------------------------
MAX_BINS = 10 ** 7
"""Most histogram bins of ``gaz place --repeat`` (three arrays of 80 MB)."""
MAX_PLACE_WORK = 1e11
"""Most particle placements of ``gaz place --repeat`` (repeat x (n + PLACE_OVERHEAD)): a few
hours (measured: 10^6 rods in 0.1 s, 10^5 repetitions of 2 rods in 2 s)."""
PLACE_OVERHEAD = 200
"""A repetition's own cost, in particle placements (about 20 us against 0.1 us a rod)."""


def _check_place_args(dim, n, radius, length):
    if dim not in (1, 2, 3):
        raise SceneError(f"--dim {dim} is not 1, 2 or 3")
    if n is None or n < 1:
        raise SceneError(f"--n must be at least 1, got {n}")
    if not (radius > 0 and math.isfinite(radius)):
        raise SceneError(f"--radius must be > 0, got {radius}")
    if not (length > 0 and math.isfinite(length)):
        raise SceneError(f"--length must be > 0, got {length}")
    from gaz_cli.geometry import DENSEST, ball_volume

    eta = n * float(ball_volume(dim, radius)) / length ** dim
    if 2 * radius >= length:
        raise SceneError(f"a particle of radius {radius:g} m (diameter {2 * radius:g} m) does not fit in a box "
                         f"of side {length:g} m; lower --radius or raise --length")
    if eta >= DENSEST[dim]:
        raise SceneError(f"{n} particles of radius {radius:g} m cannot fit in a box of side {length:g} m "
                         f"(packing fraction {eta:.3g}, densest {DENSEST[dim]:.4g}); "
                         "lower --n or --radius, or raise --length")


def place_once(dim: int, n: int, radius: float, length: float, method: str = "auto",
               seed: int | None = None) -> np.ndarray:
    """(N, D) centres of one placement, m."""
    from gaz_cli import placement

    _check_place_args(dim, n, radius, length)
    rng = np.random.default_rng(seed)
    return placement.place(dim, np.full(n, float(radius)), float(length), rng, method=method)


def placement_histogram(dim: int, n: int, radius: float, length: float, method: str,
                        seed: int | None, repeat: int, bins: int,
                        plot: str | None = None) -> pd.DataFrame:
    """The exam's Q12 study: histogram of centre positions along x over ``repeat`` placements.

    Returns a DataFrame bin_start, bin_end, count (bins over [0, L]); with
    ``plot`` also draws it, over the exact density of the uniform placement
    in 1D (:func:`gaz_cli.theory.rod_centre_density`).
    """
    from gaz_cli import placement
    from gaz_cli.analysis import plots

    _check_place_args(dim, n, radius, length)
    if bins > MAX_BINS:
        raise SceneError(f"--bins {bins} is more than the {MAX_BINS:.0e} a histogram holds; lower --bins")
    work = repeat * (n + PLACE_OVERHEAD)
    if work > MAX_PLACE_WORK:
        raise SceneError(f"--repeat {repeat} placements of {n} particles would take about {work:.3g} "
                         f"particle placements, beyond the {MAX_PLACE_WORK:.0e} allowed (hours of work); "
                         "lower --repeat")
    rng = np.random.default_rng(seed)
    radii = np.full(n, float(radius))
    edges = np.linspace(0.0, length, bins + 1)
    counts = np.zeros(bins, dtype=np.int64)
    for _ in range(repeat):
        x = placement.place(dim, radii, float(length), rng, method=method)[:, 0]
        counts += np.histogram(x, bins=edges)[0]
    frame = pd.DataFrame({"bin_start": edges[:-1], "bin_end": edges[1:], "count": counts})
    if plot:
        exact = _exact_centre_density(dim, n, radius, length)
        title = f"Q12: {n} particle(s) of radius {radius:g} m in [0, {length:g}] m, {dim}D, method {method}"
        plots.placement_histogram(plot, edges, counts, exact, repeat, title)
    return frame


def _exact_centre_density(dim, n, radius, length):
    """x -> exact density (1/m) of a centre for the uniform 1D placement, or None where unknown."""
    if dim != 1:
        return None
    return lambda x: theory.rod_centre_density(x, n, radius, length)


# --- block statistics ---------------------------------------------------------------
def block_sums(t, values, duration: float, blocks: int = BLOCKS) -> np.ndarray:
    """Sum of ``values`` over each of ``blocks`` equal time windows of [0, duration] ((blocks,) array).

    ``t`` (k,) event times, s; ``values`` (k,) or a scalar weight per event.
    Divide by ``duration / blocks`` for a rate per second in each window.
    """
    t = np.asarray(t, dtype=float)
    index = np.clip((t * (blocks / duration)).astype(np.int64), 0, blocks - 1)
    weights = np.broadcast_to(np.asarray(values, dtype=float), t.shape)
    return np.bincount(index, weights=weights, minlength=blocks)[:blocks]


def block_means(t, values, duration: float, blocks: int = BLOCKS) -> np.ndarray:
    """Mean of ``values`` over the events of each time window ((blocks,), NaN where a window is empty)."""
    sums = block_sums(t, values, duration, blocks)
    counts = block_sums(t, 1.0, duration, blocks)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(counts > 0, sums / np.where(counts > 0, counts, 1.0), np.nan)


def mean_and_error(samples) -> tuple[float, float]:
    """Mean of block values and its standard error std(ddof=1)/sqrt(k); NaN blocks are dropped.

    The error is NaN with fewer than two blocks.
    """
    a = np.asarray(samples, dtype=float)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return math.nan, math.nan
    if a.size < 2:
        return float(a.mean()), math.nan
    return float(a.mean()), float(a.std(ddof=1) / math.sqrt(a.size))


# --- one simulation, read once ------------------------------------------------------
@dataclass
class Run:
    """One simulation, as analysis needs it (SI units: kg, m, s, K, J).

    The wall bounces and collisions arrive summed by the database per wall,
    species and time bin (:data:`gaz_cli.analysis.errorbars.BINS` equal windows of
    the run): the rows themselves are read only to draw figures.
    """

    si_num: int
    dim: int
    n: int
    length: float
    duration: float
    species: pd.DataFrame
    """PA_NUM, NAME, MASS_KG, RADIUS_M, COUNT, RANK: one row per species of the mixture, in rank order
    (RANK: the species' block of particle indices, COMPOSITION.CO_RANK; NaN if not recorded)."""
    boundary: str = "walls"
    engine: str = "?"
    gravity: float = 0.0
    restitution: float = 1.0
    wall_restitution: float = 1.0
    tc: float = 0.0
    temperature: float = math.nan
    """The scene's temperature of the initial velocities, K."""
    temperature_error: float = 0.0
    """Standard error of the temperature theory is evaluated at, K (under gravity, from the hits: see report)."""
    temperature_source: str = "kinetic"
    """Where the temperature theory is evaluated at comes from: "kinetic" (the kinetic energy),
    "energy" (under gravity, the conserved energy of the initial state), "hits" (under gravity, the
    settled part's wall hits)."""
    drag: float = 0.0
    """Linear friction gamma of the step engine, 1/s (SCENE.SC_DRAG)."""
    pair_gravity: float = 0.0
    """G of the attraction between bodies, m^3/(kg s^2) (SCENE.SC_PAIR_GRAVITY)."""
    planes: int = 0
    """Extra plane walls of the scene file (its [[planes]])."""
    scene_file: str | None = None
    """The run's scene file (SCENE.SC_FILE), from which its initial state is rebuilt; None if not stored."""
    drift_energy: float = 0.0
    """Periodic box: P^2/(2M) of the total momentum, J, conserved and not thermal (0 when the velocities
    were drawn by gaz, which removes it; an explicit initial state keeps its own)."""
    record: str = "bounces"
    ke_start: float = math.nan
    ke_end: float = math.nan
    events: int | None = None
    collisions: int | None = None
    virial: float = math.nan
    hits: pd.DataFrame = field(default_factory=pd.DataFrame)
    """Bounces per (RE_DIR, PA_NUM, BIN): NB_REBONDS, SUM_VP, SUM_VIT (sql/bounce_bins.sql)."""
    collision_bins: pd.DataFrame | None = None
    """Collisions per BIN: NB_CHOCS, SUM_IMP (sql/collision_bins.sql), or None without CHOC rows."""
    pair_bins: pd.DataFrame | None = None
    """Mixtures with CHOC rows: collisions per (BIN, RANK_I, RANK_J) (sql/pair_collision_bins.sql), else None."""
    chocs: pd.DataFrame | None = None
    """CHOC rows, read only for a cooling gas (restitution < 1) with --record all."""
    store: object = None

    # --- derived ------------------------------------------------------------
    @property
    def periodic(self) -> bool:
        return self.boundary == "periodic"

    @property
    def one_species(self) -> bool:
        return len(self.species) == 1

    @property
    def wall_measure(self) -> float:
        """L^(D-1): the full wall 'area' the SQL pressure divides by (1 in 1D)."""
        return self.length ** (self.dim - 1)

    @property
    def unit(self) -> str:
        """Unit of a 'pressure' in this dimension: force per wall measure."""
        return PRESSURE_UNIT[self.dim]

    @property
    def bounces_count(self) -> int:
        return int(self.hits.NB_REBONDS.sum()) if len(self.hits) else 0

    @property
    def packing_fraction(self) -> float:
        from gaz_cli.geometry import ball_volume

        return float(np.sum(self.species.COUNT * ball_volume(self.dim, self.species.RADIUS_M.to_numpy()))
                     / self.length ** self.dim)

    @property
    def collisions_per_particle(self) -> float:
        """2 C/N over the run (nan if unknown)."""
        return 2.0 * self.collisions / self.n if self.collisions is not None else math.nan

    @property
    def mean_free_time(self) -> float:
        """Duration / collisions per particle, s (inf without collisions, nan if unknown)."""
        c = self.collisions_per_particle
        if not math.isfinite(c):
            return math.nan
        return self.duration / c if c > 0 else math.inf

    @property
    def settle_bin(self) -> int:
        """First time bin of the part of the run analysed: 0, or under gravity the bin after settling.

        The uniform start falls and thermalises in about a fall time sqrt(2L/g)
        and a few mean free times: the part before one fall time + 20 mean free
        times (rounded up to a whole bin) is left out of pressures and speeds.
        """
        if self.gravity <= 0.0:
            return 0
        tau = self.mean_free_time
        tau = 0.0 if not math.isfinite(tau) else tau
        t_settle = math.sqrt(2.0 * self.length / self.gravity) + 20.0 * tau
        return min(errorbars.BINS, int(math.ceil(t_settle / self.duration * errorbars.BINS)))

    @property
    def settled(self) -> bool:
        """Whether at least half the run is left after settling."""
        return self.settle_bin <= errorbars.BINS // 2

    @property
    def never_settles(self) -> str:
        """Why the gas never reaches the barometric equilibrium under gravity ('' when it does)."""
        if (self.gravity > 0.0 and self.dim == 1 and not self.periodic and len(self.species)
                and self.species.MASS_KG.nunique() == 1):
            return (f"1D rods of {'one mass' if self.one_species else 'equal masses'} under gravity: collisions "
                    "swap velocities, so each rod's ghost keeps its own energy m g z + m v^2/2 for ever, and "
                    "the gas never reaches the barometric equilibrium")
        return ""

    @property
    def extra_forces(self) -> str:
        """Why no hard-sphere theory describes the run, drag, pair attraction or extra plane walls
        aside from the box ('' when none)."""
        why = []
        if self.drag > 0.0:
            why.append(f"drag {self.drag:g} 1/s slows the particles (the gas cools: no equilibrium)")
        if self.pair_gravity > 0.0:
            why.append(f"pair gravity G = {self.pair_gravity:g} m^3/(kg s^2) (the bodies attract: not hard spheres)")
        if self.planes:
            why.append(f"{self.planes} extra plane wall(s) (the space is not the box [0, L]^D)")
        return ("no theory for this scene: " + "; ".join(why)) if why else ""

    @property
    def ordered_rods(self) -> str:
        """Why no wall pressure theory fits a 1D mixture (unequal masses) under gravity ('' otherwise)."""
        if self.gravity > 0.0 and self.dim == 1 and not self.periodic and len(self.species) > 1:
            return ("1D rods of several masses under gravity keep the order along the line drawn at the start: "
                    "the heights of each species follow that order, not its own barometric law, and the walls' "
                    "pressures have no theory here (the ideal mixture's was 1-3% off at packing 0.003 to 0.03, "
                    "many errors; floor - ceiling below is exact)")
        return ""

    @property
    def window(self) -> float:
        """Duration of the analysed part of the run, s."""
        return self.duration * (errorbars.BINS - self.settle_bin) / errorbars.BINS

    @property
    def kinetic_temperature(self) -> float:
        """Temperature of the run from its kinetic energy, K (nan if unknown).

        Elastic, no gravity: K is constant, the mean of start and end. Under
        gravity the initial, uniform heights settle and the kinetic energy
        changes: the end value, that of the settled part. Cooling
        (restitution < 1): the start value.
        """
        if not (math.isfinite(self.ke_start) and math.isfinite(self.ke_end)):
            return math.nan
        if self.restitution < 1.0:
            ke = self.ke_start
        elif self.gravity > 0.0:
            ke = self.ke_end
        else:
            ke = 0.5 * (self.ke_start + self.ke_end)
        return self.temperature_of(ke)

    def temperature_of(self, ke: float) -> float:
        """Temperature of the kinetic energy ``ke`` (J) of this run's gas, K (nan if unknown or not positive).

        Periodic box: the kinetic energy of the conserved total momentum is not thermal
        (:func:`gaz_cli.theory.kinetic_temperature`).
        """
        if not (math.isfinite(ke) and ke > 0.0):
            return math.nan
        t = float(theory.kinetic_temperature(self.dim, ke, self.n, periodic=self.periodic and self.n > 1,
                                             drift_energy=self.drift_energy))
        return t if t > 0.0 else math.nan

    @property
    def walls(self) -> list[int]:
        """Wall codes (RE_DIR) of the box: -1, +1, -2, +2, ..."""
        return [s * (d + 1) for d in range(self.dim) for s in (-1, 1)]

    def bounces(self) -> pd.DataFrame:
        """The REBOND rows themselves (RE_T, RE_DIR, RE_VIT, RE_VP, PA_NUM, time order), for figures."""
        from gaz_cli.results import store as st

        rows = self.store.table(st.rebond, self.si_num) if self.store is not None else pd.DataFrame()
        if not len(rows):
            return pd.DataFrame({"RE_T": [], "RE_DIR": [], "RE_VIT": [], "RE_VP": [], "PA_NUM": []})
        return rows.sort_values("RE_NUM")[["RE_T", "RE_DIR", "RE_VIT", "RE_VP", "PA_NUM"]].reset_index(drop=True)


PRESSURE_UNIT = {1: "N", 2: "N/m", 3: "Pa"}
"""A 'pressure' is a force per wall measure L^(D-1): N in 1D, N/m in 2D, Pa in 3D."""



def _only_row(store, table, si_num: int):
    """The one row of a per-simulation table (SCENE, RESULTAT) as a Series, or None if absent."""
    frame = store.table(table, si_num)
    return frame.iloc[0] if len(frame) else None

def load_run(store, si_num: int) -> Run:
    """One simulation: its scene, results, and its bounces and collisions summed per time bin in SQL."""
    from gaz_cli.results import store as st

    sim = store.table(st.simulation, si_num).iloc[0]
    comp = store.table(st.composition, si_num)
    particles = store.table(st.particule)
    _check_stored(si_num, sim, comp.merge(particles, on="PA_NUM") if len(comp) else particles.iloc[:0])
    if len(comp):
        sp = comp.merge(particles, on="PA_NUM")
        species = pd.DataFrame({"PA_NUM": sp.PA_NUM.astype(int), "NAME": sp.PA_NOM,
                                "MASS_KG": sp.PA_M.astype(float) / 1000.0,
                                "RADIUS_M": sp.PA_R.astype(float), "COUNT": sp.CO_N.astype(int),
                                "RANK": sp.CO_RANK if "CO_RANK" in sp else math.nan})
        species = species.sort_values("RANK", kind="stable").reset_index(drop=True)
    else:   # written by something else than gaz simulate: species from the bounces only
        species = pd.DataFrame(columns=["PA_NUM", "NAME", "MASS_KG", "RADIUS_M", "COUNT", "RANK"])
    run = Run(si_num=int(si_num), dim=int(sim.SI_DIM), n=int(sim.SI_N), length=float(sim.SI_L),
              duration=float(sim.SI_DUR), species=species, store=store)
    sc = _only_row(store, st.scene_table, si_num)
    if sc is not None:
        run.boundary, run.engine = str(sc.SC_BOUNDARY), str(sc.SC_ENGINE)
        run.gravity, run.restitution = float(sc.SC_GRAVITY), float(sc.SC_RESTITUTION)
        run.wall_restitution = float(sc.SC_WALL_RESTITUTION)
        run.tc, run.temperature, run.record = float(sc.SC_TC), float(sc.SC_TEMPERATURE), str(sc.SC_RECORD)
        text = sc.get("SC_FILE")
        run.scene_file = text if isinstance(text, str) and text else None
        run.drag, run.pair_gravity = float(sc.SC_DRAG), float(sc.SC_PAIR_GRAVITY)
        run.planes = plane_count(run.scene_file)
    rs = _only_row(store, st.resultat, si_num)
    if rs is not None:
        run.ke_start, run.ke_end = float(rs.RS_KE_START), float(rs.RS_KE_END)
        run.events, run.collisions = int(rs.RS_EVENTS), int(rs.RS_COLLISIONS)
        run.virial = float(rs.RS_VIRIAL)
    if run.periodic and run.n > 1:
        run.drift_energy = drift_energy(run.scene_file, run.ke_start)
    bins = dict(si_num=int(si_num), bins=errorbars.BINS, duration=run.duration)
    # SQLite groups by sorting: one bin's rows at a time sort faster than the run's; PostgreSQL
    # groups by hashing, nothing to gain (its GROUP BY of 10^7 rows: 5.5 s, by ranges 8-9 s)
    run.hits = _bin_sums_by_ranges(store, run) if store.engine.dialect.name == "sqlite" else None
    if run.hits is None:  # PostgreSQL, or rows not in time order: one GROUP BY of them all
        hits = store.query("bounce_bins", **bins)
        hits = hits[hits.BIN_KEY.notna()].reset_index(drop=True)        # no bounce: one NULL row
        key = _checked_bin_keys(run, hits.pop("BIN_KEY").to_numpy(dtype=float))
        hits.insert(0, "RE_DIR", key % 8 - 4)
        hits.insert(1, "PA_NUM", (key // 8) % 1048576)
        hits.insert(2, "BIN", np.clip(key // (8 * 1048576), 0, errorbars.BINS - 1))
        run.hits = hits
    _check_bounce_speeds(run)
    if run.record == "all":
        coll = store.query("collision_bins", **bins)
        coll = coll[coll.BIN.notna()].reset_index(drop=True)
        if len(coll):
            coll["BIN"] = np.clip(coll.BIN.to_numpy(dtype=float), 0, errorbars.BINS - 1).astype(np.int64)
            run.collision_bins = coll
            if run.restitution < 1.0:
                chocs = store.table(st.choc, si_num)
                run.chocs = chocs.sort_values("CH_NUM").reset_index(drop=True)
            if len(species) > 1 and species.RANK.notna().all():
                pairs = store.query("pair_collision_bins", **bins).dropna()
                run.pair_bins = pairs.astype({"BIN": np.int64, "RANK_I": np.int64, "RANK_J": np.int64})
    return run


def plane_count(scene_file: str | None) -> int:
    """How many extra plane walls a stored scene file has (0 without one, or if it does not load)."""
    if not isinstance(scene_file, str) or "planes" not in scene_file:
        return 0
    from gaz_cli.scenes import files as scenefile

    try:
        return len(scenefile.loads(scene_file)[0].planes)
    except GazError:
        return 0


def _refuse_stored(si_num: int, problem: str):
    """StoreError: simulation ``si_num`` holds rows no run can have (``problem`` says which, and what a run has)."""
    raise StoreError(f"simulation {si_num} cannot be analysed: {problem}; correct the row, or analyse "
                     "the others with --sim N")


def _check_stored(si_num: int, sim, species: pd.DataFrame) -> None:
    """Refuse (StoreError) a SIMULATION row, or a species of its composition, that no run can have
    (written by hand or by another program): analysis would divide by it, or its squares and
    products overflow (the ranges of :func:`gaz_cli.model.checks.check_magnitudes`; a duration up to
    sqrt(scene.HUGE), the error of a time average taking its square)."""
    from gaz_cli.model import checks as sc

    def bad(what, value, allowed):
        value = value.item() if hasattr(value, "item") else value     # a numpy scalar: its Python value
        _refuse_stored(si_num, f"{what} is {value!r}, where a run has {allowed}")

    def number(value):
        try:
            return float(value)
        except (TypeError, ValueError):
            return math.nan
    dim, n, length, duration = (number(sim.SI_DIM), number(sim.SI_N), number(sim.SI_L), number(sim.SI_DUR))
    if dim not in (1.0, 2.0, 3.0):
        bad("its SI_DIM", sim.SI_DIM, "1, 2 or 3")
    if not (n >= 1 and n == int(n)):
        bad("its SI_N", sim.SI_N, "a whole number of particles >= 1")
    lo, hi = sc.length_range(int(dim))
    if not (length > 0 and math.isfinite(length)):
        bad("its SI_L", sim.SI_L, "a box side > 0 m")
    if not lo <= length <= hi:
        bad("its SI_L", sim.SI_L, f"a box side in [{lo:.2g}, {hi:.2g}] m (what double precision carries)")
    if not (duration > 0 and math.isfinite(duration)):
        bad("its SI_DUR", sim.SI_DUR, "a duration > 0 s")
    if not duration <= math.sqrt(sc.HUGE):
        bad("its SI_DUR", sim.SI_DUR, f"a duration up to {math.sqrt(sc.HUGE):.2g} s (what double precision carries)")
    (mlo, mhi), (rlo, rhi) = sc.mass_range(), sc.radius_range()
    for row in species.itertuples():
        if not (number(row.PA_M) > 0 and math.isfinite(number(row.PA_M))):
            bad(f"the PA_M of its species {row.PA_NOM!r}", row.PA_M, "a mass > 0 g")
        if not 1000.0 * mlo <= number(row.PA_M) <= 1000.0 * mhi:
            bad(f"the PA_M of its species {row.PA_NOM!r}", row.PA_M,
                f"a mass in [{1000.0 * mlo:.2g}, {1000.0 * mhi:.2g}] g (what double precision carries)")
        if not (number(row.PA_R) >= 0 and math.isfinite(number(row.PA_R))):
            bad(f"the PA_R of its species {row.PA_NOM!r}", row.PA_R, "a radius >= 0 m")
        if number(row.PA_R) > 0 and not rlo <= number(row.PA_R) <= rhi:
            bad(f"the PA_R of its species {row.PA_NOM!r}", row.PA_R,
                f"a radius of 0 or in [{rlo:.2g}, {rhi:.2g}] m (what double precision carries)")
        if not number(row.CO_N) >= 1:
            bad(f"the CO_N of its species {row.PA_NOM!r}", row.CO_N, "a count >= 1")


_HIT_COLUMNS = ["RE_DIR", "PA_NUM", "BIN", "NB_REBONDS", "SUM_VP", "SUM_VIT", "SUM_VP2"]
_KEYS_PER_BIN = 8 * 1048576
"""sql/bounce_bins.sql's BIN_KEY = (BIN * 1048576 + PA_NUM) * 8 + RE_DIR + 4: keys per time bin."""


def _checked_bin_keys(run: Run, key: np.ndarray) -> np.ndarray:
    """sql/bounce_bins.sql's BIN_KEY as int64, refused (StoreError) where a bounce's RE_T is outside
    [0, SI_DUR] (bin BINS: a bounce at SI_DUR itself, kept in the last bin)."""
    ok = np.isfinite(key) & (key >= 0) & (key < (errorbars.BINS + 1) * _KEYS_PER_BIN)
    if not ok.all():
        _refuse_stored(run.si_num, f"a REBOND row has an RE_T outside [0, SI_DUR] = [0, {run.duration:.6g}] s, "
                                   "where a run records its bounces")
    return np.rint(key).astype(np.int64)


def _check_bounce_speeds(run: Run) -> None:
    """Refuse (StoreError) REBOND rows whose RE_VIT or RE_VP is not a speed a run in this box records:
    negative, or above :func:`gaz_cli.model.checks.speed_range`'s largest (squares and products in double
    precision), read from the per-bin sums (a bin's sum of k speeds is at most k times the largest)."""
    from gaz_cli.model import checks as sc

    h = run.hits
    if h is None or not len(h):
        return
    top = sc.speed_range(run.length, run.species.RADIUS_M.to_numpy(dtype=float) if len(run.species) else [])[1]
    count = h.NB_REBONDS.to_numpy(dtype=float)
    for column, name in (("SUM_VIT", "RE_VIT"), ("SUM_VP", "RE_VP")):
        total = h[column].to_numpy(dtype=float)
        if not np.all(np.isfinite(total) & (total >= 0) & (total <= top * count)):
            _refuse_stored(run.si_num, f"a REBOND row has an {name} outside [0, {top:.2g}] m/s, the speeds a "
                                       f"run records in a box of {run.length:.3g} m (what double precision carries)")


def _bin_floor(t: float, duration: float) -> int:
    """A time's bin as sql/bounce_bins.sql computes it on SQLite (before clipping): floor(t * bins / duration)."""
    return math.floor(t * errorbars.BINS / duration)


def _bin_start_time(b: int, duration: float) -> float:
    """The smallest time (a double) in bin ``b`` by :func:`_bin_floor`, s."""
    t = b * duration / errorbars.BINS
    while _bin_floor(t, duration) >= b:
        t = math.nextafter(t, -math.inf)
    while _bin_floor(t, duration) < b:
        t = math.nextafter(t, math.inf)
    return t


def _bin_starts(at, first: int, last: int, duration: float) -> list[int]:
    """(BINS + 1,) RE_NUM where each time bin's rows start, the last one ``last + 1``.

    ``at(r)``: (RE_NUM, RE_T) of the first row numbered ``r`` or more. Assumes
    RE_T does not decrease with RE_NUM (the caller checks each range after);
    each start is found by interpolation on RE_T, bisection when that stalls:
    a few lookups per bin when bounces come at a steady rate, O(log n) at worst.
    """
    bins = errorbars.BINS

    def before(r: int, t_b: float) -> bool:  # the first row from r on is in an earlier bin
        return r <= last and at(r)[1] < t_b

    starts = [first]
    for b in range(1, bins):
        t_b = _bin_start_time(b, duration)
        lo, hi = starts[-1], last + 1   # before(lo) unless lo already starts bin b; not before(hi)
        if not before(lo, t_b):
            starts.append(lo)
            continue
        halve = False
        while hi - lo > 1:
            if halve:
                mid = (lo + hi) // 2
            else:
                t_lo, t_hi = at(lo)[1], at(min(hi, last))[1]
                frac = (t_b - t_lo) / (t_hi - t_lo) if t_hi > t_lo else 0.5
                mid = min(max(lo + int(frac * (hi - lo)), lo + 1), hi - 1)
            width = hi - lo
            if before(mid, t_b):
                lo = mid
            else:
                hi = mid
            halve = not halve and 2 * (hi - lo) > width  # interpolation missed: bisect once
        starts.append(hi)
    starts.append(last + 1)
    return starts


def _bin_sums_by_ranges(store, run: Run) -> pd.DataFrame | None:
    """``run.hits`` summed one time bin at a time: each bin's rows are a range of RE_NUM
    (rows follow time in a run: the engines write them in event order), found by
    :func:`_bin_starts` and summed per species and wall by sql/wall_sums_in_range.sql,
    whose GROUP BY sorts one bin's rows at a time (bounce_bins.sql's sorts the whole
    run, spilling to temporary files on SQLite: 1.0 against ~0.7 us a row).

    None if a range holds a row of another bin (rows written out of time order, or by
    hand): the caller then runs bounce_bins.sql. The same sums as bounce_bins.sql's,
    each added in another order (equal up to the rounding of a reordered sum of
    positive terms: a relative (k - 1) eps for a bin's k bounces).
    """
    duration = run.duration
    if not (math.isfinite(duration) and duration > 0):
        return None
    rows = []
    with store.session() as sql:
        first, last = sql("first_last_bounce", si_num=run.si_num)[0]
        if first is not None:
            seen = {}

            def at(r):
                if r not in seen:
                    seen[r] = sql("lookup_bounce", si_num=run.si_num, re_num=r)[0]
                return seen[r]

            t_first, t_last = at(int(first))[1], at(int(last))[1]
            if not (0.0 <= t_first and t_last * errorbars.BINS / duration < errorbars.BINS + 1):
                return None     # a time no run has: bounce_bins.sql's path refuses it (_checked_bin_keys)
            starts = _bin_starts(at, int(first), int(last), duration)
            for b in range(errorbars.BINS):
                if starts[b] == starts[b + 1]:
                    continue
                t_lo = -math.inf if b == 0 else _bin_start_time(b, duration)
                t_hi = math.inf if b == errorbars.BINS - 1 else _bin_start_time(b + 1, duration)
                for key, nb, outside, s_vp, s_vit, s_vp2 in sql(
                        "wall_sums_in_range", si_num=run.si_num, lo=starts[b], hi=starts[b + 1] - 1,
                        t_lo=t_lo, t_hi=t_hi):
                    if outside:
                        return None
                    rows.append((int(key) % 8 - 4, int(key) // 8, b, int(nb), float(s_vp), float(s_vit),
                                 float(s_vp2)))
    hits = pd.DataFrame(rows, columns=_HIT_COLUMNS)
    return hits.astype({c: np.int64 for c in _HIT_COLUMNS[:4]} | {c: float for c in _HIT_COLUMNS[4:]})


# --- binned measurements ----------------------------------------------------------------
def _per_bin(bins, values) -> np.ndarray:
    """(BINS,) sums of ``values`` over their time bins."""
    return np.bincount(np.asarray(bins, dtype=np.int64), weights=np.asarray(values, dtype=float),
                       minlength=errorbars.BINS)[:errorbars.BINS]


def _hit_masses(run: Run) -> np.ndarray:
    mass = run.species.set_index("PA_NUM").MASS_KG
    return mass.reindex(run.hits.PA_NUM.to_numpy()).to_numpy(dtype=float)


def wall_bin_pressures(run: Run) -> dict[int, np.ndarray]:
    """Wall code -> (BINS,) pressure in each time bin (unit per :data:`PRESSURE_UNIT`), from (1 + e_w) m |v_perp|."""
    h = run.hits
    width = run.duration / errorbars.BINS
    if not len(h):
        return {w: np.zeros(errorbars.BINS) for w in run.walls}
    mom = _wall_momenta(run)
    wall = h.RE_DIR.to_numpy(dtype=np.int64)
    return {w: _per_bin(h.BIN[wall == w], mom[wall == w]) / (width * run.wall_measure) for w in run.walls}


def _wall_momenta(run: Run) -> np.ndarray:
    """Momentum given to the wall by each row of ``run.hits``: sum of (1 + e_w) m |v_perp| (theory.wall_impulse)."""
    return theory.wall_impulse(_hit_masses(run), run.hits.SUM_VP.to_numpy(dtype=float), run.wall_restitution)


def virial_bin_pressures(run: Run, temperature: float) -> np.ndarray | None:
    """(BINS,) virial pressure of a periodic box in each time bin, from CHOC (one species), or None.

    :func:`gaz_cli.theory.virial_pressure` of each bin: W = sum of |J| sigma over the bin's collisions.
    """
    if run.collision_bins is None or not run.one_species or not math.isfinite(temperature):
        return None
    sigma = 2.0 * float(run.species.RADIUS_M.iloc[0])
    w = _per_bin(run.collision_bins.BIN, run.collision_bins.SUM_IMP.to_numpy(dtype=float) * sigma)
    return np.asarray(theory.virial_pressure(run.dim, run.n, temperature, run.length ** run.dim, w,
                                             run.duration / errorbars.BINS), dtype=float)


def exam_per_wall(run: Run) -> pd.DataFrame:
    """sql/pressure_per_wall.sql's table (SI_NUM, RE_DIR, NB_REBONDS, QUANTITE_MOUVEMENT, PRESSION), from the bins.

    The same sums as the exam's query ((1 + e_w) m |v_perp| per bounce, 2 m
    |v_perp| for elastic walls), added up from the per-bin sums the database
    returned, so that the REBOND rows are read once.
    """
    h = run.hits
    if not len(h):
        return pd.DataFrame(columns=["SI_NUM", "RE_DIR", "NB_REBONDS", "QUANTITE_MOUVEMENT", "PRESSION"])
    mom = pd.Series(_wall_momenta(run), index=h.index)
    walls = pd.DataFrame({"NB_REBONDS": h.NB_REBONDS.groupby(h.RE_DIR).sum(),
                          "QUANTITE_MOUVEMENT": mom.groupby(h.RE_DIR).sum()}).reset_index()
    walls["PRESSION"] = walls.QUANTITE_MOUVEMENT / (run.duration * run.wall_measure)
    walls.insert(0, "SI_NUM", run.si_num)
    return walls.astype({"RE_DIR": int, "NB_REBONDS": int})


def exam_q35(run: Run) -> pd.DataFrame:
    """Q35 (sql/q35_bounces_per_simulation.sql) for this simulation alone, from the bins."""
    count = run.bounces_count
    mean = float(run.hits.SUM_VIT.sum() / count) if count else NA
    return pd.DataFrame([{"SI_NUM": run.si_num, "NB_REBONDS": count, "VITESSE_MOYENNE": mean}])


def _estimate(run: Run, series, weights=None, static_var: float = 0.0,
              relaxation: float = math.inf, end_var: float | None = None) -> errorbars.Estimate:
    """Time average of a (BINS,) series over the analysed part of the run; ``relaxation`` in mean free times."""
    start = run.settle_bin
    if start >= errorbars.BINS:
        return errorbars.NAN_ESTIMATE
    tau = run.mean_free_time
    tau = math.inf if not math.isfinite(tau) else tau * relaxation
    if not math.isfinite(run.mean_free_time) and static_var > 0.0 and run.collisions is None:
        tau = math.inf                    # collisions unknown: assume the draw stays frozen
    return errorbars.time_average(np.asarray(series)[start:],
                                  None if weights is None else np.asarray(weights)[start:],
                                  duration=run.window, static_var=static_var, relaxation_s=tau, end_var=end_var,
                                  white=not run.collisions_per_particle < FEW_COLLISIONS)


FEW_COLLISIONS = 3.0
"""Collisions per particle below which a wall pressure's error is the ends' closed form alone.

The walls' impulse is the kinetic energy, the collisional virial and an end
term (errorbars.end_variance): with c collisions per particle the virial's
noise is about c/30 of the end term's variance (measured: 0.5 of it at 29
collisions per particle, 3 of it at 121), under 10% below 3, where reading
it from four to sixteen blocks would only add their noise (benchmarks/error_coverage.py).
"""


def _end_var(run: Run, temperature: float, axes: int) -> float | None:
    """errorbars.end_variance of the pressures summed over the walls of ``axes`` axes (None under gravity)."""
    if run.gravity > 0.0 or run.periodic or not len(run.species) or not math.isfinite(temperature):
        return None
    counts, radii, masses = _counts_radii_masses(run)
    return errorbars.end_variance(float(np.sum(counts * masses)) * K_B * temperature,
                                  0.5 * (run.length - 2.0 * float(radii.max())), run.window, run.wall_measure, axes)


def wall_estimates(run: Run, expected: dict, temperature: float) -> dict[int, errorbars.Estimate]:
    """Wall code -> pressure estimate, from the two opposite walls of each axis.

    A wall's pressure is half the sum S of its axis' two walls plus (or
    minus) half their difference D. S follows the axis' kinetic energy: it is
    reblocked, with the frozen share of the energy the axis drew at the start
    (scaled by the expected, else measured, pressure). D is exactly the change
    of the gas's momentum along the axis over the run, divided by the run's
    time and the wall measure: its variance has the closed form
    2 sum_s N_s m_s k_B T/(T L^(D-1))^2 (start and end momenta independent
    draws), where reblocking would read its hit-by-hit noise as white and
    overestimate it (a momentum given to one wall is soon given back to the
    other). S and D are uncorrelated by the box's mirror symmetry.
    """
    out = {}
    share = errorbars.axis_share_var(run.dim, run.n)
    series = wall_bin_pressures(run)
    counts, _, masses = _counts_radii_masses(run)
    window = run.window
    diff_var = (2.0 * float(np.sum(counts * masses)) * K_B * temperature / (window * run.wall_measure) ** 2
                if math.isfinite(temperature) and len(run.species) and window > 0.0 else math.nan)
    for d in range(1, run.dim + 1):
        low, high = series[-d], series[d]
        exp = [expected.get(w) for w in (-d, d)]
        scale = sum(e.value if e is not None and e.known else float(np.mean(x)) for e, x in zip(exp, (low, high)))
        total = _estimate(run, low + high, static_var=share * scale ** 2,
                          relaxation=errorbars.ANISOTROPY_RELAXATION[run.dim],
                          end_var=_end_var(run, temperature, 1))
        for w, x in ((-d, low), (d, high)):
            own = _estimate(run, x)
            if not (math.isfinite(total.error) and math.isfinite(diff_var)):
                out[w] = own
                continue
            error = 0.5 * math.sqrt(total.error ** 2 + diff_var)
            var1 = float(np.var(x[run.settle_bin:], ddof=1)) if x.size - run.settle_bin > 1 else math.nan
            out[w] = errorbars.Estimate(own.mean, error, var1 / error ** 2 if error > 0 else math.nan,
                                        total.block_s, total.plateau, 0.5 * total.frozen)
    return out


# --- theory for one run ---------------------------------------------------------------
@dataclass
class Expectation:
    """One theoretical value: its number (NaN where none), the model's name and its caveat."""

    value: float
    model: str
    note: str = ""
    syst: float = 0.0
    """Relative size of the model's known systematic error for this scene (0: exact or unknown)."""
    applies: bool = True
    """False when the model is known not to fit the scene: no deviation in sigmas is printed."""
    error: float = 0.0
    """Standard error of the value from that of its input temperature (under gravity), same unit."""

    @property
    def known(self) -> bool:
        return math.isfinite(self.value)


def _try(model: str, func, note: str = "") -> Expectation:
    """Evaluate ``func()``; a theory range error becomes NaN with the reason as note."""
    try:
        return Expectation(float(func()), model, note)
    except SceneError as err:
        return Expectation(NA, model, str(err))


def _counts_radii_masses(run: Run):
    return (run.species.COUNT.to_numpy(dtype=float), run.species.RADIUS_M.to_numpy(dtype=float),
            run.species.MASS_KG.to_numpy(dtype=float))


def settled_temperature(run: Run) -> errorbars.Estimate:
    """Temperature of the analysed (settled) part of the run from its wall hits, K.

    Flux-weighted Maxwell-Boltzmann: <m v_perp^2> over the hits on any wall
    is 2 k_B T at any density and height, for every species; the hits of the
    settled part give T and its error (reblocking of the per-bin sums).
    """
    h = run.hits
    if not len(h) or "SUM_VP2" not in h:
        return errorbars.NAN_ESTIMATE
    energy = _hit_masses(run) * h.SUM_VP2.to_numpy(dtype=float) / (2.0 * K_B)
    return _estimate(run, _per_bin(h.BIN, energy), _per_bin(h.BIN, h.NB_REBONDS))


EXACT_ENGINES = ("event", "ideal", "reference")
"""Engines that conserve the energy to round-off (the step engine's leap-frog drifts)."""


def initial_state(run: Run):
    """The run's initial state rebuilt from its stored scene file, or None (:func:`rebuild_initial_state`)."""
    return rebuild_initial_state(run.scene_file, run.ke_start)


def rebuild_initial_state(scene_file: str | None, ke_start: float):
    """(Scene, State) of a run's start rebuilt from its stored scene file (SCENE.SC_FILE), or None.

    The initial state is a function of the scene and its seed. None when the scene file
    is not stored or does not rebuild the run: its kinetic energy differs from RESULTAT's
    ``ke_start`` (J; another version's placement).
    """
    if not isinstance(scene_file, str) or not math.isfinite(ke_start):
        return None
    from gaz_cli.placement import initial as scene_module
    from gaz_cli.scenes import files as scenefile

    try:
        scene, _ = scenefile.loads(scene_file)
        state = scene_module.initial_state(scene)
    except GazError:
        return None
    masses = scene.masses()
    ke = 0.5 * float(np.sum(masses[:, None] * state.velocities ** 2))
    if not math.isclose(ke, ke_start, rel_tol=1e-9, abs_tol=0.0):
        return None
    return scene, state


def drift_energy(scene_file: str | None, ke_start: float) -> float:
    """P^2/(2M) of a run's initial total momentum, J: 0 unless an explicit (or preset) initial state
    set the velocities (gaz removes the momentum of those it draws in a periodic box), or where the
    state cannot be rebuilt (:func:`rebuild_initial_state`)."""
    if not isinstance(scene_file, str) or "[initial]" not in scene_file:
        return 0.0
    rebuilt = rebuild_initial_state(scene_file, ke_start)
    if rebuilt is None:
        return 0.0
    scene, state = rebuilt
    masses = scene.masses()
    p = (masses[:, None] * state.velocities).sum(axis=0)
    return float(p @ p / (2.0 * masses.sum()))


def energy_temperature(run: Run) -> float:
    """Temperature of the settled gas under gravity from its conserved energy, K (NaN where unknown).

    Elastic dynamics under uniform gravity conserves E = K + sum m g (z - R)
    exactly; the initial state (rebuilt from the stored scene file) gives E,
    and the settled gas shares it as (D/2) N k_B T + N m g <z - R>(T)
    (:func:`gaz_cli.theory.gravity_energy_temperature`). No statistical error:
    the pressures' own error holds the exchange between kinetic and potential
    energy over the run. One species, an exact engine, nothing that dissipates.
    """
    if (run.gravity <= 0.0 or run.periodic or not run.one_species or run.engine not in EXACT_ENGINES
            or run.restitution < 1.0 or run.wall_restitution < 1.0):
        return NA
    rebuilt = initial_state(run)
    if rebuilt is None:
        return NA
    scene, state = rebuilt
    if scene.planes or scene.drag > 0.0 or scene.pair_gravity > 0.0:
        return NA
    radius = float(run.species.RADIUS_M.iloc[0])
    mass = float(run.species.MASS_KG.iloc[0])
    energy = run.ke_start + float(np.sum(scene.masses() * run.gravity * (state.positions[:, -1] - radius)))
    try:
        return float(theory.gravity_energy_temperature(run.dim, run.length, energy, run.n, radius, mass,
                                                       run.gravity))
    except SceneError:
        return NA


def _gravity_walls(run: Run, temperature: float):
    """(floor, ceiling, side, model, note) of the best gravity model for the run."""
    counts, radii, masses = _counts_radii_masses(run)
    d, L = run.dim, run.length
    if run.one_species and radii[0] > 0:
        floor, ceiling, side = theory.hard_sphere_gravity_wall_pressures(
            d, L, temperature, counts[0], radii[0], masses[0], run.gravity)
        return floor, ceiling, side, f"hard spheres under gravity, local {theory.BEST_MODEL[d]} EOS", \
            "barometric profile with the bulk EOS at the local density; first order in the wall corrections"
    floor, ceiling = theory.ideal_gravity_wall_pressures(d, L, temperature, counts, radii, masses, run.gravity)
    side = theory.ideal_wall_pressure(d, L, temperature, counts, radii) if d > 1 else 0.0
    return floor, ceiling, side, "ideal gas under gravity", "non-interacting (dilute) limit; mixture: no excess"


def pressure_models(run: Run, temperature: float, stat_rel: float = 0.0) -> list[Expectation]:
    """Every theoretical pressure that applies to the run; the first one is the best.

    Walls: what the SQL measures (per full wall area). 1D: Tonks, exact.
    2D/3D: :func:`theory.hard_sphere_wall_pressure` (one species), then the
    non-interacting gas; when its systematic error bound (wall adsorption)
    exceeds the statistical error ``stat_rel`` (relative), it does not fit the
    scene and no deviation is printed. Under gravity the mean over the walls
    of the hard-sphere barometric model. Periodic: the bulk equation of state
    against the virial. Cooling gas: no equilibrium value.
    """
    counts, radii, masses = _counts_radii_masses(run)
    d, L = run.dim, run.length
    if not math.isfinite(temperature) or not len(run.species):
        return [Expectation(NA, "none", "no kinetic energy or composition recorded for this simulation")]
    if run.restitution < 1.0:
        return [Expectation(NA, "none", f"restitution {run.restitution:g} < 1: the gas cools "
                                        "(Haff's law below), there is no equilibrium pressure")]
    if run.wall_restitution < 1.0:
        return [Expectation(NA, "none", f"wall restitution {run.wall_restitution:g} < 1: the walls cool the gas, "
                                        "there is no equilibrium pressure; measured from (1 + e_w) m |v_perp| per "
                                        "bounce, as the run summary and Q36")]
    if run.extra_forces:
        return [Expectation(NA, "none", run.extra_forces)]
    out = []
    if run.periodic:
        n = run.n / L ** d
        if run.one_species:
            model = theory.BEST_MODEL[d]
            out.append(_try(f"hard spheres, bulk {model} EOS",
                            lambda: theory.hard_sphere_pressure(d, n, 2 * radii[0], temperature)))
        else:
            out.append(_try("mixture, bulk BMCSL EOS" if d == 3 else "mixture, bulk EOS",
                            lambda: theory.mixture_pressure(d, counts / L ** d, 2 * radii, temperature),
                            "Boublik-Mansoori-Carnahan-Starling-Leland (3D; about 0.2% low at packing 0.3); "
                            "2D: the Santos-Yuste-Lopez de Haro mapping on the one-component EOS"))
        out.append(_try("ideal gas N kT/V", lambda: theory.ideal_gas_pressure(run.n, temperature, L ** d),
                        "no interactions: excess pressure ignored"))
        return out
    if run.gravity > 0.0:
        def mean_gravity(t=temperature):
            floor, ceiling, side, _, _ = _gravity_walls(run, t)
            return (floor + ceiling + (2 * d - 2) * side) / (2 * d)
        try:
            _, _, _, name, note = _gravity_walls(run, temperature)
        except SceneError as err:
            name, note = "under gravity", str(err)
        exp = _try(f"{name} (mean of the walls)", mean_gravity, note)
        if exp.known and run.temperature_error > 0:
            exp.error = abs(mean_gravity(temperature + run.temperature_error) - exp.value)
            exp.note += (f"; T = {temperature:.5g} +- {run.temperature_error:.2g} K from <v_perp^2> of the "
                         "settled part's wall hits (its error is in DEV_SIGMA)")
        elif exp.known and run.temperature_source == "energy":
            exp.note += (f"; T = {temperature:.5g} K from the conserved energy of the initial state, "
                         "kinetic plus potential")
        if not _set_aside_unsettled(exp, run) and run.ordered_rods:
            exp.applies, exp.note = False, run.ordered_rods
        elif exp.known and exp.applies and not run.one_species:
            _set_aside_excess(exp, run, stat_rel)
        out.append(exp)
        return out
    if d == 1:
        out.append(_try("Tonks, exact (1D rods)", lambda: theory.tonks_pressure(L, temperature, counts, radii),
                        "N kT/(L - N 2R), kT = (1/N) sum m v^2 from the kinetic energy"))
    elif run.one_species:
        model = theory.BEST_MODEL[d]
        exp = _try(f"hard spheres at walls, {model} at N/(L-2R)^D",
                   lambda: theory.hard_sphere_wall_pressure(d, L, temperature, counts[0], radii[0]),
                   "first order in eta and 2R/L; SYST_REL: next order (wall adsorption), a bound")
        if exp.known:
            try:
                exp.syst = abs(float(theory.wall_adsorption_shift(d, L, counts[0], radii[0])))
            except SceneError:
                exp.syst = NA
            if stat_rel > 0 and not exp.syst <= stat_rel:
                exp.applies = False
                dense = exp.syst > 10 * stat_rel
                exp.note = (("no theory for this scene: " if dense else "") +
                            f"the wall model's systematic error (up to {exp.syst:.2g} relative, wall "
                            f"adsorption: SYST_REL) exceeds the statistical error ({stat_rel:.2g}); "
                            "compare REL_DEV with SYST_REL" +
                            ("; a dense fluid at walls needs its contact density, which the database "
                             "does not hold" if dense else ""))
        out.append(exp)
    else:
        out.append(_try("mixture at walls, BMCSL at N_s/(L-2R_s)^D" if d == 3 else "mixture at walls",
                        lambda: theory.mixture_wall_pressure(d, L, temperature, counts, radii),
                        "first order in eta and 2R/L, as for one species"))
    ideal = _try("ideal gas at walls, N kT/((L-2R) L^(D-1))",
                 lambda: theory.ideal_wall_pressure(d, L, temperature, counts, radii),
                 "dilute limit (eta -> 0), exact for non-interacting particles")
    out.append(ideal)
    return out


def _set_aside_excess(exp: Expectation, run: Run, stat_rel: float) -> None:
    """A mixture under gravity, against the ideal mixture's barometric pressures: its excess pressure,
    Z - 1 of one species at the mixture's packing fraction (the best model), is the model's
    systematic error (SYST_REL); above the statistical error ``stat_rel`` (relative) ``exp`` does
    not fit the scene and is set aside, the reason in its note."""
    try:
        exp.syst = float(theory.compressibility_factor(run.dim, run.packing_fraction)) - 1.0
    except SceneError:
        exp.syst = NA
    if stat_rel > 0 and not exp.syst <= stat_rel:
        exp.applies = False
        exp.note = (f"the ideal mixture leaves out the excess pressure (about {exp.syst:.2g} relative at the "
                    f"packing fraction {run.packing_fraction:.3g}: SYST_REL), above the statistical error "
                    f"({stat_rel:.2g}); no mixture theory under gravity here: compare REL_DEV with SYST_REL")


def wall_pressure_theory(run: Run, temperature: float, best: Expectation | None = None) -> dict[int, Expectation]:
    """Wall code -> expected pressure on that wall (best model)."""
    best = best or pressure_models(run, temperature)[0]
    if run.gravity > 0.0 and best.known and not run.periodic:
        d = run.dim
        values = _gravity_walls(run, temperature)[:3]
        shifted = (_gravity_walls(run, temperature + run.temperature_error)[:3] if run.temperature_error > 0
                   else values)

        def pick(v, w):
            return float(v[0] if w == -d else v[1] if w == d else v[2])
        return {w: Expectation(pick(values, w), best.model, best.note, applies=best.applies,
                               error=abs(pick(shifted, w) - pick(values, w)))
                for w in run.walls}
    return {w: best for w in run.walls}


def _species_partial_weights(run: Run, temperature: float = NA) -> np.ndarray:
    """Expected share of the wall hits of each species, normalised.

    A wall's hits per second are its pressure over sqrt(2 pi m kT), the mean momentum a hit
    gives (physics.md section 6): a species' share is the sum over the walls of its partial
    pressure over sqrt(m_s), N_s / ((L - 2R_s) sqrt(m_s)) without gravity. Under gravity (at
    ``temperature``, K) the floor and ceiling take each species' own barometric pressures, the
    2D - 2 side walls its N_s kT/((L - 2R_s) L^(D-1)): heavy species sit low and hit the
    ceiling less.
    """
    counts, radii, masses = _counts_radii_masses(run)
    d, L = run.dim, run.length
    if d == 1 and len(counts) > 1 and run.gravity <= 0.0 and len(run.hits):
        # rods never pass each other: only the two end rods hit the walls, each wall's hits at the
        # rate P/sqrt(2 pi m kT) of its end rod's mass (the same P on both walls), whatever N_s
        w = np.zeros(len(counts))
        index = {int(pa): k for k, pa in enumerate(run.species.PA_NUM)}
        for _, at_wall in run.hits.groupby("RE_DIR").PA_NUM:
            ends = [index[int(pa)] for pa in at_wall.unique() if int(pa) in index]
            for k in ends:
                w[k] += 1.0 / (len(ends) * math.sqrt(masses[k]))
        if w.sum() > 0:
            return w / w.sum()
    if run.gravity > 0.0 and not run.periodic and math.isfinite(temperature):
        walls = np.array([sum(theory.ideal_gravity_wall_pressures(d, L, temperature, c, r, m, run.gravity))
                          + (2 * d - 2) * theory.ideal_wall_pressure(d, L, temperature, c, r)
                          for c, r, m in zip(counts, radii, masses)])
        w = walls / np.sqrt(masses)
    else:
        w = counts / ((L - 2.0 * radii) * np.sqrt(masses))
    return w / w.sum()


# --- the frames ------------------------------------------------------------------------
def _dev(measured, error, expected, applies: bool = True, theory_error: float = 0.0) -> float:
    """(measured - expected)/sqrt(error^2 + theory_error^2), or NaN."""
    if not applies or not all(map(math.isfinite, (measured, error, expected))) or error <= 0:
        return NA
    return (measured - expected) / math.hypot(error, theory_error)


def _rel(measured, expected) -> float:
    if not (math.isfinite(measured) and math.isfinite(expected)) or expected == 0:
        return NA
    return measured / expected - 1.0


def _num(x) -> float:
    """A float, NaN for None."""
    return NA if x is None else float(x)


def simulation_frame(run: Run, temperature: float) -> dict:
    """The scene in one row of scalars, with how errors are made."""
    return {"SI_NUM": run.si_num, "SI_DIM": run.dim, "SI_N": run.n, "SI_L": run.length,
            "SI_DUR": run.duration, "ENGINE": run.engine, "BOUNDARY": run.boundary,
            "SPECIES": ", ".join(f"{r.NAME}:{r.COUNT}" for r in run.species.itertuples()),
            "PACKING_FRACTION": run.packing_fraction if len(run.species) else NA,
            "GRAVITY": run.gravity, "RESTITUTION": run.restitution, "WALL_RESTITUTION": run.wall_restitution,
            "T_SCENE_K": _num(run.temperature), "T_KIN_K": _num(run.kinetic_temperature),
            "T_THEORY_K": _num(temperature), "T_THEORY_ERR_K": run.temperature_error,
            "BOUNCES": run.bounces_count, "COLLISIONS": _num(run.collisions),
            "COLL_PER_PARTICLE": run.collisions_per_particle,
            "MEAN_FREE_TIME_S": run.mean_free_time if math.isfinite(run.mean_free_time) else NA,
            "ANALYSED_FROM_S": run.duration - run.window, "P_UNIT": run.unit,
            "ESTIMATOR": errorbars.ESTIMATOR, "BINS": errorbars.BINS, "BIN_S": run.duration / errorbars.BINS}


def per_wall_frame(run: Run, per_wall: pd.DataFrame, temperature: float, summary: dict) -> pd.DataFrame:
    """The exam's per-wall pressure (SQL) with the time average analysed, its error, theory and deviation."""
    frame = per_wall.copy()
    if not len(frame):
        return frame
    expected = wall_pressure_theory(run, temperature, summary["best"])
    estimates = wall_estimates(run, expected, temperature)
    cols = {k: [] for k in ("P_UNIT", "P_MEASURED", "P_ERR", "N_EFF", "P_THEORY", "DEV_SIGMA", "NOTE")}
    for w in frame.RE_DIR.astype(int):
        est = estimates.get(w, errorbars.NAN_ESTIMATE)
        exp = expected.get(w, Expectation(NA, "none"))
        cols["P_UNIT"].append(run.unit)
        cols["P_MEASURED"].append(est.mean)
        cols["P_ERR"].append(est.error)
        cols["N_EFF"].append(est.n_eff)
        cols["P_THEORY"].append(exp.value)
        cols["DEV_SIGMA"].append(_dev(est.mean, est.error, exp.value, exp.applies, exp.error))
        cols["NOTE"].append(_wall_note(run, exp))
    for k, v in cols.items():
        frame[k] = v
    return frame


def _wall_note(run: Run, exp: Expectation) -> str:
    notes = []
    if run.settle_bin:
        notes.append(f"P_MEASURED: after settling, from {run.duration - run.window:.3g} s")
    if not exp.known or not exp.applies:
        notes.append(exp.note or "no theory for this scene")
    return "; ".join(notes)


def pressure_summary(run: Run, temperature: float) -> dict:
    """Measured pressure (mean over the walls, or virial), its error estimate, and the theories."""
    if run.periodic:
        measured = (theory.virial_pressure(run.dim, run.n, temperature, run.length ** run.dim,
                                           run.virial, run.duration)
                    if math.isfinite(temperature) and math.isfinite(run.virial) else math.nan)
        series = virial_bin_pressures(run, temperature)
        est = _estimate(run, series) if series is not None else errorbars.NAN_ESTIMATE
        how = "virial" + ("" if series is not None else " (error bar needs --record all)")
    elif not run.bounces_count:
        measured, est = math.nan, errorbars.NAN_ESTIMATE
        how = "no wall bounce recorded" + (" (--record none)" if run.record == "none" else "")
    else:
        per_bin = wall_bin_pressures(run)
        # the mean over the 2D walls: the sum over the D axes' pairs / (2D)
        ends = _end_var(run, temperature, run.dim)
        est = _estimate(run, np.mean([per_bin[w] for w in run.walls], axis=0),
                        end_var=None if ends is None else ends / (2 * run.dim) ** 2)
        measured = est.mean
        how = "mean over the walls" + (" after settling" if run.settle_bin else "")
    stat_rel = est.error / abs(measured) if math.isfinite(est.error) and measured else 0.0
    models = pressure_models(run, temperature, stat_rel)
    return {"measured": measured, "error": est.error, "n_eff": est.n_eff, "how": how,
            "best": models[0], "models": models}


def pressure_frame(run: Run, temperature: float, summary: dict) -> pd.DataFrame:
    """One row per theoretical model: expected pressure, deviation in sigmas and relative."""
    rows = []
    for exp in summary["models"]:
        rows.append({"MODEL": exp.model, "P_UNIT": run.unit, "P_MEASURED": _num(summary["measured"]),
                     "P_ERR": _num(summary["error"]), "N_EFF": summary["n_eff"], "P_THEORY": exp.value,
                     "DEV_SIGMA": _dev(summary["measured"], summary["error"], exp.value, exp.applies, exp.error),
                     "REL_DEV": _rel(summary["measured"], exp.value), "SYST_REL": exp.syst,
                     "MEASURED": summary["how"], "NOTE": exp.note})
    return pd.DataFrame(rows)


def _set_aside_unsettled(exp: Expectation, run: Run) -> bool:
    """Under gravity: ``exp`` set aside, with the reason, when the run never settles (1D rods of
    one mass) or did not settle (its fall and thermalisation fill more than the bins it may
    drop); returns whether it was."""
    if run.never_settles:
        exp.applies, exp.note = False, run.never_settles
    elif not run.settled:
        exp.applies = False
        exp.note = (f"the run did not settle: the first {run.settle_bin}/{errorbars.BINS} of it are the "
                    "fall and thermalisation; run longer")
    else:
        return False
    return True


def collision_frame(run: Run, temperature: float) -> pd.DataFrame:
    """Collisions per particle per second against Enskog (or the exact 1D result)."""
    if run.collisions is None:
        return pd.DataFrame([{"MODEL": "none", "RATE_PER_PARTICLE_HZ": NA, "RATE_ERR_HZ": NA,
                              "THEORY_HZ": NA, "DEV_SIGMA": NA, "NOTE": "no RESULTAT row for this simulation"}])
    rate = 2.0 * run.collisions / (run.n * run.duration)
    est = errorbars.NAN_ESTIMATE
    err_note = ""
    stratified = run.gravity > 0.0 and not run.periodic
    if run.collision_bins is not None and run.restitution >= 1.0:
        width = run.duration / errorbars.BINS
        per_bin = _per_bin(run.collision_bins.BIN, run.collision_bins.NB_CHOCS.to_numpy(dtype=float))
        if stratified:      # the settled part only, as the pressures: the fall collides less
            est = _estimate(run, 2.0 * per_bin / (run.n * width))
            rate = est.mean if math.isfinite(est.mean) else rate
        else:
            est = errorbars.time_average(2.0 * per_bin / (run.n * width), duration=run.duration)
    elif run.restitution >= 1.0:
        err_note = "RATE_ERR_HZ needs the collisions' times: --record all; "
    counts, radii, masses = _counts_radii_masses(run)
    d, L = run.dim, run.length
    rows = []
    if run.extra_forces:
        rows.append(Expectation(NA, "Enskog", run.extra_forces))
    elif not run.one_species:
        rows.append(Expectation(NA, "Enskog", "one species only (mixture: cross-sections and masses differ)"))
    elif not math.isfinite(temperature):
        rows.append(Expectation(NA, "Enskog", "temperature unknown"))
    elif stratified:
        exp = _try(f"Enskog, g from {theory.BEST_MODEL[d]}, averaged over the barometric profile",
                   lambda: theory.gravity_collision_frequency(d, L, temperature, run.n, radii[0], masses[0],
                                                              run.gravity),
                   "local density of the hydrostatic profile (the gas is denser low down: more partners); "
                   "walls: expect O(2R/L) off")
        if not _set_aside_unsettled(exp, run) and run.collision_bins is None:
            exp.applies = False
            exp.note = ("under gravity the settled part's rate needs the collisions' times (the count over "
                        "the run includes the fall): --record all")
        rows.append(exp)
    elif d == 1:
        rows.append(_try("1D rods, exact (N-1) <|v_rel|>/(L - N sigma)",
                         lambda: theory.rods_collision_frequency(run.n, L, radii[0], temperature, masses[0]),
                         "Maxwellian average; with equal masses the set of speeds never relaxes, "
                         "expect O(1/sqrt(N)) off"))
    elif run.periodic:
        rows.append(_try(f"Enskog, g from {theory.BEST_MODEL[d]}, n = N/L^D",
                         lambda: theory.enskog_collision_frequency(d, run.n / L ** d, 2 * radii[0],
                                                                   temperature, masses[0]),
                         "Enskog: a few % up to freezing"))
    else:
        sigma = 2 * radii[0]
        rows.append(_try(f"Enskog, g from {theory.BEST_MODEL[d]}, n = N/(L-2R)^D",
                         lambda: theory.enskog_collision_frequency(d, run.n / (L - sigma) ** d, sigma,
                                                                   temperature, masses[0]),
                         "walls: fewer partners near a wall, expect O(2R/L) off"))
    if run.restitution < 1.0 and run.one_species and math.isfinite(temperature) and d > 1 and not run.extra_forces:
        # a cooling gas: omega falls as sqrt(T); Haff integrates it over the run
        n = run.n / (L if run.periodic else L - 2 * radii[0]) ** d

        def haff_rate():
            omega0 = theory.enskog_collision_frequency(d, n, 2 * radii[0], temperature, masses[0])
            return theory.haff_collisions_per_particle(d, run.duration, run.restitution, omega0) / run.duration
        rows = [_try("Enskog omega0, cooled by Haff's law (mean over the run)", haff_rate,
                     "homogeneous cooling only: clusters raise the rate")]
        if stratified:
            rows[0].applies = False
            rows[0].note = "under gravity the cooling gas is not homogeneous: Haff's law does not apply"
    # Enskog and the 1D Maxwellian average carry model errors of a few % (notes): a deviation in
    # sigmas is printed only when the statistical error is larger than that
    frame = []
    for exp in rows:
        approximate = exp.model.startswith("Enskog") or exp.model.startswith("1D rods")
        fits = exp.applies and (not approximate or (math.isfinite(est.error) and est.error > 0.02 * rate))
        frame.append({"MODEL": exp.model, "COLLISIONS": run.collisions, "RATE_PER_PARTICLE_HZ": rate,
                      "RATE_ERR_HZ": est.error, "N_EFF": est.n_eff, "THEORY_HZ": exp.value,
                      "DEV_SIGMA": _dev(rate, est.error, exp.value, fits),
                      "REL_DEV": _rel(rate, exp.value),
                      "NOTE": err_note + exp.note + ("" if fits or not (exp.applies and math.isfinite(est.error)) else
                                                     "; model error (a few %) above the statistical "
                                                     "error: REL_DEV, not DEV_SIGMA")})
    return pd.DataFrame(frame)


def contact_frame(run: Run, temperature: float) -> pd.DataFrame:
    """A mixture's contact values g_ij per pair of species, measured from the collisions, against BMCSL.

    The collisions between species i and j per unit time are
    V n_i n_j g_ij S_D(sigma_ij) <|v_rel|> (half that for i = j,
    :func:`gaz_cli.theory.pair_collision_density`): their count over the run
    reads g_ij; its error is the reblocking of the count per time bin. CHOC's
    particle indices give the species (COMPOSITION.CO_RANK: the species'
    block of indices). A periodic box only: walls thin the density near them.
    """
    cols = ["PAIR", "COLLISIONS", "G_MEASURED", "G_ERR", "N_EFF", "G_THEORY", "DEV_SIGMA", "REL_DEV", "MODEL",
            "NOTE"]
    sp = run.species.reset_index(drop=True)
    pairs = [(a, b) for a in range(len(sp)) for b in range(a, len(sp))]

    def empty(note):
        return pd.DataFrame([{"PAIR": f"{sp.NAME[a]}-{sp.NAME[b]}", "COLLISIONS": NA, "G_MEASURED": NA, "G_ERR": NA,
                              "N_EFF": NA, "G_THEORY": NA, "DEV_SIGMA": NA, "REL_DEV": NA, "MODEL": "BMCSL",
                              "NOTE": note} for a, b in pairs], columns=cols)
    if run.record != "all" or run.pair_bins is None:
        return empty("needs the collisions' partners: --record all" if run.record != "all" else
                     "no CHOC rows, or no species ranks (COMPOSITION.CO_RANK) in this database")
    if not run.periodic:
        return empty("a periodic box only: walls thin the density next to them (contact values are bulk ones)")
    if run.extra_forces:
        return empty(run.extra_forces)
    if not math.isfinite(temperature):
        return empty("temperature unknown")
    volume = run.length ** run.dim
    density = sp.COUNT.to_numpy(dtype=float) / volume
    diam = 2.0 * sp.RADIUS_M.to_numpy(dtype=float)
    try:
        bmcsl = theory.mixture_contact_values(density, diam) if run.dim == 3 else None
    except SceneError:
        bmcsl = None
    rank = sp.RANK.to_numpy(dtype=float)
    pb = run.pair_bins
    width = run.duration / errorbars.BINS
    rows = []
    for a, b in pairs:
        sel = (((pb.RANK_I == rank[a]) & (pb.RANK_J == rank[b])) | ((pb.RANK_I == rank[b]) & (pb.RANK_J == rank[a])))
        counts = _per_bin(np.clip(pb.BIN[sel], 0, errorbars.BINS - 1), pb.NB_CHOCS[sel].to_numpy(dtype=float))
        sigma = 0.5 * (diam[a] + diam[b])
        per_unit_g = float(theory.pair_collision_density(run.dim, density[a], density[b], sigma, temperature,
                                                         sp.MASS_KG[a], sp.MASS_KG[b], 1.0, same=a == b)) * volume
        est = errorbars.time_average(counts / (width * per_unit_g), duration=run.duration)
        g_th = float(bmcsl[a, b]) if bmcsl is not None else NA
        rows.append({"PAIR": f"{sp.NAME[a]}-{sp.NAME[b]}", "COLLISIONS": int(counts.sum()), "G_MEASURED": est.mean,
                     "G_ERR": est.error, "N_EFF": est.n_eff, "G_THEORY": g_th,
                     "DEV_SIGMA": _dev(est.mean, est.error, g_th), "REL_DEV": _rel(est.mean, g_th),
                     "MODEL": "BMCSL g_ij at contact" if bmcsl is not None else "none",
                     "NOTE": ("BMCSL sits about 0.2% below simulations at packing 0.3 (and more above): "
                              "a DEV_SIGMA of a few is that, with long runs" if bmcsl is not None else
                              "no mixture contact values in 2D or 1D here")})
    return pd.DataFrame(rows, columns=cols)


def wall_speed_frame(run: Run, temperature: float) -> pd.DataFrame:
    """Q35's mean speed of wall hits, per species (and all), against the flux-weighted mean.

    Error: reblocking plus the spread of the N_s speeds drawn at the start
    (frozen until collisions redraw them, for ever for equal-mass rods). Theory at the
    run's kinetic temperature is the fixed-energy value
    (:func:`gaz_cli.theory.fixed_energy_hit_speed_factor`, 1 - 1/(4 D N)).
    Under gravity, over the settled part of the run only, against the temperature of
    the same hits' <m v_perp^2> = 2 k_B T (:func:`settled_temperature`): a test of the
    flux-weighted Maxwell-Boltzmann shape. Against the conserved energy's temperature the
    slow exchange of kinetic and potential energy, over a few falls across the box in the
    run, would enter the comparison unseen by the reblocking (10 disk seeds: rms of
    DEV_SIGMA 1.36, one at 3.5).
    """
    if run.gravity > 0.0 and not run.periodic and run.settled and run.temperature_source == "energy":
        hits = settled_temperature(run)
        if math.isfinite(hits.mean) and math.isfinite(hits.error):
            run = dataclasses.replace(run, temperature_error=hits.error, temperature_source="hits")
            temperature = hits.mean
    h = run.hits
    rows = []
    expected_all = expected_all_error = 0.0
    weights = _species_partial_weights(run, temperature) if len(run.species) else []
    pa = h.PA_NUM.to_numpy(dtype=np.int64) if len(h) else np.zeros(0, dtype=np.int64)
    # 1D rods of equal masses (one species, or several radii) swap velocities at each collision: the N
    # speeds drawn at the start are kept for ever, and every wall sees the hits of all N ghosts
    frozen_forever = run.dim == 1 and len(run.species) > 0 and run.species.MASS_KG.nunique() == 1
    relax = math.inf if frozen_forever else errorbars.SPEED_RELAXATION
    # at the run's own kinetic temperature, the D N velocity components share a fixed energy
    components = (run.dim * run.n if run.temperature_source == "kinetic" and run.gravity <= 0.0
                  and not run.periodic and run.restitution >= 1.0 and run.wall_restitution >= 1.0
                  and run.n >= 1 else None)
    for sp, w in zip(run.species.itertuples(), weights):
        sel = pa == sp.PA_NUM
        sums = _per_bin(h.BIN[sel], h.SUM_VIT[sel]) if len(h) else np.zeros(errorbars.BINS)
        counts = _per_bin(h.BIN[sel], h.NB_REBONDS[sel]) if len(h) else np.zeros(errorbars.BINS)
        exp = (_try("flux-weighted mean <v^2>/<|v|>",
                    lambda: theory.wall_hit_mean_speed(run.dim, temperature, sp.MASS_KG, components))
               if math.isfinite(temperature) else Expectation(NA, "flux-weighted", "temperature unknown"))
        static = (errorbars.hit_speed_var(run.dim, run.n if frozen_forever else int(sp.COUNT),
                                          K_B * temperature / sp.MASS_KG)
                  if math.isfinite(temperature) else 0.0)
        est = _estimate(run, sums, counts, static_var=static, relaxation=relax, end_var=0.0)
        if exp.known and run.temperature_error > 0:
            exp.error = exp.value * run.temperature_error / (2.0 * temperature)    # theory ~ sqrt(T)
        if frozen_forever:
            exp.note = "1D equal masses: the N speeds drawn at the start are kept for ever (in ERR)"
        expected_all = expected_all + w * exp.value
        expected_all_error += w * exp.error          # one temperature for all species: errors add
        rows.append({"SPECIES": sp.NAME, "BOUNCES": int(counts.sum()), "VITESSE_MOYENNE": est.mean,
                     "ERR": est.error, "N_EFF": est.n_eff, "ERR_FROZEN": est.frozen, "THEORY": exp.value,
                     "DEV_SIGMA": _dev(est.mean, est.error, exp.value, True, exp.error),
                     "REL_DEV": _rel(est.mean, exp.value),
                     "GAS_MEAN_SPEED": (float(theory.mean_speed(run.dim, temperature, sp.MASS_KG))
                                        if math.isfinite(temperature) else NA), "NOTE": exp.note})
    if len(run.species) > 1:
        sums = _per_bin(h.BIN, h.SUM_VIT) if len(h) else np.zeros(errorbars.BINS)
        counts = _per_bin(h.BIN, h.NB_REBONDS) if len(h) else np.zeros(errorbars.BINS)
        static = 0.0
        if math.isfinite(temperature) and frozen_forever:    # one set of N speeds for all species
            static = errorbars.hit_speed_var(run.dim, run.n, K_B * temperature / float(run.species.MASS_KG.iloc[0]))
        elif math.isfinite(temperature):   # the species' frozen spreads, weighted by their shares of the hits
            static = sum((wt ** 2) * errorbars.hit_speed_var(run.dim, int(sp.COUNT), K_B * temperature / sp.MASS_KG)
                         for sp, wt in zip(run.species.itertuples(), weights))
        est = _estimate(run, sums, counts, static_var=static, relaxation=relax, end_var=0.0)
        rows.append({"SPECIES": "all (Q35)", "BOUNCES": int(counts.sum()), "VITESSE_MOYENNE": est.mean,
                     "ERR": est.error, "N_EFF": est.n_eff, "ERR_FROZEN": est.frozen, "THEORY": expected_all,
                     "DEV_SIGMA": _dev(est.mean, est.error, expected_all, not run.ordered_rods, expected_all_error),
                     "REL_DEV": _rel(est.mean, expected_all), "GAS_MEAN_SPEED": NA,
                     "NOTE": ("theory weighted by the species of the two end rods, the only ones hitting the "
                              "walls, over sqrt(m_s)" if run.dim == 1 and run.gravity <= 0.0 else
                              "theory weighted by each species' share of the hits, N_s/((L-2R_s) sqrt(m_s))"
                              if run.gravity <= 0.0 else
                              "theory weighted by each species' share of the hits, its barometric floor and "
                              "ceiling pressures and side pressure over sqrt(m_s)")})
    frame = pd.DataFrame(rows)
    if run.restitution < 1.0 and len(frame):
        frame["NOTE"] = "cooling gas: theory at the initial temperature"
        frame["DEV_SIGMA"] = NA
    elif run.gravity > 0.0 and len(frame):
        source = ("the temperature of its conserved energy" if run.temperature_source == "energy" else
                  "its temperature from <m v_perp^2> = 2kT of its hits (error in DEV_SIGMA)")
        frame["NOTE"] = (run.never_settles or
                         (f"under gravity: the settled part (from {run.duration - run.window:.3g} s) against "
                          f"{source}" if run.settled else
                          "under gravity: the run did not settle (fall and thermalisation take over half of it)")
                         + ("; " + frame.NOTE if len(run.species) > 1 and not run.never_settles else ""))
        if run.ordered_rods and not run.never_settles:
            frame.loc[frame.SPECIES == "all (Q35)", "NOTE"] += "; shares of the hits: " + run.ordered_rods
        if not run.settled or run.never_settles:
            frame["DEV_SIGMA"] = NA
    if run.extra_forces and len(frame):
        frame["NOTE"] = run.extra_forces
        frame["DEV_SIGMA"] = NA
    return frame


def gravity_frame(run: Run, temperature: float) -> pd.DataFrame:
    """Floor minus ceiling force against N m g (N), and the ceiling/floor hit ratio against its theory.

    Over the analysed window tau the floor - ceiling impulse is exactly
    N m g tau + (P_end - P_start) along the vertical: the force's error is that of the
    momentum change, sqrt(2 sum_s N_s m_s k_B T)/tau (start and end momenta independent
    Maxwellian draws), where reblocking the per-bin forces reads the hits' noise, which
    the momentum carried from bin to bin cancels (it scattered from 0.3 to 6 times that).
    """
    d = run.dim
    pressures = wall_bin_pressures(run)
    series = (pressures[-d] - pressures[d]) * run.wall_measure
    est = _estimate(run, series)
    counts, radii, masses = _counts_radii_masses(run)
    if math.isfinite(est.mean) and math.isfinite(temperature) and len(run.species) and run.window > 0:
        error = math.sqrt(2.0 * float(np.sum(counts * masses)) * K_B * temperature) / run.window
        var1 = float(np.var(series[run.settle_bin:], ddof=1)) if series.size - run.settle_bin > 1 else NA
        est = errorbars.Estimate(est.mean, error, var1 / error ** 2, NA, False, 0.0)
    weight = float(np.sum(counts * masses) * run.gravity)
    pushed = run.drag > 0.0 or run.planes     # forces on the gas other than the weight and the two walls
    rows = [{"QUANTITY": "floor - ceiling force (N)", "MEASURED": est.mean, "ERR": est.error, "N_EFF": est.n_eff,
             "THEORY": weight, "DEV_SIGMA": _dev(est.mean, est.error, weight, not pushed),
             "REL_DEV": _rel(est.mean, weight),
             "NOTE": run.extra_forces if pushed else
                     "sum N m g: exact momentum balance (settled part of the run); ERR: that of the gas's "
                     "vertical momentum at its two ends"}]
    h = run.hits
    start = run.settle_bin
    wall = h.RE_DIR.to_numpy(dtype=np.int64) if len(h) else np.zeros(0, dtype=np.int64)
    floor = _per_bin(h.BIN[wall == -d], h.NB_REBONDS[wall == -d]) if len(h) else np.zeros(errorbars.BINS)
    ceiling = _per_bin(h.BIN[wall == d], h.NB_REBONDS[wall == d]) if len(h) else np.zeros(errorbars.BINS)
    ratio_est = _estimate(run, ceiling, floor)
    if run.one_species and math.isfinite(temperature) and len(run.species):
        m = masses[0]

        def hit_ratio():   # hits per time: P / sqrt(2 pi m kT) on each wall, same T: the pressure ratio
            floor_p, ceiling_p, _, _, _ = _gravity_walls(run, temperature)
            return ceiling_p / floor_p
        exp = _try("ceiling/floor pressure ratio of the barometric model", hit_ratio,
                   f"Boltzmann exp(-m g (L-2R)/kT) = "
                   f"{math.exp(-m * run.gravity * (run.length - 2 * radii[0]) / (K_B * temperature)):.4g} "
                   "for an ideal gas")
    else:
        exp = Expectation(NA, "Boltzmann", "one species only")
    if run.never_settles:
        exp.applies, exp.note = False, run.never_settles
    elif run.extra_forces:
        exp.applies, exp.note = False, run.extra_forces
    rows.append({"QUANTITY": "ceiling/floor hit ratio", "MEASURED": ratio_est.mean, "ERR": ratio_est.error,
                 "N_EFF": ratio_est.n_eff, "THEORY": exp.value,
                 "DEV_SIGMA": _dev(ratio_est.mean, ratio_est.error, exp.value, run.settled and exp.applies),
                 "REL_DEV": _rel(ratio_est.mean, exp.value),
                 "NOTE": f"settled part, {int(floor[start:].sum())} floor and {int(ceiling[start:].sum())} "
                         f"ceiling hits; {exp.note}"})
    return pd.DataFrame(rows)


def cooling_frame(run: Run) -> pd.DataFrame:
    """Final temperature of a cooling granular gas against Haff's law (time and per-collision forms).

    T_END_K is exact (the final kinetic energy); its error is that of the
    energy lost, from reblocking of the loss per time bin (needs CHOC rows).
    """
    d = run.dim
    rows = []
    t0 = run.temperature_of(run.ke_start)
    t_end = run.temperature_of(run.ke_end)
    err = NA
    counts, radii, masses = _counts_radii_masses(run)
    if run.chocs is not None and run.one_species and math.isfinite(t0):
        loss = _collision_losses(run)
        bins = np.clip((run.chocs.CH_T.to_numpy(dtype=float) * errorbars.BINS / run.duration).astype(np.int64),
                       0, errorbars.BINS - 1)
        est = errorbars.time_average(_per_bin(bins, loss), duration=run.duration)
        # the loss summed over the run is BINS times the mean loss per bin; T is linear in K
        thermal = run.ke_start - (run.drift_energy if run.periodic else 0.0)
        err = est.error * errorbars.BINS * t0 / thermal
    if run.extra_forces:
        rows.append(Expectation(NA, "Haff T0/(1 + t/t0)^2", run.extra_forces))
    elif run.one_species and math.isfinite(t0):
        sigma = 2 * radii[0]
        n = run.n / (run.length if run.periodic else run.length - sigma) ** d

        def haff_time():
            omega0 = theory.enskog_collision_frequency(d, n, sigma, t0, masses[0])
            return theory.haff_temperature(d, run.duration, t0, run.restitution, omega0)
        rows.append(_try("Haff T0/(1 + t/t0)^2, Enskog omega0", haff_time,
                         "homogeneous cooling only (before clusters form); Enskog rate at the initial density"))
    else:
        rows.append(Expectation(NA, "Haff T0/(1 + t/t0)^2", "one species only"))
    if run.collisions is not None and math.isfinite(t0) and not run.extra_forces:
        if run.chocs is not None and len(run.chocs) == run.collisions:
            elastic = tc_elastic(run.chocs.CH_T.to_numpy(dtype=float), run.chocs.CH_I.to_numpy(dtype=np.int64),
                                 run.chocs.CH_J.to_numpy(dtype=np.int64), run.tc)
            tau = 2.0 * float(np.sum(~elastic)) / run.n
            note = (f"tau = 2 inelastic collisions / N = {tau:.4g} ({int(elastic.sum())} of "
                    f"{run.collisions} made elastic by the TC model)")
        else:
            tau = 2.0 * run.collisions / run.n
            note = (f"tau = 2 collisions / N = {tau:.4g}, TC-elastic ones included "
                    "(--record all separates them)")
        rows.append(_try("Haff per collision T0 exp(-(1-e^2) tau/D)",
                         lambda: theory.haff_temperature_per_collision(d, tau, t0, run.restitution),
                         note + "; molecular chaos: clusters slow the loss per collision"))
    return pd.DataFrame([{"MODEL": e.model, "T_START_K": t0, "T_END_K": t_end, "T_END_ERR_K": err,
                          "T_THEORY_K": e.value, "REL_DEV": _rel(t_end, e.value), "NOTE": e.note}
                         for e in rows])


def _collision_losses(run: Run) -> np.ndarray:
    """(k,) kinetic energy lost by each CHOC collision, J (0 for those the TC model made elastic)."""
    m = float(run.species.MASS_KG.iloc[0])
    e = run.restitution
    t = run.chocs.CH_T.to_numpy(dtype=float)
    j = run.chocs.CH_IMP.to_numpy(dtype=float)
    inelastic = ~tc_elastic(t, run.chocs.CH_I.to_numpy(dtype=np.int64), run.chocs.CH_J.to_numpy(dtype=np.int64),
                            run.tc)
    return np.where(inelastic, (1 - e) / (1 + e) * j * j / m, 0.0)


# --- gaz analyse ------------------------------------------------------------------
TABLES = {
    "q34": "Q34 simulations per dimension",
    "q35": "Q35 wall bounces and mean speed of wall hits",
    "q36": "Q36 momentum and pressure per wall",
    "overview": "pressure against the ideal gas",
    "simulation": "simulation",
    "pressure": "pressure against theory",
    "collisions": "collision rate against Enskog",
    "contact": "contact values per pair of species",
    "speed": "mean wall-hit speed against theory",
    "gravity": "force balance under gravity",
    "cooling": "cooling against Haff's law",
    "figures": "figures",
}
"""Short names (``gaz analyse --table NAME``) of the tables ``report`` returns."""


def report(db: str, sim: int | None = None, plot_dir: str | None = None) -> dict:
    """What ``gaz analyse`` prints: a dict of table title -> DataFrame (or dict of scalars).

    Always: Q34, Q35, Q36 with the pressure per wall (with its error, the
    expected value and the deviation in sigmas) and the overview (one row per
    simulation). With ``sim``: also the scene, the pressure against every
    model that applies, the collision rate against Enskog, the mean wall-hit
    speed against the flux-weighted theory, under gravity the force balance,
    for a cooling gas Haff's law. ``plot_dir``: PNG figures for each
    simulation analysed, listed in a last table 'figures'. The database sums
    the rows (per wall, species and time bin); only figures read the rows.
    Numeric columns hold numbers (NaN where no value exists, the reason in
    a text column).
    """
    from gaz_cli.results import store as st

    if sim is not None and (isinstance(sim, bool) or not isinstance(sim, (int, np.integer))):
        raise StoreError(f"sim {sim!r} is not an int; give SIMULATION.SI_NUM as an int, e.g. sim=1")
    with interruptible(plot_dir), st.Store(db, create=False) as store:  # closed: SQLite drops -wal, -shm
        return _report(store, db, sim, plot_dir)


@contextlib.contextmanager
def interruptible(plot_dir: str | None = None):
    """SIGINT and SIGTERM inside the block raise :class:`~gaz_cli.errors.Interrupted` saying the
    analysis stopped (SIGTERM's default action would end the process without a word, exit 143)."""
    try:
        with interrupts.catching():
            yield
    except Interrupted as exc:
        figures = f"; the figures already drawn stay in '{plot_dir}'" if plot_dir is not None else ""
        raise Interrupted(exc.signum, f"{interrupts.STOPPED_ANALYSIS}{figures}") from None


def _report(store, db: str, sim: int | None, plot_dir: str | None) -> dict:
    """:func:`report` on an open store."""
    from gaz_cli.results.store import shown

    numbers = store.simulation_numbers()
    name = shown(str(db))  # (a URL's password hidden)
    if not numbers:
        raise StoreError(f"'{name}' holds no simulation yet; run 'gaz simulate --db {name}' first")
    if sim is not None and sim not in numbers:
        raise StoreError(f"simulation {sim} is not in '{name}'; it holds SI_NUM {_ranges(numbers)}")
    if plot_dir is not None:
        from gaz_cli.analysis import plots

        plots.make_folder(plot_dir)
    chosen = [sim] if sim is not None else numbers
    q34 = store.query("q34_simulations_per_dimension")
    q35 = None if sim is not None else store.query("q35_bounces_per_simulation")
    walls, overview, figures = [], [], []
    blank = []  # simulations without a figure, each with the reason
    detail = {}
    for number in chosen:
        run = load_run(store, number)
        temperature = run.kinetic_temperature
        if run.gravity > 0.0 and not run.periodic and run.settled and run.restitution >= 1.0:
            # the settled gas's temperature: from the conserved energy where the initial state is
            # known, else from the hits (an error bar that misses the slow exchange between axes)
            from_energy = energy_temperature(run)
            settled = settled_temperature(run) if not math.isfinite(from_energy) else None
            if math.isfinite(from_energy):
                temperature, run.temperature_source = from_energy, "energy"
            elif math.isfinite(settled.mean) and math.isfinite(settled.error):
                temperature, run.temperature_error = settled.mean, settled.error
                run.temperature_source = "hits"
        per_wall = exam_per_wall(run)
        if sim is not None:
            q35 = exam_q35(run)
        summary = pressure_summary(run, temperature)
        walls.append(per_wall_frame(run, per_wall, temperature, summary))
        overview.append(_overview_row(run, temperature, summary))
        if sim is not None:
            detail = {
                TABLES["simulation"]: simulation_frame(run, temperature),
                TABLES["pressure"]: pressure_frame(run, temperature, summary),
                TABLES["collisions"]: collision_frame(run, temperature),
            }
            if len(run.species) > 1:
                detail[TABLES["contact"]] = contact_frame(run, temperature)
            if not run.periodic:
                detail[TABLES["speed"]] = wall_speed_frame(run, temperature)
            if run.gravity > 0.0 and not run.periodic:
                detail[TABLES["gravity"]] = gravity_frame(run, temperature)
            if run.restitution < 1.0:
                detail[TABLES["cooling"]] = cooling_frame(run)
        if plot_dir is not None:
            drawn = make_plots(run, temperature, summary, plot_dir)
            figures.extend(drawn)
            if not drawn:
                blank.append(f"simulation {number}: {_nothing_to_draw(run)}")
    frames = {
        TABLES["q34"]: q34,
        TABLES["q35"]: q35,
        TABLES["q36"]: pd.concat(walls, ignore_index=True),
        TABLES["overview"]: pd.DataFrame(overview),
    }
    frames.update(detail)
    if blank:
        warnings.warn(GazWarning(f"--plot {plot_dir}: nothing to draw for {'; '.join(blank)}"), stacklevel=2)
    if plot_dir is not None:
        frames[TABLES["figures"]] = pd.DataFrame(figures, columns=["SI_NUM", "FIGURE", "FILE"])
    return frames


def _overview_row(run: Run, temperature: float, summary: dict) -> dict:
    """One simulation in one row: measured pressure, ideal gas, best theory, deviation in sigmas."""
    row = {"SI_NUM": run.si_num, "SI_DIM": run.dim, "SI_N": run.n, "SI_L": run.length, "SI_DUR": run.duration,
           "BOUNDARY": run.boundary, "T_KIN_K": _num(run.kinetic_temperature), "T_THEORY_K": _num(temperature),
           "P_UNIT": run.unit}
    if run.periodic:
        ideal = _try("ideal", lambda: theory.ideal_gas_pressure(run.n, temperature, run.length ** run.dim))
    else:
        counts, radii, _ = _counts_radii_masses(run)
        ideal = (_try("ideal", lambda: theory.ideal_wall_pressure(run.dim, run.length, temperature, counts, radii))
                 if len(run.species) and math.isfinite(temperature) else Expectation(NA, "ideal"))
    measured = _num(summary["measured"])
    best = summary["best"]
    row.update({"P_MEASURED": measured, "P_ERR": _num(summary["error"]), "N_EFF": summary["n_eff"],
                "P_IDEAL": ideal.value, "RATIO": _rel(measured, ideal.value) + 1.0,
                "P_THEORY": best.value, "THEORY": best.model,
                "DEV_SIGMA": _dev(measured, summary["error"], best.value, best.applies, best.error),
                "NOTE": "" if best.known and best.applies else best.note})
    return row




# --- figures -----------------------------------------------------------------------
def make_plots(run: Run, temperature: float, summary: dict, plot_dir: str) -> list:
    """Write the figures of one simulation into ``plot_dir``; returns rows (SI_NUM, FIGURE, FILE)."""
    from gaz_cli.analysis import plots

    out = []
    base = Path(plot_dir)

    def path(name):
        return str(base / f"sim{run.si_num}_{name}.png")

    b = run.bounces() if run.bounces_count else run.bounces().iloc[:0]
    species = ([(r.NAME, r.MASS_KG, w, r.COUNT / run.n)
                for r, w in zip(run.species.itertuples(), _species_partial_weights(run, temperature))]
               if len(run.species) else [])
    label = (f"simulation {run.si_num}: {run.n} particles, {run.dim}D, {run.boundary}, "
             f"L = {run.length:.3g} m, T_kin = {temperature:.4g} K")
    if len(b):
        p = path("wall_hit_speeds")
        plots.wall_hit_speeds(p, run.dim, b.RE_VIT.to_numpy(dtype=float), b.RE_VP.to_numpy(dtype=float),
                              temperature, species, label)
        out.append((run.si_num, "wall-hit speeds over the flux-weighted Maxwell-Boltzmann law", p))
        # counts per wall against the expected number of hits: P A tau / sqrt(2 pi m kT) per species
        counts = [int(np.sum(b.RE_DIR.to_numpy() == w)) for w in run.walls]
        expected = _expected_hits(run, temperature)
        p = path("bounces_per_wall")
        plots.bounces_per_wall(p, run.dim, run.walls, counts, expected, label, gravity=run.gravity > 0)
        out.append((run.si_num, "bounces per wall against theory", p))
    series = _pressure_series(run, temperature, summary) if run.restitution >= 1.0 else None
    if series is not None:
        p = path("pressure_time")
        plots.pressure_against_time(p, **series, title=label)
        out.append((run.si_num, "running pressure against simulated time", p))
    if run.gravity > 0.0 and len(b):
        prof = gravity_profile(run, temperature, bounces=b)
        if prof is not None:
            p = path("density_profile")
            plots.density_profile(p, **prof, title=label)
            out.append((run.si_num, "density profile from floor hits over the barometric law", p))
    if run.restitution < 1.0 and run.chocs is not None and run.one_species:
        cool = cooling_series(run)
        if cool is not None:
            p = path("cooling")
            plots.cooling(p, **cool, title=label)
            out.append((run.si_num, "temperature of the cooling gas against Haff's law", p))
    return out


def _nothing_to_draw(run: Run) -> str:
    """Why :func:`make_plots` drew nothing for ``run``: its figures need wall bounces (the
    periodic box's pressure against time, collisions of one species)."""
    if run.periodic:
        if run.record != "all":
            return "a periodic box has no wall bounce, and its pressure against time needs --record all"
        if not run.one_species:
            return "a periodic box has no wall bounce, and its pressure against time is drawn for one species only"
        return f"no collision in its {run.duration:.3g} s"
    if run.record == "none":
        return "its wall bounces were not recorded, --record none"
    return f"no wall bounce in its {run.duration:.3g} s"


def _expected_hits(run: Run, temperature: float):
    """Expected bounces on each wall, sum_s P_s A tau / sqrt(2 pi m_s kT), or None.

    In equilibrium the mean momentum a hit gives a wall is sqrt(2 pi m kT)
    (physics.md section 6), so the hit rate is the pressure divided by it.
    P_s is species s's share of the wall's expected pressure: its own
    barometric floor/ceiling pressure under gravity, else the best model's
    pressure shared as N_s/(L - 2R_s).
    """
    expected = wall_pressure_theory(run, temperature)
    if not len(run.species) or not all(e.known for e in expected.values()):
        return None
    counts, radii, masses = _counts_radii_masses(run)
    kt = K_B * temperature
    scale = run.wall_measure * run.duration / np.sqrt(2 * math.pi * masses * kt)
    share = counts / (run.length - 2 * radii)
    share = share / share.sum()
    out = []
    for w in run.walls:
        if run.gravity > 0.0 and abs(w) == run.dim and not run.one_species:
            per_species = np.array([theory.ideal_gravity_wall_pressures(
                run.dim, run.length, temperature, c, r, m, run.gravity)[0 if w < 0 else 1]
                for c, r, m in zip(counts, radii, masses)])
        else:
            per_species = expected[w].value * share
        out.append(float(np.sum(per_species * scale)))
    return out


def _pressure_series(run: Run, temperature: float, summary: dict, blocks: int = BLOCKS):
    """Running mean of the pressure against time, its error band, block values and theory, or None."""
    best = summary["best"]
    theory_value = best.value if best.known else None
    if run.periodic:
        series = virial_bin_pressures(run, temperature)
        what = "virial pressure"
    else:
        per_bin = wall_bin_pressures(run)
        series = np.mean([per_bin[k] for k in run.walls], axis=0) if run.bounces_count else None
        what = "wall pressure (mean over the walls)"
    if series is None:
        return None
    nbins = errorbars.BINS
    width = run.duration / nbins
    times = (np.arange(nbins) + 1) * width
    running = np.cumsum(series) / np.arange(1, nbins + 1)
    err = summary["error"]
    band = err * np.sqrt(run.duration / times) if math.isfinite(err) else None
    block_values = series[: nbins - nbins % blocks].reshape(blocks, -1).mean(axis=1)
    centres = (np.arange(blocks) + 0.5) * run.duration / blocks
    others = [(e.model, e.value) for e in summary["models"][1:] if e.known]
    return {"times": times, "running": running, "band": band, "block_times": centres,
            "block_values": block_values, "theory": theory_value, "theory_label": best.model,
            "others": others, "what": what, "unit": run.unit}


def gravity_profile(run: Run, temperature: float, bins: int = 60, bounces: pd.DataFrame | None = None):
    """Density of centres against height, rebuilt from the floor hits, with the barometric law.

    The store keeps no positions; but a particle leaving the floor at the
    vertical speed u flies freely (no collision) on z(t) = R + u t - g t^2/2,
    crossing each height z < R + u^2/(2g) twice at the speed
    w = sqrt(u^2 - 2 g (z - R)), so the time-averaged number of centres per
    unit height is n(z) = (2/tau) sum_floor hits 1/w(z) (capped at the
    ceiling). Exact for non-interacting particles; with collisions it is the
    profile the floor's hit statistics imply. Returns arrays for
    :func:`gaz_cli.analysis.plots.density_profile` or None.
    """
    d = run.dim
    if not len(run.species) or not math.isfinite(temperature):
        return None
    b = run.bounces() if bounces is None else bounces
    floor = b[b.RE_DIR == -d]
    if not len(floor):
        return None
    g, L = run.gravity, run.length
    rmin = float(run.species.RADIUS_M.min())
    z = np.linspace(rmin, L - rmin, bins + 1)
    zc = 0.5 * (z[1:] + z[:-1])
    measured = np.zeros(bins)
    expected = np.zeros(bins)
    for sp in run.species.itertuples():
        u = floor.RE_VP[floor.PA_NUM == sp.PA_NUM].to_numpy(dtype=float)
        r = sp.RADIUS_M
        lo, hi = r, L - r
        # exact bin averages of 1/w: integral of dz / sqrt(u^2 - 2g(z - R)) = -(w)/g
        for k in range(bins):
            a, c = max(z[k], lo), min(z[k + 1], hi)
            if c <= a:
                continue
            wa = np.sqrt(np.maximum(u * u - 2 * g * (a - r), 0.0))
            wc = np.sqrt(np.maximum(u * u - 2 * g * (c - r), 0.0))
            measured[k] += 2.0 * np.sum(wa - wc) / g / run.duration / (z[k + 1] - z[k])
        expected += sp.COUNT * theory.barometric_height_pdf(zc, temperature, sp.MASS_KG, g, L, r)
    return {"heights": zc, "measured": measured, "expected": expected,
            "scale_height": (K_B * temperature / (float(run.species.MASS_KG.mean()) * g))}


def tc_elastic(t, i, j, tc: float) -> np.ndarray:
    """(k,) bool: which collisions of a time-ordered list the TC model made elastic.

    A collision is elastic when either partner had collided (elastically or
    not) less than ``tc`` seconds before (Luding & McNamara; the event
    engine's rule). ``t`` (k,) s, ``i``, ``j`` (k,) particle indices.
    """
    t = np.asarray(t, dtype=float)
    k = t.size
    if k == 0 or tc <= 0.0:
        return np.zeros(k, dtype=bool)
    who = np.concatenate([np.asarray(i), np.asarray(j)])
    when = np.concatenate([t, t])
    which = np.concatenate([np.arange(k), np.arange(k)])
    order = np.lexsort((which, who))            # by particle, then in time order
    prev = np.full(2 * k, -np.inf)
    same = who[order][1:] == who[order][:-1]
    prev_sorted = np.full(2 * k, -np.inf)
    prev_sorted[1:] = np.where(same, when[order][:-1], -np.inf)
    prev[order] = prev_sorted
    since = when - prev                          # time since this partner's previous collision
    return (since[:k] < tc) | (since[k:] < tc)


def cooling_series(run: Run, points: int = 200):
    """Temperature of a cooling gas against time from the CHOC impulses, with Haff's law; or None.

    Each inelastic collision with impulse J between equal masses m loses
    (1 - e)/(1 + e) J^2/m of kinetic energy; the collisions the TC model makes
    elastic (:func:`tc_elastic`) lose nothing.
    """
    d = run.dim
    t = run.chocs.CH_T.to_numpy(dtype=float)
    loss = _collision_losses(run)
    t0 = run.temperature_of(run.ke_start)
    grid = np.linspace(0.0, run.duration, points)
    cum = np.concatenate(([0.0], np.cumsum(loss)))
    ke = run.ke_start - cum[np.searchsorted(t, grid, side="right")]
    temps = np.array([run.temperature_of(k) for k in ke])
    temps = np.where(np.isfinite(temps), temps, 0.0)
    sigma = 2 * float(run.species.RADIUS_M.iloc[0])
    m = float(run.species.MASS_KG.iloc[0])
    n = run.n / (run.length if run.periodic else run.length - sigma) ** d
    try:
        omega0 = theory.enskog_collision_frequency(d, n, sigma, t0, m)
        haff = theory.haff_temperature(d, grid, t0, run.restitution, omega0)
    except SceneError:
        haff = None
    t_end = run.temperature_of(run.ke_end)
    return {"times": grid, "temperatures": temps, "haff": haff, "t_end": t_end}


def _ranges(numbers: list[int]) -> str:
    """'1-3, 7' from [1, 2, 3, 7]."""
    out, start, prev = [], None, None
    for k in numbers:
        if start is None:
            start = prev = k
        elif k == prev + 1:
            prev = k
        else:
            out.append(f"{start}-{prev}" if prev != start else f"{start}")
            start = prev = k
    out.append(f"{start}-{prev}" if prev != start else f"{start}")
    return ", ".join(out)
