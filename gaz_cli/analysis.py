"""What ``gaz analyse`` and ``gaz place --repeat`` compute from placements and the database.

The store runs the packaged SQL and hands back tables; this module puts the
results beside theory (:mod:`gaz_cli.theory`), with statistical error bars,
and asks :mod:`gaz_cli.plots` for figures. It never prints and never writes
SQL.

Error bars are block averages: the run's duration is cut into ``BLOCKS``
equal time windows, a quantity (a wall's pressure, the mean speed of wall
hits...) is measured in each, and the standard error of the mean of the
blocks, std(blocks, ddof=1)/sqrt(BLOCKS), is the uncertainty. It is right
when a window is much longer than the correlation time of the quantity (a
few mean free times: the 'simulation' frame shows both). With hard walls and
few collisions the wall pressure converges faster than 1/sqrt(time)
(particles bounce back and forth with fixed energies), so the block error is
then on the safe side; the mean speed of the hits, whose particles keep
their speeds between collisions, is the exception, and in 1D (equal masses,
speeds never relax) its error adds the spread of the initial draw.

Each comparison names its theory (``MODEL``) and its caveats (``NOTE``);
values theory cannot give for a scene (a fit used beyond its range, a mixture,
a cooling gas) are reported as the string ``'n/a'``, never as an error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from gaz_cli import theory
from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError, StoreError

NA = "n/a"
"""What a cell holds when theory or the data cannot give a value."""

BLOCKS = 16
"""Time windows of the block averages."""


# --- placement (gaz place) --------------------------------------------------------
def _check_place_args(dim, n, radius, length):
    if dim not in (1, 2, 3):
        raise SceneError(f"--dim {dim} is not 1, 2 or 3")
    if n is None or n < 1:
        raise SceneError(f"--n must be at least 1, got {n}")
    if not (radius > 0 and math.isfinite(radius)):
        raise SceneError(f"--radius must be > 0, got {radius}")
    if not (length > 0 and math.isfinite(length)):
        raise SceneError(f"--length must be > 0, got {length}")
    from gaz_cli.scene import DENSEST, ball_volume

    eta = n * float(ball_volume(dim, radius)) / length ** dim
    if 2 * radius >= length or eta >= DENSEST[dim]:
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
    from gaz_cli import placement, plots

    _check_place_args(dim, n, radius, length)
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
    """One simulation's rows, as analysis needs them (SI units: kg, m, s, K, J)."""

    si_num: int
    dim: int
    n: int
    length: float
    duration: float
    species: pd.DataFrame
    """PA_NUM, NAME, MASS_KG, RADIUS_M, COUNT: one row per species of the mixture."""
    boundary: str = "walls"
    engine: str = "?"
    gravity: float = 0.0
    restitution: float = 1.0
    tc: float = 0.0
    temperature: float = math.nan
    """The scene's temperature of the initial velocities, K."""
    record: str = "bounces"
    ke_start: float = math.nan
    ke_end: float = math.nan
    events: int | None = None
    collisions: int | None = None
    virial: float = math.nan
    bounces: pd.DataFrame = field(default_factory=pd.DataFrame)
    """REBOND rows: RE_T, RE_DIR, RE_VIT, RE_VP, PA_NUM (time order)."""
    chocs: pd.DataFrame | None = None
    """CHOC rows (--record all) or None."""

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
    def packing_fraction(self) -> float:
        from gaz_cli.scene import ball_volume

        return float(np.sum(self.species.COUNT * ball_volume(self.dim, self.species.RADIUS_M.to_numpy()))
                     / self.length ** self.dim)

    @property
    def kinetic_temperature(self) -> float:
        """Temperature of the run from its kinetic energy, K (nan if unknown).

        Elastic, no gravity: K is constant, the mean of start and end. Under
        gravity the initial, uniform heights settle and the kinetic energy
        changes: the end value. Cooling (restitution < 1): the start value.
        """
        if not (math.isfinite(self.ke_start) and math.isfinite(self.ke_end)):
            return math.nan
        if self.restitution < 1.0:
            ke = self.ke_start
        elif self.gravity > 0.0:
            ke = self.ke_end
        else:
            ke = 0.5 * (self.ke_start + self.ke_end)
        if ke <= 0.0:
            return math.nan
        return float(theory.kinetic_temperature(self.dim, ke, self.n,
                                                periodic=self.periodic and self.n > 1))

    @property
    def walls(self) -> list[int]:
        """Wall codes (RE_DIR) of the box: -1, +1, -2, +2, ..."""
        return [s * (d + 1) for d in range(self.dim) for s in (-1, 1)]


def load_run(store, si_num: int) -> Run:
    """Every row of simulation ``si_num`` analysis uses (REBOND, CHOC included)."""
    from gaz_cli import store as st

    sim = store.table(st.simulation, si_num).iloc[0]
    comp = store.table(st.composition, si_num)
    particles = store.table(st.particule)
    if len(comp):
        sp = comp.merge(particles, on="PA_NUM")
        species = pd.DataFrame({"PA_NUM": sp.PA_NUM.astype(int), "NAME": sp.PA_NOM,
                                "MASS_KG": sp.PA_M.astype(float) / 1000.0,
                                "RADIUS_M": sp.PA_R.astype(float), "COUNT": sp.CO_N.astype(int)})
    else:   # written by something else than gaz simulate: species from the bounces only
        species = pd.DataFrame(columns=["PA_NUM", "NAME", "MASS_KG", "RADIUS_M", "COUNT"])
    run = Run(si_num=int(si_num), dim=int(sim.SI_DIM), n=int(sim.SI_N), length=float(sim.SI_L),
              duration=float(sim.SI_DUR), species=species)
    scene = store.table(st.scene_table, si_num)
    if len(scene):
        sc = scene.iloc[0]
        run.boundary, run.engine = str(sc.SC_BOUNDARY), str(sc.SC_ENGINE)
        run.gravity, run.restitution = float(sc.SC_GRAVITY), float(sc.SC_RESTITUTION)
        run.tc, run.temperature, run.record = float(sc.SC_TC), float(sc.SC_TEMPERATURE), str(sc.SC_RECORD)
    res = store.table(st.resultat, si_num)
    if len(res):
        rs = res.iloc[0]
        run.ke_start, run.ke_end = float(rs.RS_KE_START), float(rs.RS_KE_END)
        run.events, run.collisions = int(rs.RS_EVENTS), int(rs.RS_COLLISIONS)
        run.virial = float(rs.RS_VIRIAL)
    bounces = store.table(st.rebond, si_num)
    run.bounces = bounces.sort_values("RE_NUM")[["RE_T", "RE_DIR", "RE_VIT", "RE_VP", "PA_NUM"]] \
        .reset_index(drop=True) if len(bounces) else pd.DataFrame(
            {"RE_T": [], "RE_DIR": [], "RE_VIT": [], "RE_VP": [], "PA_NUM": []})
    if run.record == "all":
        chocs = store.table(st.choc, si_num)
        run.chocs = chocs.sort_values("CH_NUM").reset_index(drop=True) if len(chocs) else None
    return run


# --- measurements -------------------------------------------------------------------
def _bounce_momentum(run: Run) -> np.ndarray:
    """(k,) momentum 2 m |v_perp| given to the wall by each bounce, kg m/s."""
    mass = run.species.set_index("PA_NUM").MASS_KG
    m = mass.reindex(run.bounces.PA_NUM.to_numpy()).to_numpy(dtype=float)
    return 2.0 * m * run.bounces.RE_VP.to_numpy(dtype=float)


def wall_block_pressures(run: Run, blocks: int = BLOCKS) -> dict[int, np.ndarray]:
    """Wall code -> (blocks,) pressure in each time window (Pa, per full wall area L^(D-1))."""
    t = run.bounces.RE_T.to_numpy(dtype=float)
    wall = run.bounces.RE_DIR.to_numpy(dtype=np.int64)
    mom = _bounce_momentum(run)
    width = run.duration / blocks
    return {w: block_sums(t[wall == w], mom[wall == w], run.duration, blocks) / (width * run.wall_measure)
            for w in run.walls}


def virial_block_pressures(run: Run, temperature: float, blocks: int = BLOCKS) -> np.ndarray | None:
    """(blocks,) virial pressure of a periodic box in each time window, from CHOC (one species), or None.

    P = (N k_B T + W/(D dt))/V with W = sum of |J| sigma over the window's collisions.
    """
    if run.chocs is None or not run.one_species or not math.isfinite(temperature):
        return None
    sigma = 2.0 * float(run.species.RADIUS_M.iloc[0])
    w = block_sums(run.chocs.CH_T.to_numpy(dtype=float), run.chocs.CH_IMP.to_numpy(dtype=float) * sigma,
                   run.duration, blocks)
    width = run.duration / blocks
    return (run.n * K_B * temperature + w / (run.dim * width)) / run.length ** run.dim


# --- theory for one run ---------------------------------------------------------------
@dataclass
class Expectation:
    """One theoretical value: its number (or NA), the model's name and its caveat."""

    value: float | str
    model: str
    note: str = ""
    syst: float | str = 0.0
    """Relative size of the model's known systematic error for this scene (0: exact or unknown)."""

    @property
    def known(self) -> bool:
        return not isinstance(self.value, str) and math.isfinite(self.value)


def _try(model: str, func, note: str = "") -> Expectation:
    """Evaluate ``func()``; a theory range error becomes NA with the reason as note."""
    try:
        return Expectation(float(func()), model, note)
    except SceneError as err:
        return Expectation(NA, model, str(err))


def _counts_radii_masses(run: Run):
    return (run.species.COUNT.to_numpy(dtype=float), run.species.RADIUS_M.to_numpy(dtype=float),
            run.species.MASS_KG.to_numpy(dtype=float))


def pressure_models(run: Run, temperature: float) -> list[Expectation]:
    """Every theoretical pressure that applies to the run; the first one is the best.

    Walls: what the SQL measures (per full wall area). 1D: Tonks, exact.
    2D/3D: :func:`theory.hard_sphere_wall_pressure` (one species), then the
    non-interacting gas. Under gravity the mean over the walls of the
    non-interacting floor, ceiling and side pressures. Periodic: the bulk
    equation of state against the virial. Cooling gas: no equilibrium value.
    """
    counts, radii, masses = _counts_radii_masses(run)
    d, L = run.dim, run.length
    if not math.isfinite(temperature) or not len(run.species):
        return [Expectation(NA, "none", "no kinetic energy or composition recorded for this simulation")]
    if run.restitution < 1.0:
        return [Expectation(NA, "none", f"restitution {run.restitution:g} < 1: the gas cools "
                                        "(Haff's law below), there is no equilibrium pressure")]
    out = []
    if run.periodic:
        n = run.n / L ** d
        if run.one_species:
            model = theory.BEST_MODEL[d]
            out.append(_try(f"hard spheres, bulk {model} EOS",
                            lambda: theory.hard_sphere_pressure(d, n, 2 * radii[0], temperature)))
        out.append(_try("ideal gas N kT/V", lambda: theory.ideal_gas_pressure(run.n, temperature, L ** d),
                        "no interactions: excess pressure ignored"))
        return out
    if run.gravity > 0.0:
        def mean_gravity():
            floor, ceiling = theory.ideal_gravity_wall_pressures(d, L, temperature, counts, radii, masses,
                                                                 run.gravity)
            side = theory.ideal_wall_pressure(d, L, temperature, counts, radii) if d > 1 else 0.0
            return (floor + ceiling + (2 * d - 2) * side) / (2 * d)
        out.append(_try("ideal gas under gravity (mean of the walls)", mean_gravity,
                        "non-interacting (dilute) limit"))
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
        out.append(exp)
    out.append(_try("ideal gas at walls, N kT/((L-2R) L^(D-1))",
                    lambda: theory.ideal_wall_pressure(d, L, temperature, counts, radii),
                    "dilute limit (eta -> 0), exact for non-interacting particles"))
    return out


def wall_pressure_theory(run: Run, temperature: float) -> dict[int, Expectation]:
    """Wall code -> expected pressure on that wall (best model)."""
    counts, radii, masses = _counts_radii_masses(run)
    best = pressure_models(run, temperature)[0]
    if run.gravity > 0.0 and best.known:
        d = run.dim
        floor, ceiling = theory.ideal_gravity_wall_pressures(d, run.length, temperature, counts, radii, masses,
                                                             run.gravity)
        side = theory.ideal_wall_pressure(d, run.length, temperature, counts, radii)
        name = "ideal gas under gravity"
        return {w: Expectation(float(floor if w == -d else ceiling if w == d else side), name, best.note)
                for w in run.walls}
    return {w: best for w in run.walls}


def _species_partial_weights(run: Run) -> np.ndarray:
    """Expected share of the wall hits of each species: N_s / ((L - 2R_s) sqrt(m_s)), normalised."""
    counts, radii, masses = _counts_radii_masses(run)
    w = counts / ((run.length - 2.0 * radii) * np.sqrt(masses))
    return w / w.sum()


# --- the frames ------------------------------------------------------------------------
def _dev(measured, error, expected) -> float | str:
    """(measured - expected)/error, or NA."""
    if isinstance(expected, str) or not all(map(math.isfinite, (measured, error, expected))) or error <= 0:
        return NA
    return (measured - expected) / error


def _rel(measured, expected) -> float | str:
    if isinstance(expected, str) or not (math.isfinite(measured) and math.isfinite(expected)) or expected == 0:
        return NA
    return measured / expected - 1.0


def _num(x) -> float | str:
    """A float, or NA for None/NaN."""
    return NA if x is None or (isinstance(x, float) and not math.isfinite(x)) else x


def simulation_frame(run: Run, temperature: float) -> dict:
    """The scene in one row of scalars."""
    return {"SI_NUM": run.si_num, "SI_DIM": run.dim, "SI_N": run.n, "SI_L": run.length,
            "SI_DUR": run.duration, "ENGINE": run.engine, "BOUNDARY": run.boundary,
            "SPECIES": ", ".join(f"{r.NAME}:{r.COUNT}" for r in run.species.itertuples()) or NA,
            "PACKING_FRACTION": run.packing_fraction if len(run.species) else NA,
            "GRAVITY": run.gravity, "RESTITUTION": run.restitution,
            "T_SCENE_K": _num(run.temperature), "T_KIN_K": _num(temperature),
            "BOUNCES": len(run.bounces), "COLLISIONS": _num(run.collisions),
            "COLL_PER_PARTICLE": 2.0 * run.collisions / run.n if run.collisions is not None else NA,
            "MEAN_FREE_TIME_S": (run.n * run.duration / (2.0 * run.collisions)
                                 if run.collisions else NA),
            "BLOCKS": BLOCKS, "BLOCK_S": run.duration / BLOCKS}


def per_wall_frame(run: Run, per_wall: pd.DataFrame, temperature: float, blocks: int = BLOCKS) -> pd.DataFrame:
    """The Q36 frame with, per wall, the block error, the expected pressure and the deviation in sigmas."""
    frame = per_wall.copy()
    if not len(frame):
        return frame
    pressures = wall_block_pressures(run, blocks)
    expected = wall_pressure_theory(run, temperature)
    errors, theo, devs = [], [], []
    for w, measured in zip(frame.RE_DIR.astype(int), frame.PRESSION.astype(float)):
        _, err = mean_and_error(pressures.get(w, np.zeros(blocks)))
        exp = expected.get(w, Expectation(NA, "none"))
        errors.append(_num(err))
        theo.append(exp.value)
        devs.append(_dev(measured, err, exp.value))
    frame["P_ERR_PA"] = errors
    frame["P_THEORY_PA"] = theo
    frame["DEV_SIGMA"] = devs
    return frame


def pressure_summary(run: Run, temperature: float, blocks: int = BLOCKS) -> dict:
    """Measured pressure (mean over the walls, or virial), its error, and the best theory."""
    models = pressure_models(run, temperature)
    best = models[0]
    if run.periodic:
        measured = (theory.virial_pressure(run.dim, run.n, temperature, run.length ** run.dim,
                                           run.virial, run.duration)
                    if math.isfinite(temperature) and math.isfinite(run.virial) else math.nan)
        blocks_p = virial_block_pressures(run, temperature, blocks)
        err = mean_and_error(blocks_p)[1] if blocks_p is not None else math.nan
        how = "virial" + ("" if blocks_p is not None else " (error bar needs --record all)")
    elif not len(run.bounces):
        measured, err = math.nan, math.nan
        how = "no wall bounce recorded" + (" (--record none)" if run.record == "none" else "")
    else:
        per_block = wall_block_pressures(run, blocks)
        walls_mean = np.mean([per_block[w] for w in run.walls], axis=0)
        measured, err = mean_and_error(walls_mean)
        how = "mean over the walls"
    return {"measured": measured, "error": err, "how": how, "best": best, "models": models}


def pressure_frame(run: Run, temperature: float, summary: dict) -> pd.DataFrame:
    """One row per theoretical model: expected pressure, deviation in sigmas and relative."""
    rows = []
    for exp in summary["models"]:
        rows.append({"MODEL": exp.model, "P_MEASURED_PA": _num(summary["measured"]),
                     "P_ERR_PA": _num(summary["error"]), "P_THEORY_PA": exp.value,
                     "DEV_SIGMA": _dev(summary["measured"], summary["error"], exp.value),
                     "REL_DEV": _rel(summary["measured"], exp.value), "SYST_REL": exp.syst,
                     "MEASURED": summary["how"], "NOTE": exp.note})
    return pd.DataFrame(rows)


def collision_frame(run: Run, temperature: float, blocks: int = BLOCKS) -> pd.DataFrame:
    """Collisions per particle per second against Enskog (or the exact 1D result)."""
    if run.collisions is None:
        return pd.DataFrame([{"MODEL": "none", "NOTE": "no RESULTAT row for this simulation"}])
    rate = 2.0 * run.collisions / (run.n * run.duration)
    err = math.nan
    if run.chocs is not None and len(run.chocs) == run.collisions and run.restitution >= 1.0:
        per_block = block_sums(run.chocs.CH_T.to_numpy(dtype=float), 1.0, run.duration, blocks)
        err = mean_and_error(2.0 * per_block / (run.n * run.duration / blocks))[1]
    counts, radii, masses = _counts_radii_masses(run)
    d, L = run.dim, run.length
    rows = []
    if not run.one_species:
        exp = Expectation(NA, "Enskog", "one species only (mixture: cross-sections and masses differ)")
        rows.append(exp)
    elif not math.isfinite(temperature):
        rows.append(Expectation(NA, "Enskog", "temperature unknown"))
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
    if run.restitution < 1.0 and run.one_species and math.isfinite(temperature) and d > 1:
        # a cooling gas: omega falls as sqrt(T); Haff integrates it over the run
        n = run.n / (L if run.periodic else L - 2 * radii[0]) ** d

        def haff_rate():
            omega0 = theory.enskog_collision_frequency(d, n, 2 * radii[0], temperature, masses[0])
            return theory.haff_collisions_per_particle(d, run.duration, run.restitution, omega0) / run.duration
        rows = [_try("Enskog omega0, cooled by Haff's law (mean over the run)", haff_rate,
                     "homogeneous cooling only: clusters raise the rate")]
    frame = []
    for exp in rows:
        frame.append({"MODEL": exp.model, "COLLISIONS": run.collisions, "RATE_PER_PARTICLE_HZ": rate,
                      "RATE_ERR_HZ": _num(err) if math.isfinite(err) else
                      "n/a (needs --record all)" if run.chocs is None and run.restitution >= 1.0 else NA,
                      "THEORY_HZ": exp.value, "DEV_SIGMA": _dev(rate, err, exp.value),
                      "REL_DEV": _rel(rate, exp.value), "NOTE": exp.note})
    return pd.DataFrame(frame)


def wall_speed_frame(run: Run, temperature: float, blocks: int = BLOCKS) -> pd.DataFrame:
    """Q35's mean speed of wall hits, per species (and all), against the flux-weighted mean."""
    b = run.bounces
    t = b.RE_T.to_numpy(dtype=float)
    v = b.RE_VIT.to_numpy(dtype=float)
    pa = b.PA_NUM.to_numpy(dtype=np.int64)
    rows = []
    expected_all = 0.0
    weights = _species_partial_weights(run) if len(run.species) else []
    for sp, w in zip(run.species.itertuples(), weights):
        sel = pa == sp.PA_NUM
        mean = float(v[sel].mean()) if sel.any() else math.nan
        _, err = mean_and_error(block_means(t[sel], v[sel], run.duration, blocks))
        exp = (_try("flux-weighted mean <v^2>/<|v|>",
                    lambda: theory.wall_hit_mean_speed(run.dim, temperature, sp.MASS_KG))
               if math.isfinite(temperature) else Expectation(NA, "flux-weighted", "temperature unknown"))
        if run.dim == 1 and run.one_species and exp.known and math.isfinite(err):
            # the speeds drawn at the start are kept for ever: add their sampling spread
            spread = float(theory.rods_hit_speed_sampling_error(run.n, temperature, sp.MASS_KG))
            err = math.hypot(err, spread)
            exp.note = "1D equal masses: ERR includes the spread of the N speeds drawn at the start"
        if exp.known:
            expected_all += w * exp.value
        else:
            expected_all = math.nan
        rows.append({"SPECIES": sp.NAME, "BOUNCES": int(sel.sum()), "VITESSE_MOYENNE": _num(mean),
                     "ERR": _num(err), "THEORY": exp.value, "DEV_SIGMA": _dev(mean, err, exp.value),
                     "REL_DEV": _rel(mean, exp.value),
                     "GAS_MEAN_SPEED": (float(theory.mean_speed(run.dim, temperature, sp.MASS_KG))
                                        if math.isfinite(temperature) else NA), "NOTE": exp.note})
    if len(run.species) > 1:
        mean = float(v.mean()) if v.size else math.nan
        _, err = mean_and_error(block_means(t, v, run.duration, blocks))
        exp_all = expected_all if math.isfinite(expected_all) else NA
        rows.append({"SPECIES": "all (Q35)", "BOUNCES": int(v.size), "VITESSE_MOYENNE": _num(mean),
                     "ERR": _num(err), "THEORY": exp_all, "DEV_SIGMA": _dev(mean, err, exp_all),
                     "REL_DEV": _rel(mean, exp_all), "GAS_MEAN_SPEED": NA,
                     "NOTE": "theory weighted by each species' share of the hits, N_s/((L-2R_s) sqrt(m_s))"})
    frame = pd.DataFrame(rows)
    if run.restitution < 1.0 and len(frame):
        frame["NOTE"] = "cooling gas: theory at the initial temperature"
    elif run.gravity > 0.0 and len(frame):
        frame["NOTE"] = "under gravity: theory at the final kinetic temperature, if equilibrated"
    return frame


def gravity_frame(run: Run, temperature: float, blocks: int = BLOCKS) -> pd.DataFrame:
    """Floor minus ceiling force against N m g (N), and the ceiling/floor hit ratio against Boltzmann."""
    d = run.dim
    pressures = wall_block_pressures(run, blocks)
    force = (pressures[-d] - pressures[d]) * run.wall_measure
    measured, err = mean_and_error(force)
    counts, radii, masses = _counts_radii_masses(run)
    weight = float(np.sum(counts * masses) * run.gravity)
    rows = [{"QUANTITY": "floor - ceiling force (N)", "MEASURED": measured, "ERR": _num(err),
             "THEORY": weight, "DEV_SIGMA": _dev(measured, err, weight), "REL_DEV": _rel(measured, weight),
             "NOTE": "sum N m g: exact momentum balance, up to the change of total vertical "
                     "momentum over the run divided by its duration"}]
    wall = run.bounces.RE_DIR.to_numpy(dtype=np.int64)
    floor_hits, ceiling_hits = int(np.sum(wall == -d)), int(np.sum(wall == d))
    ratio = ceiling_hits / floor_hits if floor_hits else math.nan
    ratio_err = (ratio * math.sqrt(1.0 / max(ceiling_hits, 1) + 1.0 / floor_hits)
                 if floor_hits and ceiling_hits else math.nan)
    if run.one_species and math.isfinite(temperature):
        m, r = masses[0], radii[0]
        exp = _try("Boltzmann exp(-m g (L-2R)/kT)",
                   lambda: math.exp(-m * run.gravity * (run.length - 2 * r) / (K_B * temperature)))
    else:
        exp = Expectation(NA, "Boltzmann", "one species only")
    rows.append({"QUANTITY": "ceiling/floor hit ratio", "MEASURED": _num(ratio), "ERR": _num(ratio_err),
                 "THEORY": exp.value, "DEV_SIGMA": _dev(ratio, ratio_err, exp.value),
                 "REL_DEV": _rel(ratio, exp.value),
                 "NOTE": "non-interacting gas in equilibrium at the final kinetic T; error: Poisson counts"})
    return pd.DataFrame(rows)


def cooling_frame(run: Run) -> pd.DataFrame:
    """Final temperature of a cooling granular gas against Haff's law (time and per-collision forms)."""
    d = run.dim
    rows = []
    t0 = (float(theory.kinetic_temperature(d, run.ke_start, run.n, periodic=run.periodic and run.n > 1))
          if math.isfinite(run.ke_start) and run.ke_start > 0 else math.nan)
    t_end = (float(theory.kinetic_temperature(d, run.ke_end, run.n, periodic=run.periodic and run.n > 1))
             if math.isfinite(run.ke_end) and run.ke_end > 0 else math.nan)
    counts, radii, masses = _counts_radii_masses(run)
    if run.one_species and math.isfinite(t0):
        sigma = 2 * radii[0]
        n = run.n / (run.length if run.periodic else run.length - sigma) ** d

        def haff_time():
            omega0 = theory.enskog_collision_frequency(d, n, sigma, t0, masses[0])
            return theory.haff_temperature(d, run.duration, t0, run.restitution, omega0)
        rows.append(_try("Haff T0/(1 + t/t0)^2, Enskog omega0", haff_time,
                         "homogeneous cooling only (before clusters form); Enskog rate at the initial density"))
    else:
        rows.append(Expectation(NA, "Haff T0/(1 + t/t0)^2", "one species only"))
    if run.collisions is not None and math.isfinite(t0):
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
    return pd.DataFrame([{"MODEL": e.model, "T_START_K": _num(t0), "T_END_K": _num(t_end),
                          "T_THEORY_K": e.value, "REL_DEV": _rel(t_end, e.value), "NOTE": e.note}
                         for e in rows])


# --- gaz analyse ------------------------------------------------------------------
def report(db: str, sim: int | None = None, plot_dir: str | None = None) -> dict:
    """What ``gaz analyse`` prints: a dict of name -> DataFrame (or dict of scalars).

    Always: Q34, Q35, Q36 with the pressure per wall (with its block error,
    the expected value and the deviation in sigmas) and the overview
    'pressure against the ideal gas' (one row per simulation). With ``sim``:
    also the scene, the pressure against every model that applies, the
    collision rate against Enskog, the mean wall-hit speed against the
    flux-weighted theory, under gravity the force balance, for a cooling gas
    Haff's law. ``plot_dir``: PNG figures for each simulation analysed,
    listed in a last frame 'figures'.
    """
    from gaz_cli import store as st

    store = st.Store(db, create=False)
    numbers = store.simulation_numbers()
    if not numbers:
        raise StoreError(f"{db!r} holds no simulation yet; run 'gaz simulate --db {db}' first")
    if sim is not None and sim not in numbers:
        raise StoreError(f"simulation {sim} is not in {db!r}; it holds SI_NUM {_ranges(numbers)}")
    if plot_dir is not None:
        _make_dir(plot_dir)
    chosen = [sim] if sim is not None else numbers
    q34 = store.query("q34_simulations_per_dimension")
    q35 = store.query("q35_bounces_per_simulation")
    q35 = q35[q35.SI_NUM.isin(chosen)].reset_index(drop=True)
    walls, overview, figures = [], [], []
    detail = {}
    for number in chosen:
        run = load_run(store, number)
        temperature = run.kinetic_temperature
        per_wall = store.query("pressure_per_wall", si_num=number)
        per_wall.insert(0, "SI_NUM", number)
        walls.append(per_wall_frame(run, per_wall, temperature))
        summary = pressure_summary(run, temperature)
        overview.append(_overview_row(run, temperature, summary, per_wall))
        if sim is not None:
            detail = {
                "simulation": simulation_frame(run, temperature),
                "pressure against theory": pressure_frame(run, temperature, summary),
                "collision rate against Enskog": collision_frame(run, temperature),
            }
            if not run.periodic:
                detail["mean wall-hit speed against theory"] = wall_speed_frame(run, temperature)
            if run.gravity > 0.0 and not run.periodic:
                detail["force balance under gravity"] = gravity_frame(run, temperature)
            if run.restitution < 1.0:
                detail["cooling against Haff's law"] = cooling_frame(run)
        if plot_dir is not None:
            figures.extend(make_plots(run, temperature, summary, plot_dir))
    frames = {
        "Q34 simulations per dimension": q34,
        "Q35 wall bounces and mean speed of wall hits": q35,
        "Q36 momentum and pressure per wall": pd.concat(walls, ignore_index=True),
        "pressure against the ideal gas": pd.DataFrame(overview),
    }
    frames.update(detail)
    if plot_dir is not None:
        frames["figures"] = pd.DataFrame(figures, columns=["SI_NUM", "FIGURE", "FILE"])
    return frames


def _overview_row(run: Run, temperature: float, summary: dict, per_wall: pd.DataFrame) -> dict:
    """One simulation in one row: measured pressure, ideal gas, best theory, deviation in sigmas."""
    row = {"SI_NUM": run.si_num, "SI_DIM": run.dim, "SI_N": run.n, "SI_L": run.length, "SI_DUR": run.duration,
           "BOUNDARY": run.boundary, "T_KIN_K": _num(temperature)}
    if run.periodic:
        row["P_MEASURED_PA"] = _num(summary["measured"])
        ideal = _try("ideal", lambda: theory.ideal_gas_pressure(run.n, temperature, run.length ** run.dim))
    else:
        # the SQL pressure, summed over the walls that were hit, over the 2D walls
        row["P_MEASURED_PA"] = float(per_wall.PRESSION.sum() / (2 * run.dim)) if len(per_wall) else NA
        counts, radii, _ = _counts_radii_masses(run)
        ideal = (_try("ideal", lambda: theory.ideal_wall_pressure(run.dim, run.length, temperature, counts, radii))
                 if len(run.species) and math.isfinite(temperature) else Expectation(NA, "ideal"))
    row["P_IDEAL_PA"] = ideal.value
    measured = row["P_MEASURED_PA"]
    row["RATIO"] = (measured / ideal.value if ideal.known and not isinstance(measured, str) else NA)
    row["P_ERR_PA"] = _num(summary["error"])
    best = summary["best"]
    row["P_THEORY_PA"] = best.value
    row["THEORY"] = best.model
    row["DEV_SIGMA"] = (_dev(measured, summary["error"], best.value) if not isinstance(measured, str) else NA)
    return row


def _make_dir(path: str) -> None:
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise StoreError(f"cannot create --plot folder {path!r}: {err.strerror}") from None


# --- figures -----------------------------------------------------------------------
def make_plots(run: Run, temperature: float, summary: dict, plot_dir: str, blocks: int = BLOCKS) -> list:
    """Write the figures of one simulation into ``plot_dir``; returns rows (SI_NUM, FIGURE, FILE)."""
    from gaz_cli import plots

    out = []
    base = Path(plot_dir)

    def path(name):
        return str(base / f"sim{run.si_num}_{name}.png")

    b = run.bounces
    species = ([(r.NAME, r.MASS_KG, w, r.COUNT / run.n)
                for r, w in zip(run.species.itertuples(), _species_partial_weights(run))]
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
    series = _pressure_series(run, temperature, summary, blocks) if run.restitution >= 1.0 else None
    if series is not None:
        p = path("pressure_time")
        plots.pressure_against_time(p, **series, title=label)
        out.append((run.si_num, "running pressure against simulated time", p))
    if run.gravity > 0.0 and len(b):
        prof = gravity_profile(run, temperature)
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
        if run.gravity > 0.0 and abs(w) == run.dim:
            per_species = np.array([theory.ideal_gravity_wall_pressures(
                run.dim, run.length, temperature, c, r, m, run.gravity)[0 if w < 0 else 1]
                for c, r, m in zip(counts, radii, masses)])
        else:
            per_species = expected[w].value * share
        out.append(float(np.sum(per_species * scale)))
    return out


def _pressure_series(run: Run, temperature: float, summary: dict, blocks: int):
    """Running mean of the pressure against time, its error band, block values and theory, or None."""
    best = summary["best"]
    theory_value = best.value if best.known else None
    if run.periodic:
        if run.chocs is None or not run.one_species or not math.isfinite(temperature):
            return None
        sigma = 2.0 * float(run.species.RADIUS_M.iloc[0])
        t = run.chocs.CH_T.to_numpy(dtype=float)
        w = run.chocs.CH_IMP.to_numpy(dtype=float) * sigma
        volume = run.length ** run.dim

        def to_pressure(cum_w, time):
            return (run.n * K_B * temperature + cum_w / (run.dim * time)) / volume
        block_values = virial_block_pressures(run, temperature, blocks)
        what = "virial pressure"
    else:
        t = run.bounces.RE_T.to_numpy(dtype=float)
        w = _bounce_momentum(run) / (2 * run.dim * run.wall_measure)  # mean over the walls

        def to_pressure(cum_w, time):
            return cum_w / time
        per_block = wall_block_pressures(run, blocks)
        block_values = np.mean([per_block[k] for k in run.walls], axis=0)
        what = "wall pressure (mean over the walls)"
    if t.size < 2:
        return None
    grid = np.linspace(run.duration / 200, run.duration, 200)
    cum = np.concatenate(([0.0], np.cumsum(w)))
    running = to_pressure(cum[np.searchsorted(t, grid, side="right")], grid)
    _, err = mean_and_error(block_values)
    band = err * np.sqrt(run.duration / grid) if math.isfinite(err) else None
    centres = (np.arange(blocks) + 0.5) * run.duration / blocks
    others = [(e.model, e.value) for e in summary["models"][1:] if e.known]
    return {"times": grid, "running": running, "band": band, "block_times": centres,
            "block_values": block_values, "theory": theory_value, "theory_label": best.model,
            "others": others, "what": what, "unit": {1: "N", 2: "N/m", 3: "Pa"}[run.dim]}


def gravity_profile(run: Run, temperature: float, bins: int = 60):
    """Density of centres against height, rebuilt from the floor hits, with the barometric law.

    The store keeps no positions; but a particle leaving the floor at the
    vertical speed u flies freely (no collision) on z(t) = R + u t - g t^2/2,
    crossing each height z < R + u^2/(2g) twice at the speed
    w = sqrt(u^2 - 2 g (z - R)), so the time-averaged number of centres per
    unit height is n(z) = (2/tau) sum_floor hits 1/w(z) (capped at the
    ceiling). Exact for non-interacting particles; with collisions it is the
    profile the floor's hit statistics imply. Returns arrays for
    :func:`gaz_cli.plots.density_profile` or None.
    """
    d = run.dim
    if not len(run.species) or not math.isfinite(temperature):
        return None
    b = run.bounces
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
    m = float(run.species.MASS_KG.iloc[0])
    e = run.restitution
    t = run.chocs.CH_T.to_numpy(dtype=float)
    j = run.chocs.CH_IMP.to_numpy(dtype=float)
    inelastic = ~tc_elastic(t, run.chocs.CH_I.to_numpy(dtype=np.int64), run.chocs.CH_J.to_numpy(dtype=np.int64),
                            run.tc)
    loss = np.where(inelastic, (1 - e) / (1 + e) * j * j / m, 0.0)
    periodic = run.periodic and run.n > 1
    t0 = float(theory.kinetic_temperature(d, run.ke_start, run.n, periodic=periodic))
    grid = np.linspace(0.0, run.duration, points)
    cum = np.concatenate(([0.0], np.cumsum(loss)))
    ke = run.ke_start - cum[np.searchsorted(t, grid, side="right")]
    temps = np.array([float(theory.kinetic_temperature(d, max(k, 0.0), run.n, periodic=periodic)) for k in ke])
    sigma = 2 * float(run.species.RADIUS_M.iloc[0])
    n = run.n / (run.length if run.periodic else run.length - sigma) ** d
    try:
        omega0 = theory.enskog_collision_frequency(d, n, sigma, t0, m)
        haff = theory.haff_temperature(d, grid, t0, e, omega0)
    except SceneError:
        haff = None
    t_end = float(theory.kinetic_temperature(d, run.ke_end, run.n, periodic=periodic))
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
