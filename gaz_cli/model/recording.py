"""What engines report, and where they report it.

Engines know nothing of the database. They receive a :class:`Recorder` and
hand it arrays, in time order, chunk by chunk; the store implements one that
writes rows, tests use :class:`MemoryRecorder`. At the end an engine returns
a :class:`RunStats`.

Wall convention (the exam's RE_DIR): for the axis d (0, 1, 2), ``+(d+1)`` is
the wall at coordinate L and ``-(d+1)`` the wall at 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gaz_cli.model.scene import State


class Recorder:
    """Sink for events. The base class records nothing (``--record none``).

    ``want_bounces`` / ``want_collisions`` tell the engine whether to collect
    those arrays at all: an engine must not spend time on what nobody wants.

    The arrays an engine hands are the recorder's to keep: made for the call, never
    modified by the engine afterwards (a recorder keeps them without a copy; it must not
    modify them either, :class:`gaz_cli.run.runner.Tee` hands the same arrays to several).
    """

    want_bounces = False
    want_collisions = False
    snapshot_every: float | None = None
    """Simulated seconds between snapshots (trajectory output); None for none."""
    want_images = False
    """Whether ``add_snapshot`` takes ``images=`` (periodic box crossings; see
    :func:`hand_snapshot`)."""

    def add_bounces(self, t: np.ndarray, particle: np.ndarray, wall: np.ndarray,
                    speed: np.ndarray, vperp: np.ndarray) -> None:
        """A chunk of wall bounces, in time order.

        t (k,) float64 s, simulated time of the bounce; particle (k,) int64
        index 0..N-1; wall (k,) int64 signed RE_DIR; speed (k,) float64 |v| m/s
        and vperp (k,) float64 |v_perp| m/s, both taken just before the bounce.
        """

    def add_collisions(self, t: np.ndarray, i: np.ndarray, j: np.ndarray,
                       impulse: np.ndarray) -> None:
        """A chunk of particle-particle collisions, in time order.

        t (k,) float64 s; i, j (k,) int64 particle indices; impulse (k,)
        float64, |momentum| transferred, kg m/s.
        """

    def add_snapshot(self, t: float, positions: np.ndarray, velocities: np.ndarray,
                     images: np.ndarray | None = None) -> None:
        """The whole state at simulated time t = k * snapshot_every (k = 0, 1, ...).

        positions, velocities (N, D) float64; the recorder copies what it keeps. images
        (N, D) int64, given to a recorder that wants them (``want_images``) in a periodic
        box: each particle's box crossings since the start along each axis, counted by the
        engine (positions + images L is the unwrapped position); None otherwise.
        """

    def diagnostic(self, values: dict) -> None:
        """Periodic diagnostics of a run (time, energies, largest speed, counts...)."""

    wants_progress = False
    """Whether the engine should report progress often (the event engine then returns from
    its kernel at least every gaz_cli.progress.EVENTS_PER_REPORT events)."""

    def progress(self, t: float, events: int) -> None:
        """The run reached simulated time t (s) after ``events`` events (wall bounces and
        collisions so far). Called once the kernels are compiled (t = the start), then
        after each kernel call (gaz_cli.progress draws a bar from it)."""


def hand_snapshot(recorder: Recorder, t: float, positions: np.ndarray, velocities: np.ndarray,
                  images: np.ndarray | None) -> None:
    """An engine's snapshot to ``recorder``, with the images if it has them and the recorder
    wants them (a recorder written before images keeps its three arguments)."""
    if images is not None and getattr(recorder, "want_images", False):
        recorder.add_snapshot(t, positions, velocities, images=images)
    else:
        recorder.add_snapshot(t, positions, velocities)


class MemoryRecorder(Recorder):
    """Keeps every chunk in memory (the engine's arrays, see :class:`Recorder`); for tests
    and small runs."""

    want_bounces = True

    def __init__(self, collisions: bool = False):
        self.want_collisions = collisions
        self._bounces: list[tuple] = []
        self._collisions: list[tuple] = []

    def add_bounces(self, t, particle, wall, speed, vperp):
        self._bounces.append(tuple(np.asarray(a) for a in (t, particle, wall, speed, vperp)))

    def add_collisions(self, t, i, j, impulse):
        self._collisions.append(tuple(np.asarray(a) for a in (t, i, j, impulse)))

    def bounces(self) -> dict[str, np.ndarray]:
        """All bounces so far: dict of arrays t, particle, wall, speed, vperp."""
        names = ("t", "particle", "wall", "speed", "vperp")
        return _concat(self._bounces, names, (float, np.int64, np.int64, float, float))

    def collisions(self) -> dict[str, np.ndarray]:
        """All collisions so far: dict of arrays t, i, j, impulse."""
        names = ("t", "i", "j", "impulse")
        return _concat(self._collisions, names, (float, np.int64, np.int64, float))


def _concat(chunks, names, dtypes):
    if not chunks:
        return {n: np.empty(0, dtype=d) for n, d in zip(names, dtypes)}
    return {n: np.concatenate([c[k] for c in chunks]).astype(d, copy=False)
            for k, (n, d) in enumerate(zip(names, dtypes))}


@dataclass
class RunStats:
    """What an engine returns.

    ``virial`` is the collisional virial sum over particle-particle
    collisions, sum |J| * sigma_ij (kg m^2/s), from which the periodic-box
    pressure follows: P V = N k T + virial / (D * duration).
    ``extras`` holds engine-specific metrics (queue sizes, passes, phase times).
    """

    events: int
    wall_bounces: int
    collisions: int
    wall_time_s: float
    final: State
    virial: float = 0.0
    extras: dict = field(default_factory=dict)
