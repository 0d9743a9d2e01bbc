"""The ideal path: particles that never meet, their wall bounces in closed form, no event queue.

It applies when no two particles can collide -- one particle, or point particles
(radius 0) -- in a box of elastic walls or a periodic box, without gravity or
any force of the step engine (:func:`reason_not`). Then each particle and each
axis move independently: a particle whose centre stays in [R, L - R] (length
l = L - 2R) at position u = x - R and velocity v != 0 first meets a wall at

    t0 = (l - u)/v   (v > 0, the wall at L)     or     u/|v|   (v < 0, the wall at 0),

then every tau = l/|v| after that, at the two walls in turn; its speed never
changes. The bounces of all particles are generated window by window of
simulated time (about :data:`CHUNK` at a time), put in time order
and handed to the recorder as the event engine would hand them: the same
rows, to rounding (the event engine accumulates its clock bounce after bounce,
this path computes t0 + k tau directly).

The state at any time follows from unfolding: w = u + v t taken modulo 2l and
folded back into [0, l], the velocity's sign flipped when the fold did.
"""

from __future__ import annotations

import math
import time

import numpy as np

from gaz_cli.model.recording import Recorder, RunStats, hand_snapshot
from gaz_cli.model.scene import Scene, State

CHUNK = 1 << 16
"""About this many bounces are generated, sorted and recorded at a time, or 2 N D if more
(a window costs O(N D) to set up): small enough to sort in cache; larger windows ran far
slower (measurements: docs/explanation/engine_measurements.md#ideal-engine)."""


def reason_not(scene: Scene) -> str | None:
    """Why the ideal path cannot run ``scene`` (one short clause), or None when it can."""
    if scene.n > 1 and any(sp.radius > 0 for sp in scene.species):
        return "particles of nonzero radius can collide"
    if scene.gravity != 0.0:
        return "gravity bends the flights"
    if scene.boundary == "walls" and scene.wall_restitution != 1.0:
        return "damped walls"
    if scene.drag or scene.pair_gravity or scene.planes:
        return "forces or extra planes of the step engine"
    return None


def run(scene: Scene, state: State, recorder: Recorder | None = None,
        start_time: float = 0.0) -> RunStats:
    """Simulate ``scene`` from ``state`` in closed form; the event engine's contract.

    Bounces go to ``recorder.add_bounces`` in time order, snapshots every
    ``recorder.snapshot_every`` s to ``recorder.add_snapshot``; the clock runs from
    ``start_time`` to ``start_time + scene.duration``. ``state`` is not modified.
    """
    from gaz_cli.errors import SceneError

    why = reason_not(scene)
    if why is not None:
        raise SceneError(f"engine 'ideal' cannot run this scene: {why}; use engine 'event'")
    recorder = recorder if recorder is not None else Recorder()
    wall_clock = time.perf_counter()
    flights = _Flights(scene, state)
    duration = float(scene.duration)
    bounces = flights.count(duration)
    if recorder.want_bounces and scene.boundary == "walls":
        _record(flights, duration, bounces, start_time, recorder)
    every = getattr(recorder, "snapshot_every", None)
    if every:
        kmax = int(math.floor(duration / every * (1.0 + 1e-12)))
        for k in range(kmax + 1):
            t = min(k * every, duration)
            x, v = flights.state_at(t)
            hand_snapshot(recorder, start_time + t, x, v, flights.images_at(t, x))
    x, v = flights.state_at(duration)
    final = State(x, v, np.asarray(state.kinds).copy())
    return RunStats(events=bounces, wall_bounces=bounces, collisions=0,
                    wall_time_s=time.perf_counter() - wall_clock, final=final,
                    extras={"bounces_in_closed_form": bounces})


class _Flights:
    """Each particle-axis's free flight: first wall time t0, period tau, first wall's sign."""

    def __init__(self, scene: Scene, state: State):
        self.dim = scene.dim
        self.periodic = scene.boundary == "periodic"
        self.length = float(scene.length)
        radius = np.asarray(scene.radii(), dtype=float)[:, None]
        x = np.asarray(state.positions, dtype=float)
        self.v = np.asarray(state.velocities, dtype=float)
        self.speed = np.sqrt(np.sum(self.v ** 2, axis=1))
        self.radius = np.broadcast_to(radius, x.shape)
        self.span = self.length - 2.0 * self.radius  # l, per particle-axis
        self.u = x - self.radius
        moving = self.v != 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            self.t0 = np.where(self.v > 0, (self.span - self.u) / self.v,
                               np.where(self.v < 0, self.u / -self.v, np.inf))
            self.tau = np.where(moving, self.span / np.abs(self.v), np.inf)
        self.t0 = np.maximum(self.t0, 0.0)
        self.first = np.where(self.v > 0, 1, -1)  # +: the wall at L first

    def count(self, duration: float) -> int:
        """Wall bounces in [0, duration) over all particles and axes."""
        if self.periodic:
            return 0
        return int(np.sum(self._bounces_before(duration)))

    def _bounces_before(self, t: float) -> np.ndarray:
        """(N, D) number of bounces at times < t."""
        with np.errstate(invalid="ignore"):
            k = np.ceil((t - self.t0) / self.tau)
        return np.where(self.t0 < t, np.maximum(k, 1.0), 0.0).astype(np.int64)

    def window(self, a: float, b: float) -> tuple:
        """Every bounce with a <= t < b: times, particles, walls, speeds, normal speeds (unsorted)."""
        k0 = self._bounces_before(a)
        k1 = self._bounces_before(b)
        counts = (k1 - k0).ravel()
        total = int(counts.sum())
        flat = np.repeat(np.arange(counts.size), counts)
        # k: the bounce's index along its flight, k0 .. k1 - 1
        starts = np.cumsum(counts) - counts
        k = (np.arange(total) - np.repeat(starts, counts)) + np.repeat(k0.ravel(), counts)
        t = self.t0.ravel()[flat] + k * self.tau.ravel()[flat]
        particle = flat // self.dim
        axis = flat % self.dim
        sign = self.first.ravel()[flat] * np.where(k % 2 == 0, 1, -1)
        wall = sign * (axis + 1)
        return (t, particle.astype(np.int64), wall.astype(np.int64), self.speed[particle],
                np.abs(self.v.ravel()[flat]))

    def images_at(self, t: float, x: np.ndarray) -> np.ndarray | None:
        """Periodic box: the box crossings (N, D) int64 that take the unwrapped position at
        t, x0 + v t, to the wrapped one x (:meth:`state_at`); None with walls."""
        if not self.periodic:
            return None
        return np.rint((self.u + self.v * t + self.radius - x) / self.length).astype(np.int64)

    def state_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities at time t (a fresh pair of (N, D) arrays)."""
        w = self.u + self.v * t
        if self.periodic:
            x = np.mod(w + self.radius, self.length)
            return x, self.v.copy()
        period = 2.0 * self.span
        m = np.mod(w, period)
        back = m > self.span
        u = np.where(back, period - m, m)
        return u + self.radius, np.where(back, -self.v, self.v)


def _record(flights: _Flights, duration: float, total: int, start_time: float,
            recorder: Recorder) -> None:
    """Hand every bounce to the recorder in time order, about CHUNK at a time."""
    per_window = max(CHUNK, 2 * flights.u.size)
    windows = max(1, math.ceil(total / per_window))
    # the windows' edges one at a time, as np.linspace(0, duration, windows + 1) gives them:
    # a run of 10^14 bounces (--force) asked for an array of 10^10 edges (MemoryError)
    step = duration / windows
    for w in range(windows):
        a = w * step
        b = duration if w == windows - 1 else (w + 1) * step
        t, particle, wall, speed, vperp = flights.window(a, b)
        if not len(t):
            continue
        order = np.argsort(t)  # exact ties (measure zero) in an order fixed by the input
        recorder.add_bounces(t[order] + start_time, particle[order], wall[order],
                             speed[order], vperp[order])
