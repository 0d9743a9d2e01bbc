"""Scene validation, species, initial state."""

import math

import numpy as np
import pytest

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.scenes.options import from_options
from gaz_cli.placement.initial import initial_state
from gaz_cli.scenes.validate import validate
from gaz_cli.model.species import BUILTIN, lookup, parse_mixture


def test_builtin_argon_mass_and_radius():
    ar = lookup("argon")
    assert ar.mass == pytest.approx(39.95e-3 / 6.02214076e23, rel=1e-12, abs=0)
    assert ar.mass_g == pytest.approx(6.6338e-23, rel=1e-4, abs=0)  # physics.md §7
    assert ar.radius == pytest.approx(1.79e-10, rel=1e-12, abs=0)
    assert len(BUILTIN) == 10


def test_mixture_parsing():
    mix = parse_mixture("Ar:500,He:300", None)
    assert [(s.name, k) for s, k in mix] == [("Ar", 500), ("He", 300)]
    with pytest.raises(SceneError, match="differs"):
        parse_mixture("Ar:500,He:300", 10)
    with pytest.raises(SceneError, match="unknown species"):
        parse_mixture("Zz:5", None)
    with pytest.raises(SceneError, match="count"):
        parse_mixture("Ar:x", None)


@pytest.mark.parametrize("kw, message", [
    (dict(dim=4), "not 1, 2 or 3"),
    (dict(length=-1.0), "^length"),
    (dict(duration=0.0), "^duration"),
    (dict(temperature=-3.0), "^temperature"),
    (dict(restitution=1.5), "restitution"),
    (dict(length=1e-9), "packing fraction|does not fit"),
])
def test_validation_names_the_problem(argon_scene, kw, message):
    with pytest.raises(SceneError, match=message):
        validate(argon_scene(**kw))


def test_from_options_errors():
    with pytest.raises(SceneError, match="missing --length"):
        from_options(dim=2, n=10)
    with pytest.raises(SceneError, match="--radius and --mass"):
        from_options(dim=2, n=10, length=1.0, duration=1.0, radius=0.1)
    with pytest.raises(SceneError, match="engine step"):
        from_options(dim=2, n=10, length=1e-6, duration=1.0, drag=1.0, engine="event")
    with pytest.raises(SceneError, match="needs a time step"):
        from_options(dim=2, n=10, length=1e-6, duration=1.0, engine="step")


def test_initial_state_is_reproducible_and_maxwellian(argon_scene):
    scene = argon_scene(dim=3, n=4000, length=1e-7)
    a, b = initial_state(scene), initial_state(scene)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities, b.velocities)
    c = initial_state(scene.with_seed(2))
    assert not np.array_equal(a.positions, c.positions)
    # each component has variance kT/m: 3 * 4000 samples, relative error of the variance ~ 1.3 %
    m = lookup("Ar").mass
    var = a.velocities.var()
    assert var == pytest.approx(K_B * 300.0 / m, rel=0.05)


def test_periodic_initial_state_has_zero_momentum(argon_scene):
    scene = argon_scene(dim=2, n=500, length=1e-7, boundary="periodic")
    st = initial_state(scene)
    p = (scene.masses()[:, None] * st.velocities).sum(axis=0)
    assert np.abs(p).max() < 1e-12 * np.abs(scene.masses()[:, None] * st.velocities).sum()


@pytest.mark.parametrize("dim, packing, boundary", [
    (2, 0.5, "periodic"), (2, 0.5, "walls"), (3, 0.4, "periodic"), (2, 0.65, "periodic"), (3, 0.2, "walls"),
])
def test_initial_states_never_overlap(make_scene, dim, packing, boundary):
    """Every seed gives a valid start (growth that leaves an overlap falls back to a lattice)."""
    from gaz_cli.placement import first_overlap

    for seed in range(12):
        scene = make_scene(dim=dim, n=400, packing=packing, seed=seed, boundary=boundary)
        state = initial_state(scene)
        assert first_overlap(state.positions, scene.radii(), scene.length, boundary == "periodic") == -1, seed
        r = scene.radii()[:, None]
        lo, hi = (0.0, scene.length) if boundary == "periodic" else (r, scene.length - r)
        assert (state.positions >= lo).all() and (state.positions <= hi).all()


def test_overlap_checker_finds_a_planted_overlap(rng):
    from gaz_cli.placement import first_overlap, place

    x = place(3, np.full(1000, 0.02), 1.0, rng)
    assert first_overlap(x, np.full(1000, 0.02), 1.0) == -1
    x[7] = x[500] + np.array([0.039, 0.0, 0.0])
    assert first_overlap(x, np.full(1000, 0.02), 1.0) in (7, 500)


# --- the door: magnitudes, memory, work ----------------------------------------------------------
def _custom(mass, radius=1e-10, **kw):
    from gaz_cli.model.scene import Scene
    from gaz_cli.model.species import Species

    base = dict(dim=2, length=1e-7, duration=1e-10, components=((Species("custom", mass, radius), 10),), seed=1)
    base.update(kw)
    return Scene(**base)


def test_mass_range_is_where_the_reduced_mass_stays_a_normal_double():
    """At the ends of mass_range() m_i m_j / (m_i + m_j) is finite and normal for any pair; the scene
    is accepted there and refused a factor 10 outside (where m_i m_j leaves the headroom)."""
    import sys

    from gaz_cli.model.checks import mass_range

    lo, hi = mass_range()
    for mi in (lo, hi):
        for mj in (lo, hi):
            mu = mi * mj / (mi + mj)
            assert sys.float_info.min < mu < sys.float_info.max
    for m in (lo * 1.0001, hi / 1.0001):
        validate(_custom(m, temperature=300.0 if m < 1 else 1e200, force=True))
    for m, side in ((lo / 10, "below"), (hi * 10, "above")):
        with pytest.raises(SceneError, match=f"mass of custom .* is {side} the range"):
            validate(_custom(m, force=True))


@pytest.mark.parametrize("length", [1e-7, 1e60])
def test_the_speed_and_box_ranges_keep_the_pair_time_discriminant_finite(length):
    """At the top of the temperature range the fastest speed considered (SPEED_TAIL sqrt(kT/m)) times
    the box keeps b^2 = (dr.dv)^2 finite; at the bottom (sigma v)^2 stays normal."""
    import re
    import sys

    from gaz_cli.model.checks import HUGE, SPEED_TAIL, TINY

    sc = _custom(6.6e-26, length=length, force=True)
    with pytest.raises(SceneError) as err:
        validate(_custom(6.6e-26, length=length, temperature=1e300, force=True))
    lo, hi = (float(x) for x in re.search(r"range \[(\S+), (\S+)\] K", str(err.value)).groups())
    v_top = SPEED_TAIL * math.sqrt(K_B * hi / sc.masses()[0])
    assert (sc.length * v_top) ** 2 <= HUGE * 1.01 and v_top ** 2 <= HUGE * 1.01  # HUGE: DBL_MAX / 1e16
    v_bottom = math.sqrt(K_B * lo / sc.masses()[0])
    assert (2 * sc.radii()[0] * v_bottom) ** 2 >= TINY / 1.01 and v_bottom ** 2 >= TINY / 1.01
    assert HUGE < sys.float_info.max / 1e15 and TINY > sys.float_info.min * 1e15
    validate(_custom(6.6e-26, length=length, temperature=hi / 1.001, force=True))
    validate(_custom(6.6e-26, length=length, temperature=lo * 1.001, force=True))


def test_memory_is_refused_before_allocation_with_need_and_have(monkeypatch):
    from gaz_cli.model import estimates as scene_mod

    monkeypatch.setattr(scene_mod, "physical_memory", lambda: 10 ** 9)
    big = _custom(6.6e-26, length=1e-3, force=True)
    big = big.__class__(**{**big.__dict__, "components": ((big.species[0], 10 ** 7),)})
    with pytest.raises(SceneError, match=r"N = 1e\+07 needs about 4.8 GB .*this machine has 1 GB"):
        validate(big)


@pytest.mark.parametrize("extra", [{}, {"drag": 0.1}], ids=["event", "step"])  # drag: the step engine, its dt
def test_a_run_refused_for_memory_allocates_nothing_per_particle(monkeypatch, extra):
    """The door's checks before the memory check (the engine's choice, the work estimate, the
    step engine's dt) take means from the species, not from (N,) arrays: gaz simulate --dim 1
    --n 3000000000 ... (1.4 TB needed) was killed by the kernel's OOM killer building 24 GB
    arrays of radii and masses, on a 25 GB machine, instead of saying it needs too much."""
    import tracemalloc

    from gaz_cli.model import estimates as scene_mod

    monkeypatch.setattr(scene_mod, "physical_memory", lambda: 10 ** 9)
    n = 10 ** 7  # 4.8 GB for the event engine, 3.7 GB for the step engine: refused
    big = _custom(6.6e-26, length=1e-3)
    big = big.__class__(**{**big.__dict__, "components": ((big.species[0], n),), **extra})
    tracemalloc.start()  # numpy reports its buffers to tracemalloc
    try:
        with pytest.raises(SceneError, match=r"N = 1e\+07 needs about .* of memory"):
            validate(big)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < n  # less than a byte a particle (an (N,) float64 array is 8)


def test_work_estimate_follows_the_event_engine_and_force_lifts_the_bound(make_scene):
    """The estimate (Enskog collisions + wall hits) against the events the engine counts, 2D walls,
    packing 0.3: within a factor 1.5 (Enskog is good to a few percent here; wall hits are the
    dilute flux, the contact density at the wall is higher: measured ratios 0.83-0.99 without gravity)."""
    from gaz_cli.run import runner
    from gaz_cli.model.estimates import MAX_EVENTS, work_estimate

    sc = make_scene(dim=2, n=300, packing=0.3, duration=0.5, record="none")
    est = work_estimate(sc)["events"]
    events = runner.simulate(sc, db=None)["events"]
    assert 1 / 1.5 < est / events < 1.5, (est, events)
    long_run = sc.__class__(**{**sc.__dict__, "duration": 2 * MAX_EVENTS / work_estimate(sc)["events_per_s"]})
    with pytest.raises(SceneError, match=r"about 2e\+11 events .*add force"):
        validate(long_run)
    validate(long_run.__class__(**{**long_run.__dict__, "force": True}))


def test_work_estimate_of_a_box_barely_wider_than_its_particle(argon_scene):
    """The walls are hit at |v| / (L - 2R), the free length, not |v| / L: one argon atom in a box
    1 % wider than it, 3D, is bounced across 100 times as often as in L. The estimate against the
    mean of the engine's counts over 24 seeds (one atom's speed is one draw), and a run of 3e12
    bounces refused at the door (it was estimated at 1.5e10 and run, for hours)."""
    from gaz_cli.run import runner
    from gaz_cli.model.estimates import work_estimate

    length = 2 * lookup("Ar").radius * 1.01
    sc = argon_scene(dim=3, n=1, length=length, duration=2e-10, record="none")
    counts = [runner.simulate(sc.__class__(**{**sc.__dict__, "seed": s}), db=None)["events"] for s in range(24)]
    est = work_estimate(sc)["events"]
    assert 1 / 1.3 < est / np.mean(counts) < 1.3, (est, np.mean(counts))
    with pytest.raises(SceneError, match=r"about 3e\+12 events .*add force"):
        validate(sc.__class__(**{**sc.__dict__, "duration": 2e-10 * 3e12 / est}))


def test_work_estimate_of_rods_filling_their_segment():
    """Tonks' collision rate is exact in 1D up to a full segment: 20 rods at packing 0.999 are
    estimated within 1.5 of the events the engine counts (capped at packing 0.99, as 2D and 3D
    are, the estimate was 10 times too low)."""
    from gaz_cli.run import runner
    from gaz_cli.constants import K_B
    from gaz_cli.model.estimates import work_estimate
    from gaz_cli.model.scene import Scene
    from gaz_cli.model.species import Species

    n, length, eta = 20, 1.0, 0.999
    sc = Scene(dim=1, length=length, duration=1e-2, components=((Species("X", 1.0, eta * length / (2 * n)), n),),
               temperature=1.0 / K_B, seed=1, record="none")
    est, events = work_estimate(sc)["events"], runner.simulate(sc, db=None)["events"]
    assert 1 / 1.5 < est / events < 1.5, (est, events)
