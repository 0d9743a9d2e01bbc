"""What engines hand their recorders (gaz_cli.recording.Recorder): arrays the recorder keeps
without a copy, which the engine never touches again."""

from __future__ import annotations

import numpy as np
import pytest

from gaz_cli import engines, ideal, stepper
from gaz_cli.engine import driver
from gaz_cli.recording import Recorder
from gaz_cli.scene import Scene, initial_state
from gaz_cli.species import BUILTIN, Species

ARGON = BUILTIN["Ar"]
POINT = Species("point", ARGON.mass, 0.0)


class Keeper(Recorder):
    """Keeps each chunk's arrays as handed, and a copy of them, to compare at the end."""

    want_bounces = want_collisions = True

    def __init__(self):
        self.kept = []

    def add_bounces(self, *arrays):
        self.kept.append([(a, np.array(a, copy=True)) for a in arrays])

    def add_collisions(self, *arrays):
        self.kept.append([(a, np.array(a, copy=True)) for a in arrays])


@pytest.mark.parametrize("engine, kw, chunks", [
    ("event", {}, 4),
    ("reference", dict(duration=2e-11), 2),  # (all at the end: its bounces, its collisions)
    ("step", dict(dt=1e-14, duration=3e-11), 4),
    ("ideal", dict(components=((POINT, 40),), duration=1e-9), 4),
])
def test_the_arrays_an_engine_hands_are_never_modified_afterwards(engine, kw, chunks, monkeypatch):
    # small buffers: the engines fill and reuse their own many times in this run
    monkeypatch.setattr(driver, "BUFFER_ROWS", 64)
    monkeypatch.setattr(stepper, "FLUSH_AT", 32)
    monkeypatch.setattr(ideal, "CHUNK", 16)
    scene = Scene(**{**dict(dim=3, length=1e-8, duration=1e-10, components=((ARGON, 40),), seed=3,
                            engine=engine, record="all"), **kw})
    keeper = Keeper()
    engines.engine_run(engine)(scene, initial_state(scene), keeper)
    assert len(keeper.kept) >= chunks  # several chunks: a buffer reused would show
    for chunk in keeper.kept:
        for handed, copy in chunk:
            np.testing.assert_array_equal(handed, copy)
