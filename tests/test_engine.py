"""The event-driven engine (gaz_cli/engine) checked against physics.

Invariants (energy to round-off, momentum, no overlap, nobody outside, time
order), exact results (1D wall pressure of hard rods, ideal-gas bounce
counts, energy lost by inelastic collisions), an equation of state (periodic
virial pressure against Carnahan-Starling) and the engine's own contracts
(snapshots, recording levels, chunked buffers, the two neighbour searches
giving the same events, errors instead of hangs).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.engines.event import driver
from gaz_cli.errors import EngineError, SceneError
from gaz_cli.model.recording import MemoryRecorder, Recorder
from gaz_cli.model.scene import Scene, State
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species

UNIT_T = 1.0 / K_B
"""Temperature giving k_B T = 1 J: with m = 1 kg, unit thermal speed."""


def unit_scene(dim, n, packing, duration, boundary="walls", seed=1, mode="auto", **kw):
    """n particles of diameter 1 m and mass 1 kg at ``packing``, k_B T = 1."""
    unit = {1: 1.0, 2: math.pi / 4.0, 3: math.pi / 6.0}[dim]
    length = (n * unit / packing) ** (1.0 / dim)
    extras = {"neighbours": mode}
    return Scene(dim=dim, length=length, duration=duration,
                 components=((Species("X", 1.0, 0.5), n),), temperature=UNIT_T, seed=seed,
                 boundary=boundary, extras=extras, **kw)


def kinetic(masses, v):
    return 0.5 * float(np.sum(masses * np.sum(v * v, axis=1)))


def assert_inside_and_apart(scene, x, rtol=1e-9):
    """Centres inside the box (walls: at least R from each wall), pairs at least R_i + R_j apart."""
    L = scene.length
    r = scene.radii()
    if scene.boundary == "walls":
        assert np.all(x >= r[:, None] - 1e-12 * L), "a centre went through a wall at 0"
        assert np.all(x <= L - r[:, None] + 1e-12 * L), "a centre went through a wall at L"
    else:
        assert np.all((x >= 0.0) & (x < L)), "a periodic position is outside [0, L)"
    d = x[:, None, :] - x[None, :, :]
    if scene.boundary == "periodic":
        d -= L * np.rint(d / L)
    dist = np.sqrt(np.sum(d * d, axis=2))
    sig = r[:, None] + r[None, :]
    np.fill_diagonal(dist, np.inf)
    assert np.min(dist - sig * (1.0 - rtol)) >= 0.0, "two particles overlap"


# --------------------------------------------------------------------------
# invariants
# --------------------------------------------------------------------------

@pytest.mark.parametrize("dim,boundary,mode,packing", [
    (1, "walls", "auto", 0.5), (1, "periodic", "auto", 0.5),
    (2, "walls", "cells", 0.3), (2, "periodic", "lists", 0.5),
    (3, "walls", "cells", 0.2), (3, "periodic", "cells", 0.3), (3, "periodic", "lists", 0.4),
])
def test_elastic_run_conserves_energy_keeps_order_and_geometry(dim, boundary, mode, packing):
    sc = unit_scene(dim, 200, packing, 3.0, boundary=boundary, mode=mode)
    st = initial_state(sc)
    x0, v0 = st.positions.copy(), st.velocities.copy()
    rec = MemoryRecorder(collisions=True)
    rs = engine.run(sc, st, rec)
    m = sc.masses()
    assert rs.collisions > 200
    e0, e1 = kinetic(m, v0), kinetic(m, rs.final.velocities)
    assert abs(e1 - e0) <= 1e-12 * e0, "kinetic energy not conserved to round-off"
    if boundary == "periodic":
        p0, p1 = m @ v0, m @ rs.final.velocities
        assert np.max(np.abs(p1 - p0)) <= 1e-12 * math.sqrt(2 * e0 * m.sum())
    assert_inside_and_apart(sc, rs.final.positions)
    b, c = rec.bounces(), rec.collisions()
    assert np.all(np.diff(b["t"]) >= 0) and np.all(np.diff(c["t"]) >= 0), "events out of time order"
    assert len(c["t"]) == rs.collisions and len(b["t"]) == rs.wall_bounces
    assert rs.events == rs.collisions + rs.wall_bounces
    assert np.all((c["t"] >= 0) & (c["t"] <= sc.duration))
    # the caller's state is untouched
    assert np.array_equal(st.positions, x0) and np.array_equal(st.velocities, v0)


def test_mixture_conserves_energy_and_momentum():
    sc = Scene(dim=3, length=6.0, duration=5.0, boundary="periodic", seed=4,
               components=((Species("big", 4.0, 0.5), 60), (Species("small", 1.0, 0.2), 140)),
               temperature=UNIT_T)
    st = initial_state(sc)
    rs = engine.run(sc, st, Recorder())
    m = sc.masses()
    assert rs.collisions > 1000
    e0, e1 = kinetic(m, st.velocities), kinetic(m, rs.final.velocities)
    assert abs(e1 - e0) <= 1e-12 * e0
    p_scale = math.sqrt(2 * e0 * m.sum())
    assert np.max(np.abs(m @ rs.final.velocities - m @ st.velocities)) <= 1e-12 * p_scale
    assert_inside_and_apart(sc, rs.final.positions)


def test_gravity_conserves_kinetic_plus_potential_energy():
    g = 2.0
    for dim in (2, 3):
        sc = unit_scene(dim, 150, 0.2, 5.0, gravity=g, seed=dim)
        st = initial_state(sc)
        rs = engine.run(sc, st, Recorder())
        m = sc.masses()

        def energy(s):
            return kinetic(m, s.velocities) + float(np.sum(m * g * s.positions[:, -1]))

        assert rs.events > 100
        assert abs(energy(rs.final) - energy(st)) <= 1e-10 * energy(st)
        assert_inside_and_apart(sc, rs.final.positions)
    # the floor sees more momentum than the ceiling: force balance N m g
    sc = unit_scene(2, 100, 0.05, 200.0, gravity=g, seed=3)
    rec = MemoryRecorder()
    rs = engine.run(sc, initial_state(sc), rec)
    b = rec.bounces()
    floor = 2 * np.sum(b["vperp"][b["wall"] == -2])
    ceiling = 2 * np.sum(b["vperp"][b["wall"] == 2])
    force = (floor - ceiling) / sc.duration
    assert force == pytest.approx(sc.n * 1.0 * g, rel=0.05)


def test_stress_dense_long_runs_never_leave_the_box_or_overlap():
    """Dense states, many events, gravity: snapshots taken along the way stay valid."""

    class Snaps(Recorder):
        snapshot_every = 2.0

        def __init__(self):
            self.frames = []

        def add_snapshot(self, t, positions, velocities):
            self.frames.append((t, positions.copy()))

    cases = [unit_scene(2, 300, 0.65, 10.0, gravity=5.0, seed=2),
             unit_scene(3, 300, 0.45, 10.0, boundary="periodic", seed=3),
             unit_scene(3, 300, 0.45, 10.0, seed=5, mode="cells")]
    for sc in cases:
        rec = Snaps()
        rs = engine.run(sc, initial_state(sc), rec)
        assert rs.collisions > 20 * sc.n
        assert len(rec.frames) == 6
        for _, x in rec.frames:
            assert_inside_and_apart(sc, x)


# --------------------------------------------------------------------------
# exact results and theory
# --------------------------------------------------------------------------

def test_1d_rods_wall_pressure_is_tonks():
    """P_wall = sum m v^2 / (L - N sigma) exactly in the time average (physics.md section 1).

    Ghost picture: each of the N speeds |v_k| hits each wall every 2 L_free / |v_k|,
    so over T the measured momentum per wall is off by at most one hit per speed.
    """
    sc = unit_scene(1, 40, 0.5, 400.0, seed=7)
    st = initial_state(sc)
    rec = MemoryRecorder()
    rs = engine.run(sc, st, rec)
    b = rec.bounces()
    v = st.velocities[:, 0]
    free = sc.length - sc.n * 1.0
    theory = float(np.sum(v * v)) / free
    slack = float(np.sum(2.0 * np.abs(v))) / sc.duration
    for wall in (-1, 1):
        p = 2.0 * float(np.sum(b["vperp"][b["wall"] == wall])) / sc.duration
        assert abs(p - theory) <= slack, f"wall {wall}: {p} against {theory} +- {slack}"
    assert rs.wall_bounces > 200


def test_ideal_gas_bounce_count_is_exact():
    """Points (radius 0) never collide: each bounces at x0 -> wall -> wall every L/|v|."""
    sc = Scene(dim=1, length=2.0, duration=30.0, components=((Species("P", 1.0, 0.0), 7),),
               temperature=UNIT_T, seed=11)
    st = initial_state(sc)
    rec = MemoryRecorder()
    rs = engine.run(sc, st, rec)
    assert rs.collisions == 0
    b = rec.bounces()
    x, v, L = st.positions[:, 0], st.velocities[:, 0], sc.length
    for k in range(sc.n):
        first = (L - x[k]) / v[k] if v[k] > 0 else x[k] / -v[k]
        expected = int(math.floor((sc.duration - first) / (L / abs(v[k])))) + 1
        assert np.sum(b["particle"] == k) == expected
        assert np.allclose(b["speed"][b["particle"] == k], abs(v[k]), rtol=1e-12)


def test_periodic_virial_pressure_matches_carnahan_starling():
    """3D hard spheres at packing 0.3: Z = 1 + virial / (3 N kT T) against CS 3.9738.

    Stated error: 4 standard errors of 8 time blocks, plus 1% for the finite
    system and the CS equation itself (CS is 0.3% below the exact value here).
    """
    eta = 0.3
    sc = unit_scene(3, 500, eta, 12.0, boundary="periodic", seed=21)
    rec = MemoryRecorder(collisions=True)
    rs = engine.run(sc, initial_state(sc), rec)
    m = sc.masses()
    kT = 2.0 * kinetic(m, rs.final.velocities) / (3 * (sc.n - 1))
    c = rec.collisions()
    edges = np.linspace(0, sc.duration, 9)
    zs = []
    for q in range(8):
        sel = (c["t"] >= edges[q]) & (c["t"] < edges[q + 1])
        zs.append(1.0 + np.sum(c["impulse"][sel] * 1.0) / (3 * sc.n * kT * (edges[q + 1] - edges[q])))
    z_all = 1.0 + rs.virial / (3 * sc.n * kT * sc.duration)
    z_cs = (1 + eta + eta ** 2 - eta ** 3) / (1 - eta) ** 3
    err = np.std(zs[1:], ddof=1) / math.sqrt(len(zs) - 1)
    assert abs(np.mean(zs[1:]) - z_cs) <= 4 * err + 0.01 * z_cs
    assert abs(z_all - np.mean(zs)) <= 1e-9 * z_all


def test_inelastic_energy_loss_is_the_sum_over_collisions():
    """Each collision loses (1 - e) / (1 + e) J^2 / (2 mu) (physics.md section 8)."""
    e = 0.8
    sc = unit_scene(2, 200, 0.2, 2.0, restitution=e, seed=9)
    st = initial_state(sc)
    rec = MemoryRecorder(collisions=True)
    rs = engine.run(sc, st, rec)
    m = sc.masses()
    c = rec.collisions()
    mu = m[c["i"]] * m[c["j"]] / (m[c["i"]] + m[c["j"]])
    lost = float(np.sum((1 - e) / (1 + e) * c["impulse"] ** 2 / (2 * mu)))
    e0, e1 = kinetic(m, st.velocities), kinetic(m, rs.final.velocities)
    assert rs.collisions > 150
    assert lost > 0.01 * e0
    assert e0 - e1 == pytest.approx(lost, rel=1e-9)


def test_tc_model_keeps_an_inelastic_column_going(monkeypatch):
    """A column of rods on the floor, e = 0.5: inelastic collapse without TC, a run with it."""
    monkeypatch.setattr(driver, "CHUNK", 1 << 17)

    def column(tc):
        return Scene(dim=1, length=20.0, duration=50.0, components=((Species("X", 1.0, 0.5), 10),),
                     temperature=UNIT_T, seed=1, restitution=0.5, tc=tc, gravity=1.0)

    with pytest.raises(EngineError, match="inelastic collapse"):
        engine.run(column(0.0), initial_state(column(0.0)), Recorder())
    sc = column(1e-3)
    rs = engine.run(sc, initial_state(sc), Recorder())
    assert rs.collisions > 1000
    assert_inside_and_apart(sc, rs.final.positions)


# --------------------------------------------------------------------------
# contracts
# --------------------------------------------------------------------------

def test_snapshots_come_at_the_right_times_with_the_right_state():
    class Snaps(Recorder):
        want_bounces = True
        snapshot_every = 0.25

        def __init__(self):
            self.frames = []

        def add_snapshot(self, t, positions, velocities):
            self.frames.append((t, positions.copy(), velocities.copy()))

    sc = unit_scene(2, 100, 0.3, 1.0, seed=5)
    st = initial_state(sc)
    rec = Snaps()
    engine.run(sc, st, rec)
    assert [f[0] for f in rec.frames] == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    assert np.array_equal(rec.frames[0][1], st.positions)
    half = engine.run(replace(sc, duration=0.5), st, Recorder())
    assert np.allclose(rec.frames[2][1], half.final.positions, rtol=0, atol=1e-12)
    assert np.allclose(rec.frames[2][2], half.final.velocities, rtol=0, atol=1e-12)


def test_recording_level_does_not_change_the_run(monkeypatch):
    sc = unit_scene(3, 150, 0.25, 2.0, seed=6)
    st = initial_state(sc)
    quiet = engine.run(sc, st, Recorder())
    monkeypatch.setattr(driver, "BUFFER_ROWS", 64)  # many small chunks
    rec = MemoryRecorder(collisions=True)
    loud = engine.run(sc, st, rec)
    assert np.array_equal(quiet.final.positions, loud.final.positions)
    assert np.array_equal(quiet.final.velocities, loud.final.velocities)
    assert len(rec._bounces) > 2 and len(rec._collisions) > 2
    assert np.all(np.diff(rec.bounces()["t"]) >= 0)
    assert len(rec.bounces()["t"]) == loud.wall_bounces


def test_cell_crossings_and_neighbour_lists_give_the_same_events():
    """Two different neighbour searches, one physics: same collisions, same times."""
    runs = {}
    for mode in ("cells", "lists"):
        sc = unit_scene(3, 300, 0.4, 2.0, boundary="periodic", seed=8, mode=mode)
        rec = MemoryRecorder(collisions=True)
        rs = engine.run(sc, initial_state(sc), rec)
        assert rs.extras["neighbour_lists"] == (mode == "lists")
        runs[mode] = rec.collisions()
    a, b = runs["cells"], runs["lists"]
    n = 1500
    assert len(a["t"]) > n and len(b["t"]) > n
    pa = np.sort(np.stack([a["i"][:n], a["j"][:n]]), axis=0)
    pb = np.sort(np.stack([b["i"][:n], b["j"][:n]]), axis=0)
    assert np.array_equal(pa, pb)
    assert np.allclose(a["t"][:n], b["t"][:n], rtol=1e-9, atol=0)


def test_bad_input_is_an_error_not_a_crash():
    sc = unit_scene(3, 4, 0.3, 1.0, boundary="periodic")
    with pytest.raises(SceneError, match="two particle diameters"):
        engine.run(sc, initial_state(sc), Recorder())
    sc = unit_scene(2, 10, 0.1, 1.0)
    st = initial_state(sc)
    bad = State(st.positions.copy(), st.velocities.copy(), st.kinds)
    bad.velocities[3, 0] = np.nan
    with pytest.raises(EngineError, match="non-finite"):
        engine.run(sc, bad, Recorder())
    with pytest.raises(EngineError, match="shapes"):
        engine.run(sc, State(st.positions[:5], st.velocities[:5], st.kinds[:5]), Recorder())
