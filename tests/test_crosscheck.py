"""The fast engine against the exam's algorithm (gaz_cli/engines/reference.py), event by event.

The initial state depends on the scene and its seed only; from it both
engines must produce the same sequence of events — the same particles, the
same walls, times equal to 1e-9 relative — for the first few hundred events,
in 1D, 2D and 3D, also with unequal masses and radii. (Chaos amplifies
round-off, so long sequences are not expected to agree; the scenes are dense
on purpose: a dilute gas amplifies a difference by ~ 2 l / sigma, the mean
free path over the diameter, at every collision, a dense one by little.)
"""

from __future__ import annotations

import numpy as np
import pytest

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species

reference = pytest.importorskip("gaz_cli.engines.reference")

EVENTS = 300


def events(rec: MemoryRecorder):
    """All events in time order: (t, kind, a, b); a wall bounce is (t, 0, particle, wall),
    a collision (t, 1, i, j) with i < j."""
    b, c = rec.bounces(), rec.collisions()
    t = np.concatenate([b["t"], c["t"]])
    kind = np.concatenate([np.zeros(len(b["t"]), int), np.ones(len(c["t"]), int)])
    a = np.concatenate([b["particle"], np.minimum(c["i"], c["j"])])
    z = np.concatenate([b["wall"], np.maximum(c["i"], c["j"])])
    order = np.lexsort((z, a, kind, t))
    return t[order], kind[order], a[order], z[order]


@pytest.mark.parametrize("dim,n,radius,duration", [
    (1, 100, 0.003, 0.04), (2, 200, 0.025, 0.06), (3, 150, 0.07, 0.12)])
@pytest.mark.parametrize("mixture", [False, True])
def test_engine_and_reference_give_the_same_events(dim, n, radius, duration, mixture):
    if mixture:
        duration *= 2.5
        comps = ((Species("big", 3.0, radius), n // 2), (Species("small", 1.0, radius / 2), n - n // 2))
    else:
        comps = ((Species("X", 1.0, radius), n),)
    sc = Scene(dim=dim, length=1.0, duration=duration, components=comps,
               temperature=1.0 / K_B, seed=10 + dim)
    st = initial_state(sc)
    assert np.array_equal(st.positions, initial_state(sc).positions)  # scene + seed only
    fast, slow = MemoryRecorder(collisions=True), MemoryRecorder(collisions=True)
    engine.run(sc, st, fast)
    reference.run(sc, st, slow)
    tf, kf, af, bf = events(fast)
    ts, ks, as_, bs = events(slow)
    assert len(tf) >= EVENTS and len(ts) >= EVENTS, "scene too quiet for the comparison"
    k = EVENTS
    assert np.array_equal(kf[:k], ks[:k]), "event kinds differ"
    assert np.array_equal(af[:k], as_[:k]) and np.array_equal(bf[:k], bs[:k]), "particles or walls differ"
    assert np.allclose(tf[:k], ts[:k], rtol=1e-9, atol=0), "event times differ"
