"""Scene validation, species, initial state."""

import numpy as np
import pytest

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.scene import from_options, initial_state, validate
from gaz_cli.species import BUILTIN, lookup, parse_mixture


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
    (dict(length=-1.0), "--length"),
    (dict(duration=0.0), "--duration"),
    (dict(temperature=-3.0), "--temperature"),
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
        from_options(dim=2, n=10, length=1e-6, duration=1.0, drag=1.0)
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
