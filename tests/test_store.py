"""The store: schema of the exam, bulk writes, atomic simulations, packaged SQL."""

import shutil
import sqlite3
import subprocess

import numpy as np
import pytest
import sqlalchemy as sa

from gaz_cli import store as st
from gaz_cli.errors import StoreError
from gaz_cli.recording import RunStats
from gaz_cli.scene import initial_state
from gaz_cli.species import BUILTIN, Species


def fake_bounces(rng, n_particles, dim, k, duration):
    t = np.sort(rng.random(k) * duration)
    particle = rng.integers(0, n_particles, k)
    axis = rng.integers(0, dim, k)
    wall = (axis + 1) * rng.choice([-1, 1], k)
    vperp = rng.random(k) * 500
    speed = vperp + rng.random(k) * 100
    return t, particle, wall, speed, vperp


def write_fake(store, scene, rng, k=5000, chunks=3):
    state = initial_state(scene)
    arrays = fake_bounces(rng, scene.n, scene.dim, k, scene.duration)
    with store.simulation(scene) as w:
        for part in np.array_split(np.arange(k), chunks):
            w.add_bounces(*(a[part] for a in arrays))
        w.finish(RunStats(k, k, 0, 0.1, state), 1.0, 1.0)
    return w.si_num, arrays


def test_exam_tables_exactly(tmp_path):
    store = st.Store(str(tmp_path / "a.db"))
    insp = sa.inspect(store.engine)
    cols = {t: [c["name"].upper() for c in insp.get_columns(t)] for t in st.EXAM_TABLES}
    assert cols["simulation"] == ["SI_NUM", "SI_DEB", "SI_DUR", "SI_DIM", "SI_N", "SI_L"]
    assert cols["particule"] == ["PA_NUM", "PA_NOM", "PA_M", "PA_R"]
    assert cols["rebond"] == ["SI_NUM", "RE_NUM", "PA_NUM", "RE_T", "RE_DIR", "RE_VIT", "RE_VP"]
    assert insp.get_pk_constraint("rebond")["constrained_columns"] == ["si_num", "re_num"]
    fks = {fk["referred_table"] for fk in insp.get_foreign_keys("rebond")}
    assert fks == {"simulation", "particule"}
    particles = store.table(st.particule)
    assert list(particles.PA_NOM) == list(BUILTIN)
    ar = particles[particles.PA_NOM == "Ar"].iloc[0]
    assert ar.PA_M == pytest.approx(6.6338e-23, rel=1e-4, abs=0)  # grams


def test_rows_written_and_q36_matches_python(tmp_path, argon_scene, rng):
    store = st.Store(str(tmp_path / "a.db"))
    scene = argon_scene(dim=3, n=50)
    si, (t, particle, wall, speed, vperp) = write_fake(store, scene, rng)
    rows = store.table(st.rebond, si)
    assert len(rows) == len(t)
    assert list(rows.RE_NUM) == list(range(1, len(t) + 1))
    assert np.allclose(rows.RE_T, t, rtol=1e-15, atol=0) and np.array_equal(rows.RE_DIR, wall)
    q36 = store.query("q36_momentum_per_wall", si_num=si)
    m = BUILTIN["Ar"].mass
    for code, value in zip(q36.RE_DIR, q36.QUANTITE_MOUVEMENT):
        expected = np.sum(2 * m * vperp[wall == code])
        assert value == pytest.approx(expected, rel=1e-12, abs=0)
    pressure = store.query("pressure_per_wall", si_num=si)
    area = scene.length ** 2
    assert np.allclose(pressure.PRESSION, pressure.QUANTITE_MOUVEMENT / (scene.duration * area), rtol=1e-12, atol=0)


def test_failed_run_leaves_nothing(tmp_path, argon_scene, rng):
    store = st.Store(str(tmp_path / "a.db"))
    scene = argon_scene(dim=2, n=20, length=1e-7)
    write_fake(store, scene, rng)
    with pytest.raises(KeyboardInterrupt):
        with store.simulation(scene) as w:
            w.add_bounces(*fake_bounces(rng, 20, 2, 100, 1.0))
            raise KeyboardInterrupt
    assert store.simulation_numbers() == [1]
    assert len(store.table(st.rebond)) == 5000
    assert len(store.table(st.composition)) == 1


def test_custom_species_gets_one_row(tmp_path, argon_scene):
    store = st.Store(str(tmp_path / "a.db"))
    custom = Species("custom", 2e-26, 1e-10)
    from dataclasses import replace
    scene = replace(argon_scene(dim=2, n=10, length=1e-7), components=((custom, 10),))
    for _ in range(2):
        with store.simulation(scene) as w:
            w.finish(RunStats(0, 0, 0, 0.0, initial_state(scene)), 0.0, 0.0)
    particles = store.table(st.particule)
    assert (particles.PA_NOM == "custom").sum() == 1


def test_open_errors(tmp_path):
    with pytest.raises(StoreError, match="does not exist"):
        st.Store(str(tmp_path / "missing.db"), create=False)
    junk = tmp_path / "junk.db"
    junk.write_text("hello")
    with pytest.raises(StoreError, match="not a database"):
        st.Store(str(junk), create=False)
    other = tmp_path / "other.db"
    sqlite3.connect(other).execute("CREATE TABLE t (x)").connection.commit()
    with pytest.raises(StoreError, match="not a gaz database"):
        st.Store(str(other), create=False)
    with pytest.raises(StoreError):
        st.Store("nosuchdialect://x/y")


def test_sql_files_are_packaged():
    names = st.query_names()
    assert {"q34_simulations_per_dimension.sql", "q35_bounces_per_simulation.sql",
            "q36_momentum_per_wall.sql", "pressure_per_wall.sql"} <= set(names)


@pytest.mark.skipif(shutil.which("sqlite3") is None, reason="the sqlite3 shell is not installed")
def test_sqlite3_shell_runs_every_file(tmp_path, argon_scene, rng):
    db = tmp_path / "a.db"
    store = st.Store(str(db))
    si, _ = write_fake(store, argon_scene(dim=3, n=50), rng, k=300)
    for name in st.query_names():
        sql_path = tmp_path / name
        sql_path.write_text(st.query_text(name))
        out = subprocess.run(["sqlite3", "-csv", str(db), f".param set :si_num {si}", f".read {sql_path}"],
                             capture_output=True, text=True, timeout=60)
        assert out.returncode == 0 and not out.stderr, (name, out.stderr)
        assert out.stdout.strip(), name
    q36 = subprocess.run(["sqlite3", "-csv", str(db), f".param set :si_num {si}",
                          f".read {tmp_path / 'q36_momentum_per_wall.sql'}"], capture_output=True, text=True)
    assert len(q36.stdout.strip().splitlines()) == 6  # six walls in 3D
