"""Error bars of time averages: reblocking, plus the part of the initial draw no block can see.

A number ``gaz analyse`` measures (a wall's pressure, the mean speed of the
wall hits, a collision rate...) is a time average over the run. Its error
has two parts:

* fluctuations that decorrelate within the run (shot noise of single hits,
  density and velocity fluctuations lasting a few mean free times). The
  Flyvbjerg-Petersen reblocking (J. Chem. Phys. 91, 461 (1989)) sees them: the
  run is cut into 2^k equal time bins, pairs of neighbouring bins are merged
  again and again, and the standard error of the mean of the blocks is read
  at the smallest block length where it has stopped growing (the criterion of
  Lee, Filippi and Towler, Phys. Rev. B 84, 245117 (2011), as in ``pyblock``:
  B^3 > 2 n (s_B/s_1)^4 for blocks of B bins out of n);
* slow modes fixed by the initial draw of the N velocities: the share of the
  kinetic energy each axis holds (a wall's pressure follows its axis), the
  set of speeds (the mean wall-hit speed). They relax only by collisions,
  over a time tau of the order of the mean free time; in a run with few
  collisions per particle they stay frozen, every block sees the same value
  and reblocking reports nothing of their spread. Their variance over draws
  of N Maxwellian velocities has a closed form (``static_var``, at fixed total
  energy since theory uses the run's kinetic temperature); for a mode
  relaxing as exp(-t/tau) the variance of its average over a run of length T
  is ``static_var`` * g(T/tau), g(x) = 2 (x - 1 + e^-x)/x^2 (1 when the mode is
  frozen, 2 tau/T in a long run). Reblocking with M blocks of length b already
  sees static_var (g(b/tau) - g(T/tau))/(M - 1) of it, on average; the rest is
  added. The sum is exact for one exponential mode plus fast noise; in the two
  limits it is the full frozen spread (no collision) and the plain reblocking
  error (many collisions per block).

Pure NumPy (about 40 lines of reblocking): ``pyblock`` does the same
reblocking, but is a pandas-era package last released in 2017 and would add a
dependency for a loop of a dozen lines; the correction for frozen modes is
not in it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

BINS = 512
"""Time bins of the series handed to reblocking (a power of two)."""

ESTIMATOR = "reblocking (Flyvbjerg-Petersen) + frozen initial draw"
"""How the errors are made, as printed in the output."""


@dataclass(frozen=True)
class Estimate:
    """A time average and its standard error."""

    mean: float
    error: float
    n_eff: float
    """Effective number of independent samples: (variance of one bin's value)/error^2, bins of T/BINS."""
    block_s: float
    """Block length chosen by the reblocking, s (nan if no plateau was found)."""
    plateau: bool
    """Whether the reblocking found a plateau; if not, the largest block length was used."""
    frozen: float
    """Part of the error from the initial draw that blocks cannot see (same unit as error)."""


NAN_ESTIMATE = Estimate(math.nan, math.nan, math.nan, math.nan, False, math.nan)


def frozen_fraction(x: float) -> float:
    """g(x) = 2 (x - 1 + e^-x)/x^2: variance of the average over x relaxation times of a unit mode.

    1 for x -> 0 (frozen), 2/x for x -> infinity.
    """
    if not math.isfinite(x):
        return 0.0
    if x < 1e-4:
        return 1.0 - x / 3.0
    return 2.0 * (x - 1.0 + math.exp(-x)) / (x * x)


def reblock(series) -> tuple[float, int, bool]:
    """Standard error of the mean of ``series`` ((n,) floats, equal weights) from its reblocking.

    Returns (error, bins per block at the plateau, plateau found). Levels
    with fewer than 4 blocks are not used. From the plateau level on (the
    Lee-Filippi-Towler criterion; without one, the last two levels), the
    Flyvbjerg-Petersen estimates s_M^2 of the levels with M blocks are fitted
    by s_M^2 = V + a M; when the slope a is positive beyond three times its
    standard error and the last level is 16 times below the first (white
    noise does that by chance about once in a hundred runs), V, the variance of the mean, is returned as the error^2,
    else the plateau's s_M^2 (the Flyvbjerg-Petersen value; averaged over the
    levels from the plateau on, weighted by M - 1, which undoes the bias of
    picking the first level that passes the criterion). Why: for any noise of finite correlation time, the variance of
    the mean over a time t is b/t + a/t^2 (a < 0 for positive correlations,
    a > 0 for the end effects of periodic motion: a particle bouncing between
    two walls delivers its momentum at fixed intervals, and only the last,
    unfinished interval is random), and the expected s_M^2 is then exactly
    V + a M: a flat plateau is the special case a = 0, and the fit also
    reads a falling curve, where the plateau value alone would overestimate
    the error by a factor of up to sqrt(M). The result is kept above
    min_M s_M^2/(M + 1), its value for pure end effects.
    """
    x = np.asarray(series, dtype=float)
    n = x.size
    if n < 2:
        return math.nan, 1, False
    var, blocks, sizes = [], [], []
    size = 1
    while x.size >= 4:
        var.append(float(x.var(ddof=1) / x.size))
        blocks.append(x.size)
        sizes.append(size)
        if x.size % 2:
            x = x[:-1]
        x = 0.5 * (x[0::2] + x[1::2])
        size *= 2
    if not var:
        return float(np.std(series, ddof=1) / math.sqrt(n)), 1, False
    if var[0] == 0.0:
        return 0.0, 1, True
    start, plateau = max(len(var) - 2, 0), False
    for k, (v, b) in enumerate(zip(var, sizes)):
        if b ** 3 > 2.0 * n * (v / var[0]) ** 2:
            start, plateau = k, True
            break
    v = np.array(var[start:])
    m = np.array(blocks[start:], dtype=float)
    floor = float(np.min(v / (m + 1.0)))
    if v.size < 2:
        return math.sqrt(v[0]), sizes[start], plateau
    model = np.full_like(v, v[0])
    for _ in range(3):   # weighted least squares, weights 1/var(s^2) = (M - 1)/(2 model^2), reweighted
        weight = (m - 1.0) / np.maximum(model, floor) ** 2
        design = np.stack([np.ones_like(m), m], axis=1)
        cov = np.linalg.inv(design.T @ (design * weight[:, None]))
        intercept, slope = cov @ (design.T @ (weight * v))
        model = intercept + slope * m
    if slope > 3.0 * math.sqrt(cov[1, 1]) and v[-1] < v[0] / 16.0:   # a steeply falling curve: end effects
        return math.sqrt(max(float(intercept) + math.sqrt(cov[0, 0]), floor)), sizes[start], plateau
    weight = (m - 1.0)                                 # flat: the weighted mean of the plateau's levels
    return math.sqrt(float(np.sum(weight * v) / np.sum(weight))), sizes[start], plateau


LONG_BLOCKS = 4
"""Fewest blocks of the levels that read the white part of the noise when the ends are known (see _white_var)."""


def _levels(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flyvbjerg-Petersen levels: (s_M^2, M) for M = n, n/2, ... >= 4 blocks of the series x."""
    var, blocks = [], []
    while x.size >= 4:
        var.append(float(x.var(ddof=1) / x.size))
        blocks.append(x.size)
        if x.size % 2:
            x = x[:-1]
        x = 0.5 * (x[0::2] + x[1::2])
    return np.array(var), np.array(blocks, dtype=float)


def _white_var(y: np.ndarray, end_var: float) -> float:
    """Variance of the mean of y: the ends' known end_var plus the white part read from long blocks.

    A level of M blocks sees s_M^2 = V + end_var M once the blocks are longer
    than the noise's correlation time (V the white part, end_var M the two
    ends of each block). V is the (M - 1)-weighted mean of s_M^2 - end_var M
    over the levels of 4 to 16 blocks, not below 0; the error of the mean is
    V + end_var (one block: the run).
    """
    v, m = _levels(np.asarray(y, dtype=float))
    keep = (m >= LONG_BLOCKS) & (m <= 4 * LONG_BLOCKS)
    if not keep.any():
        return float(v[-1]) if v.size else math.nan
    white = float(np.sum((m[keep] - 1) * (v[keep] - end_var * m[keep])) / np.sum(m[keep] - 1))
    return max(white, 0.0) + end_var


def time_average(sums, weights=None, *, duration: float, static_var: float = 0.0,
                 relaxation_s: float = math.inf, end_var: float | None = None, white: bool = True) -> Estimate:
    """Time average over the run of a binned quantity, with its error.

    ``sums`` (n,) per time bin of equal width duration/n: the quantity's
    value in each bin (a pressure, a rate) when ``weights`` is None, whose
    mean is the average; or, with ``weights`` (n,) (e.g. hit counts), the bin
    sums of a ratio sum(sums)/sum(weights) (a mean speed of hits), linearised
    as (sums - mean weights)/<weights> before reblocking.
    ``static_var``: variance of the slow mode over draws of the initial
    velocities (unit^2); ``relaxation_s``: its relaxation time, s (inf: never
    relaxes). ``end_var``: None for the reblocking error (:func:`reblock`);
    else the variance (unit^2) the two ends of the run alone give the average,
    known in closed form (the momentum in flight at the start and at the end,
    :func:`end_variance`; 0 when there is none), and the error is end_var plus
    the rest of the noise read from the levels of 4 to 16 long blocks
    (:func:`_white_var`: noisier than the reblocking's plateau, but it sees
    the slow correlations the plateau misses); with ``white`` False (a run
    with too few collisions for their virial to matter), end_var alone.
    """
    s = np.asarray(sums, dtype=float)
    if weights is None:
        if s.size == 0:
            return NAN_ESTIMATE
        mean = float(s.mean())
        y = s
    else:
        w = np.asarray(weights, dtype=float)
        total = float(w.sum())
        if total <= 0:
            return NAN_ESTIMATE
        mean = float(s.sum() / total)
        y = (s - mean * w) / (total / w.size)
    n = y.size
    err, size, plateau = reblock(y)
    blocks = max(n // size, 2)            # the blocks whose spread the error reads
    if end_var is not None and end_var > 0.0 and not white:
        err, blocks = math.sqrt(end_var), 0
    elif end_var is not None and n >= 8 * LONG_BLOCKS:
        err, blocks = math.sqrt(_white_var(y, end_var)), 4 * LONG_BLOCKS
    if not math.isfinite(err):
        err = 0.0 if n >= 2 else math.nan
    frozen_var = 0.0
    if static_var > 0.0:
        x = duration / relaxation_s if relaxation_s > 0 else math.inf
        seen = (frozen_fraction(x / blocks) - frozen_fraction(x)) / (blocks - 1) if blocks >= 2 else 0.0
        frozen_var = static_var * max(0.0, frozen_fraction(x) - seen)
    total_err = math.sqrt(err * err + frozen_var)
    var1 = float(np.var(y, ddof=1)) if n > 1 else math.nan
    n_eff = var1 / total_err ** 2 if total_err > 0 and math.isfinite(var1) else math.nan
    return Estimate(mean, total_err, n_eff, size * duration / n if plateau else math.nan, plateau,
                    math.sqrt(frozen_var))


# --- the ends of the run -------------------------------------------------------------
def end_variance(masses_kt: float, half_width: float, duration: float, wall_measure: float, axes: int) -> float:
    """Variance of the time-averaged pressure summed over the walls of ``axes`` axes, from the run's ends alone.

    Along one axis, with G = sum m (x - c) v_x (c the box's centre, h the
    centres' half range (L - 2R)/2), the virial of the walls gives exactly
    h (I_low + I_high) = 2 K_x T + W_x - (G(T) - G(0)): the walls' impulse is
    the kinetic energy, the collisional virial W_x, and the change of G, a
    bounded end term. For centres uniform in the box and Maxwellian velocities
    Var G = sum m k_B T h^2/3 (``masses_kt`` = sum m k_B T), and G(0), G(T)
    are independent draws after a few crossings: the sum of the two walls'
    pressures (impulse/(T L^(D-1))) gets 2 sum m k_B T/(3 T^2 L^(2(D-1)))
    per axis. The collisionless box has nothing else (K_x frozen aside).
    """
    if not (duration > 0 and wall_measure > 0 and half_width > 0):
        return 0.0
    return axes * 2.0 * masses_kt / (3.0 * (duration * wall_measure) ** 2)


# --- the frozen modes' static variances -------------------------------------------------
def axis_share_var(dim: int, n: int) -> float:
    """Relative variance of one axis' kinetic energy D E_d/E at fixed total energy E, N Maxwellian particles.

    The N D components m v^2/kT are chi^2_1 whatever the masses, so E_d/E is
    Beta(N/2, (D-1) N/2): variance of D E_d/E = 2 (D - 1)/(D N + 2). 0 in 1D.
    A wall's pressure (on the walls of axis d) is proportional to E_d.
    """
    return 2.0 * (dim - 1) / (dim * n + 2.0)


HIT_SPEED_VAR = {1: math.pi * (math.pi - 3.0) / 4.0, 2: 0.06587, 3: 0.04703}
"""c_D: N Var(hit-weighted mean speed)/(kT/m) at fixed total energy, N frozen Maxwellian velocities.

Each particle keeps |v| and hits the walls of axis d at a rate |v_d|/(2(L - 2R)),
so Q35's mean is sum_i |v_i| sum_d |v_id| / sum_i sum_d |v_id|; the delta method with
the total energy regressed out gives c_D (1D: pi (pi - 3)/4 = 0.1112 exactly;
2D, 3D by Monte Carlo over 4 10^6 draws, +-0.1%, tests/test_errorbars.py recomputes them).
"""


def hit_speed_var(dim: int, n: int, kt_over_m: float) -> float:
    """Variance (m/s)^2 of Q35's mean wall-hit speed over draws of N frozen velocities (one species)."""
    return HIT_SPEED_VAR[dim] * kt_over_m / n


ANISOTROPY_RELAXATION = {1: math.inf, 2: 1.0, 3: 1.25}
"""Relaxation time of the axis energy shares, in mean free times 1/omega (omega: collisions per particle per s).

The traceless kinetic stress decays at p/eta (Maxwell): with the first
Chapman-Enskog viscosity of hard disks/spheres, p/eta = omega (2D) and
4 omega/5 (3D). 1D: one axis, nothing to relax.
"""

SPEED_RELAXATION = 1.5
"""Relaxation time of the set of speeds in mean free times (order one: a collision redraws both speeds).

Measured: over 100 seeds of the exam's scene (1.8 collisions per particle)
the spread of Q35's mean is that of a mode relaxing in 1.45 mean free times,
over 100 seeds of the collisionless box (0.9) it is still the full frozen spread
(benchmarks/error_coverage.py); 1.0 made the error 10-15% too small there.
"""
