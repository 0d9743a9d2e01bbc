"""Trajectories: snapshots of every particle, for MDAnalysis, OVITO, ParaView, h5py and ``gaz animate``.

:func:`open_trajectory` returns a :class:`TrajectoryWriter`, a
:class:`~gaz_cli.model.recording.Recorder` that takes only snapshots
(``snapshot_every`` = the requested interval); every engine calls its
``add_snapshot(t, positions, velocities)`` at t = 0, every, 2 every, ...
At most :data:`gaz_cli.model.scene.MAX_SNAPSHOTS` snapshots without ``--force`` (checked by
:func:`gaz_cli.model.scene.check_outputs`, the one door).
The format follows the file's extension; :func:`read_trajectory` reads each back
(``gaz animate`` draws any of them).

``.h5`` / ``.hdf5``
    HDF5 in the H5MD 1.1 layout (https://www.nongnu.org/h5md/h5md.html), through
    h5py; MDAnalysis reads it (3D runs: ``Universe.empty(N, trajectory=True)
    .load_new(path, format="H5MD")``, or with a topology)::

        /h5md                      version [1, 1]; author (name), creator (name, version)
        /h5md/modules/units        version [1, 0], system SI: every dataset with a
                                   dimension carries its unit
        /particles/all/box         attrs dimension, boundary (periodic | none per axis);
                                   edges: value (T, D) nm, step, time
        /particles/all/position    value (T, N, D) nm, step (T,), time (T,) ps
        /particles/all/velocity    value (T, N, D) nm ps-1, step, time
        /particles/all/image       periodic box only: value (T, N, D) int32, step, time
        /particles/all/species     (N,) int32, index into /parameters species_names
        /particles/all/mass        (N,) kg
        /particles/all/radius      (N,) nm (not an H5MD name; read by gaz animate)
        /parameters                attrs of the scene (dim, length m, duration s, seed...)

    ``step`` is the snapshot index k (t = k * every); every element shares one step
    and one time dataset (hard links). Lengths are in nanometres and times in
    picoseconds, not metres and seconds: MDAnalysis converts from nm, pm, fm and
    angstrom only (it refused "m"). Strings are fixed-length ASCII, as H5MD 1.1
    asks, except the ``unit`` attributes, variable-length: MDAnalysis 2.11 looks a
    unit up as a Python str and refuses a fixed-length one ("unit 'b'nm'' is not
    recognized"). In a periodic box, positions are wrapped into [0, L) and
    ``image`` counts each particle's box crossings since the start along each axis,
    exactly whatever the snapshot interval: the engines count them where they wrap a
    particle (the event engine at a cell crossing through a face of the box, at a
    neighbour-list rebuild and when it reloads its rows; the ideal path from x0 + v t),
    and hand them to ``add_snapshot(..., images=)``. position + image * edges is the
    unwrapped position (its mean squared displacement is the particles' own). A caller
    that hands no images gets them inferred between consecutive snapshots by the minimum
    image, exact only while no particle moves more than half a box between two.

``.gsd``
    GSD (HOOMD-blue's format; OVITO, freud and HOOMD read it) through the ``gsd``
    package (``pip install 'gaz[gsd]'``): one frame per snapshot, HOOMD's
    conventions: the box centred on the origin (positions shifted by -L/2),
    float32 positions in nm, velocities in nm/ps, diameters in nm, masses in
    daltons, particle types named by species; ``configuration.step`` is k and
    the log entry ``gaz/time_ps`` the time. 1D runs are written as 2D (y = 0)
    with ``gaz/dimension`` = 1 in the log. In a periodic box ``particles/image`` holds the
    box crossings as H5MD's ``image`` does (position + image * box is the unwrapped
    position; HOOMD's own convention).

``.pvd`` / ``.vtu``
    VTK XML for ParaView, written by meshio: one ``STEM_00000.vtu`` per
    snapshot (points padded to 3D, SI units, one vertex cell per particle, point
    data velocity, species, radius; use a Glyph filter scaled by radius to see
    the disks) and a ``STEM.pvd`` collection that gives ParaView the times (and
    gaz the dimension and the box, in a comment). Open the .pvd. Writing over an earlier
    .pvd first deletes it and the snapshots it lists that gaz would have written there
    (STEM_NNNNN.vtu beside it; not another .vtu it names), so that no snapshot of the
    earlier run is left among the new ones.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np

from gaz_cli import interrupts
from gaz_cli.errors import OutputError, SceneError
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene

FORMATS = {".h5": "h5md", ".hdf5": "h5md", ".gsd": "gsd", ".pvd": "vtk", ".vtu": "vtk"}
"""File extension -> format."""

NM, PS = 1e-9, 1e-12
"""The files' units of length and time (nanometre, picosecond), in metres and seconds."""

DALTON = 1.66053906660e-27
"""kg; GSD's masses are in daltons."""

_LENGTH = {"m": 1.0, "nm": NM, "pm": 1e-12, "fm": 1e-15, "Angstrom": 1e-10, "A": 1e-10, "angstrom": 1e-10}
_TIME = {"s": 1.0, "ps": PS, "fs": 1e-15, "ns": 1e-9}
"""Unit strings gaz reads back (files of older gaz versions were in m and s)."""


def open_trajectory(path: str | os.PathLike, every: float, scene: Scene,
                    write_to: str | os.PathLike | None = None) -> "TrajectoryWriter":
    """A writer of snapshots every ``every`` simulated seconds to ``path`` (format by extension).

    Use as a context manager, or call ``close()``. Raises SceneError for an
    unknown extension, a bad interval or a directory that does not exist. ``write_to``: the
    file actually written (a temporary name that the caller renames to ``path`` when its run
    is committed, :mod:`gaz_cli.atomic`; HDF5 and GSD only); messages name ``path``.
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise SceneError(f"--trajectory {str(path)!r}: unknown extension {path.suffix!r}; "
                         "use .h5 (HDF5/H5MD), .gsd (GSD, for OVITO) or .pvd (VTK for ParaView)")
    if every is None or not np.isfinite(every) or every <= 0:
        raise SceneError(f"--every must be a positive number of simulated seconds, got {every}")
    directory = path.resolve().parent
    if not directory.is_dir():
        raise SceneError(f"--trajectory {str(path)!r}: directory {str(directory)!r} does not exist")
    cls = {"h5md": H5MDWriter, "gsd": GSDWriter, "vtk": VTKWriter}[fmt]
    if write_to is None or fmt == "vtk":
        return cls(path, float(every), scene)
    writer = cls.__new__(cls)
    writer.name = path
    writer.__init__(Path(write_to), float(every), scene)
    return writer


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
    return {k: np.bytes_(v) if isinstance(v, str) else v for k, v in out.items()}  # fixed-length


def _text(value) -> str:
    """An HDF5 string attribute (fixed-length bytes or str) as str."""
    if isinstance(value, np.ndarray):
        value = value.item() if value.shape == () else value[0]
    return value.decode() if isinstance(value, bytes) else str(value)


class H5MDWriter(TrajectoryWriter):
    """HDF5 file in the H5MD 1.1 layout (see the module docstring)."""

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
            raise OutputError(f"cannot write --trajectory {str(self.name)!r}: {_reason(err)}") from None
        f = self.file
        h5md = f.create_group("h5md")
        h5md.attrs["version"] = np.array([1, 1], dtype=np.int32)
        f.create_group("h5md/author").attrs["name"] = np.bytes_("gaz user")
        creator = f.create_group("h5md/creator")
        creator.attrs["name"] = np.bytes_("gaz")
        creator.attrs["version"] = np.bytes_(__version__)
        units = f.create_group("h5md/modules/units")
        units.attrs["version"] = np.array([1, 0], dtype=np.int32)
        units.attrs["system"] = np.bytes_("SI")
        n, d = scene.n, scene.dim
        self.periodic = scene.boundary == "periodic"
        self.want_images = self.periodic
        part = f.create_group("particles/all")
        box = part.create_group("box")
        box.attrs["dimension"] = np.int32(d)
        box.attrs["boundary"] = np.array(["periodic" if self.periodic else "none"] * d, dtype="S8")
        part.create_dataset("species", data=scene.kinds().astype(np.int32))
        part.create_dataset("mass", data=scene.masses()).attrs["unit"] = "kg"
        part.create_dataset("radius", data=scene.radii() / NM).attrs["unit"] = "nm"
        self.step = part.create_dataset("position/step", shape=(0,), maxshape=(None,), chunks=(256,),
                                        dtype=np.int64)
        self.time = part.create_dataset("position/time", shape=(0,), maxshape=(None,), chunks=(256,),
                                        dtype=np.float64)
        self.time.attrs["unit"] = "ps"
        self._values = {}
        elements = [("position", (n, d), np.float64, "nm"), ("velocity", (n, d), np.float64, "nm ps-1"),
                    ("box/edges", (d,), np.float64, "nm")]
        if self.periodic:
            elements.append(("image", (n, d), np.int32, None))
        for name, shape, dtype, unit in elements:
            g = part.require_group(name)
            value = g.create_dataset("value", shape=(0, *shape), maxshape=(None, *shape),
                                     chunks=(1, *shape), dtype=dtype)
            if unit:
                value.attrs["unit"] = unit
            if name != "position":
                g["step"], g["time"] = self.step, self.time  # one step, one time: hard links
            self._values[name] = value
        self._edges = np.full(d, scene.length / NM)
        params = f.create_group("parameters")
        for key, val in _scene_attributes(scene).items():
            params.attrs[key] = val
        params.attrs["snapshot_every"] = every

    def _write(self, t, positions, velocities, images=None):
        if self.file is None:
            raise SceneError(f"--trajectory {str(self.name)!r} is closed")
        k = self.count
        data = {"position": positions / NM, "velocity": velocities * (PS / NM), "box/edges": self._edges}
        if self.periodic:
            data["image"] = self._images(positions, images)
        try:
            for dataset in (self.step, self.time, *self._values.values()):
                dataset.resize(k + 1, axis=0)
            self.step[k] = k
            self.time[k] = t / PS
            for name, value in self._values.items():
                value[k] = data[name]
        except OSError as err:
            self._discard()
            raise OutputError(f"cannot write --trajectory {str(self.name)!r} (snapshot {k}): "
                             f"{_reason(err)}; the file was removed") from None

    def close(self):
        if self.file is not None:
            try:
                self.file.close()
                self.file = None
            except OSError as err:
                self._discard()
                raise OutputError(f"cannot finish --trajectory {str(self.name)!r}: {_reason(err)}; "
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
        except (OSError, RuntimeError):  # (h5py: RuntimeError past a file-size limit, ulimit -f)
            pass
        try:
            os.unlink(self.path)
        except OSError:
            pass


class GSDWriter(TrajectoryWriter):
    """GSD file, one frame per snapshot (see the module docstring); needs the gsd package."""

    def __init__(self, path: Path, every: float, scene: Scene):
        super().__init__(path, every, scene)
        gsd_hoomd = gsd_hoomd_module()
        try:
            self.file = gsd_hoomd.open(name=str(self.path), mode="w")
        except OSError as err:
            raise OutputError(f"cannot write --trajectory {str(self.name)!r}: {_reason(err)}") from None
        self._hoomd = gsd_hoomd
        self.periodic = scene.boundary == "periodic"
        self.want_images = self.periodic
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
        try:
            self.file.append(frame)
        except OSError as err:
            self._discard()
            raise OutputError(f"cannot write --trajectory {str(self.name)!r} (snapshot {self.count}): "
                             f"{_reason(err)}; the file was removed") from None

    def close(self):
        if self.file is not None:
            f, self.file = self.file, None
            try:
                f.close()
            except OSError as err:
                self._remove()
                raise OutputError(f"cannot finish --trajectory {str(self.name)!r}: {_reason(err)}; "
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


class VTKWriter(TrajectoryWriter):
    """One .vtu per snapshot (meshio) and a .pvd collection with the times."""

    def __init__(self, path: Path, every: float, scene: Scene):
        super().__init__(path, every, scene)
        import meshio  # noqa: F401  (fail now, not at the first snapshot)

        self.pvd = self.path.with_suffix(".pvd")
        self.stem = self.path.with_suffix("")
        self.entries: list[tuple[float, str]] = []
        self._remove_earlier()
        self._closed = False
        n = scene.n
        self._cells = [("vertex", np.arange(n, dtype=np.int64).reshape(n, 1))]
        self._species = scene.kinds().astype(np.int32)
        self._radius = scene.radii()

    def _remove_earlier(self) -> None:
        """Delete the collection written over and the snapshots it lists (module docstring):
        a run with fewer snapshots would otherwise leave the earlier run's last ones beside it.
        Only the names this writer gives its snapshots (STEM_NNNNN.vtu, no folder): a .vtu of
        the user's that a collection made elsewhere lists stays. Nothing for a file that is not
        a readable collection."""
        import re
        import xml.etree.ElementTree as ET

        ours = re.compile(re.escape(self.stem.name) + r"_\d{5,}\.vtu")

        if not self.pvd.is_file():
            return
        try:
            names = [e.get("file") or "" for e in ET.parse(self.pvd).getroot().iter("DataSet")]
        except (OSError, ET.ParseError):
            return
        for name in names:
            if ours.fullmatch(name):
                try:
                    (self.pvd.parent / name).unlink(missing_ok=True)
                except OSError as err:
                    raise OutputError(f"cannot write --trajectory {str(self.pvd)!r}: its earlier snapshot "
                                      f"{name!r} cannot be removed ({_reason(err)})") from None
        try:
            self.pvd.unlink()
        except OSError as err:
            raise OutputError(f"cannot write --trajectory {str(self.pvd)!r}: {_reason(err)}") from None

    def _write(self, t, positions, velocities, images=None):
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
                 f"  <!-- gaz: dimension={self.scene.dim} box={self.scene.length!r} m -->",
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


def read_trajectory(path: str | os.PathLike) -> dict:
    """Read a trajectory written by gaz, whatever its format (by extension).

    Returns a dict in SI units: time (T,) s, positions (T, N, D) m, velocities
    (T, N, D) m/s or None, species (N,) int or None, radius (N,) m, box (D,) m,
    species_names (list of str), dim. Raises SceneError for a file it cannot read.
    """
    fmt = FORMATS.get(Path(path).suffix.lower())
    if fmt == "gsd":
        return read_gsd(path)
    if fmt == "vtk":
        return read_vtk(path)
    if fmt is None and not _is_hdf5(path):  # (an H5MD file may have any name: read by its signature)
        raise SceneError(f"cannot read trajectory {str(path)!r}: not a file gaz simulate --trajectory "
                         "writes (.h5 or .hdf5: H5MD, .gsd: GSD, .pvd or .vtu: VTK)")
    return read_h5md(path)


def _is_hdf5(path) -> bool:
    """Whether ``path`` is an HDF5 file (h5py's own test of the signature; False if unreadable)."""
    import h5py

    try:
        return bool(h5py.is_hdf5(path))
    except OSError:
        return False


MAX_READ_BYTES = 4 << 30
"""The most a trajectory read back may hold in memory (positions and velocities: 4 GiB);
a larger file is refused in one line before it is read (issue 39: unbounded reads)."""


def _check_size(path, nbytes: int) -> None:
    if nbytes > MAX_READ_BYTES:
        raise SceneError(f"trajectory {str(path)!r} holds {nbytes / 2**30:.3g} GiB of snapshots, more than the "
                         f"{MAX_READ_BYTES >> 30} GiB gaz reads back; write fewer snapshots (a larger --every)")


def read_h5md(path: str | os.PathLike) -> dict:
    """Read an H5MD trajectory written by :class:`H5MDWriter` (see :func:`read_trajectory`).

    Units are read from the file (gaz wrote m and s before 0.1's H5MD 1.1 layout, nm
    and ps since).
    """
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise SceneError(f"cannot read trajectory {str(path)!r}: {err}") from None
    with f:
        for member in ("particles/all/position/value", "particles/all/position/time", "particles/all/box/edges"):
            if member not in f:
                raise SceneError(f"{str(path)!r} is not an H5MD trajectory (no {member})")
        if "dimension" not in f["particles/all/box"].attrs:
            raise SceneError(f"{str(path)!r} is not an H5MD trajectory (no dimension on particles/all/box)")
        part = f["particles/all"]

        def scaled(dataset, table, default):
            unit = _text(dataset.attrs["unit"]) if "unit" in dataset.attrs else default
            if unit not in table:
                raise SceneError(f"trajectory {str(path)!r}: unit {unit!r} of {dataset.name} is not one "
                                 f"gaz reads ({', '.join(table)})")
            return dataset[()] * table[unit]

        position = part["position/value"]
        velocity = part["velocity/value"] if "velocity" in part else None
        _check_size(path, position.size * 8 + (0 if velocity is None else velocity.size * 8))
        edges = part["box/edges"]
        edges = edges["value"] if isinstance(edges, h5py.Group) else edges
        out = {
            "time": scaled(part["position/time"], _TIME, "s"),
            "positions": scaled(position, _LENGTH, "m"),
            "velocities": None,
            "species": part["species"][()] if "species" in part else None,
            "box": scaled(edges, _LENGTH, "m"),
            "dim": int(part["box"].attrs["dimension"]),
        }
        if out["box"].ndim == 2:
            out["box"] = out["box"][0]
        if velocity is not None:
            unit = _text(velocity.attrs.get("unit", "m s-1"))
            length, _, time = unit.partition(" ")
            if length not in _LENGTH or time[:-2] not in _TIME or not time.endswith("-1"):
                raise SceneError(f"trajectory {str(path)!r}: velocity unit {unit!r} is not one gaz reads")
            out["velocities"] = velocity[()] * (_LENGTH[length] / _TIME[time[:-2]])
        n = out["positions"].shape[1]
        out["radius"] = scaled(part["radius"], _LENGTH, "m") if "radius" in part else np.zeros(n)
        names = f["parameters"].attrs.get("species_names") if "parameters" in f else None
        out["species_names"] = [s.decode() if isinstance(s, bytes) else str(s) for s in names] \
            if names is not None else []
    return out


def read_gsd(path: str | os.PathLike) -> dict:
    """Read a GSD trajectory written by :class:`GSDWriter` (see :func:`read_trajectory`)."""
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
        _check_size(path, len(f) * int(first.particles.N) * dim * 16)
        frames = [f[k] for k in range(len(f))]
    positions = np.stack([fr.particles.position[:, :dim] for fr in frames]).astype(np.float64) * NM + box / 2
    velocities = np.stack([fr.particles.velocity[:, :dim] for fr in frames]).astype(np.float64) * (NM / PS)
    time = np.array([fr.log["gaz/time_ps"][0] * PS if "gaz/time_ps" in fr.log else fr.configuration.step
                     for fr in frames])
    return {"time": time, "positions": positions, "velocities": velocities,
            "species": first.particles.typeid.astype(np.int64),
            "radius": first.particles.diameter.astype(np.float64) * NM / 2, "box": box,
            "species_names": list(first.particles.types), "dim": dim}


def read_vtk(path: str | os.PathLike) -> dict:
    """Read a VTK trajectory written by :class:`VTKWriter`: its .pvd collection (a .vtu
    snapshot's name leads to it) and every .vtu it lists (see :func:`read_trajectory`)."""
    import xml.etree.ElementTree as ET

    import meshio

    path = Path(path)
    if path.suffix.lower() == ".vtu":
        stem = path.stem.rsplit("_", 1)[0] if path.stem.rsplit("_", 1)[-1].isdigit() else path.stem
        path = path.with_name(stem + ".pvd")
    try:
        _check_size(path, os.stat(path).st_size)  # (the collection; each snapshot's size below)
        root = ET.parse(path, ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))).getroot()
        entries = [(float(e.get("timestep")), path.parent / e.get("file")) for e in root.iter("DataSet")]
    except (OSError, ET.ParseError, TypeError, ValueError) as err:
        raise SceneError(f"cannot read trajectory {str(path)!r}: {err}") from None
    meshes = []
    with contextlib.suppress(OSError):
        _check_size(path, sum(os.stat(file).st_size for _, file in entries))
    for _, file in entries:
        # meshio's own reader, not meshio.read: that one prints "Error: Couldn't read file" and
        # calls sys.exit(1) for a file it cannot parse, and raises its ReadError for a missing one
        try:
            meshes.append(meshio.vtu.read(str(file)))
        except OSError as err:
            raise SceneError(f"cannot read trajectory {str(path)!r}: its snapshot {str(file)!r} is "
                             f"missing or unreadable ({err.strerror})") from None
        except (meshio.ReadError, ET.ParseError, ValueError) as err:
            raise SceneError(f"cannot read trajectory {str(path)!r}: its snapshot {str(file)!r} is not a "
                             f"VTU file gaz wrote (truncated or replaced{': ' + str(err) if str(err) else ''})") \
                from None
    if not meshes:
        raise SceneError(f"trajectory {str(path)!r} holds no snapshot")
    first = meshes[0]
    said = dict(word.split("=", 1) for c in root.iter(ET.Comment) if "gaz:" in (c.text or "")
                for word in c.text.split() if "=" in word)
    if "dimension" in said:
        dim = int(said["dimension"])
        box = np.full(dim, float(said["box"]))
    else:  # written before gaz said them: the box from the particles' extent
        dim = 3 - sum(bool(np.all(first.points[:, a] == 0)) for a in (1, 2))
        box = np.full(dim, float(np.max(first.points)))
    return {"time": np.array([t for t, _ in entries]),
            "positions": np.stack([m.points[:, :dim] for m in meshes]),
            "velocities": np.stack([m.point_data["velocity"][:, :dim] for m in meshes]),
            "species": np.asarray(first.point_data["species"]).astype(np.int64),
            "radius": np.asarray(first.point_data["radius"], dtype=np.float64), "box": box,
            "species_names": [], "dim": dim}
