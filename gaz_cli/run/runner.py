"""One simulation from scene to database: the driver behind ``gaz simulate``.

Order of operations: validate the scene and fix its seed; place the particles
and draw their velocities (:func:`gaz_cli.placement.initial.initial_state`, independent of
the engine: a placement that gives up is refused before any database is
created or touched); open the store (its schema checked, created or migrated:
a database that cannot take the run fails here, before any simulation); let
the engine stream its events into the run's writer (staged or
in an open transaction, see :mod:`gaz_cli.results.store`); then everything that can
still fail -- the trajectory's last write, the final state file, the
summary -- and only then the commit. The outputs (scene file, trajectory, final
state) are written under temporary names beside them and renamed into place after
the commit (:mod:`gaz_cli.atomic`); before anything is written each is compared with
the database, the run's inputs and the other outputs by identity of the file
(:mod:`gaz_cli.scenes.paths`). A failure or an interrupt (SIGINT or
SIGTERM, see :mod:`gaz_cli.interrupts`) at any point before the commit
leaves nothing in the database and every output as it was (the temporary files
removed), and the :class:`~gaz_cli.errors.Interrupted` raised says so.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gaz_cli import atomic, interrupts
from gaz_cli.constants import PRESSURE_UNIT
from gaz_cli.errors import Interrupted, OutputError, SceneError
from gaz_cli.model.recording import MemoryRecorder, Recorder, RunStats, hand_snapshot
from gaz_cli.model.scene import Scene, State, fresh_seed
from gaz_cli.placement.initial import initial_state
from gaz_cli.results.budgets import check_database_space
from gaz_cli.scenes.validate import admit_outputs, validate

from gaz_cli.engines.registry import engine_run


class Tee(Recorder):
    """Sends every report to several recorders (database, trajectory, diagnostics)."""

    def __init__(self, *recorders: Recorder):
        self.recorders = [r for r in recorders if r is not None]
        self.want_bounces = any(r.want_bounces for r in self.recorders)
        self.want_collisions = any(r.want_collisions for r in self.recorders)
        self.wants_progress = any(r.wants_progress for r in self.recorders)
        self.want_images = any(getattr(r, "want_images", False) for r in self.recorders)
        everies = [r.snapshot_every for r in self.recorders if r.snapshot_every]
        self.snapshot_every = min(everies) if everies else None
        self.profile_samples = max((getattr(r, "profile_samples", 0) for r in self.recorders), default=0)

    def add_bounces(self, *arrays):
        interrupts.check()
        for r in self.recorders:
            if r.want_bounces:
                r.add_bounces(*arrays)

    def add_collisions(self, *arrays):
        interrupts.check()
        for r in self.recorders:
            if r.want_collisions:
                r.add_collisions(*arrays)

    def add_snapshot(self, t, positions, velocities, images=None):
        interrupts.check()
        for r in self.recorders:
            if r.snapshot_every:
                hand_snapshot(r, t, positions, velocities, images)

    def add_profile_sample(self, t, positions):
        for r in self.recorders:
            if getattr(r, "profile_samples", 0):
                r.add_profile_sample(t, positions)

    def diagnostic(self, values):
        interrupts.check()
        for r in self.recorders:
            r.diagnostic(values)

    def progress(self, t, events):
        for r in self.recorders:
            r.progress(t, events)


def prepare(scene: Scene) -> Scene:
    """Validate ``scene`` and give it a seed if it has none, and the search the event engine
    will take (:func:`with_search`): recorded, so the run can be repeated."""
    scene = validate(scene)
    if scene.seed is None:
        scene = replace(scene, seed=fresh_seed())
    return with_search(scene)


def with_search(scene: Scene) -> Scene:
    """``scene`` (valid) with the event engine's search as resolved for it
    (:func:`gaz_cli.engines.event.driver.resolved_search`) in ``extras``, where the caller left it
    unset or on 'auto'; other engines' scenes unchanged. The scene file then stores it (its
    ``[search]`` table), and a rerun takes the same search, hence the same rows, whatever
    the cost model of a later gaz would choose."""
    if scene.engine != "event":
        return scene
    from gaz_cli.engines.event.driver import resolved_search

    given = {k: v for k, v in scene.extras.items() if v != "auto"}
    return replace(scene, extras={**scene.extras, **resolved_search(scene), **given})


class WallMomentum(Recorder):
    """Tallies the momentum (1 + e_w) m |v_perp| given to each wall, for the summary's pressure.

    e_w is the wall's restitution (1 for the exam's elastic walls: 2 m |v_perp|).
    """

    want_bounces = True

    def __init__(self, scene: Scene):
        from gaz_cli.theory import wall_impulse

        self.impulse = wall_impulse  # the one copy of the formula (Q36's SQL writes the same)
        self.masses = scene.masses()
        self.restitution = scene.wall_restitution
        self.dim = scene.dim
        self.momentum = np.zeros(2 * scene.dim)  # index: wall code + dim, skipping 0

    def add_bounces(self, t, particle, wall, speed, vperp):
        wall = np.asarray(wall)
        index = np.where(wall > 0, wall + self.dim - 1, wall + self.dim)
        # (bincount rather than np.add.at, several times slower before numpy 1.25, which
        # pyproject.toml allows)
        self.momentum += np.bincount(index, self.impulse(self.masses[np.asarray(particle)], vperp,
                                                         self.restitution), minlength=2 * self.dim)


class Diagnostics(Recorder):
    """Forwards an engine's periodic diagnostics to a callable."""

    def __init__(self, callback):
        self.callback = callback

    def diagnostic(self, values):
        self.callback(values)


def _check_url(db: str) -> None:
    """Refuse, before the run, a ``sqlite:///`` URL whose parameters would be ignored or
    ambiguous (:func:`gaz_cli.results.store.check_sqlite_query`, which every opening of ``--db``
    runs)."""
    if db.startswith("sqlite:///") and "?" in db:
        from gaz_cli.results.store import check_sqlite_query

        check_sqlite_query(db)


def sqlite_file(db: str | None) -> str | None:
    """The file a ``--db`` path or ``sqlite:///`` URL names; None for anything else."""
    if db is None:
        return None
    from gaz_cli.results.sqlite import is_file_path

    path = db if is_file_path(db) else (db[len("sqlite:///"):].split("?", 1)[0]
                                        if db.startswith("sqlite:///") else None)
    return path or None


@dataclass
class Run:
    """What :func:`run_scene` returns: the summary (a dict, JSON-ready; what ``gaz simulate
    --json`` prints), and on request the final state and the events, as arrays."""

    summary: dict
    state: State | None = None
    """The final positions and velocities (with ``keep_state``)."""
    bounces: dict | None = None
    """Wall bounces: arrays t, particle, wall, speed, vperp (with ``keep_bounces``)."""
    collisions: dict | None = None
    """Particle collisions: arrays t, i, j, impulse (with ``keep_collisions``)."""
    stats: RunStats | None = None
    """What the engine returned (counts, virial, final state): what a store's writer needs."""
    scene: Scene | None = None
    """The scene as run: validated, its engine resolved, its seed fixed."""

    def __repr__(self) -> str:
        """The text summary (:func:`describe`) and what was kept, by shape: a dozen lines,
        never the arrays (a notebook shows this for ``run``)."""
        kept = []
        if self.state is not None:
            kept.append(f"state: positions {self.state.positions.shape}, velocities {self.state.velocities.shape}")
        for name, rows in (("bounces", self.bounces), ("collisions", self.collisions)):
            if rows is not None:
                kept.append(f"{name}: {len(next(iter(rows.values()), ()))} rows ({', '.join(rows)})")
        try:
            lines = describe(self.summary).splitlines()
        except (KeyError, TypeError, ValueError):  # a Run made by hand, its summary partial
            lines = [f"summary with {', '.join(map(str, self.summary))}"]
        return "\n".join([f"<Run: {lines[0]}", *lines[1:], *(f"  {k}" for k in kept)]) + ">"


def simulate(scene: Scene, db: str | None = None, save_state: str | None = None,
             state: State | None = None, trajectory: str | None = None,
             every: float | None = None, diagnostics=None, write_scene: str | None = None,
             progress: bool = False, inputs: dict | None = None) -> dict:
    """Run one simulation; return its summary (a dict, JSON-ready). See :func:`run_scene`."""
    return run_scene(scene, db=db, save_state=save_state, state=state, trajectory=trajectory, every=every,
                     diagnostics=diagnostics, write_scene=write_scene, progress=progress,
                     inputs=inputs).summary


def run_scene(scene: Scene, db: str | None = None, save_state: str | None = None,
              state: State | None = None, trajectory: str | None = None,
              every: float | None = None, diagnostics=None, write_scene: str | None = None,
              keep_state: bool = False, keep_bounces: bool = False, keep_collisions: bool = False,
              progress: bool = False, inputs: dict | None = None) -> Run:
    """Run one simulation; return its :class:`Run` (summary, and what ``keep_*`` asks for).

    ``db``: path or SQLAlchemy URL of the results store, or None for no
    database. ``state``: an explicit initial state, else one is drawn from the scene and its
    seed (:func:`gaz_cli.placement.initial.initial_state`, which also makes the presets' states). ``trajectory``/``every``: snapshot
    file and interval (simulated s). ``diagnostics``: callable receiving the
    step engine's diagnostics (a dict) every ``scene.print_every`` steps; refused with another
    engine or without print_every (:func:`gaz_cli.scenes.validate.check_diagnostics`). ``write_scene``: write the scene file of the run
    (with its seed) to this path (in place once the run is committed). ``progress``: draw a progress bar (and a
    notice while the engine compiles) on stderr, see :mod:`gaz_cli.progress`. Raises
    :class:`~gaz_cli.errors.Interrupted` (a KeyboardInterrupt) when
    interrupted, saying what was left on disk. ``keep_state``, ``keep_bounces``,
    ``keep_collisions``: return the final state, the wall bounces, the collisions as arrays
    (no database needed; the bounces and collisions are kept in memory, whatever
    ``scene.record`` says). ``inputs``: the files the run was read from, by what they are
    ('the scene file' -> path): no output, nor the database, may be one of them
    (:func:`gaz_cli.scenes.paths.check`). The outputs appear under their names when the run
    is committed, not before (:mod:`gaz_cli.atomic`).
    """
    if db is not None:
        from gaz_cli.results.sqlite import database_name

        if isinstance(db, (str, os.PathLike)) and "\0" in str(os.fspath(db)):
            raise SceneError(f"--db {os.fspath(db)!r} holds a NUL character, which no file name or URL "
                             "may hold; give another name")
        db = database_name(db)
        _check_url(db)
    scene = prepare(scene)
    if trajectory and scene.engine == "reference" and scene.extras.get("engine_auto"):
        # the exam's engine writes no trajectory: a tiny run with one takes the event engine
        scene = replace(scene, engine="event", extras={
            **scene.extras, "engine_reason": "hard spheres: exact event-driven dynamics (a trajectory asked for)"})
        scene = with_search(scene)
    run = engine_run(scene.engine)
    outputs = {"--write-scene": write_scene, "--trajectory": trajectory, "--save-state": save_state}
    # the door for what the run writes: every output writable, none of them the database, an
    # input or another output (by identity of the file), the trajectory, the diagnostics; then
    # the database's disk space; all before anything is written
    admit_outputs(scene, sqlite_file(db), inputs, outputs, trajectory=trajectory, every=every,
                  diagnostics=diagnostics)
    if sqlite_file(db):
        check_database_space([scene], sqlite_file(db))
    # (PostgreSQL: a run past a 32-bit row number is refused by its writer, before the engine)
    masses = scene.masses()
    tally = WallMomentum(scene) if scene.boundary == "walls" and scene.record != "none" else None
    store = writer = traj = None
    # every output goes to a temporary name beside it, renamed into place once the run is
    # committed (gaz_cli.atomic): a failure or an interrupt leaves the old files as they were
    pending: dict[str, Path] = {}
    try:
        with contextlib.ExitStack() as stack:
            stack.enter_context(interrupts.catching())  # SIGTERM too; left last, after the commit
            if state is None:
                # before the database: a placement refused ("random placement stuck...") never
                # creates nor touches one
                state = initial_state(scene)
            if db is not None:
                # a SQLite file without SQLAlchemy's import when it can (gaz_cli.results.sqlite)
                from gaz_cli.results.writer import open_for_writing
                store = stack.enter_context(open_for_writing(db))  # refused or failing: before the engine
                writer = stack.enter_context(store.simulation(scene))
            if write_scene:
                from gaz_cli.scenes import files as scenefile

                scenefile.write(_temporary(pending, write_scene), scene, shown=write_scene)
            ke_start = state.kinetic_energy(masses)
            if trajectory:
                from gaz_cli.outputs.trajectory import open_trajectory
                traj = open_trajectory(trajectory, every, scene, write_to=_temporary(pending, trajectory))
                stack.callback(traj.close)  # (finished, not committed: a VTK collection waits for the commit)
            diag = Diagnostics(diagnostics) if diagnostics else None
            memory = MemoryRecorder(collisions=keep_collisions) if keep_bounces or keep_collisions else None
            if memory is not None:
                memory.want_bounces = keep_bounces
            bar = None
            if progress:
                from gaz_cli.progress import Progress
                bar = Progress(scene.duration)
                stack.callback(bar.close)  # the bar's line ends before anything else is said
            stats: RunStats = run(scene, state, Tee(writer, tally, traj, diag, memory, bar))
            if bar is not None:
                bar.close(complete=True)
            ke_end = stats.final.kinetic_energy(masses)
            # everything that can fail comes before the commit (the end of this block)
            if traj is not None:
                traj.close()
            if save_state:
                write_state(_temporary(pending, save_state), scene, stats.final, shown=save_state)
            out = summary(scene, stats, None, ke_start, ke_end,
                          None if tally is None else tally.momentum)
            if writer is not None:
                writer.finish(stats, ke_start, ke_end)
        with interrupts.held():  # committed: the outputs take their names, all of them
            _rename_all(pending)
            if traj is not None:
                traj.commit()
    except BaseException as exc:
        for temporary in pending.values():
            atomic.discard(temporary)
        if traj is not None and hasattr(traj, "_discard") and not pending.get(str(trajectory)):
            traj._discard()  # (a VTK collection: its temporary folder)
        signum = interrupts.signal_of(exc)
        if signum is not None:
            raise Interrupted(signum, _left_on_disk(store, writer, traj)) from None
        raise
    out["si_num"] = None if writer is None else writer.si_num
    return Run(out, stats.final if keep_state else None,
               memory.bounces() if keep_bounces else None, memory.collisions() if keep_collisions else None,
               stats, scene)


def _temporary(pending: dict, path) -> Path | None:
    """The name to write the output ``path`` under until the run is committed, noted in
    ``pending`` (None for a device or FIFO, and for a VTK trajectory, whose writer keeps its
    files in a temporary folder until its own commit)."""
    if atomic.in_place(path):
        return None
    if Path(path).suffix.lower() in (".pvd", ".vtu"):
        return None
    temporary = atomic.temporary_name(path)
    pending[str(path)] = temporary
    return temporary


def _rename_all(pending: dict) -> None:
    """Rename each output's temporary file over its name (the run is committed)."""
    while pending:
        final, temporary = next(iter(pending.items()))
        try:
            atomic.commit(temporary, final)
        except OSError as err:
            raise OutputError(f"cannot put {final!r} in place: {err.strerror} (the run was stored; "
                              f"its file is {str(temporary)!r})") from None
        del pending[final]


def _left_on_disk(store, writer, traj) -> str:
    """What an interrupted run left behind, for the interrupt's one-line message."""
    if writer is not None and writer.si_num is not None:
        said = [f"simulation {writer.si_num} was stored in {store.shown!r} before the interrupt took effect"]
    elif store is not None:
        said = [f"nothing was written to {store.shown!r}"]
    else:
        said = ["no database was written"]
    if traj is not None:
        said.append(f"no trajectory was written to {str(getattr(traj, 'name', traj.path))!r}")
    return "; ".join(said)


def summary(scene: Scene, stats: RunStats, si_num, ke_start: float, ke_end: float,
            wall_momentum: np.ndarray | None = None) -> dict:
    """The --json summary of a run.

    ``pressure`` is the mean over the walls of the measured wall pressure
    (momentum / (T L^(D-1))), or the virial pressure in a periodic box; None
    when nothing was recorded to measure it. Each dimensioned value names its unit: beside
    it (``pressure_unit``: Pa in 3D, N/m in 2D, N in 1D; ``length_unit`` m, ``duration_unit``
    s, ``kinetic_energy_unit`` J for both kinetic energies), or in its key (``wall_time_s``,
    ``events_per_second``).
    """
    out = {
        "si_num": si_num,
        "engine": scene.engine,
        "engine_reason": scene.extras.get("engine_reason") if scene.extras else None,
        "dim": scene.dim,
        "n": scene.n,
        "length": scene.length,
        "length_unit": "m",
        "duration": scene.duration,
        "duration_unit": "s",
        "seed": scene.seed,
        "boundary": scene.boundary,
        "packing_fraction": scene.packing_fraction,
        "events": int(stats.events),
        "wall_bounces": int(stats.wall_bounces),
        "collisions": int(stats.collisions),
        "kinetic_energy_start": ke_start,
        "kinetic_energy_end": ke_end,
        "kinetic_energy_unit": "J",
        "pressure": run_pressure(scene, stats, ke_start, ke_end, wall_momentum),
        "pressure_unit": PRESSURE_UNIT[scene.dim],
        "wall_time_s": stats.wall_time_s,
        "events_per_second": stats.events / stats.wall_time_s if stats.wall_time_s > 0 else None,
    }
    for key, value in stats.extras.items():
        if isinstance(value, (int, float, str, bool)) or value is None:
            out.setdefault(key, value)
        elif isinstance(value, dict):
            out.setdefault(key, {k: v for k, v in value.items() if isinstance(v, (int, float, str))})
    return out


def write_state(path: str | None, scene: Scene, state: State, shown: str | None = None) -> None:
    """Final state as CSV: species,x[,y[,z]],vx[,vy[,vz]] (species by name, SI units). ``path``
    None: ``shown`` itself (a device); ``shown``: the name the messages give (a temporary file's)."""
    shown = path if shown is None else shown
    path = shown if path is None else path
    axes = "xyz"[: scene.dim]
    header = ["species", *axes, *(f"v{a}" for a in axes)]
    names = np.array([s.name for s in scene.species])[state.kinds]
    try:
        with open(Path(path), "w", encoding="utf-8") as fh:
            fh.write(",".join(header) + "\n")
            for name, x, v in zip(names, state.positions, state.velocities):
                fh.write(",".join([str(name), *(repr(float(c)) for c in x),
                                   *(repr(float(c)) for c in v)]) + "\n")
    except OSError as err:
        raise SceneError(f"cannot write --save-state {str(shown)!r}: {err.strerror}") from None


def run_pressure(scene: Scene, stats: RunStats, ke_start: float, ke_end: float,
                 wall_momentum: np.ndarray | None = None) -> float | None:
    """The summary's pressure (:data:`gaz_cli.constants.PRESSURE_UNIT`: Pa, N/m or N): mean wall
    pressure, or the virial pressure in a periodic box."""
    from gaz_cli import theory

    if scene.boundary == "periodic":
        temperature = theory.kinetic_temperature(scene.dim, 0.5 * (ke_start + ke_end), scene.n, periodic=True)
        return float(theory.virial_pressure(scene.dim, scene.n, temperature, scene.volume,
                                            stats.virial, scene.duration))
    if wall_momentum is None:
        return None
    return float(np.mean(wall_momentum) / (scene.duration * scene.length ** (scene.dim - 1)))


def partner_search(summary: dict) -> str | None:
    """How the event engine found collision partners, in words, from a run's summary (its
    ``neighbour_lists``, ``dilute_scan``, ``wide_cells``, ``size_classes``,
    ``cells_per_axis``); None for the other engines."""
    if "cells_per_axis" not in summary:
        return None
    if summary["dim"] == 1:
        return "the two neighbours on the line"
    if summary.get("neighbour_lists"):
        return f"neighbour lists, cells {summary['cells_per_axis']} an axis"
    if summary.get("dilute_scan"):
        return "the scan of every particle (a dilute gas: no cells)"
    if summary.get("wide_cells"):
        return f"wide cells scanned in float32, {summary['cells_per_axis']} an axis"
    if summary.get("size_classes"):
        return (f"cells per size class, {summary['cells_per_axis']} fine and "
                f"{summary.get('coarse_cells_per_axis')} coarse an axis")
    return f"cells, {summary['cells_per_axis']} an axis"


def describe(summary: dict) -> str:
    """A human-readable summary of a run (the non-JSON output of ``gaz simulate``)."""
    lines = []
    where = f"simulation {summary['si_num']}" if summary["si_num"] is not None else "simulation (not stored)"
    lines.append(f"{where}: {summary['n']} particles in {summary['dim']}D, L = {summary['length']:g} m, "
                 f"T = {summary['duration']:g} s, engine {summary['engine']}, seed {summary['seed']}")
    if summary.get("engine_reason"):
        lines.append(f"  engine {summary['engine']}: {summary['engine_reason']}")
    search = partner_search(summary)
    if search:
        lines.append(f"  partner search: {search}")
    lines.append(f"  packing fraction {summary['packing_fraction']:.4g}, boundary {summary['boundary']}")
    lines.append(f"  events {summary['events']}  wall bounces {summary['wall_bounces']}  "
                 f"collisions {summary['collisions']}")
    ks, ke = summary["kinetic_energy_start"], summary["kinetic_energy_end"]
    drift = (ke - ks) / ks if ks else 0.0
    lines.append(f"  kinetic energy {ks:.6g} J -> {ke:.6g} J (relative change {drift:.2e})")
    if summary["pressure"] is not None:
        how = "mean over the walls" if summary["boundary"] == "walls" else "collision virial"
        lines.append(f"  pressure {summary['pressure']:.6g} {PRESSURE_UNIT[summary['dim']]} ({how})")
    eps = summary["events_per_second"]
    lines.append(f"  run time {summary['wall_time_s']:.3g} s"
                 + (f", {eps:,.0f} events/s" if eps else ""))
    phases = summary.get("phase_times")
    if isinstance(phases, dict) and phases:
        lines.append("  time per phase: " + "  ".join(f"{k} {v:.3g} s" for k, v in phases.items()))
    return "\n".join(lines)
