"""Which search a mixture of very different sizes takes: size classes, wide cells or the
dilute scan, each weighed by a model of its work per unit of simulated time.

A mixture with size classes (:func:`.neighbours.classes.plan`) in a box with walls and no
gravity can take any of three searches, all exact, at costs that cross over:

* size classes: fine cells sized for the small particles; a small particle crosses a fine
  face every few radii, a cheap event each, so a dilute gas of small particles among large
  ones pays many crossings per physical event (24 in a 3D mixture of 20 000 small spheres
  among 10 large ones, packing 0.05);
* wide cells (:mod:`.neighbours.wide`): one grid sized by the largest reach, each cell a
  float32 block; few crossings, but every scan covers the blocks along the particle's path,
  cells as wide as a large diameter (up to 3^D of them);
* the dilute scan (:mod:`.neighbours.dilute`): no crossings, a float32 scan of all N.

Per unit time, from the kinetic theory of the mixture (every species at the scene's
temperature; only mass ratios matter, so kT = 1 and the masses are scaled by the lightest):

* C_ij, collisions of species i and j (3D: n_i n_j V pi s^2 g_ij <v_rel>; 2D: 2 s <v_rel>;
  s the pair's reach, g_ij the BMCSL contact value in 3D, 1 in 2D; halved for i = j);
* B_i = N_i D <|v_d|> / (L - 2 r_i), wall bounces; X_i = N_i D <|v_d|> / w, crossings of
  cells of width w (<|v_d|> = sqrt(2 kT / (pi m_i)), the mean speed along an axis);
* R_i = B_i + sum_j C_ij + C_ii, full scans (a particle scans its partners again after each
  change of course).

Each search's work counts (cells visited, blocks and slots of the float32 pass, exact pair
tests) follow from those rates and the search's sizes; :data:`COST` turns them into time.
The constants are fitted (non-negative least squares, relative error) to the CPU time per
physical event of 16 mixtures measured with each search forced, and checked on 12 others
(see :data:`COST`), when wide cells scanned all 3^D blocks around a particle; the work model
now counts the blocks along its path, the unit costs kept (measurements:
docs/explanation/engine_measurements.md#event-engine-mixture-cost). :func:`cheapest` names
the search of least cost.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from gaz_cli.engines.event.layout import WIDE_LANES
from gaz_cli.engines.event.neighbours.ball import ball_cells
from gaz_cli.engines.event.sizing import path_blocks

COST = {
    "classes": {"crossing": 59.6, "cell": 2.88, "pair": 15.6},
    "wide": {"scan": 650.0, "block": 0.74, "slot": 0.42, "pair": 3.24},
    "dilute": {"slot": 0.59, "pair": 4.08},
}
"""CPU ns of each unit of work: size classes, a crossing
of a fine face (its queue event), a cell visited (fine or coarse), a pair test; wide cells,
a full scan (the event that changes a course: collision or bounce, and its set-up), a block
visited, a slot of a block, an exact pair test of a pair the float32 pass kept; the dilute
scan, a particle of the float32 pass, an exact pair test. Fitted to 16 mixtures (2D and 3D,
radius ratios 10-100, 0.1-1 % large by number, packing 0.05-0.5), each search forced:
``python benchmarks/mixture_choice.py --only FIT --fit``. An empirical fit: correlated units
share their cost (the fit puts a wide crossing's queue event in its blocks, a full scan of
size classes in its cells and pairs); what it is for is ranking the searches, not predicting
times (the fit's errors and the ranking's record:
docs/explanation/engine_measurements.md#event-engine-mixture-cost)."""

Rates = namedtuple("Rates", ["n", "vd", "vrel", "speed", "rescans", "collisions", "physical",
                             "density", "reach"])
"""Per species (S,) or pair of species (S, S): counts n, mean speeds along an axis vd, mean
relative speeds vrel, mean speeds (3D formula) speed, full scans a unit time rescans, number
densities density, pair reaches reach; physical events a unit time (collisions and
bounces), of which collisions."""


def species_of(scene) -> tuple[list, list, list]:
    """(counts, masses, radii) of a scene's species: the model's first arguments."""
    return ([k for _, k in scene.components], [s.mass for s, _ in scene.components],
            [s.radius for s, _ in scene.components])


def rates(D: int, L: float, counts, masses, radii, reach) -> Rates:
    """The mixture's event rates (kT = 1, masses over the lightest): see the module's doc.

    counts, masses, radii (S,) per species; ``reach(r)`` the reach of two particles of radius
    r (:func:`.interactions.pair_reach`), a pair of radii r_i, r_j reaching the mean of theirs.
    """
    from gaz_cli import theory  # (numpy only; imported when a scene asks)

    n = np.asarray(counts, dtype=float)
    m = np.asarray(masses, dtype=float)
    m = m / m.min()
    r = np.asarray(radii, dtype=float)
    V = L ** D
    rr = np.array([reach(x) for x in r])
    s = 0.5 * np.add.outer(rr, rr)
    mu = np.multiply.outer(m, m) / np.add.outer(m, m)
    if D == 3:
        vrel = np.sqrt(8.0 / (math.pi * mu))
        g = theory.mixture_contact_values(n / V, 2.0 * r)
    else:
        vrel = np.sqrt(math.pi / (2.0 * mu))
        g = np.ones_like(s)
    C = np.outer(n, n) / V * _section(D, s) * vrel * g
    C[np.diag_indices_from(C)] *= 0.5
    vd = np.sqrt(2.0 / (math.pi * m))
    B = n * D * vd / np.maximum(L - 2.0 * r, 1e-12 * L)
    collisions = float(np.triu(C).sum())
    rescans = B + C.sum(1) + np.diag(C)
    return Rates(n, vd, vrel, np.sqrt(8.0 / (math.pi * m)), rescans, collisions,
                 collisions + float(B.sum()), n / V, s)


def _window(nc: int) -> float:
    """Cells of a row of 3 around a cell, on average over a row of nc between walls."""
    return (3.0 * nc - 2.0) / nc if nc >= 3 else float(nc)


def _section(D: int, s):
    """The collision cross-section of a pair of reach s: pi s^2 in 3D, 2 s in 2D."""
    return math.pi * s * s if D == 3 else 2.0 * s


def wide_work(D: int, L: float, rt: Rates, nc: int) -> dict:
    """Wide cells, nc an axis, a unit time: full scans and crossings, each scanning the
    blocks along the particle's path (:func:`.sizing.path_blocks` for its largest reach over
    the cell's width; at most those of the window of 3 around, :func:`_window`), blocks of
    all particles rounded up to WIDE_LANES slots; the pairs kept, those whose lines meet
    within the scanned window (1.5 cell widths)."""
    w = L / nc
    crossing = rt.n * D * rt.vd / w
    scans = float(rt.rescans.sum())
    b = _window(nc)
    blocks = 0.0
    for i, reach in enumerate(rt.reach.max(axis=1)):
        course, at_crossing = path_blocks(D, float(reach) / w)
        blocks += (rt.rescans[i] * min(course, b ** D)
                   + crossing[i] * min(at_crossing, b ** D))
    slots = WIDE_LANES * math.ceil(rt.n.sum() / nc ** D / WIDE_LANES) * blocks
    kept = float(rt.rescans @ (_section(D, rt.reach) @ rt.density)) * 1.5 * w
    return {"scan": scans, "block": blocks, "slot": slots, "pair": kept}


def dilute_work(D: int, L: float, rt: Rates) -> dict:
    """The dilute scan a unit time: every full scan passes all N; the pairs kept, those whose
    lines meet before the next wall (half a box at the particle's mean speed; at most a box
    of relative path)."""
    flight = 0.5 * L / rt.speed
    path = np.minimum(rt.vrel * flight[:, None], L)
    kept = float(rt.rescans @ (_section(D, rt.reach) * path * rt.density[None, :]).sum(1))
    return {"slot": float(rt.rescans.sum()) * float(rt.n.sum()), "pair": kept}


def classes_work(D: int, L: float, rt: Rates, small, plan) -> dict:
    """Size classes (:func:`.neighbours.classes.plan`) a unit time: a small particle's full
    scan visits 3^D fine cells and the coarse cells around, its crossing 3^(D-1) fine cells;
    a large particle's full scan visits its ball and the coarse cells around, its crossing
    the ball's front; each fine cell holds n_small / nc^D small particles, each coarse cell
    n_large / ncl^D large ones."""
    small = np.asarray(small, dtype=bool)
    cross = rt.n * D * rt.vd / (L / plan.nc)
    per_fine = plan.n_small / plan.nc ** D
    per_coarse = plan.n_large / plan.ncl ** D
    coarse = _window(plan.ncl) ** D
    ball = ball_cells(D, plan.rint)
    fine_scan = np.where(small, _window(plan.nc) ** D, ball)
    fine_cross = np.where(small, _window(plan.nc) ** (D - 1), ball / (2 * plan.bcl + 1))
    cells = rt.rescans @ (fine_scan + coarse) + cross @ fine_cross
    pairs = (rt.rescans @ (fine_scan * per_fine + coarse * per_coarse)
             + cross @ fine_cross * per_fine)
    return {"crossing": float(cross.sum()), "cell": float(cells), "pair": float(pairs)}


def work(D: int, L: float, counts, masses, radii, reach, plan, wide_nc: int) -> dict:
    """Each search's work counts per physical event: {'classes': {...}, 'wide': {...},
    'dilute': {...}} in the units of :data:`COST`."""
    rt = rates(D, L, counts, masses, radii, reach)
    small = np.asarray(radii, dtype=float) <= plan.rcut
    out = {"classes": classes_work(D, L, rt, small, plan), "wide": wide_work(D, L, rt, wide_nc),
           "dilute": dilute_work(D, L, rt)}
    return {s: {k: v / rt.physical for k, v in w.items()} for s, w in out.items()}


def costs(D: int, L: float, counts, masses, radii, reach, plan, wide_nc: int) -> dict:
    """CPU ns per physical event of each search by :data:`COST`: 'classes', 'wide' (``wide_nc``
    cells an axis), 'dilute'."""
    w = work(D, L, counts, masses, radii, reach, plan, wide_nc)
    return {s: sum(COST[s][k] * v for k, v in w[s].items()) for s in w}


def cheapest(D: int, L: float, counts, masses, radii, reach, plan, wide_nc: int) -> str:
    """The search of least cost: 'classes', 'wide' or 'dilute' (:func:`costs`)."""
    c = costs(D, L, counts, masses, radii, reach, plan, wide_nc)
    return min(c, key=c.get)
