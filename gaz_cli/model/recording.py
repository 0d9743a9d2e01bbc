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

    profile_samples = 0
    """How many times the engine hands the particles' positions to ``add_profile_sample``:
    at (k + 1/2) duration / profile_samples, k = 0 .. profile_samples - 1 (0: never; an
    engine that cannot sample ignores it, and the run has no profile)."""

    def add_profile_sample(self, t: float, positions: np.ndarray) -> None:
        """The positions (N, D) float64, m, at simulated time t (a profile sample); the
        recorder copies what it keeps (:class:`DensityProfile` histograms them)."""

    def diagnostic(self, values: dict) -> None:
        """Periodic diagnostics of a run (time, energies, largest speed, counts...)."""

    wants_progress = False
    """Whether the engine should report progress often (the event engine then returns from
    its kernel at least every gaz_cli.progress.EVENTS_PER_REPORT events)."""

    def progress(self, t: float, events: int) -> None:
        """The run reached simulated time t (s) after ``events`` events (wall bounces and
        collisions so far). Called once the kernels are compiled (t = the start), then
        after each kernel call (gaz_cli.progress draws a bar from it)."""


PROFILE_SAMPLES = 256
"""Position samples a run with a density profile takes, evenly spaced over its duration: 4 a block
(the middle density relaxes over many samples; 512 cost twice as much, 0.05 s on issue 38's 2D box,
for the same degrees of freedom)."""
PROFILE_BLOCKS = 64
"""Blocks the samples are summed in (PROFIL.PR_BLOCK): 4 samples a block, the series whose
autocorrelation gives the profile's error."""
PROFILE_BINS = 32
"""Bins of the box side along each axis (PROFIL.PR_BIN)."""
PROFILE_MIN_SIDE = 20.0
"""Smallest box side, in diameters, of a profile: the middle half of the box then stays 4.5
diameters from every wall (L/4 - R >= 4.5 sigma), past the layering of a fluid at walls (at
14.5 diameters, 2D packing 0.45, the wall pressures sat 0.5 sigma above the middle's EOS on
average: benchmarks/error_coverage.py's dense-2d, 2026-11-28)."""


def profile_wanted(scene) -> bool:
    """Whether a run of ``scene`` records the density profile (PROFIL): the middle-of-the-box
    density that the wall pressure is compared with (mechanical equilibrium; gaz analyse).
    Only where that comparison holds: walls, 2D or 3D, one species, no gravity or other
    force, elastic, a box of at least PROFILE_MIN_SIDE diameters, rows recorded, and a
    density where the first-order wall model may be off by PROFILE_FROM_SHIFT or more."""
    if (scene.boundary != "walls" or scene.dim < 2 or len(scene.components) != 1 or scene.record == "none"
            or scene.gravity > 0.0 or scene.restitution < 1.0 or scene.wall_restitution < 1.0
            or scene.drag > 0.0 or scene.pair_gravity > 0.0 or scene.planes):
        return False
    radius = float(scene.components[0][0].radius)
    if not (radius > 0.0 and scene.length >= PROFILE_MIN_SIDE * 2.0 * radius):
        return False
    from gaz_cli.errors import SceneError
    from gaz_cli.theory import wall_adsorption_shift   # the first-order wall model's systematic error
    try:
        return abs(float(wall_adsorption_shift(scene.dim, scene.length, scene.n, radius))) >= PROFILE_FROM_SHIFT
    except SceneError:      # denser than the EOS's range at N/(L - 2R)^D: the middle may still be a fluid
        return True


PROFILE_FROM_SHIFT = 1e-4
"""A dilute box needs no profile: its wall pressure is compared with the first-order wall model,
whose systematic error (wall adsorption) is then below 1e-4 relative (the README's argon: 1e-5)."""


class DensityProfile:
    """The time-averaged density of centres along each axis, from position samples.

    Along axis d, the centres whose other coordinates lie in the middle half of the box
    (|x_j - L/2| < L/4, j != d: a tube through the box's middle, away from the side walls)
    are counted in PROFILE_BINS bins of [0, L]; the counts of the samples of one block
    are summed. ``counts`` (D, PROFILE_BLOCKS, PROFILE_BINS) int64, ``samples``
    (PROFILE_BLOCKS,) int64 the samples each block holds. O(N D) a sample.
    """

    def __init__(self, dim: int, length: float, samples: int = PROFILE_SAMPLES):
        self.dim, self.length, self.total = int(dim), float(length), int(samples)
        self.counts = np.zeros((self.dim, PROFILE_BLOCKS, PROFILE_BINS), dtype=np.int64)
        self.samples = np.zeros(PROFILE_BLOCKS, dtype=np.int64)
        self._taken = 0

    def add(self, positions: np.ndarray) -> None:
        x = np.asarray(positions, dtype=float) / self.length
        block = min(self._taken * PROFILE_BLOCKS // self.total, PROFILE_BLOCKS - 1)
        self._taken += 1
        self.samples[block] += 1
        middle = np.abs(x - 0.5) < 0.25
        others = middle.sum(axis=1)[:, None] - middle == self.dim - 1   # (N, D): in the tube along d
        cells = np.clip((x * PROFILE_BINS).astype(np.int64), 0, PROFILE_BINS - 1)
        for d in range(self.dim):
            self.counts[d, block] += np.bincount(cells[others[:, d], d], minlength=PROFILE_BINS)


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
