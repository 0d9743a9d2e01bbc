"""The Python API: what the command line calls, for notebooks and scripts.

Exposed at the package's top level (``import gaz_cli as gaz``; see docs/tutorials/python.md)::

    scene = gaz.make_scene(dim=2, species={"Ar": 100}, length=1e-7, duration=1e-10, seed=1)
    run = gaz.simulate(scene, keep_state=True, keep_bounces=True)    # no database
    run.summary["pressure"], run.state.positions, run.bounces["t"]
    gaz.simulate(scene, db="gaz.db"); frames = gaz.analyse("gaz.db", sim=1)
    walls = gaz.analyse("gaz.db", sim=1, table="q36")                # one table: a DataFrame

Every scene goes through :func:`gaz_cli.scenes.validate.validate`, as it does from the command line.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

from gaz_cli.scenes import files as scenefile
from gaz_cli.errors import QueryError, SceneError
from gaz_cli.run.runner import Run, run_scene
from gaz_cli.model.scene import Scene

if TYPE_CHECKING:  # (pandas and the store load on first use)
    import pandas as pd

    from gaz_cli.results.store import Store
    from gaz_cli.run.sweeps import Report

__all__ = ["make_scene", "load_scene", "write_scene", "scene_text", "simulate", "open_store", "analyse",
           "sweep", "versus", "Run"]


def _plain(value):
    """``value`` with NumPy scalars as Python numbers and arrays as lists, through dicts, lists
    and tuples: the scene-file checks take what TOML gives (int, float, str, list, dict)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_plain(v) for v in value)
    if type(value).__module__ == "numpy":
        import numpy as np

        if isinstance(value, np.generic):
            return value.item()
        if isinstance(value, np.ndarray):
            return value.tolist()
    return value


def _path(value, what: str, optional: bool = False):
    """``value`` if it is a path (str or os.PathLike; None too when ``optional``), else
    SceneError naming what was expected."""
    import os

    if optional and value is None:
        return value
    if not isinstance(value, (str, os.PathLike)):
        none = " or None" if optional else ""
        raise SceneError(f"{what} {value!r} is not a file path; give a path (text or pathlib.Path){none}")
    return value


def _switch(value, what: str, optional: bool = False) -> bool | None:
    """``value`` as a bool if it is one (NumPy's too; None when ``optional``), else SceneError:
    a switch given a string or a number is a mistake more often than a truth value."""
    value = _plain(value)
    if (optional and value is None) or isinstance(value, bool):
        return value
    raise SceneError(f"{what} {value!r} is not True or False" + (" (or None)" if optional else ""))


def _text(value, what: str, optional: bool = False) -> str | None:
    """``value`` if it is text (None when ``optional``), else SceneError naming what was expected."""
    if (optional and value is None) or isinstance(value, str):
        return value
    raise SceneError(f"{what} {value!r} is not text; give a name as a string" + (" or None" if optional else ""))


def _whole(scene):
    """A Scene made by hand with ``extras=None`` given the empty extras :func:`make_scene` gives it."""
    if isinstance(scene, Scene) and scene.extras is None:
        from dataclasses import replace

        scene = replace(scene, extras={})
    return scene


def make_scene(*, species, **keys) -> Scene:
    """A validated Scene from the keys of a scene file (docs/reference/scene-file.md), SI units.

    ``species``: ``{"Ar": 500, "He": 500}`` (built-in gases and counts), ``"Ar:500,He:500"``,
    or a list of scene-file tables (``[{"name": "bead", "count": 10, "mass": 1e-3,
    "radius": 1e-3}]``). ``keys``: ``dim``, ``duration``, ``length`` or ``packing``, and any
    other key (``temperature``, ``seed``, ``boundary``, ``engine``, ``dt``...). ``planes``:
    a list of ``{"point", "normal", "restitution"}`` tables.
    """
    species, keys = _plain(species), _plain(keys)  # NumPy scalars taken as the numbers they are
    if isinstance(species, str):
        from gaz_cli.model.species import parse_mixture

        entries = [{"name": sp.name, "count": k} for sp, k in parse_mixture(species, None)]
    elif isinstance(species, dict):
        entries = [{"name": name, "count": count} for name, count in species.items()]
    elif isinstance(species, (list, tuple)) and all(isinstance(t, dict) for t in species):
        entries = [dict(t) for t in species]
    else:
        raise SceneError(f"species {species!r} is not a dict of counts ({{'Ar': 500}}), a string ('Ar:500,He:500') "
                         "or a list of tables ([{'name': 'bead', 'count': 10, 'mass': 1e-3, 'radius': 1e-3}])")
    scene, outputs = scenefile.build({**keys, "species": entries})
    if outputs:
        raise SceneError("make_scene takes no [output] table; pass db, trajectory... to simulate()")
    return scene


def load_scene(path) -> Scene:
    """The validated Scene of a scene file (its [output] table is for ``gaz simulate``)."""
    return scenefile.load(_path(path, "load_scene: path"))[0]


def write_scene(path, scene: Scene) -> None:
    """Write ``scene`` as a scene file (TOML) that :func:`load_scene` reads back exactly; a scene
    the door refuses (:func:`gaz_cli.scenes.validate.validate`, SceneError) is not written."""
    scene = _whole(scene)
    _checked(scene, path)
    scenefile.write(_path(path, "write_scene: path"), scene)


def scene_text(scene: Scene) -> str:
    """The scene file of ``scene``, as text (a scene the door refuses: SceneError)."""
    scene = _whole(scene)
    _checked(scene)
    return scenefile.dumps(scene)


def _checked(scene, path=None) -> None:
    """Refuse what :func:`load_scene` would refuse of the file: no Scene, or an invalid one
    (a Scene made by hand, not through :func:`make_scene`)."""
    from gaz_cli.scenes.validate import validate

    scenefile.require_scene(scene, path)
    validate(scene)


def simulate(scene: Scene, *, db: str | None = None, keep_state: bool = False, keep_bounces: bool = False,
             keep_collisions: bool = False, trajectory: str | None = None, every: float | None = None,
             save_state: str | None = None, write_scene: str | None = None, diagnostics=None,
             progress: bool = False, inputs: dict | None = None) -> Run:
    """Run ``scene``; returns a :class:`~gaz_cli.run.runner.Run`: ``summary`` (dict), and the final
    ``state``, the ``bounces`` and ``collisions`` (dicts of numpy arrays) when asked.

    ``db``: store the run there (a path or SQLAlchemy URL; None: no database). A scene
    without a seed gets a fresh one, recorded in the summary. ``diagnostics``: a function
    called with a dict (time, step, kinetic, potential, energy, max_speed...) every
    ``print_every`` steps of the step engine (refused with another engine). ``progress``: a progress bar
    (:mod:`gaz_cli.progress`) on stderr, or in a notebook's cell (``pip install 'gaz[notebook]'``);
    ``gaz simulate`` draws one when stderr is a terminal. ``inputs``: the files the
    scene was read from ({'the scene file': path}): no output may be one of them. Every output
    appears under its name when the run is committed, whole (a temporary file renamed).
    """
    scene = _whole(scene)
    keep_state, keep_bounces, keep_collisions, progress = (
        _switch(v, f"simulate: {k}") for k, v in (("keep_state", keep_state), ("keep_bounces", keep_bounces),
                                                   ("keep_collisions", keep_collisions), ("progress", progress)))
    # (the outputs' paths and diagnostics are the door's: gaz_cli.scenes.validate.admit_outputs)
    if inputs is not None and not (isinstance(inputs, dict) and all(
            isinstance(k, str) and isinstance(v, (str, os.PathLike)) for k, v in inputs.items())):
        raise SceneError(f"simulate: inputs {inputs!r} is not a dict of what -> file path "
                         "({'the scene file': 'run.toml'}); give one, or None")
    every = _plain(every)
    return run_scene(scene, db=db, keep_state=keep_state, keep_bounces=keep_bounces,
                     keep_collisions=keep_collisions, trajectory=trajectory, every=every,
                     save_state=save_state, write_scene=write_scene, diagnostics=diagnostics,
                     progress=progress, inputs=inputs)


def open_store(db: str, create: bool = False) -> Store:
    """The results database ``db`` (:class:`gaz_cli.results.store.Store`; a context manager).
    ``create=False`` refuses to make a new one."""
    from gaz_cli.results.store import Store

    return Store(_path(db, "open_store: db"), create=_switch(create, "open_store: create"))


def analyse(db: str, sim: int | None = None, plot: str | None = None,
            table: str | None = None) -> dict[str, Any] | pd.DataFrame:
    """What ``gaz analyse`` prints.

    Without ``table``: every table, a dict of title -> pandas DataFrame (or dict of scalars).
    With ``table``: that one table as a DataFrame (a dict of scalars as one row), named by its
    short name, as ``gaz analyse --table NAME``: ``q34``, ``q35``, ``q36`` (momentum and
    pressure per wall), ``overview`` (one row per simulation, against the ideal gas), and with
    ``sim``: ``simulation``, ``pressure`` (against every theory that applies), ``collisions``,
    ``contact``, ``speed``, ``gravity``, ``cooling``; ``figures`` with ``plot``
    (:data:`gaz_cli.analysis.report.TABLES` maps each to its title). A name the analysis
    does not know, or a table this run has not (gravity without gravity...), raises
    :class:`~gaz_cli.errors.QueryError` naming those it has. ``plot``: a folder for PNG figures.
    """
    from gaz_cli.analysis import report as analysis

    _text(table, "analyse: table", optional=True)
    if table is not None and table not in analysis.TABLES:
        raise QueryError(f"table {table!r} is not one of {', '.join(analysis.TABLES)}")
    frames = analysis.report(_path(db, "analyse: db"), sim=_plain(sim),
                             plot_dir=_path(plot, "analyse: plot (a folder)", optional=True))
    if table is None:
        return frames
    import pandas as pd

    frame = pick_table(frames, table, sim, plot)
    return frame if isinstance(frame, pd.DataFrame) else pd.DataFrame([frame])


def pick_table(frames: dict[str, Any], table: str, sim: int | None, plot: str | None) -> Any:
    """The table of short name ``table`` among ``frames`` (what :func:`analyse` returns without
    ``table``), as it is there; QueryError when this analysis has none by that name, saying why."""
    from gaz_cli.analysis import report as analysis

    title = analysis.TABLES[table]
    if title not in frames:
        why = ("needs --plot DIR" if table == "figures" and plot is None else
               "needs --sim" if sim is None else "not this scene")
        raise QueryError(f"no table {table!r} for this analysis ({why}); "
                         f"it has: {', '.join(k for k, v in analysis.TABLES.items() if v in frames)}")
    return frames[title]


def sweep(scene_file, vary: list[str], seeds: int = 1, db: str | None = None, workers: int | None = None,
          scheduler: str | None = None, progress: bool | None = None) -> Report:
    """Run a sweep (``gaz sweep``): the scene file with each ``vary`` (``"KEY=V1,V2"`` or
    ``"KEY=START:STOP:COUNT"``) over ``seeds`` seeds, on Dask; every run stored in ``db``
    (None: the scene file's ``[output] db``, else gaz.db, as :func:`simulate` from a file).
    Returns a :class:`gaz_cli.run.sweeps.Report` (each point: stored, skipped or failed).
    ``progress``: the sweep's bar (None: on a terminal or in a notebook, as
    :func:`gaz_cli.progress.wanted` says).
    One ``vary`` may be given as a string."""
    from gaz_cli.scenes import files as scenefile
    from gaz_cli.run import sweeps

    _path(scene_file, "sweep: scene_file")
    _path(db, "sweep: db", optional=True)
    _text(scheduler, "sweep: scheduler (an address such as 'tcp://host:8786')", optional=True)
    progress = _switch(progress, "sweep: progress", optional=True)
    if isinstance(vary, str):
        vary = [vary]
    if not (isinstance(vary, (list, tuple)) and all(isinstance(v, str) for v in vary)):
        raise SceneError(f"vary {vary!r} is not a list of 'KEY=V1,V2' or 'KEY=START:STOP:COUNT' strings "
                         "(e.g. ['packing=0.1:0.6:6'])")
    varies = [sweeps.parse_vary(v) for v in vary]
    scene_of, base_seed, outputs = sweeps.scenes_of_file(scene_file, [k for k, _ in varies])
    points = sweeps.plan(varies, seeds, base_seed)
    return sweeps.run(points, scene_of, None, scenefile.database(db, outputs), workers=workers, scheduler=scheduler, progress=progress)


def versus(db: str, key: str, plot: str | None = None) -> pd.DataFrame:
    """What ``gaz analyse --vs KEY`` prints: per value of ``key`` the mean over the runs (seeds),
    its standard error and theory (a DataFrame); ``plot``: a folder for the figures."""
    from gaz_cli.analysis import studies
    from gaz_cli.analysis.report import interruptible

    _text(key, "versus: key")
    _path(plot, "versus: plot (a folder)", optional=True)
    with interruptible(plot):
        with open_store(db) as store:
            table = studies.versus(store, key)
        if plot:
            studies.plot(table, key, plot)
    return table
