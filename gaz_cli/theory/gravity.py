"""Uniform gravity: barometric profile, floor/ceiling pressures, the local-EOS hard-sphere model."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.geometry import ball_volume
from gaz_cli.theory._checks import _accessible, _dim, _nonnegative, _out, _positive, _species
from gaz_cli.theory.eos import BEST_MODEL, _MODEL_TABLE, _excess, compressibility_factor
from gaz_cli.theory.transport import enskog_collision_frequency


# --------------------------------------------------------------------- gravity


def barometric_height_pdf(height, temperature, mass, gravity, box_height, radius=0.0):
    """Probability density (1/m) of a centre's height z in a box of height H under gravity g.

    p(z) = exp(-(z - R)/lam) / (lam (1 - exp(-h/lam))), lam = kT/(m g), on the
    accessible heights R <= z <= H - R (h = H - 2R), 0 outside; uniform 1/h when
    g = 0. The density of centres is n(z) = N p(z) / A (A: lateral area, 1 in 1D).
    Non-interacting particles in equilibrium; z measured from the floor (m).
    Finite-N runs at fixed energy deviate at O(1/N).
    """
    z = np.asarray(height, dtype=float)
    kt = K_B * _positive("temperature", temperature, "K")
    m = _positive("mass", mass, "kg")
    g = _nonnegative("gravity", gravity, "m/s^2")
    big_h = _positive("box height", box_height, "m")
    r = _nonnegative("radius", radius, "m")
    h = _accessible("box height", big_h, r)
    s = m * g / kt                                   # 1/lam, 1/m
    with np.errstate(divide="ignore", invalid="ignore"):
        norm = np.where(s > 0.0, -np.expm1(-s * h) / np.where(s > 0.0, s, 1.0), h)  # = lam (1 - e^-h/lam)
    p = np.exp(-s * (z - r)) / norm
    return _out(np.where((z >= r) & (z <= big_h - r), p, 0.0))


def ideal_gravity_wall_pressures(dim: int, length, temperature, counts, radii, masses, gravity):
    """Floor and ceiling pressures of non-interacting particles under gravity (Pa, per full wall area L^(D-1)).

    Returns (floor, ceiling): sum_s N_s k_B T p_s(z) / L^(D-1) at the contact
    heights z = R_s and L - R_s, p_s from :func:`barometric_height_pdf`. Gravity
    pulls along the last axis; the side walls feel :func:`ideal_wall_pressure`.
    floor - ceiling = :func:`floor_minus_ceiling_pressure`.
    """
    dim = _dim(dim)
    length = _positive("box length", length, "m")
    kt = K_B * _positive("temperature", temperature, "K")
    c, r = _species(counts, radii)
    m = np.atleast_1d(_positive("mass", masses, "kg")).ravel()
    if m.size != c.size:
        raise SceneError(f"{c.size} counts for {m.size} masses: give one mass per species")
    area = length ** (dim - 1)
    floor = sum(ns * kt * barometric_height_pdf(rs, temperature, ms, gravity, length, rs)
                for ns, rs, ms in zip(c, r, m)) / area
    ceiling = sum(ns * kt * barometric_height_pdf(length - rs, temperature, ms, gravity, length, rs)
                  for ns, rs, ms in zip(c, r, m)) / area
    return _out(floor), _out(ceiling)


def chemical_potential_excess(dim: int, packing_fraction, model: str = "best"):
    """Excess chemical potential mu_ex/(k_B T) of the bulk hard-particle fluid, from Z (dimensionless).

    beta mu_ex(eta) = int_0^eta (Z(x) - 1)/x dx + Z(eta) - 1 (Gibbs-Duhem), by the
    trapezoidal rule on 4000 log-spaced points (relative error below 1e-6).
    1D Tonks: -ln(1 - eta) + eta/(1 - eta) exactly.
    """
    eta = np.atleast_1d(np.asarray(packing_fraction, dtype=float))
    top = float(eta.max()) if eta.size else 0.0
    if top <= 0.0:
        return _out(np.zeros_like(eta) if np.ndim(packing_fraction) else 0.0)
    grid = np.concatenate(([0.0], np.geomspace(1e-12, top, 4000)))
    excess = _excess(dim, grid, model)
    slope = np.where(grid > 0, excess / np.where(grid > 0, grid, 1.0), 0.0)
    slope[0] = slope[1]                                # (Z - 1)/eta -> B2 as eta -> 0
    integral = np.concatenate(([0.0], np.cumsum(0.5 * (slope[1:] + slope[:-1]) * np.diff(grid))))
    value = np.interp(eta, grid, integral) + _excess(dim, eta, model)
    return _out(value if np.ndim(packing_fraction) else value[0])


def hard_sphere_gravity_profile(dim: int, length, temperature, number, radius, mass, gravity,
                                model: str = "best", points: int = 2001):
    """Density of centres n(z) of N hard particles under gravity, in hydrostatic equilibrium.

    Local-density approximation: on the heights R <= z <= L - R the centres
    reach, ln n + beta mu_ex(eta(z)) + (z - R)/lam = const (lam = k_B T/(m g),
    :func:`chemical_potential_excess`), normalised to N = (L - 2R)^(D-1) int n dz.
    Returns (z, n): (points,) heights above the lowest centre z - R, m, and
    densities, 1/m^D. Blind to the walls' layering and the O(1/N) of a finite
    box; one species; gravity along the last axis.
    """
    dim = _dim(dim)
    length = float(_positive("box length", length, "m"))
    kt = K_B * float(_positive("temperature", temperature, "K"))
    n_total = float(_positive("number of particles", number, ""))
    r = float(_nonnegative("radius", radius, "m"))
    m = float(_positive("mass", mass, "kg"))
    g = float(_nonnegative("gravity", gravity, "m/s^2"))
    inner = float(_accessible("box length", length, r))
    lateral = inner ** (dim - 1)
    v = float(ball_volume(dim, r))
    z = np.linspace(0.0, inner, points)               # height above the lowest centre, m
    drop = m * g * z / kt                              # (z - R)/lam
    mean_n = n_total / (lateral * inner)
    upper = _MODEL_TABLE[BEST_MODEL[dim] if model == "best" else model][2] if v > 0 else 1.0
    eta_cap = min(upper, 0.999) * (1.0 - 1e-9)
    # tabulate beta mu(n) = ln n + beta mu_ex(eta) on a grid of densities, and invert it
    if v > 0:
        eta_grid = np.geomspace(1e-12, eta_cap, 3000)
        n_grid = eta_grid / v
        mu_grid = np.log(n_grid) + chemical_potential_excess(dim, eta_grid, model)
    else:
        n_grid = np.geomspace(mean_n * 1e-12, mean_n * 1e12, 3)
        mu_grid = np.log(n_grid)

    def profile(mu0):
        mu = mu0 - drop
        ln_n = np.interp(mu, mu_grid, np.log(n_grid))
        ln_n = np.where(mu < mu_grid[0], mu, ln_n)     # below the table: ideal, mu_ex ~ 0
        return np.exp(ln_n)

    def count(mu0):
        n = profile(mu0)
        return lateral * float(np.sum(0.5 * (n[1:] + n[:-1])) * (z[1] - z[0]))

    lo, hi = math.log(mean_n) - 60.0, float(mu_grid[-1])
    if count(hi) < n_total:
        raise SceneError(f"{n_total:g} particles do not fit under gravity below packing fraction "
                         f"{upper:g} ({model} model); lower --n or raise --length")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if count(mid) < n_total:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-13:
            break
    return z, profile(0.5 * (lo + hi))


def hard_sphere_gravity_wall_pressures(dim: int, length, temperature, number, radius, mass, gravity,
                                       model: str = "best", points: int = 2001):
    """Floor, ceiling and side-wall pressures of N hard particles under gravity (Pa per full wall area L^(D-1)).

    On the density profile n(z) of :func:`hard_sphere_gravity_profile`,
    P(z) = n k_B T Z(eta(z)) and

        floor = P(R) ((L - 2R)/L)^(D-1), ceiling = P(L - R) ((L - 2R)/L)^(D-1),
        side = (L - 2R)^(D-2) int P dz / L^(D-1)   (D > 1; 0 in 1D).

    Z = 1 gives :func:`ideal_gravity_wall_pressures`; floor - ceiling = N m g/L^(D-1)
    exactly (hydrostatics). At g = 0 the side value is :func:`hard_sphere_wall_pressure`.
    Like it, first order in the wall corrections (adsorption, layering) and
    blind to the O(1/N) of a finite box. One species; gravity along the last axis.
    """
    z, n = hard_sphere_gravity_profile(dim, length, temperature, number, radius, mass, gravity, model, points)
    dim = _dim(dim)
    length = float(length)
    kt = K_B * float(temperature)
    inner = float(z[-1])
    v = float(ball_volume(dim, float(radius)))
    eta = n * v
    p = n * kt * (compressibility_factor(dim, eta, model) if v > 0 else 1.0)
    scale = inner ** (dim - 1) / length ** (dim - 1)
    floor, ceiling = float(p[0] * scale), float(p[-1] * scale)
    side = (float(np.sum(0.5 * (p[1:] + p[:-1])) * (z[1] - z[0])) * inner ** (dim - 2) / length ** (dim - 1)
            if dim > 1 else 0.0)
    return floor, ceiling, side


def gravity_collision_frequency(dim: int, length, temperature, number, radius, mass, gravity,
                                model: str = "best", points: int = 2001):
    """Enskog collision frequency per particle averaged over the barometric profile (1/s).

    omega_bar = int n(z) omega(n(z)) dz / int n(z) dz, omega the
    :func:`enskog_collision_frequency` at the local density of
    :func:`hard_sphere_gravity_profile`: a particle low in the box, where the
    gas is denser, meets more partners, so the mean exceeds omega at the mean
    density N/(L - 2R)^D by <n^2>/<n>^2 (x/2) coth(x/2), x = m g (L - 2R)/(k_B T),
    in the dilute limit. One species, equilibrium; walls as in the profile.
    """
    z, n = hard_sphere_gravity_profile(dim, length, temperature, number, radius, mass, gravity, model, points)
    omega = np.asarray(enskog_collision_frequency(dim, n, 2.0 * float(radius), temperature, mass, model),
                       dtype=float)
    weight = n * omega
    return _out(float(np.sum(0.5 * (weight[1:] + weight[:-1])) / np.sum(0.5 * (n[1:] + n[:-1]))))


def gravity_energy_temperature(dim: int, length, energy, number, radius, mass, gravity,
                               model: str = "best") -> float:
    """Temperature (K) of N hard particles settled under gravity, from their total energy (J).

    ``energy`` E = K + sum m g (z - R): kinetic energy plus the potential one
    above the lowest centre height R, conserved by elastic dynamics; the
    settled gas shares it as (D/2) N k_B T + N m g <z - R>(T), the mean height
    on :func:`hard_sphere_gravity_profile`. Solved for T (monotonic: Illinois
    false position on 0 < T <= 2E/(D N k_B)). Equilibrium, one species.
    """
    dim = _dim(dim)
    e = float(_positive("energy", energy, "J"))
    n_total = float(_positive("number of particles", number, ""))
    m, g = float(_positive("mass", mass, "kg")), float(_nonnegative("gravity", gravity, "m/s^2"))

    def excess(t):
        z, n = hard_sphere_gravity_profile(dim, length, t, n_total, radius, mass, g, model)
        mean_z = float(np.sum(0.5 * (n[1:] * z[1:] + n[:-1] * z[:-1])) / np.sum(0.5 * (n[1:] + n[:-1])))
        return 0.5 * dim * n_total * K_B * t + n_total * m * g * mean_z - e

    lo, hi = 0.0, 2.0 * e / (dim * n_total * K_B)
    f_lo, f_hi = -e, excess(hi)
    if f_hi <= 0.0:                   # no potential energy (g = 0): all of it kinetic
        return hi
    side = 0
    for _ in range(100):
        t = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        f = excess(t)
        if f > 0.0:
            hi, f_hi = t, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            lo, f_lo = t, f
            if side == -1:
                f_hi *= 0.5
            side = -1
        if hi - lo < 1e-12 * hi or abs(f) < 1e-13 * e:
            break
    return float(t)


def floor_minus_ceiling_pressure(counts, masses, gravity, wall_area):
    """Exact time-averaged force balance: P_floor - P_ceiling = sum_s N_s m_s g / A (Pa).

    ``wall_area`` A = L^(D-1) (m^(D-1); 1 in 1D), the full area the SQL
    pressure divides by. Holds at any density, in or out of equilibrium on
    average (momentum balance), for elastic walls.
    """
    c = np.atleast_1d(_nonnegative("count", counts, "particles")).ravel()
    m = np.atleast_1d(_positive("mass", masses, "kg")).ravel()
    if m.size != c.size:
        raise SceneError(f"{c.size} counts for {m.size} masses: give one mass per species")
    g = _nonnegative("gravity", gravity, "m/s^2")
    area = _positive("wall area", wall_area, "m^(D-1)")
    return _out(np.sum(c * m) * g / area)
