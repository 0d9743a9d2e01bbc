"""Equations of state of one-component hard rods, disks and spheres: Z(eta) and the bulk pressure.

Tonks (1D, exact), Henderson and Kolafa-Rottner (2D), Carnahan-Starling and
Kolafa-Labik-Malijevsky (3D); the dispatcher :func:`compressibility_factor`; densities."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.geometry import ball_volume
from gaz_cli.theory._checks import _dim, _nonnegative, _out, _packing, _positive


KOLAFA_ROTTNER_MAX_PACKING = math.pi * 0.88 / 4.0
"""Upper end of the Kolafa-Rottner rho_max = 0.88 fit: eta = pi*0.88/4 = 0.69115."""

KLM_MAX_PACKING = 0.55
"""Upper end accepted for KLM: MD data reach eta = 0.539 (rho sigma^3 = 1.03); the
smooth fit is used a little beyond, to the melting point 0.545."""

# Kolafa & Rottner, Mol. Phys. 104, 3435 (2006), fit rho_max = 0.88:
# Z = sum_i A_i x^i, x = eta/(1-eta). Index = power of x.
_KR_COEFFICIENTS = np.zeros(20)
_KR_COEFFICIENTS[:13] = [
    1.0, 2.0, 1.12801775, 0.00181895291, -0.0526134737, 0.0504951668,
    -0.0325433846, 0.0133946531, 0.00174265604, -0.00944632202,
    0.00851111768, -0.0035963525, 0.000577345106,
]
_KR_COEFFICIENTS[19] = -1.06399127e-7

# Kolafa, Labik & Malijevsky, PCCP 6, 2335 (2004): Z = sum_i C_i Y^i, Y = eta/(1-eta).
_KLM_COEFFICIENTS = np.zeros(23)
_KLM_COEFFICIENTS[:9] = [
    1.0, 4.0, 6.0, 2.3647684, -0.8698551, 1.1062803, -1.1014221, 0.66605866, -0.03633431,
]
_KLM_COEFFICIENTS[10] = -0.20965164
_KLM_COEFFICIENTS[14] = 0.10555569
_KLM_COEFFICIENTS[22] = -0.00872380


# --------------------------------------------------------------------- densities


def particle_volume(dim: int, radius):
    """Volume of one particle of ``radius`` (m): m in 1D, m^2 in 2D, m^3 in 3D."""
    dim = _dim(dim)
    return _out(ball_volume(dim, _nonnegative("radius", radius, "m")))


def packing_fraction(dim: int, number_density, diameter):
    """eta = n * v_D(sigma/2) (dimensionless) from n (1/m^D) and sigma (m)."""
    dim = _dim(dim)
    n = _nonnegative("number density", number_density, "per m^D")
    sigma = _nonnegative("diameter", diameter, "m")
    return _out(n * ball_volume(dim, sigma / 2.0))


def density_from_packing(dim: int, packing_fraction, diameter):
    """Number density n (1/m^D) of particles of ``diameter`` sigma (m) at packing fraction eta."""
    dim = _dim(dim)
    eta = _packing(packing_fraction, 1.0, False, "a fluid")
    sigma = _positive("diameter", diameter, "m")
    return _out(eta / ball_volume(dim, sigma / 2.0))


# --------------------------------------------------------------------- equations of state
# Each model is a private excess Z - 1 (full precision at small eta, used by
# contact_value) and a public Z = 1 + excess that checks its validity range.


def _excess_tonks(eta):
    return eta / (1.0 - eta)


def _excess_henderson(eta):
    # (1 + eta^2/8)/(1-eta)^2 - 1, expanded
    return (2.0 * eta - 0.875 * eta * eta) / (1.0 - eta) ** 2


def _excess_kolafa_rottner(eta):
    x = eta / (1.0 - eta)
    return x * np.polyval(_KR_COEFFICIENTS[:0:-1], x)


def _excess_carnahan_starling(eta):
    # (1 + eta + eta^2 - eta^3)/(1-eta)^3 - 1, expanded
    return (4.0 * eta - 2.0 * eta * eta) / (1.0 - eta) ** 3


def _excess_klm(eta):
    y = eta / (1.0 - eta)
    return y * np.polyval(_KLM_COEFFICIENTS[:0:-1], y)


# name -> (dimension, excess function, upper packing fraction, inclusive, description)
_MODEL_TABLE = {
    "tonks": (1, _excess_tonks, 1.0, False, "Tonks rods"),
    "henderson": (2, _excess_henderson, 1.0, False, "Henderson"),
    "kolafa-rottner": (2, _excess_kolafa_rottner, KOLAFA_ROTTNER_MAX_PACKING, True,
                       "the Kolafa-Rottner fit (use model='henderson' beyond)"),
    "carnahan-starling": (3, _excess_carnahan_starling, 1.0, False, "Carnahan-Starling"),
    "klm": (3, _excess_klm, KLM_MAX_PACKING, True,
            "the KLM fit (use model='carnahan-starling' beyond)"),
}

MODELS = {d: tuple(k for k, v in _MODEL_TABLE.items() if v[0] == d) for d in (1, 2, 3)}
"""Equation-of-state models available per dimension."""

BEST_MODEL = {1: "tonks", 2: "kolafa-rottner", 3: "klm"}
"""The most accurate model per dimension, used by model='best'."""


def _excess(dim: int, packing_fraction, model: str) -> np.ndarray:
    """Z - 1 for ``model`` in dimension ``dim``, after checking both."""
    dim = _dim(dim)
    name = BEST_MODEL[dim] if model == "best" else model
    if name not in MODELS[dim]:
        raise SceneError(f"model {model!r} is not one of {', '.join(MODELS[dim] + ('best',))} in {dim}D")
    _, excess, upper, inclusive, what = _MODEL_TABLE[name]
    return excess(_packing(packing_fraction, upper, inclusive, what))


def z_tonks(packing_fraction):
    """Z = 1/(1 - eta) of 1D hard rods (Tonks 1936). Exact for 0 <= eta < 1."""
    return _out(1.0 + _excess(1, packing_fraction, "tonks"))


def z_henderson(packing_fraction):
    """Z = (1 + eta^2/8)/(1 - eta)^2 of 2D hard disks (Henderson, Mol. Phys. 30, 971, 1975).

    Fluid, 0 <= eta < 1 accepted; within 0.5% of Kolafa-Rottner up to eta = 0.51,
    2.3% at 0.65, 8.6% at 0.69 (overestimates). Disks freeze from eta = 0.700.
    """
    return _out(1.0 + _excess(2, packing_fraction, "henderson"))


def z_kolafa_rottner(packing_fraction):
    """Z = sum_i A_i x^i, x = eta/(1-eta), of 2D hard disks (Kolafa & Rottner, Mol. Phys. 104, 3435, 2006).

    The rho_max = 0.88 fit to MD data, accurate to about 1e-5 relative;
    0 <= eta <= 0.69115 (beyond it raises SceneError). Reproduces B2..B5 of disks.
    """
    return _out(1.0 + _excess(2, packing_fraction, "kolafa-rottner"))


def z_carnahan_starling(packing_fraction):
    """Z = (1 + eta + eta^2 - eta^3)/(1 - eta)^3 of 3D hard spheres (Carnahan & Starling 1969).

    Fluid, 0 <= eta < 1 accepted; underestimates Z by at most 0.3% up to
    freezing (0.494) and 0.54% at 0.545.
    """
    return _out(1.0 + _excess(3, packing_fraction, "carnahan-starling"))


def z_klm(packing_fraction):
    """Z of 3D hard spheres, Kolafa-Labik-Malijevsky (PCCP 6, 2335, 2004): a power series in eta/(1-eta).

    Fitted to MD data with relative error < 4e-5 for eta 0.105-0.539 (metastable
    fluid included) and reproducing B2..B6; accepted for 0 <= eta <= 0.55.
    """
    return _out(1.0 + _excess(3, packing_fraction, "klm"))


def compressibility_factor(dim: int, packing_fraction, model: str = "best"):
    """Z = P/(n k_B T) of hard rods (1D), disks (2D) or spheres (3D) in bulk (dimensionless).

    ``model``: 'best' (Tonks in 1D, Kolafa-Rottner in 2D, KLM in 3D) or one of
    :data:`MODELS` [dim]. Each model's validity range is in its z_* function.
    """
    return _out(1.0 + _excess(dim, packing_fraction, model))


def hard_sphere_pressure(dim: int, number_density, diameter, temperature, model: str = "best"):
    """Bulk pressure P = n k_B T Z(eta) (Pa; N/m in 2D, N in 1D) of hard particles of ``diameter`` (m).

    For a periodic box (no walls); n in 1/m^D; temperature in K.
    """
    eta = packing_fraction(dim, number_density, diameter)
    kt = K_B * _positive("temperature", temperature, "K")
    return _out(np.asarray(number_density) * kt * compressibility_factor(dim, eta, model))


FREEZING_PACKING = {1: None, 2: 0.700, 3: 0.494}
"""Packing fraction where the hard-particle fluid stops being the only stable phase: 3D freezing 0.494
(Hoover & Ree 1968), 2D the liquid-hexatic coexistence's lower end 0.700 (Bernard & Krauth 2011);
1D rods never freeze."""

MELTING_PACKING = {2: 0.720, 3: 0.545}
"""Packing fraction above which the solid is the stable phase (3D melting 0.545; 2D about 0.72)."""

FCC_CLOSE_PACKING = math.pi / math.sqrt(18.0)


def z_fcc_speedy(packing_fraction):
    """Z of the hard-sphere FCC solid, Speedy's fit (J. Phys.: Condens. Matter 10, 4387 (1998)).

    Z = 3/(1 - x) - a (x - b)/(x - c), x = eta/eta_cp, a = 0.5921, b = 0.7072, c = 0.601; from the
    melting point (eta 0.545, Z 11.2) to close packing (the coefficients recalled, not read from
    the paper: checked against Z = 11.1 at coexistence, beta P sigma^3 = 11.6).
    """
    eta = _packing(packing_fraction, FCC_CLOSE_PACKING, False, "the FCC solid")
    x = eta / FCC_CLOSE_PACKING
    return _out(3.0 / (1.0 - x) - 0.5921 * (x - 0.7072) / (x - 0.601))
