"""Ready-made scenes of the seeds for the time-stepped engine.

``PRESETS[name]() -> (Scene, State)``; the state is explicit because these
scenes are not gases at a temperature (the Scene's temperature is a
placeholder that only satisfies validation).

comet (seed 003, "la Tierra y un cometa")
    2D, SI units. The Earth (5.972e24 kg, radius 6.371e6 m) at the centre of
    a 1e9 m box and a Halley-sized comet (2.2e14 kg, radius 5.5 km) on a bound
    orbit of eccentricity 0.9 around it: apogee 4e8 m (about the Moon's
    distance), perigee 2.1e7 m (3.3 Earth radii), period about 9.7e5 s
    (11 days). Pair gravity G = 6.674e-11, softening 1 km, no walls touched,
    three orbits (duration 2.9e6 s) with dt = 60 s. Total momentum zero, so
    the Earth wobbles by about 1.5 cm. Watch energy and angular momentum
    in the diagnostics (print_every 4000).

marbles (seed 002, the C++ "marble" case)
    3D, 300 glass marbles (radius 8 mm, 5.36 g) dropped in a 0.5 m box under
    gravity 9.81 m/s^2, air friction gamma = 0.2 1/s, restitution 0.9 between
    marbles and 0.7 on the walls, a ramp across the floor (the plane
    z = 0.1 - 0.2 x, restitution 0.7); placed at random in the upper half of
    the box with random velocities of about 1 m/s (seeded), 2 s with
    dt = 2e-4 s, diagnostics every 1000 steps. The marbles fall, bounce and settle on the ramp.
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.errors import PlacementError
from gaz_cli.scene import Scene, State
from gaz_cli.species import Species

G_NEWTON = 6.674e-11
"""Newtonian constant of gravitation, m^3 kg^-1 s^-2 (CODATA 2018: 6.67430e-11)."""

EARTH = Species("Earth", 5.972e24, 6.371e6)
COMET = Species("comet", 2.2e14, 5.5e3)
MARBLE = Species("marble", 2500.0 * 4.0 / 3.0 * math.pi * 0.008 ** 3, 0.008)


def comet(apogee: float = 4.0e8, perigee: float = 2.1e7, orbits: float = 3.0,
          dt: float = 60.0, seed: int = 3) -> tuple[Scene, State]:
    """The Earth and a comet on an eccentric orbit (seed 003); see the module docstring."""
    m1, m2 = EARTH.mass, COMET.mass
    mu = G_NEWTON * (m1 + m2)
    a = 0.5 * (apogee + perigee)
    period = 2.0 * math.pi * math.sqrt(a ** 3 / mu)
    v_apo = math.sqrt(mu * (2.0 / apogee - 1.0 / a))  # relative speed at apogee
    length = 1.0e9
    centre = 0.5 * length
    # relative vector r = r_comet - r_earth = (apogee, 0), v = (0, v_apo); centre of mass at the box centre
    f1, f2 = m2 / (m1 + m2), m1 / (m1 + m2)
    positions = np.array([[centre - f1 * apogee, centre], [centre + f2 * apogee, centre]])
    velocities = np.array([[0.0, -f1 * v_apo], [0.0, f2 * v_apo]])
    duration = orbits * period
    duration = dt * math.ceil(duration / dt)
    scene = Scene(dim=2, length=length, duration=duration, components=((EARTH, 1), (COMET, 1)),
                  temperature=300.0, seed=seed, engine="step", dt=dt, pair_gravity=G_NEWTON,
                  softening=1.0e3, print_every=4000, placement="rejection",
                  extras={"period": period, "preset": "comet"})
    return scene, State(positions, velocities, scene.kinds())


def marbles(n: int = 300, duration: float = 2.0, dt: float = 2.0e-4, seed: int = 2) -> tuple[Scene, State]:
    """Marbles falling in a box with friction, inelastic collisions and damped walls (seed 002)."""
    length = 0.5
    # a ramp: the plane z = 0.1 - 0.2 x, from 0.1 m high at x = 0 down to the floor at x = L
    ramp = ((0.0, 0.0, 0.10), _unit((0.2, 0.0, 1.0)), 0.7)
    scene = Scene(dim=3, length=length, duration=duration, components=((MARBLE, n),),
                  temperature=300.0, seed=seed, engine="step", dt=dt, gravity=9.81, drag=0.2,
                  restitution=0.9, wall_restitution=0.7, planes=(ramp,), print_every=1000,
                  extras={"preset": "marbles"})
    rng = np.random.default_rng(seed)
    positions = _upper_half(rng, scene.radii(), length)
    velocities = rng.normal(0.0, 1.0 / math.sqrt(3.0), size=(n, 3))
    return scene, State(positions, velocities, scene.kinds())


def _upper_half(rng: np.random.Generator, radii: np.ndarray, length: float) -> np.ndarray:
    """(N, 3) non-overlapping centres in the upper half of the box (z in [L/2, L - R]).

    Random sequential addition with an O(N^2) check: meant for the preset's
    few hundred dilute marbles.
    """
    n = radii.size
    out = np.empty((n, 3))
    k = 0
    for _ in range(1000 * n):
        if k == n:
            break
        r = radii[k]
        p = rng.uniform([r, r, 0.5 * length], [length - r, length - r, length - r])
        if k == 0 or np.all(np.sum((out[:k] - p) ** 2, axis=1) >= (radii[:k] + r) ** 2):
            out[k] = p
            k += 1
    if k < n:
        raise PlacementError(f"could place only {k} of {n} marbles in the upper half of the box")
    return out


def _unit(v) -> tuple:
    v = np.asarray(v, dtype=float)
    return tuple(v / np.linalg.norm(v))


PRESETS = {
    "comet": comet,
    "marbles": marbles,
}
"""Preset name -> callable returning (Scene, State)."""
