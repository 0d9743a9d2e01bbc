"""The error estimator: reblocking and the frozen initial draw (gaz_cli.analysis.errorbars)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gaz_cli.analysis import errorbars


def test_reblocking_of_correlated_noise_covers_the_truth():
    """AR(1) series (correlation time 10 bins): the error's mean is within 15% of the exact one.

    Exact: sd of the mean of n AR(1) values ~ sqrt((1+phi)/(1-phi)/(1-phi^2)/n) for n >> 1/(1-phi);
    the plain standard error would be 4.4 times too small.
    """
    rng = np.random.default_rng(7)
    phi, n, runs = 0.9, 512, 300
    exact = math.sqrt((1 + phi) / (1 - phi) / (1 - phi ** 2) / n)
    errors = []
    for _ in range(runs):
        eps = rng.standard_normal(n)
        x = np.empty(n)
        x[0] = eps[0] / math.sqrt(1 - phi ** 2)
        for i in range(1, n):
            x[i] = phi * x[i - 1] + eps[i]
        errors.append(errorbars.reblock(x)[0])
    assert np.mean(errors) == pytest.approx(exact, rel=0.15)


def test_end_effects_of_periodic_motion_are_read_from_the_falling_curve():
    """x_i = e_(i+1) - e_i (a periodic train: the mean telescopes to (e_n - e_0)/n): error ~ sqrt(2)/n, not 1/sqrt(n)."""
    rng = np.random.default_rng(3)
    n = 512
    errors = [errorbars.reblock(np.diff(rng.standard_normal(n + 1)))[0] for _ in range(200)]
    exact = math.sqrt(2) / n
    assert np.median(errors) < 5 * exact          # the plateau value would be ~ sqrt(2/n) = 16 times larger
    assert np.median(errors) > 0.5 * exact


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
