"""Trajectories: snapshots of every particle, for ParaView, h5py and ``gaz animate``.

:func:`open_trajectory` returns a :class:`TrajectoryWriter`, a
:class:`~gaz_cli.recording.Recorder` that takes only snapshots
(``snapshot_every`` = the requested interval); every engine calls its
``add_snapshot(t, positions, velocities)`` at t = 0, every, 2 every, ...
The format follows the file's extension:

``.h5`` / ``.hdf5``
    HDF5 in the H5MD 1.1 layout (https://www.nongnu.org/h5md/h5md.html), through h5py::

        /h5md                      version [1, 1]; author, creator (gaz)
        /particles/all/box         attrs dimension, boundary; edges (D,) m
        /particles/all/position    value (T, N, D) m, time (T,) s, step (T,)
        /particles/all/velocity    value (T, N, D) m/s, time, step
        /particles/all/species     (N,) int, index into /parameters species_names
        /particles/all/mass        (N,) kg
        /particles/all/radius      (N,) m (not an H5MD name; read by gaz animate)
        /parameters                attrs of the scene (dim, length, duration, seed, engine...)

    ``step`` is the snapshot index k (t = k * every).

``.pvd`` / ``.vtu``
    VTK XML for ParaView, written by meshio: one ``STEM_00000.vtu`` per
    snapshot (points padded to 3D, one vertex cell per particle, point data
    velocity, species, radius; use a Glyph filter scaled by radius to see
    the disks) and a ``STEM.pvd`` collection that gives ParaView the times.
    Open the .pvd.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from gaz_cli import interrupts
from gaz_cli.errors import OutputError, SceneError
from gaz_cli.recording import Recorder
from gaz_cli.scene import Scene

FORMATS = {".h5": "h5md", ".hdf5": "h5md", ".pvd": "vtk", ".vtu": "vtk"}
"""File extension -> format."""


def open_trajectory(path: str | os.PathLike, every: float, scene: Scene) -> "TrajectoryWriter":
    """A writer of snapshots every ``every`` simulated seconds to ``path`` (format by extension).

    Use as a context manager, or call ``close()``. Raises SceneError for an
    unknown extension, a bad interval or a directory that does not exist.
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise SceneError(f"--trajectory {str(path)!r}: unknown extension {path.suffix!r}; "
                         "use .h5 (HDF5/H5MD) or .pvd (VTK for ParaView)")
    if every is None or not np.isfinite(every) or every <= 0:
        raise SceneError(f"--every must be a positive number of simulated seconds, got {every}")
    directory = path.resolve().parent
    if not directory.is_dir():
        raise SceneError(f"--trajectory {str(path)!r}: directory {str(directory)!r} does not exist")
    cls = H5MDWriter if fmt == "h5md" else VTKWriter
    return cls(path, float(every), scene)


class TrajectoryWriter(Recorder):
    """Base of the writers: a Recorder that wants snapshots only."""

    want_bounces = False
    want_collisions = False

    def __init__(self, path: Path, every: float, scene: Scene):
        self.path = Path(path)
        self.snapshot_every = every
        self.scene = scene
        self.count = 0
        self._last_t = -np.inf

    def add_snapshot(self, t, positions, velocities) -> None:
        positions = np.asarray(positions, dtype=np.float64)
        velocities = np.asarray(velocities, dtype=np.float64)
        if positions.shape != (self.scene.n, self.scene.dim) or velocities.shape != positions.shape:
            raise SceneError(f"snapshot of shape {positions.shape}, expected ({self.scene.n}, {self.scene.dim})")
        if t < self._last_t:
            raise SceneError(f"snapshot at t = {t} s after one at {self._last_t} s: snapshots must come in time order")
        self._last_t = float(t)
        with interrupts.held():  # a snapshot is in the file whole, and counted, or not at all
            self._write(float(t), positions, velocities)
            self.count += 1

    def _write(self, t: float, positions: np.ndarray, velocities: np.ndarray) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Finish the file(s); idempotent."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _reason(err: OSError) -> str:
    """One line for an OS error: its strerror ("No space left on device"), not HDF5's report."""
    if getattr(err, "errno", None):
        return os.strerror(err.errno)
    return " ".join(str(err).split())


def _scene_attributes(scene: Scene) -> dict:
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
    return out


class H5MDWriter(TrajectoryWriter):
    """HDF5 file in the H5MD layout (see the module docstring)."""

    def __init__(self, path: Path, every: float, scene: Scene):
        super().__init__(path, every, scene)
        import h5py

        from gaz_cli import __version__

        try:
            # no raw-data chunk cache: each snapshot goes to the file as it is written, so a full
            # disk is met at that write, not at close with a cache of dirty chunks HDF5 cannot
            # flush (it then crashed the interpreter at exit: exit 139)
            self.file = h5py.File(self.path, "w", rdcc_nbytes=0)
        except OSError as err:
            raise OutputError(f"cannot write --trajectory {str(self.path)!r}: {_reason(err)}") from None
        f = self.file
        h5md = f.create_group("h5md")
        h5md.attrs["version"] = np.array([1, 1], dtype=np.int32)
        f.create_group("h5md/author").attrs["name"] = "gaz user"
        creator = f.create_group("h5md/creator")
        creator.attrs["name"] = "gaz"
        creator.attrs["version"] = __version__
        n, d = scene.n, scene.dim
        part = f.create_group("particles/all")
        box = part.create_group("box")
        box.attrs["dimension"] = np.int32(d)
        boundary = "periodic" if scene.boundary == "periodic" else "none"
        box.attrs["boundary"] = np.array([boundary] * d, dtype="S")
        edges = box.create_dataset("edges", data=np.full(d, scene.length))
        edges.attrs["unit"] = "m"
        part.create_dataset("species", data=scene.kinds().astype(np.int32))
        part.create_dataset("mass", data=scene.masses()).attrs["unit"] = "kg"
        part.create_dataset("radius", data=scene.radii()).attrs["unit"] = "m"
        self._elements = {}
        for name, unit in (("position", "m"), ("velocity", "m s-1")):
            g = part.create_group(name)
            value = g.create_dataset("value", shape=(0, n, d), maxshape=(None, n, d),
                                     chunks=(1, n, d), dtype=np.float64)
            value.attrs["unit"] = unit
            time = g.create_dataset("time", shape=(0,), maxshape=(None,), chunks=(256,), dtype=np.float64)
            time.attrs["unit"] = "s"
            step = g.create_dataset("step", shape=(0,), maxshape=(None,), chunks=(256,), dtype=np.int64)
            self._elements[name] = (value, time, step)
        params = f.create_group("parameters")
        for key, val in _scene_attributes(scene).items():
            params.attrs[key] = val
        params.attrs["snapshot_every"] = every

    def _write(self, t, positions, velocities):
        if self.file is None:
            raise SceneError(f"--trajectory {str(self.path)!r} is closed")
        k = self.count
        try:
            for name, data in (("position", positions), ("velocity", velocities)):
                value, time, step = self._elements[name]
                value.resize(k + 1, axis=0)
                time.resize(k + 1, axis=0)
                step.resize(k + 1, axis=0)
                value[k] = data
                time[k] = t
                step[k] = k
        except OSError as err:
            self._discard()
            raise OutputError(f"cannot write --trajectory {str(self.path)!r} (snapshot {k}): "
                             f"{_reason(err)}; the file was removed") from None

    def close(self):
        if self.file is not None:
            try:
                self.file.close()
                self.file = None
            except OSError as err:
                self._discard()
                raise OutputError(f"cannot finish --trajectory {str(self.path)!r}: {_reason(err)}; "
                                 "the file was removed") from None

    def _discard(self) -> None:
        """Close and delete a file that could not be written (a full disk, mostly).

        HDF5 keeps what it could not write and tries again at close and at exit, where a
        failure crashed the interpreter; emptying the file first gives those writes room.
        """
        f, self.file = self.file, None
        if f is None:
            return
        try:
            os.ftruncate(f.id.get_vfd_handle(), 0)
        except (OSError, ValueError, AttributeError):
            pass
        try:
            f.close()
        except OSError:
            pass
        try:
            os.unlink(self.path)
        except OSError:
            pass


class VTKWriter(TrajectoryWriter):
    """One .vtu per snapshot (meshio) and a .pvd collection with the times."""

    def __init__(self, path: Path, every: float, scene: Scene):
        super().__init__(path, every, scene)
        import meshio  # noqa: F401  (fail now, not at the first snapshot)

        self.pvd = self.path.with_suffix(".pvd")
        self.stem = self.path.with_suffix("")
        self.entries: list[tuple[float, str]] = []
        self._closed = False
        n = scene.n
        self._cells = [("vertex", np.arange(n, dtype=np.int64).reshape(n, 1))]
        self._species = scene.kinds().astype(np.int32)
        self._radius = scene.radii()

    def _write(self, t, positions, velocities):
        import meshio

        n, d = positions.shape
        pts = np.zeros((n, 3))
        pts[:, :d] = positions
        vel = np.zeros((n, 3))
        vel[:, :d] = velocities
        name = f"{self.stem.name}_{self.count:05d}.vtu"
        mesh = meshio.Mesh(pts, self._cells,
                           point_data={"velocity": vel, "species": self._species, "radius": self._radius})
        self.entries.append((t, name))
        try:
            meshio.write(self.stem.parent / name, mesh, file_format="vtu")
        except OSError as err:
            self._discard()
            raise OutputError(f"cannot write --trajectory {str(self.stem.parent / name)!r}: {_reason(err)}; "
                             "the snapshots written were removed") from None

    def close(self):
        if self._closed:
            return
        self._closed = True
        lines = ['<?xml version="1.0"?>',
                 '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
                 "  <Collection>"]
        lines += [f'    <DataSet timestep="{t!r}" group="" part="0" file="{name}"/>'
                  for t, name in self.entries]
        lines += ["  </Collection>", "</VTKFile>", ""]
        try:
            self.pvd.write_text("\n".join(lines), encoding="utf-8")
        except OSError as err:
            self._discard()
            raise OutputError(f"cannot write --trajectory {str(self.pvd)!r}: {_reason(err)}; "
                             "the snapshots written were removed") from None

    def _discard(self) -> None:
        """Delete the snapshot files and the collection after a failed write (a full disk)."""
        self._closed = True
        for path in [self.stem.parent / name for _, name in self.entries] + [self.pvd]:
            try:
                os.unlink(path)
            except OSError:
                pass
        self.entries = []


def read_h5md(path: str | os.PathLike) -> dict:
    """Read a trajectory written by :class:`H5MDWriter`.

    Returns a dict: time (T,) s, positions (T, N, D) m, velocities (T, N, D)
    m/s, species (N,) int, radius (N,) m, box (D,) m, species_names (list
    of str), dim.
    """
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise SceneError(f"cannot read trajectory {str(path)!r}: {err}") from None
    with f:
        if "particles/all/position/value" not in f:
            raise SceneError(f"{str(path)!r} is not an H5MD trajectory (no particles/all/position)")
        part = f["particles/all"]
        out = {
            "time": part["position/time"][()],
            "positions": part["position/value"][()],
            "velocities": part["velocity/value"][()] if "velocity" in part else None,
            "species": part["species"][()] if "species" in part else None,
            "box": part["box/edges"][()],
            "dim": int(part["box"].attrs["dimension"]),
        }
        n = out["positions"].shape[1]
        out["radius"] = part["radius"][()] if "radius" in part else np.zeros(n)
        names = f["parameters"].attrs.get("species_names") if "parameters" in f else None
        out["species_names"] = [s.decode() if isinstance(s, bytes) else str(s) for s in names] \
            if names is not None else []
    return out
