"""The search a mixture of very different sizes takes (gaz_cli.engines.event.mixture_cost and the
driver's _search): the cheapest of size classes, wide cells and the dilute scan in a box with
walls, never neighbour lists unless forced; wide cells on a mixture give the events of size
classes."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from test_engine_mixtures import min_gap
from test_event_engine import HORIZON, assert_inside, event_sequence, time_tolerances

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.engines.event import mixture_cost
from gaz_cli.engines.event.driver import resolved_search
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species


def mixture(dim, n_small, n_large, ratio, packing, boundary="walls"):
    """benchmarks/mixture_choice.py's mixtures: small particles of radius 1/2, large ones
    ``ratio`` times wider and as dense, the box filled to ``packing``."""
    small, large = Species("S", 1.0, 0.5), Species("L", float(ratio) ** dim, 0.5 * ratio)
    cell = {2: math.pi / 4.0, 3: math.pi / 6.0}[dim]
    length = (cell * (n_small + n_large * ratio ** dim) / packing) ** (1.0 / dim)
    return Scene(dim=dim, length=length, duration=1.0, components=((small, n_small), (large, n_large)),
                 temperature=1.0 / K_B, seed=3, placement="auto", boundary=boundary)


def few_large(n_small, r_small, n_large=10, r_large=0.02, duration=1.0):
    """A few large spheres (mass 1) among many small ones (mass 1e-6) in a unit box."""
    return Scene(dim=3, length=1.0, duration=duration, temperature=1.0 / K_B, seed=3,
                 components=((Species("L", 1.0, r_large), n_large),
                             (Species("S", 1e-6, r_small), n_small)))


# Each with the search measured fastest, CPU per physical event, each search forced
# (benchmarks/mixture_choice.py, 2 cores, 2026-11-24): far from the crossover, so that a
# model that picks the other one is wrong, not unlucky.
@pytest.mark.parametrize("scene, search", [
    # 10 large among 20000 small, packing 3e-4: wide 2.90 us, size classes 6.94, dilute 5.55
    (few_large(20000, 0.0003), "wide"),
    # 10 large among 3000 small, packing 0.04: wide 1.31, dilute 1.55, size classes 2.39
    (few_large(3000, 0.001, r_large=0.1), "wide"),
    # 3D 1:100, 10 large among 3000 small, packing 0.05: wide 1.29, dilute 1.74, classes 2.61
    (mixture(3, 3000, 10, 100, 0.05), "wide"),
    # 3D 1:50, packing 0.15: size classes 4.98, dilute 13.6, wide 17.3
    (mixture(3, 15000, 15, 50, 0.15), "classes"),
    # 2D 1:10, packing 0.2: size classes 0.52, wide 1.58, dilute 5.36
    (mixture(2, 3000, 30, 10, 0.2), "classes"),
    # 2D 1:100 (benchmarks/fingerprint.py's): size classes 1.10, wide 1.94, dilute 6.44
    (mixture(2, 5000, 5, 100, 0.1), "classes"),
])
def test_auto_takes_the_cheapest_search_for_a_mixture_in_a_box(scene, search):
    got = resolved_search(scene)
    assert ("classes" if got["classes"] == "auto" else got["neighbours"]) == search, got


def test_radii_far_apart_take_size_classes_not_neighbour_lists():
    # lists are sized by the largest reach: at packing 0.4 (above sizing.NEIGHBOUR_LIST_FROM)
    # a 3D 1:100 mixture with walls ran 7.5x slower with them (24.9 us a physical event
    # against 3.34), a periodic 2D 1:10 at 0.6 2.6x (1.5 against 0.57). The first takes size
    # classes or, since the wide cells' scans follow the paths, wide cells (measured about
    # even there: 4.7-6.2 us against 5.3, 2026-11-25); the second, periodic, size classes.
    got = resolved_search(mixture(3, 4000, 40, 100, 0.4))
    assert got["neighbours"] != "lists"
    assert (got["classes"] == "auto") == (got["neighbours"] == "cells")
    assert resolved_search(mixture(2, 4000, 40, 10, 0.6, "periodic")) == {"neighbours": "cells",
                                                                          "classes": "auto"}
    for scene in (mixture(3, 4000, 40, 100, 0.4), mixture(2, 4000, 40, 10, 0.6, "periodic")):
        forced = dataclasses.replace(scene, extras={"neighbours": "lists"})
        assert resolved_search(forced)["neighbours"] == "lists"


def test_the_model_counts_collisions_and_bounces_as_a_run_does():
    """The model's rates (kinetic theory of the mixture) against a run's counts: the share of
    collisions among physical events. 10 large spheres among 20000 small ones at packing
    3e-4: the dilute theory's error is of the order of the packing; the count's, about
    1/sqrt(collisions) (measured: model 0.0189, a run of 9.7 million events 0.0189).
    Tolerance: 4 of those standard errors plus 1 %."""
    scene = few_large(20000, 0.0003, duration=0.01)
    rt = mixture_cost.rates(3, scene.length, *mixture_cost.species_of(scene), lambda r: 2.0 * r)
    stats = engine.run(scene, initial_state(scene))
    assert stats.collisions > 3000, stats.collisions
    share = stats.collisions / stats.events
    model = rt.collisions / rt.physical
    assert abs(share - model) <= model * (4.0 / math.sqrt(stats.collisions) + 0.01), (share, model)


@pytest.mark.parametrize("dim", [2, 3])
def test_wide_cells_give_a_mixture_the_events_of_one_grid(dim):
    """Same scene, same start, one grid of cells (the large reach wide) against wide cells:
    the same events (kind, particles) in the same order, times within the round-off model
    of test_event_engine.time_tolerances, up to where that model allows 1e-6 (as
    test_engine_mixtures does for size classes; measured here: the whole runs give the same
    events, 1330 in 2D and 2485 in 3D, times within 1e-11 and 1e-6); after the whole run
    nobody overlaps or is out, and the energy is kept."""
    scene = dataclasses.replace(mixture(dim, 600, 6, 20, 0.1), duration=30.0 if dim == 2 else 60.0)
    state = initial_state(scene)
    seqs = []
    for search in ("cells", "wide"):
        rec = MemoryRecorder(collisions=True)
        stats = engine.run(dataclasses.replace(scene, extras={"neighbours": search, "classes": "off"}),
                           state, rec)
        assert stats.extras["wide_cells"] == (search == "wide")
        assert stats.extras["overlapping_collisions"] == 0
        m = scene.masses()
        e0 = state.kinetic_energy(m)
        assert abs(stats.final.kinetic_energy(m) - e0) <= 1e-12 * e0
        assert min_gap(scene, stats.final.positions) > -1e-9
        assert_inside(scene, stats.final.positions)
        seqs.append(event_sequence(rec))
    one, two = seqs
    alone = dataclasses.replace(scene, components=((scene.components[0][0], scene.n),))
    tol = time_tolerances(alone, one)
    k = int(np.searchsorted(tol >= HORIZON, True))
    assert k > 50
    n_small = scene.components[0][1]  # the small ones are numbered first
    assert sum(1 for e in one[:k] if e[1] == 1 and e[3] >= n_small) > 20
    for e1, e2, rt in zip(one[:k], two[:k], tol[:k]):
        assert e1[1:] == e2[1:], (e1, e2)
        assert abs(e1[0] - e2[0]) <= rt * max(1.0, abs(e1[0])), (e1, e2, rt)


def test_scenes_beyond_the_contact_values_fits_still_find_their_search():
    """The cost models estimate a mean free path from the scene's packing; past the contact
    value's fits (0.55) they take 0.5 (sizing.PATH_PACKING) instead of refusing the scene
    ("packing fraction must be <= 0.55 for the KLM fit" from a scene with wide cells forced
    at 0.6, or from two large spheres filling 0.6 of a box among small ones)."""
    n, eta = 1000, 0.6
    dense = Scene(dim=3, length=(n * math.pi / 6 / eta) ** (1 / 3), duration=1.0,
                  components=((Species("X", 1.0, 0.5), n),), temperature=1.0 / K_B, seed=1,
                  placement="lattice", extras={"neighbours": "wide"})
    assert resolved_search(dense)["neighbours"] == "wide"
    two_large = Scene(dim=3, length=120.0, duration=1.0, temperature=1.0 / K_B, seed=1,
                      components=((Species("L", 1e9, 50.0), 2), (Species("S", 1.0, 0.05), 2000)))
    assert two_large.packing_fraction > 0.6
    assert resolved_search(two_large)["neighbours"] in ("cells", "wide", "dilute")


def test_the_summary_names_the_partner_search(tmp_path):
    """`gaz simulate`'s text summary says how partners were found: the README example scans
    every particle; a mixture of 10 large spheres among 3000 small ones takes wide cells."""
    from cli_helpers import invoke

    code, out, err = invoke(["simulate", "--dim", "3", "--n", "1000", "--length", "3.4e-8",
                             "--duration", "1e-11", "--seed", "1", "--no-db", "--quiet"])
    assert code == 0, err
    assert "partner search: the scan of every particle" in out
    scene = tmp_path / "mix.toml"
    scene.write_text('dim = 3\nlength = 1e-6\nduration = 1e-12\ntemperature = 300.0\nseed = 3\n'
                     '[[species]]\nname = "L"\ncount = 10\nmass = 1e-20\nradius = 1e-7\n'
                     '[[species]]\nname = "S"\ncount = 3000\nmass = 1e-26\nradius = 1e-9\n')
    code, out, err = invoke(["simulate", str(scene), "--no-db", "--quiet"])
    assert code == 0, err
    assert "partner search: wide cells scanned in float32" in out, out
