"""The command line driven end to end through click's CliRunner."""

import json
import sqlite3

import numpy as np
import pandas as pd
import pytest
from cli_helpers import invoke

ARGON_3D = ["--dim", "3", "--n", "60", "--length", "2e-8", "--duration", "2e-10", "--seed", "7"]


@pytest.fixture
def db(tmp_path):
    return str(tmp_path / "gaz.db")


@pytest.mark.parametrize("engine", ["reference", "event"])
def test_simulate_then_analyse(db, engine):
    res = invoke(["simulate", *ARGON_3D, "--db", db, "--json", "--engine", engine])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    for key in ("si_num", "engine", "events", "wall_bounces", "collisions", "kinetic_energy_start",
                "kinetic_energy_end", "pressure", "wall_time_s", "events_per_second"):
        assert key in summary
    assert summary["engine"] == engine
    assert summary["kinetic_energy_end"] == pytest.approx(summary["kinetic_energy_start"], rel=1e-9, abs=0)
    rows = sqlite3.connect(db).execute("SELECT COUNT(*) FROM REBOND WHERE SI_NUM = ?",
                                       (summary["si_num"],)).fetchone()[0]
    assert rows == summary["wall_bounces"] > 0
    res = invoke(["analyse", "--db", db, "--format", "json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert set(out) >= {"Q34 simulations per dimension", "pressure against the ideal gas"}


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("engine", ["auto", "event"])
def test_one_particle_in_a_periodic_box(db, dim, engine):
    """No wall, no collision: the particle keeps its momentum (removing it would stop it), so its
    kinetic temperature counts D degrees of freedom and the pressure is 2K/(D L^D). The run used
    to end after the engine in 'kinetic temperature needs at least 2 particle(s), got 1', exit 1."""
    res = invoke(["simulate", "--dim", str(dim), "--n", "1", "--boundary", "periodic", "--length", "3.4e-8",
                  "--duration", "1e-9", "--seed", "3", "--engine", engine, "--db", db, "--json"])
    assert res.exit_code == 0 and res.stderr == "", res.output
    summary = json.loads(res.stdout)
    assert summary["events"] == summary["wall_bounces"] == summary["collisions"] == 0
    ke = summary["kinetic_energy_start"]
    assert ke > 0 and summary["kinetic_energy_end"] == pytest.approx(ke, rel=1e-12)
    assert summary["pressure"] == pytest.approx(2 * ke / (dim * 3.4e-8 ** dim), rel=1e-12)
    res = invoke(["analyse", "--db", db, "--format", "json"])
    assert res.exit_code == 0, res.output
    row, = json.loads(res.stdout)["pressure against the ideal gas"]
    assert row["P_MEASURED"] == pytest.approx(summary["pressure"], rel=1e-12)
    assert row["T_KIN_K"] == pytest.approx(2 * ke / (dim * 1.380649e-23), rel=1e-12)


@pytest.mark.parametrize("command", [
    ["simulate", "--dim", "2", "--n", "10", "--length", "1e-7", "--duration", "1e-11"],
    ["simulate", "{tmp}/out.toml"],
    ["analyse"], ["query", "q34"], ["scene", "1"],
    ["sweep", "{tmp}/s.toml", "--vary", "temperature=100,200", "--quiet"],
])
@pytest.mark.parametrize("db", ["", "  "])
def test_an_empty_db_is_refused(tmp_path, monkeypatch, command, db):
    """gaz simulate --db '' wrote gaz.db in the current folder, exit 0 (an empty --db read as
    none given); analyse and query said "database '' does not exist; run 'gaz simulate --db '
    first", sweep "cannot open database ''". Now one line naming --db, and no file written. A
    scene file's [output] db = "" likewise."""
    monkeypatch.chdir(tmp_path)
    scene = 'dim = 2\nlength = 1e-7\nduration = 1e-11\n{}[[species]]\nname = "Ar"\ncount = 10\n'
    (tmp_path / "s.toml").write_text(scene.format(""))
    (tmp_path / "out.toml").write_text(scene.format(f'[output]\ndb = "{db}"\n'))
    files = sorted(tmp_path.iterdir())
    argv = [a.replace("{tmp}", str(tmp_path)) for a in command]
    res = invoke(argv if argv[-1].endswith("out.toml") else [*argv, "--db", db])
    lines = res.stderr.splitlines()
    assert res.exit_code in (1, 2) and len(lines) == 1 and res.stdout == "", res.output
    assert ("--db" in lines[0] and "names no database" in lines[0]) or "output: db = " in lines[0], lines[0]
    assert sorted(tmp_path.iterdir()) == files


@pytest.mark.parametrize("command", [
    ["simulate", "--dim", "2", "--n", "10", "--length", "1e-7", "--duration", "1e-11"],
    ["analyse"], ["query", "q34"], ["scene", "1"],
])
def test_a_db_that_is_a_folder_is_refused(tmp_path, monkeypatch, command):
    """--db adir, an existing folder: analyse, query and scene said "database 'adir' does not
    exist; run 'gaz simulate --db adir' first", simulate "cannot open ... check that its folder
    exists and is writable". Now one line saying it is a folder, naming a file inside it."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "adir").mkdir()
    res = invoke([*command, "--db", "adir"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1 and res.stdout == "", res.output
    assert "'adir' is a folder" in lines[0] and "adir/gaz.db" in lines[0], lines[0]
    assert list((tmp_path / "adir").iterdir()) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["adir"]


@pytest.mark.parametrize("length, narrow", [("3.6e-10", True), ("3.9e-10", True), ("4e-10", False),
                                           ("1e-6", False)])
def test_a_run_refused_for_its_work_in_a_narrow_box_says_to_raise_length(tmp_path, length, narrow):
    """One argon atom (diameter 3.58e-10 m) in a box 2e-12 m wider than it, for 1e-2 s, was
    refused with "lower --duration, --n, --temperature": the bounces come L / (L - 2R) = 180
    times as often as a point's, and a box a little longer is the fix. Now that is said when a
    centre has under 10 % of the box's side to move in (3.6e-10: 0.56 %, 3.9e-10: 8.2 %), not
    otherwise (4e-10: 10.5 %; 1e-6 m, refused for 1e6 s). Each run is 1 s unless said."""
    duration = "1" if length != "1e-6" else "1e6"
    res = invoke(["simulate", "--dim", "1", "--n", "1", "--length", length, "--duration", duration,
                  "--seed", "1", "--record", "none", "--db", str(tmp_path / "gaz.db")])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1 and "--force" in lines[0], res.output
    assert "lower --duration, --n, --temperature" in lines[0], lines[0]
    assert ("or raise --length" in lines[0]) == narrow, lines[0]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("mass, radius, name, refused", [
    ("1e-25", "1e-10", "Ar", True), ("1e-25", "1e-10", "argon", True),
    ("6.633853573359518e-26", "1.79e-10", "Ar", False),  # the built-in Ar's own values
    ("1e-25", "1e-10", "Ar-heavy", False)])
def test_a_custom_species_may_not_take_a_builtin_name(tmp_path, mass, radius, name, refused):
    """A scene file's [[species]] name = "Ar" with a mass and radius of its own was stored as a
    second PARTICULE row named Ar, so a query by name no longer told the two apart. Now refused
    in one line naming the fix (another name), nothing written; the built-in values, or another
    name, run, and PARTICULE keeps one row per name."""
    scene = tmp_path / "s.toml"
    scene.write_text(f'dim = 2\nlength = 1e-7\nduration = 1e-11\nseed = 1\n[[species]]\nname = "{name}"\n'
                     f"count = 5\nmass = {mass}\nradius = {radius}\n")
    db = tmp_path / "gaz.db"
    res = invoke(["simulate", str(scene), "--db", str(db)])
    if refused:
        lines = res.stderr.splitlines()
        assert res.exit_code == 1 and len(lines) == 1 and res.stdout == "", res.output
        assert f"species name '{name}' is the built-in Ar" in lines[0] and "another name" in lines[0], lines[0]
        assert not db.exists()
        return
    assert res.exit_code == 0, res.output
    names = [r[0] for r in sqlite3.connect(db).execute("SELECT pa_nom FROM particule")]
    assert len(names) == len(set(names)) and name in names, names


@pytest.mark.parametrize("option, value, message", [
    ("--radius", "nan", "--radius nan is not a number; give a number > 0"),
    ("--length", "NaN", "--length nan is not a number; give a number > 0"),
    ("--radius", "inf", "--radius inf must be a finite number > 0"),
    ("--length", "-2", "--length -2 must be a finite number > 0"),
])
def test_place_names_the_option_of_a_value_not_a_positive_number(option, value, message):
    """gaz place --radius nan said "Invalid value for --radius: nan must be > 0", as if nan were
    a number below zero. Now the option, the value, and what it is."""
    args = {"--radius": "0.5", "--length": "5", option: value}
    res = invoke(["place", "--dim", "2", "--n", "3", *[x for kv in args.items() for x in kv]])
    lines = res.stderr.splitlines()
    assert res.exit_code == 2 and len(lines) == 1 and res.stdout == "", res.output
    assert lines[0].startswith(f"gaz place: error: {message} "), lines[0]


def test_same_seed_same_rows(tmp_path):
    frames = []
    for k in range(2):
        db = str(tmp_path / f"{k}.db")
        res = invoke(["simulate", "--dim", "2", "--n", "30", "--length", "1e-7", "--duration", "1e-10",
                      "--seed", "3", "--db", db])
        assert res.exit_code == 0, res.output
        frames.append(pd.read_sql("SELECT * FROM REBOND", sqlite3.connect(db)))
    assert len(frames[0]) > 0
    pd.testing.assert_frame_equal(frames[0], frames[1])


def test_save_state(tmp_path, db):
    path = tmp_path / "state.csv"
    res = invoke(["simulate", "--dim", "2", "--species", "Ar:10,He:5", "--length", "1e-7",
                  "--duration", "1e-11", "--seed", "1", "--db", db, "--save-state", str(path)])
    assert res.exit_code == 0, res.output
    state = pd.read_csv(path)
    assert list(state.columns) == ["species", "x", "y", "vx", "vy"]
    assert sorted(state.species.value_counts().items()) == [("Ar", 10), ("He", 5)]
    assert state[["x", "y"]].to_numpy().min() > 0 and state[["x", "y"]].to_numpy().max() < 1e-7


def test_place_csv_and_histogram(tmp_path):
    res = invoke(["place", "--dim", "2", "--n", "20", "--radius", "0.1", "--length", "5", "--seed", "4"])
    assert res.exit_code == 0, res.output
    lines = res.stdout.strip().splitlines()
    assert lines[0] == "x,y" and len(lines) == 21
    xy = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    d = np.linalg.norm(xy[:, None] - xy[None], axis=-1) + np.eye(20) * 10
    assert d.min() >= 0.2 and xy.min() >= 0.1 and xy.max() <= 4.9
    png = tmp_path / "q12.png"
    res = invoke(["place", "--dim", "1", "--n", "2", "--radius", "1", "--length", "10", "--repeat", "500",
                  "--bins", "10", "--seed", "1", "--histogram", str(png)])
    assert res.exit_code == 0, res.output
    table = pd.read_csv(__import__("io").StringIO(res.stdout))
    assert list(table.columns) == ["bin_start", "bin_end", "count"]
    assert table["count"].sum() == 1000 and table["count"].iloc[0] == 0  # no centre closer than R to 0
    assert png.stat().st_size > 1000


@pytest.mark.parametrize("args, needle", [
    (["place", "--dim", "1", "--n", "6", "--radius", "0.5", "--length", "5"], "cannot fit"),
    # one sphere as wide as the box was told "(packing fraction 0.524, densest 0.7405)", below the densest
    (["place", "--dim", "3", "--n", "1", "--radius", "5", "--length", "10"],
     "gaz: error: a particle of radius 5 m (diameter 10 m) does not fit in a box of side 10 m; lower --radius "
     "or raise --length"),
    (["place", "--dim", "2", "--n", "-3", "--radius", "0.5", "--length", "5"], "--n"),
    (["place", "--dim", "4", "--n", "3", "--radius", "0.5", "--length", "5"], "--dim"),
    (["place", "--dim", "2", "--n", "3", "--radius", "0", "--length", "5"], "--radius"),
    (["simulate", "--dim", "5", "--n", "3", "--length", "1e-7", "--duration", "1"], "--dim"),
    (["simulate", "--dim", "2", "--n", "0", "--length", "1e-7", "--duration", "1"], "--n"),
    (["simulate", "--dim", "2", "--n", "3", "--length", "-1", "--duration", "1"], "--length"),
    (["simulate", "--dim", "2", "--n", "3", "--length", "1e-7", "--duration", "0"], "--duration"),
    (["simulate", "--dim", "2", "--n", "3", "--length", "1e-7", "--duration", "1", "--species", "Zz"],
     "unknown species"),
    (["simulate", "--dim", "3", "--n", "100000", "--length", "1e-9", "--duration", "1"], "packing fraction"),
    (["simulate", "--dim", "2", "--n", "3", "--length", "1e-7", "--duration", "1", "--bogus"], "--bogus"),
    (["analyse", "--db", "/nonexistent/x.db"], "does not exist"),
])
def test_bad_input_one_line(args, needle):
    res = invoke(args)
    assert res.exit_code != 0
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert needle in err
    assert "Traceback" not in res.output


def test_analyse_errors(tmp_path, db):
    junk = tmp_path / "junk.db"
    junk.write_text("not a database at all")
    res = invoke(["analyse", "--db", str(junk)])
    assert res.exit_code != 0 and len(res.stderr.strip().splitlines()) == 1
    res = invoke(["simulate", "--dim", "1", "--n", "3", "--length", "1e-8", "--duration", "1e-11",
                  "--seed", "1", "--db", db])
    assert res.exit_code == 0, res.output
    res = invoke(["analyse", "--db", db, "--sim", "42"])
    assert res.exit_code != 0 and "simulation 42 is not in" in res.stderr
    # the figures table needs --plot: it said "(not this scene)" with --sim, "(needs --sim)" without
    for sim in (["--sim", "1"], []):
        res = invoke(["analyse", "--db", db, *sim, "--table", "figures"])
        assert res.exit_code == 1 and res.stderr.startswith("gaz: error: no table 'figures' for this "
                                                            "analysis (needs --plot DIR); it has: q34"), res.stderr


def test_json_output_is_strict_json(db):
    """A run without collisions printed "MEAN_FREE_TIME_S": NaN in gaz analyse --sim 1 --format
    json (a table of scalars): a token jq and JavaScript refuse, where --help promises null."""
    def strict(text):
        return json.loads(text, parse_constant=lambda token: pytest.fail(f"{token} in the JSON output"))

    assert invoke(["simulate", "--dim", "1", "--n", "3", "--length", "1e-7", "--duration", "1e-13",
                   "--seed", "1", "--db", db]).exit_code == 0
    for args in (["analyse", "--sim", "1"], ["analyse"], ["analyse", "--vs", "n"], ["query", "q35"]):
        res = invoke([*args, "--db", db, "--format", "json"])
        assert res.exit_code == 0, res.stderr
        strict(res.stdout)
    out = strict(invoke(["analyse", "--sim", "1", "--db", db, "--format", "json"]).stdout)
    assert out["simulation"]["MEAN_FREE_TIME_S"] is None


@pytest.mark.parametrize("fmt", ["table", "csv", "json"])
def test_analyse_formats(db, fmt):
    assert invoke(["simulate", "--dim", "2", "--n", "20", "--length", "1e-7", "--duration", "1e-10",
                   "--seed", "2", "--db", db]).exit_code == 0
    res = invoke(["analyse", "--db", db, "--sim", "1", "--format", fmt])
    assert res.exit_code == 0, res.output
    if fmt == "json":
        json.loads(res.stdout)
    assert "PRESSION" in res.stdout or "PRESSION" in json.dumps(json.loads(res.stdout) if fmt == "json" else {})


def test_help_teaches():
    for cmd in ([], ["place"], ["simulate"], ["analyse"]):
        res = invoke([*cmd, "--help"])
        assert res.exit_code == 0
        assert "Example" in res.stdout or "A first session" in res.stdout


def test_analyse_help_names_every_table_that_table_takes():
    """gaz analyse --help listed the --table names without 'contact', which --table accepts
    (a mixture's contact values per pair of species): a reader of the help could not find it."""
    from gaz_cli.analysis import report as analysis

    text = " ".join(invoke(["analyse", "--help"]).stdout.split())
    listed = text.split("NAME: ", 1)[1].split(".", 1)[0].split(", ")
    assert listed == list(analysis.TABLES)


@pytest.mark.parametrize("args, command", [
    (["simulate", "--dim", "3", "--db"], "gaz simulate"),     # --db given no value
    (["analyse", "--sim"], "gaz analyse"),
    (["query", "q36", "--param"], "gaz query"),
    (["simulate", "--no-db=1"], "gaz simulate"),             # a flag given a value
])
def test_an_option_missing_its_value_points_at_its_command_s_help(args, command):
    """'gaz simulate ... --db' said "gaz: error: Option '--db' requires an argument. (see 'gaz
    --help')": click gives that error no context, and gaz --help lists no --db."""
    code, out, err = invoke(args)
    assert code == 2 and out == ""
    assert err.startswith(f"{command}: error: Option '") and err.strip().endswith(f"(see '{command} --help')"), err
    assert len(err.strip().splitlines()) == 1


def test_place_help_does_not_promise_a_recorded_seed():
    """gaz place --help said the default seed is "recorded in the database and the summary":
    gaz place has neither, and a placement without --seed could not be made again."""
    place = " ".join(invoke(["place", "--help"]).stdout.split())
    assert "recorded in the database" not in place and "printed nowhere" in place
    simulate = " ".join(invoke(["simulate", "--help"]).stdout.split())
    assert "a fresh seed, recorded in the database and the summary" in simulate


def test_a_run_that_met_overlapping_pairs_says_so(monkeypatch):
    """The engine counts collisions found already overlapping (a missed collision, or an
    overlapping start); simulate reports them on stderr, the results still on stdout."""
    from gaz_cli.engines.event import driver

    real = driver._Simulation._load

    def overlapping_start(self, x, v, t):
        if t == 0.0 and len(x) > 1:
            x = x.copy()
            x[1] = x[0]  # particle 1 on top of particle 0
            x[1, 0] += 0.5 * float(self.R[0])
            v = v.copy()
            v[1, 0] = -abs(v[1, 0]) - 1.0  # and coming at it
            v[0, 0] = abs(v[0, 0])
        real(self, x, v, t)

    monkeypatch.setattr(driver._Simulation, "_load", overlapping_start)
    code, out, err = invoke(["simulate", "--dim", "3", "--n", "50", "--length", "1e-8", "--engine", "event",
                             "--duration", "1e-12", "--seed", "1", "--no-db"])
    assert code == 0 and out
    lines = [line for line in err.splitlines() if "overlapping" in line]
    assert len(lines) == 1 and "warning" in lines[0]
    code, out, err = invoke(["simulate", "--dim", "3", "--n", "50", "--length", "1e-8", "--engine", "event",
                             "--duration", "1e-12", "--seed", "1", "--no-db", "--json"])
    assert code == 0 and json.loads(out)["overlapping_collisions"] >= 1


def test_a_step_too_long_is_one_warning_line_and_the_run_completes(db):
    """Argon disks at packing 0.13, dt about 3 mean free times: the run completes (exit 0) and says once,
    in one line, that its steps left overlapping pairs and which dt would avoid them."""
    res = invoke(["simulate", "--dim", "2", "--n", "500", "--length", "2e-8", "--duration", "2e-10",
                  "--engine", "step", "--dt", "1e-11", "--seed", "1", "--db", db])
    assert res.exit_code == 0, res.output
    warnings = [line for line in res.stderr.splitlines() if line.startswith("gaz: warning:")]
    assert len(warnings) == 1 and len(res.stderr.splitlines()) == 1, res.stderr
    assert "overlapping" in warnings[0] and "--dt" in warnings[0]


def test_output_cut_short_by_its_reader_exits_0_without_a_word():
    """gaz place ... | head -c 10: the reader leaves before the 20,000 rows are written. click's
    own handler of the broken pipe exited 1, silently, even outside standalone mode (a
    pipeline under `set -o pipefail` failed with nothing said); cli.main meant 0."""
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-m", "gaz_cli", "place", "--dim", "1", "--n", "20000",
                             "--radius", "1e-9", "--length", "1", "--seed", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.read(10)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert (proc.wait(timeout=120), err) == (0, "")
