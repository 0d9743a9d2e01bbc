"""H5MD trajectories (``.h5md``; ``.h5`` and ``.hdf5`` too): the writer and the reader.

HDF5 in the H5MD 1.1 layout (https://www.nongnu.org/h5md/h5md.html), through h5py, laid
out as MDAnalysis reads it: one call opens it, in 1D, 2D and 3D::

    import MDAnalysis as mda
    u = mda.Universe("run.h5md")            # a run.h5 file: mda.Universe("run.h5", format="H5MD")
    u.trajectory[-1].positions              # (N, 3) float32 angstrom: the final state, z = 0 in 2D

MDAnalysis reads the particle group ``particles/trajectory`` (its minimal topology counts
the particles there), a box of dimension 3 with edges (3,) and a unit on every value and
time. So every run is written in 3D: **a 2D run is the plane z = 0** (z and v_z are 0 for
every particle) **and a 1D run the line y = z = 0**; the box's extra edges are L, with
boundary ``none``, so that MDAnalysis has the cuboid it needs; ``/parameters`` says the
run's own dimension (``dim``) and ``embedding`` says it in words. gaz's reader gives back
the D columns of the run::

    /h5md                             version [1, 1]; author (name), creator (name, version)
    /h5md/modules/units               version [1, 0], system SI: every dataset with a
                                      dimension carries its unit
    /particles/trajectory/box         attrs dimension 3, boundary (periodic | none per axis;
                                      none on the axes added to a 1D or 2D run);
                                      edges: value (T, 3) nm, step, time
    /particles/trajectory/position    value (T, N, 3) nm, step (T,), time (T,) ps
    /particles/trajectory/velocity    value (T, N, 3) nm ps-1, step, time
    /particles/trajectory/image       periodic box only: value (T, N, 3) int32, step, time
    /particles/trajectory/species     (N,) int32, index into /parameters species_names
    /particles/trajectory/mass        (N,) kg
    /particles/trajectory/radius      (N,) nm (not an H5MD name; read by gaz animate)
    /parameters                       attrs of the scene (dim, length m, duration s, seed...),
                                      embedding (how a 1D or 2D run sits in the 3D box)

``step`` is the snapshot index k (t = k * every); every element shares one step and one
time dataset (hard links). Lengths are in nanometres and times in picoseconds, not metres
and seconds: MDAnalysis converts from nm, pm, fm and angstrom only (it refused "m").
Strings are fixed-length ASCII, as H5MD 1.1 asks, except the ``unit`` attributes,
variable-length: MDAnalysis 2.11 looks a unit up as a Python str and refuses a
fixed-length one ("unit 'b'nm'' is not recognized"). In a periodic box, positions are
wrapped into [0, L) and ``image`` counts each particle's box crossings since the start along
each axis, exactly whatever the snapshot interval: the engines count them where they wrap a
particle (the event engine at a cell crossing through a face of the box, at a neighbour-list
rebuild and when it reloads its rows; the ideal path from x0 + v t), and hand them to
``add_snapshot(..., images=)``. position + image * edges is the unwrapped position (its mean
squared displacement is the particles' own). A caller that hands no images gets them
inferred between consecutive snapshots by the minimum image, exact only while no particle
moves more than half a box between two.

Files of earlier gaz versions (group ``particles/all``, a box of the run's own dimension)
are still read.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from gaz_cli.errors import OutputError, SceneError
from gaz_cli.model.scene import Scene
from gaz_cli.outputs.writer import check_read_size
from gaz_cli.outputs.writer import (LENGTH_UNITS, NM, PS, TIME_UNITS, TrajectoryWriter, reason,
                                    scene_attributes, text)


PARTICLES = "particles/trajectory"
"""The particle group: the name MDAnalysis reads (earlier gaz versions wrote ``particles/all``)."""

SPACE = 3
"""The files' dimension: MDAnalysis reads 3D boxes only (module docstring)."""

EMBEDDING = {
    1: "1D run written as the line y = z = 0 of a 3D box: y, z, v_y, v_z are 0; the y and z "
       "edges (L, boundary none) only give MDAnalysis a cuboid",
    2: "2D run written as the plane z = 0 of a 3D box: z and v_z are 0; the z edge (L, boundary "
       "none) only gives MDAnalysis a cuboid",
    3: "3D run",
}
"""/parameters embedding: how the run sits in the file's 3D box."""


def _in_space(values: np.ndarray) -> np.ndarray:
    """(N, D) values padded with zero columns to (N, 3)."""
    if values.shape[1] == SPACE:
        return values
    out = np.zeros((values.shape[0], SPACE), dtype=values.dtype)
    out[:, :values.shape[1]] = values
    return out


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
            raise OutputError(f"cannot write --trajectory {str(self.name)!r}: {reason(err)}") from None
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
        n, d = scene.n, SPACE
        self.periodic = scene.boundary == "periodic"
        self.want_images = self.periodic
        part = f.create_group(PARTICLES)
        box = part.create_group("box")
        box.attrs["dimension"] = np.int32(d)
        box.attrs["boundary"] = np.array(["periodic" if self.periodic and axis < scene.dim else "none"
                                          for axis in range(d)], dtype="S8")
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
        for key, val in scene_attributes(scene).items():
            params.attrs[key] = val
        params.attrs["snapshot_every"] = every
        params.attrs["embedding"] = np.bytes_(EMBEDDING[scene.dim])

    def _write(self, t, positions, velocities, images=None):
        if self.file is None:
            raise SceneError(f"--trajectory {str(self.name)!r} is closed")
        k = self.count
        data = {"position": _in_space(positions / NM), "velocity": _in_space(velocities * (PS / NM)),
                "box/edges": self._edges}
        if self.periodic:
            data["image"] = _in_space(self._images(positions, images))
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
                             f"{reason(err)}; the file was removed") from None

    def close(self):
        if self.file is not None:
            try:
                self.file.close()
                self.file = None
            except OSError as err:
                self._discard()
                raise OutputError(f"cannot finish --trajectory {str(self.name)!r}: {reason(err)}; "
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



def is_hdf5(path) -> bool:
    """Whether ``path`` is an HDF5 file (h5py's own test of the signature; False if unreadable)."""
    import h5py

    try:
        return bool(h5py.is_hdf5(path))
    except OSError:
        return False


def read_h5md(path: str | os.PathLike) -> dict:
    """Read an H5MD trajectory written by :class:`H5MDWriter` (see :func:`~gaz_cli.outputs.trajectory.read_trajectory`).

    Units are read from the file (gaz wrote m and s before 0.1's H5MD 1.1 layout, nm
    and ps since).
    """
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise SceneError(f"cannot read trajectory {str(path)!r}: {err}") from None
    with f:
        group = PARTICLES if PARTICLES in f or "particles/all" not in f else "particles/all"
        for member in (f"{group}/position/value", f"{group}/position/time", f"{group}/box/edges"):
            if member not in f:
                raise SceneError(f"{str(path)!r} is not an H5MD trajectory (no {member})")
        if "dimension" not in f[f"{group}/box"].attrs:
            raise SceneError(f"{str(path)!r} is not an H5MD trajectory (no dimension on {group}/box)")
        part = f[group]
        space = int(part["box"].attrs["dimension"])
        params = f["parameters"].attrs if "parameters" in f else {}
        dim = int(params["dim"]) if "dim" in params and 1 <= int(params["dim"]) <= space else space

        def scaled(dataset, table, default):
            unit = text(dataset.attrs["unit"]) if "unit" in dataset.attrs else default
            if unit not in table:
                raise SceneError(f"trajectory {str(path)!r}: unit {unit!r} of {dataset.name} is not one "
                                 f"gaz reads ({', '.join(table)})")
            return dataset[()] * table[unit]

        position = part["position/value"]
        velocity = part["velocity/value"] if "velocity" in part else None
        check_read_size(path, position.size * 8 + (0 if velocity is None else velocity.size * 8))
        edges = part["box/edges"]
        edges = edges["value"] if isinstance(edges, h5py.Group) else edges
        out = {
            "time": scaled(part["position/time"], TIME_UNITS, "s"),
            "positions": scaled(position, LENGTH_UNITS, "m")[..., :dim],
            "velocities": None,
            "species": part["species"][()] if "species" in part else None,
            "box": scaled(edges, LENGTH_UNITS, "m"),
            "dim": dim,
            "periodic": b"periodic" in [np.bytes_(b) for b in part["box"].attrs.get("boundary", [])],
        }
        if out["box"].ndim == 2:
            out["box"] = out["box"][0]
        out["box"] = out["box"][:dim]
        if velocity is not None:
            unit = text(velocity.attrs.get("unit", "m s-1"))
            length, _, time = unit.partition(" ")
            if length not in LENGTH_UNITS or time[:-2] not in TIME_UNITS or not time.endswith("-1"):
                raise SceneError(f"trajectory {str(path)!r}: velocity unit {unit!r} is not one gaz reads")
            out["velocities"] = velocity[()][..., :dim] * (LENGTH_UNITS[length] / TIME_UNITS[time[:-2]])
        n = out["positions"].shape[1]
        out["radius"] = scaled(part["radius"], LENGTH_UNITS, "m") if "radius" in part else np.zeros(n)
        names = params.get("species_names")
        out["species_names"] = [s.decode() if isinstance(s, bytes) else str(s) for s in names] \
            if names is not None else []
    return out
