"""Scene files (TOML): written and read back exactly, checked at the one door, presets as
packaged scene files, every stored simulation re-runnable from its SC_FILE, the examples."""

from __future__ import annotations

import json
import math
import sqlite3
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from backends import BACKENDS, backend, postgres_db, postgres_url  # noqa: F401 - fixtures
from cli_helpers import invoke

from gaz_cli.scenes import files as scenefile
from gaz_cli.errors import SceneError
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.scenes.validate import validate
from gaz_cli.model.species import BUILTIN, Species

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def _rows(db) -> list:
    with sqlite3.connect(db) as conn:
        return conn.execute("SELECT RE_NUM, PA_NUM, RE_T, RE_DIR, RE_VIT, RE_VP FROM REBOND "
                            "ORDER BY SI_NUM, RE_NUM").fetchall()


# --- the module graph -------------------------------------------------------------------------
def test_importing_the_scene_imports_neither_placement_nor_theory_nor_an_engine():
    """The scene is a description: it must not pull in what it describes (no cycle back)."""
    code = ("import sys, gaz_cli.model.scene; print(sorted(m for m in sys.modules if m.startswith('gaz_cli')))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    for module in ("gaz_cli.placement", "gaz_cli.theory", "gaz_cli.engines.step", "gaz_cli.engines.event",
                   "gaz_cli.engines.reference", "gaz_cli.scenes.options"):
        assert f"'{module}'" not in loaded, loaded


def test_one_copy_of_the_packing_fraction():
    """Scene, geometry and placement agree on eta (one formula: geometry.packing_fraction)."""
    from gaz_cli import geometry

    ar, he = BUILTIN["Ar"], BUILTIN["He"]
    sc = Scene(dim=2, length=2e-8, duration=1e-12, components=((ar, 30), (he, 20)), seed=1)
    by_hand = (30 * math.pi * ar.radius ** 2 + 20 * math.pi * he.radius ** 2) / 2e-8 ** 2
    assert sc.packing_fraction == pytest.approx(by_hand, rel=1e-14)  # round-off of a few products
    assert geometry.packing_fraction(2, sc.radii(), sc.length) == pytest.approx(by_hand, rel=1e-14)


# --- write, read back -------------------------------------------------------------------------
def _scenes():
    ar = BUILTIN["Ar"]
    yield Scene(dim=3, length=3.4e-8, duration=1e-8, components=((ar, 1000),), seed=1)
    yield Scene(dim=2, length=1e-7, duration=1e-9, components=((ar, 10), (BUILTIN["He"], 7)), seed=2 ** 62,
                boundary="periodic", restitution=0.9, tc=1.2345678901234567e-15, record="all", placement="grow")
    yield Scene(dim=2, length=1.0 / 3.0, duration=0.1, components=((Species("bead", 1e-3 / 7, 1e-3 / 3), 5),),
                seed=3, engine="step", dt=1e-3, drag=0.1, gravity=9.81, wall_restitution=0.75,
                planes=(((0.0, 0.1), (0.6, 0.8), 0.5),), print_every=7, force=True)


@pytest.mark.parametrize("scene", list(_scenes()), ids=["exam", "periodic-mixture", "step-custom"])
def test_a_written_scene_reads_back_the_same(scene):
    """dumps then loads: the same Scene, field for field (floats bit for bit: repr round-trips)."""
    back, outputs = scenefile.loads(scenefile.dumps(scene, {"db": "x.db", "every": 1e-3}))
    assert back == validate(scene)  # engine "auto" resolved the same way on both sides
    assert outputs == {"db": "x.db", "every": 1e-3}


def test_an_explicit_initial_state_reads_back_bit_for_bit():
    sc, _ = scenefile.build(scenefile.preset_doc("comet"))
    back, _ = scenefile.loads(scenefile.dumps(sc))
    a, b = initial_state(sc), initial_state(back)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities, b.velocities)


# --- one door: Python, files and the CLI meet the same checks ---------------------------------
@pytest.mark.parametrize("changes, field", [
    (dict(drag=-1.0), "drag"), (dict(drag=0.5), "drag"),
    (dict(planes=(((0.0, 0.0), (0.0, 1.0), 1.0),)), "planes"),
    (dict(dt=1e-12), "dt"), (dict(softening=1e-9), "softening"), (dict(wall_restitution=0.5), "wall_restitution"),
])
def test_step_options_given_to_the_event_engine_are_refused_not_ignored(changes, field):
    """Scene(..., drag=-1) built in Python used to pass and be silently ignored by the event engine."""
    sc = Scene(dim=2, length=1e-7, duration=1e-10, components=((BUILTIN["Ar"], 10),), seed=1, engine="event",
               **changes)
    with pytest.raises(SceneError, match=rf"^{field} .*applies to engine step only"):
        validate(sc)


@pytest.mark.parametrize("changes, words", [
    (dict(drag=-1.0), "drag -1.0 is outside [0, inf)"),
    (dict(wall_restitution=1.5), "wall_restitution 1.5 is outside [0, 1]"),
    (dict(dt=1.0), "dt 1 s is longer than duration"),
    (dict(planes=(((0.0, 0.0), (0.0, 0.0), 1.0),)), "zero normal"),
    (dict(planes=(((0.0,), (1.0,), 1.0),)), "needs 2 coordinates"),
    (dict(print_every=-3), "print_every -3"),
    (dict(boundary="periodic"), "hard walls only"),
])
def test_step_options_out_of_range_name_field_value_and_range(changes, words):
    sc = Scene(dim=2, length=1e-7, duration=1e-10, components=((BUILTIN["Ar"], 10),), seed=1, engine="step",
               dt=1e-12)
    with pytest.raises(SceneError) as info:
        validate(replace(sc, **changes))
    assert words in str(info.value)


def test_the_library_names_fields_and_the_cli_its_flags(tmp_path):
    """One message, three voices: Python (field), the CLI (flag), a scene file (key, with the file)."""
    sc = Scene(dim=2, length=1e-7, duration=1e-10, components=((BUILTIN["Ar"], 10),), seed=1,
               pair_gravity=1.0, engine="event")
    with pytest.raises(SceneError, match=r"^pair_gravity 1.0 applies to engine step only"):
        validate(sc)
    code, out, err = invoke(["simulate", "--dim", "2", "--n", "10", "--length", "1e-7", "--duration", "1e-10",
                             "--engine", "event", "--pair-gravity", "1", "--no-db"])
    assert code == 1 and err.strip() == ("gaz: error: --pair-gravity 1.0 applies to --engine step only (the event "
                                         "engine would ignore it); set --engine step, or drop --pair-gravity")
    path = tmp_path / "s.toml"
    path.write_text(scenefile.dumps(Scene(dim=2, length=1e-7, duration=1e-10,
                                          components=((BUILTIN["Ar"], 10),), seed=1, engine="event")) + "")
    text = path.read_text().replace("record = ", "pair_gravity = 1.0\nrecord = ")
    path.write_text(text)
    code, out, err = invoke(["simulate", str(path), "--no-db"])
    assert code == 1 and err.startswith(f"gaz: error: {path}: pair_gravity 1.0 applies to engine step only")


def assert_refused_in_one_line(path, text, words):
    """The scene file ``text`` written at ``path`` is refused: exit 1, one line on stderr
    holding each of ``words``, nothing on stdout."""
    path.write_text(text)
    code, out, err = invoke(["simulate", str(path), "--no-db"])
    lines = err.strip().splitlines()
    assert code == 1 and len(lines) == 1 and out == "", err
    for w in words:
        assert w in lines[0], lines[0]


@pytest.mark.parametrize("line, words", [
    ("colour = 3", ["unknown key 'colour'", "= 3", "allowed: dim"]),
    ("lenght = 1e-8", ["unknown key 'lenght'", "did you mean 'length'?", "allowed: dim"]),  # a typo
    ('dim = "two"', ["dim = 'two'", "whole number"]),
    ("length = -1.0", ["length must be a positive number, got -1.0"]),
    ("temperature = 1e300", ["temperature 1e+300 K is above the range"]),
    ('boundary = "sphere"', ["boundary 'sphere' is not one of walls, periodic"]),
    ("restitution = 2.0", ["restitution 2.0 is outside [0, 1]"]),
    ("dim = 3\ndim = 2", ["not valid TOML"]),
])
def test_a_bad_scene_file_is_one_line_naming_key_value_and_range(tmp_path, line, words):
    path = tmp_path / "bad.toml"
    good = "dim = 2\nduration = 1e-10\nlength = 1e-7\nseed = 1\n"
    keys = {ln.split(" =")[0] for ln in line.splitlines()}
    body = "".join(ln + "\n" for ln in good.splitlines() if ln.split(" =")[0] not in keys)
    assert_refused_in_one_line(path, f"{line}\n{body}\n[[species]]\nname = \"Ar\"\ncount = 10\n", words)


@pytest.mark.parametrize("table, words", [
    ('[[specie]]\nname = "Ar"\ncount = 10\n', ["unknown key 'specie'", "did you mean 'species'?"]),
    ('[outptu]\ndb = "x.db"\n[[species]]\nname = "Ar"\ncount = 10\n', ["did you mean 'output'?"]),
])
def test_a_misspelt_table_is_told_the_table_s_name(tmp_path, table, words):
    """A misspelt table header, [[specie]], was told "did you mean 'seed'?" and listed only the
    top-level keys, so neither the hint nor the list named [[species]] or [output]."""
    path = tmp_path / "typo.toml"
    assert_refused_in_one_line(path, "dim = 2\nduration = 1e-10\nlength = 1e-7\n" + table,
                               [*words, "tables: [[species]], [[planes]], [initial], [search], [output]"])


def test_an_unknown_species_in_a_file_names_the_file_and_the_file_s_fix(tmp_path):
    """It said "unknown species 'Zz'; known: ... (or give --radius and --mass)": neither the file
    nor its keys (also in each failed run of a gaz sweep over that file)."""
    path = tmp_path / "zz.toml"
    assert_refused_in_one_line(path, 'dim = 2\nduration = 1e-10\nlength = 1e-7\n[[species]]\nname = "Ar"\n'
                                     'count = 5\n[[species]]\nname = "Zz"\ncount = 5\n',
                               [f"gaz: error: {path}: species[1]: unknown species 'Zz'; built in: He, Ne, Ar",
                                "give it mass (kg) and radius (m)"])
    code, out, err = invoke(["simulate", str(path), "--no-db"])
    assert "--radius" not in err


def test_a_count_of_zero_in_a_file_names_the_species_count_and_the_flag_stays_n(tmp_path):
    """count = 0 in a file said "n must be at least 1, got 0": a file has no key n (nor does a
    gaz sweep over it with --vary count=0); it names the [[species]] count now, the species
    too in a mixture. From the command line, --n 0 still says --n."""
    head = 'dim = 2\nduration = 1e-10\nlength = 1e-7\n[[species]]\nname = "Ar"\ncount = {}\n'
    one, two = tmp_path / "one.toml", tmp_path / "two.toml"
    assert_refused_in_one_line(one, head.format(0), [f"{one}: [[species]] count must be at least 1, got 0"])
    assert_refused_in_one_line(two, head.format(5) + '[[species]]\nname = "He"\ncount = 0\n',
                               [f"{two}: the [[species]] count of He must be at least 1, got 0"])
    for args in (["simulate", str(one), "--n", "0"], ["simulate", "--dim", "2", "--n", "0", "--length", "1e-7",
                                                      "--duration", "1e-10"]):
        code, out, err = invoke([*args, "--no-db"])
        assert code == 1 and err.strip().endswith("--n must be at least 1, got 0"), err


def test_an_unknown_key_with_a_huge_value_is_one_short_line(tmp_path):
    """An unknown key holding 200,000 numbers was echoed whole: one line of 1.2 MB on stderr."""
    path = tmp_path / "huge.toml"
    body = "dim = 2\nduration = 1e-10\nlength = 1e-7\nx = [" + ", ".join(["1.0"] * 200_000) + "]\n"
    assert_refused_in_one_line(path, body + '[[species]]\nname = "Ar"\ncount = 10\n',
                               ["unknown key 'x' (= [1.0, 1.0", "...", "allowed: dim"])
    code, out, err = invoke(["simulate", str(path), "--no-db"])
    assert len(err) < 1000, len(err)


CUSTOM = ('dim = 2\nduration = 1e-11\nlength = 1e-7\nseed = 1\n'
          '[[species]]\nname = {}\ncount = 5\nmass = 1e-25\nradius = 1e-10\n')


@pytest.mark.parametrize("name, words", [
    ('""', ["species name '' is empty"]),
    ('"   "', ["species name '   ' is empty"]),
    ('"' + "x" * 65 + '"', ["has 65 characters, more than the 64", "PA_NOM"]),
    ('"a\\u0000b"', ["control character"]),
    ('"two\\nlines"', ["control character"]),
])
def test_a_species_name_the_database_cannot_hold_is_refused_at_the_door(tmp_path, name, words):
    """Such names were run and stored in SQLite; PostgreSQL refused them when the run was over
    ('value too long for type character varying(64)', 'cannot contain NUL (0x00) bytes')."""
    path, db = tmp_path / "named.toml", tmp_path / "gaz.db"
    path.write_text(CUSTOM.format(name))
    code, out, err = invoke(["simulate", str(path), "--db", str(db)])
    assert code == 1 and out == "" and len(err.splitlines()) == 1, err
    assert err.startswith(f"gaz: error: {path}: species name ")
    for w in words:
        assert w in err, err
    assert not db.exists()


@pytest.mark.parametrize("backend", BACKENDS, indirect=True)
def test_species_names_up_to_64_characters_any_script_are_stored_as_given(backend, tmp_path):
    from gaz_cli.results import store as st

    names = ["x" * 64, "Argon \u2603 \u6c29", "a;b=c'd\"e"]  # ',' and ':' are refused (mixtures)
    path = tmp_path / "named.toml"
    for seed, name in enumerate(names, 1):
        path.write_text(CUSTOM.format(json.dumps(name)).replace("seed = 1", f"seed = {seed}"), encoding="utf-8")
        code, out, err = invoke(["simulate", str(path), "--db", backend])
        assert code == 0, err
    with st.Store(backend, create=False) as store:
        stored = store.read_sql("SELECT PA_NOM FROM PARTICULE WHERE PA_NUM > 10 ORDER BY PA_NUM")
    assert list(stored.iloc[:, 0]) == names


# --- presets ----------------------------------------------------------------------------------
def test_a_preset_refuses_flags_its_state_depends_on_in_one_line():
    """`--preset marbles --n 10 --dim 2` ran 300 marbles in 3D, silently."""
    code, out, err = invoke(["simulate", "--preset", "marbles", "--n", "10", "--dim", "2", "--no-db"])
    assert code == 1 and out == "" and len(err.strip().splitlines()) == 1
    assert "--preset marbles sets --dim itself" in err
    code, out, err = invoke(["simulate", "--preset", "marbles", "--temperature", "500", "--no-db"])
    assert code == 1 and "--preset marbles sets --temperature itself" in err  # it would be ignored


def test_gaz_scene_of_a_simulation_without_a_scene_row_says_so(tmp_path):
    """A SIMULATION row with no SCENE row (written by other software, as the exam's INSERTs would)
    was "no simulation 1 in 'gaz.db'" though gaz analyse --sim 1 analysed it."""
    db = tmp_path / "gaz.db"
    assert invoke(["simulate", "--dim", "2", "--n", "5", "--length", "1e-7", "--duration", "1e-11",
                   "--seed", "1", "--db", str(db)]).exit_code == 0
    with sqlite3.connect(db) as conn:
        conn.execute("DELETE FROM SCENE WHERE SI_NUM = 1")
    conn.close()
    code, out, err = invoke(["scene", "1", "--db", str(db)])
    assert (code, out) == (1, "") and len(err.splitlines()) == 1
    assert err.startswith("gaz: error: simulation 1 was stored without its scene file"), err
    code, out, err = invoke(["scene", "2", "--db", str(db)])
    assert code == 1 and err == f"gaz: error: no simulation 2 in '{db}'; gaz analyse --db {db} lists them\n"


def test_a_custom_species_stored_under_a_built_in_name_is_renamed_by_gaz_scene_and_reruns(tmp_path):
    """A database of a gaz older than the built-in name check may hold a custom species named
    'Ar' with other values; gaz scene printed its file as stored, which gaz simulate now refuses
    ("species name 'Ar' is the built-in Ar ..."). Now gaz scene renames it 'Ar-custom' (said in
    the file and in one warning line): the file runs, to the same REBOND rows."""
    db, again, scene_file = tmp_path / "old.db", tmp_path / "new.db", tmp_path / "again.toml"
    code, out, err = invoke(["simulate", "--dim", "2", "--n", "10", "--radius", "2e-10", "--mass", "7e-26",
                             "--length", "1e-7", "--duration", "1e-9", "--seed", "1", "--db", str(db)])
    assert code == 0, err
    with sqlite3.connect(db) as conn:  # what an older gaz stored: the custom species named Ar
        conn.execute("""UPDATE SCENE SET SC_FILE = replace(SC_FILE, 'name = "custom"', 'name = "Ar"')""")
        conn.execute("UPDATE PARTICULE SET PA_NOM = 'Ar' WHERE PA_NOM = 'custom'")
    conn.close()
    code, out, err = invoke(["scene", "1", "--db", str(db)])
    assert code == 0 and err.splitlines() == [
        "gaz: warning: species 'Ar' (mass 7e-26 kg, radius 2e-10 m) renamed 'Ar-custom': a custom species may "
        "no longer bear a built-in name (the run is the same)"], err
    assert "renamed 'Ar-custom': stored by an older gaz under a built-in name" in out.splitlines()[1]
    scene_file.write_text(out)
    scene, _ = scenefile.load(scene_file)
    assert scene.species == [Species("Ar-custom", 7e-26, 2e-10)] and scene.seed == 1
    code, out, err = invoke(["simulate", str(scene_file), "--db", str(again)])
    assert code == 0, err
    assert len(_rows(db)) > 10 and _rows(db) == _rows(again)


def test_a_preset_with_a_seed_is_placed_with_it_and_reruns_from_the_database(tmp_path):
    """--preset marbles --seed 5: placed with seed 5 (the seed SCENE records); `gaz scene` prints a
    file that runs again to the same REBOND rows, bit for bit."""
    db, again = tmp_path / "a.db", tmp_path / "b.db"
    args = ["--preset", "marbles", "--n", "30", "--duration", "0.05", "--print-every", "0"]
    code, out, err = invoke(["simulate", *args, "--seed", "5", "--db", str(db), "--json"])
    assert code == 0, err
    assert json.loads(out)["seed"] == 5
    scene_file = tmp_path / "again.toml"
    code, out, err = invoke(["scene", "1", "--db", str(db)])
    assert code == 0, err
    scene_file.write_text(out)
    stored, _ = scenefile.load(scene_file)
    assert stored.seed == 5 and stored.n == 30 and stored.initial["kind"] == "upper-half"
    made, _ = scenefile.build({**scenefile.preset_doc("marbles"), "seed": 5, "duration": 0.05, "print_every": 0,
                               "species": [{**scenefile.preset_doc("marbles")["species"][0], "count": 30}]})
    assert np.array_equal(initial_state(stored).positions, initial_state(made).positions)
    code, out, err = invoke(["simulate", str(scene_file), "--db", str(again)])
    assert code == 0, err
    first = _rows(db)
    assert len(first) > 5 and first == _rows(again)


def test_a_stored_event_run_reruns_to_the_same_rows_and_write_scene_agrees(tmp_path):
    db, again, written = tmp_path / "a.db", tmp_path / "b.db", tmp_path / "w.toml"
    code, out, err = invoke(["simulate", "--dim", "2", "--species", "Ar:20,He:10", "--length", "1e-7",
                             "--duration", "3e-10", "--restitution", "0.8", "--db", str(db),
                             "--write-scene", str(written)])
    assert code == 0, err
    code, stored, err = invoke(["scene", "1", "--db", str(db)])
    assert code == 0 and stored == written.read_text()
    assert scenefile.loads(stored)[0].tc > 0  # the default tc was computed and is stored
    code, out, err = invoke(["simulate", str(written), "--db", str(again)])
    assert code == 0, err
    assert len(_rows(db)) > 10 and _rows(db) == _rows(again)


def test_a_run_given_its_search_is_stored_with_it_and_reruns_to_the_same_rows(tmp_path):
    """Every search is exact but rounds its own way, and a gas is chaotic: the same seed with
    cells and with the dilute scan (what 'auto' picks for this gas) gives other REBOND rows.
    The scene file stored with a run (SCENE.SC_FILE) names the search it was given
    ([search]), not what was derived (engine_reason), and runs again to its rows."""
    from gaz_cli import api

    keys = dict(dim=2, length=1.0, duration=1.0, temperature=1.0 / 1.380649e-23, seed=5,
                engine="event")
    species = [{"name": "X", "count": 200, "mass": 1.0, "radius": 0.005}]
    cells = api.make_scene(species=species, search={"neighbours": "cells", "skin": 0.5}, **keys)
    assert cells.extras["neighbours"] == "cells" and cells.extras["skin"] == 0.5
    db, again, auto = tmp_path / "a.db", tmp_path / "b.db", tmp_path / "c.db"
    assert not api.simulate(cells, db=str(db)).stats.extras["dilute_scan"]
    assert api.simulate(api.make_scene(species=species, **keys), db=str(auto)).stats.extras["dilute_scan"]
    code, stored, err = invoke(["scene", "1", "--db", str(db)])
    assert code == 0, err
    assert '[search]\nneighbours = "cells"\nclasses = "off"\nskin = 0.5\n' in stored  # one grid: resolved
    assert "engine_reason" not in stored
    (tmp_path / "run.toml").write_text(stored)
    code, out, err = invoke(["simulate", str(tmp_path / "run.toml"), "--db", str(again)])
    assert code == 0, err
    assert len(_rows(db)) > 100 and _rows(db) == _rows(again)
    assert _rows(db) != _rows(auto)  # the search the file names matters


def test_a_run_left_on_auto_stores_the_search_it_took_and_reruns_to_its_rows_under_another_cost_model(
        tmp_path, monkeypatch):
    """A run left on 'auto' stores the search it took ([search]: what the driver resolved),
    not 'auto': a later gaz whose cost model (sizing) chooses otherwise reruns the stored
    scene file to the same rows, while a new run on 'auto' takes the other search."""
    from gaz_cli import api
    from gaz_cli.engines.event import sizing
    from gaz_cli.results.queries import stored_scene_file

    keys = dict(dim=2, length=1.0, duration=1.0, temperature=1.0 / 1.380649e-23, seed=5,
                engine="event")
    species = [{"name": "X", "count": 200, "mass": 1.0, "radius": 0.005}]
    db, again, other = tmp_path / "a.db", tmp_path / "b.db", tmp_path / "c.db"
    assert api.simulate(api.make_scene(species=species, **keys), db=str(db)).stats.extras["dilute_scan"]
    stored = stored_scene_file(str(db), 1)
    assert '[search]\nneighbours = "dilute"\nclasses = "off"\n' in stored, stored
    # a refitted cost model: cells (the wide cells' float32 pass keeps the dilute scan's exact
    # roots, hence its rows, so it is refused too)
    monkeypatch.setattr(sizing, "dilute_scan_pays", lambda *args: False)
    monkeypatch.setattr(sizing, "use_wide_cells", lambda *args: False)
    assert not api.simulate(api.make_scene(species=species, **keys), db=str(other)).stats.extras["dilute_scan"]
    (tmp_path / "run.toml").write_text(stored)
    code, out, err = invoke(["simulate", str(tmp_path / "run.toml"), "--db", str(again), "--json"])
    assert code == 0, err
    assert json.loads(out)["dilute_scan"]
    assert len(_rows(db)) > 100 and _rows(db) == _rows(again)
    assert _rows(db) != _rows(other)  # the cost model's choice would have changed the rows


def test_a_search_given_explicitly_is_kept_and_the_skin_of_lists_stored():
    from gaz_cli.engines.event import sizing
    from gaz_cli.run.runner import prepare

    base = Scene(dim=3, components=((BUILTIN["Ar"], 400),), length=3.0e-9, duration=1e-13,
                 boundary="periodic", engine="event", seed=1, force=True)
    assert base.packing_fraction > sizing.NEIGHBOUR_LIST_FROM[3]
    search = ("neighbours", "classes", "skin")
    dense = prepare(base)  # 'auto': lists, one grid, the default skin
    assert {k: dense.extras.get(k) for k in search} == {
        "neighbours": "lists", "classes": "off", "skin": sizing.NEIGHBOUR_SKIN}
    given = prepare(replace(base, extras={"neighbours": "lists", "skin": 0.5}))
    assert {k: given.extras.get(k) for k in search} == {"neighbours": "lists", "classes": "off", "skin": 0.5}
    cells = prepare(replace(base, extras={"neighbours": "cells"}))
    assert {k: cells.extras.get(k) for k in search} == {"neighbours": "cells", "classes": "off", "skin": None}
    assert not set(search) & set(prepare(replace(base, dim=1, length=1e-6)).extras)  # no search in 1D


@pytest.mark.parametrize("line, words", [
    ('neighbours = "octree"', ["neighbours 'octree' is not one of auto, cells, lists, dilute"]),
    ("skin = -0.5", ["skin -0.5 must be a positive number"]),
    ('classes = "on"', ["classes 'on' is not one of auto, off"]),
    ('kd = "tree"', ["search: unknown key 'kd'", "allowed: neighbours, classes, skin"]),
    ("skin = \"wide\"", ["search: skin = 'wide' must be a number"]),
    ('engine = "step"', ["search: unknown key 'engine' (= 'step')", "allowed: neighbours, classes, skin"]),
])
def test_a_bad_search_is_one_line_naming_key_value_and_choices(tmp_path, line, words):
    assert_refused_in_one_line(tmp_path / "bad.toml", "dim = 2\nduration = 1e-10\nlength = 1e-7\n\n[[species]]\n"
                          f"name = \"Ar\"\ncount = 10\n\n[search]\n{line}\n", words)


@pytest.mark.parametrize("top", ['engine = "step"\ndt = 1e-14', 'engine = "reference"',
                                 "drag = 0.5"])
def test_a_search_given_to_an_engine_that_does_not_search_is_refused(tmp_path, top):
    """[search] neighbours = "lists" with engine = "step" (or reference, or drag, which takes the
    step engine) ran, exit 0, the search ignored in silence; now one line naming the table, the
    key and the engine it applies to. Left on auto, a scene with a search takes the event engine
    (a tiny run went to the reference engine and ignored it too)."""
    path = tmp_path / "bad.toml"
    assert_refused_in_one_line(path, f"dim = 2\nduration = 1e-11\nlength = 1e-7\n{top}\n\n[[species]]\n"
                               'name = "Ar"\ncount = 2\n\n[search]\nneighbours = "lists"\n',
                               ["[search] neighbours 'lists' applies to engine event only", "set engine event"])
    path.write_text(path.read_text().replace(top, ""))
    code, out, err = invoke(["simulate", str(path), "--no-db", "--json"])
    assert code == 0, err
    assert json.loads(out)["engine"] == "event" and json.loads(out)["neighbour_lists"]


@pytest.mark.parametrize("top, search, words, count, length", [
    ('boundary = "periodic"', "dilute", ["neighbours 'dilute' searches a box with walls",
                                         "is periodic", "use 'auto', 'cells' or 'lists'"], 10, 1e-7),
    ("gravity = 9.81", "dilute", ["neighbours 'dilute' searches a box with walls", "is under gravity"],
     10, 1e-7),
    ("gravity = 9.81", "wide", ["neighbours 'wide' searches straight flights", "is under gravity"],
     10, 1e-7),
    # 2.5 diameters: fewer than 3 cells an axis, a cell would be scanned through two images
    ('boundary = "periodic"', "wide", ["neighbours 'wide' needs a periodic box 3 particle diameters",
                                       "this one is 2.51", "raise length"], 2, 9e-10),
])
def test_a_straight_search_forced_where_it_cannot_run_is_refused(tmp_path, top, search, words,
                                                                 count, length):
    """The dilute scan and wide cells bound a straight flight up to its horizon (a wall bounce;
    for wide cells in a periodic box, a wrap): forced under gravity, or the dilute scan on a
    periodic box, or wide cells on a periodic box too narrow for 3 cells an axis, they would
    give way to cells in silence."""
    path = tmp_path / "bad.toml"
    assert_refused_in_one_line(path, f"dim = 2\nduration = 1e-10\nlength = {length}\n{top}\n\n"
                               f"[[species]]\nname = \"Ar\"\ncount = {count}\n\n[search]\n"
                               f"neighbours = \"{search}\"\n", words)
    path.write_text(path.read_text().replace(top, ""))  # the same search with walls runs
    code, out, err = invoke(["simulate", str(path), "--no-db"])
    assert code == 0, err


def test_a_bad_search_is_refused_at_the_one_door_with_the_cli_message():
    """scene.validate alone checks the search (the driver's sizing no longer repeats it): a
    Python caller gets the line the CLI prints."""
    scene = Scene(dim=2, components=((BUILTIN["Ar"], 10),), length=1e-7, duration=1e-10,
                  extras={"neighbours": "octree"})
    with pytest.raises(SceneError, match="neighbours 'octree' is not one of auto, cells, lists, dilute"):
        validate(scene)


def test_flags_override_a_scene_file(tmp_path):
    code, out, err = invoke(["simulate", str(EXAMPLES / "mixture.toml"), "--duration", "1e-11",
                             "--temperature", "600", "--seed", "9", "--no-db", "--write-scene",
                             str(tmp_path / "w.toml")])
    assert code == 0, err
    sc, _ = scenefile.load(tmp_path / "w.toml")
    assert (sc.duration, sc.temperature, sc.seed, sc.n) == (1e-11, 600.0, 9, 1000)


# --- the examples -----------------------------------------------------------------------------
EXAMPLE_RUNS = {
    # name: (flags making it short, check on the summary)
    "exam": (["--duration", "2e-11"], lambda s: s["wall_bounces"] > 0 and s["dim"] == 3 and s["n"] == 1000),
    "periodic_fluid": (["--duration", "2e-13"], lambda s: abs(s["packing_fraction"] - 0.30) < 1e-12
                       and s["collisions"] > 0),
    "mixture": (["--duration", "2e-11"], lambda s: s["n"] == 1000 and s["events"] > 0),
    "isotherm_2d": (["--duration", "1e-11"], lambda s: abs(s["packing_fraction"] - 0.30) < 1e-12
                    and s["collisions"] > 0),
    "marbles": (["--duration", "0.02", "--n", "20", "--print-every", "0"],
                lambda s: s["kinetic_energy_end"] < s["kinetic_energy_start"] + 20 * 5.36e-3 * 9.81 * 0.5),
    "comet": (["--duration", "6000", "--print-every", "0"], lambda s: s["n"] == 2 and s["collisions"] == 0),
}


@pytest.mark.parametrize("name", sorted(EXAMPLE_RUNS))
def test_every_example_runs(name, tmp_path):
    """Each example runs (shortened); elastic event-engine runs keep their kinetic energy to round-off."""
    flags, ok = EXAMPLE_RUNS[name]
    code, out, err = invoke(["simulate", str(EXAMPLES / f"{name}.toml"), *flags, "--seed", "1",
                             "--db", str(tmp_path / "x.db"), "--json"])
    assert code == 0, err
    summary = json.loads(out)
    assert ok(summary), summary
    if summary["engine"] == "event":  # elastic: each collision conserves energy to ~1e-16 relative
        ks, ke = summary["kinetic_energy_start"], summary["kinetic_energy_end"]
        assert abs(ke - ks) / ks < 1e-10 * max(1, summary["events"]) ** 0.5


def test_every_example_is_tested_and_the_presets_are_the_examples():
    assert {p.stem for p in EXAMPLES.glob("*.toml")} == set(EXAMPLE_RUNS)
    for name in scenefile.presets():
        assert scenefile.load(EXAMPLES / f"{name}.toml")[0] == scenefile.build(scenefile.preset_doc(name))[0]


def test_packing_is_a_flag_as_it_is_a_key():
    """`packing` was a scene file's key but no flag (`gaz simulate --packing 0.3` said: No such
    option). The flag sets the box side from the packing fraction as the key does: the same
    packing to the round-off of a cube root (a few ulps), the same box as the key's; one line
    for both --length and --packing, and a packing past the densest one names --packing."""
    code, out, err = invoke(["simulate", "--dim", "3", "--n", "200", "--packing", "0.2", "--duration", "1e-13",
                             "--no-db", "--json", "--seed", "3"])
    assert code == 0, err
    flagged = json.loads(out)
    assert flagged["packing_fraction"] == pytest.approx(0.2, rel=1e-14)
    doc = {"dim": 3, "packing": 0.2, "duration": 1e-13, "seed": 3, "species": [{"name": "Ar", "count": 200}]}
    scene, _ = scenefile.build(doc)
    assert scene.length == flagged["length"]
    for args, words in [(["--length", "1e-8"], ["give --length or --packing, not both"]),
                        (["--packing", "0.8"], ["--packing 0.8 is at or above 0.7405", "lower --packing"])]:
        base = ["simulate", "--dim", "3", "--n", "200", "--duration", "1e-13", "--no-db"]
        code, out, err = invoke(base + (["--packing", "0.2"] if "--length" in args else []) + args)
        assert (code, out, len(err.splitlines())) == (1, "", 1), (code, out, err)
        for w in words:
            assert w in err, err
