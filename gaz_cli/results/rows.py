"""One run's rows: the mapping from a run to the rows of every table, used by both writers.

A run is its :class:`~gaz_cli.model.scene.Scene`, the time it started, the numbers its
database gives it (SI_NUM; each species' PA_NUM), the engine's arrays (REBOND and CHOC
columns, :class:`TableRecorder`) and its summary (the engine's
:class:`~gaz_cli.model.recording.RunStats`, the kinetic energy at start and end, J).
:class:`RunStore` is what both front ends share: the ``simulation()`` block that hands
out a run's writer and commits it whole.

Each function returns one table's rows as plain Python values (int, float, str, None, a
``datetime``), keyed by lower-case column name in the table's order
(:mod:`gaz_cli.results.schema`). The writers insert them as given: the SQLite writer
through ``sqlite3`` (:mod:`gaz_cli.results.sqlite`, which writes a ``datetime`` as
SQLAlchemy's DATETIME text), the PostgreSQL writer through SQLAlchemy and COPY
(:mod:`gaz_cli.results.postgres`). REBOND and CHOC come as columns (numpy arrays, one per
column, in the table's order). Units are converted here and nowhere else: the exam's PA_M
in grams (:attr:`Species.mass_g`), every other value SI. No database, no SQLAlchemy is
imported.
"""

from __future__ import annotations

import contextlib
import datetime as _dt

import numpy as np

from gaz_cli import __version__
from gaz_cli.model.recording import PROFILE_SAMPLES, DensityProfile, Recorder, RunStats, profile_wanted
from gaz_cli.model.scene import OPTIONS, Scene
from gaz_cli.model.species import BUILTIN, Species
from gaz_cli.scenes import files as scenefile

SAME_SPECIES_RTOL = 1e-12
"""Two species of one name are one PARTICULE row when their masses (g) and radii (m) agree
to this relative tolerance: the row's floats round-trip, a value typed again does too."""


_COLUMN_TYPES = {"real": float, "int": int, "str": str}
"""The Python type a SCENE column takes, by the option's kind."""


def simulation_row(scene: Scene, started: _dt.datetime) -> dict:
    """SIMULATION's row but SI_NUM (the database numbers it): start, simulated duration s,
    dimension, N, box side m."""
    return {"si_deb": started, "si_dur": float(scene.duration), "si_dim": int(scene.dim),
            "si_n": int(scene.n), "si_l": float(scene.length)}


def composition_rows(si_num: int, pa_nums: list[int], scene: Scene) -> list[dict]:
    """COMPOSITION's rows: one per species of the scene, in its order (CO_RANK 0 first, the
    order of the particles' blocks), with its count. ``pa_nums``: each species' PA_NUM."""
    return [{"si_num": si_num, "pa_num": num, "co_n": int(k), "co_rank": rank}
            for rank, (num, (_, k)) in enumerate(zip(pa_nums, scene.components))]


def scene_row(si_num: int, scene: Scene) -> dict:
    """SCENE's row: the options that made the run, this gaz's version, and the scene file that
    runs it again with the same rows (SC_FILE, :func:`gaz_cli.scenes.files.dumps`)."""
    row = {"si_num": si_num}
    for name, option in OPTIONS.items():  # the options with a column of their own: the table's rows
        if option.column:
            value = getattr(scene, name)
            row[f"sc_{name}"] = None if value is None else _COLUMN_TYPES[option.kind](value)
    return {**row, "sc_version": __version__, "sc_file": scenefile.dumps(scene)}


def result_row(si_num: int, stats: RunStats, ke_start: float, ke_end: float) -> dict:
    """RESULTAT's row: event counts, kinetic energy at start and end (J), the collisional
    virial (kg m^2/s) and the engine's wall-clock time (s)."""
    return {"si_num": si_num, "rs_events": int(stats.events), "rs_bounces": int(stats.wall_bounces),
            "rs_collisions": int(stats.collisions), "rs_ke_start": float(ke_start),
            "rs_ke_end": float(ke_end), "rs_virial": float(stats.virial),
            "rs_wall_time": float(stats.wall_time_s)}


def profile_rows(si_num: int, profile: DensityProfile | None) -> list[dict]:
    """PROFIL's rows: one per (axis 1..D, block, bin) of the run's density profile, its
    samples and count of centres (:class:`gaz_cli.model.recording.DensityProfile`); none
    without a profile or a sample."""
    if profile is None or not profile.samples.sum():
        return []
    return [{"si_num": si_num, "pr_axis": d + 1, "pr_block": b, "pr_bin": k,
             "pr_samples": int(profile.samples[b]), "pr_count": int(profile.counts[d, b, k])}
            for d in range(profile.dim) for b in range(profile.samples.size) if profile.samples[b]
            for k in range(profile.counts.shape[2])]


def particule_row(species: Species) -> dict:
    """PARTICULE's row of a species but PA_NUM (the database numbers it): name, mass in grams
    (the exam's unit), radius m."""
    return {"pa_nom": species.name, "pa_m": species.mass_g, "pa_r": species.radius}


def builtin_particule_rows() -> list[dict]:
    """PARTICULE's rows of a new database: the built-in species, in their order."""
    return [particule_row(sp) for sp in BUILTIN.values()]


def species_number(species: Species, rows) -> int | None:
    """PA_NUM of ``species`` among ``rows`` of PARTICULE bearing its name, as
    ``(pa_num, pa_m g, pa_r m)`` in PA_NUM order: the first whose mass and radius are its
    own (:data:`SAME_SPECIES_RTOL`); None when none is (the writer then adds its row)."""
    for num, m_g, r in rows:
        if _close(m_g, species.mass_g) and _close(r, species.radius):
            return int(num)
    return None


def _close(found: float, wanted: float) -> bool:
    """numpy's ``isclose(found, wanted, rtol=SAME_SPECIES_RTOL, atol=0)``, without numpy."""
    return abs(found - wanted) <= SAME_SPECIES_RTOL * abs(wanted)


class RunStore:
    """What both database front ends share (:class:`gaz_cli.results.store.Store`,
    :class:`gaz_cli.results.sqlite.SqliteFile`): a context manager (``close`` at the end)
    whose :meth:`simulation` hands out one run's writer and commits it at the block's end.
    A front end provides ``close()``, ``_errors()`` (a context turning its database's
    failures into one StoreError line) and ``_writer(scene, started)`` (a
    :class:`TableRecorder` with ``commit()`` and ``abort()``)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @contextlib.contextmanager
    def simulation(self, scene, started: _dt.datetime | None = None):
        """One simulation's writer (a :class:`Recorder`), committed at the end.

        Call ``finish(stats, ke_start, ke_end)`` inside the block; the block's
        normal end commits in one short transaction and sets ``si_num``; an
        exception (KeyboardInterrupt included) discards everything.
        """
        started = started or _dt.datetime.now().replace(microsecond=0)
        with self._errors():
            run = self._writer(scene, started)
        try:
            yield run
            if not run.finished:
                raise RuntimeError("the simulation's finish() was not called")
            with self._errors():
                run.commit()
        except BaseException:
            run.abort()
            raise


class TableRecorder(Recorder):
    """What every database writer shares: which rows it keeps (the scene's ``record``),
    the REBOND and CHOC columns in table order from the engine's arrays, row numbers
    from 1, and the results kept for the commit.

    A writer provides ``_add(table_name, columns)``, ``_errors()`` (a context turning its
    database's failures into one line), ``_si`` (the SI_NUM its rows carry while they
    wait) and ``_pa_of_particle`` (each particle's PA_NUM, or species index). ``si_num``
    is None until the commit has succeeded.
    """

    def __init__(self, scene, started):
        self.scene = scene
        self.started = started
        self.want_bounces = scene.record in ("bounces", "all")
        self.want_collisions = scene.record == "all"
        self.finished = False
        self.si_num = None
        self._n = {"rebond": 0, "choc": 0}
        self._result = None
        self.profile = DensityProfile(scene.dim, scene.length) if profile_wanted(scene) else None
        self.profile_samples = PROFILE_SAMPLES if self.profile is not None else 0

    def add_profile_sample(self, t, positions):
        self.profile.add(positions)

    def _numbers(self, table: str, k: int) -> np.ndarray:
        """The next ``k`` row numbers of ``table`` (RE_NUM, CH_NUM: 1, 2, ... in each run)."""
        start = self._n[table] + 1
        self._n[table] += k
        return np.arange(start, start + k)

    def add_bounces(self, t, particle, wall, speed, vperp):
        k = len(t)
        if k:
            with self._errors():
                self._add("rebond", [np.full(k, self._si, dtype=np.int64), self._numbers("rebond", k),
                                     self._pa_of_particle[np.asarray(particle)], np.asarray(t, dtype=float),
                                     np.asarray(wall, dtype=np.int64), np.asarray(speed, dtype=float),
                                     np.asarray(vperp, dtype=float)])

    def add_collisions(self, t, i, j, impulse):
        k = len(t)
        if k:
            with self._errors():
                self._add("choc", [np.full(k, self._si, dtype=np.int64), self._numbers("choc", k),
                                   np.asarray(t, dtype=float), np.asarray(i, dtype=np.int64),
                                   np.asarray(j, dtype=np.int64), np.asarray(impulse, dtype=float)])

    def finish(self, stats: RunStats, ke_start: float, ke_end: float) -> None:
        """Keep the run's results for the commit."""
        self._result = (stats, ke_start, ke_end)
        self.finished = True
