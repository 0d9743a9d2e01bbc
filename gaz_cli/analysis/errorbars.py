"""Error bars of time averages: an autocorrelation window, plus the part of the initial draw no block can see.

A number ``gaz analyse`` measures (a wall's pressure, the mean speed of the
wall hits, a collision rate...) is a time average over the run. Its error
has two parts:

* fluctuations that decorrelate within the run (shot noise of single hits,
  density and velocity fluctuations lasting a few mean free times). The
  integrated autocorrelation time with Sokal's automatic window (Madras &
  Sokal 1988; emcee.autocorr.integrated_time) sees them
  (:func:`autocorrelation_error`): the sum of the autocovariances stops at the
  first lag W >= 5 tau(W), corrected for the sample mean's own spread, floored
  at the naive standard error; then the spread of 64 to 4 long blocks checks
  it for slow modes the window cut off (an F test; where one shows, that
  level's variance and its M - 1 degrees of freedom are kept). The error
  carries its effective degrees of freedom (about n/(2W + 1)): a deviation is
  judged on Student's t (:func:`normal_equivalent`) and withheld below
  :data:`MIN_DOF`. On synthetic series (tests/test_errorbars.py: white noise,
  AR(1) at phi 0.2/0.5/0.9, a sum of two AR(1), a slow oscillation) |z| > 4 and
  an error below half the truth each occur in at most 0.1 % of series;
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

NumPy and scipy.stats (already a dependency): ``emcee.autocorr`` holds the same
window in a dozen lines, but works on one series at a time, has no correction
for the sample mean nor degrees of freedom, and would add a dependency for
them; ``pyblock`` (reblocking, last released in 2017) is what this replaced.
Neither has the correction for frozen modes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

BINS = 512
"""Time bins of the series handed to reblocking (a power of two)."""

ESTIMATOR = "autocorrelation window (Sokal) + long-block check + frozen initial draw; Student t"
"""How the errors are made, as printed in the output."""


@dataclass(frozen=True)
class Estimate:
    """A time average and its standard error."""

    mean: float
    error: float
    n_eff: float
    """Effective number of independent samples: (variance of one bin's value)/error^2, bins of T/BINS."""
    window_s: float
    """Longest lag of the autocorrelation sum (Sokal's window), s (nan where a closed form or long
    blocks gave the error)."""
    frozen: float
    """Part of the error from the initial draw that blocks cannot see (same unit as error)."""
    dof: float = math.inf
    """Effective degrees of freedom of the error (inf: closed forms only): the error's own relative
    standard deviation is about 1/sqrt(2 dof); a deviation is judged on Student's t with dof."""


NAN_ESTIMATE = Estimate(math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)


def frozen_fraction(x: float) -> float:
    """g(x) = 2 (x - 1 + e^-x)/x^2: variance of the average over x relaxation times of a unit mode.

    1 for x -> 0 (frozen), 2/x for x -> infinity.
    """
    if not math.isfinite(x):
        return 0.0
    if x < 1e-4:
        return 1.0 - x / 3.0
    return 2.0 * (x - 1.0 + math.exp(-x)) / (x * x)


WINDOW_C = 5.0
"""Sokal's windowing constant: the autocorrelation sum stops at the first lag W >= WINDOW_C tau_int(W)
(emcee.autocorr's default; Madras & Sokal, J. Stat. Phys. 50, 109 (1988))."""

SLOW_LEVELS = (64, 32, 16, 8, 4)
"""Numbers of long blocks whose spread checks the windowed error for slow modes (coarsest last)."""

DRIFT_P = 0.05
"""False-alarm rate of each long-block check (a false alarm only swaps in a noisier, unbiased error)."""

MIN_DOF = 4.0
"""Fewest effective degrees of freedom of an error for a deviation to be printed (below: withheld)."""


def _autocovariances(d: np.ndarray) -> np.ndarray:
    """(..., n) autocovariances sum_i d_i d_(i+t) / n of centred rows ``d`` (..., n), lags 0..n-1, by FFT."""
    n = d.shape[-1]
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(d, n=size, axis=-1)
    return np.fft.irfft(f * np.conj(f), n=size, axis=-1)[..., :n] / n


def autocorrelation_error(series, c: float = WINDOW_C):
    """Standard error of the mean of a correlated series, its degrees of freedom and the window.

    ``series`` (n,) or (k, n) rows. The variance of the mean is sum_t gamma(t)/n over all
    lags; the sum S(W) = gamma(0) + 2 sum_{t=1..W} gamma(t) of the sample autocovariances
    (centred on the sample mean) stops at Sokal's window, the first W with W >= c tau(W),
    tau(W) = S(W)/gamma(0) (at most n/4: without a window there, W = n/4). The sample mean's
    own spread biases S(W) low by (2W + 1)/n of the truth: error^2 = S(W)/(n - 2W - 1),
    W = 0 giving the naive s^2/n. The error is floored at the naive standard error (positive
    correlations only raise it; where the data know better, e.g. the momentum in flight at a
    wall, the callers add their closed forms instead). Its relative variance is about
    2 (2W + 1)/n (Madras-Sokal), hence ``dof`` = n/(2W + 1) effective degrees of freedom.
    Returns (error, dof, W), floats or (k,) arrays.
    """
    y = np.asarray(series, dtype=float)
    single = y.ndim == 1
    y = np.atleast_2d(y)
    k, n = y.shape
    if n < 2:
        out = np.full(k, np.nan)
        return (out[0], out[0], out[0]) if single else (out, out, out)
    d = y - y.mean(axis=1, keepdims=True)
    g = _autocovariances(d)
    g0 = g[:, 0]
    s = g0[:, None] + 2.0 * np.cumsum(g[:, 1:], axis=1)          # S(W), W = 1..n-1
    lags = np.arange(1, n, dtype=float)
    top = max(n // 4, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = s / g0[:, None]
        ok = lags[None, :top] >= c * tau[:, :top]
    found = ok.any(axis=1)
    w = np.where(found, np.argmax(ok, axis=1), top - 1) + 1          # window, lags
    w = np.where(g0 > 0.0, w, 0)                                      # a constant: nothing to sum
    sw = np.where(w > 0, s[np.arange(k), np.maximum(w, 1) - 1], g0)
    denominator = np.maximum(n - 2.0 * w - 1.0, 1.0)
    naive = g0 * n / (n - 1.0) / n
    var = np.maximum(sw / denominator, naive)
    err = np.sqrt(var)
    dof = n / (2.0 * w + 1.0)
    # long blocks: a slow drift or mode too weak at short lags for the window shows in the spread of
    # a few long block means; where it is beyond the window's estimate (F test at DRIFT_P), that
    # level's variance of the mean and its M - 1 degrees of freedom are kept instead
    from scipy import stats

    for m in SLOW_LEVELS:
        if n < 2 * m:
            continue
        b = y[:, : n - n % m].reshape(k, m, -1).mean(axis=2)
        var_m = b.var(axis=1, ddof=1) / m
        with np.errstate(invalid="ignore", divide="ignore"):
            slow = var_m / var > stats.f.isf(DRIFT_P, m - 1, dof)
        var = np.where(slow, var_m, var)
        dof = np.where(slow, np.minimum(dof, m - 1.0), dof)
    err = np.sqrt(var)
    zero = g0 <= 0.0
    err = np.where(zero, 0.0, err)
    if single:
        return float(err[0]), float(dof[0]), int(w[0])
    return err, dof, w


def combined_dof(parts) -> float:
    """Welch-Satterthwaite degrees of freedom of a sum of variances: ``parts`` of (variance, dof),
    dof inf for a closed form. inf when nothing is estimated, nan when the sum is 0."""
    total = sum(v for v, _ in parts)
    denominator = sum(v * v / k for v, k in parts if math.isfinite(k) and k > 0 and v > 0)
    if total <= 0.0:
        return math.nan
    return math.inf if denominator == 0.0 else total * total / denominator


def normal_equivalent(t, dof):
    """The deviation t (in standard errors with ``dof`` degrees of freedom) as the normal deviate of the
    same tail probability: Student's t judged as a normal z (t itself when dof is inf; NaN below MIN_DOF)."""
    t = np.asarray(t, dtype=float)
    dof = np.broadcast_to(np.asarray(dof, dtype=float), t.shape)
    from scipy import stats

    with np.errstate(invalid="ignore"):
        tail = stats.t.sf(np.abs(t), np.where(np.isfinite(dof), dof, 1.0))
        z = np.where(np.isfinite(dof), np.sign(t) * stats.norm.isf(tail), t)
    z = np.where(dof >= MIN_DOF, z, np.nan)
    # far tails: sf underflows to 0 (isf inf); keep the sign and the size of t there
    z = np.where(np.isinf(z), t, z)
    return float(z) if z.ndim == 0 else z


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


def _white_var(y: np.ndarray, end_var: float) -> tuple[float, float]:
    """Variance of the mean of y: the ends' known end_var plus the white part read from long blocks,
    and its effective degrees of freedom.

    A level of M blocks sees s_M^2 = V + end_var M once the blocks are longer
    than the noise's correlation time (V the white part, end_var M the two
    ends of each block). V is the (M - 1)-weighted mean of s_M^2 - end_var M
    over the levels of 4 to 16 blocks, not below 0; the error of the mean is
    V + end_var (one block: the run). Degrees of freedom: the white part's, 4 LONG_BLOCKS - 1
    (its widest level's), combined with the exact end_var by Welch-Satterthwaite; this leaves
    out the noise of the subtraction (about 2 (16 end_var)^2/15 where V is small), which the
    coverage over seeds (tests/test_coverage.py) has calibrated in rms but which spreads the
    error over seeds (issue 38: up to a factor 5 for 2D boxes at packing 0.2).
    """
    v, m = _levels(np.asarray(y, dtype=float))
    keep = (m >= LONG_BLOCKS) & (m <= 4 * LONG_BLOCKS)
    if not keep.any():
        return (float(v[-1]), float(m[-1] - 1)) if v.size else (math.nan, math.nan)
    white = float(np.sum((m[keep] - 1) * (v[keep] - end_var * m[keep])) / np.sum(m[keep] - 1))
    white = max(white, 0.0)
    return white + end_var, combined_dof([(white, 4.0 * LONG_BLOCKS - 1.0), (end_var, math.inf)])


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
    relaxes). ``end_var``: None for the windowed autocorrelation error (:func:`autocorrelation_error`);
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
    err, dof, window = autocorrelation_error(y)
    window_s = window * duration / n if n >= 2 else math.nan
    blocks = max(int(dof), 2)              # about as many independent stretches as the error reads
    if end_var is not None and end_var > 0.0 and not white:
        err, dof, blocks, window_s = math.sqrt(end_var), math.inf, 0, math.nan
    elif end_var is not None and end_var > 0.0 and n >= 8 * LONG_BLOCKS:
        var, dof = _white_var(y, end_var)
        err, blocks, window_s = math.sqrt(var), 4 * LONG_BLOCKS, math.nan
    if not math.isfinite(err):
        err = 0.0 if n >= 2 else math.nan
    frozen_var = 0.0
    if static_var > 0.0:
        x = duration / relaxation_s if relaxation_s > 0 else math.inf
        seen = (frozen_fraction(x / blocks) - frozen_fraction(x)) / (blocks - 1) if blocks >= 2 else 0.0
        frozen_var = static_var * max(0.0, frozen_fraction(x) - seen)
    total_err = math.sqrt(err * err + frozen_var)
    dof = combined_dof([(err * err, dof), (frozen_var, math.inf)])
    var1 = float(np.var(y, ddof=1)) if n > 1 else math.nan
    n_eff = var1 / total_err ** 2 if total_err > 0 and math.isfinite(var1) else math.nan
    return Estimate(mean, total_err, n_eff, window_s, math.sqrt(frozen_var), dof)


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


# --- the mean pressure at walls in closed form ----------------------------------------------
VIRIAL_SPREAD = 4.0 / math.pi
"""<J^2>/<J>^2 of the impulses of hard-sphere collisions in equilibrium, any dimension.

A collision's impulse is mu g_n, g_n the normal relative speed at contact, whose
distribution is the flux-weighted normal component of a Gaussian, g_n exp(-mu g_n^2/2kT):
a Rayleigh law, <g_n^2>/<g_n>^2 = 4/pi.
"""


def collision_virial_var(pressure: float, virial: float, kinetic_impulse: float, collisions: float,
                         pairs: float = 1.0) -> float:
    """Variance of the walls' mean pressure from the noise of its collisions' virial, unit^2.

    The walls' impulse summed over the 2D walls is (2 K T + W - (G(T) - G(0)))/h
    (:func:`end_variance`): with the kinetic energy K fixed, the collisions' virial
    W = sum |J| sigma is the only noise besides the ends. Taken as a compound Poisson
    sum of ``collisions`` independent impulses of spread :data:`VIRIAL_SPREAD`,
    Var W = (4/pi) W^2/C, and the pressure, ``pressure`` = (2 K T + W)/(h T L^(D-1) 2D),
    gets pressure^2 (4/pi)/C (W/(2 K T + W))^2. ``kinetic_impulse`` 2 K T and ``virial``
    W in kg m^2/s. In a mixture the pairs of species differ in impulse and distance:
    Var W = (4/pi) sum_ij W_ij^2/C_ij, ``pairs`` = sum_ij (W_ij/W)^2/(C_ij/C) (>= 1,
    :func:`pair_shares`; He:Xe at packing 0.05: 2.2). Measured against the seeds' spread less
    the ends' (40 seeds, 2026-11-28): 0.7 of it in a dilute 3D box (29 collisions per
    particle), 1.0-1.1 in 2D boxes at packing 0.2-0.45.
    """
    if not (collisions and collisions > 0 and math.isfinite(virial) and virial > 0 and kinetic_impulse > 0):
        return 0.0
    share = virial / (kinetic_impulse + virial)
    return pressure * pressure * VIRIAL_SPREAD * pairs * share * share / collisions


def species_split_var(counts, pressures, dim: int) -> float:
    """Relative variance of the walls' mean pressure over draws of how the species share the kinetic energy.

    ``counts`` (S,) N_s; ``pressures`` (S,) each species' part of the mean pressure (any unit).
    At fixed total energy the shares K_s/K of N Maxwellian particles are Dirichlet(D N_s/2);
    a species' part follows its own kinetic energy (its centres reach a box L - 2R_s of their
    own, its collisions' virial its own speeds), so the mean P = sum_s P_s varies by
    Var P/P^2 = (sum_s P_s^2/f_s - P^2)/(P^2 (D N/2 + 1)), f_s = N_s/N. 0 for one species.
    """
    counts = np.asarray(counts, dtype=float)
    pressures = np.asarray(pressures, dtype=float)
    total, n = float(pressures.sum()), float(counts.sum())
    if counts.size < 2 or total <= 0.0 or n <= 0.0:
        return 0.0
    shares = counts / n
    spread = max(float(np.sum(pressures ** 2 / shares)) - total * total, 0.0)
    return spread / (total * total * (dim * n / 2.0 + 1.0))


def pair_shares(dim: int, counts, masses, radii):
    """Each pair of species i <= j: (i, j, its share of the collisions, its share of the virial), (P,) arrays.

    Low density: pair i-j collides at a rate N_i N_j sigma_ij^(D-1) sqrt(k_B T/mu_ij) (N_i (N_i - 1)/2
    for i = j), with a mean impulse mu_ij <g_n> ~ sqrt(mu_ij k_B T) at distance sigma_ij = R_i + R_j.
    """
    n, m, r = (np.asarray(a, dtype=float) for a in (counts, masses, radii))
    i, j = np.triu_indices(n.size)
    mu = m[i] * m[j] / (m[i] + m[j])
    sigma = r[i] + r[j]
    rate = n[i] * np.where(i == j, np.maximum(n[j] - 1.0, 0.0) / 2.0, n[j]) * sigma ** (dim - 1) / np.sqrt(mu)
    virial = rate * sigma * np.sqrt(mu)
    if rate.sum() <= 0.0 or virial.sum() <= 0.0:
        return i, j, np.zeros(i.size), np.zeros(i.size)
    return i, j, rate / rate.sum(), virial / virial.sum()


def pair_spread(dim: int, counts, masses, radii) -> float:
    """sum_ij (W_ij/W)^2/(C_ij/C) over the pairs of species (:func:`pair_shares`): 1 for one species."""
    _, _, c, w = pair_shares(dim, counts, masses, radii)
    keep = c > 0
    return float(np.sum(w[keep] ** 2 / c[keep])) if keep.any() else 1.0


def species_split_relaxation(dim: int, counts, masses, radii, collision_rate: float) -> float:
    """Relaxation time (s) of the species' kinetic-energy split, from their cross collisions.

    A collision of an i with a j gives the i on average -4 m_i m_j/(m_i + m_j)^2 k_B (T_i - T_j)
    (hard spheres, Maxwellians, any D: the impulse times the centre-of-mass velocity, whose
    correlation with the relative velocity is k_B (T_i - T_j)/(m_i + m_j), over the
    flux-weighted <g_n^2> = 2 k_B T/mu). With Z_ij cross collisions per second, T_i - T_j
    relaxes at rate (8/D) sum_(i<j) m_i m_j/(m_i + m_j)^2 Z_ij (1/N_i + 1/N_j). ``collision_rate``
    (all pairs, per s) is shared among the pairs by :func:`pair_shares`. inf without cross
    collisions.
    """
    n, m = np.asarray(counts, dtype=float), np.asarray(masses, dtype=float)
    if n.size < 2 or not collision_rate > 0:
        return math.inf
    i, j, share, _ = pair_shares(dim, counts, masses, radii)
    cross = i != j
    lam = (8.0 / dim) * float(np.sum((m[i] * m[j] / (m[i] + m[j]) ** 2 * collision_rate * share
                                      * (1.0 / n[i] + 1.0 / n[j]))[cross]))
    return 1.0 / lam if lam > 0 else math.inf
