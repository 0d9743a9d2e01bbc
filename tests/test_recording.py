"""What engines hand their recorders (gaz_cli.model.recording.Recorder): arrays the recorder keeps
without a copy, which the engine never touches again."""

from __future__ import annotations

import numpy as np
import pytest

from gaz_cli.engines import registry as engines
from gaz_cli.engines import ideal
from gaz_cli.engines import step as stepper
from gaz_cli.engines.event import driver
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import BUILTIN, Species

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


class Chunks(Recorder):
    """Keeps each chunk of bounces as handed."""

    want_bounces = True

    def __init__(self):
        self.chunks = []

    def add_bounces(self, *arrays):
        self.chunks.append(arrays)


def test_the_event_engines_last_chunk_is_small_and_its_rows_the_same():
    """The buffers taper near the run's end (driver._chunk_cap): a writer inserting each chunk
    while the engine computes the next leaves the user waiting for a small last one; when
    the kernel hands its rows over changes no event."""
    scene = Scene(dim=3, length=3.4e-8, duration=2.3e-9, components=((ARGON, 1000),), seed=1, engine="event")
    tapered, whole = Chunks(), Chunks()
    engines.engine_run("event")(scene, initial_state(scene), tapered)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(driver, "TAIL_ROWS", driver.BUFFER_ROWS)  # no taper
        engines.engine_run("event")(scene, initial_state(scene), whole)
    sizes = [len(c[0]) for c in tapered.chunks]
    assert sum(sizes) > 2 * driver.BUFFER_ROWS  # a run of several full buffers
    assert max(sizes) <= driver.BUFFER_ROWS
    # the pace so far guesses the rows to come within a few percent here (~35 thousand
    # bounces, Poisson): the last chunk stays near TAIL_ROWS, far below a buffer
    assert sizes[-1] <= 2 * driver.TAIL_ROWS < driver.BUFFER_ROWS / 2
    assert len(whole.chunks[-1][0]) > 2 * driver.TAIL_ROWS  # (untapered, this run's last is large)
    for k in range(5):
        np.testing.assert_array_equal(np.concatenate([c[k] for c in tapered.chunks]),
                                      np.concatenate([c[k] for c in whole.chunks]))
