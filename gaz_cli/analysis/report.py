"""What ``gaz analyse`` computes from the database: :func:`report`, a dict of tables.

The store runs the packaged SQL and hands back tables; the analysis package puts the
results beside theory (:mod:`gaz_cli.theory`), with statistical error bars
(:mod:`gaz_cli.analysis.errorbars`), and draws figures (:mod:`gaz_cli.analysis.figures`).
It never prints and never writes SQL. Its parts:

* :mod:`~gaz_cli.analysis.stored`: one simulation read once (:class:`~gaz_cli.analysis.stored.StoredRun`),
  its bounces and collisions summed per time bin by the database;
* :mod:`~gaz_cli.analysis.estimators`: time averages and their error bars;
* :mod:`~gaz_cli.analysis.expectations`: the models that fit the scene, their values and caveats;
* :mod:`~gaz_cli.analysis.comparisons`: one table per entry of the registry ``COMPARISONS``;
* :mod:`~gaz_cli.analysis.figures`: the figures of one simulation;
* :mod:`~gaz_cli.analysis.placements`: ``gaz place --repeat``'s study.

Error bars: every time average (a wall's pressure, the mean over the walls,
the virial pressure, the mean speed of wall hits, the collision rate, the
force balance under gravity, the cooling) is cut into
:data:`gaz_cli.analysis.errorbars.BINS` time bins, its error estimated from
their correlations, and, for the quantities an initial draw of few particles
fixes for longer than the run (a wall's share of the kinetic energy, the set
of speeds), the closed-form spread of that draw not yet relaxed by collisions
is added. The error is one standard deviation of the number over repeated
runs (seeds) of the same scene; ``N_EFF`` is the effective number of
independent samples.

Each comparison names its theory (``MODEL``) and its caveats (``NOTE``);
where theory cannot give a value for a scene (a fit used beyond its range, a
cooling gas) or does not fit it (a dense fluid at walls, a run that did not
settle), the numeric cell is NaN (empty in csv, null in json) and the reason
is in ``NOTE``: no deviation in sigmas is printed against a theory that does
not apply.
"""

from __future__ import annotations

import contextlib
import math
import warnings

import numpy as np
import pandas as pd

from gaz_cli import interrupts
from gaz_cli.analysis.comparisons import COMPARISONS, overview_row, per_wall_frame, pressure_summary
from gaz_cli.analysis.estimators import exam_per_wall, exam_q35, settled_temperature
from gaz_cli.analysis.expectations import energy_temperature
from gaz_cli.analysis.figures import make_plots, nothing_to_draw
from gaz_cli.analysis.stored import load_run
from gaz_cli.errors import GazWarning, Interrupted, StoreError


_EXAM_TABLES = {
    "q34": "Q34 simulations per dimension",
    "q35": "Q35 wall bounces and mean speed of wall hits",
    "q36": "Q36 momentum and pressure per wall",
    "overview": "pressure against the ideal gas",
}
TABLES = {**_EXAM_TABLES, **{c.key: c.title for c in COMPARISONS}, "figures": "figures"}
"""Short names (``gaz analyse --table NAME``) of the tables ``report`` returns: the exam's,
then :data:`gaz_cli.analysis.comparisons.COMPARISONS`, then the figures."""


def report(db: str, sim: int | None = None, plot_dir: str | None = None) -> dict:
    """What ``gaz analyse`` prints: a dict of table title -> DataFrame (or dict of scalars).

    Always: Q34, Q35, Q36 with the pressure per wall (with its error, the
    expected value and the deviation in sigmas) and the overview (one row per
    simulation). With ``sim``: also the scene, the pressure against every
    model that applies, the collision rate against Enskog, the mean wall-hit
    speed against the flux-weighted theory, under gravity the force balance,
    for a cooling gas Haff's law. ``plot_dir``: PNG figures for each
    simulation analysed, listed in a last table 'figures'. The database sums
    the rows (per wall, species and time bin); only figures read the rows.
    Numeric columns hold numbers (NaN where no value exists, the reason in
    a text column).
    """
    from gaz_cli.results import store as st

    if sim is not None and (isinstance(sim, bool) or not isinstance(sim, (int, np.integer))):
        raise StoreError(f"sim {sim!r} is not an int; give SIMULATION.SI_NUM as an int, e.g. sim=1")
    with interruptible(plot_dir), st.Store(db, create=False) as store:  # closed: SQLite drops -wal, -shm
        return _report(store, db, sim, plot_dir)


@contextlib.contextmanager
def interruptible(plot_dir: str | None = None):
    """SIGINT and SIGTERM inside the block raise :class:`~gaz_cli.errors.Interrupted` saying the
    analysis stopped (SIGTERM's default action would end the process without a word, exit 143)."""
    try:
        with interrupts.catching():
            yield
    except Interrupted as exc:
        figures = f"; the figures already drawn stay in '{plot_dir}'" if plot_dir is not None else ""
        raise Interrupted(exc.signum, f"{interrupts.STOPPED_ANALYSIS}{figures}") from None


def _report(store, db: str, sim: int | None, plot_dir: str | None) -> dict:
    """:func:`report` on an open store."""
    from gaz_cli.results.store import shown

    numbers = store.simulation_numbers()
    name = shown(str(db))  # (a URL's password hidden)
    if not numbers:
        raise StoreError(f"'{name}' holds no simulation yet; run 'gaz simulate --db {name}' first")
    if sim is not None and sim not in numbers:
        raise StoreError(f"simulation {sim} is not in '{name}'; it holds SI_NUM {_ranges(numbers)}")
    if plot_dir is not None:
        from gaz_cli.analysis import plots

        plots.make_folder(plot_dir)
    chosen = [sim] if sim is not None else numbers
    q34 = store.query("q34_simulations_per_dimension")
    q35 = None if sim is not None else store.query("q35_bounces_per_simulation")
    walls, overview, figures = [], [], []
    blank = []  # simulations without a figure, each with the reason
    detail = {}
    for number in chosen:
        run = load_run(store, number)
        temperature = run.kinetic_temperature
        if run.gravity > 0.0 and not run.periodic and run.settled and run.restitution >= 1.0:
            # the settled gas's temperature: from the conserved energy where the initial state is
            # known, else from the hits (an error bar that misses the slow exchange between axes)
            from_energy = energy_temperature(run)
            settled = settled_temperature(run) if not math.isfinite(from_energy) else None
            if math.isfinite(from_energy):
                temperature, run.temperature_source = from_energy, "energy"
            elif math.isfinite(settled.mean) and math.isfinite(settled.error):
                temperature, run.temperature_error = settled.mean, settled.error
                run.temperature_source = "hits"
        per_wall = exam_per_wall(run)
        if sim is not None:
            q35 = exam_q35(run)
        summary = pressure_summary(run, temperature)
        walls.append(per_wall_frame(run, per_wall, temperature, summary))
        overview.append(overview_row(run, temperature, summary))
        if sim is not None:
            detail = {c.title: c.frame(run, temperature, summary) for c in COMPARISONS if c.shown(run)}
        if plot_dir is not None:
            drawn = make_plots(run, temperature, summary, plot_dir)
            figures.extend(drawn)
            if not drawn:
                blank.append(f"simulation {number}: {nothing_to_draw(run)}")
    frames = {
        TABLES["q34"]: q34,
        TABLES["q35"]: q35,
        TABLES["q36"]: pd.concat(walls, ignore_index=True),
        TABLES["overview"]: pd.DataFrame(overview),
    }
    frames.update(detail)
    if blank:
        warnings.warn(GazWarning(f"--plot {plot_dir}: nothing to draw for {'; '.join(blank)}"), stacklevel=2)
    if plot_dir is not None:
        frames[TABLES["figures"]] = pd.DataFrame(figures, columns=["SI_NUM", "FIGURE", "FILE"])
    return frames


def _ranges(numbers: list[int]) -> str:
    """'1-3, 7' from [1, 2, 3, 7]."""
    out, start, prev = [], None, None
    for k in numbers:
        if start is None:
            start = prev = k
        elif k == prev + 1:
            prev = k
        else:
            out.append(f"{start}-{prev}" if prev != start else f"{start}")
            start = prev = k
    out.append(f"{start}-{prev}" if prev != start else f"{start}")
    return ", ".join(out)
