"""Pressures on the hard walls of a box [0, L]^D: non-interacting particles and 1D rods (exact),
hard spheres to first order in the wall and density corrections, wall adsorption; the exact
density of rod centres for the uniform 1D placement (the exam's Q12)."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.geometry import ball_volume
from gaz_cli.theory._checks import _accessible, _dim, _nonnegative, _out, _positive, _species
from gaz_cli.theory.eos import compressibility_factor
from gaz_cli.theory.mixtures import mixture_pressure


# --------------------------------------------------------------------- box pressures


def ideal_gas_pressure(number, temperature, volume):
    """P = N k_B T / V (Pa; N/m in 2D, N in 1D) for N particles in V (m^D).

    Valid for point particles, or any gas in the limit eta -> 0.
    """
    n = _nonnegative("number of particles", number, "")
    t = _positive("temperature", temperature, "K")
    v = _positive("volume", volume, "m^D")
    return _out(n * K_B * t / v)


def ideal_wall_pressure(dim: int, length, temperature, counts, radii):
    """Pressure measured on a hard wall of a box [0, L]^D per unit of FULL wall area.

    P = sum_s N_s k_B T / ((L - 2 R_s) L^(D-1))  (Pa; N/m in 2D, N in 1D).

    This is what the SQL pressure measures (momentum / (duration * L^(D-1))):
    one non-interacting particle of radius R pushes a wall with the
    time-averaged force k_B T / (L - 2R), whatever the wall's area. Exact for
    non-interacting particles in equilibrium at temperature T; for hard
    spheres it is the dilute limit (eta -> 0). ``counts`` and ``radii``: one
    entry per species (or scalars); ``length`` (m) and ``temperature`` (K)
    may be arrays.
    """
    dim, length, kt, c, r = _box_gas(dim, length, temperature, counts, radii)
    total = sum(ns * kt / (length - 2.0 * rs) for ns, rs in zip(c, r))
    return _out(total / length ** (dim - 1))


def ideal_accessible_pressure(dim: int, length, temperature, counts, radii):
    """Non-interacting pressure on the area accessible to centres: sum_s N_s k_B T / (L - 2R_s)^D.

    Pa (N/m in 2D, N in 1D). It is the force on a wall divided by the wall area
    the centres can reach, (L - 2R)^(D-1); equal to :func:`ideal_wall_pressure`
    times (L/(L - 2R))^(D-1). Meaningful for one species (with several, each
    has its own accessible area). Not what the SQL pressure measures.
    """
    dim, length, kt, c, r = _box_gas(dim, length, temperature, counts, radii)
    return _out(sum(ns * kt / (length - 2.0 * rs) ** dim for ns, rs in zip(c, r)))


def _box_gas(dim, length, temperature, counts, radii):
    """The checked arguments of a gas in a box: dim, L (m), k_B T (J), counts and radii per
    species; SceneError unless every particle fits (L > 2R)."""
    dim = _dim(dim)
    length = _positive("box length", length, "m")
    kt = K_B * _positive("temperature", temperature, "K")
    c, r = _species(counts, radii)
    if not np.all(length > 2.0 * r.max()):
        raise SceneError("box length must exceed every particle diameter")
    return dim, length, kt, c, r


def tonks_pressure(length, temperature, counts, radii):
    """Exact pressure of hard rods between walls at 0 and L: P = N k_B T / (L - sum_i sigma_i) (N).

    Tonks (1936); exact for every N and every packing fraction < 1, mixtures of
    rod lengths included (sum over particles of the diameters 2R). Equal to the
    bulk equation of state at n = N/L. ``counts``/``radii``: one entry per species.
    """
    length, kt, c, free = _rods(length, temperature, counts, radii, "box")
    return _out(np.sum(c) * kt / free)


def _rods(length, temperature, counts, radii, where: str):
    """The checked arguments of hard rods on a line of ``length`` (m): L, k_B T (J), the counts
    per species and the free length L - sum sigma (m); SceneError when the rods fill the ``where``."""
    length = _positive("box length", length, "m")
    kt = K_B * _positive("temperature", temperature, "K")
    c, r = _species(counts, radii)
    free = length - np.sum(c * 2.0 * r)
    if not np.all(free > 0.0):
        raise SceneError(f"the rods fill the {where}: total rod length must be below the box length")
    return length, kt, c, free


def ring_pressure(length, temperature, counts, radii):
    """Exact pressure of N hard rods on a ring of length L (1D periodic box), finite N (N).

    With one rod's position fixed by the conserved momentum's frame, the configurational
    integral is L (L - sum sigma)^(N-1)/(N-1)!, so P = k_B T/L + (N - 1) k_B T/(L - sum_i sigma_i),
    with k_B T = 2K/(N - 1) (the kinetic temperature at fixed total momentum). Against the
    infinite-N Tonks value N k_B T/(L - sum sigma) it differs by a relative -eta/N exactly.
    ``counts``/``radii``: one entry per species (mixtures of rod lengths included).
    """
    length, kt, c, free = _rods(length, temperature, counts, radii, "ring")
    return _out(kt / length + (np.sum(c) - 1.0) * kt / free)


def rods_wall_pressure(velocities, mass, length, radius):
    """Exact time-averaged wall pressure of equal-mass hard rods: sum_k m v_k^2 / (L - N sigma) (N).

    ``velocities``: (N,) or (N, 1) m/s, any set (equal-mass collisions only
    exchange velocities, so the set is conserved); ``mass`` kg; ``length`` m;
    ``radius`` m (sigma = 2R). The same on both walls; it is the average over
    times much longer than 2 (L - N sigma)/min|v|. Unequal masses break it.
    """
    v = np.asarray(velocities, dtype=float).reshape(-1)
    if not np.all(np.isfinite(v)):
        raise SceneError("velocities must be finite")
    m = _positive("mass", mass, "kg")
    length = _positive("box length", length, "m")
    sigma = 2.0 * _nonnegative("radius", radius, "m")
    free = length - v.size * sigma
    if not free > 0.0:
        raise SceneError("the rods fill the box: N * 2R must be below the box length")
    return _out(m * np.sum(v * v) / free)


def hard_sphere_wall_pressure(dim: int, length, temperature, number, radius, model: str = "best"):
    """Pressure on a hard wall of a box [0, L]^D per unit of FULL wall area, hard particles (Pa).

    What the SQL pressure measures (momentum / (duration * L^(D-1))), for N
    particles of one ``radius`` R (sigma = 2R). 1D: the exact Tonks result
    N k_B T / (L - N sigma) (:func:`tonks_pressure`). 2D/3D (no exact result):
    the bulk equation of state at the density of centres in the volume they
    can reach, n = N/(L - sigma)^D, times the reachable fraction of the wall,
    ((L - sigma)/L)^(D-1):

        P = N k_B T Z(eta') / ((L - sigma) L^(D-1)),  eta' = N v_D(R) / (L - sigma)^D.

    It is exact for non-interacting particles (Z = 1: :func:`ideal_wall_pressure`)
    and right to first order in eta and in sigma/L; the errors are of order
    eta sigma/L (wall layering, the adsorption of the fluid at the wall; edges
    and corners) and grow with eta as dlnZ/dln eta. ``model`` as in
    :func:`compressibility_factor`; eta' beyond the model's range raises SceneError.
    """
    dim = _dim(dim)
    if dim == 1:
        return tonks_pressure(length, temperature, number, radius)
    length = _positive("box length", length, "m")
    kt = K_B * _positive("temperature", temperature, "K")
    n = _nonnegative("number of particles", number, "")
    r = _nonnegative("radius", radius, "m")
    inner = _accessible("box length", length, r)
    eta = n * ball_volume(dim, r) / inner ** dim
    z = compressibility_factor(dim, eta, model)
    return _out(n * kt * z / (inner * length ** (dim - 1)))


def mixture_wall_pressure(dim: int, length, temperature, counts, radii):
    """Wall pressure of a hard-sphere mixture in a box, per full wall area (Pa), to first order.

    As :func:`hard_sphere_wall_pressure` for each species: the BMCSL
    compressibility factor at the densities n_s = N_s/(L - 2R_s)^3 of the
    volumes the centres reach, each species on the part of the wall it
    reaches: sum_s n_s k_B T Z ((L - 2R_s)/L)^2. 3D only.
    """
    length = _positive("box length", length, "m")
    c, r = _species(counts, radii)
    inner = _accessible("box length", length, r)
    n = c / inner ** 3
    kt = K_B * _positive("temperature", temperature, "K")
    z = mixture_pressure(dim, n, 2.0 * r, temperature) / (kt * float(np.sum(n)))
    return float(np.sum(n * kt * z * (inner / length) ** 2))


def bulk_wall_pressure(dim: int, length, temperature, number_density, radius, edges: bool = True,
                       model: str = "best"):
    """Pressure on a hard wall of a box [0, L]^D per unit of FULL wall area, from the bulk (Pa).

    Mechanical equilibrium: across any plane parallel to a wall the normal stress sums to
    the wall's force. Far from the side walls that stress is the bulk pressure
    P = n k_B T Z(eta) at the density ``number_density`` n of the box's middle (1/m^D); on
    the 2(D - 1) side walls' layers it differs by their surface tension gamma
    (relative to the plane the centres reach), so that the force is
    (L - sigma)^(D-2) [P (L - sigma) - 2 (D - 1) gamma]. With ``edges``, gamma is
    -k_B T Gamma / 2 (Gibbs' adsorption at first order in density,
    :func:`wall_adsorption`); its size is the formula's systematic error. 2D/3D.
    """
    dim = _dim(dim)
    if dim == 1:
        raise SceneError("1D rods between walls: use tonks_pressure (exact)")
    length = _positive("box length", length, "m")
    kt = K_B * _positive("temperature", temperature, "K")
    n = _nonnegative("number density", number_density, "per m^D")
    r = _nonnegative("radius", radius, "m")
    inner = _accessible("box length", length, r)
    bulk = n * kt * compressibility_factor(dim, n * ball_volume(dim, r), model)
    edge = (dim - 1) * kt * wall_adsorption(dim, n, 2.0 * r) if edges else 0.0
    return _out(inner ** (dim - 2) * (bulk * inner + edge) / length ** (dim - 1))


def wall_adsorption(dim: int, number_density, diameter):
    """Excess centres per unit wall area at a flat hard wall, to first order: Gamma = c_D n^2 sigma^(D+1) (1/m^(D-1)).

    Relative to the plane the centres can reach (distance R from the wall).
    A centre at height h < sigma above that plane has the cap of its exclusion
    ball (radius sigma) beyond it free of other centres, so n(h)/n = 1 + n V_cap;
    integrating V_cap over h gives c_1 = 1/2, c_2 = 2/3, c_3 = pi/4. Exact to
    second order in density (it reproduces the wall contact theorem at first
    order); at higher density the true adsorption is smaller (about half at
    eta = 0.3 in 2D, measured here).
    """
    dim = _dim(dim)
    n = _nonnegative("number density", number_density, "per m^D")
    sigma = _nonnegative("diameter", diameter, "m")
    c = {1: 0.5, 2: 2.0 / 3.0, 3: math.pi / 4.0}[dim]
    return _out(c * n * n * sigma ** (dim + 1))


def wall_adsorption_shift(dim: int, length, number, radius, model: str = "best"):
    """Relative change of :func:`hard_sphere_wall_pressure` that wall adsorption brings at the next order.

    -(Gamma S / N) dlnP/dln n: the 2D walls of area S = 2D (L - 2R)^(D-1)
    hold Gamma S of the N particles (:func:`wall_adsorption` at n = N/(L-2R)^D),
    which thins the interior. Negative; its size is a measure of the
    systematic error of the first-order formula (the true shift is smaller at
    high density). 2D/3D, one species; 0 for N -> 0.
    """
    dim = _dim(dim)
    length = _positive("box length", length, "m")
    n_particles = _positive("number of particles", number, "")
    r = _nonnegative("radius", radius, "m")
    inner = _accessible("box length", length, r)
    n = n_particles / inner ** dim
    eta = n * ball_volume(dim, r)
    gamma = wall_adsorption(dim, n, 2.0 * r)
    area = 2.0 * dim * inner ** (dim - 1)
    step = 1e-5
    z_lo = compressibility_factor(dim, eta * (1.0 - step), model)
    z_hi = compressibility_factor(dim, eta * (1.0 + step), model)
    with np.errstate(divide="ignore", invalid="ignore"):
        dlnz = np.where(eta > 0, (np.log(z_hi) - np.log(z_lo)) / (2.0 * step), 0.0)
    return _out(-(gamma * area / n_particles) * (1.0 + dlnz))


def rod_centre_density(x, number, radius, length):
    """Exact probability density (1/m) of the centre of a rod picked at random, uniform 1D placement.

    N rods of radius R (sigma = 2R) placed uniformly over the valid
    configurations in [0, L] (the exam's placement1Drapide, Q10): the k-th rod
    from the left sits at u_(k) + (2k - 1) R, u_(k) the k-th smallest of N
    uniforms on [0, a], a = L - 2NR, whose density is the Beta law
    N!/((k-1)!(N-k)!) u^(k-1) (a-u)^(N-k) / a^N. Returns the mean over k of
    these densities at ``x`` (m, float or array), 0 outside [R, L - R]; it
    integrates to 1. This is what the Q12 histogram of centres converges to
    (a sequential rejection placement does not, for N >= 2). N = 1: uniform on
    [R, L - R]; a = 0 (full box) is refused.
    """
    n = int(number)
    if n < 1 or n != number:
        raise SceneError(f"number of rods must be an integer >= 1, got {number!r}")
    r = float(_nonnegative("radius", radius, "m"))
    length = float(_positive("box length", length, "m"))
    a = length - 2.0 * n * r
    if not a > 0.0:
        raise SceneError(f"{n} rods of radius {r:g} m fill the box of length {length:g} m: no room to place them")
    x = np.asarray(x, dtype=float)
    total = np.zeros_like(x)
    log_norm = math.lgamma(n + 1) - n * math.log(a)
    for k in range(1, n + 1):
        u = x - (2 * k - 1) * r
        inside = (u >= 0.0) & (u <= a)
        uc = np.clip(u, 0.0, a)
        with np.errstate(divide="ignore", invalid="ignore"):
            logp = (log_norm - math.lgamma(k) - math.lgamma(n - k + 1)
                    + (k - 1) * np.where(k > 1, np.log(uc), 0.0)
                    + (n - k) * np.where(n > k, np.log(a - uc), 0.0))
        total += np.where(inside, np.exp(logp), 0.0)
    return _out(total / n)
