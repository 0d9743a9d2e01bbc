"""The exam's functions, under the exam's names: the executable specification.

Seed ``000`` ("Simulation de la cinétique d'un gaz parfait") in Python, as the
exam writes it, so that a reader holding the exam finds every question here:

========================  =====  ==============================================
function                  Q      role
========================  =====  ==============================================
placement1D               1-9    rejection placement of rods (Q6 + Q9 included)
placement1Drapide         10-12  O(N log N), exactly uniform rod placement
placement                 13     rejection placement in D = 1, 2, 3
situationInitiale         II     placement + Maxwell-Boltzmann velocities
vol                       17     free flight
rebond                    18     wall bounce
choc                      19     elastic collision (D = 1, 2, 3, any masses)
tr                        20     time to the next wall
tc                        21     time to contact of two particles
ajoutEv                   22     insert an event into the sorted catalogue
ajout1p                   23     the next events of one particle
initCat                   24-27  the initial catalogue
etape                     29     advance every particle through one event
majCat                    30     update the catalogue after an event
enregistrer               31     record an event into a Recorder (the ``bdd``)
simulation                31-33  the whole run, relative event times
run                       --     the same algorithm behind
                                 ``gaz simulate --engine reference``
========================  =====  ==============================================

Data, exactly as in the exam:

* a particle is a list ``[position, velocity]`` of two float ndarrays of shape
  (D,), in m and m/s;
* an event is a list ``[valid, dt, i, j, d]``: ``valid`` bool, ``dt`` seconds
  from the current instant, ``i`` the (first) particle, ``j`` the second
  particle or None (wall bounce), ``d`` the axis perpendicular to the wall or
  None (collision);
* the catalogue is a Python list of events sorted by *decreasing* ``dt``: the
  nearest event is at the end, taken with ``catalogue.pop()``.

Two extensions, both optional keywords or argument types, so that the exam's
calls work unchanged: ``R`` may be a sequence of N radii instead of one float
(mixtures: the contact distance of i and j is R_i + R_j) and ``masses`` may
give per-particle masses (unequal-mass collisions). Random functions take an
optional ``rng`` (a ``numpy.random.Generator``); without it they draw from
numpy's global generator as the exam does (``np.random.rand``), so
``np.random.seed(k)`` makes them repeatable.

Numerical stability (physics.md §9): ``tc`` predicts a collision only for an
approaching pair, with the cancellation-free root clipped at 0, so a pair left
slightly overlapping by round-off and approaching collides at once, and one
that separates is left alone; ``tr`` clips at 0 likewise, so a particle past a
wall and moving outwards is reflected at once.

This module is simple and exact, not fast: every event costs O(N) flights,
O(N) contact times and O(C) catalogue updates (C, the catalogue length, grows
as invalid events are kept, Q30). The fast engine (``gaz_cli.engines.event``) is
checked and benchmarked against it.
"""

from __future__ import annotations

import bisect
import math
import time

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import EngineError, PlacementError, SceneError
from gaz_cli.model.recording import Recorder, RunStats
from gaz_cli.geometry import DENSEST, packing_fraction
from gaz_cli.model.checks import field_error
from gaz_cli.model.scene import STEP_ONLY, Scene, State
from gaz_cli.model.species import BUILTIN

MAX_RESTARTS = 10_000
"""Default bounded effort of the rejection placements (Q9 restarts).

The exam's Q7 case (4 rods of radius 0.5 in 5) succeeds with probability
1/256 per attempt, so it fails after 10,000 restarts with probability
(255/256)^10000 ~ 1e-17."""

ARGON = BUILTIN["Ar"]
"""The exam gives no mass: :func:`situationInitiale` and :func:`simulation`
use argon (6.63e-26 kg) at ``TEMPERATURE``."""

TEMPERATURE = 300.0
"""Default temperature of :func:`situationInitiale`, K."""


# --------------------------------------------------------------------------
# I  Initialisation
# --------------------------------------------------------------------------

def _uniform(rng, size):
    """Uniform floats in [0, 1) of shape ``size``: the exam's np.random.rand, or rng."""
    return np.random.rand(*size) if rng is None else rng.random(size)


def reference_refusal(scene: Scene) -> str | None:
    """What the reference engine (the exam's algorithm: hard elastic walls, no gravity) cannot
    take in ``scene``, as a marked field and value (`boundary` periodic), or None."""
    if scene.boundary != "walls":
        return f"`boundary` {scene.boundary}"
    if scene.gravity != 0.0:
        return f"`gravity` {scene.gravity:g}"
    if scene.restitution != 1.0:
        return f"`restitution` {scene.restitution:g}"
    return None


def check_reference_scene(scene: Scene) -> None:
    """SceneError (fields named) unless the reference engine can run ``scene``."""
    why = reference_refusal(scene)
    if why is not None:
        raise field_error(f"`engine` reference (the exam's algorithm) handles hard elastic walls "
                          f"without gravity only, not {why}; use `engine` event")


def placement1D(N: int, R: float, L: float, *, rng=None,
                max_restarts: int = MAX_RESTARTS) -> list:
    """Centres of N rods of radius R placed at random on the segment [0, L] (Q1-Q9).

    The exam's rejection algorithm with its two improvements:

    * Q6: a candidate centre is drawn uniformly in [R, L - R] (line 9 becomes
      ``p = R + (L - 2R) * np.random.rand(1)``), so ``possible`` never rejects
      it for touching a wall;
    * Q9: as soon as ``possible`` rejects a candidate, everything restarts from
      zero. This ends the Q7 dead end (three rods at 1, 2.5, 4 leave no room for
      a fourth of diameter 1 in [0, 5], and the original loop never ends), and
      makes the result *exactly* uniform over the valid configurations (it is
      rejection sampling of the whole configuration), at the price of an
      acceptance probability (L - 2NR)^N / (L - 2R)^N that falls fast with N.

    Bounded effort: if 2NR > L no configuration exists and PlacementError is
    raised at once; otherwise after ``max_restarts`` restarts.

    Returns a list of N float ndarrays of shape (1,), m, in drawing order.

    Complexity (Q8): with N << N_max every candidate is accepted with high
    probability and ``possible`` scans the rods already placed, so O(N^2).
    """
    if N < 0 or R < 0 or L <= 0:
        raise PlacementError(f"placement1D needs N >= 0, R >= 0, L > 0; got N={N}, R={R}, L={L}")
    if 2 * N * R > L:
        raise PlacementError(f"{N} rods of diameter {2 * R:g} need {2 * N * R:g} > L = {L:g}: "
                             "no placement exists; lower N or R, or raise L")

    def possible(c: np.ndarray) -> bool:
        if c[0] < R or c[0] > L - R:
            return False
        for p in res:
            if abs(c[0] - p[0]) < 2 * R:
                return False
        return True

    res = []
    restarts = 0
    while len(res) < N:
        p = R + (L - 2 * R) * _uniform(rng, (1,))        # Q6
        if possible(p):
            res.append(p)
        else:                                           # Q9: start again from zero
            res = []
            restarts += 1
            if restarts > max_restarts:
                raise PlacementError(
                    f"placement1D gave up after {max_restarts} restarts (Q9): {N} rods of radius "
                    f"{R:g} in L = {L:g} leave a free length of {L - 2 * N * R:g}; use "
                    "placement1Drapide (Q10), which never rejects, or lower N / raise L")
    return res


def placement1Drapide(N: int, R: float, L: float, *, rng=None) -> list:
    """Centres of N rods of radius R on [0, L], exactly uniform, no rejection (Q10).

    1. the free length is l = L - 2NR;
    2. N point-like virtual rods are drawn uniformly in [0, l) and sorted;
    3. the k-th one (k = 0..N-1) becomes a real rod by shifting it, and every
       rod to its right, by the room of the rods before it: x_k = u_(k) + (2k+1)R.

    The map from sorted points of [0, l)^N to ordered rod configurations is a
    translation on each coordinate (volume preserving and one to one), so the
    result is uniform over the valid configurations: Q12's histogram of centres
    is flat on [R, L-R] for N = 1, the sum of two shifted triangles (Beta(1,2)
    and Beta(2,1) laws over l = L - 4R) for N = 2, and five spikes at 1, 3, 5,
    7, 9 for N = 5, R = 1, L = 10 (l = 0: the segment is full).

    Returns a list of N float ndarrays of shape (1,), m, from left to right.
    Raises PlacementError if 2NR > L.

    Complexity (Q11): O(N log N), the sort; drawing and shifting are O(N). Far
    better than the O(N^2) of placement1D, with no rejection at all, up to a
    full segment.
    """
    if N < 0 or R < 0 or L <= 0:
        raise PlacementError(f"placement1Drapide needs N >= 0, R >= 0, L > 0; got N={N}, R={R}, L={L}")
    libre = L - 2 * N * R
    if libre < 0:
        raise PlacementError(f"{N} rods of diameter {2 * R:g} need {2 * N * R:g} > L = {L:g}: "
                             "no placement exists; lower N or R, or raise L")
    u = np.sort(libre * _uniform(rng, (N,)))
    x = u + (2 * np.arange(N) + 1) * R
    return [np.array([xk]) for xk in x]


def placement(D: int, N: int, R: float, L: float, *, rng=None,
              max_restarts: int = MAX_RESTARTS) -> list:
    """Centres of N spheres of radius R placed at random in the box [0, L]^D (Q13).

    placement1D generalised to D = 1, 2, 3, with Q6 (candidates drawn in
    [R, L - R]^D) and Q9 (restart from zero on any rejection), so exactly
    uniform over valid configurations, but only practical when N^2 (2R)^D / L^D
    is small: the acceptance probability of an attempt falls like
    exp(-N^2 v_excl / 2 V). Bounded effort: PlacementError when the packing
    fraction reaches the densest packing, or after ``max_restarts`` restarts
    (use gaz_cli.placement.place, with its cell grid and lattice starts, for
    dense or large systems).

    Returns a list of N float ndarrays of shape (D,), m. Complexity O(N^2 D)
    per successful attempt.
    """
    if D not in (1, 2, 3):
        raise PlacementError(f"placement: D = {D} is not 1, 2 or 3")
    if N < 0 or R < 0 or L <= 0:
        raise PlacementError(f"placement needs N >= 0, R >= 0, L > 0; got N={N}, R={R}, L={L}")
    eta = packing_fraction(D, R, L, N)
    if 2 * R > L or (N > 1 and eta >= DENSEST[D]):
        raise PlacementError(f"{N} spheres of radius {R:g} fill {eta:.3g} of the box of side {L:g}, "
                             f"at or above the densest packing {DENSEST[D]:.4g}: no placement exists; "
                             "lower N or R, or raise L")

    def possible(c: np.ndarray) -> bool:
        if np.any(c < R) or np.any(c > L - R):
            return False
        for p in res:
            if np.sum((c - p) ** 2) < (2 * R) ** 2:
                return False
        return True

    res = []
    restarts = 0
    while len(res) < N:
        p = R + (L - 2 * R) * _uniform(rng, (D,))        # Q6
        if possible(p):
            res.append(p)
        else:                                           # Q9
            res = []
            restarts += 1
            if restarts > max_restarts:
                raise PlacementError(
                    f"placement gave up after {max_restarts} restarts (Q9): {N} spheres of radius "
                    f"{R:g} fill {eta:.3g} of the box, too dense for restarting from zero; use "
                    "gaz_cli.placement.place (gaz place --method rejection or lattice), "
                    "or lower N / raise L")
    return res


def situationInitiale(D: int, N: int, R: float, L: float, *, rng=None,
                      masse: float = ARGON.mass, temperature: float = TEMPERATURE) -> list:
    """N particles of radius R at random in [0, L]^D with Maxwell-Boltzmann velocities (part II).

    Positions from :func:`placement` (Q13); velocities: each component normal
    with variance k_B T / m. The exam gives no mass: by default argon
    (``masse`` = 6.63e-26 kg) at ``temperature`` = 300 K, about 250 m/s per
    component. Returns a list of N particles [position (D,), velocity (D,)].
    """
    positions = placement(D, N, R, L, rng=rng)
    sigma = math.sqrt(K_B * temperature / masse)
    if rng is None:
        v = np.random.standard_normal((N, D))
    else:
        v = rng.standard_normal((N, D))
    return [[np.array(x, dtype=float), sigma * v[k].copy()] for k, x in enumerate(positions)]


# --------------------------------------------------------------------------
# II  Motion of the particles
# --------------------------------------------------------------------------

def vol(p: list, t: float) -> None:
    """Move particle p in a straight line for t seconds, in place (Q14, Q17).

    Between events a particle is free: x <- x + v t, v unchanged. Any D; the
    position array is updated in place (it must be a float array). O(D).
    """
    p[0] += t * p[1]


def rebond(p: list, d: int) -> None:
    """Bounce p on a wall perpendicular to axis d, in place (Q16, Q18).

    The normal component of the velocity changes sign, the others are kept
    (a wall is a particle of infinite mass, Q16). Does not check the contact. O(1).
    """
    p[1][d] = -p[1][d]


def _normale(p1: list, p2: list) -> np.ndarray:
    """Unit vector from the centre of p1 to that of p2, (D,)."""
    r = p2[0] - p1[0]
    norme = math.sqrt(float(np.dot(r, r)))
    if norme == 0.0:
        if r.size == 1:
            return np.ones(1)
        raise EngineError("choc: the two centres coincide, the line of centres is undefined")
    return r / norme


def choc(p1: list, p2: list, *, masses=None) -> None:
    """Elastic collision of p1 and p2: new velocities, in place (Q15, Q19).

    In 1D (Q19) the exam's formulas::

        v1' = (m1 - m2)/(m1 + m2) v1 + 2 m2/(m1 + m2) v2
        v2' = 2 m1/(m1 + m2) v1 + (m2 - m1)/(m1 + m2) v2

    which for m1 = m2 exchange the velocities exactly (Q15). In 2D and 3D the
    same law acts along the line of centres n = (x2 - x1)/|x2 - x1|: the
    impulse J = 2 m1 m2/(m1 + m2) ((v2 - v1).n) n gives v1 += J/m1,
    v2 -= J/m2; the tangential components are kept. Momentum and kinetic
    energy are conserved. ``masses`` = (m1, m2), kg; default equal masses.
    Does not check the contact. O(D).
    """
    m1, m2 = (1.0, 1.0) if masses is None else (float(masses[0]), float(masses[1]))
    if p1[1].size == 1:
        v1, v2 = p1[1][0], p2[1][0]
        s = m1 + m2
        p1[1][0] = (m1 - m2) / s * v1 + 2 * m2 / s * v2
        p2[1][0] = 2 * m1 / s * v1 + (m2 - m1) / s * v2
        return
    n = _normale(p1, p2)
    vn = float(np.dot(p2[1] - p1[1], n))
    j = (2.0 * m1 * m2 / (m1 + m2) * vn) * n
    p1[1] += j / m1
    p2[1] -= j / m2


def _impulsion(p1: list, p2: list, m1: float, m2: float) -> float:
    """|J| of the elastic collision p1-p2 that just happened, kg m/s, from the state after it.

    An elastic collision reverses the normal relative velocity, so
    |J| = 2 m1 m2/(m1 + m2) |(v2 - v1).n| is the same before and after.
    """
    n = _normale(p1, p2)
    return 2.0 * m1 * m2 / (m1 + m2) * abs(float(np.dot(p2[1] - p1[1], n)))


# --------------------------------------------------------------------------
# III  Events
# --------------------------------------------------------------------------

def tr(p: list, R: float, L: float):
    """Time to the next wall of particle p of radius R in the box [0, L]^D (Q20).

    On each axis d with v_d != 0 the wall ahead is met when x_d reaches L - R
    (v_d > 0) or R (v_d < 0), after (L - R - x_d)/v_d or (R - x_d)/v_d; the
    earliest axis wins. Other particles are ignored. A time below 0 (a
    particle already past the wall and moving out) is clipped to 0: it is
    reflected at once. Returns None if p is at rest, else (dt s, d). O(D).
    """
    x, v = p[0], p[1]
    best = None
    for d in range(len(v)):
        if v[d] > 0:
            t = (L - R - x[d]) / v[d]
        elif v[d] < 0:
            t = (R - x[d]) / v[d]
        else:
            continue
        t = max(0.0, float(t))
        if best is None or t < best[0]:
            best = (t, d)
    return best


def _temps_contact(r: np.ndarray, v: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Contact times of K pairs, (K,) s, NaN where they never meet.

    r, v (K, D): relative positions and velocities (second minus first);
    sigma (K,): contact distances. With a = v.v, b = r.v, c = r.r - sigma^2:
    no event if b >= 0 (receding) or b^2 - a c <= 0 (missing); otherwise the
    cancellation-free root t = max(0, c / (-b + sqrt(b^2 - a c))) (physics.md §9).
    """
    a = np.sum(v * v, axis=1)
    b = np.sum(r * v, axis=1)
    c = np.sum(r * r, axis=1) - sigma * sigma
    disc = b * b - a * c
    ok = (b < 0) & (disc > 0)
    t = np.full(b.shape, np.nan)
    t[ok] = np.maximum(0.0, c[ok] / (-b[ok] + np.sqrt(disc[ok])))
    return t


def tc(p1: list, p2: list, R: float):
    """Time until particles p1 and p2 of radius R touch, alone in infinite space (Q21).

    Smallest t >= 0 with |(x2 - x1) + (v2 - v1) t| = 2R, for D = 1, 2, 3,
    computed as in :func:`_temps_contact` (numerically stable rule of
    physics.md §9: an approaching overlapping pair gives 0, a receding one
    None). Returns None if they never meet, else dt in s. O(D).
    """
    r = (p2[0] - p1[0])[None, :]
    v = (p2[1] - p1[1])[None, :]
    t = _temps_contact(r, v, np.array([2.0 * R]))[0]
    return None if np.isnan(t) else float(t)


def ajoutEv(catalogue: list, e: list) -> None:
    """Insert event e into the catalogue, kept sorted by decreasing dt (Q22).

    The place is found by bisection (``bisect.insort`` on the key -dt): O(log C)
    comparisons, plus the O(C) shift of list.insert (a memmove, cheap). Among
    events of equal dt the newest goes nearer the end, so it is taken first.
    """
    bisect.insort(catalogue, e, key=_cle)


def _cle(e: list) -> float:
    return -e[1]


def _rayons(R, n: int) -> np.ndarray:
    """R as (n,) radii: one float for all (the exam) or one radius per particle."""
    return np.broadcast_to(np.asarray(R, dtype=float), (n,))


def ajout1p(catalogue: list, i: int, R, L: float, particules: list) -> None:
    """Add the next potential events of particle i to the sorted catalogue (Q23).

    The next wall bounce (:func:`tr`) and the next collision with each other
    particle j (:func:`tc`, ignoring everybody else), all marked valid, each
    inserted with :func:`ajoutEv`: [True, dt, i, None, d] and
    [True, dt, i, j, None]. ``R`` is the radius, or a sequence of the N radii
    (contact distance R_i + R_j).

    The N - 1 contact times are the formula of :func:`tc` evaluated on all j at
    once with numpy (same operations, same results; tests check it against a
    loop of tc). O(N D) for the times, plus O(k log C) to insert the k events found.
    """
    n = len(particules)
    rayons = _rayons(R, n)
    paroi = tr(particules[i], float(rayons[i]), L)
    if paroi is not None:
        ajoutEv(catalogue, [True, paroi[0], i, None, paroi[1]])
    if n < 2:
        return
    x = np.array([p[0] for p in particules], dtype=float)
    v = np.array([p[1] for p in particules], dtype=float)
    t = _temps_contact(x - x[i], v - v[i], rayons[i] + rayons)
    t[i] = np.nan
    for j in np.flatnonzero(~np.isnan(t)):
        ajoutEv(catalogue, [True, float(t[j]), i, int(j), None])


def initCat(particules: list, R, L: float) -> list:
    """The catalogue of the next potential events of all particles, by decreasing dt (Q24).

    ``ajout1p`` for every particle. Q25: every collision i-j appears twice,
    once from ajout1p(i) (as [.., i, j, None]) and once from ajout1p(j): the
    pair is considered from each of its two particles.

    Complexity (Q26), 1D: N (N - 1) contact times, O(N^2); in 1D any
    approaching pair meets (nothing can miss), so about half of the pairs give
    an event and C = Theta(N^2) events are inserted. With the exam's ajoutEv
    (a linear scan of the sorted list) each insertion costs O(C): Theta(N^4) in
    all. Q27: ajoutEv is the function to optimise first: a binary search
    (dichotomie, used here) makes the search O(log C), so O(N^2 log N)
    comparisons (the list shifts remain, as a fast memmove); a binary heap,
    or sorting all events once, gives O(N^2 log N) outright. In 2D and 3D a
    pair meets only if its relative path passes within sigma = R_i + R_j, so
    C = O(N^2 (sigma/L)^(D-1)) and the N^2 contact times dominate: O(N^2).
    """
    catalogue = []
    for i in range(len(particules)):
        ajout1p(catalogue, i, R, L, particules)
    return catalogue


# --------------------------------------------------------------------------
# IV  Simulation
# --------------------------------------------------------------------------

def etape(particules: list, e: list, *, masses=None) -> None:
    """Advance every particle through event e (assumed valid and the nearest), in place (Q29).

    All particles fly for e[1] seconds (:func:`vol`), then the wall bounce
    (:func:`rebond`, e[3] is None) or the collision (:func:`choc`) of the
    particles concerned. ``masses``: the N masses, kg (default equal). O(N D).

    Q28: the catalogue is never empty unless every particle is at rest: a
    moving particle always heads for some wall, so tr gives it an event (and
    two particles at rest never meet). The simulation then just lets time pass.
    """
    for p in particules:
        vol(p, e[1])
    i, j, d = e[2], e[3], e[4]
    if j is None:
        rebond(particules[i], d)
    else:
        choc(particules[i], particules[j],
             masses=None if masses is None else (masses[i], masses[j]))


def majCat(catalogue: list, particules: list, e: list, R, L: float) -> None:
    """Update the catalogue after event e (already popped and applied by etape) (Q30).

    Every event that involves a particle of e (as first or second particle) is
    marked invalid (not removed: fewer list manipulations), then the new next
    events of those particles are added with :func:`ajout1p`. The other events
    stay valid: their particles flew freely, which changes nothing but the
    common time shift (done by the caller). O(C) for the scan, O(N) per
    particle involved for the new times.

    Q32: the duplicates of Q25 are handled here: when the first copy of a
    collision i-j is processed, the second copy concerns i and j and is
    marked invalid, so it is discarded when it reaches the end of the list.
    """
    concernes = (e[2],) if e[3] is None else (e[2], e[3])
    for ev in catalogue:
        if ev[0] and (ev[2] in concernes or ev[3] in concernes):
            ev[0] = False
    for k in concernes:
        ajout1p(catalogue, k, R, L, particules)


def _mur(p: list, d: int) -> int:
    """RE_DIR of the wall p just bounced on: +(d+1) at L, -(d+1) at 0.

    After the bounce the normal velocity points away from the wall: negative
    away from the wall at L, positive away from the wall at 0.
    """
    return d + 1 if p[1][d] < 0 else -(d + 1)


def enregistrer(bdd, t: float, e: list, particules: list, *, masses=None) -> None:
    """Record event e, which happened at simulated time t s, into ``bdd`` (Q31).

    ``particules`` is the state just after e. ``bdd`` None: nothing. Otherwise
    a :class:`gaz_cli.model.recording.Recorder`: a wall bounce goes to
    ``bdd.add_bounces`` (1-element arrays: time, particle, RE_DIR, |v|,
    |v_perp|; an elastic bounce keeps both, so the values after it are those
    just before), if ``bdd.want_bounces``; a collision goes to
    ``bdd.add_collisions`` (time, i, j, |J| kg m/s), if ``bdd.want_collisions``.
    ``masses``: the N masses, kg, for |J| (default: argon, as in simulation).
    """
    if bdd is None:
        return
    i, j, d = e[2], e[3], e[4]
    if j is None:
        if getattr(bdd, "want_bounces", True):
            p = particules[i]
            bdd.add_bounces(np.array([t]), np.array([i], dtype=np.int64),
                            np.array([_mur(p, d)], dtype=np.int64),
                            np.array([math.sqrt(float(np.dot(p[1], p[1])))]),
                            np.array([abs(float(p[1][d]))]))
    elif getattr(bdd, "want_collisions", False):
        m1, m2 = (ARGON.mass, ARGON.mass) if masses is None else (masses[i], masses[j])
        bdd.add_collisions(np.array([t]), np.array([i], dtype=np.int64),
                           np.array([j], dtype=np.int64),
                           np.array([_impulsion(particules[i], particules[j], m1, m2)]))


def _boucle(particules: list, R, L: float, T: float, masses, rappel) -> dict:
    """The exam's event loop (Q31), shared by :func:`simulation` and :func:`run`.

    catalogue = initCat; then repeatedly: pop the nearest event; skip it if
    invalid; stop if it falls after T; otherwise shift every event time by
    its dt (relative times), ``etape``, ``rappel(t, e, particules)`` and
    ``majCat``. At the end every particle flies to exactly T. Guard: 10 N + 100
    events in a row within 1e-12 T of simulated time mean an invalid state
    (overlapping particles, or a broken contact rule); EngineError then, never
    an endless loop.

    Returns counts: events, popped_invalid, catalogue_initial, catalogue_max,
    catalogue_final.
    """
    n = len(particules)
    catalogue = initCat(particules, R, L)
    info = {"catalogue_initial": len(catalogue), "catalogue_max": len(catalogue),
            "popped_invalid": 0}
    t = 0.0
    evenements = 0
    limite = 10 * n + 100
    fenetre_t, fenetre_n = 0.0, 0          # guard: time at the start of the last window
    while catalogue:
        e = catalogue.pop()
        if not e[0]:
            info["popped_invalid"] += 1
            continue
        dt = e[1]
        if t + dt > T:
            break
        if dt != 0.0:
            for ev in catalogue:
                ev[1] -= dt
        etape(particules, e, masses=masses)
        t += dt
        evenements += 1
        if evenements - fenetre_n >= limite:
            if t - fenetre_t <= 1e-12 * T:
                raise EngineError(f"reference engine: {limite} events in a row at t = {t:g} s "
                                  "without time advancing; the state is invalid (overlapping particles?)")
            fenetre_t, fenetre_n = t, evenements
        rappel(t, e, particules)
        majCat(catalogue, particules, e, R, L)
        if len(catalogue) > info["catalogue_max"]:
            info["catalogue_max"] = len(catalogue)
    for p in particules:
        vol(p, T - t)
    info["events"] = evenements
    info["catalogue_final"] = len(catalogue)
    return info


def simulation(bdd, d: int, N: int, R: float, L: float, T: float, *, rng=None) -> int:
    """Simulate N identical particles of radius R in [0, L]^d for T seconds (Q31).

    situationInitiale (argon at 300 K), initCat, then the event loop: the
    nearest event is popped (invalid ones are discarded, Q32); if it happens
    after T the run stops; otherwise the relative times of all remaining
    events are decreased by its dt, ``etape`` applies it, ``enregistrer``
    records it at the absolute time t and ``majCat`` updates the catalogue.
    Returns the number of events that happened.

    Complexity per event: O(N D) for etape, O(C) to shift the times and to
    invalidate in majCat, O(N) contact times; C grows with the invalid events
    kept (Q30).

    Q33: relative times force this O(C) shift after each event and accumulate
    one rounding per shift; times counted from a fixed origin (absolute) leave
    the catalogue untouched (stale events recognised, e.g., by per-particle
    event counters) and are computed once, exactly, and particles can then
    be moved lazily from their own time stamps instead of all at every event.
    Absolute times are better on both counts, which is what the fast engine
    (gaz_cli.engines.event) uses; relative times only keep numbers small, which
    doubles do not need.
    """
    particules = situationInitiale(d, N, R, L, rng=rng)

    def rappel(t, e, parts):
        enregistrer(bdd, t, e, parts)

    return _boucle(particules, R, L, T, None, rappel)["events"]


# --------------------------------------------------------------------------
# The engine adapter: gaz simulate --engine reference
# --------------------------------------------------------------------------

_CHUNK = 8192
"""Events buffered before a chunk is handed to the recorder."""


def _check_scene(scene) -> None:
    """SceneError unless the scene is the exam's: hard elastic walls, no force. The tests are
    the scene's own (scene.reference_refusal; the step engine's options that change the
    physics against their values when unused, scene.STEP_ONLY), whatever engine the scene
    names; the messages name the CLI's flags, as this engine's callers expect."""
    why = reference_refusal(scene)  # "`boundary` periodic"
    if why is not None:
        flag = why.replace("`", "--", 1).replace("`", "")
        raise SceneError(f"--engine reference (the exam's algorithm) handles hard elastic walls "
                         f"without gravity only, not {flag}; use --engine event")
    if any(getattr(scene, name) != STEP_ONLY[name] for name in STEP_PHYSICS):
        raise SceneError("--engine reference handles free flight between hard elastic walls only "
                         "(no drag, pair gravity, extra planes or damped walls); use --engine step")


STEP_PHYSICS = ("drag", "pair_gravity", "planes", "wall_restitution")
"""The step engine's options that change the motion (dt, softening without pair gravity and
print_every do not): the reference engine refuses them."""


def run(scene, state: State, recorder: Recorder | None = None) -> RunStats:
    """Run ``scene`` from ``state`` with the exam's algorithm; the reference engine.

    The same algorithm as :func:`simulation` (the loop is shared): catalogue
    list sorted by decreasing relative time, events invalidated by majCat,
    etape, every relative time shifted after each event. Generalised to the
    scene's per-particle radii (contact distance R_i + R_j) and masses
    (unequal-mass collisions). Hard elastic walls without gravity only:
    anything else raises SceneError.

    Events happen up to and including ``scene.duration`` T, never after; the
    final state is every particle flown to exactly T. The caller's state is
    not modified. Wall bounces (time = simulated time, |v| and |v_perp| just
    before the bounce, unchanged by it) go to ``recorder.add_bounces`` when
    ``recorder.want_bounces``, collisions (|J|) to ``add_collisions`` when
    ``recorder.want_collisions``, in chunks, in time order.

    Returns RunStats: events, wall_bounces, collisions, wall_time_s (the
    event loop, initCat included, timed with perf_counter), final State
    (copies), virial = sum over collisions of |J| (R_i + R_j), kg m^2/s, and
    extras (catalogue sizes, invalid events popped).
    """
    _check_scene(scene)
    if recorder is None:
        recorder = Recorder()
    if recorder.snapshot_every:
        raise SceneError("--engine reference (the exam's algorithm) writes no trajectory; "
                         "use --engine event with --trajectory")
    x = np.array(state.positions, dtype=float, copy=True)
    v = np.array(state.velocities, dtype=float, copy=True)
    n = scene.n
    if x.shape != (n, scene.dim) or v.shape != (n, scene.dim):
        raise SceneError(f"state of shape {x.shape}/{v.shape} does not match the scene "
                         f"({n} particles in {scene.dim}D)")
    masses = scene.masses()
    rayons = scene.radii()
    L = float(scene.length)
    T = float(scene.duration)
    want_b = bool(recorder.want_bounces)
    want_c = bool(recorder.want_collisions)
    particules = [[x[k], v[k]] for k in range(n)]  # views: vol and choc update x and v

    bounces: list[tuple] = []
    collisions: list[tuple] = []
    counts = {"wall_bounces": 0, "collisions": 0, "virial": 0.0}

    def flush_bounces():
        if bounces:
            t_, i_, w_, s_, p_ = zip(*bounces)
            recorder.add_bounces(np.array(t_), np.array(i_, dtype=np.int64),
                                 np.array(w_, dtype=np.int64), np.array(s_), np.array(p_))
            bounces.clear()

    def flush_collisions():
        if collisions:
            t_, i_, j_, J_ = zip(*collisions)
            recorder.add_collisions(np.array(t_), np.array(i_, dtype=np.int64),
                                    np.array(j_, dtype=np.int64), np.array(J_))
            collisions.clear()

    def rappel(t, e, parts):
        i, j, d = e[2], e[3], e[4]
        if j is None:
            counts["wall_bounces"] += 1
            if want_b:
                p = parts[i]
                bounces.append((t, i, _mur(p, d), math.sqrt(float(np.dot(p[1], p[1]))),
                                abs(float(p[1][d]))))
                if len(bounces) >= _CHUNK:
                    flush_bounces()
        else:
            counts["collisions"] += 1
            J = _impulsion(parts[i], parts[j], masses[i], masses[j])
            counts["virial"] += J * (rayons[i] + rayons[j])
            if want_c:
                collisions.append((t, i, j, J))
                if len(collisions) >= _CHUNK:
                    flush_collisions()

    debut = time.perf_counter()
    info = _boucle(particules, rayons, L, T, masses, rappel)
    wall_time = time.perf_counter() - debut
    flush_bounces()
    flush_collisions()
    final = State(x.copy(), v.copy(), np.array(state.kinds, copy=True))
    extras = {k: info[k] for k in ("catalogue_initial", "catalogue_max", "catalogue_final",
                                   "popped_invalid")}
    return RunStats(events=info["events"], wall_bounces=counts["wall_bounces"],
                    collisions=counts["collisions"], wall_time_s=wall_time, final=final,
                    virial=counts["virial"], extras=extras)
