"""Collisions: contact value g(sigma), Enskog collision frequency, mean free path, 1D rods."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.errors import SceneError
from gaz_cli.theory._checks import _dim, _nonnegative, _out, _positive
from gaz_cli.theory.eos import _excess, packing_fraction
from gaz_cli.theory.speeds import mean_speed


# --------------------------------------------------------------------- collisions


def contact_value(dim: int, packing_fraction, model: str = "best"):
    """Pair distribution at contact g(sigma+), from Z by the contact theorem Z = 1 + 2^(D-1) eta g.

    Dimensionless; g -> 1 as eta -> 0. Same validity range as the model.
    """
    excess = _excess(dim, packing_fraction, model)
    eta = np.asarray(packing_fraction, dtype=float)
    scale = 2.0 ** (_dim(dim) - 1) * eta
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.where(eta > 0.0, excess / np.where(eta > 0.0, scale, 1.0), 1.0)
    return _out(g)


def _cross_section(dim: int, diameter):
    """Collision cross-section of one particle: 1 (1D, a point target), 2 sigma (2D), pi sigma^2 (3D)."""
    return {1: 1.0, 2: 2.0, 3: math.pi}[dim] * np.asarray(diameter, dtype=float) ** (dim - 1)


def enskog_collision_frequency(dim: int, number_density, diameter, temperature, mass,
                               model: str = "best"):
    """Enskog collision frequency per particle, omega = n g(sigma) S_D <|v_rel|> (1/s).

    S_D = 1, 2 sigma, pi sigma^2 and <|v_rel|> is the Maxwell-Boltzmann mean
    speed at the reduced mass m/2, giving 2 n g sqrt(kT/(pi m)) (1D),
    2 n sigma g sqrt(pi kT/m) (2D), 4 n sigma^2 g sqrt(pi kT/m) (3D).
    One species; equilibrium fluid (exact in the dilute limit, and in 1D;
    good to a few percent in 2D and 3D up to the freezing density). Each
    collision involves two particles: the system's collision rate is N omega / 2.
    """
    dim = _dim(dim)
    eta = packing_fraction(dim, number_density, diameter)
    g = contact_value(dim, eta, model)
    v_rel = mean_speed(dim, temperature, _positive("mass", mass, "kg") / 2.0)  # reduced mass m/2
    return _out(np.asarray(number_density) * g * _cross_section(dim, diameter) * v_rel)


def pair_collision_density(dim: int, density_a, density_b, diameter_ab, temperature, mass_a, mass_b,
                           contact=1.0, same: bool = False):
    """Collisions between species a and b per unit volume and time, n_a n_b g_ab S_D <|v_rel|> (1/(m^D s)).

    S_D the cross-section of the contact distance sigma_ab = (sigma_a +
    sigma_b)/2 (1, 2 sigma, pi sigma^2), <|v_rel|> the Maxwell-Boltzmann mean
    speed at the reduced mass m_a m_b/(m_a + m_b), ``contact`` g_ab(sigma_ab)
    the pair distribution at contact; ``same`` (a = b) halves it (each pair
    once). Enskog's collision frequency of one species is 2/n of it. Divide a
    measured count by it (with contact = 1) to read g_ab.
    """
    dim = _dim(dim)
    ma, mb = _positive("mass", mass_a, "kg"), _positive("mass", mass_b, "kg")
    v_rel = mean_speed(dim, temperature, ma * mb / (ma + mb))
    rate = (np.asarray(density_a, dtype=float) * np.asarray(density_b, dtype=float) * np.asarray(contact)
            * _cross_section(dim, _positive("diameter", diameter_ab, "m")) * v_rel)
    return _out(0.5 * rate if same else rate)


def rods_collision_frequency(number, length, radius, temperature, mass):
    """Collisions per rod per second of N equal hard rods in a 1D box, Maxwellian velocities (1/s).

    omega = (N - 1) <|v_rel|> / (L - N sigma), <|v_rel|> = 2 sqrt(k_B T/(pi m)):
    the Maxwellian average of :func:`rods_collision_frequency_exact`. Walls
    at 0 and L or a periodic ring of length L alike. It is the Enskog value
    (bulk, n = N/L, g = 1/(1 - eta)) times (N - 1)/N.
    """
    n = _positive("number of rods", number, "")
    length = _positive("box length", length, "m")
    sigma = 2.0 * _nonnegative("radius", radius, "m")
    free = length - n * sigma
    if not np.all(free > 0.0):
        raise SceneError("the rods fill the box: N * 2R must be below the box length")
    v_rel = mean_speed(1, temperature, _positive("mass", mass, "kg") / 2.0)
    return _out((n - 1.0) * v_rel / free)


def rods_collision_frequency_exact(velocities, length, radius):
    """Exact time-averaged collisions per rod per second of N equal hard rods between walls (1/s).

    Ghost picture (physics.md section 1): equal-mass collisions swap velocities,
    so N free points with the fixed speeds |v_k| move in L_free = L - N sigma;
    a collision is two ghosts crossing. Unfolded on a circle of 2 L_free, the
    ghosts of speeds u and w cross at the rate (|u - w| + |u + w|)/(2 L_free)
    = max(|u|, |w|)/L_free, so omega = (2/N) sum_{i<j} max(|v_i|, |v_j|)/L_free.
    ``velocities`` (N,) or (N, 1) m/s; time average over times much longer
    than 2 L_free / min|v|. (A periodic ring gives |u - w|/L_free per pair instead.)
    """
    v = np.sort(np.abs(np.asarray(velocities, dtype=float).reshape(-1)))
    if not np.all(np.isfinite(v)):
        raise SceneError("velocities must be finite")
    length = _positive("box length", length, "m")
    sigma = 2.0 * _nonnegative("radius", radius, "m")
    free = length - v.size * sigma
    if not free > 0.0:
        raise SceneError("the rods fill the box: N * 2R must be below the box length")
    # the k-th smallest speed (k = 0..N-1) is the larger one of k pairs
    pairs_max = float(np.sum(v * np.arange(v.size)))
    return _out(2.0 * pairs_max / (v.size * free))


def mean_free_path(dim: int, number_density, diameter, model: str = "best"):
    """Mean free path l = <|v|>/omega = 1/(sqrt(2) n g S_D) (m).

    3D: 1/(sqrt(2) pi n sigma^2 g); 2D: 1/(2 sqrt(2) n sigma g); 1D: 1/(sqrt(2) n g).
    The sqrt(2) is <|v_rel|>/<|v|> (reduced mass m/2). Independent of T and m.
    """
    dim = _dim(dim)
    eta = packing_fraction(dim, number_density, diameter)
    n = _positive("number density", number_density, "per m^D")
    g = contact_value(dim, eta, model)
    return _out(1.0 / (math.sqrt(2.0) * n * g * _cross_section(dim, diameter)))
