"""Trajectory files (HDF5/H5MD, VTK for ParaView) and the GIF animation."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from gaz_cli import stepper
from gaz_cli.errors import SceneError
from gaz_cli.recording import MemoryRecorder
from gaz_cli.scene import Scene, State
from gaz_cli.species import Species
from gaz_cli.trajectory import open_trajectory, read_h5md

A, B = Species("A", 1.0, 0.02), Species("B", 2.0, 0.04)


def small_scene(dim=2, n=6, **kw) -> Scene:
    return Scene(dim=dim, length=1.0, duration=0.1, components=((A, n - 2), (B, 2)), seed=1,
                 engine="step", dt=1e-3, **kw)


def snapshots(scene, count=3, seed=0):
    rng = np.random.default_rng(seed)
    return [(0.05 * k, rng.uniform(0.1, 0.9, (scene.n, scene.dim)), rng.normal(0, 1, (scene.n, scene.dim)))
            for k in range(count)]


@pytest.mark.parametrize("suffix", [".h5", ".hdf5"])
def test_h5md_round_trip(tmp_path, suffix):
    import h5py

    sc = small_scene(dim=3)
    snaps = snapshots(sc)
    path = tmp_path / f"run{suffix}"
    with open_trajectory(path, 0.05, sc) as w:
        assert w.snapshot_every == 0.05 and not w.want_bounces
        for t, x, v in snaps:
            w.add_snapshot(t, x, v)
    with h5py.File(path, "r") as f:
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        pos = f["particles/all/position"]
        np.testing.assert_array_equal(pos["value"][()], np.stack([x for _, x, _ in snaps]))
        np.testing.assert_array_equal(pos["time"][()], [t for t, _, _ in snaps])
        np.testing.assert_array_equal(pos["step"][()], [0, 1, 2])
        np.testing.assert_array_equal(f["particles/all/velocity/value"][()], np.stack([v for _, _, v in snaps]))
        np.testing.assert_array_equal(f["particles/all/box/edges"][()], [1.0, 1.0, 1.0])
        assert f["particles/all/box"].attrs["dimension"] == 3
        np.testing.assert_array_equal(f["particles/all/species"][()], [0, 0, 0, 0, 1, 1])
    data = read_h5md(path)
    np.testing.assert_array_equal(data["positions"][1], snaps[1][1])
    np.testing.assert_array_equal(data["radius"], sc.radii())
    assert data["species_names"] == ["A", "B"] and data["dim"] == 3


@pytest.mark.parametrize("name", ["run.pvd", "run.vtu"])
def test_vtk_round_trip_through_meshio(tmp_path, name):
    import meshio

    sc = small_scene(dim=2)
    snaps = snapshots(sc)
    with open_trajectory(tmp_path / name, 0.05, sc) as w:
        for t, x, v in snaps:
            w.add_snapshot(t, x, v)
    root = ET.parse(tmp_path / "run.pvd").getroot()
    entries = root.findall("./Collection/DataSet")
    assert [float(e.get("timestep")) for e in entries] == [t for t, _, _ in snaps]
    for entry, (t, x, v) in zip(entries, snaps):
        mesh = meshio.read(tmp_path / entry.get("file"))
        np.testing.assert_allclose(mesh.points[:, :2], x, rtol=0, atol=0)
        np.testing.assert_array_equal(mesh.points[:, 2], 0.0)
        np.testing.assert_allclose(mesh.point_data["velocity"][:, :2], v, rtol=0, atol=0)
        np.testing.assert_array_equal(mesh.point_data["species"], sc.kinds())
        np.testing.assert_array_equal(mesh.point_data["radius"], sc.radii())


def test_writer_errors(tmp_path):
    sc = small_scene()
    with pytest.raises(SceneError, match="extension"):
        open_trajectory(tmp_path / "run.txt", 0.1, sc)
    with pytest.raises(SceneError, match="--every"):
        open_trajectory(tmp_path / "run.h5", 0.0, sc)
    with pytest.raises(SceneError, match="does not exist"):
        open_trajectory(tmp_path / "missing" / "run.h5", 0.1, sc)
    with open_trajectory(tmp_path / "run.h5", 0.1, sc) as w:
        with pytest.raises(SceneError, match="shape"):
            w.add_snapshot(0.0, np.zeros((3, 2)), np.zeros((3, 2)))
        w.add_snapshot(0.1, np.zeros((6, 2)), np.zeros((6, 2)))
        with pytest.raises(SceneError, match="time order"):
            w.add_snapshot(0.0, np.zeros((6, 2)), np.zeros((6, 2)))


def test_step_engine_writes_a_trajectory(tmp_path):
    """The engine's snapshots land in the file at t = k * every, the last one equal to the final state."""
    from gaz_cli.runner import Tee

    sc = small_scene(n=8)
    rng = np.random.default_rng(2)
    x = np.array([[0.15 + 0.2 * (i % 4), 0.3 + 0.4 * (i // 4)] for i in range(8)])
    st = State(x, rng.normal(0, 1, (8, 2)), sc.kinds())
    with open_trajectory(tmp_path / "run.h5", 0.02, sc) as w:
        rs = stepper.run(sc, st, Tee(MemoryRecorder(), w))
    data = read_h5md(tmp_path / "run.h5")
    np.testing.assert_allclose(data["time"], 0.02 * np.arange(6), atol=1e-15)
    np.testing.assert_array_equal(data["positions"][0], x)
    np.testing.assert_allclose(data["positions"][-1], rs.final.positions, atol=1e-12)


@pytest.mark.parametrize("dim", [1, 2])
def test_render_gif(tmp_path, dim):
    from PIL import Image

    from gaz_cli.animate import render_gif

    sc = small_scene(dim=dim)
    with open_trajectory(tmp_path / "run.h5", 0.05, sc) as w:
        for t, x, v in snapshots(sc, count=4):
            w.add_snapshot(t, x, v)
    frames = render_gif(tmp_path / "run.h5", tmp_path / "run.gif", fps=5, size_px=200,
                        frame_png=tmp_path / "last.png")
    assert frames == 4
    with Image.open(tmp_path / "run.gif") as gif:
        assert gif.n_frames == 4
    assert (tmp_path / "last.png").stat().st_size > 0
    with pytest.raises(SceneError, match="HDF5"):
        render_gif(tmp_path / "run.pvd", tmp_path / "x.gif")
    (tmp_path / "bad.h5").write_bytes(b"not hdf5")
    with pytest.raises(SceneError, match="cannot read"):
        render_gif(tmp_path / "bad.h5", tmp_path / "x.gif")


# --- a full disk ------------------------------------------------------------------------
@pytest.fixture
def tiny_disk(tmp_path):
    """A 1 MiB tmpfs mounted under tmp_path (root only; skipped where mounting is not permitted)."""
    import subprocess

    mount = tmp_path / "full"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1M", "tmpfs", str(mount)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here: {done.stderr.strip() or done.returncode}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], capture_output=True)


@pytest.mark.parametrize("name", ["run.h5", "run.pvd"])
def test_a_full_disk_is_one_line_and_exit_1(tiny_disk, tmp_path, name):
    """500 disks, 1001 snapshots of 16 kB each, on a 1 MiB disk.

    Without --force the door refuses it (the size against the free space); with --force the
    writer meets ENOSPC. HDF5 used to crash the interpreter at exit there (SIGSEGV, exit 139)
    trying to flush the chunks it could not write; now the run stops with one line, exit 1,
    the file removed and the database untouched. A subprocess, since the failure was a crash
    of the process.
    """
    import subprocess
    import sys

    db = tmp_path / "gaz.db"
    args = [sys.executable, "-m", "gaz_cli", "simulate", "--dim", "2", "--n", "500", "--length", "1e-6",
            "--duration", "1e-9", "--seed", "1", "--db", str(db), "--trajectory", str(tiny_disk / name),
            "--every", "1e-12"]
    refused = subprocess.run(args, capture_output=True, text=True, timeout=300)
    assert refused.returncode == 1 and "free" in refused.stderr and len(refused.stderr.splitlines()) == 1, \
        refused.stderr
    done = subprocess.run(args + ["--force"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 1, (done.returncode, done.stderr[-2000:])
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "No space left on device" in lines[0], done.stderr
    assert list(tiny_disk.iterdir()) == []
    if db.exists():
        import sqlite3

        assert sqlite3.connect(db).execute("SELECT COUNT(*) FROM SIMULATION").fetchone()[0] == 0
