"""gaz_cli.analysis.report and gaz_cli.analysis.plots on data with known answers (fast; no engine needed).

The databases here are written through the store's own writer with
synthetic wall hits of an ideal gas drawn from the flux-weighted laws of
physics.md section 6 (Poisson hits per wall at the rate P A / sqrt(2 pi m kT),
Rayleigh normal speeds, Gaussian tangential ones), so that every number
analysis reports has a known expectation.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from gaz_cli import theory
from gaz_cli.analysis import comparisons
from gaz_cli.analysis import estimators
from gaz_cli.analysis import figures
from gaz_cli.analysis import placements
from gaz_cli.analysis import report as analysis
from gaz_cli.analysis import stored
from gaz_cli.analysis import errorbars
from gaz_cli.constants import K_B
from gaz_cli.errors import StoreError
from gaz_cli.model.recording import RunStats
from gaz_cli.model.scene import Scene, State
from gaz_cli.model.species import Species
from gaz_cli.results.store import Store

from cli_helpers import invoke

MASS, RADIUS, TEMPERATURE = 6.6e-26, 1.8e-10, 300.0        # an argon-like particle, kg, m, K


# --------------------------------------------------------------------- block statistics


def test_block_sums_put_each_event_in_its_window():
    t = np.array([0.0, 0.24, 0.25, 0.5, 0.99, 1.0])
    assert estimators.block_sums(t, 1.0, 1.0, 4).tolist() == [2, 1, 1, 2]   # t = duration: last window
    assert estimators.block_sums(t, np.arange(6.0), 1.0, 4).tolist() == [1, 2, 3, 9]
    means = estimators.block_means(np.array([0.1, 0.2, 0.9]), np.array([1.0, 3.0, 5.0]), 1.0, 3)
    assert means[0] == 2.0 and math.isnan(means[1]) and means[2] == 5.0


def test_mean_and_error_drops_nan_and_needs_two_blocks():
    assert estimators.mean_and_error([1.0, 3.0, np.nan]) == (2.0, pytest.approx(1.0))
    m, e = estimators.mean_and_error([4.0])
    assert m == 4.0 and math.isnan(e)


def test_block_error_of_a_compound_poisson_pressure():
    """Hits at rate lam with impulses of mean mu: the block error estimates sqrt(lam E[J^2]/tau).

    Over 400 synthetic runs the mean block error is within 5% of the exact
    standard deviation of the estimate, and |estimate - truth| < 2 errors
    about as often as Student's t with 15 degrees of freedom says (93.6%).
    """
    rng = np.random.default_rng(2024)
    lam, mu, tau, blocks, runs = 2000.0, 3.0, 5.0, 16, 400
    exact_sd = math.sqrt(lam * 2 * mu * mu / tau)     # exponential impulses: E[J^2] = 2 mu^2
    errors, inside = [], 0
    for _ in range(runs):
        k = rng.poisson(lam * tau)
        t = np.sort(rng.random(k) * tau)
        j = rng.exponential(mu, size=k)
        rates = estimators.block_sums(t, j, tau, blocks) / (tau / blocks)
        mean, err = estimators.mean_and_error(rates)
        assert mean == pytest.approx(j.sum() / tau, rel=1e-12)   # the blocks' mean is the run's mean
        errors.append(err)
        inside += abs(mean - lam * mu) < 2 * err
    assert np.mean(errors) == pytest.approx(exact_sd, rel=0.05)
    assert 0.90 < inside / runs < 0.97


# --------------------------------------------------------------------- synthetic runs


def ideal_hits(rng, dim, n, length, duration, temperature, mass, radius, gravity=0.0):
    """Synthetic wall hits of a non-interacting gas in equilibrium: (t, wall, speed, vperp) arrays."""
    kt = K_B * temperature
    scale = math.sqrt(kt / mass)
    side = theory.ideal_wall_pressure(dim, length, temperature, n, radius)
    if gravity > 0:
        floor, ceiling = theory.ideal_gravity_wall_pressures(dim, length, temperature, n, radius, mass, gravity)
    out = []
    for d in range(dim):
        for sign in (-1, 1):
            p = side
            if gravity > 0 and d == dim - 1:
                p = floor if sign < 0 else ceiling
            expected = p * length ** (dim - 1) * duration / math.sqrt(2 * math.pi * mass * kt)
            k = rng.poisson(expected)
            vperp = rng.rayleigh(scale, size=k)
            tang = rng.normal(0.0, scale, size=(k, dim - 1))
            speed = np.sqrt(vperp ** 2 + np.sum(tang ** 2, axis=1))
            out.append((rng.random(k) * duration, np.full(k, sign * (d + 1)), speed, vperp))
    t, wall, speed, vperp = (np.concatenate(a) for a in zip(*out))
    order = np.argsort(t)
    return t[order], wall[order], speed[order], vperp[order]


def write_synthetic(db, dim=2, n=400, length=2e-7, duration=2e-9, seed=1, gravity=0.0, species=None):
    """One simulation of synthetic ideal-gas hits in ``db``; returns its SI_NUM."""
    rng = np.random.default_rng(seed)
    sp = species or Species("Ar", MASS, RADIUS)
    scene = Scene(dim=dim, length=length, duration=duration, components=((sp, n),),
                  temperature=TEMPERATURE, seed=seed, gravity=gravity)
    t, wall, speed, vperp = ideal_hits(rng, dim, n, length, duration, TEMPERATURE, sp.mass, sp.radius, gravity)
    ke = 0.5 * dim * n * K_B * TEMPERATURE
    with Store(db) as store, store.simulation(scene) as writer:
        particle = rng.integers(0, n, size=t.size)
        for chunk in np.array_split(np.arange(t.size), 3):
            writer.add_bounces(t[chunk], particle[chunk], wall[chunk], speed[chunk], vperp[chunk])
        final = State(np.zeros((n, dim)), np.zeros((n, dim)), np.zeros(n, dtype=np.int64))
        # independent hits are those of a gas whose particles collide often: claim 1000
        # collisions per particle, so that no initial draw is frozen (errorbars)
        writer.finish(RunStats(events=int(t.size), wall_bounces=int(t.size), collisions=500 * n,
                               wall_time_s=1.0, final=final), ke, ke)
        return writer.si_num


@pytest.fixture
def synthetic_db(tmp_path):
    db = str(tmp_path / "synthetic.db")
    write_synthetic(db, dim=2, seed=1)
    write_synthetic(db, dim=3, n=1000, length=1e-7, duration=1e-9, seed=2)
    return db


def test_report_on_an_ideal_gas_agrees_with_theory(synthetic_db):
    frames = analysis.report(synthetic_db, sim=2)
    walls = frames["Q36 momentum and pressure per wall"]
    assert walls.RE_DIR.tolist() == [-3, -2, -1, 1, 2, 3]
    # synthetic hits are independent on every wall, unlike a gas, whose momentum makes the
    # difference of opposite walls bounded (errorbars use that): compare the axis sums
    by_wall = walls.set_index("RE_DIR")
    for d in (1, 2, 3):
        pair = by_wall.loc[[-d, d]]
        err = math.sqrt(float((pair.P_ERR ** 2).sum()))     # >= the sum's error (half-sum + half-difference)
        assert abs(pair.P_MEASURED.sum() - pair.P_THEORY.sum()) < 3.5 * 2 * err, pair
    # relative error per wall, for independent hits, ~ 1/sqrt(hits) times the spread of the impulses,
    # sqrt(4/pi), over sqrt(2) (half the sum of two walls' independent noises). A gas's hits are not
    # independent: over these three crossings a particle hitting one wall hits the other next, and the
    # errors subtract the known end terms (errorbars.end_variance) the synthetic hits lack: the error
    # here may be smaller than the white-noise value, never much larger, and not below the ends' own
    hits = walls.NB_REBONDS.to_numpy()
    rel = walls.P_ERR.to_numpy() / walls.PRESSION.to_numpy()
    white = np.sqrt(4 / math.pi / hits / 2)
    assert np.all(rel < 1.3 * white), (rel, white)
    ends = 0.5 * math.sqrt(errorbars.end_variance(1000 * MASS * K_B * TEMPERATURE, 0.5e-7, 1e-9, 1e-14, 1)
                           + 2 * 1000 * MASS * K_B * TEMPERATURE / (1e-9 * 1e-14) ** 2)
    np.testing.assert_array_less(0.99 * ends, walls.P_ERR.to_numpy())
    pressure = frames["pressure against theory"]
    ideal = pressure[pressure.MODEL.str.startswith("ideal gas at walls")].iloc[0]
    assert abs(ideal.DEV_SIGMA) < 3
    assert ideal.P_THEORY == pytest.approx(
        theory.ideal_wall_pressure(3, 1e-7, TEMPERATURE, 1000, RADIUS), rel=1e-12, abs=0)
    speed = frames["mean wall-hit speed against theory"].iloc[0]
    assert abs(speed.DEV_SIGMA) < 3
    assert speed.THEORY == pytest.approx(theory.wall_hit_mean_speed(3, TEMPERATURE, MASS, 3 * 1000), rel=1e-12)
    sim = frames["simulation"]
    assert sim["T_KIN_K"] == pytest.approx(TEMPERATURE, rel=1e-12)
    # collisions without CHOC rows: the rate, a positive theory, no error bar and no deviation
    coll = frames["collision rate against Enskog"].iloc[0]
    assert coll.RATE_PER_PARTICLE_HZ == pytest.approx(1000 / 1e-9) and coll.THEORY_HZ > 0
    assert math.isnan(coll.RATE_ERR_HZ) and math.isnan(coll.DEV_SIGMA) and "--record all" in coll.NOTE


def test_report_sees_a_wrong_pressure(tmp_path):
    """The same hits read with the wrong mass: the pressure is now off by many sigma."""
    db = str(tmp_path / "wrong.db")
    write_synthetic(db, dim=2, n=2000, seed=3)
    # claim the particles are 30% heavier than the ones the hits were drawn for
    with Store(db).engine.begin() as conn:
        conn.exec_driver_sql("UPDATE PARTICULE SET PA_M = PA_M * 1.3 WHERE PA_NOM = 'Ar'")
    row = analysis.report(db, sim=1)["pressure against the ideal gas"].iloc[0]
    # DEV_SIGMA is Student's t as a normal deviate: its far tail grows slower than t
    assert row.DEV_SIGMA > 5 and row.P_MEASURED / row.P_THEORY - 1 > 5 * row.P_ERR / row.P_THEORY, row


def test_gravity_force_balance_and_profile(tmp_path):
    db = str(tmp_path / "gravity.db")
    g = K_B * TEMPERATURE / (MASS * 1e-7)      # scale height 1e-7 m, half the box
    # the synthetic hits are those of an ideal gas: points (R -> 0), so that the hard-disk excess vanishes
    write_synthetic(db, dim=2, n=3000, length=2e-7, duration=4e-9, seed=4, gravity=g,
                    species=Species("Ar", MASS, 1e-14))
    frames = analysis.report(db, sim=1, plot_dir=str(tmp_path / "fig"))
    force = frames["force balance under gravity"]
    balance = force.iloc[0]
    assert balance.THEORY == pytest.approx(3000 * MASS * g, rel=1e-12, abs=0)
    assert abs(balance.DEV_SIGMA) < 3, force
    assert abs(force.iloc[1].DEV_SIGMA) < 3, force
    walls = frames["Q36 momentum and pressure per wall"]
    assert (walls.DEV_SIGMA.abs() < 3.5).all(), walls
    # the profile rebuilt from the floor hits follows the barometric law
    run = stored.load_run(Store(db, create=False), 1)
    prof = figures.gravity_profile(run, TEMPERATURE, bins=20)
    area = np.diff(np.linspace(1e-14, 2e-7 - 1e-14, 21))
    assert np.sum(prof["expected"] * area) == pytest.approx(3000, rel=1e-3)   # midpoint rule
    np.testing.assert_allclose(prof["measured"], prof["expected"], rtol=0.06)
    drawn = frames["figures"]
    assert "density profile" in " ".join(drawn.FIGURE)


def test_a_gravity_run_shorter_than_its_fall_is_analysed_with_a_note(tmp_path):
    """A run under gravity shorter than one fall time across the box (all of it is the fall:
    2D, L = 1e-7 m, g = 1e12 m/s^2, 1e-10 s; the marbles preset for 0.5 s) ended gaz analyse in
    'internal error: ZeroDivisionError: float division by zero', exit 3, with or without --sim:
    one such run stopped the analysis of every run in the database."""
    db = str(tmp_path / "fall.db")
    for args in (["--gravity", "1e12"], []):
        res = invoke(["simulate", "--dim", "2", "--n", "40", "--length", "1e-7", "--duration", "1e-10",
                      "--seed", "9", "--db", db, "--engine", "event", "--quiet", *args])
        assert res.exit_code == 0, res.stderr
    for args in (["--sim", "1"], []):
        res = invoke(["analyse", "--db", db, "--format", "json", *args])
        assert res.exit_code == 0 and res.stderr == "", res.stderr
    overview = json.loads(res.stdout)["pressure against the ideal gas"]
    assert overview[0]["P_MEASURED"] is None and "did not settle" in overview[0]["NOTE"]
    assert overview[1]["P_MEASURED"] > 0


def test_mixture_weights_the_theory_by_hit_shares(tmp_path):
    """Two species: Q35's mean over all hits is the hit-share-weighted mean of the species' means."""
    db = str(tmp_path / "mix.db")
    rng = np.random.default_rng(5)
    heavy, light = Species("Ar", MASS, RADIUS), Species("He", MASS / 10, 1.3e-10)
    dim, length, duration = 2, 2e-7, 2e-9
    scene = Scene(dim=dim, length=length, duration=duration, components=((heavy, 300), (light, 300)),
                  temperature=TEMPERATURE, seed=5)
    parts = []
    for k, sp in enumerate((heavy, light)):
        t, wall, speed, vperp = ideal_hits(rng, dim, 300, length, duration, TEMPERATURE, sp.mass, sp.radius)
        parts.append((t, rng.integers(0, 300, t.size) + 300 * k, wall, speed, vperp))
    t, particle, wall, speed, vperp = (np.concatenate(a) for a in zip(*parts))
    order = np.argsort(t)
    ke = 0.5 * dim * 600 * K_B * TEMPERATURE
    with Store(db).simulation(scene) as writer:
        writer.add_bounces(t[order], particle[order], wall[order], speed[order], vperp[order])
        writer.finish(RunStats(events=t.size, wall_bounces=t.size, collisions=500 * 600, wall_time_s=1.0,
                               final=State(np.zeros((600, 2)), np.zeros((600, 2)), np.zeros(600, int))), ke, ke)
    frames = analysis.report(db, sim=1)
    speeds = frames["mean wall-hit speed against theory"]
    assert speeds.SPECIES.tolist() == ["Ar", "He", "all (Q35)"]
    assert (speeds.DEV_SIGMA.abs() < 3).all(), speeds
    q35 = frames["Q35 wall bounces and mean speed of wall hits"].iloc[0]
    assert speeds.iloc[2].VITESSE_MOYENNE == pytest.approx(q35.VITESSE_MOYENNE, rel=1e-12)
    # a 2D mixture: no equation of state here, said so, and the ideal gas follows
    first = frames["pressure against theory"].iloc[0]
    assert first.MODEL.startswith("mixture") and math.isnan(first.P_THEORY) and "2D" in first.NOTE
    assert frames["pressure against theory"].iloc[1].MODEL.startswith("ideal gas")
    assert math.isnan(frames["collision rate against Enskog"].iloc[0].THEORY_HZ)


def test_theory_beyond_its_range_is_na_not_an_error(tmp_path):
    """A 2D wall scene denser than the Kolafa-Rottner fit's range: the model says n/a."""
    db = str(tmp_path / "dense.db")
    n, length = 400, 1e-8
    radius = math.sqrt(0.70 * length ** 2 / (n * math.pi))      # eta = 0.70, beyond 0.691
    write_synthetic(db, dim=2, n=n, length=length, duration=1e-11, seed=6,
                    species=Species("big", MASS, radius))
    frames = analysis.report(db, sim=1)
    row = frames["pressure against theory"].iloc[0]
    assert math.isnan(row.P_THEORY) and math.isnan(row.DEV_SIGMA)
    assert "packing fraction" in row.NOTE
    assert math.isnan(frames["collision rate against Enskog"].iloc[0].THEORY_HZ)


def test_tc_elastic_matches_a_loop():
    rng = np.random.default_rng(8)
    k, n, tc = 3000, 40, 0.002
    t = np.sort(rng.random(k))
    i = rng.integers(0, n, k)
    j = (i + rng.integers(1, n, k)) % n
    last = np.full(n, -np.inf)
    expected = np.zeros(k, dtype=bool)
    for c in range(k):
        expected[c] = t[c] - last[i[c]] < tc or t[c] - last[j[c]] < tc
        last[i[c]] = last[j[c]] = t[c]
    got = comparisons.tc_elastic(t, i, j, tc)
    assert got.tolist() == expected.tolist() and 0 < got.sum() < k
    assert not comparisons.tc_elastic(t, i, j, 0.0).any()


# --------------------------------------------------------------------- formats and errors


def test_formats_carry_the_same_numbers(synthetic_db):
    code, out_json, _ = invoke(["analyse", "--db", synthetic_db, "--sim", "1", "--format", "json"])
    assert code == 0
    data = json.loads(out_json)
    code, out_csv, _ = invoke(["analyse", "--db", synthetic_db, "--sim", "1", "--format", "csv"])
    assert code == 0
    code, out_table, _ = invoke(["analyse", "--db", synthetic_db, "--sim", "1"])
    assert code == 0
    frames = analysis.report(synthetic_db, sim=1)
    assert set(data) == set(frames)
    for name in frames:
        assert f"# {name}" in out_csv and f"== {name} ==" in out_table
    # one frame read back from csv equals its json twin and the library's numbers
    block = out_csv.split("# pressure against theory\n")[1].split("\n# ")[0]
    from io import StringIO
    from_csv = pd.read_csv(StringIO(block))
    from_json = pd.DataFrame(data["pressure against theory"])
    lib = frames["pressure against theory"]
    for col in ("P_MEASURED", "P_ERR", "P_THEORY", "DEV_SIGMA"):
        np.testing.assert_allclose(from_csv[col].astype(float), lib[col].astype(float), rtol=1e-12)
        # cli.emit_frames writes JSON through pandas with 15 decimals: ~12 significant digits here
        np.testing.assert_allclose(from_json[col].astype(float), lib[col].astype(float), rtol=1e-10)
        assert f"{float(lib[col].iloc[0]):.6g}" in out_table
    assert data["simulation"]["SI_NUM"] == 1


def test_unknown_simulation_is_one_line(synthetic_db):
    code, out, err = invoke(["analyse", "--db", synthetic_db, "--sim", "9"])
    assert code != 0 and out == ""
    assert err.strip().count("\n") == 0 and "simulation 9 is not in" in err and "1-2" in err


def test_report_closes_the_database(synthetic_db):
    """gaz analyse left the SQLite file's -wal and -shm files beside it, on success and on a
    refusal (--sim 99): the store was never closed (measured from the command line)."""
    import os

    analysis.report(synthetic_db)
    with pytest.raises(StoreError):
        analysis.report(synthetic_db, sim=99)
    assert [f for f in os.listdir(os.path.dirname(synthetic_db)) if f != "synthetic.db"] == []


def test_overview_without_sim_has_one_row_per_simulation(synthetic_db):
    frames = analysis.report(synthetic_db)
    over = frames["pressure against the ideal gas"]
    assert over.SI_NUM.tolist() == [1, 2]
    assert {"P_ERR", "P_THEORY", "DEV_SIGMA", "THEORY"} <= set(over.columns)
    assert "simulation" not in frames


# --------------------------------------------------------------------- figures


def _is_png(path):
    with open(path, "rb") as fh:
        head = fh.read(8)
    return head == b"\x89PNG\r\n\x1a\n"


def test_plots_are_written(synthetic_db, tmp_path):
    out = tmp_path / "figs"
    frames = analysis.report(synthetic_db, sim=1, plot_dir=str(out))
    files = frames["figures"].FILE.tolist()
    assert len(files) == 3
    for f in files:
        assert _is_png(f) and (out / f.split("/")[-1]).stat().st_size > 20_000


def test_plot_dir_that_cannot_be_made_is_one_line(synthetic_db, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, _, err = invoke(["analyse", "--db", synthetic_db, "--sim", "1", "--plot", str(blocker / "sub")])
    assert code != 0 and err.strip().count("\n") == 0 and "--plot" in err


def test_placement_histogram_plot_with_exact_density(tmp_path):
    png = tmp_path / "q12.png"
    frame = placements.placement_histogram(1, 2, 1.0, 10.0, "rapid", 3, 2000, 20, plot=str(png))
    assert frame["count"].sum() == 4000
    assert _is_png(png) and png.stat().st_size > 20_000
    # the counts follow the exact density of the uniform placement (chi-square, 20 bins)
    edges = np.append(frame.bin_start.to_numpy(), 10.0)
    from scipy.integrate import quad
    prob = np.array([quad(lambda x: theory.rod_centre_density(x, 2, 1.0, 10.0), a, b)[0]
                     for a, b in zip(edges[:-1], edges[1:])])
    expected = 4000 * prob
    keep = expected > 5
    chi2 = np.sum((frame["count"].to_numpy()[keep] - expected[keep]) ** 2 / expected[keep])
    from scipy import stats
    assert stats.chi2.sf(chi2, keep.sum() - 1) > 1e-3


def test_per_wall_sums_from_the_bins_equal_the_exam_query(synthetic_db):
    """analyse adds up the database's per-bin sums; sql/pressure_per_wall.sql on the rows gives the same table."""
    frames = analysis.report(synthetic_db, sim=2)
    walls = frames["Q36 momentum and pressure per wall"]
    exam = Store(synthetic_db, create=False).query("pressure_per_wall", si_num=2)
    assert walls.RE_DIR.tolist() == exam.RE_DIR.tolist()
    assert walls.NB_REBONDS.tolist() == exam.NB_REBONDS.tolist()
    np.testing.assert_allclose(walls.PRESSION, exam.PRESSION, rtol=1e-12)
    q35 = Store(synthetic_db, create=False).query("q35_bounces_per_simulation").set_index("SI_NUM").loc[2]
    mine = frames["Q35 wall bounces and mean speed of wall hits"].iloc[0]
    assert mine.NB_REBONDS == q35.NB_REBONDS
    assert mine.VITESSE_MOYENNE == pytest.approx(q35.VITESSE_MOYENNE, rel=1e-12)


def test_csv_table_is_read_by_pandas_with_numeric_columns(tmp_path):
    """--table NAME prints one csv table; a value that does not exist is an empty cell, not text."""
    db = str(tmp_path / "dense.db")
    n, length = 400, 1e-8
    radius = math.sqrt(0.70 * length ** 2 / (n * math.pi))      # beyond the 2D fit: no theory value
    write_synthetic(db, dim=2, n=n, length=length, duration=1e-11, seed=6, species=Species("big", MASS, radius))
    from io import StringIO
    for table, numeric in (("pressure", ["P_MEASURED", "P_ERR", "P_THEORY", "DEV_SIGMA"]),
                           ("collisions", ["RATE_PER_PARTICLE_HZ", "RATE_ERR_HZ", "THEORY_HZ", "DEV_SIGMA"]),
                           ("q36", ["PRESSION", "P_ERR", "P_THEORY", "DEV_SIGMA"])):
        code, out, err = invoke(["analyse", "--db", db, "--sim", "1", "--format", "csv", "--table", table])
        assert code == 0, err
        frame = pd.read_csv(StringIO(out))
        for col in numeric:
            assert pd.api.types.is_float_dtype(frame[col]), (table, col, frame[col])
    assert frame.P_UNIT.tolist() == ["N/m"] * 4
    code, _, err = invoke(["analyse", "--db", db, "--table", "gravity"])
    assert code != 0 and err.count("\n") == 1 and "no table 'gravity'" in err


@pytest.mark.parametrize("extra, reason", [
    (["--engine", "reference", "--record", "none"], "its wall bounces were not recorded, --record none"),
    (["--engine", "reference", "--length", "1e-6", "--duration", "1e-14"], "no wall bounce in its 1e-14 s"),
    (["--engine", "event", "--boundary", "periodic"], "a periodic box has no wall bounce, and its pressure against time needs "
                                 "--record all"),
])
def test_plot_of_a_run_with_nothing_to_draw_says_so(tmp_path, extra, reason):
    """gaz analyse --sim N --plot DIR on a run without wall bounces wrote no figure and said
    nothing, exit 0. Now one warning line on stderr naming why, still exit 0; a run with
    bounces draws its figures without it."""
    db, figs = str(tmp_path / "gaz.db"), tmp_path / "figs"
    base = ["simulate", "--dim", "2", "--n", "10", "--length", "1e-7",
            "--duration", "1e-10", "--seed", "1", "--db", db]
    assert invoke([*base, *extra]).exit_code == 0
    res = invoke(["analyse", "--db", db, "--sim", "1", "--plot", str(figs), "--format", "json"])
    assert res.exit_code == 0 and json.loads(res.stdout), res.output
    assert res.stderr.splitlines() == [f"gaz: warning: --plot {figs}: nothing to draw for simulation 1: {reason}"]
    assert list(figs.iterdir()) == []
    assert invoke([*base, "--engine", "reference"]).exit_code == 0
    res = invoke(["analyse", "--db", db, "--sim", "2", "--plot", str(figs), "--format", "json"])
    assert res.exit_code == 0 and res.stderr == "" and len(list(figs.iterdir())) >= 2, res.output


def test_table_names_in_help_are_the_registry():
    """``gaz analyse --help`` names every table of the registry (analysis.TABLES), and no other."""
    import re

    from click.testing import CliRunner

    from gaz_cli import cli

    text = " ".join(CliRunner().invoke(cli.cli, ["analyse", "--help"]).output.split())
    listed = re.search(r"NAME: ([a-z0-9, ]+)\.", text).group(1).split(", ")
    assert listed == list(analysis.TABLES)
