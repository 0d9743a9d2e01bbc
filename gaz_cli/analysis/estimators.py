"""Time averages of one stored run and their error bars: pressures per wall and time bin, the
exam's per-wall table, and the estimates :mod:`gaz_cli.analysis.errorbars` makes of them
(block statistics for figures and studies too)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from gaz_cli import theory
from gaz_cli.analysis import errorbars
from gaz_cli.analysis.stored import StoredRun
from gaz_cli.constants import K_B

NA = math.nan
"""What a numeric cell holds when theory or the data cannot give a value (the reason goes in NOTE)."""

BLOCKS = 16
"""Time windows of the block values drawn in the pressure figure, and of :func:`block_sums`' default."""


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


def per_bin(bins, values) -> np.ndarray:
    """(BINS,) sums of ``values`` over their time bins."""
    return np.bincount(np.asarray(bins, dtype=np.int64), weights=np.asarray(values, dtype=float),
                       minlength=errorbars.BINS)[:errorbars.BINS]


def hit_masses(run: StoredRun) -> np.ndarray:
    mass = run.species.set_index("PA_NUM").MASS_KG
    return mass.reindex(run.hits.PA_NUM.to_numpy()).to_numpy(dtype=float)


def wall_bin_pressures(run: StoredRun) -> dict[int, np.ndarray]:
    """Wall code -> (BINS,) pressure in each time bin (unit per :data:`gaz_cli.constants.PRESSURE_UNIT`), from (1 + e_w) m |v_perp|."""
    h = run.hits
    width = run.duration / errorbars.BINS
    if not len(h):
        return {w: np.zeros(errorbars.BINS) for w in run.walls}
    mom = wall_momenta(run)
    wall = h.RE_DIR.to_numpy(dtype=np.int64)
    return {w: per_bin(h.BIN[wall == w], mom[wall == w]) / (width * run.wall_measure) for w in run.walls}


def wall_momenta(run: StoredRun) -> np.ndarray:
    """Momentum given to the wall by each row of ``run.hits``: sum of (1 + e_w) m |v_perp| (theory.wall_impulse)."""
    return theory.wall_impulse(hit_masses(run), run.hits.SUM_VP.to_numpy(dtype=float), run.wall_restitution)


def virial_bin_pressures(run: StoredRun, temperature: float) -> np.ndarray | None:
    """(BINS,) virial pressure of a periodic box in each time bin, from CHOC (a mixture: per pair of species), or None.

    :func:`gaz_cli.theory.virial_pressure` of each bin: W = sum of |J| sigma over the bin's collisions.
    """
    if run.collision_bins is None or not math.isfinite(temperature):
        return None
    if run.one_species:
        sigma = 2.0 * float(run.species.RADIUS_M.iloc[0])
        w = per_bin(run.collision_bins.BIN, run.collision_bins.SUM_IMP.to_numpy(dtype=float) * sigma)
    elif run.pair_bins is not None and "SUM_IMP" in run.pair_bins:
        # a mixture: each pair of species at its own contact distance R_i + R_j (species by rank)
        radii = run.species.RADIUS_M.to_numpy(dtype=float)
        p = run.pair_bins
        sigma = radii[p.RANK_I.to_numpy()] + radii[p.RANK_J.to_numpy()]
        w = per_bin(p.BIN, p.SUM_IMP.to_numpy(dtype=float) * sigma)
    else:
        return None
    return np.asarray(theory.virial_pressure(run.dim, run.n, temperature, run.length ** run.dim, w,
                                             run.duration / errorbars.BINS), dtype=float)


def exam_per_wall(run: StoredRun) -> pd.DataFrame:
    """sql/pressure_per_wall.sql's table (SI_NUM, RE_DIR, NB_REBONDS, QUANTITE_MOUVEMENT, PRESSION), from the bins.

    The same sums as the exam's query ((1 + e_w) m |v_perp| per bounce, 2 m
    |v_perp| for elastic walls), added up from the per-bin sums the database
    returned, so that the REBOND rows are read once.
    """
    h = run.hits
    if not len(h):
        return pd.DataFrame(columns=["SI_NUM", "RE_DIR", "NB_REBONDS", "QUANTITE_MOUVEMENT", "PRESSION"])
    mom = pd.Series(wall_momenta(run), index=h.index)
    walls = pd.DataFrame({"NB_REBONDS": h.NB_REBONDS.groupby(h.RE_DIR).sum(),
                          "QUANTITE_MOUVEMENT": mom.groupby(h.RE_DIR).sum()}).reset_index()
    walls["PRESSION"] = walls.QUANTITE_MOUVEMENT / (run.duration * run.wall_measure)
    walls.insert(0, "SI_NUM", run.si_num)
    return walls.astype({"RE_DIR": int, "NB_REBONDS": int})


def exam_q35(run: StoredRun) -> pd.DataFrame:
    """Q35 (sql/q35_bounces_per_simulation.sql) for this simulation alone, from the bins."""
    count = run.bounces_count
    mean = float(run.hits.SUM_VIT.sum() / count) if count else NA
    return pd.DataFrame([{"SI_NUM": run.si_num, "NB_REBONDS": count, "VITESSE_MOYENNE": mean}])


def run_average(run: StoredRun, series, weights=None, static_var: float = 0.0,
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


def ends_variance(run: StoredRun, temperature: float, axes: int) -> float | None:
    """errorbars.end_variance of the pressures summed over the walls of ``axes`` axes (None under gravity)."""
    if run.gravity > 0.0 or run.periodic or not len(run.species) or not math.isfinite(temperature):
        return None
    counts, radii, masses = species_arrays(run)
    return errorbars.end_variance(float(np.sum(counts * masses)) * K_B * temperature,
                                  0.5 * (run.length - 2.0 * float(radii.max())), run.window, run.wall_measure, axes)


EXACT_ENGINES = ("event", "ideal", "reference")
"""Engines that conserve the energy to round-off (the step engine's leap-frog drifts)."""


def mean_wall_pressure(run: StoredRun, temperature: float) -> errorbars.Estimate:
    """The mean over the walls of their pressures (the time bins' mean), with its error.

    Where the kinetic energy is fixed (elastic walls and collisions, an exact engine, no
    gravity nor other force), the walls' summed impulse is exactly (2 K T + W - (G(T) - G(0)))/h
    (:func:`gaz_cli.analysis.errorbars.end_variance`): the error is in closed form, with
    infinite degrees of freedom: the ends', the collisions' virial as independent impulses
    (:func:`~gaz_cli.analysis.errorbars.collision_virial_var`), and in a mixture the split of
    the kinetic energy among the species drawn at the start, relaxing by their cross collisions
    (:func:`~gaz_cli.analysis.errorbars.species_split_var`, ``..._relaxation``). Elsewhere the
    time series is reblocked (:func:`run_average`, with the ends where they are known).

    Why not blocks where the closed form holds (issue 38): the virial's noise read from 4 to 16
    long blocks, less the ends', scattered over the seeds of one scene as an error with 4 degrees
    of freedom where 15-18 were claimed (2D box N = 200 and He:Xe at walls: rms z 1.5-1.8, up to
    7 sigma, the seeds with the smallest error the outliers).
    """
    by_wall = wall_bin_pressures(run)
    series = np.mean([by_wall[w] for w in run.walls], axis=0)
    ends = ends_variance(run, temperature, run.dim)
    closed = (ends is not None and run.settle_bin == 0 and run.collisions is not None
              and math.isfinite(run.virial) and math.isfinite(run.ke_start) and run.restitution >= 1.0 and run.wall_restitution >= 1.0
              and run.engine in EXACT_ENGINES and not run.extra_forces and run.duration > 0.0)
    if not closed:
        return run_average(run, series, end_var=None if ends is None else ends / (2 * run.dim) ** 2)
    mean = float(np.mean(series))
    var = ends / (2 * run.dim) ** 2
    counts, radii, masses = species_arrays(run)
    var += errorbars.collision_virial_var(mean, run.virial, 2.0 * run.ke_start * run.duration, run.collisions,
                                          errorbars.pair_spread(run.dim, counts, masses, radii))
    frozen = 0.0
    if len(run.species) > 1 and len(run.hits):
        mom = wall_momenta(run)
        pa = run.hits.PA_NUM.to_numpy()
        parts = [float(mom[pa == p].sum()) for p in run.species.PA_NUM]
        tau = errorbars.species_split_relaxation(run.dim, counts, masses, radii, run.collisions / run.duration)
        frozen = (mean * mean * errorbars.species_split_var(counts, parts, run.dim)
                  * errorbars.frozen_fraction(run.duration / tau))
    var += frozen
    error = math.sqrt(var)
    var1 = float(np.var(series, ddof=1)) if series.size > 1 else math.nan
    return errorbars.Estimate(mean, error, var1 / var if var > 0 else math.nan, math.nan, math.sqrt(frozen),
                              math.inf)


def axis_sum(run: StoredRun, series: dict, d: int, temperature: float, static_var: float) -> errorbars.Estimate:
    """The sum S of the pressures of axis d's two walls, over the analysed part, with its error.

    ``series``: :func:`wall_bin_pressures`; ``static_var``: the frozen axis share's variance
    of S (unit^2). S = M + A: M the mean over the axes of their sums (twice the walls' mean
    pressure), A = S - M the axis' excess, which follows the share of the kinetic energy the
    axis holds. The axes are alike, so M and A are uncorrelated: Var S = Var M + Var A.
    Where M's error is in closed form (:func:`mean_wall_pressure`), A alone is reblocked
    (:func:`run_average`: its ends' part is (1 - 1/D) of the axis', the frozen share all in
    A; in 1D A is 0); else S is. Reading S's whole noise from blocks less the ends, as
    before, scattered the error over seeds (2D box, N = 200: a factor 4 over 30 seeds,
    walls up to 5.2 sigma).
    """
    pair = series[-d] + series[d]
    ends = ends_variance(run, temperature, 1)
    relaxation = errorbars.ANISOTROPY_RELAXATION[run.dim]
    mean = mean_wall_pressure(run, temperature) if ends is not None else errorbars.NAN_ESTIMATE
    if math.isfinite(mean.dof) or not math.isfinite(mean.error):
        return run_average(run, pair, static_var=static_var, relaxation=relaxation, end_var=ends)
    if run.dim == 1:       # one axis: S is twice the mean, no excess
        return errorbars.Estimate(float(np.mean(pair)), 2.0 * mean.error, math.nan, math.nan, 0.0, math.inf)
    axes = 2.0 * np.mean([series[w] for w in run.walls], axis=0)
    excess = run_average(run, pair - axes, static_var=static_var, relaxation=relaxation,
                         end_var=ends * (1.0 - 1.0 / run.dim))
    var_m = 4.0 * mean.error ** 2
    return errorbars.Estimate(float(np.mean(pair[run.settle_bin:])), math.sqrt(excess.error ** 2 + var_m), math.nan,
                              excess.window_s, excess.frozen,
                              errorbars.combined_dof([(excess.error ** 2, excess.dof), (var_m, math.inf)]))


def wall_estimates(run: StoredRun, expected: dict, temperature: float) -> dict[int, errorbars.Estimate]:
    """Wall code -> pressure estimate, from the two opposite walls of each axis.

    A wall's pressure is half the sum S of its axis' two walls plus (or
    minus) half their difference D. S follows the axis' kinetic energy (:func:`axis_sum`:
    the walls' mean in closed form, the axis' excess reblocked, with the frozen share of
    the energy the axis drew at the start, scaled by the expected, else measured,
    pressure). D is exactly the change of the gas's momentum along the axis over the run, divided by the run's
    time and the wall measure: its variance has the closed form
    2 sum_s N_s m_s k_B T/(T L^(D-1))^2 (start and end momenta independent
    draws), where reblocking would read its hit-by-hit noise as white and
    overestimate it (a momentum given to one wall is soon given back to the
    other). S and D are uncorrelated by the box's mirror symmetry.
    """
    out = {}
    share = errorbars.axis_share_var(run.dim, run.n)
    series = wall_bin_pressures(run)
    counts, _, masses = species_arrays(run)
    window = run.window
    diff_var = (2.0 * float(np.sum(counts * masses)) * K_B * temperature / (window * run.wall_measure) ** 2
                if math.isfinite(temperature) and len(run.species) and window > 0.0 else math.nan)
    for d in range(1, run.dim + 1):
        low, high = series[-d], series[d]
        exp = [expected.get(w) for w in (-d, d)]
        scale = sum(e.value if e is not None and e.known else float(np.mean(x)) for e, x in zip(exp, (low, high)))
        total = axis_sum(run, series, d, temperature, share * scale ** 2)
        for w, x in ((-d, low), (d, high)):
            own = run_average(run, x)
            if not (math.isfinite(total.error) and math.isfinite(diff_var)):
                out[w] = own
                continue
            error = 0.5 * math.sqrt(total.error ** 2 + diff_var)
            var1 = float(np.var(x[run.settle_bin:], ddof=1)) if x.size - run.settle_bin > 1 else math.nan
            out[w] = errorbars.Estimate(own.mean, error, var1 / error ** 2 if error > 0 else math.nan,
                                        total.window_s, 0.5 * total.frozen,
                                        errorbars.combined_dof([(total.error ** 2, total.dof), (diff_var, math.inf)]))
    return out


def species_arrays(run: StoredRun):
    return (run.species.COUNT.to_numpy(dtype=float), run.species.RADIUS_M.to_numpy(dtype=float),
            run.species.MASS_KG.to_numpy(dtype=float))


def settled_temperature(run: StoredRun) -> errorbars.Estimate:
    """Temperature of the analysed (settled) part of the run from its wall hits, K.

    Flux-weighted Maxwell-Boltzmann: <m v_perp^2> over the hits on any wall
    is 2 k_B T at any density and height, for every species; the hits of the
    settled part give T and its error (reblocking of the per-bin sums).
    """
    h = run.hits
    if not len(h) or "SUM_VP2" not in h:
        return errorbars.NAN_ESTIMATE
    energy = hit_masses(run) * h.SUM_VP2.to_numpy(dtype=float) / (2.0 * K_B)
    return run_average(run, per_bin(h.BIN, energy), per_bin(h.BIN, h.NB_REBONDS))
