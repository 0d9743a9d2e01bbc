"""Theory for one stored run: which models apply to its scene, their values and caveats.

Each :class:`Expectation` names its model, its known systematic error (SYST_REL) and whether
it fits the scene (``applies``); where it does not, no deviation in sigmas is printed and the
reason is its note."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gaz_cli import theory
from gaz_cli.analysis import errorbars
from gaz_cli.analysis.estimators import EXACT_ENGINES, NA, species_arrays
from gaz_cli.analysis.stored import StoredRun, rebuilt_state
from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError


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
    """Standard error of the value from that of its input temperature (under gravity) or density
    (the box's middle), same unit."""
    error_dof: float = math.inf
    """Effective degrees of freedom of ``error`` (inf: exact or closed form)."""

    @property
    def known(self) -> bool:
        return math.isfinite(self.value)


def evaluate(model: str, func, note: str = "") -> Expectation:
    """Evaluate ``func()``; a theory range error becomes NaN with the reason as note."""
    try:
        return Expectation(float(func()), model, note)
    except SceneError as err:
        return Expectation(NA, model, str(err))




def energy_temperature(run: StoredRun) -> float:
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
    rebuilt = rebuilt_state(run)
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


def gravity_walls(run: StoredRun, temperature: float):
    """(floor, ceiling, side, model, note) of the best gravity model for the run."""
    counts, radii, masses = species_arrays(run)
    d, L = run.dim, run.length
    if run.one_species and radii[0] > 0:
        floor, ceiling, side = theory.hard_sphere_gravity_wall_pressures(
            d, L, temperature, counts[0], radii[0], masses[0], run.gravity)
        return floor, ceiling, side, f"hard spheres under gravity, local {theory.BEST_MODEL[d]} EOS", \
            "barometric profile with the bulk EOS at the local density; first order in the wall corrections"
    floor, ceiling = theory.ideal_gravity_wall_pressures(d, L, temperature, counts, radii, masses, run.gravity)
    side = theory.ideal_wall_pressure(d, L, temperature, counts, radii) if d > 1 else 0.0
    return floor, ceiling, side, "ideal gas under gravity", "non-interacting (dilute) limit; mixture: no excess"


def pressure_models(run: StoredRun, temperature: float, stat_rel: float = 0.0,
                    measured: float = NA) -> list[Expectation]:
    """Every theoretical pressure that applies to the run; the first one is the best.

    Walls: what the SQL measures (per full wall area). 1D: Tonks, exact.
    2D/3D: :func:`theory.hard_sphere_wall_pressure` (one species), then the
    non-interacting gas; when its systematic error bound (wall adsorption)
    exceeds the statistical error ``stat_rel`` (relative), it does not fit the
    scene and no deviation is printed. Under gravity the mean over the walls
    of the hard-sphere barometric model. Periodic: the bulk equation of state
    against the virial; 1D: the exact ring of N rods; at a packing where the solid
    is stable, the phase is read from ``measured`` (the pressure): nearer the FCC
    solid's EOS than the fluid's, the solid's is the model. Cooling gas: no
    equilibrium value. Every model carries where it holds: outside, its
    ``applies`` is False and its note says why (the ideal gas too, beyond the
    dilute limit: it is shown for scale, never as the verdict).
    """
    counts, radii, masses = species_arrays(run)
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
        if d == 1:
            out.append(evaluate("1D ring of N rods, exact: kT/L + (N-1) kT/(L - N sigma)",
                                lambda: theory.ring_pressure(L, temperature, counts, radii),
                                "finite N at fixed total momentum (kT = 2K/(N-1)); infinite-N Tonks is "
                                "eta/N above it"))
        elif run.one_species:
            out.extend(_bulk_phase_models(run, temperature, n, 2 * radii[0], stat_rel, measured))
        else:
            densities = counts / L ** d
            if d == 3:
                out.append(evaluate(f"mixture, bulk {theory.BEST_MODEL[3]} mapped onto the mixture",
                                    lambda: theory.mixture_pressure_mapped(d, densities, 2 * radii, temperature),
                                    "one-component KLM through contact values 1/(1-eta) + alpha z_ij + beta z_ij^2 "
                                    "(Santos-Yuste-Lopez de Haro construction; from Carnahan-Starling it gives BMCSL)"))
            out.append(evaluate("mixture, bulk BMCSL EOS" if d == 3 else "mixture, bulk EOS",
                                lambda: theory.mixture_pressure(d, densities, 2 * radii, temperature),
                                "Boublik-Mansoori-Carnahan-Starling-Leland: about 0.2-0.3 % low at packing 0.3-0.4 "
                                "(as Carnahan-Starling); kept beside the mapped KLM above"
                                if d == 3 else "no mixture equation of state in 1D rings or 2D here"))
        out.append(_ideal(run, evaluate("ideal gas N kT/V",
                                        lambda: theory.ideal_gas_pressure(run.n, temperature, L ** d),
                                        "no interactions: excess pressure ignored"), stat_rel))
        return out
    if run.gravity > 0.0:
        def mean_gravity(t=temperature):
            floor, ceiling, side, _, _ = gravity_walls(run, t)
            return (floor + ceiling + (2 * d - 2) * side) / (2 * d)
        try:
            _, _, _, name, note = gravity_walls(run, temperature)
        except SceneError as err:
            name, note = "under gravity", str(err)
        exp = evaluate(f"{name} (mean of the walls)", mean_gravity, note)
        if exp.known and run.temperature_error > 0:
            exp.error = abs(mean_gravity(temperature + run.temperature_error) - exp.value)
            exp.note += (f"; T = {temperature:.5g} +- {run.temperature_error:.2g} K from <v_perp^2> of the "
                         "settled part's wall hits (its error is in DEV_SIGMA)")
        elif exp.known and run.temperature_source == "energy":
            exp.note += (f"; T = {temperature:.5g} K from the conserved energy of the initial state, "
                         "kinetic plus potential")
        if not set_aside_unsettled(exp, run) and run.ordered_rods:
            exp.applies, exp.note = False, run.ordered_rods
        elif exp.known and exp.applies and not run.one_species:
            _set_aside_excess(exp, run, stat_rel)
        elif exp.known and exp.applies and d > 1 and radii[0] > 0:
            # the local-EOS model is first order in the walls, as the box's without gravity: the same
            # wall adsorption bounds its error (SYST_REL)
            _first_order_syst(exp, run, stat_rel)
        out.append(exp)
        return out
    if d == 1:
        out.append(evaluate("Tonks, exact (1D rods)", lambda: theory.tonks_pressure(L, temperature, counts, radii),
                        "N kT/(L - N 2R), kT = (1/N) sum m v^2 from the kinetic energy"))
    elif run.one_species:
        middle = middle_pressure(run, temperature, stat_rel)
        if middle is not None:
            out.append(middle)
        model = theory.BEST_MODEL[d]
        exp = evaluate(f"hard spheres at walls, {model} at N/(L-2R)^D",
                   lambda: theory.hard_sphere_wall_pressure(d, L, temperature, counts[0], radii[0]),
                   "first order in eta and 2R/L; SYST_REL: next order (wall adsorption), a bound")
        if exp.known:
            _first_order_syst(exp, run, stat_rel)
        out.append(exp)
    else:
        exp = evaluate("mixture at walls, BMCSL at N_s/(L-2R_s)^D" if d == 3 else "mixture at walls",
                       lambda: theory.mixture_wall_pressure(d, L, temperature, counts, radii),
                       "first order in eta and 2R/L, as for one species; SYST_REL: the wall adsorption of "
                       "one species of the largest radius at the mixture's number, a bound")
        if exp.known:
            try:
                exp.syst = max(abs(float(theory.wall_adsorption_shift(d, L, float(np.sum(counts)), r)))
                               for r in radii)
            except SceneError:
                exp.syst = NA
            _beyond_syst(exp, stat_rel)
        out.append(exp)
    ideal = evaluate("ideal gas at walls, N kT/((L-2R) L^(D-1))",
                 lambda: theory.ideal_wall_pressure(d, L, temperature, counts, radii),
                 "dilute limit (eta -> 0), exact for non-interacting particles")
    out.append(_ideal(run, ideal, stat_rel))
    return out


def _first_order_syst(exp: Expectation, run: StoredRun, stat_rel: float) -> None:
    """A first-order wall model of one species: its SYST_REL the wall adsorption's shift
    (:func:`gaz_cli.theory.wall_adsorption_shift`, NaN out of its range), set aside beyond
    the statistical error ``stat_rel`` (:func:`_beyond_syst`)."""
    counts, radii, _ = species_arrays(run)
    try:
        exp.syst = abs(float(theory.wall_adsorption_shift(run.dim, run.length, counts[0], radii[0])))
    except SceneError:
        exp.syst = NA
    _beyond_syst(exp, stat_rel)


MIDDLE_BLOCKS = slice(8, 24)
"""The profile's bins (of 32) in the middle half of the box: [L/4, 3L/4)."""


def middle_density(run: StoredRun) -> errorbars.Estimate:
    """Number density of centres in the box's middle, the cube [L/4, 3L/4]^D (1/m^D), and its error.

    From the density profile (PROFIL, axis 1: the centres in the middle half along the other
    axes, counted in the middle half's bins), one value per block of samples; the error is
    the time average's (:func:`gaz_cli.analysis.errorbars.time_average`: the autocorrelation
    of the block series, Student's t degrees of freedom). NaN without a profile."""
    if run.profile is None:
        return errorbars.NAN_ESTIMATE
    axis = run.profile[run.profile.PR_AXIS == 1]
    blocks = axis.groupby("PR_BLOCK")
    counts = blocks.apply(lambda b: b.PR_COUNT[b.PR_BIN.between(MIDDLE_BLOCKS.start, MIDDLE_BLOCKS.stop - 1)].sum())
    samples = blocks.PR_SAMPLES.first()
    series = (counts / samples).to_numpy(dtype=float) / (run.length / 2.0) ** run.dim
    return errorbars.time_average(series, duration=run.duration)


def middle_pressure(run: StoredRun, temperature: float, stat_rel: float) -> Expectation | None:
    """The wall pressure mechanical equilibrium gives: the bulk EOS at the density measured in the
    box's middle (:func:`middle_density`, its error carried as the theory's), on the wall
    with its edges (:func:`gaz_cli.theory.bulk_wall_pressure`); None without a profile.

    Holds for one species at walls without forces (the profile is recorded only there), in 2D
    (3D is shown without a verdict: its edges' term is known to first order only, measured about
    3 times short at packing 0.28), a middle 4.5 diameters or more from every wall (the layering of a fluid at a wall has died
    out there below freezing), a fluid (2D: below 0.70; 3D: below freezing, 0.494). Its
    systematic error (SYST_REL) is the edges' term, taken as uncertain by its whole size."""
    n_mid = middle_density(run)
    if not math.isfinite(n_mid.mean):
        return None
    d, L = run.dim, run.length
    radius = float(run.species.RADIUS_M.iloc[0])
    model = theory.BEST_MODEL[d]
    exp = evaluate(f"hard spheres at walls, {model} at the measured middle density (mechanical equilibrium)",
                   lambda: theory.bulk_wall_pressure(d, L, temperature, n_mid.mean, radius),
                   "the wall's pressure is the bulk's at the density of the box's middle (PROFIL), through "
                   "its edges; the middle density's error is in DEV_SIGMA; SYST_REL: the edges' term")
    if not exp.known:
        return exp
    eta = float(theory.packing_fraction(d, n_mid.mean, 2 * radius))
    freezing = theory.FREEZING_PACKING[d] or 0.70
    if d == 3:
        exp.applies = False
        exp.note = ("no verdict in 3D yet: the force through the box's 12 edges needs the side walls' surface "
                    "tension, known here to first order in density only (SYST_REL), which falls short by a "
                    "factor of about 3 at packing 0.28 (measured REL_DEV +4 % against SYST_REL 1.5 %); "
                    "compare REL_DEV with SYST_REL")
    elif L / 4.0 - radius < 4.5 * 2 * radius:
        exp.applies = False
        exp.note = "the box has no bulk: its middle half is within 4.5 diameters of a wall"
    elif eta >= freezing:
        exp.applies = False
        exp.note = f"middle packing {eta:.3g} at or above freezing ({freezing:g}): not a fluid"
    if exp.applies and not n_mid.dof >= errorbars.MIN_DOF:
        exp.applies = False
        exp.note = (f"DEV_SIGMA withheld: the middle density's error has about {n_mid.dof:.2g} effective degrees "
                    f"of freedom (fewer than {errorbars.MIN_DOF:g}: it relaxes slowly, by diffusion across the "
                    "box); run longer")
    try:
        bare = float(theory.bulk_wall_pressure(d, L, temperature, n_mid.mean, radius, edges=False))
        exp.syst = abs(exp.value - bare) / exp.value
        shifted = theory.bulk_wall_pressure(d, L, temperature, n_mid.mean + n_mid.error, radius)
        exp.error, exp.error_dof = abs(float(shifted) - exp.value), n_mid.dof
    except SceneError as err:        # the density's error bar reaches beyond the EOS's range
        exp.applies, exp.note = False, str(err)
    if not math.isfinite(exp.error):
        exp.applies, exp.note = False, "no error bar for the middle density"
    if exp.applies:
        _beyond_syst(exp, math.hypot(stat_rel, exp.error / exp.value))
    return exp


def _beyond_syst(exp: Expectation, stat_rel: float) -> None:
    """``exp`` set aside when its systematic error bound (SYST_REL) exceeds the statistical error
    ``stat_rel`` (relative): a wall model at a density where wall adsorption matters."""
    if stat_rel > 0 and not exp.syst <= stat_rel:
        exp.applies = False
        dense = exp.syst > 10 * stat_rel
        exp.note = (("no theory for this scene: " if dense else "") +
                    f"the wall model's systematic error (up to {exp.syst:.2g} relative, wall "
                    f"adsorption: SYST_REL) exceeds the statistical error ({stat_rel:.2g}); "
                    "compare REL_DEV with SYST_REL" +
                    ("; a dense fluid at walls needs its contact density, which the database "
                     "does not hold" if dense else ""))


def _ideal(run: StoredRun, exp: Expectation, stat_rel: float) -> Expectation:
    """The ideal gas holds in the dilute limit only: its systematic error is the excess pressure
    Z - 1 at the run's packing fraction; beyond the statistical error it is shown for scale,
    without a deviation."""
    try:
        exp.syst = float(theory.compressibility_factor(run.dim, run.packing_fraction)) - 1.0
    except SceneError:
        exp.syst = NA
    if exp.known and stat_rel > 0 and not exp.syst <= stat_rel:
        exp.applies = False
        exp.note = (f"shown for scale, not this scene's model: the excess pressure (Z - 1 = {exp.syst:.2g} "
                    f"at packing {run.packing_fraction:.3g}: SYST_REL) is beyond the statistical error "
                    f"({stat_rel:.2g})")
    return exp


def _bulk_phase_models(run: StoredRun, temperature: float, n: float, sigma: float, stat_rel: float,
                       measured: float) -> list[Expectation]:
    """One species in a periodic box: the fluid's EOS, and above freezing the phase the run is in.

    Above the freezing packing (3D 0.494) the measured Z decides: nearer the FCC solid's EOS
    (Speedy) than the fluid's, the run is a solid (a lattice start that did not melt, or a
    fluid that froze), compared with the solid's EOS (SYST_REL 1 %: finite N, vacancies); the
    fluid's EOS is then shown without a deviation. 2D from 0.700 (liquid-hexatic coexistence,
    hexatic, solid): no EOS here, no verdict.
    """
    d = run.dim
    model = theory.BEST_MODEL[d]
    fluid = evaluate(f"hard spheres, bulk {model} EOS",
                     lambda: theory.hard_sphere_pressure(d, n, sigma, temperature))
    eta = run.packing_fraction
    freezing = theory.FREEZING_PACKING[d]
    if freezing is None or eta < freezing:
        return [fluid]
    kt_n = n * K_B * temperature
    z_measured = measured / kt_n if math.isfinite(measured) and kt_n > 0 else NA
    if d == 2:
        fluid.applies = False
        fluid.note = (f"packing {eta:.3g} at or above the liquid-hexatic coexistence (0.700, Bernard & Krauth "
                      "2011): hexatic or solid phases with large finite-size effects; no EOS for them here")
        return [fluid]
    try:
        z_solid = float(theory.z_fcc_speedy(eta))
    except SceneError:
        z_solid = NA
    solid = Expectation(z_solid * kt_n if math.isfinite(z_solid) else NA, "hard-sphere FCC solid, Speedy EOS",
                        "solid: the measured Z is nearer the FCC solid's EOS than the fluid's at a packing above "
                        "freezing (0.494); SYST_REL: finite N, vacancies, other stackings", syst=0.01)
    is_solid = (math.isfinite(z_measured) and math.isfinite(z_solid) and
                (not fluid.known or abs(z_measured - z_solid) < abs(z_measured - fluid.value / kt_n)))
    if is_solid:
        if stat_rel > 0 and not solid.syst <= stat_rel:
            solid.applies = False
            solid.note += f"; above the statistical error ({stat_rel:.2g}): compare REL_DEV with SYST_REL"
        fluid.applies = False
        fluid.note = "not the run's phase: the run is a solid (the row above)"
        return [solid, fluid]
    fluid.note = (f"packing {eta:.3g} above freezing (0.494): a metastable or coexisting fluid; its pressure "
                  "matched the fluid's EOS better than the solid's")
    if solid.known:
        solid.applies = False
        solid.note = "not the run's phase: its pressure is nearer the fluid's EOS"
        return [fluid, solid]
    return [fluid]


def _set_aside_excess(exp: Expectation, run: StoredRun, stat_rel: float) -> None:
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


def wall_pressure_theory(run: StoredRun, temperature: float, best: Expectation | None = None) -> dict[int, Expectation]:
    """Wall code -> expected pressure on that wall (best model)."""
    best = best or pressure_models(run, temperature)[0]
    if run.gravity > 0.0 and best.known and not run.periodic:
        d = run.dim
        values = gravity_walls(run, temperature)[:3]
        shifted = (gravity_walls(run, temperature + run.temperature_error)[:3] if run.temperature_error > 0
                   else values)

        def pick(v, w):
            return float(v[0] if w == -d else v[1] if w == d else v[2])
        return {w: Expectation(pick(values, w), best.model, best.note, applies=best.applies,
                               error=abs(pick(shifted, w) - pick(values, w)))
                for w in run.walls}
    return {w: best for w in run.walls}


def hit_shares(run: StoredRun, temperature: float = NA) -> np.ndarray:
    """Expected share of the wall hits of each species, normalised.

    A wall's hits per second are its pressure over sqrt(2 pi m kT), the mean momentum a hit
    gives (physics.md section 6): a species' share is the sum over the walls of its partial
    pressure over sqrt(m_s), N_s / ((L - 2R_s) sqrt(m_s)) without gravity. Under gravity (at
    ``temperature``, K) the floor and ceiling take each species' own barometric pressures, the
    2D - 2 side walls its N_s kT/((L - 2R_s) L^(D-1)): heavy species sit low and hit the
    ceiling less.
    """
    counts, radii, masses = species_arrays(run)
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


def deviation(measured, error, expected, applies: bool = True, theory_error: float = 0.0,
              dof: float = math.inf, theory_dof: float = math.inf) -> float:
    """(measured - expected)/sqrt(error^2 + theory_error^2) judged on Student's t, or NaN.

    ``dof``, ``theory_dof``: the errors' effective degrees of freedom (combined by Welch-Satterthwaite);
    the t value is printed as the normal deviate of the same tail probability
    (:func:`gaz_cli.analysis.errorbars.normal_equivalent`), NaN below errorbars.MIN_DOF.
    """
    if not applies or not all(map(math.isfinite, (measured, error, expected))) or error <= 0:
        return NA
    t = (measured - expected) / math.hypot(error, theory_error)
    if math.isfinite(dof) or math.isfinite(theory_dof):
        dof = errorbars.combined_dof([(error * error, dof), (theory_error * theory_error, theory_dof)])
    return errorbars.normal_equivalent(t, dof)


def few_dof_note(dof: float, applies: bool = True) -> str:
    """NOTE's words where a deviation is withheld for too few degrees of freedom ('' otherwise)."""
    if applies and math.isfinite(dof) and dof < errorbars.MIN_DOF:
        return (f"DEV_SIGMA withheld: the error has about {dof:.2g} effective degrees of freedom "
                f"(fewer than {errorbars.MIN_DOF:g}); run longer")
    return ""


def relative(measured, expected) -> float:
    if not (math.isfinite(measured) and math.isfinite(expected)) or expected == 0:
        return NA
    return measured / expected - 1.0


def number_or_nan(x) -> float:
    """A float, NaN for None."""
    return NA if x is None else float(x)


def set_aside_unsettled(exp: Expectation, run: StoredRun) -> bool:
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
