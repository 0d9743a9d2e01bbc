"""How big the engine's structures are: cells, neighbour lists, the calendar's buckets.

Functions of the scene and of the pending events only; each constant is a tuning, with
what it was measured on (the figures:
docs/explanation/engine_measurements.md#event-engine-sizing). The driver calls them at
set-up and when it retunes the calendar.
"""

from __future__ import annotations

import bisect
import functools
import math

import numpy as np

from gaz_cli.engines.event.layout import GATHER_SLOTS, WIDE_LANES
from gaz_cli.geometry import UNIT_BALL
from gaz_cli.engines.event.search import PERIODIC_WIDE_CELLS

CELLS_PER_PARTICLE = 2.0
"""At most this many cells per particle (dilute gases); cells stay at least one diameter wide.
1, 1.4 and 3 ran no faster (measurements:
docs/explanation/engine_measurements.md#event-engine-sizing)."""

NEIGHBOUR_SKIN = 0.25
"""Neighbour lists: a particle may move this many largest diameters from its list's centre."""

NEIGHBOUR_LIST_FROM = {2: 0.55, 3: 0.33}
"""'auto' uses neighbour lists from this packing fraction on (cell crossings below);
crossovers measured on periodic fluids of N = 4000 with each search forced."""

EVENTS_PER_BUCKET = 4.0
"""Calendar tuning: mean number of events per bucket of the calendar."""

MAX_BUCKETS = 1 << 13
"""Calendar tuning: at most this many buckets (their heads, 64 KB, stay in the cache; larger
systems get wider buckets, hence more events a bucket). Every event inserts into a bucket
at random: with one bucket per particle, as EVENTS_PER_BUCKET alone gives, each insertion
of a system of 10^5-10^6 particles missed the cache (measurements:
docs/explanation/engine_measurements.md#event-engine-sizing)."""


def use_neighbour_lists(choice: str, D: int, periodic: bool, L: float, pairs: bool,
                        sigma: float, h: float, packing: float) -> bool:
    """Whether a run uses neighbour lists (dense 2D/3D) or cell-crossing events.

    ``choice`` (scene.extras['neighbours'], one of :data:`gaz_cli.engines.event.search.SEARCH`'s: checked at
    the door, scene.validate) may force 'lists' or 'cells'; 'auto' picks lists from
    NEIGHBOUR_LIST_FROM on. Periodic boxes need three list-sized cells per axis (one image
    per neighbour): narrower ones use cells.
    """
    if not pairs or D == 1 or choice in ("cells", "dilute", "wide"):
        return False
    if periodic and L < 3.0 * (sigma + 2.0 * h) * (1.0 + 1e-9):
        return False
    if choice == "lists":
        return True
    return packing >= NEIGHBOUR_LIST_FROM[D]


DILUTE_BELOW = 0.05
"""'auto' considers the dilute scan below this packing fraction only (gases: denser scenes
keep their cells, and their events, whatever the cost model says)."""

WIDE_BELOW = {2: 0.05, 3: 0.08}
"""'auto' considers wide cells below this packing fraction only (by dimension; walls or
periodic). Since the scans follow the particles' paths (:mod:`.neighbours.wide`), wide cells
run faster than cells up to packing 0.05-0.1 (by dimension and boundary). Below these the
models (:data:`WIDE_COST`, :data:`DILUTE_COST`) decide; they rate wide cells too cheap in 2D,
hence the thresholds (measurements:
docs/explanation/engine_measurements.md#event-engine-sizing)."""


def use_dilute_scan(choice: str, D: int, n: int, L: float, periodic: bool, gravity: bool,
                    pairs: bool, use_nl: bool, sigma: float, packing: float) -> bool:
    """Whether a run scans every particle at each event, without cells
    (:mod:`.neighbours.dilute`): 2D/3D, hard walls, no gravity, no neighbour lists.

    ``choice`` 'dilute' forces it where it applies (elsewhere the cells stay);
    'auto' takes it below DILUTE_BELOW when it costs less than the cheaper of cells and
    wide cells, by the models of :func:`dilute_scan_pays` (a mixture with size classes in
    a box with walls is weighed by :mod:`.mixture_cost` instead: the driver's _search).
    """
    if not (pairs and D > 1 and not periodic and not gravity and not use_nl):
        return False
    if choice == "dilute":
        return True
    if choice != "auto" or packing >= DILUTE_BELOW:
        return False
    return dilute_scan_pays(D, n, L, sigma, packing)


DILUTE_COST = {"event": 1.0, "pair": 0.027, "scanned": 0.0025}
"""Relative CPU cost of a queue event (pop, apply, next wall or face, push), of a pair test
in a cell scan, and of a particle in the dilute scan's rejection pass (vectorised), in units
of a queue event; event and pair fitted on the README example (3D, N = 1000) run with 1 to
13 cells an axis (CPU time); 'scanned' refitted for the float32 pass: the one value that
best fits (least squares in log) the measured cost ratios cells / dilute, both forced, argon
3D at the README's density and at scene (b)'s. The model's cells term is the one to refine
(it overrates cells at the lower density, underrates them at the higher). The figures and
the fit's errors: docs/explanation/engine_measurements.md#event-engine-sizing."""


def dilute_scan_pays(D: int, n: int, L: float, sigma: float, packing: float) -> bool:
    """Whether scanning all n particles costs less a particle's event than cells and than
    wide cells (:func:`_wide_cost` at :func:`wide_cells_per_axis`).

    A model of each, per event of a particle: with cells of width w (those of
    :func:`cells_per_axis`), the event, k_D l / w crossings (each a queue event and a
    scan of the 3^(D-1) cells that come into view) and the scan of 3^D cells, l the
    path between two events of a particle, 1 / (1/lambda + D / (2 L)) (collisions at
    the mean free path lambda, bounces off D pairs of walls), k_D the mean of
    sum |v_d| / |v| (4/pi in 2D, 3/2 in 3D); without cells, the event and a scan of all n
    (:mod:`.neighbours.dilute`). The README example: 9 crossings per event with cells,
    the dilute scan 2x cheaper; scene (b) of benchmarks/engine.py (N = 10^4) keeps its
    cells. ``sigma`` is the largest pair reach (the cells' width); lambda is that of n
    equal particles filling the scene's ``packing`` fraction (a mixture's mean volume: a
    few large spheres among many small ones must not count as n large ones, which gave
    packings above 1 and the contact value's refusal).

    It weighs wide cells as well as cells: against cells alone it took the dilute scan where
    wide cells run faster (measurements:
    docs/explanation/engine_measurements.md#event-engine-sizing).
    """
    path = _path(D, n, L, packing)
    dilute = DILUTE_COST["event"] + DILUTE_COST["scanned"] * n
    other = min(_cells_auto_cost(D, n, L, path, sigma),
                _wide_auto_cost(D, n, L, path, sigma, packing))
    return dilute < other


def _cells_cost(D: int, n: int, L: float, path: float, nc: int) -> float:
    """The cost of a particle's event with cells (nc an axis) by the model of
    :func:`dilute_scan_pays`, in DILUTE_COST's units."""
    w = L / nc
    per_cell = n / nc ** D
    cross = (4.0 / math.pi if D == 2 else 1.5) * path / w
    c = DILUTE_COST
    return c["event"] * (1.0 + cross) + c["pair"] * per_cell * (3 ** D + 3 ** (D - 1) * cross)


def _cells_auto_cost(D: int, n: int, L: float, path: float, sigma: float) -> float:
    """The cost of cells as 'auto' weighs them: :func:`_cells_cost` at the cells of
    :func:`cells_per_axis` (walls, no lists)."""
    return _cells_cost(D, n, L, path, cells_per_axis(D, n, L, True, False, sigma, 0.0, False))


PATH_PACKING = 0.5
"""The densest packing :func:`_path` takes (denser scenes: their path at this packing)."""


@functools.lru_cache(maxsize=256)
def _path(D: int, n: int, L: float, packing: float) -> float:
    """The mean path between two events of a particle in a box with walls, 1 / (1/lambda +
    D / (2 L)) (collisions at the mean free path lambda of n equal particles filling the
    scene's ``packing`` fraction, bounces off D pairs of walls). A cost estimate: the
    packing is taken at most PATH_PACKING (the contact value's fits end at 0.55; a few
    large spheres can fill a box beyond it)."""
    from gaz_cli import theory  # (numpy only; imported when a scene asks)

    packing = min(packing, PATH_PACKING)
    diameter = 2.0 * (packing * L ** D / (n * UNIT_BALL[D])) ** (1.0 / D)
    lam = float(theory.mean_free_path(D, n / L ** D, diameter))
    return 1.0 / (1.0 / lam + D / (2.0 * L))


def use_wide_cells(choice: str, D: int, n: int, L: float, periodic: bool, gravity: bool,
                   pairs: bool, use_nl: bool, dilute: bool, classes: bool, sigma: float,
                   packing: float) -> bool:
    """Whether a run uses wide cells scanned by the float32 pass (:mod:`.neighbours.wide`):
    2D/3D, hard walls or a periodic box at least 3 diameters wide (3 cells an axis), no
    gravity, no neighbour lists, not the dilute scan, no size classes (``classes``: the run
    has them).

    ``choice`` 'wide' forces it where it applies (elsewhere the other searches stay); 'auto'
    takes it below WIDE_BELOW (by dimension, walls or periodic) when the model of
    :func:`wide_cells_per_axis` costs less than that of cells (:func:`dilute_scan_pays`)."""
    if not (pairs and D > 1 and not gravity and not use_nl and not dilute and not classes):
        return False
    if periodic and _most_wide_cells(L, sigma) < PERIODIC_WIDE_CELLS:
        return False
    if choice == "wide":
        return True
    if choice != "auto" or packing >= WIDE_BELOW[D]:
        return False
    path = _path(D, n, L, packing)
    return (_wide_auto_cost(D, n, L, path, sigma, packing, periodic)
            < _cells_auto_cost(D, n, L, path, sigma))


def _most_wide_cells(L: float, sigma: float) -> int:
    """The most wide cells an axis: each at least a pair's reach (sigma) wide, at most 64."""
    return max(1, min(64, int(math.floor(L / (sigma * (1.0 + 1e-9))))))


WIDE_COST = {"event": 1.43, "slot": 0.0043}
"""Relative CPU cost, with wide cells, of a queue event (the event, its scan's set-up) and of
a slot of a block in the float32 pass, in the units of DILUTE_COST. Fitted on scene (b) of
benchmarks/engine.py (argon, N = 10^4, packing 0.01, walls; CPU time) with 5 to 11 cells an
axis forced; then scaled to DILUTE_COST's units by the one factor that best fits the
measured cost ratios cells / wide of :data:`WIDE_BELOW`'s 20 scenes (least squares in log;
the 2D ratios overrated). The figures:
docs/explanation/engine_measurements.md#event-engine-sizing."""

PATH_BLOCKS = {
    2: ((0.0, 0.01, 0.03, 0.1, 0.2, 0.4, 0.7, 1.0),
        (1.96, 2.06, 2.19, 2.65, 3.33, 4.72, 6.91, 9.0),
        (3.63, 3.77, 3.85, 4.17, 4.62, 5.51, 6.96, 9.0)),
    3: ((0.0, 0.01, 0.03, 0.1, 0.2, 0.4, 0.7, 1.0),
        (1.97, 2.11, 2.35, 3.27, 4.86, 9.03, 17.48, 27.0),
        (3.81, 4.02, 4.29, 5.28, 6.82, 10.32, 16.81, 27.0)),
}
"""The mean number of wide cells a scan covers (:func:`.neighbours.wide._path_block`), by
dimension, against the reach over the cell's width (first tuple): after a course change (a
path from a uniform point in the cell to its exit, isotropic), and at a crossing (from a
uniform point of the face it enters by). Monte Carlo, 2 10^5 paths each
(benchmarks/wide_blocks.py); linear in between."""


def path_blocks(D: int, rho: float) -> tuple[float, float]:
    """(cells a scan covers after a course change, at a crossing) for wide cells whose width
    is 1/rho reaches (:data:`PATH_BLOCKS`, linear in between; plain floats: the search
    weighs up to 64 cell counts three times a run, and np.interp on one number cost more
    than the rest of the search)."""
    x, course, cross = PATH_BLOCKS[D]
    rho = min(max(rho, 0.0), 1.0)
    i = min(max(bisect.bisect_right(x, rho) - 1, 0), len(x) - 2)
    f = (rho - x[i]) / (x[i + 1] - x[i])
    return (course[i] + f * (course[i + 1] - course[i]),
            cross[i] + f * (cross[i + 1] - cross[i]))


def _wide_cost(D: int, n: int, L: float, path: float, nc: int, sigma: float) -> float:
    """The cost of a particle's event with wide cells (nc an axis), in DILUTE_COST's units:
    the event, k_D l / w crossings (each a queue event and a scan) and its own scan (l the
    path between two events of a particle, k_D as in :func:`dilute_scan_pays`); each scan
    covers the cells of :func:`path_blocks` for a reach ``sigma``; a cell holds n / nc^D
    particles, its scan covers them rounded up to WIDE_LANES (the pass's vector step)."""
    per_cell = n / nc ** D
    slots = WIDE_LANES * math.ceil(per_cell / WIDE_LANES)
    cross = (4.0 / math.pi if D == 2 else 1.5) * path * nc / L
    course, at_crossing = path_blocks(D, sigma * nc / L)
    blocks = min(course, nc ** D) + min(at_crossing, nc ** D) * cross
    c = WIDE_COST
    return c["event"] * (1.0 + cross) + c["slot"] * slots * blocks


def _wide_auto_cost(D: int, n: int, L: float, path: float, sigma: float,
                    packing: float, periodic: bool = False) -> float:
    """The cost of wide cells as 'auto' weighs them (:func:`_wide_cost` at
    :func:`wide_cells_per_axis`): infinite at WIDE_BELOW and above."""
    if packing >= WIDE_BELOW[D]:
        return math.inf
    return _wide_cost(D, n, L, path, wide_cells_per_axis(D, n, L, sigma, packing, periodic),
                      sigma)


@functools.lru_cache(maxsize=256)
def wide_cells_per_axis(D: int, n: int, L: float, sigma: float, packing: float,
                        periodic: bool = False) -> int:
    """Cells along each axis for wide cells: the count, among those at least a pair's reach
    (sigma) wide (at most 64; in a periodic box at least PERIODIC_WIDE_CELLS), that costs
    least by the model of :func:`_wide_cost` (the same model with walls or periodic: a wrap
    is a crossing). Cached: a script that changes WIDE_COST or PATH_BLOCKS calls
    ``wide_cells_per_axis.cache_clear()``."""
    path = _path(D, n, L, packing)
    least = PERIODIC_WIDE_CELLS if periodic else 1
    most = max(least, _most_wide_cells(L, sigma))
    return min(range(least, most + 1), key=lambda nc: _wide_cost(D, n, L, path, nc, sigma))


def cells_per_axis(D: int, n: int, L: float, pairs: bool, periodic: bool, sigma: float,
                   h: float, use_nl: bool) -> int:
    """Cells along each axis: as many as fit cells wider than a pair's reach (sigma, or
    sigma + 2 h with lists), at most CELLS_PER_PARTICLE per particle; 1 without pairs or
    in 1D."""
    if not (pairs and D > 1):
        return 1
    reach = sigma + 2.0 * h if use_nl else sigma
    by_size = int(math.floor(L / (reach * (1.0 + 1e-9))))
    by_count = int(math.ceil((CELLS_PER_PARTICLE * n) ** (1.0 / D)))
    nc = max(1, min(by_size, by_count))
    if use_nl and periodic:
        # a list gathers from 3 cells an axis, each once: fewer would list a
        # neighbour once per image (by_size >= 3 here, see use_neighbour_lists)
        nc = max(nc, 3)
    return nc


def _cell_capacity(per_cell: float) -> int:
    """Initial room of a cell for ``per_cell`` particles a cell on average (grown when full)."""
    return int(max(4, math.ceil(2.0 * per_cell + 3.0 * math.sqrt(per_cell) + 2)))


def _cell_width(cap: int) -> int:
    """Row width of the cell table for ``cap`` particles a cell: the count, then the
    particles, rounded up to whole 16-byte blocks (a cell's row never straddles more
    cache lines than it must)."""
    return max(4 * ((cap + 1 + 3) // 4), GATHER_SLOTS + 1)


def _median_and_q90(a: np.ndarray) -> tuple[float, float]:
    """(median, 90th percentile) of the values a (1D, at least one), the percentile
    interpolated linearly between order statistics (numpy's default): from one partial sort
    of a (in place) instead of one for each (np.median, np.quantile), which the calendar's
    sizing paid at every start and retune."""
    m = a.size
    h = 0.9 * (m - 1)
    q = int(h)
    kth = sorted({(m - 1) // 2, m // 2, q, min(q + 1, m - 1)})
    a.partition(kth)
    med = 0.5 * (float(a[(m - 1) // 2]) + float(a[m // 2]))
    lo, hi = float(a[q]), float(a[min(q + 1, m - 1)])
    return med, lo + (h - q) * (hi - lo)


def calendar_size(keys: np.ndarray, t_now: float, duration: float, n: int) -> tuple[float, int]:
    """(bucket width, bucket count) for the pending keys (N,) at t_now: EVENTS_PER_BUCKET
    events per bucket (more when MAX_BUCKETS caps the count).

    Each particle's next event comes at a rate ~ ln 2 / median(delay);
    the median ignores bursts of simultaneous events (a lattice start
    puts whole planes of particles on cell faces). The buckets span the
    90th percentile of the delays.
    """
    finite = keys[np.isfinite(keys)] - t_now
    if finite.size == 0:
        return duration / 1024.0, 16
    med, horizon = _median_and_q90(finite)
    if not med > 0.0:
        med = float(np.mean(finite))
    if not med > 0.0:
        med = duration * 1e-9
    w = EVENTS_PER_BUCKET * med / (finite.size * math.log(2.0))
    if not (w > 0.0 and math.isfinite(w)):
        return duration / 1024.0, 16
    # at most 2^40 buckets over the run: delays of ~0 (a pair at contact) gave 1e-26 s
    # buckets, and bucket numbers past int64 (calendar._jump)
    w = max(w, duration * 2.0 ** -40)
    want = max(16, min(1 << 22, int(horizon / w) + 1, 4 * n))
    nbk = 1 << int(math.ceil(math.log2(want)))
    if nbk > MAX_BUCKETS:
        w *= nbk / MAX_BUCKETS
        nbk = MAX_BUCKETS
    return w, nbk
