"""Studies across runs (gaz analyse --vs): hard rods between walls, whose pressure is
known exactly for any N (Tonks), swept over the packing fraction with several seeds."""

from __future__ import annotations

import math

import pytest

from gaz_cli.analysis import studies
from gaz_cli.errors import GazError
from gaz_cli.run.runner import simulate
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import BUILTIN
from gaz_cli.results.store import Store

ARGON = BUILTIN["Ar"]
N = 50
PACKINGS = (0.2, 0.5)
SEEDS = 8


@pytest.fixture(scope="module")
def rods_db(tmp_path_factory):
    db = str(tmp_path_factory.mktemp("studies") / "rods.db")
    for eta in PACKINGS:
        length = N * 2 * ARGON.radius / eta
        for seed in range(1, SEEDS + 1):
            simulate(Scene(dim=1, length=length, duration=2e-10, components=((ARGON, N),), seed=seed),
                     db=db)
    return db


def test_rods_pressure_against_packing_agrees_with_tonks(rods_db):
    """Each packing's mean over 8 seeds within 5 standard errors of Tonks' exact pressure.

    Error model: the runs are independent, so (mean - exact)/SE follows Student's t
    with 7 degrees of freedom; |t| > 5 has probability 0.16 % per point.
    """
    with Store(rods_db, create=False) as store:
        table = studies.versus(store, "packing")
    assert table.PACKING.tolist() == pytest.approx(list(PACKINGS), rel=1e-9)
    assert (table.RUNS == SEEDS).all()
    for _, row in table.iterrows():
        assert row.P_ERR > 0 and abs(row.P_DEV_SIGMA) < 5, row.to_dict()
        assert abs(row.Z_DEV_SIGMA) < 5, row.to_dict()
        # the exact rod result: Z = 1/(1 - eta) up to the walls' share (L - 2R)
        assert row.Z_THEORY == pytest.approx(1 / (1 - row.PACKING), rel=0.05)
        assert abs(row.RATE_DEV_SIGMA) < 5, row.to_dict()


def test_unknown_key_and_empty_database_are_one_line(rods_db, tmp_path):
    with Store(rods_db, create=False) as store:
        with pytest.raises(GazError, match="--vs 'colour' is not a key"):
            studies.versus(store, "colour")
    with Store(str(tmp_path / "empty.db")) as store:
        with pytest.raises(GazError, match="no simulation"):
            studies.versus(store, "packing")


def test_runs_recorded_without_bounces_add_no_pressure(rods_db, tmp_path):
    """Runs of record = "none" store no bounce: their pressure was averaged as 0 (two such runs
    beside eight took a third off P and Z); now they measure none, and still count for the
    collision rate."""
    import shutil

    db = str(tmp_path / "mixed.db")
    shutil.copyfile(rods_db, db)
    length = N * 2 * ARGON.radius / PACKINGS[0]
    for seed in (SEEDS + 1, SEEDS + 2):
        simulate(Scene(dim=1, length=length, duration=2e-10, components=((ARGON, N),), seed=seed,
                       record="none"), db=db)
    with Store(rods_db, create=False) as store:
        before = studies.versus(store, "packing").iloc[0]
    with Store(db, create=False) as store:
        after = studies.versus(store, "packing").iloc[0]
    assert after.RUNS == SEEDS + 2
    for name in ("P", "P_ERR", "P_THEORY", "P_DEV_SIGMA", "Z", "Z_ERR", "Z_THEORY"):
        assert after[name] == pytest.approx(before[name], rel=1e-12), name
    assert after.RATE != before.RATE  # the two runs' collisions are measured


def test_plot_draws_one_figure_per_dimension_and_boundary(rods_db, tmp_path):
    with Store(rods_db, create=False) as store:
        table = studies.versus(store, "packing")
    files = studies.plot(table, "packing", str(tmp_path / "figs"))
    assert len(files) == 1 and all(math.isfinite(z) for z in table.Z)
    assert (tmp_path / "figs" / "vs_packing_1d_walls.png").stat().st_size > 1000



def test_theory_curve_is_drawn_apart_from_every_data_series(two_scenes_db):
    """The Tonks curve was drawn in C1, the colour of the first series' theory markers, with the
    next series in C2, C3: the exact 1D theory looked like one of the series. Now theory curves
    take plots.THEORY (black, dashed), and each series one colour of the cycle."""
    import warnings

    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    from gaz_cli.analysis import plots

    with Store(two_scenes_db, create=False) as store, warnings.catch_warnings():
        warnings.simplefilter("ignore")          # the mixture left out, said in a warning
        table = studies.versus(store, "packing")
    fig = studies.figure(table, "packing")
    try:
        ax = fig.axes[0]
        tonks = [ln for ln in ax.get_lines() if ln.get_label().startswith("Tonks")]
        # (series name, colour) of the measured points (errorbar containers) and the theory markers
        measured = [(c.get_label().rsplit(":", 1)[0], to_rgba(c.lines[0].get_color())) for c in ax.containers]
        markers = [(ln.get_label().rsplit(":", 1)[0], to_rgba(ln.get_color())) for ln in ax.get_lines()
                   if ln.get_label().endswith(": theory")]
        scenes = table.SCENE.nunique()
        assert len(tonks) == 1 and len(measured) == len(markers) == scenes
        assert to_rgba(tonks[0].get_color()) == to_rgba(plots.THEORY["color"])
        assert tonks[0].get_linestyle() == plots.THEORY["ls"]
        assert all(color != to_rgba(tonks[0].get_color()) for _, color in measured + markers)
        # one colour per series: its measured points and its theory markers alike, each series its own
        assert dict(measured) == dict(markers) and len(set(dict(measured).values())) == scenes
    finally:
        plt.close(fig)

def test_a_plot_folder_that_cannot_be_made_is_one_line(rods_db, tmp_path):
    """gaz analyse --vs packing --plot FILE/sub ended in 'internal error: NotADirectoryError', exit 3,
    as gaz analyse --sim 1 --plot FILE/sub did not."""
    from cli_helpers import invoke

    (tmp_path / "afile").write_text("")
    res = invoke(["analyse", "--db", rods_db, "--vs", "packing", "--plot", str(tmp_path / "afile" / "sub")])
    assert (res.exit_code, res.stdout) == (1, "")
    assert res.stderr == f"gaz: error: cannot create --plot folder '{tmp_path / 'afile' / 'sub'}': Not a directory\n"


def test_vs_csv_is_read_by_pandas_as_is(rods_db):
    """gaz analyse --vs packing --format csv began with a '# against packing' line, which
    pandas.read_csv took for the header of one column ('--table' is refused with --vs)."""
    import io

    import pandas as pd
    from cli_helpers import invoke

    res = invoke(["analyse", "--db", rods_db, "--vs", "packing", "--format", "csv"])
    assert res.exit_code == 0, res.stderr
    frame = pd.read_csv(io.StringIO(res.stdout))
    assert list(frame.columns[:4]) == ["DIM", "BOUNDARY", "PACKING", "RUNS"] and len(frame) == len(PACKINGS)
    assert frame.P.dtype.kind == "f"


def test_dense_disks_against_walls_say_no_theory(tmp_path):
    """2D disks at packing 0.4 between walls: the first-order wall theory's own error exceeds
    the error bar, so no deviation in sigma is printed -- the reason is in NOTE."""
    db = str(tmp_path / "walls.db")
    length = (100 * math.pi * ARGON.radius ** 2 / 0.4) ** 0.5
    for seed in (1, 2):
        simulate(Scene(dim=2, length=length, duration=2e-11, components=((ARGON, 100),), seed=seed,
                       record="all", engine="event"), db=db)
    with Store(db, create=False) as store:
        row = studies.versus(store, "packing").iloc[0]
    assert row.SYST_REL > row.Z_ERR / row.Z_THEORY
    assert math.isnan(row.Z_DEV_SIGMA) and math.isnan(row.P_DEV_SIGMA) and "no theory" in row.NOTE


@pytest.fixture(scope="module")
def two_scenes_db(rods_db, tmp_path_factory):
    """rods_db (50 rods at packings 0.2 and 0.5, 8 seeds each) and, beside them, 20 rods at
    packing 0.2 and a mixture of 25 Ar and 25 He in the box of the first, 2 seeds each."""
    import shutil

    db = str(tmp_path_factory.mktemp("two") / "two.db")
    shutil.copyfile(rods_db, db)
    helium = BUILTIN["He"]
    for seed in (1, 2):
        simulate(Scene(dim=1, length=20 * 2 * ARGON.radius / PACKINGS[0], duration=2e-10,
                       components=((ARGON, 20),), seed=seed), db=db)
        simulate(Scene(dim=1, length=N * 2 * ARGON.radius / PACKINGS[0], duration=2e-10,
                       components=((ARGON, 25), (helium, 25)), seed=seed), db=db)
    return db


def test_runs_of_different_scenes_are_never_averaged_together(rods_db, two_scenes_db):
    """--vs temperature averaged every run at 300 K into one row (50 and 20 rods, packings 0.2
    and 0.5, a mixture: 20 'seeds' of 4 scenes); --vs packing put the 20 rods in the 50 rods'
    row at 0.2 and dropped the mixture without a word. Now one row per scene and value, a
    column SCENE saying what differs; a sweep of one scene keeps its table as it was."""
    from gaz_cli.errors import GazWarning

    with Store(rods_db, create=False) as store:
        alone = studies.versus(store, "packing")
    assert "SCENE" not in alone and list(alone.RUNS) == [SEEDS, SEEDS]
    with Store(two_scenes_db, create=False) as store:
        hot = studies.versus(store, "temperature")
        with pytest.warns(GazWarning, match=r"--vs packing: 2 of 20 runs left out, having no packing: a mixture"):
            dense = studies.versus(store, "packing")
    assert sorted(hot.RUNS) == [2, 2, SEEDS, SEEDS] and hot.SCENE.nunique() == 4
    assert set(hot.TEMPERATURE) == {300.0}
    mixture = hot[hot.SCENE.str.contains("Ar:25,He:25")]
    assert len(mixture) == 1 and mixture.RUNS.iloc[0] == 2
    assert sorted(zip(dense.SCENE, dense.PACKING.round(6), dense.RUNS)) == [
        ("n=20", 0.2, 2), ("n=50", 0.2, SEEDS), ("n=50", 0.5, SEEDS)]
    fifty = dense[dense.SCENE == "n=50"].reset_index(drop=True)
    for name in ("P", "Z", "RATE", "Z_THEORY"):  # the 50 rods' rows as when they were alone
        assert list(fifty[name]) == pytest.approx(list(alone[name]), rel=1e-12), name


def test_analyse_vs_says_in_one_line_how_many_runs_it_left_out(two_scenes_db, tmp_path):
    from cli_helpers import invoke

    res = invoke(["analyse", "--db", two_scenes_db, "--vs", "packing", "--format", "csv", "--plot",
                  str(tmp_path / "figs")])
    assert res.exit_code == 0, res.stderr
    assert res.stderr.strip().splitlines() == [
        "gaz: warning: --vs packing: 2 of 20 runs left out, having no packing: a mixture has no single "
        "packing fraction (its species differ in size)"]
    assert (tmp_path / "figs" / "vs_packing_1d_walls.png").stat().st_size > 1000


def test_n_is_printed_as_a_whole_number(rods_db):
    """gaz analyse --vs n printed N as 50.0 (table, csv and json); it is a count: 50."""
    import json

    from cli_helpers import invoke

    res = invoke(["analyse", "--db", rods_db, "--vs", "n", "--format", "json"])
    assert res.exit_code == 0, res.stderr
    rows = json.loads(res.stdout)["against n"]  # two rows: 50 rods at two packings
    assert [row["N"] for row in rows] == [50, 50] and all(isinstance(row["N"], int) for row in rows)
    for fmt in ("csv", "table"):
        res = invoke(["analyse", "--db", rods_db, "--vs", "n", "--format", fmt])
        assert res.exit_code == 0 and " 50 " in res.stdout.replace(",", " ") and "50.0" not in res.stdout, res.stdout


def test_vs_n_makes_one_series_per_packing_or_per_box(two_scenes_db, tmp_path):
    """--vs n over 50 rods at packings 0.2 and 0.5 and 20 rods at 0.2 gave three rows told apart
    by their box sides ('length=1.79e-08', ...), one point each: the box of a sweep of n at a
    packing held grows with n. Now the series hold the packing (a sweep of n at a box held: the
    box), whichever makes fewer series: 20 and 50 rods at 0.2 are one series."""
    import warnings

    with Store(two_scenes_db, create=False) as store, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = studies.versus(store, "n")
    rods = table[~table.SCENE.str.contains("He")]       # the mixture: a series of its own
    assert sorted(zip(rods.SCENE, rods.N)) == [("species=Ar packing=0.2", 20), ("species=Ar packing=0.2", 50),
                                               ("species=Ar packing=0.5", 50)]
    # a sweep of n in one box: one series (no SCENE column), whose packing grows with n
    db = str(tmp_path / "box.db")
    for n in (20, 40):
        for seed in (1, 2):
            simulate(Scene(dim=1, length=20 * 2 * ARGON.radius / 0.2, duration=2e-10,
                           components=((ARGON, n),), seed=seed), db=db)
    with Store(db, create=False) as store:
        box = studies.versus(store, "n")
    assert "SCENE" not in box and list(box.N) == [20, 40] and list(box.RUNS) == [2, 2]


def test_runs_under_gravity_get_no_uniform_theory(tmp_path):
    """--vs temperature over 24 runs of argon under gravity (3D, g = 1e12 m/s^2) printed Z_DEV_SIGMA
    31 and RATE_DEV_SIGMA 15 against the uniform gas's theories: the gas is stratified. Now no
    theory, the reason in NOTE (gaz analyse --sim N has the barometric one)."""
    db = str(tmp_path / "g.db")
    for seed in (1, 2):
        simulate(Scene(dim=1, length=N * 2 * ARGON.radius / 0.2, duration=2e-10, components=((ARGON, N),),
                       gravity=1e13, seed=seed), db=db)
    with Store(db, create=False) as store:
        row = studies.versus(store, "temperature").iloc[0]
    assert row.RUNS == 2 and math.isfinite(row.P) and math.isfinite(row.RATE)
    for name in ("P", "Z", "RATE"):
        assert math.isnan(row[f"{name}_THEORY"]) and math.isnan(row[f"{name}_DEV_SIGMA"]), row
    assert "gravity" in row.NOTE and "--sim" in row.NOTE


def test_runs_with_extra_plane_walls_are_a_scene_of_their_own_without_theory(tmp_path):
    """--vs grouped a run with an extra plane wall with the same scene without it (planes were
    no scene setting) and compared both with the box's theory. Now the plane's runs make a row
    of their own, with no theory and the reason in NOTE; the run without keeps its theory."""
    from test_analysis_forces import _front_of_plane

    db = str(tmp_path / "p.db")
    state = _front_of_plane(n=36)
    for planes in ((), (((5e-8, 0.0), (1.0, 0.0), 1.0),)):
        simulate(Scene(dim=2, length=1e-7, duration=1e-11, components=((ARGON, 36),), engine="step",
                       dt=1e-13, seed=1, planes=planes, initial=state), db=db)
    with Store(db, create=False) as store:
        table = studies.versus(store, "temperature")
    assert len(table) == 2 and list(table.RUNS) == [1, 1], table
    with_plane = table[table.NOTE.str.contains("plane", na=False)]
    assert len(with_plane) == 1 and math.isnan(with_plane.iloc[0].P_THEORY), table
    assert math.isfinite(table[~table.index.isin(with_plane.index)].iloc[0].P_THEORY), table
