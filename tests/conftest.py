"""Shared fixtures: scene factories used by tests (and benchmarks)."""

from __future__ import annotations

import contextlib
import math

import numpy as np

import pytest

try:
    from hypothesis import settings as _hypothesis_settings
except ImportError:  # pragma: no cover - hypothesis is in the test extra
    _hypothesis_settings = None

from gaz_cli.constants import K_B
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import Species, lookup

UNIT = Species("unit", 1.0, 0.5)
"""A particle of mass 1 kg and diameter 1 m: with temperature 1/K_B, k_B T = m = sigma = 1."""


def radius_for(dim: int, n: int, packing_fraction: float, length: float = 1.0) -> float:
    """Radius giving ``packing_fraction`` for n particles in [0, length]^dim."""
    unit = {1: 2.0, 2: math.pi, 3: 4.0 * math.pi / 3.0}[dim]
    return (packing_fraction * length ** dim / (n * unit)) ** (1.0 / dim)


@pytest.fixture
def make_scene():
    """make_scene(dim, n, packing, seed, **overrides) -> Scene in reduced units (m = kT = 1)."""

    def factory(dim=2, n=50, packing=0.1, seed=1, length=1.0, duration=1.0, **kw):
        r = radius_for(dim, n, packing, length) if packing > 0 else 0.0
        species = Species("X", 1.0, r)
        return Scene(dim=dim, length=length, duration=duration, components=((species, n),),
                     temperature=1.0 / K_B, seed=seed, **kw)

    return factory


@pytest.fixture
def argon_scene():
    """argon_scene(dim, n, length, duration, **kw): argon at 300 K."""

    def factory(dim=3, n=100, length=3.4e-8, duration=1e-10, seed=1, **kw):
        return Scene(dim=dim, length=length, duration=duration,
                     components=((lookup("Ar"), n),), seed=seed, **kw)

    return factory


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


if _hypothesis_settings is not None:
    # Property tests (test_kernel_properties.py). "gaz", the default: derandomized, so every
    # run on every machine tries the same examples and the suite cannot turn red at random
    # (a failure found by exploring becomes an explicit @example); no deadline, since the
    # first example of a test may wait for a Numba compilation; a bounded number of
    # examples, so the file takes seconds. "explore" (--hypothesis-profile explore): fresh
    # random examples, many more, for a search by hand.
    _hypothesis_settings.register_profile("gaz", derandomize=True, deadline=None,
                                          max_examples=100, database=None, print_blob=True)
    _hypothesis_settings.register_profile("explore", deadline=None, max_examples=2000)
    _hypothesis_settings.load_profile("gaz")

KERNEL_RTOL = 64 * np.finfo(float).eps
"""An engine kernel against its twin in gaz_cli.engines.reference (pair time against tc, wall time
against tr, collision against choc, flight against vol), relative. Error model: the two
evaluate the same closed form in another order (the pair time's discriminant by Lagrange's
identity against b^2 - a c, the impulse along dx / |dx|^2 against a unit normal), each side
rounding at most ~16 times by a relative eps, amplified by the condition number of the
result, which the tests keep below 2 by their draws (pairs at most 3 sigma apart hitting
with an impact parameter below 0.8 sigma, walls at least 0.01 L away): 2 * 16 * 2 = 64 eps.
A wrong formula (a sign, a factor 2, a lost term, the wrong wall) is off by O(1)."""


def random_rows(scene, k, seed):
    """k random wall bounces and collisions of ``scene`` in time order, as the engine hands
    them to a writer: (t, particle, wall, speed, vperp) and (i, j, impulse)."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.random(k)) * scene.duration
    particle = rng.integers(0, scene.n, k)
    wall = (rng.integers(0, scene.dim, k) + 1) * rng.choice([-1, 1], k)
    vperp = rng.random(k) * 500
    speed = vperp * (1 + rng.random(k))
    i, j, imp = rng.integers(0, scene.n, k), rng.integers(0, scene.n, k), rng.random(k) * 1e-23
    return (t, particle, wall, speed, vperp), (i, j, imp)


@contextlib.contextmanager
def mounted_tmpfs(folder, size: str):
    """A tmpfs of ``size`` (e.g. "1M") mounted on the new folder ``folder``, unmounted afterwards
    (root only; the test is skipped where mounting is not permitted)."""
    import subprocess

    folder.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip() or done.returncode}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], capture_output=True)


@pytest.fixture
def tiny_disk(tmp_path):
    """A 1 MiB tmpfs mounted under tmp_path, for a full disk (:func:`mounted_tmpfs`)."""
    with mounted_tmpfs(tmp_path / "small", "1M") as mount:
        yield mount
