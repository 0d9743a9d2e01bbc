"""Random scenes (issue 38, item 5): whatever the scene, no printed deviation is far off.

Scenes are drawn at random (fixed seeds, so the test is deterministic): dimension,
boundary, packing up to a little below freezing, one species or two of different
radii and masses, gravity (with walls), N and duration. Each runs once; every
DEV_SIGMA analyse prints, in every table, must be below FAR in size: a comparison
either fits the scene and its error is honest, or it prints no deviation.
Reduced units: m = k_B T = 1, box side 1.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from gaz_cli.analysis import report as analysis
from gaz_cli.constants import K_B
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import Species
from gaz_cli.run import runner

FAR = 5.0
"""A printed |DEV_SIGMA| at or beyond this is a wrong verdict (6e-7 of a normal's draws)."""

TOP_PACKING = {1: 0.6, 2: 0.5, 3: 0.35}
"""Largest packing drawn (below 2D's 0.70 and 3D's 0.494 freezing, with room for small N)."""
UNIT = {1: 2.0, 2: math.pi, 3: 4.0 * math.pi / 3.0}


def draw_scene(k: int) -> Scene:
    """Scene number ``k`` of the random set."""
    rng = np.random.default_rng(1000 + k)
    dim = int(rng.integers(1, 4))
    boundary = "periodic" if rng.random() < 0.4 else "walls"
    n = int(rng.integers(20, {1: 150, 2: 150, 3: 120}[dim]))
    packing = float(rng.uniform(0.01, TOP_PACKING[dim]))
    two = rng.random() < 0.35
    if two:
        ratio, heavy = float(rng.uniform(0.5, 1.0)), float(rng.uniform(1.0, 5.0))
        n_a = n // 2
        volume = n_a * 1.0 + (n - n_a) * ratio ** dim
        r = (packing / (UNIT[dim] * volume)) ** (1.0 / dim)
        components = ((Species("A", 1.0, r), n_a), (Species("B", heavy, r * ratio), n - n_a))
    else:
        r = (packing / (UNIT[dim] * n)) ** (1.0 / dim)
        components = ((Species("X", 1.0, r), n),)
    gravity = float(rng.uniform(0.5, 2.0)) if boundary == "walls" and rng.random() < 0.25 else 0.0
    duration = float(rng.uniform(4.0, 12.0))
    record = "all" if rng.random() < 0.5 else "bounces"
    return Scene(dim=dim, length=1.0, duration=duration, components=components, temperature=1.0 / K_B,
                 seed=int(rng.integers(1, 10 ** 6)), boundary=boundary, gravity=gravity, record=record)


def printed_deviations(frames: dict) -> list[tuple[str, str, float]]:
    """(table, row label, DEV_SIGMA) of every finite deviation in analyse's tables."""
    out = []
    for title, frame in frames.items():
        if isinstance(frame, pd.DataFrame) and "DEV_SIGMA" in frame:
            for i, row in frame.iterrows():
                z = row.DEV_SIGMA
                if isinstance(z, float) and math.isfinite(z):
                    label = str(row.get("MODEL", row.get("SPECIES", row.get("QUANTITY", row.get("RE_DIR", i)))))
                    out.append((title, label, float(z)))
    return out


def _far_off(tmp_path, scenes: range):
    db = str(tmp_path / "random.db")
    far, printed = [], 0
    for k in scenes:
        scene = draw_scene(k)
        summary = runner.simulate(scene, db=db)
        devs = printed_deviations(analysis.report(db, sim=summary["si_num"]))
        printed += len(devs)
        far += [(k, scene.dim, scene.boundary, len(scene.components), scene.gravity, *d)
                for d in devs if abs(d[2]) >= FAR]
    return far, printed


def test_no_printed_deviation_is_far_off_on_random_scenes(tmp_path):
    """40 scenes, about 15 s."""
    far, printed = _far_off(tmp_path, range(40))
    assert not far, far
    assert printed >= 40              # verdicts are given, not all withheld (79 on these)


@pytest.mark.coverage
@pytest.mark.long
def test_no_printed_deviation_is_far_off_on_many_random_scenes(tmp_path):
    """200 more scenes (about four minutes of CPU: behind the long marker, python -m pytest -m long)."""
    far, printed = _far_off(tmp_path, range(40, 240))
    assert not far, far
    assert printed >= 2 * 200


MIDDLE_MODEL = "at the measured middle density"
"""The wall verdict of a box dense enough to need its density profile (PROFIL)."""


def draw_wall_scene(k: int, dim: int = 2) -> Scene:
    """Scene number ``k`` of the random boxes with walls at fluid densities: one species, a box
    wide enough for a bulk in its middle (N 250-500 in 2D, 1800-2500 in 3D), packing up to 0.45
    (2D) or 0.35 (3D): the wall pressure against the EOS at the middle's density."""
    rng = np.random.default_rng(5000 + k)
    n = int(rng.integers(250, 500)) if dim == 2 else int(rng.integers(1800, 2500))
    packing = float(rng.uniform(0.05, 0.45 if dim == 2 else 0.35))
    r = (packing / (UNIT[dim] * n)) ** (1.0 / dim)
    return Scene(dim=dim, length=1.0, duration=float(rng.uniform(20.0, 40.0)),
                 components=((Species("X", 1.0, r), n),), temperature=1.0 / K_B,
                 seed=int(rng.integers(1, 10 ** 6)))


def _walls_far_off(tmp_path, scenes: range, dim: int = 2):
    db = str(tmp_path / "walls.db")
    far, middle = [], []
    for k in scenes:
        scene = draw_wall_scene(k, dim)
        summary = runner.simulate(scene, db=db)
        frames = analysis.report(db, sim=summary["si_num"])
        best = frames["pressure against theory"].iloc[0]
        if MIDDLE_MODEL in best.MODEL and math.isfinite(best.DEV_SIGMA):
            middle.append(float(best.DEV_SIGMA))
        far += [(k, *d) for d in printed_deviations(frames) if abs(d[2]) >= FAR]
    return far, np.array(middle)


def _honest(z: np.ndarray) -> None:
    """The mean pressures' deviations from the middle's EOS look like draws of a normal: their rms
    below 2 and their mean within 4.5 of its standard errors of 0 (an honest error bar makes
    either fail in fewer than 1e-4 of sets: chi-square of len(z) degrees of freedom, a normal mean);
    a bias of a few per cent in the theory (a wall area (L - sigma) taken as L) fails them."""
    assert math.sqrt(float(np.mean(z ** 2))) < 2.0, z
    assert abs(float(np.mean(z))) < 4.5 / math.sqrt(z.size), z


def test_boxes_with_walls_at_fluid_densities_get_an_honest_verdict(tmp_path):
    """12 2D boxes with walls, packing 0.05-0.45: the mean pressure is judged against the EOS at the
    measured middle density (its error, Student's t on its degrees of freedom, in DEV_SIGMA), and
    no printed deviation reaches FAR."""
    far, middle = _walls_far_off(tmp_path, range(12))
    assert not far, far
    assert middle.size >= 6           # a numeric verdict on most (the others: too few DOF, withheld; 9 here)
    _honest(middle)


@pytest.mark.coverage
@pytest.mark.long
def test_many_boxes_with_walls_at_fluid_densities(tmp_path):
    """60 more 2D boxes, and 10 3D ones, whose middle-density model is shown without a verdict (its
    edges' term is known to first order only): none printed (about 2 minutes: behind the long marker)."""
    far, middle = _walls_far_off(tmp_path, range(12, 72))
    far3, middle3 = _walls_far_off(tmp_path, range(10), dim=3)
    assert not far + far3, far + far3
    assert middle.size >= 30 and middle3.size == 0
    _honest(middle)


def test_a_periodic_mixture_pressure_has_an_error_bar(tmp_path):
    """3D He:Xe, packing 0.35, --record all: the virial pressure's error comes from each pair of
    species' collisions at its own contact distance, so both mixture EOS (KLM mapped, BMCSL) get a
    DEV_SIGMA; an honest one is below FAR (seeds 1-8 at 0.3: |z| <= 1.3 and 1.5)."""
    from gaz_cli.model.species import lookup
    scene = Scene(dim=3, length=1.0, duration=1e-10, components=((lookup("He"), 60), (lookup("Xe"), 60)),
                  seed=4, boundary="periodic", record="all")
    rv = sum(k * sp.radius ** 3 for sp, k in scene.components)
    scene = Scene(dim=3, length=(4.0 * math.pi * rv / (3.0 * 0.35)) ** (1 / 3), duration=1e-10,
                  components=scene.components, seed=4, boundary="periodic", record="all")
    db = str(tmp_path / "mix.db")
    runner.simulate(scene, db=db)
    p = analysis.report(db, sim=1)["pressure against theory"]
    mixture = p[p.MODEL.str.startswith("mixture")]
    assert len(mixture) == 2 and (mixture.P_ERR / mixture.P_MEASURED).between(1e-4, 2e-2).all()
    assert mixture.DEV_SIGMA.abs().lt(FAR).all(), mixture[["MODEL", "DEV_SIGMA"]]
