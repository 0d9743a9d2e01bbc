"""The base of the trajectory writers, and what the formats share: units, the scene's
parameters as attributes, one line for an OS error.

:class:`TrajectoryWriter` is a :class:`~gaz_cli.model.recording.Recorder` that takes
only snapshots (``snapshot_every`` = the requested interval); every engine calls its
``add_snapshot(t, positions, velocities)`` at t = 0, every, 2 every, ... Each format
(:mod:`gaz_cli.outputs.h5md`, :mod:`gaz_cli.outputs.gsd`, :mod:`gaz_cli.outputs.vtk`)
subclasses it with its ``_write`` and ``close``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from gaz_cli import interrupts
from gaz_cli.errors import SceneError
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene

NM, PS = 1e-9, 1e-12
"""The files' units of length and time (nanometre, picosecond), in metres and seconds."""

DALTON = 1.66053906660e-27
"""kg; GSD's masses are in daltons."""

LENGTH_UNITS = {"m": 1.0, "nm": NM, "pm": 1e-12, "fm": 1e-15, "Angstrom": 1e-10, "A": 1e-10, "angstrom": 1e-10}
TIME_UNITS = {"s": 1.0, "ps": PS, "fs": 1e-15, "ns": 1e-9}
"""Unit strings gaz reads back (files of older gaz versions were in m and s)."""


class TrajectoryWriter(Recorder):
    """Base of the writers: a Recorder that wants snapshots only."""

    want_bounces = False
    want_collisions = False
    want_images = False

    def __init__(self, path: Path, every: float, scene: Scene):
        self.path = Path(path)  # the file written
        self.name = getattr(self, "name", self.path)  # the file named in messages
        self.snapshot_every = every
        self.scene = scene
        self.count = 0
        self._last_t = -np.inf
        self._image = self._previous = None  # periodic images so far, and the last positions

    def add_snapshot(self, t, positions, velocities, images=None) -> None:
        positions = np.asarray(positions, dtype=np.float64)
        velocities = np.asarray(velocities, dtype=np.float64)
        if positions.shape != (self.scene.n, self.scene.dim) or velocities.shape != positions.shape:
            raise SceneError(f"snapshot of shape {positions.shape}, expected ({self.scene.n}, {self.scene.dim})")
        if images is not None:
            images = np.asarray(images)
            if images.shape != positions.shape:
                raise SceneError(f"images of shape {images.shape}, expected {positions.shape}")
        if t < self._last_t:
            raise SceneError(f"snapshot at t = {t} s after one at {self._last_t} s: snapshots must come in time order")
        self._last_t = float(t)
        with interrupts.held():  # a snapshot is in the file whole, and counted, or not at all
            self._write(float(t), positions, velocities, images)
            self.count += 1

    def _write(self, t: float, positions: np.ndarray, velocities: np.ndarray,
               images: np.ndarray | None) -> None:
        """One snapshot into the file(s); images (N, D) or None (see :meth:`add_snapshot`)."""
        raise NotImplementedError

    def _images(self, positions: np.ndarray, images: np.ndarray | None) -> np.ndarray:
        """(N, D) int32 box crossings since the start of a periodic run's snapshot: the
        engine's count when it hands one, else inferred from the previous snapshot by the
        minimum image (module docstring); for the writers that store them (H5MD, GSD)."""
        if self._image is None:
            self._image = np.zeros(positions.shape, dtype=np.int32)
        if images is not None:  # the engine's count
            self._image = images.astype(np.int32)
        elif self._previous is not None:  # no count given: the minimum image
            self._image -= np.rint((positions - self._previous) / self.scene.length).astype(np.int32)
        self._previous = positions.copy()
        return self._image

    def close(self) -> None:
        """Finish the file(s); idempotent."""

    def commit(self) -> None:
        """Put the finished file(s) in place, once the run is stored: nothing to do for a format
        written to one file (its caller renames it, :mod:`gaz_cli.atomic`); a VTK collection's
        files move from their temporary folder."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def reason(err: OSError) -> str:
    """One line for an OS error: its strerror ("No space left on device"), not HDF5's report."""
    if getattr(err, "errno", None):
        return os.strerror(err.errno)
    return " ".join(str(err).split())


def scene_attributes(scene: Scene) -> dict:
    """Scalar scene parameters as HDF5/XML friendly values."""
    out = {
        "dim": scene.dim, "length": scene.length, "duration": scene.duration,
        "temperature": scene.temperature, "seed": -1 if scene.seed is None else int(scene.seed),
        "boundary": scene.boundary, "engine": scene.engine, "gravity": scene.gravity,
        "restitution": scene.restitution, "drag": scene.drag, "pair_gravity": scene.pair_gravity,
        "wall_restitution": scene.wall_restitution,
        "species_names": np.array([s.name for s in scene.species], dtype="S"),
    }
    if scene.dt is not None:
        out["dt"] = scene.dt
    return {k: np.bytes_(v) if isinstance(v, str) else v for k, v in out.items()}  # fixed-length


def text(value) -> str:
    """An HDF5 string attribute (fixed-length bytes or str) as str."""
    if isinstance(value, np.ndarray):
        value = value.item() if value.shape == () else value[0]
    return value.decode() if isinstance(value, bytes) else str(value)


MAX_READ_BYTES = 4 << 30
"""The most a trajectory read back may hold in memory (positions and velocities: 4 GiB);
a larger file is refused in one line before it is read (issue 39: unbounded reads)."""


def check_read_size(path, nbytes: int) -> None:
    """SceneError when reading ``nbytes`` of snapshots from ``path`` would pass :data:`MAX_READ_BYTES`."""
    if nbytes > MAX_READ_BYTES:
        raise SceneError(f"trajectory {str(path)!r} holds {nbytes / 2**30:.3g} GiB of snapshots, more than the "
                         f"{MAX_READ_BYTES >> 30} GiB gaz reads back; write fewer snapshots (a larger --every)")
