"""One copy of each formula (issue 17, item 5): the wall momentum and the virial pressure.

Damped walls (restitution e_w < 1) are where the wall momentum's two old
copies disagreed: the run summary gave (1 + e_w) m |v_perp| per bounce, the
SQL and analyse 2 m |v_perp|. Now the summary, the exam's SQL (Q36, the
pressure per wall) and analyse all give (1 + e_w) m |v_perp|
(gaz_cli.theory.wall_impulse); the tolerance is float rounding (sums in a
different order), 1e-12 relative.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gaz_cli import theory
from gaz_cli.analysis import estimators
from gaz_cli.analysis import report as analysis
from gaz_cli.analysis import stored
from gaz_cli.run import runner
from gaz_cli.constants import K_B
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import Species
from gaz_cli.results.store import Store

ROUNDING = 1e-12
"""Relative tolerance: the same sums, added in another order."""

DISK = Species("D", 6.6e-26, 1e-10)


def test_wall_impulse_is_one_plus_e_times_m_v():
    assert theory.wall_impulse(2.0, -3.0) == 12.0
    assert theory.wall_impulse(2.0, 3.0, 0.5) == pytest.approx(9.0)


def test_damped_walls_give_one_pressure_in_summary_sql_and_analyse(tmp_path):
    db = str(tmp_path / "damped.db")
    e_w = 0.8
    scene = Scene(dim=2, length=2e-8, duration=3e-10, components=((DISK, 30),), engine="step", dt=3e-14,
                  wall_restitution=e_w, temperature=300.0, seed=3)
    summary = runner.simulate(scene, db=db)
    frames = analysis.report(db, sim=summary["si_num"])
    per_wall = frames["Q36 momentum and pressure per wall"].set_index("RE_DIR")
    with Store(db, create=False) as store:
        q36 = store.query("q36_momentum_per_wall", si_num=summary["si_num"]).set_index("RE_DIR")
        sql_p = store.query("pressure_per_wall", si_num=summary["si_num"]).set_index("RE_DIR")
        rows = store.read_sql("SELECT RE_DIR, SUM(RE_VP) AS S FROM REBOND WHERE SI_NUM = :s GROUP BY RE_DIR",
                              s=summary["si_num"]).set_index("RE_DIR")
    assert len(per_wall) == 4 and summary["pressure"] > 0
    # the exam's 2 m |v_perp| would be 2/(1 + e_w) = 1.11 times larger: the formula is the damped one
    np.testing.assert_allclose(q36.QUANTITE_MOUVEMENT, (1 + e_w) * DISK.mass_g / 1000.0 * rows.S, rtol=ROUNDING)
    np.testing.assert_allclose(per_wall.QUANTITE_MOUVEMENT, q36.QUANTITE_MOUVEMENT, rtol=ROUNDING)
    np.testing.assert_allclose(per_wall.PRESSION, sql_p.PRESSION, rtol=ROUNDING)
    np.testing.assert_allclose(per_wall.P_MEASURED, sql_p.PRESSION, rtol=ROUNDING)
    overview = frames["pressure against the ideal gas"].iloc[0]
    assert overview.P_MEASURED == pytest.approx(summary["pressure"], rel=ROUNDING)
    assert per_wall.PRESSION.mean() == pytest.approx(summary["pressure"], rel=ROUNDING)


def test_virial_pressure_binned_and_whole_run_agree(tmp_path):
    """The per-bin virial pressures (CHOC) average to the whole run's (RESULTAT's virial) and the summary's."""
    db = str(tmp_path / "virial.db")
    scene = Scene(dim=3, length=1.0, duration=0.5, components=((Species("X", 1.0, 0.09), 64),),
                  boundary="periodic", record="all", temperature=1.0 / K_B, seed=4)
    summary = runner.simulate(scene, db=db)
    frames = analysis.report(db, sim=summary["si_num"])
    measured = frames["pressure against theory"].P_MEASURED.iloc[0]
    assert measured == pytest.approx(summary["pressure"], rel=ROUNDING)
    with Store(db, create=False) as store:
        run = stored.load_run(store, summary["si_num"])
    bins = estimators.virial_bin_pressures(run, run.kinetic_temperature)
    assert summary["collisions"] > 100 and bins is not None
    assert float(np.mean(bins)) == pytest.approx(measured, rel=1e-9)
    assert math.isfinite(frames["pressure against theory"].P_ERR.iloc[0])


def test_cooling_gas_is_analysed_and_drawn(tmp_path):
    """A cooling gas with --record all: Haff's table and the cooling figure (cooling_series once raised NameError)."""
    db, figs = str(tmp_path / "cool.db"), tmp_path / "figs"
    scene = Scene(dim=2, length=1.0, duration=0.3, components=((Species("G", 1.0, 0.02), 200),),
                  boundary="periodic", record="all", restitution=0.9, temperature=1.0 / K_B, seed=5)
    summary = runner.simulate(scene, db=db)
    frames = analysis.report(db, sim=summary["si_num"], plot_dir=str(figs))
    cooling = frames["cooling against Haff's law"]
    assert (cooling.T_END_K < cooling.T_START_K).all() and np.isfinite(cooling.T_THEORY_K).all()
    assert "temperature of the cooling gas against Haff's law" in set(frames["figures"].FIGURE)
    assert (figs / f"sim{summary['si_num']}_cooling.png").stat().st_size > 1000
