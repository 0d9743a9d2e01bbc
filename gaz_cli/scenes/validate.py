"""The one door: every scene, from the CLI, a scene file, a preset, a sweep or Python, is
admitted here before anything runs or is written, and the engines assume a valid scene.

:func:`validate` checks, in order: the scene's own fields (:func:`gaz_cli.model.checks.check_fields`);
the engine (``auto`` resolved, :func:`gaz_cli.engines.registry.choose`) and that engine's own
checks (:func:`gaz_cli.engines.registry.accepts`); the initial state; the magnitudes double
precision carries; the packing fraction; the memory and, unless ``force``, the work
(:mod:`gaz_cli.model.estimates`). :func:`admit_outputs` admits what a run writes besides its
rows (no output over the database or an input, compared by identity of the file; the
trajectory, the diagnostics), before anything is written;
:func:`check_placement` is the door of ``gaz place``.
"""

from __future__ import annotations

import math
import os
from dataclasses import replace

import numpy as np

from gaz_cli.engines import registry
from gaz_cli.errors import SceneError
from gaz_cli.geometry import DENSEST, DENSEST_NAME
from gaz_cli.model.checks import (SPEED_TAIL, check_count, check_fields, check_magnitudes, check_outside,
                                  check_positive, field_error, is_real, length_range, radius_range, speed_range)
from gaz_cli.model.estimates import MAX_SNAPSHOTS, check_memory, check_work, format_bytes, memory_needed
from gaz_cli.model.scene import INITIAL_KINDS, Scene


def validate(scene: Scene) -> Scene:
    """Check everything a scene holds; raise :class:`SceneError` naming the field, the value,
    the allowed range and the fix. Returns the scene with ``engine`` resolved (idempotent).

    In order: the scene's own fields (:func:`gaz_cli.model.checks.check_fields`); the engine
    (``auto`` resolved) and its own checks (:func:`gaz_cli.engines.registry.accepts`: the step
    engine's options, refused with any other engine, where they would be ignored; the event
    engine's search settings; what the reference engine handles); the initial state; the
    magnitudes double precision carries (:func:`gaz_cli.model.checks.check_magnitudes`);
    packing fraction below close packing; the memory the run needs; unless ``scene.force``,
    the run's work (:func:`gaz_cli.model.estimates.work_estimate`) below its bound.
    """
    check_fields(scene)
    scene = _resolve_engine(scene)
    registry.accepts(scene)
    check_initial(scene)
    check_magnitudes(scene)
    eta = scene.packing_fraction
    densest = DENSEST[scene.dim]
    if eta >= densest:
        raise field_error(f"packing fraction {eta:.3g} is at or above {densest:.4g}, {DENSEST_NAME[scene.dim]}; "
                          "lower `n` or raise `length`")
    check_memory(scene.n, scene.engine, scene.dim)
    check_memory_limit(scene.n, scene.engine, scene.dim)
    if not scene.force:
        check_work(scene)
    return scene


def memory_limit() -> tuple[int, int, str] | None:
    """This process's memory limit, when one is set below what the machine has: (the limit, what
    of it is left now, its name), bytes; None for none. ``ulimit -v`` (RLIMIT_AS) bounds the
    address space, of which the process uses some already (Python, NumPy, Numba's compiler: about
    a gigabyte); ``ulimit -d`` (RLIMIT_DATA) bounds the heap."""
    try:
        import resource

        with open("/proc/self/statm") as f:
            used = int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (ImportError, OSError, ValueError, IndexError):
        return None
    found = None
    for kind, flag in ((resource.RLIMIT_AS, "ulimit -v"), (resource.RLIMIT_DATA, "ulimit -d")):
        soft = resource.getrlimit(kind)[0]
        if soft != resource.RLIM_INFINITY and (found is None or soft - used < found[1]):
            found = (soft, max(0, soft - used), flag)
    return found


def check_memory_limit(n: int, engine: str, dim: int = 3) -> None:
    """Refuse, before any allocation, a run that needs more memory than this process may still
    take under its limit (:func:`memory_limit`); a run within it that still runs out ends as
    'out of memory' (the CLI's one line, :func:`gaz_cli.cli.main`)."""
    limit = memory_limit()
    need = memory_needed(n, engine, dim)
    if limit is not None and need > limit[1]:
        soft, left, flag = limit
        what = f"N = {n:.3g} needs about {format_bytes(need)} of memory ({engine} engine)" if engine != "place" \
            else f"placing N = {n:.3g} particles needs about {format_bytes(need)} of memory"
        raise field_error(f"{what}; this process may take {format_bytes(left)} more ({flag}: "
                          f"{format_bytes(soft)} in all); lower `n`, or raise the limit")


def _resolve_engine(scene: Scene) -> Scene:
    """``engine = "auto"`` replaced by the path the scene needs (:func:`gaz_cli.engines.registry.choose`);
    the reason, in one line, goes to ``extras['engine_reason']`` for the run's summary."""
    if scene.extras.get("engine_reason") and scene.engine != "auto":
        return scene  # resolved before (validate is idempotent)
    chosen, reason = registry.choose(scene)
    if chosen.engine == "ideal" and scene.engine == "ideal":
        from gaz_cli.engines import ideal

        why = ideal.reason_not(scene)
        if why is not None:
            raise field_error(f"`engine` ideal (closed-form bounces) cannot run this scene: {why}; "
                              "use `engine` event or auto")
    return replace(chosen, extras={**scene.extras, "engine_reason": reason,
                                   "engine_auto": scene.engine == "auto"})


def check_initial(scene: Scene) -> None:
    """Scene.initial: its kind and arrays (an explicit state must match the scene's N and D)."""
    init = scene.initial
    if init is None:
        return
    if not isinstance(init, dict) or init.get("kind") not in INITIAL_KINDS:
        kind = init.get("kind") if isinstance(init, dict) else init
        raise field_error(f"`initial` kind {kind!r} is not one of {', '.join(INITIAL_KINDS)}")
    if scene.placement != "auto":
        raise field_error(f"`placement` {scene.placement} does not apply with an `initial` state "
                          f"({init['kind']}), which places the particles itself; drop `placement`")
    allowed = {"explicit": {"kind", "positions", "velocities"}, "upper-half": {"kind", "velocity_sd"}}[init["kind"]]
    extra = sorted(set(init) - allowed)
    if extra:
        raise field_error(f"`initial` key {extra[0]!r} does not belong to kind {init['kind']!r}; "
                          f"its keys: {', '.join(sorted(allowed))}")
    if init["kind"] == "explicit":
        for key in ("positions", "velocities"):
            try:
                arr = np.asarray(init.get(key), dtype=float)
            except (TypeError, ValueError):
                raise field_error(f"`initial` {key} is not an array of numbers") from None
            if arr.shape != (scene.n, scene.dim):
                raise field_error(f"`initial` {key} has shape {arr.shape}, the scene needs "
                                  f"({scene.n}, {scene.dim}) (n particles, dim coordinates)")
            if not np.all(np.isfinite(arr)):
                raise field_error(f"`initial` {key} holds a non-finite number")
        pos, r = np.asarray(init["positions"], dtype=float), scene.radii()[:, None]
        if np.any(pos < r) or np.any(pos > scene.length - r):
            raise field_error("`initial` positions put a particle outside the box [R, L - R]")
        if scene.planes:
            from gaz_cli.engines.step.accepts import check_in_front_of_planes

            check_in_front_of_planes(scene, pos)
        pair = overlapping_pair(pos, scene.radii(), scene.length, scene.boundary == "periodic")
        if pair is not None:
            raise field_error(f"`initial` positions overlap: particles {pair[0]} and {pair[1]} are closer "
                              "than the sum of their radii; move them apart")
        # the largest speed bounded without squaring (|v| <= sqrt(D) max |v_k|): no overflow
        fastest = float(np.max(np.abs(np.asarray(init["velocities"], dtype=float)))) * math.sqrt(scene.dim)
        scale = "velocities"
    else:
        sd = init.get("velocity_sd")
        if not is_real("velocity_sd", sd) or not math.isfinite(sd) or sd < 0:
            raise field_error(f"`initial` velocity_sd {sd!r} is outside [0, inf) m/s")
        fastest, scale = SPEED_TAIL * sd * math.sqrt(scene.dim), "velocity_sd"
    vhi = speed_range(scene.length, [sp.radius for sp, _ in scene.components])[1]
    if fastest > vhi:
        raise field_error(f"`initial` {scale} reach {fastest:.3g} m/s, above the {vhi:.2g} m/s where the "
                          f"particles' speeds (times the box, {scene.length:.3g} m) stay within double "
                          f"precision; lower the `initial` {scale}")


def overlapping_pair(pos: np.ndarray, radii: np.ndarray, length: float, periodic: bool):
    """Two particles of an explicit state that overlap (beyond 1e-9 relative), or None: all
    pairs in numpy up to 1000 particles (no compiled code to load), else the placement's
    cell scan (:func:`gaz_cli.placement.first_overlap`)."""
    n = len(pos)
    if n < 2 or not np.any(radii > 0):
        return None
    if n > 1000:
        from gaz_cli.placement import first_overlap

        k = first_overlap(pos, radii, length, periodic)
        return None if k < 0 else (k, "another")
    d = pos[:, None, :] - pos[None, :, :]
    if periodic:
        d -= length * np.round(d / length)
    contact = (radii[:, None] + radii[None, :]) * (1.0 - 1e-9)
    close = np.sum(d * d, axis=2) < contact * contact
    np.fill_diagonal(close, False)
    i, j = np.unravel_index(int(np.argmax(close)), close.shape)
    return (int(min(i, j)), int(max(i, j))) if close[i, j] else None


def check_diagnostics(scene: Scene, diagnostics) -> None:
    """Check the ``diagnostics`` callable given to a run (Python API); raise SceneError naming the fix.

    The step engine alone reports diagnostics (energies, largest speed, counts), every
    ``print_every`` steps: with another engine, or with ``print_every`` 0, the callable would
    never be called; the event engine's driver is not asked for them (its state between
    events is not at one time, and the exact engine conserves energy to round-off).
    """
    if diagnostics is None:
        return
    if not callable(diagnostics):
        raise SceneError(f"diagnostics {diagnostics!r} is not callable: give a function taking one dict "
                         "(time, step, kinetic, potential, energy...), or None")
    if scene.engine != "step":
        raise SceneError(f"diagnostics are written by the step engine; this scene runs the {scene.engine} "
                         "engine: use engine='step' with print_every (steps between reports), or drop diagnostics")
    if not scene.print_every:
        raise SceneError("diagnostics given, but print_every is 0: the step engine would report nothing; "
                         "set print_every (steps between reports), or drop diagnostics")


def check_outputs(scene: Scene, trajectory=None, every=None) -> None:
    """Check a run's trajectory request against its scene; raise SceneError naming the fix.

    The engine must write snapshots (the reference engine does not); ``every`` must be a
    positive number of simulated seconds, at most the duration (else the start alone would
    be written); unless ``scene.force``, at most MAX_SNAPSHOTS
    snapshots and a file smaller than the free space of its disk.
    """
    if not trajectory:
        if every is not None:
            raise field_error(f"`every` {every!r} applies to `trajectory` only (no snapshot would be "
                              "written); add `trajectory` FILE, or drop `every`")
        return
    from gaz_cli.outputs.trajectory import FORMATS

    suffix = os.path.splitext(str(trajectory))[1].lower()
    if suffix not in FORMATS:
        known = ", ".join(sorted(FORMATS))
        raise field_error(f"`trajectory` {str(trajectory)!r}: unknown extension {suffix!r}; "
                          f"use one of {known} (.h5: HDF5/H5MD, .gsd: HOOMD, .pvd: VTK for ParaView)")
    if FORMATS[suffix] == "gsd":
        from gaz_cli.outputs.trajectory import gsd_hoomd_module

        gsd_hoomd_module()  # the optional gsd package, asked for before any database is created
    if scene.engine == "reference":
        raise field_error("`engine` reference (the exam's algorithm) writes no trajectory; "
                          "use `engine` event with `trajectory`")
    if every is None:
        raise field_error("`trajectory` needs `every` DT, the simulated time between snapshots (s)")
    if not (is_real("every", every) and math.isfinite(every) and every > 0):
        raise field_error(f"`every` must be a positive number of simulated seconds, got {every}")
    if every > scene.duration:
        raise field_error(f"`every` {every:g} s is longer than `duration` {scene.duration:g} s: the trajectory "
                          f"would hold the start alone; use `every` {scene.duration:g} or less")
    snapshots = math.floor(scene.duration / every) + 1
    if scene.force:
        return
    if snapshots > MAX_SNAPSHOTS:
        least = scene.duration / (MAX_SNAPSHOTS - 1)
        raise field_error(f"`every` {every:g} s over `duration` {scene.duration:g} s makes {snapshots:,} "
                          f"snapshots, more than {MAX_SNAPSHOTS:,}; use `every` {least:.3g} or more, "
                          "or add `force` to write them all")
    size = snapshots * scene.n * 3 * 16.0  # positions and velocities, 3 float64 each (1D and 2D embedded in 3D)
    try:
        import shutil

        free = shutil.disk_usage(os.path.dirname(os.path.abspath(str(trajectory)))).free
    except OSError:
        return
    if size > free:
        raise field_error(f"`trajectory` {str(trajectory)!r} would take about {format_bytes(size)} "
                         f"({snapshots:.3g} snapshots of {scene.n} particles); its disk has {format_bytes(free)} "
                         "free; raise `every` or free some space (or add `force`)")


def admit_outputs(scene: Scene, db_file, inputs, outputs: dict, *, trajectory=None, every=None,
                  diagnostics=None) -> None:
    """The door for what a run of ``scene`` writes besides its database rows: raise SceneError
    (one line, naming the option and the fix) before anything is written.

    ``outputs``: option -> path or None (``--save-state``, ``--write-scene``, ``--trajectory``),
    each a name a file system takes, in an existing folder; ``db_file``: the SQLite file the
    run is stored in (None: no file, or a server); ``inputs``: what -> path, the files the run
    was read from. No output may be the database, an input or another output, compared by
    identity of the file (:func:`gaz_cli.scenes.paths.check`); the trajectory's request
    (:func:`check_outputs`) and the diagnostics' callable (:func:`check_diagnostics`) follow.
    (The rows' disk space is the store's to check: :func:`gaz_cli.results.budgets.check_database_space`.)
    """
    from gaz_cli.scenes import paths

    for option, path in outputs.items():
        paths.check_writable(path, option)
    paths.check(db_file, inputs, outputs)
    check_outputs(scene, trajectory, every)
    check_diagnostics(scene, diagnostics)


def check_placement(dim: int, n: int, radius: float, length: float) -> None:
    """The door of ``gaz place``: count, radius and box in range, memory, before any allocation."""
    if dim not in (1, 2, 3):
        raise field_error(f"`dim` {dim} is not 1, 2 or 3")
    check_count(n)
    check_positive("radius", radius, " (m)")
    check_positive("length", length, " (m)")
    lo, hi = length_range(dim)
    check_outside("`length`", length, lo, hi, "m", f"where L^{dim} and |dr|^2 stay within double precision",
             "change `length`")
    rlo, rhi = radius_range()
    check_outside("`radius`", radius, rlo, rhi, "m", "where the contact distance squared stays within double "
             "precision", "change `radius`")
    check_memory(n, "place", dim)
    check_memory_limit(n, "place", dim)
