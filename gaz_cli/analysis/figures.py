"""The figures of one simulation (``gaz analyse --plot DIR``): what each shows, computed from a
stored run; :mod:`gaz_cli.analysis.plots` draws them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from gaz_cli import theory
from gaz_cli.analysis import errorbars
from gaz_cli.analysis.comparisons import collision_losses
from gaz_cli.analysis.estimators import BLOCKS, species_arrays, virial_bin_pressures, wall_bin_pressures
from gaz_cli.analysis.expectations import hit_shares, wall_pressure_theory
from gaz_cli.analysis.stored import StoredRun
from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError


def make_plots(run: StoredRun, temperature: float, summary: dict, plot_dir: str) -> list:
    """Write the figures of one simulation into ``plot_dir``; returns rows (SI_NUM, FIGURE, FILE)."""
    from gaz_cli.analysis import plots

    out = []
    base = Path(plot_dir)

    def path(name):
        return str(base / f"sim{run.si_num}_{name}.png")

    b = run.bounces() if run.bounces_count else run.bounces().iloc[:0]
    species = ([(r.NAME, r.MASS_KG, w, r.COUNT / run.n)
                for r, w in zip(run.species.itertuples(), hit_shares(run, temperature))]
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


def nothing_to_draw(run: StoredRun) -> str:
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


def _expected_hits(run: StoredRun, temperature: float):
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
    counts, radii, masses = species_arrays(run)
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


def _pressure_series(run: StoredRun, temperature: float, summary: dict, blocks: int = BLOCKS):
    """Running mean of the pressure against time, its error band, block values and theory, or None."""
    best = summary["best"]
    theory_value = best.value if best.known else None
    if run.periodic:
        series = virial_bin_pressures(run, temperature)
        what = "virial pressure"
    else:
        by_wall = wall_bin_pressures(run)
        series = np.mean([by_wall[k] for k in run.walls], axis=0) if run.bounces_count else None
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


def gravity_profile(run: StoredRun, temperature: float, bins: int = 60, bounces: pd.DataFrame | None = None):
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


def cooling_series(run: StoredRun, points: int = 200):
    """Temperature of a cooling gas against time from the CHOC impulses, with Haff's law; or None.

    Each inelastic collision with impulse J between equal masses m loses
    (1 - e)/(1 + e) J^2/m of kinetic energy; the collisions the TC model makes
    elastic (:func:`gaz_cli.analysis.comparisons.tc_elastic`) lose nothing.
    """
    d = run.dim
    t = run.chocs.CH_T.to_numpy(dtype=float)
    loss = collision_losses(run)
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
