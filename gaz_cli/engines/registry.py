"""Which engine runs a scene: the registry, and ``auto``'s choice of the cheapest exact path.

``auto`` (the default) looks at what the scene holds and takes, in order:

1. ``ideal`` when no two particles can meet (one particle, or point particles)
   and nothing bends a flight: wall bounces in closed form, no event queue
   (:mod:`gaz_cli.engines.ideal`);
2. ``step`` when the scene asks for what only the time-stepped engine models:
   drag, gravity between particles, extra planes, damped walls. Without a
   time step it picks one from the scene: :data:`STEPS_PER_FLIGHT` steps per
   mean free time, box crossing or diameter crossing, whichever is shortest (said in
   the reason);
3. ``reference`` for a tiny run (:data:`TINY_WORK`): the exam's exact engine needs
   no compiled code, whose loading would cost more than the run;
4. ``event`` otherwise: hard spheres, with at most uniform gravity, exactly
   (in 1D it follows each rod's two neighbours only).

A scene that sets the event engine's partner search (a scene file's ``[search]``, not
'auto') takes ``event`` unless it needs ``step`` (which refuses the search, as every engine
but ``event`` does). The choice and its reason go to the run's summary (``engine``, ``engine_reason``).
"""

from __future__ import annotations

import importlib
import math
from dataclasses import replace

from gaz_cli.errors import SceneError
from gaz_cli.model.scene import ENGINES as ENGINE_NAMES, STEP_ONLY

ENGINES = {
    "event": "gaz_cli.engines.event.driver",
    "ideal": "gaz_cli.engines.ideal",
    "reference": "gaz_cli.engines.reference",
    "step": "gaz_cli.engines.step",
}
"""Engine name -> module exposing ``run(scene, state, recorder) -> RunStats``."""

CHOICES = ENGINE_NAMES
"""What a scene's ``engine`` may say (:data:`gaz_cli.model.scene.ENGINES`)."""

TINY_WORK = 2e4
"""A run of at most this many events x particles plus particles^2 (estimated: its catalogue
of all pairs) is tiny: ``auto`` gives it to the exam's engine, which needs no compiled code
-- loading the event engine's costs about a second, the reference engine spends about
1e-5 s per event and particle."""

STEPS_PER_FLIGHT = 50
"""Steps per mean free time, box crossing or diameter crossing (the shortest) when ``auto``
picks the step engine's dt: 0.02 of the mean free time, where the step engine stops missing
collisions (README, run time against error)."""


def engine_run(name: str):
    """The ``run`` function of the engine called ``name``."""
    if name not in ENGINES:
        raise SceneError(f"engine {name!r} is not one of {', '.join(CHOICES)}")
    return importlib.import_module(ENGINES[name]).run


def accepts(scene) -> None:
    """Raise SceneError (fields named) unless the engine ``scene`` names (resolved: not 'auto')
    runs it: the step engine's options in range with ``engine`` step and absent with any other
    (which would ignore them); the event engine's search settings, set with ``engine`` event
    only; the event engine's periodic box; what the reference engine handles."""
    from gaz_cli.engines.event.search import check_event_scene, check_search
    from gaz_cli.model.checks import field_error

    if scene.engine != "step":
        for name, unused in STEP_ONLY.items():
            value = getattr(scene, name)
            if value is not unused and value != unused:
                raise field_error(f"`{name}` {value!r} applies to `engine` step only (the {scene.engine} "
                                  f"engine would ignore it); set `engine` step, or drop `{name}`")
    else:
        from gaz_cli.engines.step.accepts import check_step_scene

        check_step_scene(scene)
    if scene.engine == "reference":
        from gaz_cli.engines.reference import check_reference_scene

        check_reference_scene(scene)
    if scene.engine == "event":
        check_event_scene(scene)
    check_search(scene)


def choose(scene):
    """``scene`` with ``engine`` resolved (``auto`` replaced by a path) and the reason, one line.

    A scene naming its engine keeps it (reason: "asked for").
    """
    if scene.engine != "auto":
        return scene, f"engine {scene.engine!r} asked for"
    from gaz_cli.engines import ideal

    step_needs = [what for what, present in (
        ("drag", bool(scene.drag)), ("gravity between particles", bool(scene.pair_gravity)),
        ("extra planes", bool(scene.planes)),
        ("damped walls", scene.boundary == "walls" and scene.wall_restitution != 1.0)) if present]
    if step_needs:
        reason = f"{' and '.join(step_needs)}: only the time-stepped engine models them"
        if scene.dt is None:
            dt, basis = step_for(scene)
            scene = replace(scene, dt=dt)
            reason += f"; dt = {dt:.3g} s, {basis}"
        return replace(scene, engine="step"), reason
    from gaz_cli.engines.event.search import search_given

    given = search_given(scene.extras)
    if given:
        settings = ", ".join(f"{k} {scene.extras[k]!r}" for k in given)
        return replace(scene, engine="event"), f"a partner search set ({settings}): the event engine's"
    if ideal.reason_not(scene) is None:
        why = "one particle" if scene.n == 1 else "point particles"
        return replace(scene, engine="ideal"), f"{why} never collide: wall bounces in closed form, no event queue"
    tiny = _tiny_work(scene)
    if tiny is not None:
        return replace(scene, engine="reference"), (
            f"a tiny run (about {tiny:.0f} events x particles, with the initial catalogue): "
            "the exam's exact engine, no compiled code to load")
    if scene.dim == 1:
        return replace(scene, engine="event"), "hard rods: exact events, each rod against its two neighbours"
    return replace(scene, engine="event"), "hard spheres: exact event-driven dynamics"


def _tiny_work(scene) -> float | None:
    """The reference engine's work for the run (events x particles + particles^2, its initial
    catalogue: :func:`gaz_cli.model.estimates.work_estimate`), if at most TINY_WORK; else None.

    Without the catalogue's N^2, a few thousand particles over a few events counted as tiny
    and ran slower on the reference engine than on the event engine with its start-up
    (measurements: docs/explanation/engine_measurements.md#engine-registry)."""
    from gaz_cli.engines.reference import reference_refusal
    from gaz_cli.model.estimates import work_estimate

    if reference_refusal(scene) is not None or scene.initial:
        return None
    try:
        work = float(work_estimate(replace(scene, engine="reference"))["work"])
    except Exception:  # noqa: BLE001 - an estimate that fails only means "not tiny"
        return None
    return work if work <= TINY_WORK else None


def step_for(scene) -> tuple[float, str]:
    """A time step for the step engine, and a phrase saying which time set it: 1/STEPS_PER_FLIGHT
    of the shortest of the mean free time, the time to cross the box, the time to cross a
    particle diameter at the mean speed (a longer step lets pairs pass through each other) and
    the run's duration (slow particles would otherwise get a step longer than the run). Under
    gravity the speed is at least sqrt(2 g L), reached falling across the box: marbles at 300 K
    move by their fall, not by their thermal speed. Under pair gravity it is at least
    sqrt(2 G M / d), M the bodies' total mass and d the larger of a diameter and the softening:
    the speed of a body falling from afar onto all the others gathered at contact, the most
    the attraction can give it (bodies at 300 K that attract each other move by their pull)."""
    from gaz_cli import theory

    mass = scene.mean_mass()  # (no (N,) array: a run of 10^9 particles is checked here too)
    radius = scene.mean_radius()
    speed = float(theory.mean_speed(scene.dim, scene.temperature, mass))
    pulls = {" at the speed of a fall across the box": math.sqrt(2.0 * scene.gravity * scene.length)}  # m/s
    try:  # checked later, with the step engine's options (accepts)
        reach = max(2.0 * radius, float(scene.softening), 0.0)
    except (TypeError, ValueError):
        reach = 2.0 * radius
    if scene.pair_gravity > 0 and reach > 0:
        pulls[" at the speed of the bodies falling together"] = math.sqrt(
            2.0 * scene.pair_gravity * mass * scene.n / reach)
    pull = max(pulls, key=pulls.get)
    speed_said = pull if pulls[pull] > speed else ""
    speed = max(speed, pulls[pull])
    times = {"box crossing": scene.length / speed, "run": float(scene.duration)}
    if radius > 0 and scene.n > 1:
        times["diameter crossing"] = 2.0 * radius / speed
        try:
            times["mean free time"] = float(theory.mean_free_path(scene.dim, scene.n / scene.volume,
                                                                  2.0 * radius)) / speed
        except SceneError:
            pass
    basis = min(times, key=times.get)
    if basis == "run":
        speed_said = ""
    return times[basis] / STEPS_PER_FLIGHT, f"{STEPS_PER_FLIGHT} steps per {basis}{speed_said}"
