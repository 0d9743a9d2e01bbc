"""One mapping from a run to its rows (gaz_cli.results.rows), used by both writers: the SQLite
writer (gaz_cli.results.sqlite) and the PostgreSQL writer (through SQLAlchemy and COPY) store
the same rows for the same runs, in every table.

Each scene runs once (its engine's arrays kept in memory); its arrays and results are then
handed to a writer in the same chunks, with the same start time, so that every column can be
compared exactly, the engine's wall time included. On SQLite the rows are checked against the
run's arrays and the mapping itself; on PostgreSQL (see backends.py) against the SQLite file's.
"""

from __future__ import annotations

import datetime as _dt

import numpy as np
import pandas as pd
import pytest

from backends import postgres_db, postgres_url  # noqa: F401 - fixtures
from gaz_cli.model import recording
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import Species, lookup
from gaz_cli.results import rows
from gaz_cli.results import writer
from gaz_cli.results import store as st
from gaz_cli.run.runner import run_scene

STARTED = _dt.datetime(2026, 11, 28, 7, 30, 15, 123456)
"""Every run's SI_DEB (to the microsecond: both writers keep it)."""

TABLES = ("simulation", "particule", "composition", "scene", "resultat", "rebond", "choc", "profil")

CUSTOM = Species("Marble", 2.5e-26, 1.6e-10)
"""A species of no built-in name: a PARTICULE row of its own, added by the run's writer."""


def _scenes() -> list[Scene]:
    """A mixture in walls, a periodic mixture, gravity; every row recorded (collisions too)."""
    mixture = ((lookup("Ar"), 20), (lookup("He"), 10))
    return [
        Scene(dim=2, length=1e-7, duration=1e-9, seed=3, record="all", components=mixture),
        Scene(dim=3, length=3e-9, duration=3e-11, seed=5, record="all", boundary="periodic",
              components=((lookup("Kr"), 12), (CUSTOM, 12))),
        Scene(dim=2, length=1e-8, duration=2e-11, seed=7, record="all", gravity=1e12,
              components=((CUSTOM, 10), (lookup("Ne"), 6))),
        # one species at walls, dense: a density profile (PROFIL)
        Scene(dim=2, length=7e-9, duration=2e-12, seed=9, components=((CUSTOM, 120),)),
    ]


def _samples(scene: Scene, k: int) -> list[np.ndarray]:
    """``k`` position samples (N, D) m of ``scene``, drawn uniformly in its box (any values: counted)."""
    rng = np.random.default_rng(11)
    return [rng.uniform(0.0, scene.length, (scene.n, scene.dim)) for _ in range(k)]


@pytest.fixture(scope="module")
def runs():
    """Each scene run once: (scene as run, bounces, collisions, stats, (ke_start, ke_end) J)."""
    out = []
    for scene in _scenes():
        run = run_scene(scene, keep_bounces=True, keep_collisions=True)
        ke = (1.5e-21, float(run.stats.final.kinetic_energy(run.scene.masses())))  # (any values: copied)
        out.append((run.scene, run.bounces, run.collisions, run.stats, ke))
    return out


def _write(store, runs, chunks: int = 3) -> list[int]:
    """Hand each run's arrays to ``store``'s writer in ``chunks`` chunks; its SI_NUMs."""
    numbers = []
    for scene, bounces, collisions, stats, ke in runs:
        with store.simulation(scene, STARTED) as w:
            for part in np.array_split(np.arange(len(bounces["t"])), chunks):
                w.add_bounces(*(bounces[k][part] for k in ("t", "particle", "wall", "speed", "vperp")))
            for part in np.array_split(np.arange(len(collisions["t"])), chunks):
                w.add_collisions(*(collisions[k][part] for k in ("t", "i", "j", "impulse")))
            for x in _samples(scene, w.profile_samples):
                w.add_profile_sample(0.0, x)
            w.finish(stats, *ke)
        numbers.append(w.si_num)
    return numbers


def _tables(db: str) -> dict[str, pd.DataFrame]:
    with st.Store(db, create=False) as store:
        return {t: store.table(st.metadata.tables[t]) for t in TABLES}


def test_the_runs_cover_what_the_writers_map(runs):
    """The scenes hold what this file claims: bounces and collisions, a mixture, a periodic
    box, gravity, a custom species."""
    assert all(len(b["t"]) > 0 for _, b, *_ in runs[:1] + runs[2:])
    assert all(len(c["t"]) > 0 for _, _, c, *_ in runs)
    assert [s.boundary for s, *_ in runs] == ["walls", "periodic", "walls", "walls"]
    assert runs[2][0].gravity > 0
    assert all(len(s.species) == 2 for s, *_ in runs[:3])
    assert [recording.profile_wanted(s) for s, *_ in runs] == [False, False, False, True]


def test_sqlite_rows_are_the_mapping_of_the_runs(runs, tmp_path):
    db = str(tmp_path / "gaz.db")
    st.Store(db).close()  # an existing file: the staged path
    with writer.open_for_writing(db) as store:
        numbers = _write(store, runs)
    fresh = str(tmp_path / "fresh.db")  # a new file: its first run's early insert, private file
    with writer.open_for_writing(fresh) as store:
        assert _write(store, runs) == numbers
    tables = _tables(db)
    for name, frame in _tables(fresh).items():
        pd.testing.assert_frame_equal(frame, tables[name], check_exact=True, obj=name)

    particule = tables["particule"]
    pa = {row.PA_NOM: row.PA_NUM for row in particule.itertuples()}
    assert particule[particule.PA_NOM == CUSTOM.name].to_dict("records") == [
        {"PA_NUM": pa[CUSTOM.name], "PA_NOM": CUSTOM.name, "PA_M": CUSTOM.mass_g, "PA_R": CUSTOM.radius}]
    for si, (scene, bounces, collisions, stats, ke) in zip(numbers, runs):
        nums = [pa[sp.name] for sp in scene.species]
        one = {name: frame[frame.SI_NUM == si].reset_index(drop=True) for name, frame in tables.items()
               if name != "particule"}
        expected = {
            "simulation": [{"si_num": si, **rows.simulation_row(scene, STARTED)}],
            "composition": rows.composition_rows(si, nums, scene),
            "scene": [rows.scene_row(si, scene)],
            "resultat": [rows.result_row(si, stats, *ke)],
            "profil": rows.profile_rows(si, _profile(scene)),
        }
        for name, records in expected.items():
            found = [{k.lower(): v for k, v in r.items()} for r in one[name].to_dict("records")]
            found = [{k: (None if isinstance(v, float) and np.isnan(v) else v) for k, v in r.items()}
                     for r in found]
            assert found == records, name
        k = len(bounces["t"])
        rebond = one["rebond"]
        assert list(rebond.RE_NUM) == list(range(1, k + 1))
        assert np.array_equal(rebond.PA_NUM, np.array(nums)[scene.kinds()[bounces["particle"]]])
        for column, key in (("RE_T", "t"), ("RE_DIR", "wall"), ("RE_VIT", "speed"), ("RE_VP", "vperp")):
            assert np.array_equal(rebond[column], bounces[key]), column
        choc = one["choc"]
        assert list(choc.CH_NUM) == list(range(1, len(collisions["t"]) + 1))
        for column, key in (("CH_T", "t"), ("CH_I", "i"), ("CH_J", "j"), ("CH_IMP", "impulse")):
            assert np.array_equal(choc[column], collisions[key]), column


def _profile(scene: Scene) -> recording.DensityProfile | None:
    """The density profile the writer kept of ``scene``'s samples (None where it takes none)."""
    if not recording.profile_wanted(scene):
        return None
    profile = recording.DensityProfile(scene.dim, scene.length)
    for x in _samples(scene, recording.PROFILE_SAMPLES):
        profile.add(x)
    return profile


def test_the_profile_counts_the_middle_tubes():
    """PROFIL's counts: along each axis, the centres whose other coordinates lie in the middle
    half, in 32 bins, summed over a block's samples (a hand-made sample of 3 particles in 2D)."""
    profile = recording.DensityProfile(2, 1.0, samples=128)
    x = np.array([[0.5, 0.5], [0.01, 0.6], [0.9, 0.1]])
    profile.add(x)
    profile.add(x)
    assert profile.samples[0] == 2 and profile.samples[1:].sum() == 0
    assert profile.counts[0, 0].tolist() == [2 if k in (0, 16) else 0 for k in range(32)]  # y in the middle
    assert profile.counts[1, 0].tolist() == [2 if k == 16 else 0 for k in range(32)]      # x in the middle
    assert profile.counts[:, 1:].sum() == 0


@pytest.mark.postgres
def test_postgres_rows_are_the_sqlite_rows(runs, tmp_path, postgres_db):
    """The same runs through both writers: every table equal, row for row, column for column
    (the PostgreSQL writer's partitions attached at the commit, its COPY blocks built by numpy)."""
    db = str(tmp_path / "gaz.db")
    with writer.open_for_writing(db) as store:
        numbers = _write(store, runs)
    with st.Store(postgres_db) as store:
        assert _write(store, runs) == numbers
    lite, pg = _tables(db), _tables(postgres_db)
    for name in TABLES:
        a = lite[name].sort_values(list(lite[name].columns[:2])).reset_index(drop=True)
        b = pg[name].sort_values(list(pg[name].columns[:2])).reset_index(drop=True)
        pd.testing.assert_frame_equal(a, b, check_exact=True, check_dtype=False, obj=name)


def test_the_profile_samples_change_no_event():
    """The event engine stops at each of the 256 sample times to hand the positions over
    (Recorder.profile_samples): the run's bounces, collisions and final state are the same,
    bit for bit, as without the stops."""
    from gaz_cli.engines import event
    from gaz_cli.placement.initial import initial_state

    class Sampled(recording.MemoryRecorder):
        def __init__(self, samples):
            super().__init__(collisions=True)
            self.profile_samples, self.times = samples, []

        def add_profile_sample(self, t, positions):
            self.times.append(t)

    scene = Scene(dim=2, length=7e-9, duration=2e-12, seed=9, components=((CUSTOM, 120),))
    state = initial_state(scene)
    plain, sampled = Sampled(0), Sampled(recording.PROFILE_SAMPLES)
    a, b = event.run(scene, state, plain), event.run(scene, state, sampled)
    assert np.allclose(sampled.times, (np.arange(256) + 0.5) * scene.duration / 256, rtol=1e-12, atol=0.0)
    assert a.events == b.events and np.array_equal(a.final.positions, b.final.positions)
    for k, v in plain.bounces().items():
        assert np.array_equal(v, sampled.bounces()[k]), k
    assert np.array_equal(plain.collisions()["t"], sampled.collisions()["t"])
