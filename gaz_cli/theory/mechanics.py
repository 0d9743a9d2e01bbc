"""What a run measures, in closed form: wall impulse, virial pressure, kinetic temperature."""

from __future__ import annotations

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.theory._checks import _dim, _nonnegative, _out, _positive, _show


# --------------------------------------------------------------------- periodic boxes


def wall_impulse(mass, normal_speed, wall_restitution=1.0):
    """Momentum a wall receives from one bounce, (1 + e_w) m |v_perp| (kg m/s).

    ``normal_speed`` |v_perp| is the speed towards the wall before the bounce
    (REBOND.RE_VP), ``wall_restitution`` e_w the wall's restitution: the
    particle leaves at e_w |v_perp|. 2 m |v_perp| for the exam's elastic walls.
    The one copy of the formula: the SQL of Q36 and of the pressure per wall
    (sql/q36_momentum_per_wall.sql, sql/pressure_per_wall.sql) writes the same.
    """
    e = np.asarray(wall_restitution, dtype=float)
    return (1.0 + e) * np.asarray(mass, dtype=float) * np.abs(np.asarray(normal_speed, dtype=float))


def virial_pressure(dim: int, number, temperature, volume, virial, duration):
    """Pressure of a periodic box from the collision virial: P = (N k_B T + W/(D tau)) / V (Pa).

    ``virial`` W = sum over collisions of |J| sigma_ij (kg m^2/s), J the impulse
    exchanged; ``duration`` tau (s); ``volume`` L^D (m^D); ``temperature`` the
    kinetic temperature (K). Exact time average for hard particles; for equal
    elastic masses |J| = m |v_ij . r_hat|.
    """
    dim = _dim(dim)
    n = _nonnegative("number of particles", number, "")
    t = _positive("temperature", temperature, "K")
    v = _positive("volume", volume, "m^D")
    w = _nonnegative("virial", virial, "kg m^2/s")
    tau = _positive("duration", duration, "s")
    return _out((n * K_B * t + w / (dim * tau)) / v)


def kinetic_temperature(dim: int, kinetic_energy, number, periodic: bool = False, drift_energy=0.0):
    """Temperature (K) from the total kinetic energy K (J): k_B T = 2K/(D N).

    With ``periodic`` the total momentum P is conserved: its D degrees of freedom
    are not thermal, k_B T = 2 (K - P^2/(2M))/(D (N - 1)), ``drift_energy``
    P^2/(2M) (J; 0 when the momentum was removed at the start, as gaz does for
    the velocities it draws: :func:`gaz_cli.placement.initial.initial_state`; an explicit
    initial state keeps its own). A single particle keeps its momentum and counts
    its D degrees of freedom, periodic or not (removing it would stop the particle).
    """
    dim = _dim(dim)
    k = _nonnegative("kinetic energy", kinetic_energy, "J")
    n = np.asarray(number, dtype=float)
    if not np.all(n >= 1.0):
        raise SceneError(f"kinetic temperature needs at least 1 particle, got {_show(number)}")
    drift = _nonnegative("drift energy", drift_energy, "J")
    if periodic:
        k = np.where(n > 1.0, np.maximum(k - drift, 0.0), k)
    dof_n = np.where(n > 1.0, n - 1.0, n) if periodic else n
    return _out(2.0 * k / (dim * dof_n * K_B))
