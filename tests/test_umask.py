"""Files gaz creates take the process's umask, as any tool's do: a new database, trajectory,
state or scene file, a figure, is 0644 under umask 022 (a class's shared database readable by all) and
0600 under umask 077."""

from __future__ import annotations

import os
import stat

import pytest

from cli_helpers import invoke


@pytest.fixture
def umask():
    """umask(value): set the process's umask for the test, restored after it."""
    old = os.umask(0o022)
    os.umask(old)
    yield os.umask
    os.umask(old)


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.mark.parametrize("mask,expected", [(0o022, 0o644), (0o027, 0o640), (0o077, 0o600)],
                         ids=["022", "027", "077"])
def test_new_files_take_the_umask(tmp_path, umask, mask, expected):
    umask(mask)
    res = invoke(["simulate", "--dim", "2", "--n", "5", "--length", "1e-7", "--duration", "1e-11", "--seed", "1",
                  "--db", str(tmp_path / "gaz.db"), "--trajectory", str(tmp_path / "run.h5md"),
                  "--every", "5e-12", "--save-state", str(tmp_path / "state.csv"),
                  "--write-scene", str(tmp_path / "scene.toml")])
    assert res.exit_code == 0, res.stderr
    res = invoke(["animate", str(tmp_path / "run.h5md"), "-o", str(tmp_path / "run.gif")])
    assert res.exit_code == 0, res.stderr
    made = sorted(p.name for p in tmp_path.iterdir())
    assert made == ["gaz.db", "run.gif", "run.h5md", "scene.toml", "state.csv"], made
    assert {name: oct(mode(tmp_path / name)) for name in made} == {name: oct(expected) for name in made}


@pytest.mark.parametrize("mask,expected", [(0o022, 0o644), (0o077, 0o600)], ids=["022", "077"])
def test_a_gsd_trajectory_takes_the_umask_too(tmp_path, umask, mask, expected):
    """The gsd package creates its files 0640 whatever the umask: the rename into place sets
    the mode a new file takes (gaz_cli.atomic.commit)."""
    pytest.importorskip("gsd")
    umask(mask)
    res = invoke(["simulate", "--dim", "2", "--n", "5", "--length", "1e-7", "--duration", "1e-11", "--seed", "1",
                  "--no-db", "--trajectory", str(tmp_path / "run.gsd"), "--every", "5e-12"])
    assert res.exit_code == 0, res.stderr
    assert oct(mode(tmp_path / "run.gsd")) == oct(expected)
