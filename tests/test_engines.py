"""--engine auto: the cheapest exact path for each scene, and the reason it gives."""

from __future__ import annotations

import pytest

from gaz_cli import theory
from gaz_cli.engines import registry as engines
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import BUILTIN, Species

ARGON = BUILTIN["Ar"]
POINT = Species("point", ARGON.mass, 0.0)


def _scene(**kw) -> Scene:
    base = dict(dim=3, length=1e-7, duration=1e-9, components=((ARGON, 100),), seed=1, engine="auto")
    return Scene(**{**base, **kw})


@pytest.mark.parametrize("kw, engine, words", [
    (dict(components=((POINT, 100),)), "ideal", "point particles"),
    (dict(components=((ARGON, 1),)), "ideal", "one particle"),
    (dict(components=((POINT, 100),), boundary="periodic"), "ideal", "closed form"),
    (dict(), "event", "hard spheres"),
    (dict(gravity=1e12), "event", "hard spheres"),
    (dict(components=((POINT, 100),), gravity=1e12), "event", "hard spheres"),
    (dict(dim=1), "event", "neighbours"),
    (dict(drag=1e9, dt=1e-13), "step", "drag"),
    (dict(wall_restitution=0.9, dt=1e-13), "step", "damped walls"),
    (dict(engine="reference"), "reference", "asked for"),
    (dict(duration=1e-13), "reference", "tiny run"),
    # a few events but 3000 particles: the reference engine's initial catalogue alone is
    # N^2 / 2 pair times in Python (2.2 s), not tiny
    (dict(components=((ARGON, 3000),), duration=1e-13), "event", "hard spheres"),
])
def test_auto_takes_the_path_the_scene_needs(kw, engine, words):
    scene, reason = engines.choose(_scene(**kw))
    assert scene.engine == engine and words in reason and "\n" not in reason


def test_auto_picks_a_step_from_the_mean_free_time():
    dense = _scene(length=2.52e-9, components=((ARGON, 200),), drag=1e9)
    scene, reason = engines.choose(dense)
    speed = theory.mean_speed(3, dense.temperature, ARGON.mass)
    free_time = theory.mean_free_path(3, 200 / 2.52e-9 ** 3, 2 * ARGON.radius) / speed
    assert scene.engine == "step" and "mean free time" in reason
    assert scene.dt == pytest.approx(free_time / engines.STEPS_PER_FLIGHT, rel=1e-12)
    # a dilute gas of point-like particles crosses the box before it meets anyone
    scene, reason = engines.choose(_scene(length=1e-6, components=((POINT, 10),), drag=1e9, duration=1e-6))
    assert "box crossing" in reason
    assert scene.dt == pytest.approx(1e-6 / speed / engines.STEPS_PER_FLIGHT, rel=1e-12)
    # dilute spheres: a step must not let two of them pass through each other
    scene, reason = engines.choose(_scene(length=1e-6, components=((ARGON, 10),), drag=1e9, duration=1e-6))
    assert "diameter crossing" in reason
    assert scene.dt == pytest.approx(2 * ARGON.radius / speed / engines.STEPS_PER_FLIGHT, rel=1e-12)


def test_auto_never_picks_a_step_longer_than_the_run():
    """gaz simulate --n 1 --radius 0.01 --mass 1 --length 1 --duration 1 --drag 0.5 (a 1 kg body at
    300 K, 1e-11 m/s) picked dt = 2.5e8 s, 1/50 of its box crossing, then refused it: '--dt
    2.47952e+08 s is longer than --duration 1 s; lower --dt', an option the user never gave."""
    from gaz_cli.scenes.validate import validate

    body = Species("body", 1.0, 0.01)
    scene = validate(Scene(dim=2, length=1.0, duration=1.0, components=((body, 1),), seed=1, engine="auto",
                           drag=0.5))
    assert scene.engine == "step" and scene.dt == pytest.approx(1.0 / engines.STEPS_PER_FLIGHT, rel=1e-12)
    assert "50 steps per run" in scene.extras["engine_reason"]


def test_auto_steps_falling_bodies_by_their_fall_not_their_thermal_speed():
    """gaz simulate --dim 2 --n 100 --radius 0.01 --mass 1 --length 1 --duration 2 --drag 0.1
    --gravity 9.81 took dt = 0.04 s from the bodies' thermal speed at 300 K (1e-11 m/s): falling
    at up to 4.4 m/s they moved 9 diameters a step and passed through each other (the engine
    warned of pairs left 0.09 sigma apart). The fall across the box sets the speed now."""
    import warnings

    from gaz_cli.engines import step as stepper
    from gaz_cli.model.recording import Recorder
    from gaz_cli.placement.initial import initial_state
    from gaz_cli.scenes.validate import validate

    body = Species("body", 1.0, 0.01)
    scene = validate(Scene(dim=2, length=1.0, duration=0.6, components=((body, 100),), seed=1, engine="auto",
                           drag=0.1, gravity=9.81))
    fall = (2 * 9.81 * 1.0) ** 0.5
    assert scene.dt == pytest.approx(2 * 0.01 / fall / engines.STEPS_PER_FLIGHT, rel=1e-12)
    assert "at the speed of a fall across the box" in scene.extras["engine_reason"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the warning of pairs left overlapping
        stats = stepper.run(scene, initial_state(scene), Recorder())
    assert stats.extras["overlap_steps"] == 0


def test_auto_steps_attracting_bodies_by_their_pull_not_their_thermal_speed():
    """gaz simulate --dim 2 --n 10 --radius 0.01 --mass 1 --length 1 --duration 10
    --pair-gravity 0.01 took dt = 0.2 s, 1/50 of the run, from the bodies' thermal speed at
    300 K: pulled together at up to 1 m/s they passed through each other in close passes at
    dt = 0.2 s and the total energy went from -1.43 J to +234 J, nothing said. The speed a body
    reaches falling onto all the others, sqrt(2 G M / 2R), sets the step now.

    Tolerance, error model: velocity Verlet at 50 steps per diameter crossing errs by about
    (1/50)^2 = 4e-4 of the energy at stake in each close pass, of either sign: over the ~300
    collisions of the run, sqrt(300) x 4e-4 = 0.7 %; 3 % of |E0| leaves room, and the old
    step's error was 160 |E0|."""
    from gaz_cli.engines import step as stepper
    from gaz_cli.model.recording import Recorder
    from gaz_cli.placement.initial import initial_state
    from gaz_cli.scenes.validate import validate

    body = Species("body", 1.0, 0.01)
    scene = validate(Scene(dim=2, length=1.0, duration=5.0, components=((body, 10),), seed=1, engine="auto",
                           pair_gravity=0.01))
    pull = (2 * 0.01 * 10 / 0.02) ** 0.5
    assert scene.dt == pytest.approx(0.02 / pull / engines.STEPS_PER_FLIGHT, rel=1e-12)
    assert "at the speed of the bodies falling together" in scene.extras["engine_reason"]
    state = initial_state(scene)
    stats = stepper.run(scene, state, Recorder())
    e0 = sum(stepper.energies(scene, state.positions, state.velocities))
    e1 = sum(stepper.energies(scene, stats.final.positions, stats.final.velocities))
    assert stats.collisions > 100
    assert abs(e1 - e0) < 0.03 * abs(e0), (e0, e1)


def test_a_tiny_run_loads_no_compiled_engine():
    """Start-up (issue 15): a tiny scene takes the exam's engine, placed without compiled code:
    no event loop is built, no placement kernel compiled, the event engine's driver and loop
    are not even imported, no TOML parser is loaded for a scene given as options, and the
    process imports neither Numba (most of ``import numpy, numba``), pandas, SQLAlchemy,
    matplotlib, h5py nor dask."""
    import subprocess
    import sys

    code = ("import sys\nfrom gaz_cli.cli import main\n"
            "try:\n    main(['simulate', '--dim', '3', '--n', '100', '--length', '1e-8', '--duration', '1e-12',"
            " '--seed', '1', '--no-db', '--json'])\nexcept SystemExit:\n    pass\n"
            "from gaz_cli import placement\n"
            "loop = sys.modules.get('gaz_cli.engines.event.loop')\n"
            "built = loop.build.cache_info().currsize if loop else 0\n"
            "heavy = ('pandas', 'sqlalchemy', 'matplotlib', 'h5py', 'dask', 'gaz_cli.engines.event.driver',"
            " 'gaz_cli.engines.event.loop', 'tomllib', 'numba')\n"
            "print(sorted(m for m in heavy if m in sys.modules), built, placement.rsa._compiled_rsa.cache_info().currsize,"
            " file=sys.stderr)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert '"engine": "reference"' in out.stdout, out.stdout + out.stderr
    assert out.stderr.strip().splitlines()[-1] == "[] 0 0", out.stderr


def test_a_tiny_run_places_as_the_compiled_kernel_does():
    """The interpreted placement of small scenes gives the compiled kernel's positions."""
    import numpy as np

    from gaz_cli import placement

    radii = np.full(200, ARGON.radius)
    interpreted = placement.rejection(3, radii, 1e-8, np.random.default_rng(3))
    saved = placement.rsa.INTERPRETED_MAX
    try:
        placement.rsa.INTERPRETED_MAX = 0
        compiled = placement.rejection(3, radii, 1e-8, np.random.default_rng(3))
    finally:
        placement.rsa.INTERPRETED_MAX = saved
    assert np.array_equal(interpreted, compiled)
