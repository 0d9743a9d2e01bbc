"""Trajectory files (HDF5/H5MD, VTK for ParaView) and the GIF animation."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest

from gaz_cli.engines import step as stepper
from gaz_cli.errors import OutputError, SceneError
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.model.scene import Scene, State
from gaz_cli.model.species import Species
from gaz_cli.model.estimates import MAX_SNAPSHOTS
from gaz_cli.scenes.validate import check_outputs
from gaz_cli.outputs.h5md import read_h5md
from gaz_cli.outputs.trajectory import open_trajectory, read_trajectory

A, B = Species("A", 1.0, 0.02), Species("B", 2.0, 0.04)

UNITS = 4.5e-16
"""Relative tolerance of a value stored in the file's units (nm, ps) and read back in SI:
two roundings of a float64 product (x / 1e-9, then * 1e-9; velocities three), ~2 ulp."""


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
    nm, ps = 1e-9, 1e-12
    with h5py.File(path, "r") as f:
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        assert list(f["h5md/modules/units"].attrs["version"]) == [1, 0]
        pos = f["particles/trajectory/position"]
        # stored in nm and ps (MDAnalysis's units): one rounding of x / 1e-9
        np.testing.assert_allclose(pos["value"][()] * nm, np.stack([x for _, x, _ in snaps]), rtol=UNITS)
        np.testing.assert_allclose(pos["time"][()] * ps, [t for t, _, _ in snaps], rtol=UNITS)
        np.testing.assert_array_equal(pos["step"][()], [0, 1, 2])
        assert pos["value"].attrs["unit"] == "nm" and pos["time"].attrs["unit"] == "ps"
        velocity = f["particles/trajectory/velocity"]
        assert velocity["value"].attrs["unit"] == "nm ps-1"
        np.testing.assert_allclose(velocity["value"][()] * nm / ps, np.stack([v for _, _, v in snaps]), rtol=UNITS)
        edges = f["particles/trajectory/box/edges"]
        np.testing.assert_allclose(edges["value"][()] * nm, np.ones((3, 3)), rtol=UNITS)
        assert edges["step"] == pos["step"] and edges["time"] == pos["time"]  # shared: hard links
        box = f["particles/trajectory/box"]
        assert box.attrs["dimension"] == 3 and list(box.attrs["boundary"]) == [b"none"] * 3
        assert "image" not in f["particles/trajectory"]  # walls: no image
        np.testing.assert_array_equal(f["particles/trajectory/species"][()], [0, 0, 0, 0, 1, 1])
        # H5MD 1.1's fixed-length strings (units aside, see gaz_cli.outputs.h5md)
        for attrs, key in ((f["h5md/creator"].attrs, "name"), (f["h5md/author"].attrs, "name"),
                           (box.attrs, "boundary"), (f["parameters"].attrs, "engine"),
                           (f["h5md/modules/units"].attrs, "system")):
            assert not h5py.check_string_dtype(attrs.get_id(key).dtype).length is None, key
    data = read_h5md(path)
    np.testing.assert_allclose(data["positions"][1], snaps[1][1], rtol=UNITS)
    np.testing.assert_allclose(data["velocities"][2], snaps[2][2], rtol=UNITS)
    np.testing.assert_allclose(data["time"], [t for t, _, _ in snaps], rtol=UNITS)
    np.testing.assert_allclose(data["radius"], sc.radii(), rtol=UNITS)
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


def test_a_pvd_written_over_leaves_none_of_the_earlier_snapshots(tmp_path):
    """gaz simulate ... --trajectory out.pvd over an earlier run with more snapshots left that
    run's last .vtu files beside the new ones (a glob of the folder mixed them in). Now the
    earlier collection's own snapshots go, and nothing else: not a .vtu it does not list, not
    one it names outside its folder, not one named otherwise than gaz names its snapshots."""
    sc = small_scene(dim=2)
    outside = tmp_path / "outside.vtu"
    outside.write_text("not gaz's")
    (tmp_path / "sub").mkdir()
    unrelated = tmp_path / "sub" / "run_00009.vtu"
    unrelated.write_text("not listed")
    with open_trajectory(tmp_path / "sub" / "run.pvd", 0.05, sc) as w:
        for t, x, v in snapshots(sc, count=5):
            w.add_snapshot(t, x, v)
    pvd = tmp_path / "sub" / "run.pvd"
    mine = tmp_path / "sub" / "mine.vtu"  # a mesh of the user's, which a collection made elsewhere lists
    mine.write_text("the user's")
    pvd.write_text(pvd.read_text().replace("</Collection>", '<DataSet timestep="1" file="../outside.vtu"/>'
                                           '<DataSet timestep="2" file="mine.vtu"/></Collection>'))
    snaps = snapshots(sc, count=2, seed=1)
    with open_trajectory(pvd, 0.05, sc) as w:
        for t, x, v in snaps:
            w.add_snapshot(t, x, v)
    assert sorted(p.name for p in (tmp_path / "sub").iterdir()) == \
        ["mine.vtu", "run.pvd", "run_00000.vtu", "run_00001.vtu", "run_00009.vtu"]
    assert outside.read_text() == "not gaz's" and unrelated.read_text() == "not listed"
    assert mine.read_text() == "the user's"
    data = read_trajectory(pvd)
    np.testing.assert_array_equal(data["positions"][1], snaps[1][1])


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
    from gaz_cli.run.runner import Tee

    sc = small_scene(n=8)
    rng = np.random.default_rng(2)
    x = np.array([[0.15 + 0.2 * (i % 4), 0.3 + 0.4 * (i // 4)] for i in range(8)])
    st = State(x, rng.normal(0, 1, (8, 2)), sc.kinds())
    with open_trajectory(tmp_path / "run.h5", 0.02, sc) as w:
        rs = stepper.run(sc, st, Tee(MemoryRecorder(), w))
    data = read_h5md(tmp_path / "run.h5")
    np.testing.assert_allclose(data["time"], 0.02 * np.arange(6), atol=1e-15)
    np.testing.assert_allclose(data["positions"][0], x, rtol=UNITS)
    np.testing.assert_allclose(data["positions"][-1], rs.final.positions, atol=1e-12)


@pytest.mark.parametrize("dim,suffix", [(1, ".h5"), (2, ".h5"), (1, ".gsd"), (2, ".pvd")])
def test_render_gif(tmp_path, dim, suffix):
    """gaz animate draws every format simulate writes."""
    from PIL import Image

    from gaz_cli.outputs.animate import render_gif

    if suffix == ".gsd":
        pytest.importorskip("gsd")
    sc = small_scene(dim=dim)
    with open_trajectory(tmp_path / f"run{suffix}", 0.05, sc) as w:
        for t, x, v in snapshots(sc, count=4):
            w.add_snapshot(t, x, v)
    frames = render_gif(tmp_path / f"run{suffix}", tmp_path / "run.gif", fps=5, size_px=200,
                        frame_png=tmp_path / "last.png")
    assert frames == 4
    with Image.open(tmp_path / "run.gif") as gif:
        assert gif.n_frames == 4
    assert (tmp_path / "last.png").stat().st_size > 0
    (tmp_path / "bad.h5").write_bytes(b"not hdf5")
    with pytest.raises(SceneError, match="cannot read"):
        render_gif(tmp_path / "bad.h5", tmp_path / "x.gif")


@pytest.mark.parametrize("drop", ["particles/trajectory/box", "particles/trajectory/position/time"])
def test_an_h5_lacking_what_gaz_reads_is_one_line(tmp_path, drop):
    """An HDF5 file with positions but no box (a foreign or hand-made one) ended gaz animate in
    'internal error: KeyError: Unable to synchronously open object (component not found)', exit 3."""
    import h5py
    from cli_helpers import invoke

    sc = small_scene(dim=2)
    with open_trajectory(tmp_path / "run.h5", 0.05, sc) as w:
        for t, x, v in snapshots(sc, count=2):
            w.add_snapshot(t, x, v)
    with h5py.File(tmp_path / "run.h5", "a") as f:
        del f[drop]
    code, out, err = invoke(["animate", str(tmp_path / "run.h5"), "-o", str(tmp_path / "x.gif")])
    assert (code, out, len(err.splitlines())) == (1, "", 1), err
    assert err.startswith(f"gaz: error: '{tmp_path / 'run.h5'}' is not an H5MD trajectory (no particles/trajectory/")
    assert not (tmp_path / "x.gif").exists()


def test_animate_help_and_readme_say_how_3d_and_long_runs_are_drawn():
    """gaz animate --help did not say that 3D is drawn as a side view (x, z), nor that a long
    trajectory is subsampled; the README said it renders "1D/2D" trajectories."""
    from pathlib import Path

    from cli_helpers import invoke
    from gaz_cli.outputs.animate import MAX_FRAMES

    help_text = " ".join(invoke(["animate", "--help"]).stdout.split())
    assert "3D spheres as a side view (x across, z up" in help_text, help_text
    assert f"more than {MAX_FRAMES} snapshots is subsampled evenly to {MAX_FRAMES} frames" in help_text
    row = next(line for line in (Path(__file__).parents[1] / "README.md").read_text().splitlines()
               if line.startswith("| `gaz animate`"))
    assert "1D/2D" not in row and "3D as a side view (x, z)" in row and f"{MAX_FRAMES} frames" in row, row


@pytest.mark.parametrize("output", ["", "  "])
def test_animate_refuses_an_empty_output(tmp_path, output):
    """gaz animate run.h5 -o '' wrote run.gif, exit 0, as if no -o had been given. Now one line
    naming -o, nothing written."""
    from cli_helpers import invoke

    sc = small_scene(dim=2)
    with open_trajectory(tmp_path / "run.h5", 0.05, sc) as w:
        for t, x, v in snapshots(sc, count=2):
            w.add_snapshot(t, x, v)
    code, out, err = invoke(["animate", str(tmp_path / "run.h5"), "-o", output])
    assert (code, out, len(err.splitlines())) == (1, "", 1), (code, out, err)
    assert err.startswith(f"gaz: error: -o {output!r} names no file"), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5"]


@pytest.mark.parametrize("damage", ["missing", "truncated", "empty"])
def test_animate_names_a_snapshot_missing_or_damaged_from_its_collection(tmp_path, damage):
    """A .pvd whose .vtu was deleted ended in 'internal error: ReadError', exit 3; a truncated or
    empty one in meshio's own 'Error: Couldn't read file ... as vtu' after a blank line."""
    from cli_helpers import invoke

    sc = small_scene(dim=2)
    with open_trajectory(tmp_path / "run.pvd", 0.05, sc) as w:
        for t, x, v in snapshots(sc, count=4):
            w.add_snapshot(t, x, v)
    vtu = tmp_path / "run_00002.vtu"
    if damage == "missing":
        vtu.unlink()
    else:
        vtu.write_bytes(vtu.read_bytes()[:400] if damage == "truncated" else b"")
    code, out, err = invoke(["animate", str(tmp_path / "run.pvd"), "-o", str(tmp_path / "x.gif")])
    assert (code, out, len(err.splitlines())) == (1, "", 1), (code, out, err)
    assert err.startswith(f"gaz: error: cannot read trajectory '{tmp_path / 'run.pvd'}': its snapshot '{vtu}'")
    assert not (tmp_path / "x.gif").exists()


@pytest.mark.parametrize("suffix", [".h5", ".gsd", ".pvd"])
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_every_format_reads_back_what_was_written(tmp_path, suffix, dim):
    """read_trajectory gives back times, positions, velocities, box, radii and species in SI
    units: to float64 unit rounding (H5MD, VTK), to float32 (GSD stores single precision)."""
    if suffix == ".gsd":
        pytest.importorskip("gsd")
    sc = small_scene(dim=dim)
    snaps = snapshots(sc, count=3, seed=dim)
    with open_trajectory(tmp_path / f"run{suffix}", 0.05, sc) as w:
        for t, x, v in snaps:
            w.add_snapshot(t, x, v)
    data = read_trajectory(tmp_path / f"run{suffix}")
    rtol = 2 ** -23 if suffix == ".gsd" else UNITS  # float32: half an ulp of a value < 2x the box
    assert data["dim"] == dim and data["positions"].shape == (3, sc.n, dim)
    np.testing.assert_allclose(data["time"], [t for t, _, _ in snaps], rtol=UNITS)
    np.testing.assert_allclose(data["positions"], np.stack([x for _, x, _ in snaps]), rtol=0, atol=rtol * 2)
    np.testing.assert_allclose(data["velocities"], np.stack([v for _, _, v in snaps]), rtol=rtol, atol=1e-30)
    np.testing.assert_allclose(data["box"], np.full(dim, sc.length), rtol=UNITS)
    np.testing.assert_allclose(data["radius"], sc.radii(), rtol=rtol)
    np.testing.assert_array_equal(data["species"], sc.kinds())
    assert data["periodic"] is False  # walls (the periodic case: test_animate_wraps_periodic_disks...)


def test_periodic_image_counts_box_crossings(tmp_path):
    """H5MD image: position + image * L is the unwrapped path, across wraps both ways."""
    import h5py

    sc = small_scene(dim=2, n=2, boundary="periodic")
    unwrapped = np.array([[[0.9, 0.5], [0.1, 0.5]], [[1.2, 0.5], [-0.3, 0.5]], [[1.6, 0.5], [-0.7, 0.5]],
                          [[2.05, 0.5], [-1.1, 0.5]]])  # steps under half a box
    with open_trajectory(tmp_path / "run.h5", 0.05, sc) as w:
        for k, x in enumerate(unwrapped):
            w.add_snapshot(0.05 * k, np.mod(x, 1.0), np.zeros_like(x))
    with h5py.File(tmp_path / "run.h5") as f:
        image = f["particles/trajectory/image/value"][()]
        assert f["particles/trajectory/image/step"] == f["particles/trajectory/position/step"]
        # the 2D run in the plane z = 0 of the file's 3D box: z is no periodic axis, never crossed
        assert list(f["particles/trajectory/box"].attrs["boundary"]) == [b"periodic"] * 2 + [b"none"]
        assert not image[:, :, 2].any()
        image = image[:, :, :2]
    data = read_h5md(tmp_path / "run.h5")
    np.testing.assert_allclose(data["positions"] + image * sc.length, unwrapped, atol=1e-15)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_mdanalysis_reads_a_run_in_one_call(tmp_path, dim):
    """mda.Universe("run.h5md") alone (the minimal topology reads particles/trajectory), its units
    converted (angstrom, ps); 1D and 2D runs as the line or the plane through 0 of a 3D box."""
    mda = pytest.importorskip("MDAnalysis")
    sc = replace(small_scene(dim=dim), length=1e-9)  # a box of 1 nm
    snaps = snapshots(sc, count=3)
    with open_trajectory(tmp_path / "run.h5md", 0.05, sc) as w:
        for t, x, v in snaps:
            w.add_snapshot(t * 1e-12, x * 1e-9, v)  # nm-sized box, ps times
    u = mda.Universe(str(tmp_path / "run.h5md"))
    assert u.atoms.n_atoms == sc.n and u.trajectory.n_frames == 3
    for k, ts in enumerate(u.trajectory):
        # MDAnalysis keeps float32 angstroms: half an ulp of values up to 10 A
        np.testing.assert_allclose(ts.positions[:, :dim], snaps[k][1] * 10.0, rtol=0, atol=10 * 2 ** -23)
        np.testing.assert_array_equal(ts.positions[:, dim:], 0.0)
        np.testing.assert_allclose(ts.time, snaps[k][0], rtol=1e-12)  # ps
        np.testing.assert_allclose(ts.dimensions, [10.0, 10.0, 10.0, 90, 90, 90], rtol=1e-7)
        np.testing.assert_allclose(ts.velocities[:, :dim], snaps[k][2] * 1e-2, rtol=2 ** -23)  # m/s -> A/ps
        np.testing.assert_array_equal(ts.velocities[:, dim:], 0.0)


def test_gsd_opens_in_the_gsd_package(tmp_path):
    """The .gsd file as HOOMD/OVITO see it (read by the gsd package itself): a box centred
    on the origin in nm, particle types by species, diameters, the time in the log."""
    gsd_hoomd = pytest.importorskip("gsd.hoomd")
    sc = replace(small_scene(dim=3), length=1e-9)  # a box of 1 nm
    snaps = snapshots(sc, count=2)
    with open_trajectory(tmp_path / "run.gsd", 0.05, sc) as w:
        for t, x, v in snaps:
            w.add_snapshot(t, x * 1e-9, v)
    with gsd_hoomd.open(str(tmp_path / "run.gsd"), "r") as f:
        assert len(f) == 2
        frame = f[1]
        np.testing.assert_allclose(frame.configuration.box, [1, 1, 1, 0, 0, 0])
        assert frame.configuration.dimensions == 3 and frame.configuration.step == 1
        assert list(frame.particles.types) == ["A", "B"]
        np.testing.assert_array_equal(frame.particles.typeid, [0, 0, 0, 0, 1, 1])
        np.testing.assert_allclose(frame.particles.position, snaps[1][1] - 0.5, atol=2 ** -24)
        np.testing.assert_allclose(frame.particles.diameter, 2 * sc.radii() * 1e9, rtol=2 ** -23)
        np.testing.assert_allclose(frame.log["gaz/time_ps"], [0.05e12])


@pytest.fixture
def no_gsd(monkeypatch):
    """The gsd package made unimportable (as where it is not installed)."""
    import builtins

    real = builtins.__import__

    def importing(name, *args, **kw):
        if name.startswith("gsd"):
            raise ImportError(name)
        return real(name, *args, **kw)

    monkeypatch.setattr(builtins, "__import__", importing)


def test_missing_gsd_names_the_extra(tmp_path, no_gsd):
    with pytest.raises(OutputError, match=r"pip install 'gaz\[gsd\]'"):
        open_trajectory(tmp_path / "run.gsd", 0.05, small_scene())


def test_missing_gsd_is_refused_before_the_database_is_created(tmp_path, no_gsd):
    """gaz simulate ... --db new.db --trajectory t.gsd without the gsd package created new.db,
    placed the particles, then said 'GSD trajectories (.gsd) need the gsd package', exit 1: an
    empty gaz database left. Now the same line comes from the door (check_outputs), before it."""
    from cli_helpers import invoke

    res = invoke(["simulate", "--dim", "2", "--n", "5", "--length", "1e-7", "--duration", "1e-11", "--seed", "1",
                  "--db", str(tmp_path / "new.db"), "--trajectory", str(tmp_path / "t.gsd"), "--every", "1e-12"])
    assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.output
    assert "GSD trajectories (.gsd) need the gsd package: pip install 'gaz[gsd]'" in res.stderr, res.stderr
    assert list(tmp_path.iterdir()) == []


def test_more_than_max_snapshots_is_refused_naming_the_fix(tmp_path):
    sc = small_scene()  # duration 0.1 s
    out = tmp_path / "run.h5"
    check_outputs(sc, out, 0.1 / (MAX_SNAPSHOTS - 1))  # exactly MAX_SNAPSHOTS snapshots
    with pytest.raises(SceneError, match=r"makes 10,001 snapshots, more than 10,000; use every 1e-05 "
                                         r"or more, or add force"):
        check_outputs(sc, out, 0.1 / MAX_SNAPSHOTS)
    check_outputs(replace(sc, force=True), out, 0.1 / MAX_SNAPSHOTS)


def test_every_longer_than_the_run_is_refused_naming_the_fix(tmp_path):
    """--every 2 over --duration 1 wrote the t = 0 snapshot alone, exit 0, nothing said; now one
    line naming the fix. --every equal to the duration stays accepted (the start and the end)."""
    from cli_helpers import invoke

    base = ["simulate", "--n", "5", "--dim", "2", "--length", "1e-7", "--duration", "1e-10", "--no-db",
            "--seed", "1", "--trajectory", str(tmp_path / "a.h5")]
    res = invoke(base + ["--every", "2e-10"])
    assert res.exit_code == 1 and len(res.stderr.splitlines()) == 1, res.stderr
    assert "longer than --duration 1e-10 s" in res.stderr and "--every 1e-10 or less" in res.stderr, res.stderr
    assert not (tmp_path / "a.h5").exists()
    res = invoke(base + ["--every", "1e-10"])
    assert res.exit_code == 0, res.stderr
    import h5py

    with h5py.File(tmp_path / "a.h5", "r") as f:
        assert len(f["particles/trajectory/position/time"]) == 2


def test_cli_names_the_flags_and_every_format(tmp_path):
    from cli_helpers import invoke

    base = ["simulate", "--n", "5", "--dim", "2", "--length", "1e-7", "--duration", "0.1", "--no-db"]
    res = invoke(base + ["--trajectory", str(tmp_path / "a.h5"), "--every", "1e-6"])
    assert res.exit_code == 1 and len(res.stderr.splitlines()) == 1
    assert "--every 1e-05 or more" in res.stderr and "--force" in res.stderr
    res = invoke(base + ["--trajectory", str(tmp_path / "a.xyz"), "--every", "0.01"])
    assert res.exit_code == 1 and len(res.stderr.splitlines()) == 1
    assert all(ext in res.stderr for ext in (".h5", ".gsd", ".pvd"))


# --- a full disk ------------------------------------------------------------------------
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


# --- periodic images: exact whatever the snapshot interval ------------------------------------
SMALL, BIG = Species("S", 1.0, 0.005), Species("G", 1.0, 0.06)

PERIODIC_SEARCHES = {
    # name: (dim, components, extras, rebase and restart every few events)
    "2d cells": (2, ((Species("X", 1.0, 0.01), 60),), {}, False),
    "3d lists": (3, ((Species("X", 1.0, 0.01), 60),), {"neighbours": "lists"}, False),
    "2d size classes": (2, ((SMALL, 60), (BIG, 3)), {}, False),
    # rods keep their order: the ones of a Maxwell start, of no net momentum, stay caged; these
    # drift together, colliding on the way
    "1d rods": (1, ((Species("X", 1.0, 0.002), 3),), {}, False),
    "2d cells, rebased and restarted": (2, ((Species("X", 1.0, 0.01), 60),), {}, True),
}


def periodic_scene(dim, components, extras, **kw) -> Scene:
    from gaz_cli.constants import K_B
    from gaz_cli.scenes.validate import validate

    if dim == 1:
        kw["initial"] = {"kind": "explicit", "positions": [[0.1], [0.4], [0.7]],
                         "velocities": [[3.0], [1.5], [2.5]]}

    # m = 1 kg, k_B T = 1 J, L = 1 m: thermal speeds near 1 m/s, a box crossing in about 1 s
    return replace(validate(Scene(dim=dim, length=1.0, duration=2.0, components=components,
                                  temperature=1.0 / K_B, seed=3, boundary="periodic", engine="event",
                                  record="none", **kw)), extras=extras)


def write_run(scene, every, path, run=None):
    """Run ``scene`` (the event engine unless ``run``) into the trajectory ``path`` (H5MD, or
    GSD for a .gsd path); (stats, times, wrapped positions, images, velocities) read back, SI."""
    from gaz_cli.engines import event as engine
    from gaz_cli.placement.initial import initial_state

    with open_trajectory(path, every, scene) as w:
        stats = (run or engine.run)(scene, initial_state(scene), w)
    data = read_trajectory(path)
    if path.suffix == ".gsd":
        import gsd.hoomd

        with gsd.hoomd.open(str(path), "r") as f:
            images = np.stack([fr.particles.image[:, :scene.dim] for fr in f]).astype(np.int64)
    else:
        import h5py

        with h5py.File(path) as f:
            images = f["particles/trajectory/image/value"][()][:, :, :scene.dim].astype(np.int64)
    return stats, data["time"], data["positions"], images, data["velocities"]


def fastest_speed_bound(scene) -> float:
    """sqrt(2 E / m_min): no particle is ever faster (energy conserved, shared by collisions)."""
    from gaz_cli.placement.initial import initial_state

    v = initial_state(scene).velocities
    energy = 0.5 * float(np.sum(scene.masses()[:, None] * v ** 2))
    return float(np.sqrt(2.0 * energy / scene.masses().min()))


@pytest.mark.parametrize("search", list(PERIODIC_SEARCHES))
def test_images_of_sparse_snapshots_are_those_of_a_dense_run(tmp_path, monkeypatch, search):
    """Snapshots further apart than half a box crossing: the engine's images are exactly those
    the minimum image infers between the snapshots of a dense run of the same seed (same
    events), whose interval is short enough for it to be exact: the fastest possible speed,
    sqrt(2 E / m_min), times the interval is under half the box."""
    _check_sparse_images(tmp_path, monkeypatch, search, ".h5")


@pytest.mark.parametrize("search", ["2d cells", "3d lists", "1d rods"])
def test_gsd_images_of_sparse_snapshots_are_those_of_a_dense_run(tmp_path, monkeypatch, search):
    """The same in a GSD file: particles/image (HOOMD's convention, positions centred on the
    origin in float32 nm) holds the engine's box crossings, as H5MD's image does."""
    pytest.importorskip("gsd.hoomd")
    _check_sparse_images(tmp_path, monkeypatch, search, ".gsd")


def _check_sparse_images(tmp_path, monkeypatch, search, suffix):
    """Sparse snapshots' images = the dense run's minimum-image count (see the tests above)."""
    from gaz_cli.engines.event import driver

    dim, components, extras, churn = PERIODIC_SEARCHES[search]
    if churn:  # rows reloaded (rebase) and renumbered (restart) every few events per particle
        monkeypatch.setattr(driver, "REBASE_EVENTS_PER_PARTICLE", 3)
        monkeypatch.setattr(driver, "RESTART_FROM_N", 1)
        monkeypatch.setattr(driver, "RESTART_EVERY", 2)
    scene = periodic_scene(dim, components, extras)
    dense_every = 0.45 * scene.length / fastest_speed_bound(scene)
    ratio = int(np.ceil(0.5 / dense_every))
    dense_every = 0.5 / ratio  # the sparse snapshots (every 0.5 s) fall on dense ones
    stats, t, x, _, _ = write_run(scene, dense_every, tmp_path / f"dense{suffix}")
    sparse_stats, ts, xs, images, _ = write_run(scene, 0.5, tmp_path / f"sparse{suffix}")
    assert sparse_stats.collisions == stats.collisions > 0
    if churn:
        assert sparse_stats.extras["rebases"] > 3 and sparse_stats.extras["restarts"] > 3
    if search == "3d lists":
        assert sparse_stats.extras["neighbour_lists"]
    if search == "2d size classes":
        assert sparse_stats.extras["size_classes"]
    # the dense run's minimum image, exact there
    steps = np.diff(x, axis=0)
    dense_images = np.concatenate([np.zeros((1, *x.shape[1:]), dtype=np.int64),
                                   -np.cumsum(np.rint(steps / scene.length).astype(np.int64), axis=0)])
    np.testing.assert_array_equal(t[::ratio], ts)
    np.testing.assert_array_equal(x[::ratio], xs)  # same events, same positions
    np.testing.assert_array_equal(images, dense_images[::ratio])
    # and the sparse interval is one where the minimum image fails: a particle moved more than
    # half a box between two sparse snapshots
    unwrapped = xs + images * scene.length
    assert np.abs(np.diff(unwrapped, axis=0)).max() > 0.5 * scene.length
    guessed = -np.cumsum(np.rint(np.diff(xs, axis=0) / scene.length).astype(np.int64), axis=0)
    assert np.any(guessed != images[1:])


@pytest.mark.parametrize("path", ["event", "ideal"])
@pytest.mark.parametrize("dim", [2, 3])
def test_free_particles_mean_squared_displacement_grows_as_v_t_squared(tmp_path, path, dim):
    """Point particles in a periodic box fly free: each unwrapped displacement (position +
    image L, from the file) is v t exactly, so the mean squared displacement is <v^2> t^2,
    with snapshots far enough apart for some particles to cross the whole box between two.

    Tolerance: the unwrapped position is a wrapped one (rounded in the engine's flight, the
    wrap, the nanometre conversion and back: a few ulp of L) plus an exact image count, and
    v t is rounded once: 16 eps (L + |v| t) a coordinate."""
    from gaz_cli.engines import event as engine
    from gaz_cli.engines import ideal

    scene = periodic_scene(dim, ((Species("P", 1.0, 0.0), 20),), {})
    stats, t, x, images, v = write_run(scene, 1.0, tmp_path / "free.h5",
                                       engine.run if path == "event" else ideal.run)
    assert stats.collisions == 0 and len(t) == 3
    unwrapped = x + images * scene.length
    displacement = unwrapped - unwrapped[0]
    expected = v[0][None] * t[:, None, None]
    assert np.abs(np.diff(unwrapped, axis=0)).max() > scene.length  # more than a box
    tol = 16 * np.finfo(float).eps * (scene.length + np.abs(expected))
    assert np.all(np.abs(displacement - expected) <= tol)
    msd = np.mean(np.sum(displacement ** 2, axis=2), axis=1)
    speed2 = np.mean(np.sum(v[0] ** 2, axis=1))
    np.testing.assert_allclose(msd, speed2 * t ** 2, rtol=1e-12)


def test_animate_names_the_formats_for_a_file_that_is_no_trajectory(tmp_path):
    """`gaz animate state.csv` (a --save-state file) answered with HDF5's "file signature not
    found": every name it did not know went to the H5MD reader. Now one line naming the
    formats; an H5MD file under another name (run.h5md) is still read, by its signature."""
    from cli_helpers import invoke

    csv = tmp_path / "state.csv"
    csv.write_text("x,y\n0.5,0.5\n")
    code, out, err = invoke(["animate", str(csv), "-o", str(tmp_path / "x.gif")])
    assert (code, out, len(err.splitlines())) == (1, "", 1), (code, out, err)
    assert "not a file gaz simulate --trajectory writes" in err and ".gsd" in err and ".pvd" in err
    assert not (tmp_path / "x.gif").exists()
    sc = small_scene(dim=2)
    with open_trajectory(tmp_path / "run.h5", 0.05, sc) as w:
        for t, x, v in snapshots(sc, count=2):
            w.add_snapshot(t, x, v)
    (tmp_path / "run.h5").rename(tmp_path / "run.h5md")
    assert read_trajectory(tmp_path / "run.h5md")["positions"].shape == (2, sc.n, 2)


@pytest.mark.parametrize("suffix", [".h5md", ".gsd", ".pvd"])
@pytest.mark.parametrize("boundary", ["periodic", "walls"])
def test_animate_wraps_periodic_disks_at_the_edges(tmp_path, suffix, boundary):
    """A disk across the left edge of a periodic box is drawn on both sides (itself and its
    periodic image), in every format; between walls it is drawn once, clipped. Read from the
    frame's pixels: the disk's colour (C0) in the right third of the image or not."""
    from PIL import Image

    from gaz_cli.outputs.animate import render_gif

    if suffix == ".gsd":
        pytest.importorskip("gsd")
    sc = Scene(dim=2, length=1.0, duration=0.1, components=((Species("A", 1.0, 0.1), 1),), seed=1,
               engine="step", dt=1e-3, boundary=boundary)
    with open_trajectory(tmp_path / f"run{suffix}", 0.05, sc) as w:
        for k in range(2):
            w.add_snapshot(0.05 * k, np.array([[0.03, 0.5]]), np.zeros((1, 2)))
    render_gif(tmp_path / f"run{suffix}", tmp_path / "run.gif", size_px=300, frame_png=tmp_path / "last.png")
    pixels = np.asarray(Image.open(tmp_path / "last.png").convert("RGB")).astype(int)
    blue = np.abs(pixels - np.array([31, 119, 180])).sum(axis=2) < 30  # matplotlib's C0
    columns = np.nonzero(blue.any(axis=0))[0]
    width = pixels.shape[1]
    assert columns.size and columns.min() < width / 3  # the disk itself, at the left edge
    assert (columns.max() > 2 * width / 3) == (boundary == "periodic"), columns
