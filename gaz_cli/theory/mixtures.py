"""Equation of state and contact values of hard-sphere mixtures (BMCSL in 3D)."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.theory._checks import _dim, _nonnegative, _positive
from gaz_cli.theory.eos import compressibility_factor


def _bmcsl_moments(number_densities, diameters):
    n = np.atleast_1d(_nonnegative("number density", number_densities, "per m^3")).astype(float).ravel()
    s = np.atleast_1d(_nonnegative("diameter", diameters, "m")).astype(float).ravel()
    if n.size != s.size:
        raise SceneError(f"{n.size} densities for {s.size} diameters: give one diameter per species")
    xi = [math.pi / 6.0 * float(np.sum(n * s ** k)) for k in range(4)]
    if xi[3] >= 1.0:
        raise SceneError(f"packing fraction {xi[3]:.3g} of the mixture is not below 1")
    return n, s, xi


def mixture_pressure(dim: int, number_densities, diameters, temperature):
    """Bulk pressure of a hard-sphere mixture, Boublik-Mansoori-Carnahan-Starling-Leland (Pa).

    beta P = (6/pi) [xi0/(1 - xi3) + 3 xi1 xi2/(1 - xi3)^2 + (3 - xi3) xi2^3/(1 - xi3)^3],
    xi_k = (pi/6) sum_s n_s sigma_s^k. One species: Carnahan-Starling. Known to
    sit about 0.2% below simulations at packing 0.3 (like Carnahan-Starling).
    3D only: 1D and 2D mixtures raise SceneError (no model here).
    """
    if _dim(dim) != 3:
        raise SceneError(f"no mixture equation of state in {dim}D here (BMCSL is for 3D spheres)")
    kt = K_B * _positive("temperature", temperature, "K")
    _, _, (x0, x1, x2, x3) = _bmcsl_moments(number_densities, diameters)
    y = 1.0 - x3
    return float(kt * 6.0 / math.pi * (x0 / y + 3.0 * x1 * x2 / y ** 2 + (3.0 - x3) * x2 ** 3 / y ** 3))


def mixture_contact_values(number_densities, diameters):
    """(S, S) contact values g_ij(sigma_ij) of a hard-sphere mixture, BMCSL (dimensionless).

    g_ij = 1/(1 - xi3) + 3 xi2 d_ij/(1 - xi3)^2 + 2 xi2^2 d_ij^2/(1 - xi3)^3,
    d_ij = sigma_i sigma_j/(sigma_i + sigma_j) (Boublik 1970; consistent with
    :func:`mixture_pressure` by the virial theorem).
    """
    _, s, (_, _, x2, x3) = _bmcsl_moments(number_densities, diameters)
    y = 1.0 - x3
    pair = np.add.outer(s, s)
    d = np.divide(np.outer(s, s), pair, out=np.zeros_like(pair), where=pair > 0)  # points: 0
    return 1.0 / y + 3.0 * x2 * d / y ** 2 + 2.0 * x2 ** 2 * d ** 2 / y ** 3


def _mapped_contact_terms(number_densities, diameters, model: str = "best"):
    """(x, s, eta, alpha, beta, moments M_k = sum_s x_s sigma_s^k) of :func:`mixture_pressure_mapped`."""
    n, s, _ = _bmcsl_moments(number_densities, diameters)
    rho = float(np.sum(n))
    if rho <= 0.0:
        raise SceneError("the mixture has no particle")
    x = n / rho
    m = [float(np.sum(x * s ** k)) for k in range(4)]
    eta = math.pi / 6.0 * rho * m[3]
    g_s = 1.0 / (1.0 - eta) if eta == 0.0 else (float(compressibility_factor(3, eta, model)) - 1.0) / (4.0 * eta)
    alpha = 1.5 * eta / (1.0 - eta) ** 2
    beta = g_s - 1.0 / (1.0 - eta) - alpha
    return x, s, eta, alpha, beta, m


def mixture_contact_values_mapped(number_densities, diameters, model: str = "best"):
    """(S, S) contact values g_ij of a 3D hard-sphere mixture mapped from a one-component EOS.

    g_ij = 1/(1 - eta) + alpha z_ij + beta z_ij^2, z_ij = (sigma_i sigma_j/sigma_ij) M2/M3,
    alpha = 3 eta/(2 (1 - eta)^2) (the scaled-particle/Percus-Yevick linear term), beta fixed so
    that equal spheres get the one-component g(sigma) of ``model`` (KLM by default). The
    construction of Santos, Yuste & Lopez de Haro (Mol. Phys. 96, 1 (1999); recalled, not read):
    with Carnahan-Starling as input it gives the BMCSL contact values exactly.
    """
    _, s, _, alpha, beta, m = _mapped_contact_terms(number_densities, diameters, model)
    pair = 0.5 * np.add.outer(s, s)
    z = np.divide(np.outer(s, s), pair, out=np.zeros_like(pair), where=pair > 0) * m[2] / m[3]
    eta = math.pi / 6.0 * float(np.sum(np.atleast_1d(number_densities))) * m[3]
    return 1.0 / (1.0 - eta) + alpha * z + beta * z * z


def mixture_pressure_mapped(dim: int, number_densities, diameters, temperature, model: str = "best"):
    """Bulk pressure of a 3D hard-sphere mixture from a one-component EOS (KLM by default), Pa.

    The virial route Z = 1 + (2 pi rho/3) sum_ij x_i x_j sigma_ij^3 g_ij with the contact values of
    :func:`mixture_contact_values_mapped`, in closed form:
    Z = 1 + eta/(1 - eta) (1 + 3 M1 M2/M3) + 2 eta alpha M2 (M1 M3 + M2^2)/M3^2 + 4 eta beta M2^3/M3^2.
    Carnahan-Starling as ``model`` gives BMCSL exactly; KLM, accurate to 4e-5 for one species,
    lifts it by 0.2-0.3 % at packing 0.3-0.4, where BMCSL runs low against simulations.
    """
    if _dim(dim) != 3:
        raise SceneError(f"no mixture equation of state in {dim}D here (the mapping is written for 3D spheres)")
    kt = K_B * _positive("temperature", temperature, "K")
    _, _, eta, alpha, beta, m = _mapped_contact_terms(number_densities, diameters, model)
    m1, m2, m3 = m[1], m[2], m[3]
    z = (1.0 + eta / (1.0 - eta) * (1.0 + 3.0 * m1 * m2 / m3) + 2.0 * eta * alpha * m2 * (m1 * m3 + m2 * m2) / m3 ** 2
         + 4.0 * eta * beta * m2 ** 3 / m3 ** 2)
    rho = float(np.sum(np.atleast_1d(number_densities)))
    return float(rho * kt * z)
