"""GSD trajectories (``.gsd``): the writer and the reader; need the gsd package.

GSD (HOOMD-blue's format) through the ``gsd`` package (``pip install 'gaz[gsd]'``): one
frame per snapshot, HOOMD's conventions: the box centred on the origin (positions shifted by
-L/2), float32 positions in nm, velocities in nm/ps, diameters in nm, masses in daltons,
particle types named by species; ``configuration.step`` is k. 1D runs are written as 2D
(y = 0). In a periodic box ``particles/image`` holds the box crossings as H5MD's ``image``
does (position + image * box is the unwrapped position; HOOMD's own convention).

GSD has no walls: every GSD box is periodic. A run between walls is written in the same box
(its particles never leave it, never cross it) and each frame's log says so:

``gaz/walls``
    [1] for a run between hard walls at 0 and L on every axis: the box's periodicity is
    then not the run's (in OVITO untick the cell's periodic boundary conditions, in freud
    make the box with ``periodic=False``); [0] for a periodic run.
``gaz/time_ps``
    the snapshot's time, ps.
``gaz/dimension``
    the run's dimension (1 for a run written as 2D).

Opened as each tool's own documentation says:

- OVITO (GUI: File > Load File; Python: ``ovito.io.import_file("run.gsd")``): particles
  with Position, Velocity, Radius, Mass and Particle Type; the log entries become global
  attributes (``gaz/walls``, ``gaz/time_ps``, ``gaz/dimension``).
- freud: ``freud.box.Box.from_box(frame.configuration.box)`` and ``frame.particles.position``
  of ``frame = gsd.hoomd.open("run.gsd")[k]``.
- HOOMD-blue: ``simulation.create_state_from_gsd("run.gsd", frame=k)``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from gaz_cli.errors import OutputError, SceneError
from gaz_cli.model.scene import Scene
from gaz_cli.outputs.writer import DALTON, NM, PS, TrajectoryWriter, check_read_size, reason


class GSDWriter(TrajectoryWriter):
    """GSD file, one frame per snapshot (see the module docstring); needs the gsd package."""

    def __init__(self, path: Path, every: float, scene: Scene):
        super().__init__(path, every, scene)
        gsd_hoomd = gsd_hoomd_module()
        try:
            self.file = gsd_hoomd.open(name=str(self.path), mode="w")
        except OSError as err:
            raise OutputError(f"cannot write --trajectory {str(self.name)!r}: {reason(err)}") from None
        self._hoomd = gsd_hoomd
        self.periodic = scene.boundary == "periodic"
        self.want_images = self.periodic
        self._walls = np.array([0 if self.periodic else 1], dtype=np.uint8)
        d, length = scene.dim, scene.length / NM
        # GSD boxes are 2D (Lz = 0) or 3D: a 1D run is drawn in a square, on y = 0
        self._box = [length, length, length if d == 3 else 0.0, 0.0, 0.0, 0.0]
        self._types = [s.name for s in scene.species]
        self._typeid = scene.kinds().astype(np.uint32)
        self._diameter = (2.0 * scene.radii() / NM).astype(np.float32)
        self._mass = (scene.masses() / DALTON).astype(np.float32)

    def _write(self, t, positions, velocities, images=None):
        if self.file is None:
            raise SceneError(f"--trajectory {str(self.name)!r} is closed")
        n, d = positions.shape
        frame = self._hoomd.Frame()
        frame.configuration.step = self.count
        frame.configuration.dimensions = 3 if d == 3 else 2
        frame.configuration.box = self._box
        pos = np.zeros((n, 3), dtype=np.float32)
        pos[:, :d] = positions / NM - 0.5 * self.scene.length / NM
        vel = np.zeros((n, 3), dtype=np.float32)
        vel[:, :d] = velocities * (PS / NM)
        frame.particles.N = n
        frame.particles.types = self._types
        frame.particles.typeid = self._typeid
        frame.particles.position = pos
        frame.particles.velocity = vel
        frame.particles.diameter = self._diameter
        frame.particles.mass = self._mass
        if self.periodic:
            image = np.zeros((n, 3), dtype=np.int32)
            image[:, :d] = self._images(positions, images)
            frame.particles.image = image
        frame.log["gaz/time_ps"] = np.array([t / PS])
        frame.log["gaz/dimension"] = np.array([d], dtype=np.int32)
        frame.log["gaz/walls"] = self._walls
        try:
            self.file.append(frame)
        except OSError as err:
            self._discard()
            raise OutputError(f"cannot write --trajectory {str(self.name)!r} (snapshot {self.count}): "
                             f"{reason(err)}; the file was removed") from None

    def close(self):
        if self.file is not None:
            f, self.file = self.file, None
            try:
                f.close()
            except OSError as err:
                self._remove()
                raise OutputError(f"cannot finish --trajectory {str(self.name)!r}: {reason(err)}; "
                                 "the file was removed") from None

    def _discard(self) -> None:
        f, self.file = self.file, None
        if f is not None:
            try:
                f.close()
            except OSError:
                pass
        self._remove()

    def _remove(self) -> None:
        try:
            os.unlink(self.path)
        except OSError:
            pass


def gsd_hoomd_module():
    """The gsd package's ``gsd.hoomd``, or one OutputError line naming the extra to install."""
    try:
        import gsd.hoomd
    except ImportError:
        raise OutputError("GSD trajectories (.gsd) need the gsd package: pip install 'gaz[gsd]' "
                          "(or pip install gsd)") from None
    return gsd.hoomd



def read_gsd(path: str | os.PathLike) -> dict:
    """Read a GSD trajectory written by :class:`GSDWriter` (see :func:`~gaz_cli.outputs.trajectory.read_trajectory`)."""
    gsd_hoomd = gsd_hoomd_module()
    try:
        f = gsd_hoomd.open(name=str(path), mode="r")
    except (OSError, RuntimeError, ValueError) as err:
        raise SceneError(f"cannot read trajectory {str(path)!r}: {err}") from None
    with f:
        if len(f) == 0:
            raise SceneError(f"trajectory {str(path)!r} holds no snapshot")
        first = f[0]
        dim = int(first.log["gaz/dimension"][0]) if "gaz/dimension" in first.log \
            else int(first.configuration.dimensions)
        box = np.asarray(first.configuration.box[:dim], dtype=np.float64) * NM
        # (every GSD box is periodic: the log says whether the run's was; a file without it does not say)
        periodic = "gaz/walls" in first.log and int(first.log["gaz/walls"][0]) == 0
        check_read_size(path, len(f) * int(first.particles.N) * dim * 16)
        frames = [f[k] for k in range(len(f))]
    positions = np.stack([fr.particles.position[:, :dim] for fr in frames]).astype(np.float64) * NM + box / 2
    velocities = np.stack([fr.particles.velocity[:, :dim] for fr in frames]).astype(np.float64) * (NM / PS)
    time = np.array([fr.log["gaz/time_ps"][0] * PS if "gaz/time_ps" in fr.log else fr.configuration.step
                     for fr in frames])
    return {"time": time, "positions": positions, "velocities": velocities,
            "species": first.particles.typeid.astype(np.int64),
            "radius": first.particles.diameter.astype(np.float64) * NM / 2, "box": box,
            "species_names": list(first.particles.types), "dim": dim, "periodic": periodic}
