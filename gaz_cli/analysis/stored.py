"""One simulation as analysis reads it from the database: :class:`StoredRun` and :func:`load_run`.

The database does the summing: bounces per wall, species and time bin
(``sql/bounce_bins.sql``, or one time bin at a time by ``sql/wall_sums_in_range.sql``),
collisions per time bin (``sql/collision_bins.sql``); analysis reads those few thousand
numbers, not the REBOND rows (figures excepted). Rows no run can have are refused here
(:class:`~gaz_cli.errors.StoreError`). Also the initial state rebuilt from a stored scene file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from gaz_cli import theory
from gaz_cli.analysis import errorbars
from gaz_cli.errors import GazError, StoreError
from gaz_cli.constants import PRESSURE_UNIT  # noqa: F401 - a pressure is a force per wall measure

@dataclass
class StoredRun:
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
    profile: pd.DataFrame | None = None
    """PR_AXIS, PR_BLOCK, PR_BIN, PR_SAMPLES, PR_COUNT: the density profile (PROFIL), None where the run has none."""
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



def _only_row(store, table, si_num: int):
    """The one row of a per-simulation table (SCENE, RESULTAT) as a Series, or None if absent."""
    frame = store.table(table, si_num)
    return frame.iloc[0] if len(frame) else None

def load_run(store, si_num: int) -> StoredRun:
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
    run = StoredRun(si_num=int(si_num), dim=int(sim.SI_DIM), n=int(sim.SI_N), length=float(sim.SI_L),
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
    import sqlalchemy as sa

    if not run.periodic and sa.inspect(store.engine).has_table(st.profil.name):   # schema 7 on
        profile = store.table(st.profil, si_num)
        run.profile = profile if len(profile) else None
    if run.periodic and run.n > 1:
        run.drift_energy = drift_energy(run.scene_file, run.ke_start)
    bins = dict(si_num=int(si_num), bins=errorbars.BINS, duration=run.duration)
    # SQLite groups by sorting: one bin's rows at a time sort faster than the run's; PostgreSQL
    # groups by hashing, nothing to gain (its GROUP BY of 10^7 rows: 5.5 s, by ranges 8-9 s)
    run.hits = _bin_sums_by_ranges(store, run) if store.engine.dialect.name == "sqlite" else None
    if run.hits is None:  # PostgreSQL, or rows not in time order: one GROUP BY of them all
        store.check_number_columns(st.rebond, run.si_num)   # (SQLite's SUM reads text as 0)
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
        if coll.NB_ODD.sum():   # text edited by hand, summed as 0: named
            store.check_number_columns(st.choc, run.si_num)
        coll = coll.drop(columns="NB_ODD")
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


def _checked_bin_keys(run: StoredRun, key: np.ndarray) -> np.ndarray:
    """sql/bounce_bins.sql's BIN_KEY as int64, refused (StoreError) where a bounce's RE_T is outside
    [0, SI_DUR] (bin BINS: a bounce at SI_DUR itself, kept in the last bin)."""
    ok = np.isfinite(key) & (key >= 0) & (key < (errorbars.BINS + 1) * _KEYS_PER_BIN)
    if not ok.all():
        _refuse_stored(run.si_num, f"a REBOND row has an RE_T outside [0, SI_DUR] = [0, {run.duration:.6g}] s, "
                                   "where a run records its bounces")
    return np.rint(key).astype(np.int64)


def _check_bounce_speeds(run: StoredRun) -> None:
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


def _bin_sums_by_ranges(store, run: StoredRun) -> pd.DataFrame | None:
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
            if not (isinstance(t_first, float) and isinstance(t_last, float)):
                return None     # text edited by hand: the caller's path names it
            if not (0.0 <= t_first and t_last * errorbars.BINS / duration < errorbars.BINS + 1):
                return None     # a time no run has: bounce_bins.sql's path refuses it (_checked_bin_keys)
            starts = _bin_starts(at, int(first), int(last), duration)
            for b in range(errorbars.BINS):
                if starts[b] == starts[b + 1]:
                    continue
                t_lo = -math.inf if b == 0 else _bin_start_time(b, duration)
                t_hi = math.inf if b == errorbars.BINS - 1 else _bin_start_time(b + 1, duration)
                for key, nb, outside, odd, s_vp, s_vit, s_vp2 in sql(
                        "wall_sums_in_range", si_num=run.si_num, lo=starts[b], hi=starts[b + 1] - 1,
                        t_lo=t_lo, t_hi=t_hi):
                    if outside or odd:
                        return None
                    rows.append((int(key) % 8 - 4, int(key) // 8, b, int(nb), float(s_vp), float(s_vit),
                                 float(s_vp2)))
    hits = pd.DataFrame(rows, columns=_HIT_COLUMNS)
    return hits.astype({c: np.int64 for c in _HIT_COLUMNS[:4]} | {c: float for c in _HIT_COLUMNS[4:]})


def rebuilt_state(run: StoredRun):
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
