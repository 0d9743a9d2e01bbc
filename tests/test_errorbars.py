"""The error estimator: reblocking and the frozen initial draw (gaz_cli.analysis.errorbars)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gaz_cli.analysis import errorbars


def _ar1(rng, k: int, n: int, phi: float) -> np.ndarray:
    """(k, n) stationary AR(1) rows x_t = phi x_(t-1) + e_t, e unit normal."""
    from scipy.signal import lfilter

    e = rng.standard_normal((k, n))
    x0 = e[:, :1] / math.sqrt(1.0 - phi * phi)
    rest, _ = lfilter([1.0], [1.0, -phi], e[:, 1:], axis=1, zi=phi * x0)
    return np.concatenate([x0, rest], axis=1)


def _ar1_sd_of_mean(n: int, phi: float) -> float:
    """Exact standard deviation of the mean of n stationary AR(1) values (unit innovations)."""
    lag = np.arange(1, n)
    return math.sqrt((1.0 + 2.0 * np.sum((1.0 - lag / n) * phi ** lag)) / (1.0 - phi * phi) / n)


def _white(rng, k, n):
    return rng.standard_normal((k, n)), 1.0 / math.sqrt(n)


def _slow_drift(rng, k, n, amplitude=0.1, cycles=1.4):
    """White noise plus a slow oscillation of random phase, 1.4 periods over the series: at short
    lags too weak for the window to see (the window alone reads 0.86 of the error), caught by
    the long blocks. Slower drifts (under a period in the series) are one draw of a frozen mode
    that no estimator from one series can size; analysis adds those from closed forms."""
    t = np.arange(n)
    phase = rng.uniform(0.0, 2.0 * math.pi, (k, 1))
    omega = 2.0 * math.pi * cycles / n
    drift_var = 0.5 * amplitude ** 2 * abs(np.mean(np.exp(1j * omega * t))) ** 2
    return (rng.standard_normal((k, n)) + amplitude * np.sin(omega * t + phase),
            math.sqrt(1.0 / n + drift_var))


SERIES = {
    # class: (n, make(rng, k, n) -> (rows, exact sd of the mean))
    "white noise": (512, _white),
    "AR(1) phi 0.2": (512, lambda rng, k, n: (_ar1(rng, k, n, 0.2), _ar1_sd_of_mean(n, 0.2))),
    "AR(1) phi 0.5": (512, lambda rng, k, n: (_ar1(rng, k, n, 0.5), _ar1_sd_of_mean(n, 0.5))),
    "AR(1) phi 0.9": (4096, lambda rng, k, n: (_ar1(rng, k, n, 0.9), _ar1_sd_of_mean(n, 0.9))),
    "AR(1) 0.3 + 0.5 AR(1) 0.95": (4096, lambda rng, k, n: (
        _ar1(rng, k, n, 0.3) + 0.5 * _ar1(rng, k, n, 0.95),
        math.hypot(_ar1_sd_of_mean(n, 0.3), 0.5 * _ar1_sd_of_mean(n, 0.95)))),
    "slow drift": (2048, _slow_drift),
    # few effective samples (about 27): most verdicts withheld, the rest judged on Student's t
    "AR(1) phi 0.9, short": (512, lambda rng, k, n: (_ar1(rng, k, n, 0.9), _ar1_sd_of_mean(n, 0.9))),
}

FAR = 4.0
"""|z| beyond which a verdict is far off: 6e-5 of a normal's draws."""
RARE = 0.001
"""Largest share of series allowed |z| > FAR, or an error below half the truth with a verdict given."""


CHUNK = 2000
"""Series drawn and estimated at a time (a (2000, 4096) block's FFTs take about 0.3 GB)."""


def synthetic_table(k: int, seed: int = 11) -> dict:
    """Class -> (share |z| > FAR, share error < truth/2 with a verdict, withheld, mean error/truth, rms z)."""
    rng = np.random.default_rng(seed)
    out = {}
    for name, (n, make) in SERIES.items():
        parts = [make(rng, min(CHUNK, k - start), n) for start in range(0, k, CHUNK)]   # memory: chunks
        truth = parts[0][1]
        got = [errorbars.autocorrelation_error(rows) + (rows.mean(axis=1),) for rows, _ in parts]
        err, dof, mean = (np.concatenate([g[i] for g in got]) for i in (0, 1, 3))
        z = errorbars.normal_equivalent(mean / err, dof)
        given = np.isfinite(z)
        shown = np.where(given, z, 0.0)
        out[name] = (float(np.mean(np.abs(shown) > FAR)), float(np.mean((err < truth / 2) & given)),
                     float(1.0 - given.mean()), float(np.mean(err) / truth),
                     float(np.sqrt(np.mean(shown[given] ** 2))))
    return out


def _check(table):
    for name, (far, low, withheld, ratio, rms) in table.items():
        assert far <= RARE, (name, table[name])
        if name.endswith("short"):
            # 4 to 10 degrees of freedom: an error below half the truth is a chi-square event of a
            # few % (P(chi2_4 < 1) = 9 %), which Student's t accounts for: |z| > 4 stays rare
            assert low < 0.03 and 0.3 < withheld < 0.7, (name, table[name])
        elif name == "slow drift":       # long blocks swapped in: conservative, fewer degrees of freedom
            assert low <= RARE and withheld < 0.2 and 0.95 < ratio < 1.3 and 0.85 < rms < 1.1, (name, table[name])
        else:
            assert low <= RARE, (name, table[name])
            assert withheld < 0.1 and 0.9 < ratio < 1.15 and 0.85 < rms < 1.1, (name, table[name])


def test_autocorrelation_error_is_never_overconfident():
    """3,000 series of each class: |z| > 4 and an error below half the truth (with a verdict) in at
    most 0.1 % each; the error within 10 % of the exact one on average; a few seconds."""
    _check(synthetic_table(3000))


@pytest.mark.coverage
@pytest.mark.long
def test_autocorrelation_error_is_never_overconfident_long():
    """The same on 20,000 series of each class (about a minute)."""
    _check(synthetic_table(20000, seed=12))


def test_autocorrelation_error_limits():
    """White noise: the naive s/sqrt(n) floor; a constant: 0; one value: NaN; dof of white noise about n/11."""
    x = np.array([1.0, -1.0] * 8)          # anticorrelated: the naive error is the floor
    err, dof, w = errorbars.autocorrelation_error(x)
    assert err == pytest.approx(np.std(x, ddof=1) / 4.0)
    assert errorbars.autocorrelation_error(np.full(64, 2.0))[0] == 0.0
    assert math.isnan(errorbars.autocorrelation_error([1.0])[0])
    rng = np.random.default_rng(2)
    _, dof, w = errorbars.autocorrelation_error(rng.standard_normal(512))
    assert 1 <= w <= 10 and dof == pytest.approx(512 / (2 * w + 1))


def test_normal_equivalent_of_student_t():
    """t with dof degrees of freedom as the normal deviate of the same two-sided tail; withheld below MIN_DOF."""
    from scipy import stats

    assert errorbars.normal_equivalent(2.0, math.inf) == 2.0
    z = errorbars.normal_equivalent(-3.0, 10.0)
    assert z == pytest.approx(-stats.norm.isf(stats.t.sf(3.0, 10.0)), rel=1e-12) and -3.0 < z < -2.0
    assert math.isnan(errorbars.normal_equivalent(1.0, errorbars.MIN_DOF - 0.5))
    assert errorbars.combined_dof([(1.0, 10.0), (1.0, math.inf)]) == pytest.approx(40.0)


def test_frozen_draw_is_added_when_no_collision_relaxes_it():
    """A constant series (every bin the same): no reblocking error, the whole static spread stays."""
    est = errorbars.time_average(np.full(512, 3.0), duration=1.0, static_var=0.25, relaxation_s=math.inf)
    assert est.mean == 3.0 and est.error == pytest.approx(0.5) and est.frozen == pytest.approx(0.5)
    # relaxing over the run (x = 4 relaxation times): g(4), less what 512 one-bin blocks would have seen
    g = errorbars.frozen_fraction
    x = 4.0
    part = errorbars.time_average(np.full(512, 3.0), duration=1.0, static_var=0.25, relaxation_s=1 / x)
    assert part.error == pytest.approx(math.sqrt(0.25 * (g(x) - (g(x / 512) - g(x)) / 511)), rel=1e-12)
    assert 0.25 * 2 / x * 0.5 < part.error ** 2 < 0.25


def test_frozen_fraction_limits():
    assert errorbars.frozen_fraction(0.0) == 1.0
    assert errorbars.frozen_fraction(1e4) == pytest.approx(2e-4, rel=1e-3)
    assert errorbars.frozen_fraction(1.0) == pytest.approx(2 * math.exp(-1.0))


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_hit_speed_constants_by_monte_carlo(dim):
    """c_D: N Var(sum |v| sum|v_d| / sum sum|v_d|) at fixed energy, by the delta method on 10^6 draws (+-1%)."""
    rng = np.random.default_rng(dim)
    v = rng.standard_normal((1_000_000, dim))
    speed, flux, energy = np.linalg.norm(v, axis=1), np.abs(v).sum(axis=1), (v * v).sum(axis=1)
    mu = (speed * flux).mean() / flux.mean()
    r = speed * flux - mu * flux
    r = r - np.cov(r, energy)[0, 1] / energy.var() * energy
    assert r.var() / flux.mean() ** 2 == pytest.approx(errorbars.HIT_SPEED_VAR[dim], rel=0.01)


def test_axis_share_variance_by_monte_carlo():
    """D E_d/E over draws of N = 50 particles in 3D: variance 2 (D-1)/(D N + 2)."""
    rng = np.random.default_rng(1)
    v2 = rng.standard_normal((20000, 50, 3)) ** 2
    share = 3 * v2[:, :, 0].sum(axis=1) / v2.sum(axis=(1, 2))
    assert share.var() == pytest.approx(errorbars.axis_share_var(3, 50), rel=0.03)


def test_virial_spread_of_flux_weighted_impulses():
    """<J^2>/<J>^2 = 4/pi: the normal relative speed at contact, a Gaussian component weighted by itself."""
    rng = np.random.default_rng(3)
    g = np.abs(rng.standard_normal(2_000_000))
    weight = g / g.sum()                       # flux weighting
    ratio = np.sum(weight * g * g) / np.sum(weight * g) ** 2
    assert ratio == pytest.approx(errorbars.VIRIAL_SPREAD, rel=3e-3)   # MC error about 1e-3


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_species_split_variance_by_monte_carlo(dim):
    """Var(sum_s c_s K_s/K)/mean^2 at fixed total energy, N Maxwellian components, against 200,000 draws."""
    rng = np.random.default_rng(dim)
    counts = np.array([30, 10, 20])
    parts = np.array([1.0, 0.7, 1.6])             # each species' part of the pressure, at equipartition
    per_energy = parts / (counts / counts.sum())  # c_s: pressure per unit share of the energy
    k = 200_000
    energies = np.stack([rng.chisquare(dim * c, k) for c in counts], axis=1)
    p = (energies / energies.sum(axis=1, keepdims=True)) @ per_energy
    # 200,000 draws: the variance is known to about 0.3 % (sqrt(2/k)), plus its kurtosis
    assert np.var(p) / np.mean(p) ** 2 == pytest.approx(errorbars.species_split_var(counts, parts, dim), rel=0.015)
    assert errorbars.species_split_var([50], [1.0], dim) == 0.0


def test_pair_spread_and_split_relaxation():
    """One species: spread 1, nothing to relax; equal masses: rate (8/D) (1/4) Z_12 (1/N_1 + 1/N_2)."""
    assert errorbars.pair_spread(3, [100], [1.0], [0.1]) == pytest.approx(1.0)
    assert errorbars.species_split_relaxation(3, [100], [1.0], [0.1], 1e3) == math.inf
    # two species identical but for their label: half the collisions are cross (N^2 against 2 N(N-1)/2)
    n, rate = 50, 1000.0
    cross = rate * n * n / (n * n + n * (n - 1))
    expected = 1.0 / ((8.0 / 2) * 0.25 * cross * (2.0 / n))
    assert errorbars.species_split_relaxation(2, [n, n], [1.0, 1.0], [0.1, 0.1], rate) == pytest.approx(expected)
    # a mixture's pairs differ: the virial's spread over pairs is above 1 (He:Xe at walls about 2)
    assert errorbars.pair_spread(3, [100, 100], [4.0, 131.3], [1.1, 2.2]) > 1.5
