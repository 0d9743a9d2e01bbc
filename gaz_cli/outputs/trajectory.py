"""Trajectories: snapshots of every particle, for MDAnalysis, OVITO, ParaView, h5py and ``gaz animate``.

The formats gaz writes are registered once, in :data:`REGISTRY`: each names its file
extensions and the module holding its writer and reader (:mod:`gaz_cli.outputs.h5md`,
:mod:`gaz_cli.outputs.gsd`, :mod:`gaz_cli.outputs.vtk`, where each file's layout is
described). :func:`open_trajectory` picks the writer by the file's extension and returns a
:class:`~gaz_cli.outputs.writer.TrajectoryWriter`, a
:class:`~gaz_cli.model.recording.Recorder` that takes only snapshots; every engine calls its
``add_snapshot(t, positions, velocities)`` at t = 0, every, 2 every, ...
At most :data:`gaz_cli.model.estimates.MAX_SNAPSHOTS` snapshots without ``--force`` (checked by
:func:`gaz_cli.scenes.validate.check_outputs`, the one door). :func:`read_trajectory` reads each
format back (``gaz animate`` draws any of them).

A new format is one module with a writer class and a reader function, and one row here.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gaz_cli.errors import SceneError
from gaz_cli.model.scene import Scene
from gaz_cli.outputs import gsd, h5md, vtk
from gaz_cli.outputs.gsd import gsd_hoomd_module  # noqa: F401  (asked here by model.scene.check_outputs)
from gaz_cli.outputs.writer import TrajectoryWriter


@dataclass(frozen=True)
class TrajectoryFormat:
    """One trajectory format: its name, the extensions that select it, its writer (a
    :class:`~gaz_cli.outputs.writer.TrajectoryWriter`) and its reader."""

    name: str
    suffixes: tuple[str, ...]
    label: str
    """What the file is and for whom, for messages (``.h5 (HDF5/H5MD)``)."""
    writer: type[TrajectoryWriter]
    read: Callable[[str | os.PathLike], dict]
    """The file read back in SI units (see :func:`read_trajectory`)."""


REGISTRY = (
    TrajectoryFormat("h5md", (".h5md", ".h5", ".hdf5"), "HDF5/H5MD, for MDAnalysis", h5md.H5MDWriter, h5md.read_h5md),
    TrajectoryFormat("gsd", (".gsd",), "GSD, for OVITO", gsd.GSDWriter, gsd.read_gsd),
    TrajectoryFormat("vtk", (".pvd", ".vtu"), "VTK for ParaView", vtk.VTKWriter, vtk.read_vtk),
)
"""The formats gaz writes, one row each (their modules import h5py, gsd and meshio only when
a file is opened)."""

FORMATS = {suffix: f.name for f in REGISTRY for suffix in f.suffixes}
"""File extension -> format name (read from :data:`REGISTRY`)."""

_BY_NAME = {f.name: f for f in REGISTRY}


def _either(words: list[str]) -> str:
    """'a, b or c'."""
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def format_of(path: str | os.PathLike) -> TrajectoryFormat | None:
    """The registered format of ``path`` by its extension, or None."""
    name = FORMATS.get(Path(path).suffix.lower())
    return None if name is None else _BY_NAME[name]


def open_trajectory(path: str | os.PathLike, every: float, scene: Scene,
                    write_to: str | os.PathLike | None = None) -> TrajectoryWriter:
    """A writer of snapshots every ``every`` simulated seconds to ``path`` (format by extension).

    Use as a context manager, or call ``close()``. Raises SceneError for an
    unknown extension, a bad interval or a directory that does not exist. ``write_to``: the
    file actually written (a temporary name that the caller renames to ``path`` when its run
    is committed, :mod:`gaz_cli.atomic`; HDF5 and GSD only); messages name ``path``.
    """
    path = Path(path)
    fmt = format_of(path)
    if fmt is None:
        known = _either([f"{f.suffixes[0]} ({f.label})" for f in REGISTRY])
        raise SceneError(f"--trajectory {str(path)!r}: unknown extension {path.suffix!r}; use {known}")
    if every is None or not np.isfinite(every) or every <= 0:
        raise SceneError(f"--every must be a positive number of simulated seconds, got {every}")
    directory = path.resolve().parent
    if not directory.is_dir():
        raise SceneError(f"--trajectory {str(path)!r}: directory {str(directory)!r} does not exist")
    if write_to is None or fmt.name == "vtk":
        return fmt.writer(path, float(every), scene)
    writer = fmt.writer.__new__(fmt.writer)
    writer.name = path  # the file named in messages; the one written is write_to
    writer.__init__(Path(write_to), float(every), scene)
    return writer


def read_trajectory(path: str | os.PathLike) -> dict:
    """Read a trajectory written by gaz, whatever its format (by extension).

    Returns a dict in SI units: time (T,) s, positions (T, N, D) m, velocities
    (T, N, D) m/s or None, species (N,) int or None, radius (N,) m, box (D,) m,
    species_names (list of str), dim, periodic (whether the run's box was periodic: False for
    walls, and for a file that does not say). Raises SceneError for a file it cannot read.
    """
    fmt = format_of(path)
    if fmt is None:
        if not h5md.is_hdf5(path):  # (an H5MD file may have any name: read by its signature)
            known = ", ".join(f"{' or '.join(f.suffixes)}: {f.name.upper()}" for f in REGISTRY)
            raise SceneError(f"cannot read trajectory {str(path)!r}: not a file gaz simulate --trajectory "
                             f"writes ({known})")
        fmt = _BY_NAME["h5md"]
    return fmt.read(path)
