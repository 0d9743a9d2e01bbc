"""Haff's cooling law for inelastic particles."""

from __future__ import annotations

import numpy as np

from gaz_cli.errors import SceneError
from gaz_cli.theory._checks import _dim, _nonnegative, _out, _positive, _show


# --------------------------------------------------------------------- inelastic cooling


def haff_cooling_rate(dim: int, restitution, collision_frequency):
    """1/t0 = (1 - e^2) omega0 / (2D) (1/s) of Haff's law.

    ``collision_frequency`` omega0 (1/s) per particle at the initial temperature,
    e.g. :func:`enskog_collision_frequency`; restitution e in [0, 1].
    """
    dim = _dim(dim)
    e = np.asarray(restitution, dtype=float)
    if not np.all((e >= 0.0) & (e <= 1.0)):
        raise SceneError(f"restitution must be in [0, 1], got {_show(restitution)}")
    omega = _nonnegative("collision frequency", collision_frequency, "1/s")
    return _out((1.0 - e * e) * omega / (2.0 * dim))


def haff_temperature(dim: int, time, initial_temperature, restitution, collision_frequency):
    """Haff's law T(t) = T0 / (1 + t/t0)^2 (K), t in s, omega0 per particle at T0.

    From dT/dt = -(1 - e^2) omega T / D with omega proportional to sqrt(T).
    Valid in the homogeneous cooling state only (before clustering), with
    small non-Gaussian corrections; e = 1 gives T = T0.
    """
    rate = haff_cooling_rate(dim, restitution, collision_frequency)
    t = _nonnegative("time", time, "s")
    t0 = _positive("initial temperature", initial_temperature, "K")
    return _out(t0 / (1.0 + t * rate) ** 2)


def haff_temperature_per_collision(dim: int, collisions_per_particle, initial_temperature, restitution):
    """Haff's law against collisions per particle tau: T = T0 exp(-(1 - e^2) tau / D) (K).

    tau = 2 * (number of collisions) / N (each collision counts for two
    particles). Same validity as :func:`haff_temperature`.
    """
    dim = _dim(dim)
    tau = _nonnegative("collisions per particle", collisions_per_particle, "")
    e = np.asarray(restitution, dtype=float)
    if not np.all((e >= 0.0) & (e <= 1.0)):
        raise SceneError(f"restitution must be in [0, 1], got {_show(restitution)}")
    t0 = _positive("initial temperature", initial_temperature, "K")
    return _out(t0 * np.exp(-(1.0 - e * e) * tau / dim))


def haff_collisions_per_particle(dim: int, time, restitution, collision_frequency):
    """Collisions per particle by time t under Haff's law: tau = omega0 t0 ln(1 + t/t0) (dimensionless).

    omega = omega0 sqrt(T/T0) = omega0/(1 + t/t0), integrated; with
    1/t0 = :func:`haff_cooling_rate`. Equals omega0 t for e = 1. Consistent
    with :func:`haff_temperature_per_collision`. Same validity as Haff's law.
    """
    rate = np.asarray(haff_cooling_rate(dim, restitution, collision_frequency), dtype=float)
    t = _nonnegative("time", time, "s")
    omega = np.asarray(collision_frequency, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(rate > 0.0, omega * np.log1p(t * rate) / np.where(rate > 0.0, rate, 1.0), omega * t)
    return _out(tau)
