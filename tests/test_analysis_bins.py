"""The per-bin sums analyse reads from the database (``Run.hits``): the rows summed per
RE_NUM range of each time bin (what analyse does on SQLite; the same SQL files run on
PostgreSQL), or by sql/bounce_bins.sql's GROUP BY of the whole run (rows out of time
order; PostgreSQL); both against the same sums made by numpy from the rows.

Tolerance: the database adds a bin's k positive terms in another order than numpy's
pairwise sum; each sum is then within (k - 1) eps of the other (relative), and k is at
most the run's bounce count here (REORDERED_SUM below)."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from backends import BACKENDS, backend, postgres_db, postgres_url  # noqa: F401 - fixtures
from gaz_cli.analysis import report as analysis
from gaz_cli.analysis import stored
from gaz_cli.analysis import errorbars
from gaz_cli.model.recording import RunStats
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import BUILTIN
from gaz_cli.results.store import Store, rebond

both = pytest.mark.parametrize("backend", BACKENDS, indirect=True)
K = 6000
REORDERED_SUM = K * np.finfo(float).eps
"""Relative difference between two orders of summing at most K positive terms."""


def bounces(rng, scene, k=K):
    """k wall hits in time order, some exactly on bin edges, one at t = duration (last bin)."""
    t = np.sort(np.concatenate([rng.random(k - 40) * scene.duration,
                                np.arange(1, 40) * scene.duration / errorbars.BINS, [scene.duration]]))
    wall = (rng.integers(0, scene.dim, k) + 1) * rng.choice([-1, 1], k)
    vperp = rng.rayleigh(300.0, k)
    return t, rng.integers(0, scene.n, k), wall, np.hypot(vperp, rng.rayleigh(300.0, k)), vperp


def write(store, scene, arrays):
    with store.simulation(scene) as w:
        for part in np.array_split(np.arange(len(arrays[0])), 3):
            w.add_bounces(*(a[part] for a in arrays))
        w.finish(RunStats(len(arrays[0]), len(arrays[0]), 0, 0.1, initial_state(scene)), 1.0, 1.0)
    return w.si_num


def expected(store, si, duration):
    """Run.hits's sums made by numpy from the rows themselves."""
    rows = store.table(rebond, si)
    t = rows.RE_T.to_numpy()
    rows = rows.assign(BIN=np.clip(np.floor(t * errorbars.BINS / duration), 0, errorbars.BINS - 1).astype(np.int64),
                       VP2=rows.RE_VP ** 2)
    g = rows.groupby(["BIN", "PA_NUM", "RE_DIR"])
    return pd.DataFrame({"NB_REBONDS": g.size(), "SUM_VP": g.RE_VP.sum(), "SUM_VIT": g.RE_VIT.sum(),
                         "SUM_VP2": g.VP2.sum()})


def assert_same(hits, reference):
    """Equal sums per (bin, species, wall); the GROUP BY's clipping may leave two rows of a
    key (t = duration falls in bin BINS before clipping), which every reader adds up."""
    got = hits.groupby(["BIN", "PA_NUM", "RE_DIR"]).sum().sort_index()
    assert got.index.equals(reference.index)
    assert (got.NB_REBONDS.to_numpy() == reference.NB_REBONDS.to_numpy()).all()
    for col in ("SUM_VP", "SUM_VIT", "SUM_VP2"):
        np.testing.assert_allclose(got[col].to_numpy(), reference[col].to_numpy(), rtol=REORDERED_SUM, atol=0)


@both
def test_summed_per_range_as_numpy_does(backend, argon_scene, rng):
    scene = argon_scene(dim=3, n=40)
    with Store(backend) as store:
        si = write(store, scene, bounces(rng, scene))
        run = stored.load_run(store, si)
        assert_same(stored._bin_sums_by_ranges(store, run), expected(store, si, scene.duration))
        assert_same(run.hits, expected(store, si, scene.duration))  # what analyse reads


@both
def test_rows_out_of_time_order_fall_back_to_group_by(backend, argon_scene, rng):
    """Two rows of different bins swapped: the ranges no longer hold their bins, the
    check says so, and the GROUP BY gives the right sums."""
    scene = argon_scene(dim=2, n=40, length=1e-7)
    t, *rest = bounces(rng, scene)
    t = t.copy()
    t[[100, 5000]] = t[[5000, 100]]
    with Store(backend) as store:
        si = write(store, scene, (t, *rest))
        run = stored.load_run(store, si)
        assert stored._bin_sums_by_ranges(store, run) is None
        assert_same(run.hits, expected(store, si, scene.duration))


@both
def test_mixture_and_no_bounce(backend, argon_scene, rng):
    scene = replace(argon_scene(dim=3, n=40), components=((BUILTIN["Ar"], 25), (BUILTIN["He"], 15)))
    with Store(backend) as store:
        si = write(store, scene, bounces(rng, scene))
        empty = write(store, scene, tuple(np.zeros(0) for _ in range(5)))
        run = stored.load_run(store, si)
        assert_same(stored._bin_sums_by_ranges(store, run), expected(store, si, scene.duration))
        one = replace(argon_scene(dim=3, n=40))
        nothing = write(store, one, tuple(np.zeros(0) for _ in range(5)))
        for number in (empty, nothing):
            assert len(stored.load_run(store, number).hits) == 0


@both
def test_a_row_of_another_species_is_summed_too(backend, argon_scene, rng):
    """A row added by hand to a one-species run, of another species (in time order): summed
    under its own PA_NUM, as the GROUP BY of the whole run would."""
    import sqlalchemy as sa

    scene = argon_scene(dim=3, n=40)
    with Store(backend) as store:
        si = write(store, scene, bounces(rng, scene))
        helium = list(BUILTIN).index("He") + 1
        with store.engine.begin() as conn:
            conn.execute(sa.text("INSERT INTO rebond VALUES (:si, :k, :pa, :t, 1, 500.0, 400.0)"),
                         dict(si=si, k=K + 1, pa=helium, t=scene.duration))
        run = stored.load_run(store, si)
        hits = stored._bin_sums_by_ranges(store, run)
        assert_same(hits, expected(store, si, scene.duration))
        assert helium in set(hits.PA_NUM)
