"""Sweeps on a real Dask cluster: the plan, every run stored once with the rows a single
run gives, failures reported while the others go on, a stored run skipped."""

from __future__ import annotations

import gc

from dataclasses import replace

import numpy as np
import pytest

from gaz_cli.run import sweeps as sweep
from gaz_cli.errors import SceneError
from gaz_cli.run.runner import simulate
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import BUILTIN
from gaz_cli.results.store import Store, rebond

from backends import postgres_db, postgres_url  # noqa: E402,F401 - fixtures

pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def cluster():
    """One real Dask cluster (a worker process) for the tests that do not test the local default."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0") as c:
        yield c.scheduler_address

BASE = Scene(dim=2, length=1e-7, duration=2e-10, components=((BUILTIN["Ar"], 20),), seed=7)


def scene_of(overrides: dict) -> Scene:
    """A point's scene: ``n`` varies; a point asking for more than fits fails to build."""
    n = overrides["n"]
    if n > 1000:
        raise SceneError(f"n = {n}: too many for this box")
    return replace(BASE, seed=overrides["seed"], components=((BUILTIN["Ar"], n),))


def key_of(scene: Scene) -> str:
    return f"n={scene.n} seed={scene.seed}"


# --- the plan -------------------------------------------------------------------
def test_vary_reads_lists_and_ranges():
    assert sweep.parse_vary("packing=0.1:0.6:6") == ("packing", [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert sweep.parse_vary("n=10,20") == ("n", [10, 20])
    assert sweep.parse_vary("temperature=300,1e3") == ("temperature", [300.0, 1000.0])
    assert sweep.parse_vary("boundary=walls,periodic") == ("boundary", ["walls", "periodic"])
    assert sweep.parse_vary("length=2:2:1") == ("length", [2.0])


@pytest.mark.parametrize("text", ["packing", "packing=", "=1,2", "n=1,,2", "packing=0.1:0.6",
                                  "packing=0.1:0.6:0", "packing=a:b:3", "packing=0.1:0.6:2.5",
                                  "packing=0.1:0.6:1", "count=10:20:4", "count=10.5,20", "force=yes,no"])
def test_vary_refuses_malformed_text_in_one_line(text):
    with pytest.raises(SceneError) as err:
        sweep.parse_vary(text)
    assert "\n" not in str(err.value) and "--vary" in str(err.value)


def test_vary_reads_values_as_the_key_takes_them():
    """--vary count=10:40:4 made floats, 10.0 to 40.0, and every point was refused ("count = 10.0
    must be a whole number"): a range of counts, dims or print_every could never run, nor
    count=1e2,2e2; force=true,false were strings ("force = 'true' must be true or false").
    Now a whole-number key reads whole floats as ints, a true-or-false key reads true/false;
    a range whose step is not whole is refused naming the value (test above)."""
    assert sweep.parse_vary("count=10:40:4") == ("count", [10, 20, 30, 40])
    assert sweep.parse_vary("count.He=1e2,2e2") == ("count.He", [100, 200])
    assert sweep.parse_vary("dim=1:3:3") == ("dim", [1, 2, 3])
    assert sweep.parse_vary("force=true,False") == ("force", [True, False])
    assert sweep.parse_vary("boundary=walls,periodic") == ("boundary", ["walls", "periodic"])
    assert all(type(v) is int for v in sweep.parse_vary("print_every=10:30:3")[1])
    with pytest.raises(SceneError, match=r"13.3333333333 is not a whole number; count takes whole numbers"):
        sweep.parse_vary("count=10:20:4")


@pytest.mark.parametrize("text, twice", [("temperature=100,100", "100"), ("temperature=100,1e2", "100.0"),
                                         ("boundary=walls,walls", "'walls'"), ("length=2:2:3", "2.0")])
def test_a_value_given_twice_is_refused(text, twice):
    """temperature=100,100 ran the same scene with the same seed twice and stored both runs (the
    mean over the runs counted it twice)."""
    with pytest.raises(SceneError) as err:
        sweep.parse_vary(text)
    assert str(err.value) == (f"--vary {text!r}: {twice} comes twice; give each value once "
                              "(--seeds K runs each point with K seeds)")


def test_gaz_sweep_with_a_value_given_twice_is_one_line_and_writes_nothing(tmp_path):
    from cli_helpers import invoke

    scene, db = tmp_path / "rods.toml", tmp_path / "s.db"
    scene.write_text(RODS)
    code, out, err = invoke(["sweep", str(scene), "--vary", "temperature=100,100", "--db", str(db)])
    assert (code, out, len(err.splitlines())) == (1, "", 1) and "100 comes twice" in err, err
    assert not db.exists()


def test_a_range_of_too_many_values_is_refused_before_it_is_built():
    """temperature=1:2:100000000000 built 10^11 floats before the plan counted them (the
    command hung past 120 s); it is refused as the plan refuses more than MAX_POINTS runs."""
    with pytest.raises(SceneError, match="more than 100000") as err:
        sweep.parse_vary("temperature=1:2:100000000000")
    assert "\n" not in str(err.value) and "--vary" in str(err.value)


def test_plan_is_the_product_of_the_values_times_the_seeds():
    points = sweep.plan([("n", [10, 20, 30]), ("temperature", [100.0, 300.0])], seeds=4, base_seed=7)
    assert len(points) == 3 * 2 * 4 and len(set(points)) == len(points)
    assert {p.seed for p in points} == {7, 8, 9, 10}
    assert {p.overrides()["n"] for p in points} == {10, 20, 30}
    assert sweep.plan([("n", [1])], seeds=2)[0].seed == 1  # no seed in the scene: from 1
    with pytest.raises(SceneError, match="given twice"):
        sweep.plan([("n", [1]), ("n", [2])], seeds=1)
    with pytest.raises(SceneError, match="--seeds"):
        sweep.plan([("n", [1])], seeds=0)
    with pytest.raises(SceneError, match="more than"):
        sweep.plan([("n", list(range(1000)))], seeds=1000)


# --- on a cluster ----------------------------------------------------------------
def _rows(db: str, si_num: int) -> np.ndarray:
    with Store(db, create=False) as store:
        frame = store.table(rebond, si_num)
    return frame[["RE_NUM", "RE_T", "RE_DIR", "RE_VIT", "RE_VP"]].to_numpy()


def test_a_sweep_stores_each_run_as_a_single_run_would(tmp_path):
    """Two worker processes: each point is stored once, with exactly the rows of the same
    scene run alone (same seed, same rows). (A run failing on a worker while the others go on:
    test_a_failing_run_on_a_worker_is_reported_and_the_others_go_on.)"""
    db = str(tmp_path / "sweep.db")
    points = sweep.plan([("n", [10, 20])], seeds=2, base_seed=BASE.seed)
    report = sweep.run(points, scene_of, key_of, db, workers=min(2, sweep.cores()), progress=False)  # at most the cores
    stored = [r for r in report.rows if r[1] == "stored"]
    assert len(stored) == 4 == len(report.rows)
    assert len({r[2] for r in stored}) == 4  # distinct SI_NUM
    for point, _, si_num, _ in stored:
        alone = simulate(scene_of(point.overrides()), db=str(tmp_path / "alone.db"))
        rows = _rows(db, si_num)
        assert len(rows) > 0 and np.array_equal(rows, _rows(str(tmp_path / "alone.db"), alone["si_num"]))


def test_a_range_of_counts_runs_each_count(tmp_path, cluster):
    """gaz sweep FILE --vary count=10:20:2 refused both points (count = 10.0 must be a whole
    number); now it stores a run of 10 rods and one of 20."""
    from cli_helpers import invoke

    scene, db = tmp_path / "rods.toml", tmp_path / "r.db"
    scene.write_text(RODS)
    res = invoke(["sweep", str(scene), "--vary", "count=10:20:2", "--scheduler", cluster, "--db", str(db), "--quiet"])
    assert res.exit_code == 0, res.output
    with Store(str(db), create=False) as store:
        assert sorted(store.read_sql("SELECT SI_N FROM SIMULATION").SI_N) == [10, 20]


def test_the_report_lists_the_points_in_the_plans_order(tmp_path, cluster):
    """The table listed the runs as they came: skipped ones first, then each as it finished
    (gaz sweep rods.toml --vary packing=0.6:0.1:6 printed 0.6, 0.5, 0.2, 0.1, 0.4, 0.3 on 2
    workers). Now in the plan's order, whatever finished first: here the second point is
    stored already (skipped at once), the first runs."""
    db = str(tmp_path / "s.db")
    simulate(scene_of({"n": 20, "seed": 1}), db=db)
    report = sweep.run(sweep.plan([("n", [10, 20])], seeds=1), scene_of, None, db, scheduler=cluster,
                       progress=False)
    assert [(p.label, status) for p, status, _, _ in report.rows] == [("n=10 seed=1", "stored"),
                                                                      ("n=20 seed=1", "skipped")]


def test_the_cluster_is_handed_a_few_runs_per_worker_at_a_time(tmp_path, cluster, monkeypatch):
    """Every run was submitted at once: a plan of 100,000 points (temperature=100:1000:1000
    --seeds 100, 20 rods) kept the client submitting until its connection to the scheduler
    closed, and the sweep waited for good: 0 runs stored after 14 minutes. Now at most
    IN_FLIGHT_PER_THREAD runs per worker thread are out at once, the next submitted as one comes
    back (the same plan stores about 115 runs a second on 2 workers). Counted here on the
    client: runs submitted minus runs stored, at each submission, on a cluster of one thread."""
    from distributed import Client

    counts = {"submitted": 0, "stored": 0, "peak": 0}
    submit, store = Client.submit, sweep._store

    def counting_submit(self, *args, **kw):
        counts["submitted"] += 1
        counts["peak"] = max(counts["peak"], counts["submitted"] - counts["stored"])
        return submit(self, *args, **kw)

    def counting_store(*args):
        counts["stored"] += 1
        return store(*args)

    monkeypatch.setattr(Client, "submit", counting_submit)
    monkeypatch.setattr(sweep, "_store", counting_store)
    monkeypatch.setattr(sweep, "IN_FLIGHT_PER_THREAD", 2)
    report = sweep.run(sweep.plan([("n", [10, 11, 12, 13, 14, 15])], seeds=1), scene_of, key_of,
                       str(tmp_path / "s.db"), scheduler=cluster, progress=False)
    assert report.count("stored") == 6 == counts["submitted"] == counts["stored"]
    assert counts["peak"] == 2, counts


def test_a_failing_run_on_a_worker_is_reported_and_the_others_go_on(tmp_path, cluster):
    """A run that raises inside the worker fails alone: random placement asked for beyond
    its jamming density (2D, packing 0.6 > 0.547) passes validation and gives up on the worker."""
    import math

    db = str(tmp_path / "sweep.db")

    def broken_or_not(overrides):
        scene = scene_of(overrides)
        if overrides["n"] != 20:
            return scene
        jammed = math.sqrt(20 * math.pi * BUILTIN["Ar"].radius ** 2 / 0.6)
        return replace(scene, placement="rejection", length=jammed)

    report = sweep.run(sweep.plan([("n", [10, 20])], seeds=1, base_seed=3), broken_or_not, key_of,
                       db, scheduler=cluster, progress=False)
    status = {p.overrides()["n"]: (s, why) for p, s, _, why in report.rows}
    assert status[10][0] == "stored"
    assert status[20][0] == "failed" and "placement stuck" in status[20][1] and "\n" not in status[20][1]


def test_a_sweep_whose_runs_all_fail_creates_no_database(tmp_path, cluster):
    """Every run failing on the workers (random placement beyond its jamming density), the sweep
    reports them and left --db, new, behind as an empty gaz database; now no file."""
    import math

    def jammed(overrides):
        scene = scene_of(overrides)
        return replace(scene, placement="rejection",
                       length=math.sqrt(scene.n * math.pi * BUILTIN["Ar"].radius ** 2 / 0.6))

    report = sweep.run(sweep.plan([("n", [20])], seeds=2), jammed, key_of, str(tmp_path / "sweep.db"),
                       scheduler=cluster, progress=False)
    assert [s for _, s, _, _ in report.rows] == ["failed", "failed"]
    assert list(tmp_path.iterdir()) == []


def test_a_sweep_runs_on_an_existing_scheduler(tmp_path, cluster):
    report = sweep.run(sweep.plan([("n", [10])], seeds=2), scene_of, key_of,
                       str(tmp_path / "s.db"), scheduler=cluster, progress=False)
    assert report.count("stored") == 2


def test_a_database_given_as_a_pathlib_path_is_used(tmp_path, cluster):
    """gaz.sweep(..., db=pathlib.Path) raised TypeError "argument of type 'PosixPath' is not
    iterable" (the disk check's look at the SQLite file); gaz.simulate takes a Path."""
    db = tmp_path / "s.db"
    report = sweep.run(sweep.plan([("n", [10])], seeds=1), scene_of, key_of, db, scheduler=cluster, progress=False)
    assert [r[1] for r in report.rows] == ["stored"] and report.db == str(db)
    assert len(_rows(str(db), report.rows[0][2])) > 0


def test_an_unreachable_scheduler_is_one_line(tmp_path, monkeypatch):
    """An unreachable --scheduler is one line, and creates no database (a new --db file was
    created, empty, before the scheduler was asked)."""
    monkeypatch.setattr(sweep, "SCHEDULER_TIMEOUT_S", 1)
    with pytest.raises(sweep.GazError, match="cannot reach the Dask scheduler"):
        sweep.run(sweep.plan([("n", [10])], seeds=1), scene_of, key_of, str(tmp_path / "s.db"),
                  scheduler="tcp://127.0.0.1:9", progress=False)
    assert list(tmp_path.iterdir()) == []


def test_a_malformed_scheduler_address_is_one_line(tmp_path):
    """--scheduler nonsense ended in 'internal error: ValueError: missing port number in
    address 'nonsense'', exit 3."""
    with pytest.raises(sweep.GazError, match="cannot reach the Dask scheduler") as err:
        sweep.run(sweep.plan([("n", [10])], seeds=1), scene_of, key_of, str(tmp_path / "s.db"),
                  scheduler="nonsense", progress=False)
    assert "\n" not in str(err.value) and "missing port number" in str(err.value)


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:9", "nonsense"])
def test_a_scheduler_that_fails_leaves_no_client_for_the_garbage_collector(monkeypatch, address):
    """.ci/run hung for good in test_gaz_sweep_stores_then_skips_and_analyse_tabulates: the
    Client that an unreachable --scheduler left half-made (kept by the error's traceback) was
    closed by the garbage collector inside the next sweep's Client start, which held the lock
    that its close takes (py-spy: Client.__del__ -> LoopRunner.stop under
    LoopRunner._start_unlocked). Now no Client of the failed call is alive once it has failed,
    collected or not."""
    from distributed import Client

    monkeypatch.setattr(sweep, "SCHEDULER_TIMEOUT_S", 1)
    before = {id(o) for o in gc.get_objects() if isinstance(o, Client)}
    with pytest.raises(sweep.GazError, match="cannot reach the Dask scheduler") as err:
        sweep._client(None, address, 1).__enter__()
    left = [o for o in gc.get_objects() if isinstance(o, Client) and id(o) not in before]  # (no gc.collect)
    assert left == [], (left, err.value)


# --- from the command line ------------------------------------------------------------
RODS = """dim = 1
packing = 0.3
duration = 1e-11
seed = 5
[[species]]
name = "Ar"
count = 20
"""


def test_gaz_sweep_stores_then_skips_and_analyse_tabulates(tmp_path, cluster):
    """gaz sweep over a scene file: every run stored once with the file's seeds; the same
    command again stores nothing (each run recognised by its scene file) and names each run's
    SI_NUM, which it left empty; analyse --vs reads it."""
    from click.testing import CliRunner

    from gaz_cli.cli import cli

    scene = tmp_path / "rods.toml"
    scene.write_text(RODS)
    db = str(tmp_path / "rods.db")
    args = ["sweep", str(scene), "--vary", "packing=0.2,0.4", "--seeds", "2", "--scheduler", cluster,
            "--db", db, "--format", "csv", "--quiet"]
    first = CliRunner().invoke(cli, args)
    assert first.exit_code == 0, first.output
    assert first.output.count(",stored,") == 4
    import io

    import pandas as pd

    runs = pd.read_csv(io.StringIO(first.stdout))  # one table: no '# runs' line for read_csv to take as its header
    assert list(runs.columns) == ["packing", "SEED", "STATUS", "SI_NUM", "NOTE"] and len(runs) == 4
    with Store(db, create=False) as store:
        seeds = sorted(store.read_sql("SELECT SC_SEED FROM SCENE").SC_SEED)
    assert seeds == [5, 5, 6, 6]
    again = CliRunner().invoke(cli, args)
    assert again.exit_code == 0 and again.output.count(",skipped,") == 4
    # a skipped run is named by its SI_NUM in the database (it was left empty): the same as stored
    assert list(pd.read_csv(io.StringIO(again.stdout)).SI_NUM) == list(runs.SI_NUM)
    with Store(db, create=False) as store:
        assert len(store.simulation_numbers()) == 4
    table = CliRunner().invoke(cli, ["analyse", "--db", db, "--vs", "packing", "--format", "csv"])
    assert table.exit_code == 0 and "0.2," in table.output and "0.4," in table.output


def _no_cluster(monkeypatch):
    def no_cluster(*args):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(sweep, "_client", no_cluster)


@pytest.mark.parametrize("existing", [False, True])
def test_a_point_the_scene_refuses_is_one_line_before_any_run(tmp_path, monkeypatch, existing):
    """gaz sweep FILE --vary packing=0.1,0.5,0.95 (2D: 0.95 is above 0.9069, the densest disk
    packing) ran 0.1 and 0.5, stored them and reported 0.95 failed, exit 1: a sweep half done, to
    be finished by a second command after the value was dropped. Now every point goes through the
    scene's door before anything runs: one line naming the value, the door's reason and the fix;
    no cluster; a new --db not created, an existing one byte for byte as it was."""
    from cli_helpers import invoke

    scene, db = tmp_path / "disks.toml", tmp_path / "d.db"
    scene.write_text(RODS.replace("dim = 1", "dim = 2"))
    if existing:  # a database holding the sweep's first point already
        simulate(_point_scene(scene, 0.1), db=str(db))
    before = db.read_bytes() if existing else None
    _no_cluster(monkeypatch)
    res = invoke(["sweep", str(scene), "--vary", "packing=0.1,0.5,0.95", "--db", str(db), "--quiet"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1 and res.stdout == "", res.output
    assert lines[0] == (f"gaz: error: --vary packing=0.95: {scene}: packing 0.95 is at or above 0.9069, the densest "
                        "disk packing; lower packing; drop 0.95 from --vary packing (1 of 3 runs refused, none "
                        "started)"), lines[0]
    assert (db.read_bytes() == before) if existing else not db.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["disks.toml", *(["d.db"] if existing else [])])


def _point_scene(path, packing):
    """The scene of ``path`` at ``packing``, as a sweep builds it."""
    scene_of, seed, _ = sweep.scenes_of_file(path, ["packing"])
    return scene_of({"packing": packing, "seed": seed})


def test_a_combination_the_scene_refuses_names_the_whole_point(tmp_path, monkeypatch):
    """Neither value is wrong alone: packing 0.8 with one disk leaves a box narrower than the
    disk; packing 0.8 with 20 disks and 0.1 with one run. The line names the combination."""
    from cli_helpers import invoke

    scene, db = tmp_path / "disks.toml", tmp_path / "d.db"
    scene.write_text(RODS.replace("dim = 1", "dim = 2"))
    _no_cluster(monkeypatch)
    res = invoke(["sweep", str(scene), "--vary", "packing=0.1,0.8", "--vary", "count=1,20", "--db", str(db),
                  "--quiet"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1 and res.stdout == "", res.output
    assert lines[0].startswith("gaz: error: --vary packing=0.8 count=1 seed=5: "), lines[0]
    assert lines[0].endswith("; change the values or the seeds so that every combination can run "
                             "(1 of 4 runs refused, none started)"), lines[0]
    assert not db.exists()


@pytest.mark.parametrize("vary, fragment", [
    ("colour=1,2", "--vary colour: unknown parameter 'colour'; a sweep can vary dim, length, packing"),
    ("pakcing=0.1,0.2", "--vary pakcing: unknown parameter 'pakcing' (did you mean 'packing'?); a sweep can "
                        "vary dim, length, packing,"),
    ("cuont=10,20", "unknown parameter 'cuont' (did you mean 'count'?)"),
    ("species=1,2", "--vary species: unknown parameter 'species'"),
    ("count.Ne=10,20", "--vary count.Ne: unknown species 'Ne'; the file's species: Ar (vary count or count.Ar)"),
    ("count.Arr=10,20", "--vary count.Arr: unknown species 'Arr' (did you mean 'Ar'?); the file's species: Ar"),
])
def test_gaz_sweep_refuses_a_key_it_cannot_vary_before_any_run(tmp_path, vary, fragment):
    """--vary colour=1,2 started the sweep, opened (created) the database and failed every run
    with the scene file's 'unknown key', exit 1; now one line at the door listing the keys, no
    database, no cluster. A typo (pakcing) was told no closer name; now the closest allowed one
    (the scene file's own resolver, scenefile.unknown_name)."""
    from cli_helpers import invoke

    scene = tmp_path / "rods.toml"
    scene.write_text(RODS)
    db = tmp_path / "r.db"
    res = invoke(["sweep", str(scene), "--vary", vary, "--db", str(db), "--quiet"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1 and fragment in lines[0], res.stderr
    assert "count.Ar" in lines[0]  # the file's own count keys, not a placeholder
    assert res.stdout == "" and not db.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["rods.toml"]


def test_gaz_sweep_stores_into_the_scene_files_output_db_unless_db_is_given(tmp_path, cluster, monkeypatch):
    """A scene file's [output] db = "other.db" was ignored by gaz sweep, which wrote gaz.db
    (gaz simulate FILE honours it); now the sweep goes there, and --db still wins."""
    from cli_helpers import invoke

    monkeypatch.chdir(tmp_path)
    (tmp_path / "out.toml").write_text(RODS + '[output]\ndb = "other.db"\n')
    args = ["sweep", "out.toml", "--vary", "temperature=100,200", "--scheduler", cluster, "--quiet"]
    res = invoke(args)
    assert res.exit_code == 0, res.stderr
    assert "(--db other.db)" in res.stderr and not (tmp_path / "gaz.db").exists()
    with Store("other.db", create=False) as store:
        assert len(store.simulation_numbers()) == 2
    res = invoke([*args, "--db", "given.db"])
    assert res.exit_code == 0 and "(--db given.db)" in res.stderr, res.stderr
    with Store("given.db", create=False) as store:
        assert len(store.simulation_numbers()) == 2
    with Store("other.db", create=False) as store:
        assert len(store.simulation_numbers()) == 2


@pytest.mark.parametrize("change, vary, seeds, line", [
    (("seed = 5", "seed = 5\nrestitution = 2"), "temperature=100,200", "1",
     "rods.toml: restitution 2.0 is outside [0, 1]"),
    (("seed = 5", "seed = -1"), "temperature=100,200", "3", "rods.toml: seed -1 must be between 0 and 2^63 - 1"),
    (("", ""), "packing=1.5,2", "1", "no point of the sweep can run; the first, packing=1.5 seed=5: "),
])
def test_a_sweep_no_point_of_which_can_run_is_one_line_before_any_database_or_cluster(
        tmp_path, monkeypatch, change, vary, seeds, line):
    """restitution = 2 (or seed = -1) in the file failed every point alike: a table of N
    identical failures and an empty gaz database left behind (seed = -1 with --seeds 3 even
    ran seeds 0 and 1). Now one line naming the file and the key; no database, no cluster."""
    from cli_helpers import invoke

    def no_cluster(*args):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(sweep, "_client", no_cluster)
    scene, db = tmp_path / "rods.toml", tmp_path / "r.db"
    scene.write_text(RODS.replace(*change))
    res = invoke(["sweep", str(scene), "--vary", vary, "--seeds", seeds, "--db", str(db), "--quiet"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1 and line in lines[0], res.stderr
    assert res.stdout == "" and not db.exists()


def _disks_without_a_cluster(tmp_path, monkeypatch):
    """A scene file of 20 argon disks whose rows fill a tiny disk, and no cluster allowed to start."""
    def no_cluster(*args):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(sweep, "_client", no_cluster)
    scene = tmp_path / "disks.toml"
    scene.write_text('dim = 2\nlength = 1e-7\nduration = 1e-7\nseed = 1\n[[species]]\nname = "Ar"\ncount = 20\n')
    return scene


def test_a_sweep_beyond_the_free_space_of_the_database_disk_is_one_line_before_any_run(tmp_path, monkeypatch,
                                                                                      tiny_disk):
    """gaz sweep had no disk check (gaz simulate has one): four runs of 0.2 to 0.4 MB of rows
    each, 1.3 MB in all, into a new database on a 1 MiB disk started the cluster and ran them
    until the disk was full. Now one line naming the runs, the growth and the peak (all the
    runs' rows, and the largest one's WAL copy), in the scene file's words; no database, no
    cluster. One of the runs alone fits."""
    from cli_helpers import invoke

    from gaz_cli.results.budgets import check_database_space
    from gaz_cli.scenes.files import load

    scene = _disks_without_a_cluster(tmp_path, monkeypatch)
    db = tiny_disk / "s.db"
    res = invoke(["sweep", str(scene), "--vary", "temperature=100,200,300,400", "--db", str(db), "--quiet"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1, res.stderr
    assert f"database '{db}' would grow by about 1.3" in lines[0] and "(4 runs, " in lines[0], lines[0]
    assert "needs about 1.7" in lines[0] and "its disk has 1.0" in lines[0], lines[0]
    assert "vary fewer values or seeds, shorten duration, use record none" in lines[0], lines[0]
    assert res.stdout == "" and list(tiny_disk.iterdir()) == []
    check_database_space([load(scene)[0]], db)  # the file's own run alone (300 K): 2 x 0.38 MB


def test_a_sweep_refused_for_its_disk_leaves_an_older_database_unmigrated(tmp_path, monkeypatch, tiny_disk):
    """A sweep into a database of an older schema migrated it (Store opened for writing, to read
    its stored runs) before the disk check refused the sweep: a refused sweep wrote to it. Now
    the stored runs are read without writing; the refused sweep leaves the file byte for byte."""
    from cli_helpers import invoke
    from test_store import _version_1

    scene = _disks_without_a_cluster(tmp_path, monkeypatch)
    db = tiny_disk / "old.db"
    _version_1(str(db))
    before = db.read_bytes()
    res = invoke(["sweep", str(scene), "--vary", "temperature=100,200,300,400", "--db", str(db), "--quiet"])
    assert res.exit_code == 1 and len(res.stderr.splitlines()) == 1, res.stderr
    assert f"database '{db}' would grow by about" in res.stderr, res.stderr
    assert db.read_bytes() == before and sorted(p.name for p in tiny_disk.iterdir()) == ["old.db"]


@pytest.mark.postgres
def test_a_sweep_past_32_bit_row_numbers_is_refused_before_its_cluster(tmp_path, monkeypatch, postgres_db):
    """A sweep into a PostgreSQL database made before schema 6 (32-bit RE_NUM) whose runs would
    number their rows past it is refused before any cluster starts, one line; nothing written."""
    import sqlalchemy as sa
    from cli_helpers import invoke

    from gaz_cli.results import store as st

    st.Store(postgres_db).close()
    engine = sa.create_engine(postgres_db)
    with engine.begin() as conn:  # as made by gaz before schema 6
        conn.exec_driver_sql("ALTER TABLE rebond ALTER COLUMN re_num TYPE integer")

    def no_cluster(*args):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(sweep, "_client", no_cluster)
    scene = tmp_path / "big.toml"  # the README example run for 2e-4 s: about 3.6e9 wall bounces
    scene.write_text('dim = 3\nlength = 3.4e-8\nduration = 2e-4\nseed = 1\n[[species]]\nname = "Ar"\n'
                     'count = 1000\n')
    res = invoke(["sweep", str(scene), "--vary", "temperature=300,310", "--db", postgres_db, "--quiet"])
    assert res.exit_code == 1 and len(res.stderr.splitlines()) == 1, res.stderr
    assert "32-bit integer" in res.stderr and "ALTER TABLE rebond" in res.stderr, res.stderr
    try:
        with engine.connect() as conn:
            assert conn.exec_driver_sql("SELECT count(*) FROM simulation").scalar() == 0
    finally:
        engine.dispose()


def test_more_workers_than_cores_is_one_line_before_any_database_or_cluster(tmp_path, monkeypatch):
    """gaz sweep rods.toml --vary temperature=100,200 --workers 100000 started a LocalCluster of
    as many worker processes as runs, whatever the cores (100,000 runs: 100,000 processes). Now
    one line naming the cores; no database, no cluster. The cores themselves are accepted."""
    from cli_helpers import invoke

    def no_cluster(*args):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(sweep, "_client", no_cluster)
    scene, db = tmp_path / "rods.toml", tmp_path / "r.db"
    scene.write_text(RODS)
    n = sweep.cores()
    res = invoke(["sweep", str(scene), "--vary", "temperature=100,200", "--workers", str(n + 1),
                  "--db", str(db), "--quiet"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1, res.stderr
    assert f"--workers {n + 1} is more than the {n} cores of this machine" in lines[0], lines[0]
    assert f"give --workers {n} or fewer" in lines[0], lines[0]
    assert res.stdout == "" and not db.exists()
    for wrong in (0, -3, 2.5, True):
        with pytest.raises(SceneError, match=rf"^--workers {wrong!r} must be a whole number from 1 to the {n} cores"):
            sweep.check_workers(wrong)
    sweep.check_workers(n)
    sweep.check_workers(None)


def test_gaz_sweep_takes_one_vary_as_a_string_and_refuses_seeds_of_another_type(tmp_path, monkeypatch):
    """gaz.sweep(FILE, 'temperature=100,200') iterated the string's characters: "--vary 't': write
    KEY=V1,V2,..."; seeds='3' raised TypeError "'<' not supported between instances of 'str' and
    'int'", seeds=2.5 made a range() of a float. Now one string is one vary, and seeds is a
    whole number or one line; nothing runs."""
    import gaz_cli as gaz

    planned = []

    def no_run(points, *args, **kw):  # the plan is what is tested: no cluster, no database
        planned.extend(points)
        return sweep.Report()

    monkeypatch.setattr(sweep, "run", no_run)
    scene = tmp_path / "rods.toml"
    scene.write_text(RODS)
    gaz.sweep(scene, "temperature=100,200", seeds=2, db=str(tmp_path / "r.db"))
    assert [p.label for p in planned] == ["temperature=100 seed=5", "temperature=100 seed=6",
                                          "temperature=200 seed=5", "temperature=200 seed=6"]
    for seeds in ("3", 2.5, True, 0):
        with pytest.raises(SceneError, match=rf"^--seeds {seeds!r}: give a whole number, at least 1$"):
            gaz.sweep(scene, ["temperature=100"], seeds=seeds, db=str(tmp_path / "r.db"))
    with pytest.raises(SceneError, match=r"^vary 5 is not a list of 'KEY=V1,V2'"):
        gaz.sweep(scene, 5, db=str(tmp_path / "r.db"))
    assert not (tmp_path / "r.db").exists()


def test_a_scene_files_outputs_other_than_db_are_said_to_be_ignored_by_a_sweep(tmp_path, monkeypatch):
    """A scene file with [output] trajectory, every and save_state, swept: the runs were stored
    and no file written, nothing said. Now one warning line naming them (the runs would write
    over each other's files) and what to do; the sweep goes on into [output] db."""
    from cli_helpers import invoke

    seen = []

    def no_run(points, scene_of, key, db, **kw):
        seen.append(db)
        return sweep.Report(db=db)

    monkeypatch.setattr(sweep, "run", no_run)
    scene = tmp_path / "rods.toml"
    scene.write_text(RODS + f'[output]\ndb = "{tmp_path / "r.db"}"\ntrajectory = "{tmp_path / "t.h5"}"\n'
                            f'every = 1e-12\nsave_state = "{tmp_path / "s.csv"}"\n')
    res = invoke(["sweep", str(scene), "--vary", "temperature=100,200", "--quiet"])
    assert res.exit_code == 0 and seen == [str(tmp_path / "r.db")], res.output
    assert res.stderr.splitlines()[0] == (
        f"gaz: warning: {scene}: [output] trajectory, every, save_state not written by a sweep (its runs would "
        "write over each other's files); only [output] db is used: run one point with gaz simulate for its files")
    scene.write_text(RODS + f'[output]\ndb = "{tmp_path / "r.db"}"\n')
    res = invoke(["sweep", str(scene), "--vary", "temperature=100,200", "--quiet"])
    assert res.exit_code == 0 and "warning" not in res.stderr, res.stderr


def test_workers_with_a_scheduler_is_refused_in_one_line(tmp_path):
    """gaz sweep FILE --vary ... --scheduler tcp://host:8786 --workers 1 ran on the scheduler's
    cluster, all its workers, and ignored --workers without a word. Now one line saying which
    to drop, before any database or cluster."""
    from cli_helpers import invoke

    scene, db = tmp_path / "rods.toml", tmp_path / "r.db"
    scene.write_text(RODS)
    res = invoke(["sweep", str(scene), "--vary", "temperature=100,200", "--workers", "1", "--scheduler",
                  "tcp://127.0.0.1:9", "--db", str(db), "--quiet"])
    assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.output
    assert ("--workers 1 sizes the local cluster, and --scheduler 'tcp://127.0.0.1:9' runs the sweep on its own "
            "cluster's workers: drop --workers") in res.stderr, res.stderr
    assert not db.exists()


@pytest.mark.parametrize("vary, wrong", [("temperature=-5,abc", "'abc'"), ("temperature=abc,300", "'abc'"),
                                         ("count=10,2x0", "'2x0'")])
def test_a_value_not_a_number_is_named_itself(tmp_path, vary, wrong):
    """--vary temperature=-5,abc made every value text, and the sweep said "temperature = '-5'
    must be a number" (and the same for 'abc'): the message named a number. Now one line
    naming the value that is not one, before any database."""
    from cli_helpers import invoke

    scene, db = tmp_path / "rods.toml", tmp_path / "r.db"
    scene.write_text(RODS)
    res = invoke(["sweep", str(scene), "--vary", vary, "--db", str(db), "--quiet"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1, res.stderr
    assert f"{wrong} is not a number" in lines[0] and "'-5'" not in lines[0] and "'10'" not in lines[0], lines[0]
    assert res.stdout == "" and not db.exists()


def test_a_varied_count_of_zero_names_the_species_count(tmp_path, monkeypatch):
    """--vary count.He=0,3 failed its first point with "n must be at least 1, got 0"; it names the
    [[species]] count of He now, before any run."""
    from cli_helpers import invoke

    scene = tmp_path / "mix.toml"
    scene.write_text(RODS + '[[species]]\nname = "He"\ncount = 20\n')
    _no_cluster(monkeypatch)
    res = invoke(["sweep", str(scene), "--vary", "count.He=0,3", "--format", "json",
                  "--db", str(tmp_path / "m.db"), "--quiet"])
    assert res.exit_code == 1 and res.stdout == "", res.stderr
    assert res.stderr == (f"gaz: error: --vary count.He=0: {scene}: the [[species]] count of He must be at least 1, "
                          "got 0; drop 0 from --vary count.He (1 of 2 runs refused, none started)\n")


def test_the_local_clusters_own_errors_stay_off_the_terminal():
    """The local cluster's logs at ERROR level -- a worker's heartbeat failing as the scheduler
    closes under it, what an interrupted sweep printed, a traceback of 30 lines before gaz's
    own line -- do not reach stderr: gaz reports every run's failure itself (the report's
    NOTE, the interrupted sweep's one line)."""
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent("""
        import logging
        from gaz_cli.run import sweeps
        with sweeps._client(workers=1, scheduler=None, runs=1) as client:
            client.run(lambda: logging.getLogger("distributed.worker").error("worker says boom"))
            logging.getLogger("distributed.scheduler").error("scheduler says boom")
        print("done")
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and res.stdout == "done\n", res.stderr
    assert "boom" not in res.stderr, res.stderr


@pytest.mark.postgres
def test_gaz_sweeps_last_line_hides_the_password(tmp_path, cluster, postgres_db):
    """The sweep's closing line names --db without its password (it printed the URL as given:
    'gaz sweep: 2 runs: 2 stored, ... (--db postgresql://gaz:s3cret@...)'). (The test server
    trusts its socket: the password is given, and not checked.)"""
    from click.testing import CliRunner

    from gaz_cli.cli import cli

    scene = tmp_path / "rods.toml"
    scene.write_text(RODS)
    db = sa_url_with_password(postgres_db, "s3cret")
    res = CliRunner().invoke(cli, ["sweep", str(scene), "--vary", "packing=0.2,0.4", "--scheduler", cluster,
                                   "--db", db, "--quiet"])
    assert res.exit_code == 0, res.output
    assert "2 stored" in res.stderr and "s3cret" not in res.stderr + res.stdout, res.stderr


def sa_url_with_password(url: str, password: str) -> str:
    import sqlalchemy as sa

    return sa.make_url(url).set(password=password).render_as_string(hide_password=False)


def _help_examples() -> list[list[str]]:
    """The ``gaz sweep`` lines of ``gaz sweep --help``'s examples, as argument lists."""
    import shlex

    from cli_helpers import invoke

    text = invoke(["sweep", "--help"]).stdout
    return [shlex.split(line)[1:] for line in text.splitlines() if line.strip().startswith("gaz sweep ")]


def test_the_help_examples_run_as_written(tmp_path, monkeypatch):
    """gaz sweep --help showed 'gaz sweep scene.toml --vary temperature=100,300,1000 --vary
    count=100,400 --db t.db': no scene.toml anywhere ("Path 'scene.toml' does not exist", exit 2).
    Now each example names a file of examples/ (run from the repository, as the README's) and
    every point of it passes the scene's checks; the fast one (6 runs of the exam's gas of 100
    and 400 atoms, about 3 s) runs to the end, every run stored."""
    from pathlib import Path

    from cli_helpers import invoke

    from gaz_cli.run.runner import prepare

    examples = _help_examples()
    assert len(examples) >= 2, examples
    root = Path(__file__).resolve().parent.parent
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(root / "examples")
    for args in examples:
        file, varies = args[1], [args[k + 1] for k, a in enumerate(args) if a == "--vary"]
        assert (root / file).is_file(), file
        scene_of, seed, _ = sweep.scenes_of_file(file, [sweep.parse_vary(v)[0] for v in varies])
        for point in sweep.plan([sweep.parse_vary(v) for v in varies], 1, seed):
            prepare(scene_of(point.overrides()))
    fast = next(args for args in examples if "examples/exam.toml" in args)
    res = invoke([*fast, "--workers", "1", "--quiet"])
    assert res.exit_code == 0 and "6 stored" in res.stderr, res.output


def test_ctrl_c_at_a_terminal_is_one_line_not_a_traceback_per_worker(tmp_path):
    """Ctrl-C at a terminal sends SIGINT to the whole process group: gaz and every worker of its
    local cluster. Each worker printed a KeyboardInterrupt traceback of 33 lines ("Process Dask
    Worker process (from Nanny): ... CancelledError ... KeyboardInterrupt"), 66 lines on 2
    workers before gaz's own line. Now the workers ignore SIGINT (sweeps.dask_setup, their
    preload) and gaz alone answers: one line, exit 130, the stored runs kept. The command runs
    in a session of its own with SIGINT's default action, as a shell in a terminal starts it,
    and the signal goes to the group once the first run is stored (the others running)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    scene, db = tmp_path / "disks.toml", tmp_path / "i.db"
    scene.write_text('dim = 2\npacking = 0.3\nduration = 1e-8\nseed = 1\nrecord = "none"\n'
                     '[[species]]\nname = "Ar"\ncount = 400\n')   # about 1.5 s a run
    env = {**os.environ, "NUMBA_CACHE_DIR": os.environ.get("NUMBA_CACHE_DIR", str(tmp_path / "nc"))}
    proc = subprocess.Popen([sys.executable, "-m", "gaz_cli", "sweep", str(scene), "--vary",
                             "temperature=100:600:6", "--workers", str(min(2, sweep.cores())), "--db", str(db),
                             "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 90
        while not db.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert db.exists() and proc.poll() is None, "the sweep stored no run, or ended, before the signal"
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130 and out == "", (proc.returncode, err)
    assert len(err.splitlines()) == 1 and err.startswith("gaz: interrupted by SIGINT; "), err
    assert "run the same sweep again to finish it" in err, err


@pytest.mark.parametrize("example, vary, fixed", [
    ("comet.toml", "temperature=100,300", "[initial] kind = 'explicit') fixes temperature: every point would run "
                                          "the same state, whatever its temperature;"),
    ("comet.toml", "count.comet=1,2", "fixes count.comet:"),
    ("marbles.toml", "temperature=100,300", "[initial] kind = 'upper-half') fixes temperature:"),
])
def test_a_key_the_files_initial_state_fixes_is_refused_before_any_run(tmp_path, monkeypatch, example, vary, fixed):
    """gaz sweep examples/comet.toml --vary temperature=100,300 stored two runs of the same
    explicit state (its velocities are given: the temperature is ignored), told apart by their
    temperature only, which gaz analyse --vs temperature would then tabulate; gaz simulate
    refuses --temperature on that file. Now the sweep is refused by the same rule
    (scenefile.fixed_by_initial), one line, no database."""
    from pathlib import Path

    from cli_helpers import invoke

    _no_cluster(monkeypatch)
    scene = Path(__file__).resolve().parent.parent / "examples" / example
    db = tmp_path / "c.db"
    res = invoke(["sweep", str(scene), "--vary", vary, "--db", str(db), "--quiet"])
    lines = res.stderr.splitlines()
    assert res.exit_code == 1 and len(lines) == 1 and fixed in lines[0], res.stderr
    assert lines[0].endswith("vary another key, or describe the scene without its initial state"), lines[0]
    assert res.stdout == "" and not db.exists()


@pytest.mark.parametrize("varies, line", [
    (["packing=0.1,0.2", "length=1e-7,2e-7"], "gaz: error: --vary packing and --vary length both set the box side; "
                                              "vary one of them (with packing, the box follows from it and the counts)"),
    (["engine=auto,reference"], "gaz: error: --vary: engine=auto seed=5 and engine=reference seed=5 are the same run "
                                "(the same scene, seed included): it would be stored twice; drop one of the values "
                                "that make them"),
])
def test_points_that_make_one_run_are_refused_before_any_run(tmp_path, monkeypatch, varies, line):
    """--vary packing=0.1,0.2 --vary length=1e-7,2e-7 stored 4 runs of 2 scenes: the length given
    last replaced the packing (SI_L 1e-7, 2e-7, 1e-7, 2e-7), each scene stored twice under two
    packings. --vary engine=auto,reference (auto takes the reference engine for 20 disks) stored
    the same run twice. Now one line each, no database, no cluster."""
    from cli_helpers import invoke

    _no_cluster(monkeypatch)
    scene, db = tmp_path / "disks.toml", tmp_path / "d.db"
    scene.write_text(RODS.replace("dim = 1", "dim = 2"))
    res = invoke(["sweep", str(scene), *(a for v in varies for a in ("--vary", v)), "--db", str(db), "--quiet"])
    assert (res.exit_code, res.stdout, res.stderr) == (1, "", line + "\n")
    assert not db.exists()


def test_a_seed_past_the_largest_is_blamed_on_the_seeds(tmp_path, monkeypatch):
    """seed = 2^63 - 1 in the file with --seeds 2: the second seed, 2^63, is refused at every
    value; the line named one point ("--vary temperature=100 seed=9223372036854775808") and told
    to "change the values or the seeds", a --vary of the seed. Now it names the seed and the fix,
    --seeds or the file's."""
    from cli_helpers import invoke

    _no_cluster(monkeypatch)
    scene, db = tmp_path / "big.toml", tmp_path / "b.db"
    scene.write_text(RODS.replace("seed = 5", "seed = 9223372036854775807"))
    res = invoke(["sweep", str(scene), "--vary", "temperature=100,200", "--seeds", "2", "--db", str(db), "--quiet"])
    assert (res.exit_code, res.stdout) == (1, "") and res.stderr == (
        f"gaz: error: --seeds: seed 9223372036854775808: {scene}: seed 9223372036854775808 must be between 0 and "
        "2^63 - 1; lower --seeds or the file's seed (2 of 4 runs refused, none started)\n"), res.stderr
    assert not db.exists()
