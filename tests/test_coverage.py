"""Coverage of analyse's error bars over seeds, per scene class (issue 14, item 2).

For each class, 60 seeds of a small scene (tests/coverage_scenes.py) are run
and analysed; z = (measured - reference)/error for the mean pressure, each
wall's pressure (each wall on its own, and the walls pooled) and the mean
wall-hit speed. An honest one-sigma error puts 68.3% of |z| below 1 and
95.4% below 2; the issue's bounds are asserted, two-sided, on every
quantity: within 1 sigma in [0.5, 0.85], within 2 sigma in [0.85, 1].

Why 60 seeds: the fraction within 1 sigma over k seeds has a binomial
spread sqrt(0.683 x 0.317/k): 0.085 for 30 seeds, where [0.5, 0.85] is
+-2 spreads and a correct estimator fails one of the ~30 checks below about
four times in five; 0.060 for 60, where the bounds are 2.8 and 3.0 spreads
away. Measured on 100 seeds per class (docs/explanation/error-bars.md),
the fractions sit within 1.5 spreads of 0.683 except the collisionless
box's mean pressure (0.78: its error, the closed form of the run's ends, is
right in rms, 0.97, but the deviation is not Gaussian: lighter tails); with
those fractions a fresh set of 60 seeds fails a check about once in ten.
The seeds are fixed, so the test is deterministic; benchmarks/error_coverage.py
measures other seed sets and prints the table.

The reference is analyse's own theory where it is exact for the scene (the
collisionless box: ideal gas at the run's kinetic temperature), the mean
over the seeds of measured/theory otherwise (the wall models are first
order in the density, Enskog's rate a few % off): z is then scaled by
sqrt(n/(n - 1)) for the mean's own noise.

Marked ``coverage``; it is in the default run (pyproject's addopts
deselects nothing): about two minutes on two idle cores with the kernels
compiled.
"""

from __future__ import annotations

import pytest

from coverage_scenes import CLASSES, coverage_table, run_class

pytestmark = pytest.mark.coverage

SEEDS = range(1, 61)

QUANTITIES = ("mean pressure", "wall pressure", "wall-hit speed")
"""The issue's three; 'wall pressure' is pooled over the walls, and each wall is checked on its own too."""


@pytest.mark.parametrize("name", [k for k, v in CLASSES.items() if v.in_test])
def test_error_bars_cover_the_spread_over_seeds(name, tmp_path):
    reference = CLASSES[name].reference
    table = coverage_table(run_class(name, SEEDS, str(tmp_path / "c.db")))
    table = table[table.reference == reference].set_index("quantity")
    expected = [q for q in QUANTITIES if not (CLASSES[name].periodic and q != "mean pressure")]
    checked = expected + [q for q in table.index if q.startswith("wall ") and q != "wall pressure"]
    assert set(expected) <= set(table.index), (name, table)
    for q in checked:
        row = table.loc[q]
        assert row.samples >= 0.9 * len(SEEDS), (name, q, row)   # a few withheld (DOF < 4), as analyse does
        assert 0.5 <= row.within_1 <= 0.85 and 0.85 <= row.within_2, (name, q, table)


MEAN_PRESSURE_SEEDS = range(1, 31)
"""30 seeds: a right error bar's rms z is 1 +- 0.13 (sqrt(1/2n)); [0.7, 1.35] is about 2.5 of that."""


@pytest.mark.parametrize("name", ["hexe-3d-walls", "box-2d-n200"])
def test_walls_mean_pressure_error_is_its_closed_form(name, tmp_path):
    """The walls' mean pressure where the kinetic energy is fixed: ends, collisions' virial and, in a
    mixture, the species' energy split, in closed form (estimators.mean_wall_pressure). The blocks'
    estimate it replaced gave rms z 1.5-1.8 and up to 7 sigma on these classes (issue 38)."""
    from coverage_scenes import z_scores

    table = z_scores(run_class(name, MEAN_PRESSURE_SEEDS, str(tmp_path / "c.db")), "seed mean")
    z = table[table.quantity == "mean pressure"]
    rms = float((z.z ** 2).mean() ** 0.5)
    assert z.z.notna().all() and len(z) == len(MEAN_PRESSURE_SEEDS), z
    assert 0.7 <= rms <= 1.35 and z.z.abs().max() < 4.0, (name, rms, z.z.abs().max())
    # the error's size is not chance: it varies over seeds as the run's temperature and pressure do
    # (a few %), where the blocks' estimate spread a factor 4-7
    relative = z.error / z.measured
    assert relative.max() / relative.min() < 1.3, (name, relative.describe())
    # each wall: the mean's closed form plus the axis' excess reblocked (estimators.axis_sum); reblocking
    # the whole axis sum spread the walls' error a factor 4 over these seeds of the 2D box (now 2.0;
    # He:Xe 2.4, the excess's share of the noise larger)
    walls = table[table.quantity == "wall pressure"]
    rms = float((walls.z ** 2).mean() ** 0.5)
    assert 0.7 <= rms <= 1.35 and walls.z.abs().max() < 4.0, (name, rms, walls.z.abs().max())
    relative = walls.error / walls.measured
    assert relative.max() / relative.min() < 3.0, (name, relative.describe())
