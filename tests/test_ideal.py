"""The ideal path (closed-form wall bounces, no queue) against the event engine: the same
REBOND rows and the same final state on scenes where no two particles can meet."""

from __future__ import annotations

import numpy as np
import pytest

from gaz_cli.engines import event as engine
from gaz_cli.engines import ideal
from gaz_cli.errors import SceneError
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.scenes.validate import validate
from gaz_cli.model.species import BUILTIN, Species

ARGON = BUILTIN["Ar"]
POINT = Species("point", ARGON.mass, 0.0)

# Error model: the event engine reaches bounce k of a flight by k additions of the flight
# time to its clock, this path by t0 + k tau at once; both round each operation to half an
# ulp, so they differ by about k ulps of t. Over these runs k stays below 100: 1e-12
# relative leaves a margin of 40 over k eps.
REL = 1e-12


class Snapshots(MemoryRecorder):
    def __init__(self, every):
        super().__init__()
        self.snapshot_every = every
        self.snaps = []

    def add_snapshot(self, t, positions, velocities):
        self.snaps.append((t, positions.copy(), velocities.copy()))


def _both(scene: Scene, every=None):
    scene = validate(scene)
    state = initial_state(scene)
    runs = []
    for run in (engine.run, ideal.run):
        rec = Snapshots(every) if every else MemoryRecorder()
        runs.append((run(scene, state, rec), rec))
    return scene, runs


def _same_rows(a: dict, b: dict, scale: float) -> None:
    assert len(a["t"]) == len(b["t"]) > 0
    assert np.array_equal(a["particle"], b["particle"]) and np.array_equal(a["wall"], b["wall"])
    for key in ("t", "speed", "vperp"):
        np.testing.assert_allclose(b[key], a[key], rtol=REL, atol=0)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_point_particles_bounce_as_in_the_event_engine(dim):
    scene, ((ev, rec_ev), (cf, rec_cf)) = _both(
        Scene(dim=dim, length=1e-7, duration=1e-9, components=((POINT, 100),), seed=11))
    _same_rows(rec_ev.bounces(), rec_cf.bounces(), scene.duration)
    assert cf.events == ev.events == cf.wall_bounces and cf.collisions == 0
    np.testing.assert_allclose(cf.final.positions, ev.final.positions, rtol=0, atol=REL * scene.length)
    assert np.array_equal(cf.final.velocities, ev.final.velocities)  # only signs ever change


def test_one_sphere_of_nonzero_radius_and_its_snapshots():
    scene, ((ev, rec_ev), (cf, rec_cf)) = _both(
        Scene(dim=3, length=1e-8, duration=2e-10, components=((ARGON, 1),), seed=5), every=5e-11)
    _same_rows(rec_ev.bounces(), rec_cf.bounces(), scene.duration)
    assert len(rec_cf.snaps) == len(rec_ev.snaps) == 5
    for (ta, xa, va), (tb, xb, vb) in zip(rec_ev.snaps, rec_cf.snaps):
        assert ta == tb
        np.testing.assert_allclose(xb, xa, rtol=0, atol=REL * scene.length)
        assert np.array_equal(va, vb)
        assert np.all(xb >= ARGON.radius) and np.all(xb <= scene.length - ARGON.radius)


def test_periodic_point_particles_wrap_and_never_bounce():
    scene, ((ev, _), (cf, rec_cf)) = _both(
        Scene(dim=2, length=1e-8, duration=1e-9, components=((POINT, 20),), seed=2, boundary="periodic"))
    assert cf.events == ev.events == 0 and len(rec_cf.bounces()["t"]) == 0
    np.testing.assert_allclose(cf.final.positions, ev.final.positions, rtol=0, atol=1e-9 * scene.length)
    assert np.all((cf.final.positions >= 0) & (cf.final.positions < scene.length))


def test_windows_give_the_same_rows_in_time_order(monkeypatch):
    """Many small windows (CHUNK 16): the rows of one window, in one global time order."""
    scene = validate(Scene(dim=2, length=1e-7, duration=5e-9, components=((POINT, 20),), seed=4))
    state = initial_state(scene)
    whole = MemoryRecorder()
    ideal.run(scene, state, whole)
    monkeypatch.setattr(ideal, "CHUNK", 16)
    parts = MemoryRecorder()
    ideal.run(scene, state, parts)
    assert len(parts._bounces) > 5  # several windows did run
    a, b = whole.bounces(), parts.bounces()
    assert np.all(np.diff(b["t"]) >= 0)
    for key in a:
        assert np.array_equal(a[key], b[key])


def test_a_scene_where_particles_can_meet_is_refused():
    scene = validate(Scene(dim=3, length=1e-7, duration=1e-9, components=((ARGON, 10),), seed=1))
    assert "collide" in ideal.reason_not(scene)
    with pytest.raises(SceneError, match="engine 'ideal' cannot run this scene"):
        ideal.run(scene, initial_state(scene))
