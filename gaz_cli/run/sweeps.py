"""Sweeps: one scene, some of its keys varied, several seeds, run on Dask.

A sweep is the cartesian product of the varied keys' values times K seeds
(:func:`plan`); each point is one ordinary simulation. The points run on a
Dask cluster -- a :class:`distributed.LocalCluster` of this machine's cores by
default, or an existing cluster given by its scheduler's address -- and each
worker returns arrays (the run's bounces, collisions and results), never
touching the database: the client alone writes, one run at a time, as runs
finish (:func:`run`). So SQLite works, a crash of a worker loses only its
run, and an interrupt keeps every run already stored.

Before any cluster starts, a sweep into a SQLite file whose runs would not fit on its
disk is refused, as ``gaz simulate`` refuses one run
(:func:`gaz_cli.results.budgets.check_database_space`: every run's rows, and the largest one's
copy in the WAL file and scratch file), and a sweep into a PostgreSQL database made before
schema 6 whose runs would number their rows past its 32-bit integers
(:meth:`gaz_cli.results.store.Store.check_row_numbers`).
Until these checks have passed and the cluster answers, the database is only read (the
runs it holds already): nothing is created or migrated for a sweep that is refused.

A run already in the database -- the same scene file text, seed included
(SCENE.SC_FILE) -- is skipped, so running the same sweep again finishes an
interrupted one. Every point goes through the scene's door (:func:`gaz_cli.scenes.validate.validate`)
before anything is read or run: one refused is the whole sweep refused, in one line
(:func:`_refuse_points_that_cannot_run`). A run that fails on its worker (a placement that
gives up) is reported and the others go on.

The seeds of a sweep are ``base, base + 1, ..., base + K - 1`` where ``base``
is the scene's own seed (1 if it has none): the same command gives the same
runs, row for row.
"""

from __future__ import annotations

import gc
import itertools
import logging
import math
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Any, Callable

from gaz_cli import interrupts
from gaz_cli.errors import GazError, Interrupted, SceneError

SCHEDULER_TIMEOUT_S = 10
"""How long to wait for an existing Dask scheduler to answer, s."""

MAX_POINTS = 100_000
"""A sweep larger than this is refused (a typo in START:STOP:COUNT, most likely)."""


def cores() -> int:
    """The cores this process may run on (its CPU affinity where the system says; else the
    machine's count): the local cluster's default size and its bound."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # no affinity on this system (macOS, Windows)
        return os.cpu_count() or 1


def check_workers(workers, scheduler: str | None = None) -> None:
    """Raise SceneError unless ``workers`` (``--workers``) is None or a whole number from 1 to
    :func:`cores`: each worker is a process running one simulation at a time, so more than the
    cores only share them (and a huge count would start that many processes). With a
    ``scheduler`` it would be ignored (that cluster's workers run the sweep): refused too."""
    if workers is None:
        return
    if scheduler:
        raise SceneError(f"--workers {workers!r} sizes the local cluster, and --scheduler {scheduler!r} runs the "
                         "sweep on its own cluster's workers: drop --workers (or --scheduler, to run here)")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise SceneError(f"--workers {workers!r} must be a whole number from 1 to the {cores()} cores of "
                         "this machine (or leave it out: one worker per core)")
    if workers > cores():
        raise SceneError(f"--workers {workers} is more than the {cores()} cores of this machine (each worker "
                         f"runs one simulation at a time); give --workers {cores()} or fewer, or leave it out")


# --- the plan -------------------------------------------------------------------
def parse_vary(text: str) -> tuple[str, list]:
    """``KEY=V1,V2,...`` or ``KEY=START:STOP:COUNT`` (COUNT values, both ends included).

    Values are read as the key takes them (:data:`gaz_cli.scenes.files.SCALARS`; ``count`` and
    ``count.NAME`` whole numbers): a whole number written ``1e2`` or reached by a range is an
    int, ``true``/``false`` a boolean. A key of no known type (refused later, with its closest
    name): ints where every value reads as an int, else floats, else strings. Raises
    SceneError naming the problem.
    """
    key, sep, values = text.partition("=")
    key = key.strip()
    if not sep or not key or not values.strip():
        raise SceneError(f"--vary {text!r}: write KEY=V1,V2,... or KEY=START:STOP:COUNT "
                         "(e.g. packing=0.1:0.6:6)")
    if ":" in values:
        parts = values.split(":")
        try:
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        except (ValueError, IndexError):
            raise SceneError(f"--vary {text!r}: START:STOP:COUNT needs two numbers and a whole count "
                             "(e.g. packing=0.1:0.6:6)") from None
        if len(parts) != 3 or count < 1 or not (math.isfinite(start) and math.isfinite(stop)):
            raise SceneError(f"--vary {text!r}: START:STOP:COUNT needs finite ends and COUNT >= 1")
        if count > MAX_POINTS:
            raise SceneError(f"--vary {text!r}: COUNT {count} makes more than {MAX_POINTS} runs; "
                             "vary fewer values")
        if count == 1 and stop != start:
            raise SceneError(f"--vary {text!r}: COUNT 1 is START alone, {parts[1].strip()} left out; give "
                             f"{key}={parts[0].strip()}, or COUNT 2 or more to reach STOP")
        step = (stop - start) / (count - 1) if count > 1 else 0.0
        return key, _once(text, _typed(text, key, [_tidy(start + k * step) for k in range(count)], ranged=True))
    from gaz_cli.model.species import split_list

    items = split_list(values, f"--vary {text!r}", f"{key}=100,200,300")
    return key, _once(text, _typed(text, key, items))


def _kind(key: str) -> str | None:
    """The type a scene key takes (:data:`gaz_cli.scenes.files.SCALARS`; ``count`` and ``count.NAME``
    a whole number); None for a key of no known type."""
    from gaz_cli.scenes import files as scenefile

    if key == "count" or key.startswith("count."):
        return scenefile.INT
    return scenefile.SCALARS.get(key, (None,))[0]


def _typed(text: str, key: str, values: list, ranged: bool = False) -> list:
    """``values`` (strings as typed, or a range's floats) read as ``key`` takes them; SceneError
    naming the first one that is not of its type."""
    from gaz_cli.scenes import files as scenefile

    kind = _kind(key)
    if kind == scenefile.BOOL:
        truth = {"true": True, "false": False}
        wrong = next((v for v in values if str(v).lower() not in truth), None)
        if wrong is not None:
            raise SceneError(f"--vary {text!r}: {wrong!r} is not true or false; {key} takes true or false")
        return [truth[str(v).lower()] for v in values]
    if kind == scenefile.STR:
        return values
    numbers = [_number(v) for v in values]
    if kind in (scenefile.REAL, scenefile.INT) and None in numbers:  # the value that is not a number
        raise SceneError(f"--vary {text!r}: {values[numbers.index(None)]!r} is not a number; {key} takes numbers")
    if kind == scenefile.INT:
        wrong = next((v for v in numbers if not float(v).is_integer()), None)
        if wrong is not None:
            fix = " (choose COUNT so that the step (STOP - START)/(COUNT - 1) is whole)" if ranged else ""
            raise SceneError(f"--vary {text!r}: {wrong!r} is not a whole number; {key} takes whole numbers{fix}")
        return [int(v) for v in numbers]
    if None in numbers:  # no known type: strings (the key is refused later, by its name)
        return values
    return numbers if all(isinstance(v, int) for v in numbers) else [float(v) for v in numbers]


def _number(value):
    """``value`` (a string as typed, or a number) as an int when it reads as one, else a float;
    None when it is no number."""
    if not isinstance(value, str):
        return value
    for kind in (int, float):
        try:
            return kind(value)
        except ValueError:
            continue
    return None


def _once(text: str, values: list) -> list:
    """``values``, refused when one comes twice: each would be run and stored twice, the same
    scene with the same seed, and counted twice in the mean over the runs."""
    seen = set()
    for v in values:
        if v in seen:
            raise SceneError(f"--vary {text!r}: {v!r} comes twice; give each value once "
                             "(--seeds K runs each point with K seeds)")
        seen.add(v)
    return values


def _tidy(x: float) -> float:
    """0.30000000000000004 -> 0.3: the value a user would have typed (12 significant digits)."""
    return float(f"{x:.12g}")


@dataclass(frozen=True)
class Point:
    """One run of a sweep: the varied keys' values and the seed."""

    values: tuple  # ((key, value), ...) in the order the keys were given
    seed: int

    @property
    def label(self) -> str:
        return " ".join([*(f"{k}={v}" for k, v in self.values), f"seed={self.seed}"])

    def overrides(self) -> dict:
        return {**dict(self.values), "seed": self.seed}


def plan(varies: list[tuple[str, list]], seeds: int, base_seed: int | None = None) -> list[Point]:
    """The sweep's points: the cartesian product of ``varies`` times ``seeds`` seeds."""
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise SceneError(f"--seeds {seeds!r}: give a whole number, at least 1")
    keys = [k for k, _ in varies]
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        raise SceneError(f"--vary {repeated[0]} is given twice; give each key once with all its values")
    if "seed" in keys:
        raise SceneError("--vary seed: use --seeds K (K seeds from the scene's seed on)")
    total = seeds * math.prod(len(v) for _, v in varies)
    if total > MAX_POINTS:
        raise SceneError(f"the sweep has {total} runs, more than {MAX_POINTS}; "
                         "vary fewer values or fewer seeds")
    base = 1 if base_seed is None else int(base_seed)
    return [Point(tuple(zip(keys, combo)), base + k)
            for combo in itertools.product(*(v for _, v in varies)) for k in range(seeds)]


# --- a scene file's points -----------------------------------------------------
def varied_keys(species: list[str]) -> list[str]:
    """What ``--vary`` may name in a sweep of a file whose species are named ``species``: a
    top-level key of a scene file but ``seed`` (``--seeds``), and the count of a species:
    ``count`` (a file of one species) and ``count.NAME`` for each species."""
    from gaz_cli.scenes import files as scenefile

    scalars = [k for k in scenefile.SCALARS if k != "seed"]
    return scalars + (["count"] if len(species) == 1 else []) + [f"count.{name}" for name in species]


def check_varied_key(key: str, species: list[str], where: str = "") -> None:
    """Raise SceneError, one line, unless a sweep of a file whose species are named ``species``
    can vary ``key`` (:func:`varied_keys`; ``seed`` passes: :func:`plan` tells it to use
    --seeds). The closest allowed name is suggested (:func:`gaz_cli.scenes.files.unknown_name`),
    and the allowed ones listed."""
    from gaz_cli.scenes import files as scenefile

    allowed = varied_keys(species)
    if key in allowed or key == "seed":
        return
    name = key.partition(".")[2]
    counts = [k for k in allowed if k == "count" or k.startswith("count.")]
    if key.startswith("count.") and name:
        raise SceneError(f"{where}--vary {key}: {scenefile.unknown_name(name, species, 'species')}; the file's "
                         f"species: {', '.join(species) or 'none'} (vary {' or '.join(counts) or 'no count'})")
    if key == "count":  # several species: which count?
        raise SceneError(f"{where}--vary count needs one species; with several, vary one of {', '.join(counts)}")
    raise SceneError(f"--vary {key}: {scenefile.unknown_name(key, allowed, 'parameter')}; "
                     f"a sweep can vary {', '.join(allowed)}")


def scenes_of_file(path, keys=()) -> tuple[Callable[[dict], Any], int | None, dict]:
    """The scene builder of a sweep over the scene file ``path``, the file's seed, and its
    ``[output]`` table (where the runs go: :func:`gaz_cli.scenes.files.database`).

    A point's overrides set top-level keys of the file (``packing``, ``temperature``,
    ``length``, ``duration``, ``seed``...), or ``count`` -- the count of the file's one
    species (several species: ``count.NAME``). Each scene goes through the same door as
    ``gaz simulate FILE`` (:func:`gaz_cli.scenes.files.build`). ``keys``: the keys the sweep
    varies, refused here, before any run, unless the file's sweep can vary them
    (:func:`check_varied_key`).
    """
    from gaz_cli.scenes import files as scenefile

    doc = scenefile.read(path)
    where = f"{path}: "
    scenefile.check(doc, where)  # the file's own unknown keys and types first, once
    species = [str(t.get("name")) for t in doc.get("species", []) if isinstance(t, dict)]
    for key in keys:
        check_varied_key(key, species, where)
    if "packing" in keys and "length" in keys:  # each replaces the other (scene_of): one would be ignored
        raise SceneError("--vary packing and --vary length both set the box side; vary one of them "
                         "(with packing, the box follows from it and the counts)")
    fields = {("n" if key == "count" or key.startswith("count.") else key): key for key in keys}
    fixed = [fields[k] for k in scenefile.fixed_by_initial(doc, fields)]
    if fixed:  # the sweep's runs would differ in their labels only (gaz simulate refuses these flags too)
        kind = doc["initial"].get("kind", "explicit") if isinstance(doc["initial"], dict) else "explicit"
        raise SceneError(f"{where}its initial state ([initial] kind = {kind!r}) fixes {', '.join(fixed)}: every "
                         f"point would run the same state, whatever its {', '.join(fixed)}; vary another key, or "
                         "describe the scene without its initial state")

    def scene_of(overrides: dict):
        point = {k: v for k, v in doc.items() if k != "output"}
        point["species"] = [dict(t) for t in doc.get("species", [])]
        for key, value in overrides.items():
            if key == "count" or key.startswith("count."):
                _set_count(point["species"], key, value, where)
            else:
                if key == "packing":
                    point.pop("length", None)
                elif key == "length":
                    point.pop("packing", None)
                point[key] = value
        return scenefile.build(point, where)[0]

    seed = doc.get("seed")
    outputs = doc.get("output")
    if outputs is not None:
        scenefile.check({"output": outputs}, where)  # its db must be a path before the store opens it
        ignored = [k for k in outputs if k != "db"]
        if ignored:
            import warnings

            from gaz_cli.errors import GazWarning

            warnings.warn(f"{where}[output] {', '.join(ignored)} not written by a sweep (its runs would write "
                          "over each other's files); only [output] db is used: run one point with gaz simulate "
                          "for its files", GazWarning, stacklevel=2)
    return (scene_of, seed if isinstance(seed, int) and not isinstance(seed, bool) else None,
            dict(outputs or {}))


def _set_count(species: list, key: str, value, where: str) -> None:
    """Set the count of ``key`` (``count``, ``count.NAME``: checked once, before any point, by
    :func:`check_varied_key`)."""
    name = key.partition(".")[2]
    next(t for t in species if not name or str(t.get("name")) == name)["count"] = value


def key_of(scene) -> str:
    """How a run is recognised in the database: its scene file, seed included (SCENE.SC_FILE)."""
    from gaz_cli.scenes import files as scenefile

    return scenefile.dumps(scene)


# --- one run, on a worker -------------------------------------------------------
def simulate_in_memory(scene):
    """Run one scene without a database; return its :class:`~gaz_cli.run.runner.Run` with the
    arrays the store needs (the worker's task)."""
    from gaz_cli.run.runner import run_scene

    return run_scene(scene, keep_bounces=scene.record in ("bounces", "all"),
                     keep_collisions=scene.record == "all")


# --- the sweep, on the client ----------------------------------------------------
@dataclass
class Report:
    """What happened to each point: stored (with its SI_NUM), skipped (already stored) or failed."""

    rows: list = field(default_factory=list)  # (point, status, si_num or None, message)
    db: str = ""  # where the runs were stored (a path or URL, as given)
    helpers: str | None = None
    """What went wrong with the processes the sweep started besides its runs (multiprocessing's
    resource tracker died, a helper wrote on stderr), one line; None if nothing did. The runs
    stored are whole all the same; ``gaz sweep`` exits 1."""

    def count(self, status: str) -> int:
        return sum(1 for r in self.rows if r[1] == status)

    @property
    def failed(self) -> int:
        return self.count("failed")

    def in_order(self, points: list) -> "Report":
        """This report, its rows sorted in the order of ``points`` (the plan's)."""
        rank = {point: k for k, point in enumerate(points)}
        self.rows.sort(key=lambda row: rank[row[0]])
        return self


def run(points: list[Point], scene_of: Callable[[dict], Any], key: Callable[[Any], str] | None,
        db: str, workers: int | None = None, scheduler: str | None = None,
        progress: bool | None = None) -> Report:
    """Run every point not already in ``db``; store each as it finishes; return the report,
    its rows in the order of ``points`` (the same sweep, the same table; not the order the runs
    finished in).

    ``scene_of(overrides)`` builds (and validates) the scene of a point;
    ``key(scene)`` is the text by which a run already stored is recognised among
    SCENE.SC_FILE's (default :func:`key_of`, the scene file itself). ``workers``: LocalCluster size (default the
    core count, :func:`cores`; more is refused, :func:`check_workers`); ``scheduler``: address of an
    existing Dask scheduler instead.
    ``progress``: a progress bar on stderr (default: when stderr is a terminal).
    Raises :class:`~gaz_cli.errors.Interrupted` on SIGINT/SIGTERM, saying what
    was stored.
    """
    from gaz_cli.run.runner import prepare, sqlite_file
    from gaz_cli.results.budgets import check_database_space
    from gaz_cli.results.store import Store

    from gaz_cli.results.sqlite import database_name
    from gaz_cli.results.writer import open_for_writing

    check_workers(workers, scheduler)
    db = database_name(db)  # a pathlib.Path as its text
    key = key or key_of
    report = Report(db=db)
    built, refused = [], {}
    for point in points:  # every scene built and validated (cheap) before the database or a cluster
        try:
            built.append((point, prepare(scene_of(point.overrides()))))
        except GazError as err:  # an impossible point (e.g. a packing beyond the densest)
            refused[point] = str(err)
    _refuse_points_that_cannot_run(points, refused)
    path = sqlite_file(db)
    todo = []
    if path is not None and not os.path.exists(os.path.expanduser(path)):
        done = {}  # a new file: every point runs, and the file is created after the checks
    else:
        # read only: a database refused (foreign, newer) is refused here, and one to create or
        # migrate is written only once the checks below have passed and the cluster answers
        with Store(db, create=False, empty_ok=True) as store:
            done = store.scene_files()  # SC_FILE -> SI_NUM
            try:  # a PostgreSQL database made before schema 6 numbers its rows in 32 bits
                store.check_row_numbers([scene for _, scene in built])
            except SceneError as err:
                raise SceneError(str(err)) from None  # the scene file's key names, not gaz simulate's flags
    _refuse_points_that_are_one_run(built, key)
    for point, scene in built:
        if key(scene) in done:
            report.rows.append((point, "skipped", done[key(scene)], "already in the database"))
        else:
            todo.append((point, scene))
    if not todo:
        return report.in_order(points)
    try:
        if path is not None:  # the runs to do, one after the other, on the database's disk
            check_database_space([scene for _, scene in todo], path,
                                 fix="vary fewer values or seeds, shorten `duration`")
    except SceneError as err:
        raise SceneError(str(err)) from None
    # the cluster before the database: an unreachable --scheduler creates or migrates nothing
    # a new SQLite file takes its name with the first run stored (sqlite_writer.SqliteFile): none if none is
    helpers = _Helpers()
    with interrupts.catching(), helpers, _client(workers, scheduler, len(todo)) as client, \
            open_for_writing(db) as store, _Bar(len(todo), progress) as bar:
        before = len(report.rows)
        try:
            _run_all(client, store, todo, report, bar)
        except BaseException as exc:
            signum = interrupts.signal_of(exc)
            if signum is None:
                raise
            left = len(todo) - (len(report.rows) - before)
            raise Interrupted(signum, f"{report.count('stored')} runs of the sweep were stored in "
                                      f"{store.shown!r}, {left} were not; run the same sweep again to "
                                      "finish it (stored runs are skipped)") from None
    report.helpers = helpers.trouble()
    return report.in_order(points)


def _tracker() -> int | None:
    """The process id of multiprocessing's resource tracker, a child of this process, started
    here if it was not (None where it cannot be known)."""
    try:
        from multiprocessing import resource_tracker

        resource_tracker.ensure_running()
        return resource_tracker._resource_tracker._pid  # (private)
    except (ImportError, AttributeError, OSError):
        return None


def _tracker_died(first: int | None) -> bool:
    """Whether the resource tracker ``first`` has died: relaunched since (at the next semaphore
    made or freed, with a warning), or dead and not relaunched yet."""
    if first is None:
        return False
    try:
        from multiprocessing import resource_tracker

        if resource_tracker._resource_tracker._pid != first:
            return True
        return os.waitpid(first, os.WNOHANG)[0] == first
    except (ImportError, AttributeError, ChildProcessError, OSError):
        return False


class _Helpers:
    """The standard error of the processes a sweep starts (the cluster's workers, and
    multiprocessing's resource tracker, relaunched by this process when it dies) goes to a
    temporary file while the cluster lives; this process's own (``sys.stderr``: the bar, gaz's
    lines) is kept on the real one. A resource tracker killed in the middle of a sweep (SIGKILL,
    the OOM killer) was relaunched with a warning, and the new one printed a KeyError traceback
    for every semaphore the old one had registered: 51 lines, exit 0. :meth:`trouble` makes one
    line of it. Where standard error is no real descriptor (a test's capture), nothing moves."""

    def __init__(self):
        self.died = False
        self._saved = self._file = self._stderr = self._warnings = self._first = None

    def __enter__(self):
        import tempfile
        import warnings

        self._warnings = warnings.catch_warnings(record=True)
        self._caught = self._warnings.__enter__()
        warnings.simplefilter("always", UserWarning)  # (resource_tracker's "process died unexpectedly")
        try:
            fd = sys.stderr.fileno()
        except (AttributeError, OSError, ValueError):
            return self
        if fd != 2:
            return self
        sys.stderr.flush()
        self._file = tempfile.TemporaryFile()
        self._saved = os.dup(2)
        self._stderr = sys.stderr
        sys.stderr = open(os.dup(self._saved), "w", encoding=self._stderr.encoding,  # noqa: SIM115
                          errors=self._stderr.errors, buffering=1)
        os.dup2(self._file.fileno(), 2)
        self._first = _tracker()  # (started now, its standard error the file's)
        return self

    def __exit__(self, *exc):
        try:
            if self._saved is not None:
                sys.stderr.flush()
                sys.stderr.close()
                sys.stderr = self._stderr
                os.dup2(self._saved, 2)
                os.close(self._saved)
        finally:
            self.died = self.died or _tracker_died(self._first)
            self._warnings.__exit__(*exc)
            for w in self._caught:
                if "resource_tracker" in str(w.message):
                    self.died = True
                else:  # another warning of the sweep's: shown as before
                    import warnings

                    warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        return False

    def trouble(self) -> str | None:
        """One line for what went wrong with the helper processes, or None."""
        written = b""
        if self._file is not None:
            self._file.seek(0)
            written = self._file.read()
            self._file.close()
        lines = [line for line in written.decode(errors="replace").splitlines() if line.strip()]
        if not self.died and not lines:
            return None
        what = ("multiprocessing's resource tracker, a helper process of the cluster, died during the "
                "sweep (killed, or out of memory)" if self.died else
                "the sweep's helper processes wrote on standard error")
        last = f" (their last line: {lines[-1].strip()[:200]!r})" if lines else ""
        return (f"{what}{last}; the runs stored are whole (the table above), but the cluster's named "
                "semaphores may be left in /dev/shm; look for what killed it (dmesg)")


def _refuse_points_that_cannot_run(points: list[Point], refused: dict) -> None:
    """Raise SceneError, in one line, when a point of the sweep cannot run: the scene door
    (:func:`gaz_cli.scenes.validate.validate`, through ``scene_of``) refused it. ``refused``: each such
    point and the door's message. Said before any database or cluster, so that a sweep either
    runs every point or none (a packing beyond the densest at its third value ran and stored
    the first two).

    An error of the file itself (``restitution = 2``, ``seed = -1``) refuses every point alike:
    its message alone. Otherwise the first point refused, named by its values (the ones every
    point sharing them fails with: the value to drop; else the whole point, seed included),
    its message, and how many runs were refused; a seed that every point fails with, likewise."""
    if not refused:
        return
    messages = set(refused.values())
    firsts = list({p.values: p for p in reversed(points)}.values())  # each set of values, its first seed
    if len(messages) == 1 and all(p in refused for p in firsts):
        raise SceneError(next(iter(messages)))
    point = next(p for p in points if p in refused)
    if len(refused) == len(points):
        raise SceneError(f"no point of the sweep can run; the first, {point.label}: {refused[point]}")
    blamed = [(k, v) for k, v in point.values
              if all(q in refused for q in points if dict(q.values)[k] == v)]
    if blamed:
        what = "--vary " + " ".join(f"{k}={v}" for k, v in blamed)
        fix = "drop " + " and ".join(f"{v} from --vary {k}" for k, v in blamed)
    elif all(q in refused for q in points if q.seed == point.seed):  # --seeds K went past what a seed may be
        what = f"--seeds: seed {point.seed}"
        fix = "lower --seeds or the file's seed"
    else:  # this combination only, or this seed: no one value is wrong everywhere
        what = f"--vary {point.label}"
        fix = "change the values or the seeds so that every combination can run"
    raise SceneError(f"{what}: {refused[point]}; {fix} ({len(refused)} of {len(points)} runs refused, "
                     "none started)")


def _refuse_points_that_are_one_run(built: list, key: Callable[[Any], str]) -> None:
    """Raise SceneError, one line, when two points build the same run (``key`` of their scenes
    equal: the same scene file, seed included), which would be run and stored twice and counted
    twice in a mean over the runs: e.g. ``--vary engine=auto,event`` where auto takes the event
    engine. ``built``: (point, scene) pairs."""
    seen = {}
    for point, scene in built:
        first = seen.setdefault(key(scene), point)
        if first is not point:
            raise SceneError(f"--vary: {first.label} and {point.label} are the same run (the same scene, seed "
                             "included): it would be stored twice; drop one of the values that make them")


IN_FLIGHT_PER_THREAD = 4
"""Runs handed to the cluster at once, per worker thread: enough to keep every worker busy
while the client stores what came back, few enough that the client is never busy submitting."""

NO_WORKER_S = 60.0
"""How long a sweep waits on a cluster without a single worker before it gives up, s: an
existing cluster's workers killed (``dask worker --no-nanny``: nobody starts them again) left it
waiting for good (a local cluster's nannies start theirs again within seconds)."""


def _run_all(client, store, todo, report, bar) -> None:
    """Run ``todo`` on ``client``'s cluster, at most :data:`IN_FLIGHT_PER_THREAD` per worker thread
    at a time, each storing as it finishes. All submitted at once, a plan of 100,000 points kept the
    client submitting for minutes: its connection to the scheduler closed ("Closed comm ...") and the
    sweep waited for good on futures that were gone, nothing stored after 14 minutes."""
    from dask.distributed import wait

    try:
        threads = sum(client.nthreads().values())
    except Exception:  # the scheduler did not answer in time: as for one worker
        threads = 1
    window = IN_FLIGHT_PER_THREAD * max(1, threads)
    queue = iter(enumerate(todo))
    futures, pending = {}, set()

    def submit_more() -> None:
        for k, (point, scene) in itertools.islice(queue, max(0, window - len(pending))):
            fut = client.submit(simulate_in_memory, scene, pure=False, key=f"gaz-run-{k}-{os.getpid()}")
            futures[fut] = point
            pending.add(fut)

    submit_more()
    stored = failed = 0
    alone_since = None  # when the cluster was last seen without a worker
    while pending:
        try:
            finished, pending = wait(pending, timeout=0.5, return_when="FIRST_COMPLETED")
        except TimeoutError:  # nothing finished in this tick: refresh the bar
            finished = ()
        interrupts.check()
        if not finished:
            alone_since = _without_workers(client, alone_since, report)
        for fut in finished:
            point = futures.pop(fut)
            if fut.status == "finished":
                si_num = _store(store, fut.result())
                report.rows.append((point, "stored", si_num, ""))
                stored += 1
            else:
                report.rows.append((point, "failed", None, _why(fut.exception())))
                failed += 1
            fut.release()
        submit_more()
        bar.update(done=stored, failed=failed, running=_running(client, pending))


def _without_workers(client, since: float | None, report) -> float | None:
    """When the cluster was first seen without a worker in this stretch (None: it has one);
    GazError once that is :data:`NO_WORKER_S` ago, saying what was stored."""
    try:
        workers = len(client.nthreads())
    except Exception:  # noqa: BLE001 - the scheduler did not answer in time: not known to be alone
        return since
    if workers:
        return None
    now = time.monotonic()
    if since is None:
        return now
    if now - since < NO_WORKER_S:
        return since
    raise GazError(f"the Dask cluster has had no worker for {NO_WORKER_S:g} s (its workers died or left: "
                   f"killed, or out of memory); {report.count('stored')} runs of the sweep were stored whole, "
                   "the others not; start workers, then run the same sweep again (stored runs are skipped)")


def _store(store, run) -> int:
    """Write one run's arrays through the store's ordinary writer (one short transaction)."""
    with store.simulation(run.scene) as writer:
        b, c = run.bounces, run.collisions
        if writer.want_bounces and b is not None and len(b["t"]):
            writer.add_bounces(b["t"], b["particle"], b["wall"], b["speed"], b["vperp"])
        if writer.want_collisions and c is not None and len(c["t"]):
            writer.add_collisions(c["t"], c["i"], c["j"], c["impulse"])
        writer.finish(run.stats, run.summary["kinetic_energy_start"], run.summary["kinetic_energy_end"])
    return writer.si_num


def _why(exc: BaseException | None) -> str:
    """One line for a failed run: the library's own message, or the exception's type and text."""
    if exc is None:
        return "failed without an exception (the worker was lost)"
    text = " ".join(str(exc).split())
    if isinstance(exc, GazError):
        return text
    if type(exc).__name__ == "KilledWorker":  # (Dask's words run over 300 characters and a link)
        return ("its worker process died each time it ran it (killed, or out of memory: dmesg says "
                "which); run the same sweep again to retry it, with fewer --workers if memory is short")
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _running(client, pending) -> int:
    """How many of the pending runs are running now: those the scheduler has handed to a
    worker, at most one per worker thread (a worker also holds the next ones in line)."""
    try:
        busy = {key for keys in client.processing().values() for key in keys}
        threads = sum(client.nthreads().values())
    except Exception:  # the scheduler did not answer in time: the bar shows 0 for a tick
        return 0
    return min(sum(1 for f in pending if f.key in busy), threads)


class _client:
    """A Dask client: on an existing scheduler, or on a LocalCluster started and stopped here."""

    def __init__(self, workers: int | None, scheduler: str | None, runs: int):
        self.workers, self.scheduler, self.runs = workers, scheduler, runs
        self.cluster = self.client = None

    def __enter__(self):
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            raise GazError("gaz sweep runs on Dask, which is not installed; "
                           "pip install 'gaz[sweep]' (or pip install 'dask[distributed]')") from None
        if self.scheduler:
            failure = None
            try:
                self.client = Client(self.scheduler, timeout=f"{SCHEDULER_TIMEOUT_S}s")
            except (OSError, TimeoutError, ValueError) as err:  # ValueError: a malformed address
                failure = (f"--scheduler {self.scheduler!r}: cannot reach the Dask scheduler "
                           f"({' '.join(str(err).split()) or type(err).__name__}); "
                           "check the address, or leave --scheduler out to run here")
            if failure is not None:
                # the half-made Client is closed now, by its __del__: left to the garbage
                # collector (its traceback keeps it until then), it was closed at any later
                # allocation, once inside another Client's start, which holds the lock that
                # every Client's loop runner shares and that its close takes: a sweep hung
                # for good (distributed's LoopRunner._lock). Raised outside the except
                # block, so that the error does not keep the failure's traceback either.
                gc.collect()
                raise GazError(failure)
            return self.client
        workers = self.workers or cores()
        # the cluster's own logs stay off stderr up to ERROR (a worker's heartbeat failing as an
        # interrupted sweep closes the scheduler printed a traceback): gaz says every run's failure
        # preload: each worker process runs dask_setup below as it starts (its SIGINT ignored)
        try:
            self.cluster = LocalCluster(n_workers=min(workers, self.runs), threads_per_worker=1,
                                        processes=True, dashboard_address=":0",
                                        silence_logs=logging.CRITICAL, preload=[__name__])
            self.client = Client(self.cluster)
        except Exception as err:  # noqa: BLE001 - "Nanny failed to start", and whatever else stops it
            self.__exit__()
            raise GazError(f"the local Dask cluster could not start its workers ({' '.join(str(err).split())}); "
                           "from a script, call gaz.sweep under \"if __name__ == '__main__':\" (each "
                           "worker process imports the script first), or give --scheduler") from None
        return self.client

    def __exit__(self, *exc):
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def dask_setup(worker=None) -> None:
    """Run in each worker process of the local cluster as it starts (Dask's preload, given
    this module's name): SIGINT ignored there. A Ctrl-C at a terminal reaches the whole
    process group; each worker then printed a KeyboardInterrupt traceback of 33 lines before
    gaz's own one line. The client alone answers it (it stops the cluster, :func:`run`)."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


class _Bar:
    """The sweep's progress (:func:`gaz_cli.progress.bar`, the bar of every long command): runs
    done, running and failed, time left; on stderr, or in a notebook's cell."""

    def __init__(self, total: int, show: bool | None):
        from gaz_cli import progress

        self.total = total
        self.show = progress.wanted(False) if show is None else show
        self.progress = None
        self.started = time.monotonic()

    def __enter__(self):
        if self.show:
            from rich.progress import MofNCompleteColumn

            from gaz_cli import progress

            self.progress = progress.bar("sweep", MofNCompleteColumn(),
                                         "runs · {task.fields[running]} running · {task.fields[failed]} failed")
            self.progress.start()
            self.task = self.progress.add_task("sweep", total=self.total, running=0, failed=0)
        return self

    def update(self, done: int, failed: int, running: int) -> None:
        if self.progress is not None:
            self.progress.update(self.task, completed=done + failed, running=running, failed=failed)

    def __exit__(self, *exc):
        if self.progress is not None:
            self.progress.stop()
