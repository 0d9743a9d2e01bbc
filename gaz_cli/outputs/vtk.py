"""VTK trajectories (``.pvd`` collection of ``.vtu`` snapshots, for ParaView): the
writer and the reader, through meshio.

VTK XML, written by meshio: one ``STEM_00000.vtu`` per snapshot and a ``STEM.pvd``
collection that gives ParaView the times (and gaz the dimension, the box and the boundary,
in a comment).
Each snapshot is an unstructured grid of N points (padded to 3D: z = 0 in 2D, y = z = 0 in
1D; SI units, metres), one vertex cell per particle, and point data ``velocity`` (m/s),
``species`` (index into the scene's species), ``radius`` and ``diameter`` (m).

- ParaView: open the .pvd (its time steps are the snapshots' times, s); then Filters >
  Glyph with Glyph Type Sphere, Scale Array ``diameter`` and Scale Factor 1 (ParaView's
  sphere has diameter 1): each particle drawn at its true size; colour by ``species``.
- pyvista: ``reader = pyvista.get_reader("run.pvd")``, ``reader.set_active_time_point(k)``,
  ``mesh = reader.read()[0]``; ``mesh.glyph(scale="diameter", geom=pyvista.Sphere(radius=0.5),
  orient=False)`` is ParaView's Glyph filter.
- OVITO reads the collection as meshes, without particles: open the GSD file there.

The collection is written whole or not at all, as the other formats: its snapshots and its
.pvd go to a temporary folder beside it (``.STEM.pvd.tmp-XXXXXXXX/``), and :meth:`VTKWriter.commit`
(``gaz simulate``: once the run is stored) moves the snapshots into place, then the .pvd over
the earlier one (the step that makes the new collection the one ParaView opens), then deletes
the earlier collection's snapshots that gaz had written there and the new one does not list
(STEM_NNNNN.vtu beside it; not another .vtu it names), so that none of the earlier run is left
among the new ones. A failure or an interrupt before the commit removes the temporary folder
and leaves the earlier collection as it was.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np

from gaz_cli import atomic
from gaz_cli.errors import OutputError, SceneError
from gaz_cli.model.scene import Scene
from gaz_cli.outputs.writer import TrajectoryWriter, check_read_size, reason


class VTKWriter(TrajectoryWriter):
    """One .vtu per snapshot (meshio) and a .pvd collection with the times."""

    def __init__(self, path: Path, every: float, scene: Scene):
        super().__init__(path, every, scene)
        import meshio  # noqa: F401  (fail now, not at the first snapshot)

        self.pvd = self.path.with_suffix(".pvd")
        self.stem = self.path.with_suffix("")
        self.entries: list[tuple[float, str]] = []
        self.folder = atomic.temporary_name(self.pvd).with_suffix("")  # the snapshots until the commit
        try:
            self.folder.mkdir()
        except OSError as err:
            raise OutputError(f"cannot write --trajectory {str(self.pvd)!r}: {reason(err)}") from None
        self._closed = self._done = False
        n = scene.n
        self._cells = [("vertex", np.arange(n, dtype=np.int64).reshape(n, 1))]
        self._species = scene.kinds().astype(np.int32)
        self._radius = scene.radii()
        self._diameter = 2.0 * self._radius

    def _earlier(self) -> list[str]:
        """The snapshots of the collection written over that this writer would have named
        (STEM_NNNNN.vtu, no folder): a .vtu of the user's that a collection made elsewhere lists
        stays. None for a file that is not a readable collection."""
        import re
        import xml.etree.ElementTree as ET

        ours = re.compile(re.escape(self.stem.name) + r"_\d{5,}\.vtu")
        if not self.pvd.is_file():
            return []
        try:
            names = [e.get("file") or "" for e in ET.parse(self.pvd).getroot().iter("DataSet")]
        except (OSError, ET.ParseError):
            return []
        return [name for name in names if ours.fullmatch(name)]

    def commit(self) -> None:
        """Put the finished collection in place (module docstring); idempotent."""
        import shutil

        if self._done:
            return
        self.close()
        earlier = self._earlier()
        final = atomic.target(self.pvd).parent
        try:
            for _, name in self.entries:
                os.replace(self.folder / name, final / name)
            atomic.commit(self.folder / self.pvd.name, self.pvd)
        except OSError as err:
            raise OutputError(f"cannot put --trajectory {str(self.pvd)!r} in place: {reason(err)} (the run "
                              f"was stored; its snapshots are in {str(self.folder)!r})") from None
        self._done = True
        for name in set(earlier) - {name for _, name in self.entries}:
            with contextlib.suppress(OSError):
                (final / name).unlink()
        shutil.rmtree(self.folder, ignore_errors=True)

    def __exit__(self, kind, *exc) -> None:
        """(Used alone, not by ``gaz simulate``: committed at the end of the block, or discarded.)"""
        if kind is None:
            self.commit()
        else:
            self._discard()

    def _write(self, t, positions, velocities, images=None):
        import meshio

        n, d = positions.shape
        pts = np.zeros((n, 3))
        pts[:, :d] = positions
        vel = np.zeros((n, 3))
        vel[:, :d] = velocities
        name = f"{self.stem.name}_{self.count:05d}.vtu"
        mesh = meshio.Mesh(pts, self._cells,
                           point_data={"velocity": vel, "species": self._species, "radius": self._radius,
                                       "diameter": self._diameter})
        self.entries.append((t, name))
        try:
            meshio.write(self.folder / name, mesh, file_format="vtu")
        except OSError as err:
            self._discard()
            raise OutputError(f"cannot write --trajectory {str(self.stem.parent / name)!r}: {reason(err)}; "
                             "the snapshots written were removed") from None

    def close(self):
        if self._closed:
            return
        self._closed = True
        lines = ['<?xml version="1.0"?>',
                 '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
                 f"  <!-- gaz: dimension={self.scene.dim} box={self.scene.length!r} m "
                 f"boundary={self.scene.boundary} -->",
                 "  <Collection>"]
        lines += [f'    <DataSet timestep="{t!r}" group="" part="0" file="{name}"/>'
                  for t, name in self.entries]
        lines += ["  </Collection>", "</VTKFile>", ""]
        try:
            (self.folder / self.pvd.name).write_text("\n".join(lines), encoding="utf-8")
        except OSError as err:
            self._discard()
            raise OutputError(f"cannot write --trajectory {str(self.pvd)!r}: {reason(err)}; "
                             "the snapshots written were removed") from None

    def _discard(self) -> None:
        """Delete the temporary folder after a failed write (a full disk), a failed run or an
        interrupt: the earlier collection, if any, stays as it was."""
        import shutil

        self._closed = True
        if not self._done:
            shutil.rmtree(self.folder, ignore_errors=True)
        self.entries = []


def read_vtk(path: str | os.PathLike) -> dict:
    """Read a VTK trajectory written by :class:`VTKWriter`: its .pvd collection (a .vtu
    snapshot's name leads to it) and every .vtu it lists (see :func:`~gaz_cli.outputs.trajectory.read_trajectory`)."""
    import xml.etree.ElementTree as ET

    import meshio

    path = Path(path)
    if path.suffix.lower() == ".vtu":
        stem = path.stem.rsplit("_", 1)[0] if path.stem.rsplit("_", 1)[-1].isdigit() else path.stem
        path = path.with_name(stem + ".pvd")
    try:
        check_read_size(path, os.stat(path).st_size)  # (the collection; each snapshot's size below)
        root = ET.parse(path, ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))).getroot()
        entries = [(float(e.get("timestep")), path.parent / e.get("file")) for e in root.iter("DataSet")]
    except (OSError, ET.ParseError, TypeError, ValueError) as err:
        raise SceneError(f"cannot read trajectory {str(path)!r}: {err}") from None
    meshes = []
    with contextlib.suppress(OSError):
        check_read_size(path, sum(os.stat(file).st_size for _, file in entries))
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
            "species_names": [], "dim": dim, "periodic": said.get("boundary") == "periodic"}
