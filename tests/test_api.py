"""The Python API at the package's top level: the example of docs/tutorials/python.md runs, bounces
kept in memory are the rows the database stores, and `import gaz_cli` stays light."""

from __future__ import annotations

import re
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

TUTORIAL = Path(__file__).resolve().parent.parent / "docs" / "tutorials" / "python.md"


def _example() -> str:
    """The tutorial's first block (a run in memory) and the block that stores it and analyses it."""
    text = TUTORIAL.read_text(encoding="utf-8")
    first = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    stored = re.search(r"```python\n(.*?)```", text.split("## Stored runs and their analysis", 1)[1], re.S).group(1)
    return first + stored


def test_the_tutorial_example_runs_and_memory_holds_the_stored_rows(tmp_path, monkeypatch, capsys):
    """The Python tutorial's example, as written; then its in-memory bounces against the rows it
    stored (same scene, same seed: the same bounces, bit for bit)."""
    monkeypatch.chdir(tmp_path)
    space: dict = {}
    exec(compile(_example(), str(TUTORIAL), "exec"), space)
    run, stored = space["run"], space["stored"]
    assert "PRESSION" in capsys.readouterr().out  # the Q36 table printed
    assert run.bounces["t"].size == run.summary["wall_bounces"] > 0
    assert run.state.positions.shape == (1000, 3)
    with sqlite3.connect(tmp_path / "notebook.db") as conn:
        rows = np.array(conn.execute("SELECT RE_T, RE_DIR, RE_VIT, RE_VP FROM REBOND WHERE SI_NUM = ? "
                                     "ORDER BY RE_NUM", (stored.summary["si_num"],)).fetchall())
    assert np.array_equal(rows[:, 0], run.bounces["t"]) and np.array_equal(rows[:, 1], run.bounces["wall"])
    assert np.array_equal(rows[:, 3], run.bounces["vperp"])


def test_import_gaz_cli_is_light():
    """Start-up time (issue 15): the top level loads the API on first use only."""
    code = "import sys, gaz_cli; print(sorted(m for m in ('numpy', 'pandas', 'sqlalchemy', 'matplotlib', 'numba') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_api_goes_through_the_one_door():
    import gaz_cli as gaz

    with pytest.raises(gaz.SceneError, match="^drag -1.0 applies to engine step only"):
        gaz.make_scene(dim=2, species={"Ar": 10}, length=1e-7, duration=1e-10, drag=-1.0, engine="event")
    with pytest.raises(gaz.SceneError, match="drag"):  # auto takes the step engine for drag: out of range
        gaz.make_scene(dim=2, species={"Ar": 10}, length=1e-7, duration=1e-10, drag=-1.0)
    with pytest.raises(AttributeError):
        gaz.no_such_thing  # noqa: B018


def test_a_scene_written_from_python_loads_back(tmp_path):
    import gaz_cli as gaz

    scene = gaz.make_scene(dim=3, species="Ar:20,He:10", packing=0.01, duration=1e-11, seed=3)
    gaz.write_scene(tmp_path / "s.toml", scene)
    assert gaz.load_scene(tmp_path / "s.toml") == scene


def test_every_exception_of_the_library_is_at_the_top_level(tmp_path):
    """gaz.StoreError raised AttributeError (only GazError and SceneError were exported), while
    gaz.open_store and gaz.simulate(db=...) raise it: a notebook could not catch it by the
    package's name. Now every exception and warning of gaz_cli.errors is there."""
    import inspect

    import gaz_cli as gaz
    from gaz_cli import errors

    mine = {name for name, value in vars(errors).items()
            if inspect.isclass(value) and issubclass(value, BaseException) and value.__module__ == errors.__name__}
    assert {"GazError", "StoreError", "OutputError", "Interrupted", "GazWarning"} <= mine
    for name in mine:
        assert getattr(gaz, name) is getattr(errors, name) and name in gaz.__all__, name
    with pytest.raises(gaz.StoreError, match="does not exist"):
        gaz.open_store(tmp_path / "none.db")


@pytest.mark.parametrize("key", ["trajectory", "save_state", "write_scene"])
def test_an_output_path_of_another_type_is_refused_in_one_line(tmp_path, key):
    """gaz.simulate(scene, save_state=5) (or trajectory=5, write_scene=5) raised TypeError
    'expected str, bytes or os.PathLike object, not int' from pathlib; a database given the
    same way was already one line. Now a SceneError naming the option, before anything runs;
    a pathlib.Path is taken."""
    import gaz_cli as gaz

    scene = gaz.make_scene(dim=2, species={"Ar": 5}, length=1e-7, duration=1e-11, seed=1)
    every = {"every": 5e-12} if key == "trajectory" else {}
    option = "--" + key.replace("_", "-")
    with pytest.raises(gaz.SceneError, match=rf"^{option} 5 is not a file path; give a path"):
        gaz.simulate(scene, db=str(tmp_path / "g.db"), **{key: 5}, **every)
    assert list(tmp_path.iterdir()) == []
    name = {"trajectory": "t.h5", "save_state": "s.csv", "write_scene": "s.toml"}[key]
    gaz.simulate(scene, **{key: tmp_path / name}, **every)
    assert (tmp_path / name).is_file()


def test_a_scene_the_door_refuses_is_not_written(tmp_path):
    """gaz.write_scene(path, gaz.Scene(..., duration=-1.0)) (a Scene made by hand) wrote a file
    that gaz.load_scene then refused, 'duration must be a positive number, got -1.0'; its
    docstring promises a file that reads back. Now the same SceneError, and no file; a valid
    scene made by hand is written and reads back."""
    import gaz_cli as gaz
    from gaz_cli.model.species import BUILTIN

    bad = gaz.Scene(dim=2, length=1e-7, duration=-1.0, components=((BUILTIN["Ar"], 5),), seed=1)
    with pytest.raises(gaz.SceneError, match="duration must be a positive number, got -1.0"):
        gaz.write_scene(tmp_path / "s.toml", bad)
    with pytest.raises(gaz.SceneError, match="duration must be a positive number, got -1.0"):
        gaz.scene_text(bad)
    assert list(tmp_path.iterdir()) == []
    good = gaz.Scene(dim=2, length=1e-7, duration=1e-11, components=((BUILTIN["Ar"], 5),), seed=1)
    gaz.write_scene(tmp_path / "s.toml", good)
    assert gaz.load_scene(tmp_path / "s.toml") == gaz.make_scene(dim=2, species={"Ar": 5}, length=1e-7,
                                                                 duration=1e-11, seed=1)


@pytest.mark.parametrize("given", [{"dim": 2}, "scene.toml", None])
def test_writing_something_else_than_a_scene_says_what_is_expected(tmp_path, given):
    """gaz.scene_text({'dim': 2}) and gaz.write_scene(path, 'hello') raised AttributeError "'dict'
    object has no attribute 'dim'" from scenefile.py; the arguments swapped, write_scene(scene,
    path), a TypeError about os.PathLike. Now a SceneError (a ValueError) naming the Scene
    expected, nothing written."""
    import gaz_cli as gaz

    expected = rf"^expected a Scene \(from gaz.make_scene or gaz.load_scene\), got {type(given).__name__} "
    with pytest.raises(gaz.SceneError, match=expected):
        gaz.scene_text(given)
    with pytest.raises(ValueError, match=expected):
        gaz.write_scene(tmp_path / "s.toml", given)
    scene = gaz.make_scene(dim=2, species={"Ar": 5}, length=1e-7, duration=1e-12, seed=1)
    with pytest.raises(gaz.SceneError, match=r"^write_scene\(path, scene\) was given a Scene first and a "
                                             r"PosixPath second: the path comes first$"):
        gaz.write_scene(scene, tmp_path / "s.toml")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sim", ["1", 1.0, True])
def test_analyse_refuses_a_sim_that_is_not_an_int(tmp_path, sim):
    """gaz.analyse(db, sim="1") said 'simulation 1 is not in ...; it holds SI_NUM 1'."""
    import gaz_cli as gaz
    from gaz_cli.errors import StoreError

    db = str(tmp_path / "g.db")
    gaz.simulate(gaz.make_scene(dim=2, species={"Ar": 5}, length=1e-7, duration=1e-12, seed=1), db=db)
    with pytest.raises(StoreError, match=rf"^sim {sim!r} is not an int; give SIMULATION.SI_NUM as an int"):
        gaz.analyse(db, sim=sim)
    assert "Q36 momentum and pressure per wall" in gaz.analyse(db, sim=1)


@pytest.mark.parametrize("species", [None, 5, ["Ar"], [("Ar", 5)], {"Ar"}])
def test_make_scene_refuses_species_of_another_type_in_one_line(species):
    """make_scene(species=None) raised TypeError: 'NoneType' object is not iterable, from api.py;
    species=['Ar'] a ValueError about a dictionary update sequence."""
    import gaz_cli as gaz

    with pytest.raises(gaz.SceneError, match=r"^species .* is not a dict of counts \({'Ar': 500}\), a string"):
        gaz.make_scene(dim=2, species=species, length=1e-7, duration=1e-10)
    assert gaz.make_scene(dim=2, species=[{"name": "Ar", "count": 5}], length=1e-7, duration=1e-10).n == 5


def test_a_database_given_as_a_pathlib_path_is_used_and_another_type_refused(tmp_path):
    """gaz.simulate(scene, db=tmp_path / "g.db") raised TypeError "argument of type 'PosixPath' is
    not iterable" from sqlite_writer.py, and gaz.analyse / gaz.open_store said such a path 'names
    no database', while load_scene and write_scene take paths."""
    import gaz_cli as gaz
    from gaz_cli.errors import StoreError

    scene = gaz.make_scene(dim=2, species={"Ar": 5}, length=1e-7, duration=1e-12, seed=1)
    db = tmp_path / "g.db"
    assert gaz.simulate(scene, db=db).summary["si_num"] == 1
    assert "Q36 momentum and pressure per wall" in gaz.analyse(db, sim=1)
    with gaz.open_store(db) as store:
        assert store.simulation_numbers() == [1]
    with pytest.raises(StoreError, match=r"^--db 5 names no database; give a file path or a URL$"):
        gaz.simulate(scene, db=5)


def test_diagnostics_are_given_by_the_step_engine_and_refused_where_nobody_would_call_them():
    """``diagnostics`` reaches the step engine's reports; where it would never be called (another
    engine, or print_every 0) or is not a function, the run is refused before it starts, in one
    line naming the fix. Before, the event engine ignored it silently, and diagnostics=5 was
    accepted (or failed mid-run with "TypeError: 'int' object is not callable")."""
    import gaz_cli as gaz
    from gaz_cli.errors import SceneError

    keys = dict(dim=2, species={"Ar": 10}, length=1e-7, duration=1e-11, seed=1)
    step = gaz.make_scene(engine="step", dt=1e-12, print_every=5, **keys)
    got = []
    run = gaz.simulate(step, diagnostics=got.append)
    assert [d["step"] for d in got] == [0, 5, 10] and run.summary["engine"] == "step"
    for scene, diagnostics, says in [
            (gaz.make_scene(engine="event", **keys), got.append,
             "diagnostics are written by the step engine; this scene runs the event engine"),
            (gaz.make_scene(**keys), got.append, "diagnostics are written by the step engine"),
            (gaz.make_scene(engine="step", dt=1e-12, **keys), got.append, "print_every is 0"),
            (step, 5, "diagnostics 5 is not callable"),
            (gaz.make_scene(engine="event", **keys), "energy", "diagnostics 'energy' is not callable")]:
        with pytest.raises(SceneError, match=re.escape(says)) as err:
            gaz.simulate(scene, diagnostics=diagnostics)
        assert "\n" not in str(err.value)
    assert len(got) == 3  # nothing more was reported


def test_the_command_line_prints_diagnostics_of_the_step_engine_only():
    """--print-every: diagnostics on stderr with the step engine; refused with another engine;
    a step run without it prints none (the CLI passes its printer only with --print-every)."""
    from cli_helpers import invoke

    base = ["simulate", "--dim", "2", "--n", "10", "--length", "1e-7", "--duration", "1e-11", "--seed", "1",
            "--no-db", "--quiet"]
    res = invoke(base + ["--engine", "step", "--dt", "1e-12", "--print-every", "5"])
    assert res.exit_code == 0 and res.stderr.count("energy=") == 3
    res = invoke(base + ["--engine", "step", "--dt", "1e-12"])
    assert res.exit_code == 0 and "energy=" not in res.stderr
    res = invoke(base + ["--engine", "event", "--print-every", "5"])
    assert res.exit_code != 0 and "--print-every 5 applies to --engine step only" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
