"""The comparisons ``gaz analyse --sim N`` prints: one table each, measured against theory.

Each table is a :class:`Comparison` of :data:`COMPARISONS`, the one list that
``gaz analyse`` (which tables a scene gets, in which order), ``--table`` and its
``--help`` (:data:`gaz_cli.analysis.report.TABLES`) read. A comparison's frame
holds the measured number, its error (:mod:`gaz_cli.analysis.estimators`), the
theory (:mod:`gaz_cli.analysis.expectations`) and the deviation in sigmas; where
theory does not fit the scene, DEV_SIGMA is NaN and NOTE says why.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import pandas as pd

from gaz_cli import theory
from gaz_cli.analysis import errorbars
from gaz_cli.analysis.estimators import (NA, mean_wall_pressure, per_bin, run_average, settled_temperature,
                                         species_arrays, virial_bin_pressures, wall_bin_pressures,
                                         wall_estimates)
from gaz_cli.analysis.expectations import (Expectation, deviation, evaluate, few_dof_note, gravity_walls, hit_shares,
                                           number_or_nan, pressure_models, relative, set_aside_unsettled,
                                           wall_pressure_theory)
from gaz_cli.analysis.stored import StoredRun
from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError


def simulation_frame(run: StoredRun, temperature: float) -> dict:
    """The scene in one row of scalars, with how errors are made."""
    return {"SI_NUM": run.si_num, "SI_DIM": run.dim, "SI_N": run.n, "SI_L": run.length,
            "SI_DUR": run.duration, "ENGINE": run.engine, "BOUNDARY": run.boundary,
            "SPECIES": ", ".join(f"{r.NAME}:{r.COUNT}" for r in run.species.itertuples()),
            "PACKING_FRACTION": run.packing_fraction if len(run.species) else NA,
            "GRAVITY": run.gravity, "RESTITUTION": run.restitution, "WALL_RESTITUTION": run.wall_restitution,
            "T_SCENE_K": number_or_nan(run.temperature), "T_KIN_K": number_or_nan(run.kinetic_temperature),
            "T_THEORY_K": number_or_nan(temperature), "T_THEORY_ERR_K": run.temperature_error,
            "BOUNCES": run.bounces_count, "COLLISIONS": number_or_nan(run.collisions),
            "COLL_PER_PARTICLE": run.collisions_per_particle,
            "MEAN_FREE_TIME_S": run.mean_free_time if math.isfinite(run.mean_free_time) else NA,
            "ANALYSED_FROM_S": run.duration - run.window, "P_UNIT": run.unit,
            "ESTIMATOR": errorbars.ESTIMATOR, "BINS": errorbars.BINS, "BIN_S": run.duration / errorbars.BINS}


def per_wall_frame(run: StoredRun, per_wall: pd.DataFrame, temperature: float, summary: dict) -> pd.DataFrame:
    """The exam's per-wall pressure (SQL) with the time average analysed, its error, theory and deviation."""
    frame = per_wall.copy()
    if not len(frame):
        return frame
    expected = wall_pressure_theory(run, temperature, summary["best"])
    estimates = wall_estimates(run, expected, temperature)
    cols = {k: [] for k in ("P_UNIT", "P_MEASURED", "P_ERR", "N_EFF", "DOF", "P_THEORY", "DEV_SIGMA", "NOTE")}
    for w in frame.RE_DIR.astype(int):
        est = estimates.get(w, errorbars.NAN_ESTIMATE)
        exp = expected.get(w, Expectation(NA, "none"))
        cols["P_UNIT"].append(run.unit)
        cols["P_MEASURED"].append(est.mean)
        cols["P_ERR"].append(est.error)
        cols["N_EFF"].append(est.n_eff)
        cols["DOF"].append(est.dof)
        cols["P_THEORY"].append(exp.value)
        dev = deviation(est.mean, est.error, exp.value, exp.applies, exp.error, est.dof, exp.error_dof)
        cols["DEV_SIGMA"].append(dev)
        cols["NOTE"].append(_joined(_wall_note(run, exp), few_dof_note(est.dof, exp.known and exp.applies and math.isfinite(est.error))))
    for k, v in cols.items():
        frame[k] = v
    return frame


def _wall_note(run: StoredRun, exp: Expectation) -> str:
    notes = []
    if run.settle_bin:
        notes.append(f"P_MEASURED: after settling, from {run.duration - run.window:.3g} s")
    if not exp.known or not exp.applies:
        notes.append(exp.note or "no theory for this scene")
    return "; ".join(notes)


def pressure_summary(run: StoredRun, temperature: float) -> dict:
    """Measured pressure (mean over the walls, or virial), its error estimate, and the theories."""
    if run.periodic:
        measured = (theory.virial_pressure(run.dim, run.n, temperature, run.length ** run.dim,
                                           run.virial, run.duration)
                    if math.isfinite(temperature) and math.isfinite(run.virial) else math.nan)
        series = virial_bin_pressures(run, temperature)
        est = run_average(run, series) if series is not None else errorbars.NAN_ESTIMATE
        how = "virial" + ("" if series is not None else " (error bar needs --record all)")
    elif not run.bounces_count:
        measured, est = math.nan, errorbars.NAN_ESTIMATE
        how = "no wall bounce recorded" + (" (--record none)" if run.record == "none" else "")
    else:
        est = mean_wall_pressure(run, temperature)      # the mean over the 2D walls
        measured = est.mean
        how = "mean over the walls" + (" after settling" if run.settle_bin else "")
    stat_rel = est.error / abs(measured) if math.isfinite(est.error) and measured else 0.0
    models = pressure_models(run, temperature, stat_rel, measured)
    return {"measured": measured, "error": est.error, "n_eff": est.n_eff, "dof": est.dof, "how": how,
            "best": models[0], "models": models}


def pressure_frame(run: StoredRun, temperature: float, summary: dict) -> pd.DataFrame:
    """One row per theoretical model: expected pressure, deviation in sigmas and relative."""
    rows = []
    for exp in summary["models"]:
        rows.append({"MODEL": exp.model, "P_UNIT": run.unit, "P_MEASURED": number_or_nan(summary["measured"]),
                     "P_ERR": number_or_nan(summary["error"]), "N_EFF": summary["n_eff"], "DOF": summary["dof"],
                     "P_THEORY": exp.value,
                     "DEV_SIGMA": deviation(summary["measured"], summary["error"], exp.value, exp.applies, exp.error,
                                            summary["dof"], exp.error_dof),
                     "REL_DEV": relative(summary["measured"], exp.value), "SYST_REL": exp.syst,
                     "MEASURED": summary["how"],
                     "NOTE": _joined(exp.note, few_dof_note(summary["dof"], exp.known and exp.applies
                                                            and math.isfinite(summary["error"])))})
    return pd.DataFrame(rows)


ENSKOG_SYST = 0.02
"""Relative model error of Enskog's rate (and the 1D Maxwellian average) in a bulk fluid below freezing;
at walls at least D sigma/L (the share of particles within a diameter of a wall, with fewer partners)."""


def collision_frame(run: StoredRun, temperature: float) -> pd.DataFrame:
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
        binned = per_bin(run.collision_bins.BIN, run.collision_bins.NB_CHOCS.to_numpy(dtype=float))
        if stratified:      # the settled part only, as the pressures: the fall collides less
            est = run_average(run, 2.0 * binned / (run.n * width))
            rate = est.mean if math.isfinite(est.mean) else rate
        else:
            est = errorbars.time_average(2.0 * binned / (run.n * width), duration=run.duration)
    elif run.restitution >= 1.0:
        err_note = "RATE_ERR_HZ needs the collisions' times: --record all; "
    counts, radii, masses = species_arrays(run)
    d, L = run.dim, run.length
    rows = []
    if run.extra_forces:
        rows.append(Expectation(NA, "Enskog", run.extra_forces))
    elif not run.one_species:
        rows.append(Expectation(NA, "Enskog", "one species only (mixture: cross-sections and masses differ)"))
    elif not math.isfinite(temperature):
        rows.append(Expectation(NA, "Enskog", "temperature unknown"))
    elif stratified:
        exp = evaluate(f"Enskog, g from {theory.BEST_MODEL[d]}, averaged over the barometric profile",
                   lambda: theory.gravity_collision_frequency(d, L, temperature, run.n, radii[0], masses[0],
                                                              run.gravity),
                   "local density of the hydrostatic profile (the gas is denser low down: more partners); "
                   "walls: expect O(2R/L) off")
        if not set_aside_unsettled(exp, run) and run.collision_bins is None:
            exp.applies = False
            exp.note = ("under gravity the settled part's rate needs the collisions' times (the count over "
                        "the run includes the fall): --record all")
        rows.append(exp)
    elif d == 1:
        rows.append(evaluate("1D rods, exact (N-1) <|v_rel|>/(L - N sigma)",
                         lambda: theory.rods_collision_frequency(run.n, L, radii[0], temperature, masses[0]),
                         "Maxwellian average; with equal masses the set of speeds never relaxes, "
                         "expect O(1/sqrt(N)) off"))
    elif run.periodic:
        rows.append(evaluate(f"Enskog, g from {theory.BEST_MODEL[d]}, n = N/L^D",
                         lambda: theory.enskog_collision_frequency(d, run.n / L ** d, 2 * radii[0],
                                                                   temperature, masses[0]),
                         "Enskog: a few % up to freezing"))
    else:
        sigma = 2 * radii[0]
        rows.append(evaluate(f"Enskog, g from {theory.BEST_MODEL[d]}, n = N/(L-2R)^D",
                         lambda: theory.enskog_collision_frequency(d, run.n / (L - sigma) ** d, sigma,
                                                                   temperature, masses[0]),
                         "walls: fewer partners near a wall, expect O(2R/L) off"))
        rows[-1].syst = max(ENSKOG_SYST, d * sigma / L)
    if run.restitution < 1.0 and run.one_species and math.isfinite(temperature) and d > 1 and not run.extra_forces:
        # a cooling gas: omega falls as sqrt(T); Haff integrates it over the run
        n = run.n / (L if run.periodic else L - 2 * radii[0]) ** d

        def haff_rate():
            omega0 = theory.enskog_collision_frequency(d, n, 2 * radii[0], temperature, masses[0])
            return theory.haff_collisions_per_particle(d, run.duration, run.restitution, omega0) / run.duration
        rows = [evaluate("Enskog omega0, cooled by Haff's law (mean over the run)", haff_rate,
                     "homogeneous cooling only: clusters raise the rate")]
        if stratified:
            rows[0].applies = False
            rows[0].note = "under gravity the cooling gas is not homogeneous: Haff's law does not apply"
    # Enskog and the 1D Maxwellian average carry model errors of a few % (notes): a deviation in
    # sigmas is printed only when the statistical error is larger than that
    frame = []
    for exp in rows:
        approximate = exp.model.startswith("Enskog") or exp.model.startswith("1D rods")
        syst = max(exp.syst, ENSKOG_SYST) if approximate else exp.syst
        fits = exp.applies and (not approximate or (math.isfinite(est.error) and est.error > syst * rate))
        frame.append({"MODEL": exp.model, "COLLISIONS": run.collisions, "RATE_PER_PARTICLE_HZ": rate,
                      "RATE_ERR_HZ": est.error, "N_EFF": est.n_eff, "DOF": est.dof, "THEORY_HZ": exp.value,
                      "DEV_SIGMA": deviation(rate, est.error, exp.value, fits, 0.0, est.dof),
                      "REL_DEV": relative(rate, exp.value),
                      "NOTE": err_note + exp.note + ("" if fits or not (exp.applies and math.isfinite(est.error)) else
                                                     f"; model error (up to {syst:.2g} relative) above the "
                                                     "statistical error: REL_DEV, not DEV_SIGMA")})
    return pd.DataFrame(frame)


def contact_frame(run: StoredRun, temperature: float) -> pd.DataFrame:
    """A mixture's contact values g_ij per pair of species, measured from the collisions, against BMCSL.

    The collisions between species i and j per unit time are
    V n_i n_j g_ij S_D(sigma_ij) <|v_rel|> (half that for i = j,
    :func:`gaz_cli.theory.pair_collision_density`): their count over the run
    reads g_ij; its error is the reblocking of the count per time bin. CHOC's
    particle indices give the species (COMPOSITION.CO_RANK: the species'
    block of indices). A periodic box only: walls thin the density near them.
    """
    cols = ["PAIR", "COLLISIONS", "G_MEASURED", "G_ERR", "N_EFF", "DOF", "G_THEORY", "DEV_SIGMA", "REL_DEV", "MODEL",
            "NOTE"]
    sp = run.species.reset_index(drop=True)
    pairs = [(a, b) for a in range(len(sp)) for b in range(a, len(sp))]

    def empty(note):
        return pd.DataFrame([{"PAIR": f"{sp.NAME[a]}-{sp.NAME[b]}", "COLLISIONS": NA, "G_MEASURED": NA, "G_ERR": NA,
                              "N_EFF": NA, "DOF": NA, "G_THEORY": NA, "DEV_SIGMA": NA, "REL_DEV": NA, "MODEL": "BMCSL",
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
        mapped = theory.mixture_contact_values_mapped(density, diam) if run.dim == 3 else None
    except SceneError:
        bmcsl = mapped = None
    rank = sp.RANK.to_numpy(dtype=float)
    pb = run.pair_bins
    width = run.duration / errorbars.BINS
    rows = []
    for a, b in pairs:
        sel = (((pb.RANK_I == rank[a]) & (pb.RANK_J == rank[b])) | ((pb.RANK_I == rank[b]) & (pb.RANK_J == rank[a])))
        counts = per_bin(np.clip(pb.BIN[sel], 0, errorbars.BINS - 1), pb.NB_CHOCS[sel].to_numpy(dtype=float))
        sigma = 0.5 * (diam[a] + diam[b])
        per_unit_g = float(theory.pair_collision_density(run.dim, density[a], density[b], sigma, temperature,
                                                         sp.MASS_KG[a], sp.MASS_KG[b], 1.0, same=a == b)) * volume
        est = errorbars.time_average(counts / (width * per_unit_g), duration=run.duration)
        g_th = float(mapped[a, b]) if mapped is not None else NA
        rows.append({"PAIR": f"{sp.NAME[a]}-{sp.NAME[b]}", "COLLISIONS": int(counts.sum()), "G_MEASURED": est.mean,
                     "G_ERR": est.error, "N_EFF": est.n_eff, "DOF": est.dof, "G_THEORY": g_th,
                     "DEV_SIGMA": deviation(est.mean, est.error, g_th, True, 0.0, est.dof),
                     "REL_DEV": relative(est.mean, g_th),
                     "MODEL": f"{theory.BEST_MODEL[3]} mapped onto the mixture, g_ij at contact"
                              if mapped is not None else "none",
                     "NOTE": (f"BMCSL's g_ij {float(bmcsl[a, b]):.5g} (about 0.2-0.3 % low at packing 0.3-0.4)"
                              if bmcsl is not None else "no mixture contact values in 2D or 1D here")})
    return pd.DataFrame(rows, columns=cols)


def wall_speed_frame(run: StoredRun, temperature: float) -> pd.DataFrame:
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
    weights = hit_shares(run, temperature) if len(run.species) else []
    pa = h.PA_NUM.to_numpy(dtype=np.int64) if len(h) else np.zeros(0, dtype=np.int64)
    # 1D rods of equal masses (one species, or several radii) swap velocities at each collision: the N
    # speeds drawn at the start are kept for ever, and every wall sees the hits of all N ghosts
    frozen_forever = run.dim == 1 and len(run.species) > 0 and run.species.MASS_KG.nunique() == 1
    relax = math.inf if frozen_forever else errorbars.SPEED_RELAXATION
    # at the run's own kinetic temperature, the D N velocity components share a fixed energy
    components = (run.dim * run.n if run.temperature_source == "kinetic" and run.gravity <= 0.0
                  and not run.periodic and run.restitution >= 1.0 and run.wall_restitution >= 1.0
                  and run.n >= 1 else None)
    # 2D/3D mixtures at walls without gravity: the species' shares of the hits follow their contact
    # densities, which wall adsorption shifts from N_s/(L - 2R_s) (big spheres gather at a wall:
    # +7 % on Q35's mean at packing 0.33); the theory of the mean over all hits takes the measured
    # shares, a test of each species' flux-weighted speed
    measured_shares = (run.dim > 1 and run.gravity <= 0.0 and len(run.species) > 1 and len(h) > 0
                       and float(h.NB_REBONDS.sum()) > 0)
    if measured_shares:
        total_hits = float(h.NB_REBONDS.sum())
        share_of = [float(h.NB_REBONDS[pa == sp.PA_NUM].sum()) / total_hits for sp in run.species.itertuples()]
    for k, (sp, w) in enumerate(zip(run.species.itertuples(), weights)):
        w = share_of[k] if measured_shares else w
        sel = pa == sp.PA_NUM
        sums = per_bin(h.BIN[sel], h.SUM_VIT[sel]) if len(h) else np.zeros(errorbars.BINS)
        counts = per_bin(h.BIN[sel], h.NB_REBONDS[sel]) if len(h) else np.zeros(errorbars.BINS)
        exp = (evaluate("flux-weighted mean <v^2>/<|v|>",
                    lambda: theory.wall_hit_mean_speed(run.dim, temperature, sp.MASS_KG, components))
               if math.isfinite(temperature) else Expectation(NA, "flux-weighted", "temperature unknown"))
        static = (errorbars.hit_speed_var(run.dim, run.n if frozen_forever else int(sp.COUNT),
                                          K_B * temperature / sp.MASS_KG)
                  if math.isfinite(temperature) else 0.0)
        est = run_average(run, sums, counts, static_var=static, relaxation=relax, end_var=0.0)
        if exp.known and run.temperature_error > 0:
            exp.error = exp.value * run.temperature_error / (2.0 * temperature)    # theory ~ sqrt(T)
        if frozen_forever:
            exp.note = "1D equal masses: the N speeds drawn at the start are kept for ever (in ERR)"
        expected_all = expected_all + w * exp.value
        expected_all_error += w * exp.error          # one temperature for all species: errors add
        rows.append({"SPECIES": sp.NAME, "BOUNCES": int(counts.sum()), "VITESSE_MOYENNE": est.mean,
                     "ERR": est.error, "N_EFF": est.n_eff, "DOF": est.dof, "ERR_FROZEN": est.frozen, "THEORY": exp.value,
                     "DEV_SIGMA": deviation(est.mean, est.error, exp.value, True, exp.error, est.dof),
                     "REL_DEV": relative(est.mean, exp.value),
                     "GAS_MEAN_SPEED": (float(theory.mean_speed(run.dim, temperature, sp.MASS_KG))
                                        if math.isfinite(temperature) else NA), "NOTE": exp.note})
    if len(run.species) > 1:
        sums = per_bin(h.BIN, h.SUM_VIT) if len(h) else np.zeros(errorbars.BINS)
        counts = per_bin(h.BIN, h.NB_REBONDS) if len(h) else np.zeros(errorbars.BINS)
        static = 0.0
        if math.isfinite(temperature) and frozen_forever:    # one set of N speeds for all species
            static = errorbars.hit_speed_var(run.dim, run.n, K_B * temperature / float(run.species.MASS_KG.iloc[0]))
        elif math.isfinite(temperature):   # the species' frozen spreads, weighted by their shares of the hits
            static = sum((wt ** 2) * errorbars.hit_speed_var(run.dim, int(sp.COUNT), K_B * temperature / sp.MASS_KG)
                         for sp, wt in zip(run.species.itertuples(), weights))
        est = run_average(run, sums, counts, static_var=static, relaxation=relax, end_var=0.0)
        rows.append({"SPECIES": "all (Q35)", "BOUNCES": int(counts.sum()), "VITESSE_MOYENNE": est.mean,
                     "ERR": est.error, "N_EFF": est.n_eff, "DOF": est.dof, "ERR_FROZEN": est.frozen, "THEORY": expected_all,
                     "DEV_SIGMA": deviation(est.mean, est.error, expected_all, not run.ordered_rods, expected_all_error,
                                            est.dof),
                     "REL_DEV": relative(est.mean, expected_all), "GAS_MEAN_SPEED": NA,
                     "NOTE": ("theory weighted by the species of the two end rods, the only ones hitting the "
                              "walls, over sqrt(m_s)" if run.dim == 1 and run.gravity <= 0.0 else
                              "theory weighted by each species' measured share of the hits (their contact "
                              "densities: wall adsorption shifts them from N_s/(L-2R_s))"
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


def gravity_frame(run: StoredRun, temperature: float) -> pd.DataFrame:
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
    est = run_average(run, series)
    counts, radii, masses = species_arrays(run)
    if math.isfinite(est.mean) and math.isfinite(temperature) and len(run.species) and run.window > 0:
        error = math.sqrt(2.0 * float(np.sum(counts * masses)) * K_B * temperature) / run.window
        var1 = float(np.var(series[run.settle_bin:], ddof=1)) if series.size - run.settle_bin > 1 else NA
        est = errorbars.Estimate(est.mean, error, var1 / error ** 2, NA, 0.0, math.inf)
    weight = float(np.sum(counts * masses) * run.gravity)
    pushed = run.drag > 0.0 or run.planes     # forces on the gas other than the weight and the two walls
    rows = [{"QUANTITY": "floor - ceiling force (N)", "MEASURED": est.mean, "ERR": est.error, "N_EFF": est.n_eff, "DOF": est.dof,
             "THEORY": weight, "DEV_SIGMA": deviation(est.mean, est.error, weight, not pushed),
             "REL_DEV": relative(est.mean, weight),
             "NOTE": run.extra_forces if pushed else
                     "sum N m g: exact momentum balance (settled part of the run); ERR: that of the gas's "
                     "vertical momentum at its two ends"}]
    h = run.hits
    start = run.settle_bin
    wall = h.RE_DIR.to_numpy(dtype=np.int64) if len(h) else np.zeros(0, dtype=np.int64)
    floor = per_bin(h.BIN[wall == -d], h.NB_REBONDS[wall == -d]) if len(h) else np.zeros(errorbars.BINS)
    ceiling = per_bin(h.BIN[wall == d], h.NB_REBONDS[wall == d]) if len(h) else np.zeros(errorbars.BINS)
    ratio_est = run_average(run, ceiling, floor)
    if run.one_species and math.isfinite(temperature) and len(run.species):
        m = masses[0]

        def hit_ratio():   # hits per time: P / sqrt(2 pi m kT) on each wall, same T: the pressure ratio
            floor_p, ceiling_p, _, _, _ = gravity_walls(run, temperature)
            return ceiling_p / floor_p
        exp = evaluate("ceiling/floor pressure ratio of the barometric model", hit_ratio,
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
                 "N_EFF": ratio_est.n_eff, "DOF": ratio_est.dof, "THEORY": exp.value,
                 "DEV_SIGMA": deviation(ratio_est.mean, ratio_est.error, exp.value, run.settled and exp.applies, 0.0,
                                        ratio_est.dof),
                 "REL_DEV": relative(ratio_est.mean, exp.value),
                 "NOTE": f"settled part, {int(floor[start:].sum())} floor and {int(ceiling[start:].sum())} "
                         f"ceiling hits; {exp.note}"})
    return pd.DataFrame(rows)


def cooling_frame(run: StoredRun) -> pd.DataFrame:
    """Final temperature of a cooling granular gas against Haff's law (time and per-collision forms).

    T_END_K is exact (the final kinetic energy); its error is that of the
    energy lost, from reblocking of the loss per time bin (needs CHOC rows).
    """
    d = run.dim
    rows = []
    t0 = run.temperature_of(run.ke_start)
    t_end = run.temperature_of(run.ke_end)
    err = NA
    counts, radii, masses = species_arrays(run)
    if run.chocs is not None and run.one_species and math.isfinite(t0):
        loss = collision_losses(run)
        bins = np.clip((run.chocs.CH_T.to_numpy(dtype=float) * errorbars.BINS / run.duration).astype(np.int64),
                       0, errorbars.BINS - 1)
        est = errorbars.time_average(per_bin(bins, loss), duration=run.duration)
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
        rows.append(evaluate("Haff T0/(1 + t/t0)^2, Enskog omega0", haff_time,
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
        rows.append(evaluate("Haff per collision T0 exp(-(1-e^2) tau/D)",
                         lambda: theory.haff_temperature_per_collision(d, tau, t0, run.restitution),
                         note + "; molecular chaos: clusters slow the loss per collision"))
    return pd.DataFrame([{"MODEL": e.model, "T_START_K": t0, "T_END_K": t_end, "T_END_ERR_K": err,
                          "T_THEORY_K": e.value, "REL_DEV": relative(t_end, e.value), "NOTE": e.note}
                         for e in rows])


def collision_losses(run: StoredRun) -> np.ndarray:
    """(k,) kinetic energy lost by each CHOC collision, J (0 for those the TC model made elastic)."""
    m = float(run.species.MASS_KG.iloc[0])
    e = run.restitution
    t = run.chocs.CH_T.to_numpy(dtype=float)
    j = run.chocs.CH_IMP.to_numpy(dtype=float)
    inelastic = ~tc_elastic(t, run.chocs.CH_I.to_numpy(dtype=np.int64), run.chocs.CH_J.to_numpy(dtype=np.int64),
                            run.tc)
    return np.where(inelastic, (1 - e) / (1 + e) * j * j / m, 0.0)


def overview_row(run: StoredRun, temperature: float, summary: dict) -> dict:
    """One simulation in one row: measured pressure, ideal gas, best theory, deviation in sigmas."""
    row = {"SI_NUM": run.si_num, "SI_DIM": run.dim, "SI_N": run.n, "SI_L": run.length, "SI_DUR": run.duration,
           "BOUNDARY": run.boundary, "T_KIN_K": number_or_nan(run.kinetic_temperature), "T_THEORY_K": number_or_nan(temperature),
           "P_UNIT": run.unit}
    if run.periodic:
        ideal = evaluate("ideal", lambda: theory.ideal_gas_pressure(run.n, temperature, run.length ** run.dim))
    else:
        counts, radii, _ = species_arrays(run)
        ideal = (evaluate("ideal", lambda: theory.ideal_wall_pressure(run.dim, run.length, temperature, counts, radii))
                 if len(run.species) and math.isfinite(temperature) else Expectation(NA, "ideal"))
    measured = number_or_nan(summary["measured"])
    best = summary["best"]
    row.update({"P_MEASURED": measured, "P_ERR": number_or_nan(summary["error"]), "N_EFF": summary["n_eff"], "DOF": summary["dof"],
                "P_IDEAL": ideal.value, "RATIO": relative(measured, ideal.value) + 1.0,
                "P_THEORY": best.value, "THEORY": best.model,
                "DEV_SIGMA": deviation(measured, summary["error"], best.value, best.applies, best.error, summary["dof"],
                                       best.error_dof),
                "NOTE": (few_dof_note(summary["dof"], math.isfinite(summary["error"])) if best.known and best.applies
                         else best.note)})
    return row


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


def _joined(*notes: str) -> str:
    return "; ".join(n for n in notes if n)


# --- the registry ---------------------------------------------------------------------
@dataclass(frozen=True)
class Comparison:
    """One table of ``gaz analyse --sim N``: its ``--table`` name, its title, which scenes get it,
    and how it is made from a run, the temperature theory is evaluated at (K) and the pressure
    summary (:func:`pressure_summary`)."""

    key: str
    title: str
    shown: Callable[[StoredRun], bool]
    frame: Callable[[StoredRun, float, dict], "pd.DataFrame | dict"]


COMPARISONS = (
    Comparison("simulation", "simulation", lambda run: True,
               lambda run, t, summary: simulation_frame(run, t)),
    Comparison("pressure", "pressure against theory", lambda run: True, pressure_frame),
    Comparison("collisions", "collision rate against Enskog", lambda run: True,
               lambda run, t, summary: collision_frame(run, t)),
    Comparison("contact", "contact values per pair of species", lambda run: len(run.species) > 1,
               lambda run, t, summary: contact_frame(run, t)),
    Comparison("speed", "mean wall-hit speed against theory", lambda run: not run.periodic,
               lambda run, t, summary: wall_speed_frame(run, t)),
    Comparison("gravity", "force balance under gravity", lambda run: run.gravity > 0.0 and not run.periodic,
               lambda run, t, summary: gravity_frame(run, t)),
    Comparison("cooling", "cooling against Haff's law", lambda run: run.restitution < 1.0,
               lambda run, t, summary: cooling_frame(run)),
)
"""Every comparison of one simulation, in the order ``gaz analyse --sim N`` prints them."""
