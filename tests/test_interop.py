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
