"""Maxwell-Boltzmann speeds and the flux-weighted statistics of wall hits."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.theory._checks import _dim, _nonnegative, _out, _positive


# --------------------------------------------------------------------- Maxwell-Boltzmann


def _sphere_area(dim: int) -> float:
    """Area of the unit sphere in D dimensions: 2, 2 pi, 4 pi."""
    return 2.0 * math.pi ** (dim / 2.0) / math.gamma(dim / 2.0)


def speed_pdf(dim: int, speed, temperature, mass):
    """Maxwell-Boltzmann probability density of the speed |v| (s/m).

    f(v) = S_D v^(D-1) (m/(2 pi kT))^(D/2) exp(-m v^2/(2 kT)), S_D = 2, 2 pi, 4 pi;
    0 for v < 0. Equilibrium gas at temperature T (K), particle mass m (kg).
    """
    dim = _dim(dim)
    kt = K_B * _positive("temperature", temperature, "K")
    m = _positive("mass", mass, "kg")
    v = np.asarray(speed, dtype=float)
    vpos = np.maximum(v, 0.0)
    f = (_sphere_area(dim) * vpos ** (dim - 1) * (m / (2.0 * math.pi * kt)) ** (dim / 2.0)
         * np.exp(-m * vpos * vpos / (2.0 * kt)))
    return _out(np.where(v >= 0.0, f, 0.0))


def mean_speed(dim: int, temperature, mass):
    """Mean Maxwell-Boltzmann speed <|v|> = sqrt(2kT/m) Gamma((D+1)/2)/Gamma(D/2) (m/s).

    sqrt(2kT/(pi m)) in 1D, sqrt(pi kT/(2m)) in 2D, sqrt(8kT/(pi m)) in 3D.
    """
    dim = _dim(dim)
    kt = K_B * _positive("temperature", temperature, "K")
    m = _positive("mass", mass, "kg")
    with np.errstate(over="ignore"):  # inf beyond double precision, which the door refuses in one line
        return _out(np.sqrt(2.0 * kt / m) * math.gamma((dim + 1) / 2.0) / math.gamma(dim / 2.0))


def rms_speed(dim: int, temperature, mass):
    """Root-mean-square speed sqrt(<v^2>) = sqrt(D kT/m) (m/s)."""
    dim = _dim(dim)
    kt = K_B * _positive("temperature", temperature, "K")
    m = _positive("mass", mass, "kg")
    return _out(np.sqrt(dim * kt / m))


def most_probable_speed(dim: int, temperature, mass):
    """Speed at the maximum of :func:`speed_pdf`: sqrt((D-1) kT/m) (m/s); 0 in 1D."""
    dim = _dim(dim)
    kt = K_B * _positive("temperature", temperature, "K")
    m = _positive("mass", mass, "kg")
    return _out(np.sqrt((dim - 1) * kt / m))


def wall_hit_speed_pdf(dim: int, speed, temperature, mass):
    """Probability density (s/m) of the speed |v| of particles hitting a wall.

    Hits are weighted by the flux, i.e. by v_perp; averaged over directions this
    weights each speed by v: p(v) = v f(v)/<|v|>. 3D: (1/2)(m/kT)^2 v^3 e^(-mv^2/2kT);
    2D: sqrt(2/pi)(m/kT)^(3/2) v^2 e^(-mv^2/2kT); 1D: (m/kT) v e^(-mv^2/2kT).
    Equilibrium ideal gas (also hard spheres: the flux at contact is Maxwellian).
    This is the distribution of REBOND.RE_VIT.
    """
    v = np.asarray(speed, dtype=float)
    return _out(np.maximum(v, 0.0) * speed_pdf(dim, v, temperature, mass)
                / mean_speed(dim, temperature, mass))


def wall_hit_mean_speed(dim: int, temperature, mass, shared_components: int | None = None):
    """Mean speed of particles hitting a wall, <v^2>/<|v|> (m/s): what Q35 measures.

    In units of sqrt(kT/m): sqrt(pi/2) = 1.2533 (1D), sqrt(8/pi) = 1.5958 (2D),
    3 sqrt(pi/8) = 1.8800 (3D); ratio to the gas's mean speed pi/2, 4/pi, 3 pi/8.
    With ``shared_components`` = D N (a walled box of N particles at a fixed kinetic
    energy, k_B T = 2K/(D N) its kinetic temperature), times
    :func:`fixed_energy_hit_speed_factor` (1 - 1/(4 D N)): the microcanonical value.
    """
    canonical = np.asarray(rms_speed(dim, temperature, mass)) ** 2 / mean_speed(dim, temperature, mass)
    if shared_components is None:
        return _out(canonical)
    return _out(canonical * fixed_energy_hit_speed_factor(shared_components))


def fixed_energy_hit_speed_factor(components: int) -> float:
    """Mean wall-hit speed at a fixed kinetic energy over its canonical value at the same
    kinetic temperature: sqrt(2/M) Gamma((M + 1)/2)/Gamma(M/2) = 1 - 1/(4M) + O(1/M^2).

    M = D N velocity components share the energy K (walls: no conserved momentum). In the
    variables u = sqrt(m) v they are uniform on the sphere |u|^2 = 2K whatever the masses, so
    one particle's r = |u| has the density r^(D-1) (2K - r^2)^((M-D-2)/2). The flux weights a
    hit by |u_perp|, whose angular factor cancels in the mean hit speed <r^2>/<r>: against the
    Maxwellian's at k_B T = 2K/M, the ratio above, the same for every D and species (0.99377
    for 40 rods, 0.99917 for 100 spheres). Exact for an ergodic gas; the canonical value is
    biased high by 1/(4M) relative, a fifth of the error bar of a 1D run with 40 rods.
    """
    m = int(components)
    if m < 1:
        raise SceneError(f"a fixed-energy hit speed needs at least 1 velocity component, got {components!r}")
    return math.sqrt(2.0 / m) * math.exp(math.lgamma((m + 1) / 2.0) - math.lgamma(m / 2.0))


def rods_hit_speed_sampling_error(number, temperature, mass):
    """Spread (m/s) of Q35's mean wall-hit speed about its theory, 1D equal-mass rods.

    Equal-mass rods only exchange velocities, so the N speeds drawn at the
    start are kept forever and the time-averaged flux-weighted mean speed is
    that of the sample, sum v^2 / sum |v|. Compared with
    :func:`wall_hit_mean_speed` (1, T_kin) at the sample's own kinetic
    temperature, the difference over draws of N Maxwellian velocities has the
    standard deviation sqrt(pi (pi - 3)/4) sqrt(kT/m)/sqrt(N) = 0.3335 sqrt(kT/(m N))
    (delta method, to leading order in 1/N). No time average shrinks it.
    """
    n = _positive("number of rods", number, "")
    kt = K_B * _positive("temperature", temperature, "K")
    m = _positive("mass", mass, "kg")
    return _out(math.sqrt(math.pi * (math.pi - 3.0) / 4.0) * np.sqrt(kt / m) / np.sqrt(n))


def wall_hit_normal_speed_pdf(normal_speed, temperature, mass):
    """Probability density (s/m) of |v_perp| of wall hits, any D: Rayleigh (m/kT) v e^(-m v^2/(2kT)).

    The 1D case of :func:`wall_hit_speed_pdf`. This is the distribution of REBOND.RE_VP.
    """
    return wall_hit_speed_pdf(1, normal_speed, temperature, mass)


def wall_hit_mean_normal_speed(temperature, mass):
    """Mean |v_perp| of wall hits, sqrt(pi kT/(2m)) (m/s), any D; <v_perp^2>_hit = 2kT/m.

    The mean momentum given to a wall per hit is 2 m times this, sqrt(2 pi m kT).
    """
    return wall_hit_mean_speed(1, temperature, mass)


def wall_hit_rate(number_density, temperature, mass):
    """Hits per unit wall area per second, j = n <v_perp^+> = n sqrt(kT/(2 pi m)) (1/(m^(D-1) s)).

    n (1/m^D) is the density of centres at contact with the wall; = n<|v|>/4
    in 3D, n<|v|>/pi in 2D. For a dilute gas in a box, n = N/(L - 2R)^D and
    the wall's accessible area is (L - 2R)^(D-1).
    """
    n = _nonnegative("number density", number_density, "per m^D")
    return _out(n * np.asarray(mean_speed(1, temperature, mass)) / 2.0)
