"""gaz's files in the tools their users open them with, as those tools' own conventions ask:
MDAnalysis (H5MD), gsd and freud (GSD), pyvista (VTK); each read back by the real package,
compared with what ``gaz simulate`` itself says (``--save-state``, the run's clock, --json).

A reader that does not install here is skipped with its reason (the test extra installs
MDAnalysis and gsd; the others are tried when present)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from cli_helpers import invoke

L, DURATION, EVERY = 1e-7, 2e-10, 5e-11
"""A box of 100 nm, five snapshots (t = 0, 50, ..., 200 ps)."""

F32 = 2.0 ** -23
"""Relative half-ulp of float32, as MDAnalysis (angstrom) and GSD (nm) store coordinates."""


def simulate(tmp_path, dim, name, *extra):
    """``gaz simulate`` of 20 argon atoms with --trajectory NAME and --save-state: (path of the
    trajectory, the saved state's positions and velocities (N, dim) m and m/s, the --json
    summary)."""
    traj, state = tmp_path / name, tmp_path / "state.csv"
    res = invoke(["simulate", "--dim", str(dim), "--species", "Ar:20", "--length", str(L),
                  "--duration", str(DURATION), "--seed", "3", "--no-db", "--json", "--trajectory", str(traj),
                  "--every", str(EVERY), "--save-state", str(state), *extra])
    assert res.exit_code == 0, res.stderr
    with open(state, newline="") as fh:
        rows = list(csv.DictReader(fh))
    axes = "xyz"[:dim]
    x = np.array([[float(r[a]) for a in axes] for r in rows])
    v = np.array([[float(r["v" + a]) for a in axes] for r in rows])
    return traj, x, v, json.loads(res.stdout)


@pytest.mark.parametrize("dim", [2, 3])
def test_mdanalysis_opens_a_run_in_one_call(tmp_path, dim):
    """mda.Universe("run.h5md"): no topology, no format; the last frame is --save-state's state
    (angstrom and angstrom/ps, float32), at the run's duration (ps), in the run's box; a 2D
    run lies in the plane z = 0, as the file's /parameters embedding says."""
    mda = pytest.importorskip("MDAnalysis", reason="MDAnalysis is in the test extra: pip install -e '.[test]'")
    import h5py

    path, x, v, summary = simulate(tmp_path, dim, "run.h5md")
    u = mda.Universe(str(path))
    assert u.atoms.n_atoms == 20 and u.trajectory.n_frames == 5
    last = u.trajectory[-1]
    np.testing.assert_allclose(last.positions[:, :dim], x * 1e10, rtol=0, atol=L * 1e10 * F32)
    np.testing.assert_allclose(last.velocities[:, :dim], v * 1e-2, rtol=F32, atol=1e-30)
    np.testing.assert_allclose(last.time, summary["duration"] * 1e12, rtol=1e-12)
    np.testing.assert_allclose(last.dimensions, [L * 1e10] * 3 + [90.0] * 3, rtol=F32)
    np.testing.assert_allclose([ts.time for ts in u.trajectory], np.arange(5) * EVERY * 1e12, rtol=1e-12)
    if dim == 2:
        assert not u.trajectory[-1].positions[:, 2].any() and not u.trajectory[-1].velocities[:, 2].any()
    with h5py.File(path, "r") as f:
        assert f["parameters"].attrs["dim"] == dim
        assert f["parameters"].attrs["embedding"].decode().startswith(
            "2D run written as the plane z = 0" if dim == 2 else "3D run")


def test_the_h5_alias_is_the_same_file_for_mdanalysis(tmp_path):
    """run.h5 (gaz's earlier name, kept) holds the same H5MD; MDAnalysis guesses a format by the
    extension alone (even its minimal topology ignores format=), so such a file is read in two
    calls, as the docs say: an empty Universe, then load_new with the format named."""
    mda = pytest.importorskip("MDAnalysis", reason="MDAnalysis is in the test extra: pip install -e '.[test]'")
    path, x, _, _ = simulate(tmp_path, 2, "run.h5")
    u = mda.Universe.empty(20, trajectory=True)
    u.load_new(str(path), format="H5MD")
    np.testing.assert_allclose(u.trajectory[-1].positions[:, :2], x * 1e10, rtol=0, atol=L * 1e10 * F32)


@pytest.mark.parametrize("boundary", ["walls", "periodic"])
def test_gsd_says_whether_the_box_had_walls(tmp_path, boundary):
    """GSD has no walls (its boxes are periodic): each frame's log gaz/walls says 1 for a run
    between walls, 0 for a periodic one; the last frame is --save-state's state (float32 nm,
    centred on the origin), at the run's duration."""
    gsd_hoomd = pytest.importorskip("gsd.hoomd", reason="gsd is in the test extra: pip install -e '.[test]'")
    path, x, v, summary = simulate(tmp_path, 2, "run.gsd", "--boundary", boundary)
    with gsd_hoomd.open(str(path), "r") as f:
        assert len(f) == 5
        assert all(int(frame.log["gaz/walls"][0]) == (boundary == "walls") for frame in f)
        last = f[-1]
        np.testing.assert_allclose(last.particles.position[:, :2] + 50.0, x * 1e9, rtol=0, atol=100 * F32)
        np.testing.assert_allclose(last.particles.velocity[:, :2], v * 1e-3, rtol=F32)  # nm/ps
        np.testing.assert_allclose(last.log["gaz/time_ps"], summary["duration"] * 1e12, rtol=1e-12)


FREUD = """
import json, sys
import freud, gsd.hoomd
with gsd.hoomd.open(sys.argv[1], "r") as f:
    last = f[-1]
box = freud.box.Box.from_box(last.configuration.box)
box.periodic = (not int(last.log["gaz/walls"][0]),) * 3
points = last.particles.position
n = len(points)
i = [a for a in range(n) for b in range(a + 1, n)]
j = [b for a in range(n) for b in range(a + 1, n)]
print(json.dumps({"is2D": bool(box.is2D), "L": [float(box.Lx), float(box.Ly)],
                  "periodic": [bool(p) for p in box.periodic],
                  "fractional": box.make_fractional(points).tolist(),
                  "distances": box.compute_distances(points[i], points[j]).tolist()}))
"""
"""freud in a child process: at exit freud's bindings (nanobind) print a page of 'leaked
function' lines, which would follow pytest's summary in CI's log."""


def test_freud_reads_the_gsd_box_and_positions(tmp_path):
    """freud's Box of the GSD frame maps the particles back to --save-state's positions (its
    fractional coordinates times L), and with the walls the log states (periodic=False) its
    distances are the straight ones between the saved positions."""
    import subprocess
    import sys

    import importlib.util

    if importlib.util.find_spec("freud") is None:  # (not imported here: see FREUD)
        pytest.skip("freud-analysis is in the test extra: pip install -e '.[test]'")
    pytest.importorskip("gsd.hoomd", reason="gsd is in the test extra")
    path, x, _, _ = simulate(tmp_path, 2, "run.gsd")
    child = subprocess.run([sys.executable, "-c", FREUD, str(path)], capture_output=True, text=True, timeout=300)
    assert child.returncode == 0, child.stderr[-2000:]
    seen = json.loads(child.stdout)
    assert seen["is2D"] and np.allclose(seen["L"], 100.0) and seen["periodic"] == [False] * 3
    np.testing.assert_allclose(np.array(seen["fractional"])[:, :2] * L, x, rtol=0, atol=L * F32)
    i, j = np.triu_indices(len(x), 1)
    np.testing.assert_allclose(np.array(seen["distances"]) * 1e-9, np.linalg.norm(x[i] - x[j], axis=1),
                               rtol=0, atol=2 * L * F32)


@pytest.mark.parametrize("dim", [2, 3])
def test_ovito_imports_the_gsd_file(tmp_path, dim):
    """OVITO's own importer (ovito.io.import_file) reads the GSD file: every snapshot a frame,
    the last one --save-state's positions in its cell, radii and species names, and the log's
    gaz/walls among the global attributes."""
    pytest.importorskip("ovito", reason="ovito is in the test extra: pip install -e '.[test]'")
    from ovito.io import import_file

    path, x, _, _ = simulate(tmp_path, dim, "run.gsd")
    pipeline = import_file(str(path))
    assert pipeline.source.num_frames == 5
    data = pipeline.compute(4)
    origin = np.asarray(data.cell[:, 3])
    np.testing.assert_allclose((np.asarray(data.particles.positions) - origin)[:, :dim], x * 1e9,
                               rtol=0, atol=100 * F32)
    assert data.attributes["gaz/walls"] == 1 and data.attributes["gaz/dimension"] == dim
    np.testing.assert_allclose(data.particles["Radius"], 0.179, rtol=1e-6)  # argon, nm
    assert [t.name for t in data.particles.particle_types.types] == ["Ar"]


def test_pyvista_reads_the_pvd_and_glyphs_true_sizes(tmp_path):
    """pyvista (VTK's own readers) opens the .pvd: the snapshots' times, the last one
    --save-state's positions; ParaView's glyph filter (vtkGlyph3D) scaled by the point array
    ``diameter`` draws each particle at its true size (a sphere of diameter 1 scaled: the
    glyphs' z extent is each particle's z plus or minus its radius)."""
    pv = pytest.importorskip("pyvista", reason="pyvista is in the test extra: pip install -e '.[test]'")
    path, x, v, summary = simulate(tmp_path, 3, "run.pvd")
    reader = pv.get_reader(str(path))
    np.testing.assert_allclose(reader.time_values, np.arange(5) * EVERY, rtol=1e-12)
    reader.set_active_time_point(4)
    mesh = reader.read()[0]
    np.testing.assert_array_equal(mesh.points, x)
    np.testing.assert_array_equal(mesh.point_data["velocity"], v)
    radius = np.asarray(mesh.point_data["radius"])
    np.testing.assert_allclose(radius, 0.179e-9, rtol=1e-12)
    assert set(mesh.point_data["species"]) == {0}
    glyphs = mesh.glyph(scale="diameter", factor=1.0, geom=pv.Sphere(radius=0.5), orient=False)
    zmin, zmax = glyphs.bounds[4], glyphs.bounds[5]
    np.testing.assert_allclose([zmin, zmax], [np.min(x[:, 2] - radius), np.max(x[:, 2] + radius)], rtol=1e-6)
