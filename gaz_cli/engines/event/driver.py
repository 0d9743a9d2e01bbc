"""The Python side of the event-driven engine: validate, allocate, call the kernels, report.

Order of operations in :func:`run`:

1. check the scene and the initial state; choose the neighbour search (line
   order in 1D; in 2D/3D cells with crossing events, or neighbour lists for
   dense fluids) and the kernels for this kind of scene (dimension, walls or
   periodic, gravity, restitution, radii > 0);
2. number the particles internally in space order (cell by cell; along the
   line in 1D) so that neighbours sit close in memory, and load the state
   into the particle rows (the caller's arrays are never touched);
3. predict every particle's first event and build the calendar queue;
4. run the event loop up to each stop time (each snapshot, then the
   duration); whenever it returns early, flush the record buffers to the
   recorder (bounded memory, rows in time order, particles under their own
   numbers), grow a full cell or neighbour list, retune the calendar, or (large
   systems) restart: every particle advanced to now, renumbered in space
   order again, every prediction made afresh;
5. return :class:`RunStats` with the final state, every particle advanced
   to exactly ``scene.duration``, in the caller's order.
"""

from __future__ import annotations

import math
import time

import numpy as np

from gaz_cli.engines.event import mixture_cost, sizing
from gaz_cli.engines.event.calendar import _build_queue
from gaz_cli.engines.event.dynamics import _state_at
from gaz_cli.engines.event.guards import RunawayGuard
from gaz_cli.engines.event.interactions import pair_params, pair_reach
from gaz_cli.engines.event.layout import (BUFFER_FULL, CELL_FULL, DONE, KEY, NL_FULL, NONE, PAUSE, QB,
                                          STATE, Tables)
from gaz_cli.engines.event.loop import build
from gaz_cli.engines.event.memory import _alloc
from gaz_cli.engines.event.neighbours import classes
from gaz_cli.engines.event.rows import Rows
from gaz_cli.errors import EngineError, SceneError
from gaz_cli.progress import EVENTS_PER_REPORT
from gaz_cli.model.recording import Recorder, RunStats, hand_snapshot
from gaz_cli.model.scene import Scene, State

BUFFER_ROWS = 1 << 14
"""Rows of each record buffer (bounces, collisions), handed to the recorder when full: memory
stays bounded on any run. 16384 rather than 65536: a run into a SQLite file inserts each
chunk from a thread while the engine computes the next (gaz_cli.results.sqlite._EarlyInsert),
so the user waits for the last chunk's insert: smaller chunks cut the wall time recording
adds, at the same CPU (measurements:
docs/explanation/engine_measurements.md#event-engine-driver).
A kernel return costs tens of microseconds: ~1 % at 16384 bounces a chunk."""

TAIL_ROWS = 1 << 11
"""The smallest chunk the buffers are tapered to near the run's end (:meth:`_Simulation._chunk_cap`):
the rows a recorder's writer is still inserting when the engine stops, what the user waits
for (~1 ms of SQLite inserts), for a few more kernel returns (~4, tens of microseconds each)."""

RESTART_FROM_N = 20_000
RESTART_EVERY = 20
"""Systems of RESTART_FROM_N particles or more are renumbered in space order every
RESTART_EVERY events per particle (memory locality; small systems fit in cache): from 5000
instead, a 3D gas of 10^4 ran slower (measurements:
docs/explanation/engine_measurements.md#event-engine-driver)."""

PREFETCH_FROM_N = 20_000
"""Systems of this many particles or more prefetch the cells and rows of each scan, and
the partners and cells of the next events (their data no longer fits in the caches; every
run requests the next events' own rows, :mod:`.prefetch`; below, the other hints
cost more than they save; measurements:
docs/explanation/engine_measurements.md#event-engine-driver)."""

PREFETCH_LISTS_FROM_N = 5_000
"""The same with neighbour lists, whose scans read the rows of a list at random: the prefetch
pays from about this size on (measurements:
docs/explanation/engine_measurements.md#event-engine-driver)."""

FIRST_CHUNK = 50_000
CHUNK = 1 << 22
"""Events per kernel call between two checks of the calendar's tuning."""

SIGNAL_EVENTS = 1 << 16
"""At most this many events per kernel call: the kernel returns to Python (tens of
microseconds) so that a SIGINT or SIGTERM takes effect within a fraction of a second (65536
events: 0.03-0.3 s of the engine), where a call of CHUNK events ran seconds without a look at
the signals. Such a return changes nothing else: the loop goes on where it was, and the
calendar's tuning is checked every CHUNK events as before (the same events)."""

REBASE_EVENTS_PER_PARTICLE = 1 << 20
REBASE_EVENTS_PER_PARTICLE_GRAVITY = 1 << 6
"""The kernels count time from an origin moved to 'now' every this many events a particle
(and from the run's start time, which may be large): event times stay resolved to about
1e-16 times 10^6 flight times instead of losing a digit every tenfold of the clock. Under
gravity a time stamp off by eps t also moves a velocity by g eps t, and that error adds up
in the energy: the origin moves every 64 events a particle (a new prediction of every
particle, about 1/64 of the events' own cost)."""


def run(scene: Scene, state: State, recorder: Recorder | None = None,
        start_time: float = 0.0) -> RunStats:
    """Simulate ``scene`` from ``state`` exactly, event by event; see the module docstring.

    The clock starts at ``start_time`` s (a continued run) and stops at ``start_time +
    scene.duration``; recorded times are on that clock.

    ``state`` positions (N, D) m and velocities (N, D) m/s are copied, never
    modified. Wall bounces go to ``recorder.add_bounces`` (if it wants them),
    particle-particle collisions to ``recorder.add_collisions`` (if it wants
    them), snapshots every ``recorder.snapshot_every`` s to
    ``recorder.add_snapshot``. Returns :class:`RunStats`: ``events`` counts
    the physical events (collisions + wall bounces); ``extras`` holds the cell
    crossings, stale predictions, compile and set-up times, ``pair_tests`` (pair times
    computed exactly, on every search path: cells, lists, the dilute scan's survivors)
    and ``dilute_scanned`` (particles, or with wide cells slots, the float32 rejection pass
    went through; 0 on the other paths); ``--json`` prints them.

    ``scene.extras`` may hold 'neighbours' ('auto', 'cells' or 'lists') and
    'skin' (neighbour-list skin in largest diameters) for benchmarks.
    """
    recorder = recorder if recorder is not None else Recorder()
    start_time = float(start_time)
    if not (math.isfinite(start_time) and start_time >= 0.0):
        raise SceneError(f"start time {start_time} must be a finite number >= 0")
    sim = _Simulation(scene, state, recorder)
    return sim.run(start_time)


def _search(scene: Scene, radii: np.ndarray, PP: tuple) -> tuple:
    """The neighbour search of a run: (neighbour lists?, dilute scan?, size-class plan or
    None, cells per axis, list skin h in m, wide cells?), for ``scene`` (valid) with these radii (N,) m and
    interaction parameters PP (:func:`.interactions.pair_params`).

    Cells with crossing events, neighbour lists or the dilute scan, sized on the
    interaction's reach; radii far apart: cells per size class (extras 'classes': 'off'
    forces one grid), never neighbour lists unless forced (they would be sized by the
    largest reach, far slower; measurements:
    docs/explanation/engine_measurements.md#event-engine-driver), and in a box with walls
    without gravity the cheapest of size classes, wide cells and the dilute scan by the
    model of :mod:`.mixture_cost`."""
    D, n, L = int(scene.dim), radii.size, float(scene.length)
    periodic = scene.boundary == "periodic"
    gravity = float(scene.gravity) > 0.0
    pairs = float(radii.max()) > 0.0 and n > 1
    sigma = pair_reach(float(radii.max()), PP)
    extras = scene.extras or {}
    choice = extras.get("neighbours", "auto")
    h = float(extras.get("skin", sizing.NEIGHBOUR_SKIN)) * sigma
    plan = None if extras.get("classes", "auto") == "off" else classes.plan(
        radii, D, L, periodic, pairs, False, lambda r: pair_reach(r, PP),
        sizing.cells_per_axis)
    use_nl = (sizing.use_neighbour_lists(choice, D, periodic, L, pairs, sigma, h,
                                         scene.packing_fraction)
              and (plan is None or choice == "lists"))
    if use_nl:
        plan = None
    if plan is not None and choice == "auto" and not periodic and not gravity:
        return _mixture_search(scene, plan, sigma, h, PP)
    dilute = sizing.use_dilute_scan(choice, D, n, L, periodic, gravity, pairs, use_nl, sigma,
                                    scene.packing_fraction)
    nc = 1 if dilute else sizing.cells_per_axis(D, n, L, pairs, periodic, sigma, h, use_nl)
    mix = None if dilute else plan
    nc = mix.nc if mix is not None else nc
    # dilute gases without gravity: wide cells scanned in float32 (neighbours.wide)
    wide = sizing.use_wide_cells(choice, D, n, L, periodic, gravity, pairs, use_nl, dilute,
                                 mix is not None, sigma, scene.packing_fraction)
    if wide:
        nc = sizing.wide_cells_per_axis(D, n, L, sigma, scene.packing_fraction, periodic)
    return use_nl, dilute, mix, nc, h, wide


def _mixture_search(scene: Scene, plan, sigma: float, h: float, PP: tuple) -> tuple:
    """:func:`_search` for a mixture with size classes in a box with walls, no gravity, the
    search left to 'auto': size classes, wide cells or the dilute scan, whichever
    :func:`.mixture_cost.cheapest` rates cheapest."""
    D, n, L = int(scene.dim), scene.n, float(scene.length)
    wide_nc = sizing.wide_cells_per_axis(D, n, L, sigma, scene.packing_fraction)
    pick = mixture_cost.cheapest(D, L, *mixture_cost.species_of(scene),
                                 lambda r: pair_reach(r, PP), plan, wide_nc)
    if pick == "dilute":
        return False, True, None, 1, h, False
    if pick == "wide":
        return False, False, None, wide_nc, h, True
    return False, False, plan, plan.nc, h, False


def resolved_search(scene: Scene) -> dict:
    """The search a run of ``scene`` (valid, event engine) takes, in the names of the scene
    file's ``[search]`` table (:data:`gaz_cli.engines.event.search.SEARCH`): 'neighbours' (the path taken:
    'lists', 'dilute', 'wide' or 'cells'), 'classes' ('off' when one grid; 'auto' when the size
    classes are used, the plan being a rule of the radii alone), 'skin' (with lists: the
    skin in largest diameters). Empty when no search runs (1D, no pairs).

    The runner stores it in the scene (what the caller set stays): a scene left on 'auto'
    reruns from its scene file with the same search, hence the same rows, whatever a later
    cost model (:mod:`.sizing`) would choose. A new search kind adds its name here."""
    radii = np.ascontiguousarray(scene.radii(), dtype=np.float64)
    if scene.dim == 1 or radii.size < 2 or not float(radii.max()) > 0.0:
        return {}
    use_nl, dilute, mix, _, h, wide = _search(scene, radii, pair_params(scene))
    out = {"neighbours": "lists" if use_nl else "dilute" if dilute else "wide" if wide else "cells",
           "classes": "auto" if mix is not None else "off"}
    if use_nl:
        out["skin"] = float((scene.extras or {}).get("skin", sizing.NEIGHBOUR_SKIN))
    return out


class _Simulation(Rows):
    """One run: its arrays (:class:`.rows.Rows`) and the calls around the kernels."""

    def __init__(self, scene: Scene, state: State, recorder: Recorder):
        self.scene = scene
        self.rec = recorder
        D = int(scene.dim)
        if D not in (1, 2, 3):
            raise SceneError(f"--dim {D} is not 1, 2 or 3")
        pos = np.asarray(state.positions, dtype=np.float64)
        vel = np.asarray(state.velocities, dtype=np.float64)
        masses = np.ascontiguousarray(scene.masses(), dtype=np.float64)
        radii = np.ascontiguousarray(scene.radii(), dtype=np.float64)
        n = masses.size
        if n == 0:
            raise SceneError("no particles: give --n")
        if pos.shape != (n, D) or vel.shape != (n, D):
            raise EngineError(f"state arrays have shapes {pos.shape} and {vel.shape}, "
                              f"the scene needs ({n}, {D})")
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(vel))):
            raise EngineError("initial state holds a non-finite position or velocity")
        L = float(scene.length)
        if not (L > 0 and math.isfinite(L)):
            raise SceneError(f"--length {L} must be a positive number")
        periodic = scene.boundary == "periodic"
        g = float(scene.gravity)
        if g > 0 and periodic:
            raise SceneError("--gravity needs hard walls; drop --boundary periodic")
        if g < 0 or not math.isfinite(g):
            raise SceneError(f"--gravity {g} must be >= 0")
        e = float(scene.restitution)
        if not 0.0 <= e <= 1.0:
            raise SceneError(f"--restitution {e} is outside [0, 1]")
        duration = float(scene.duration)
        if not (duration > 0 and math.isfinite(duration)):
            raise SceneError(f"--duration {duration} must be a positive number")
        rmax = float(radii.max())
        pairs = rmax > 0.0 and n > 1
        if periodic and pairs and 4.0 * rmax >= L:
            raise SceneError(f"a periodic box must be wider than two particle diameters "
                             f"({4 * rmax:g} m); raise --length")
        self.D, self.n, self.L, self.g, self.periodic = D, n, L, g, periodic
        self.duration, self.pairs, self.inelastic = duration, pairs, e < 1.0

        self.PP = pair_params(scene)
        use_nl, self.dilute, self.mix, nc, h, self.wide = _search(scene, radii, self.PP)
        self.nc, self.use_nl, self.h = nc, use_nl, h
        images = periodic and (nc < 4 or (self.mix is not None and self.mix.ncl < 4))
        self.kern = build(D, periodic, g > 0.0, pairs, use_nl, images, self.mix is not None,
                          self.dilute, self.wide)
        self.edges = np.arange(nc + 1) * (L / nc)
        self.edges[-1] = L
        self.restart_every = RESTART_EVERY * n if (pairs and D > 1 and n >= RESTART_FROM_N) else 0

        # record buffers
        self.want_b = bool(recorder.want_bounces)
        self.want_c = bool(recorder.want_collisions)
        rows_b = BUFFER_ROWS if self.want_b else 1
        rows_c = BUFFER_ROWS if self.want_c else 1
        self.bt, self.bp = np.empty(rows_b), np.empty(rows_b, dtype=np.int64)
        self.bw = np.empty(rows_b, dtype=np.int64)
        self.bs, self.bv = np.empty(rows_b), np.empty(rows_b)
        self.ct, self.ci = np.empty(rows_c), np.empty(rows_c, dtype=np.int64)
        self.cj, self.cimp = np.empty(rows_c, dtype=np.int64), np.empty(rows_c)

        self.S = np.zeros(1, STATE)  # the loop's state: self.st, its one record
        st = self.st = self.S[0]
        self.buffer_rows = BUFFER_ROWS
        st["bufcap"], st["recb"], st["recc"] = BUFFER_ROWS, self.want_b, self.want_c
        pf_from = min(PREFETCH_FROM_N, PREFETCH_LISTS_FROM_N) if self.use_nl else PREFETCH_FROM_N
        st["nc"], st["n"], st["pf"] = nc, n, n >= pf_from and self.mix is None
        if self.mix is not None:
            mx = self.mix
            st["ncl"], st["fcl"], st["rint"], st["bcl"], st["rcut"] = (mx.ncl, mx.f, mx.rint,
                                                                       mx.bcl, mx.rcut)
        self.CL = np.zeros((1, 5), dtype=np.int32)  # size classes: the coarse table, the
        self.CV = np.zeros(1, dtype=np.int32)  # fine cells' counts of large particles near
        st["L"], st["g"], st["h"] = L, g, h
        st["w"], st["iw"], st["nbk"] = 1.0, 1.0, 16
        self.BH = -np.ones(16, dtype=np.int64)
        self.HK = _alloc(n)
        self.HI = _alloc(n, np.int64)
        self.cap = 0
        self.nb_width = 24 if D == 3 else 12
        self.restarts = 0
        self.rebases = 0
        self.cell_growths = 0

        # internal numbering in space order; ident[k] = caller's number of row k
        x = pos.copy()
        self.images = np.zeros((n, D), dtype=np.int64)  # periodic: wraps before the rows' IM
        if periodic and D > 1 and pairs:
            self.images = self._box_images(x)
            x = self._wrap(x)
        self.ident = self._space_order(x)
        self.M = _alloc(n, fill=masses[self.ident])
        self.R = radii[self.ident]
        self.TL = _alloc(n if self.inelastic else 1, fill=-np.inf)
        self._load(x[self.ident], vel[self.ident], 0.0)

    # --- kernel calls ---------------------------------------------------------
    def _loop(self, t_stop: float, max_events: int) -> int:
        T = Tables(self.P, self.M, self.TL, self.XN, self.I, self.EV, self.Q, self.HK, self.HI,
                   self.BH, self.cells, self.GB, self.GS, self.XS, self.XC, self.XB, self.NB,
                   self.NN, self.SCR,
                   self.order, self.edges, self.ident, self.bt, self.bp, self.bw, self.bs, self.bv,
                   self.ct, self.ci, self.cj, self.cimp, self.CL, self.CV, self.IM)
        return self.kern.loop(T, self.S, self.PP, float(t_stop), int(max_events))

    def _predict(self, t: float) -> None:
        """Every particle's first predictions from time t (the loop in prediction mode)."""
        if self._loop(t, -1) != DONE:
            raise EngineError("prediction pass did not complete")

    def _warm_up(self) -> float:
        """Compile (or load from the cache) every kernel of this run; seconds spent.

        Each kernel is called once on empty input (a loop with t_stop < 0
        returns at once), so compilation stays out of the measured time.
        """
        t0 = time.perf_counter()
        self._loop(-1.0, 0)
        _build_queue(self.EV[:0], self.Q[:0], self.HK, self.HI, self.BH, self.S)
        out = np.empty((0, self.D))
        _state_at(self.P[:0], 0.0, self.g, self.D, out, out)
        return time.perf_counter() - t0

    def _start(self, t: float) -> None:
        """Predict every particle's next event from time t and build the calendar."""
        self._predict(t)
        self._tune_calendar(t)
        self.st["tnow"] = t
        self._since_restart = int(self.st["events"])

    def _tune_calendar(self, t_now: float) -> None:
        """Size the calendar for the pending keys (sizing.calendar_size) and rebuild it."""
        st = self.st
        w, nbk = sizing.calendar_size(self.EV[:, KEY], t_now, self.duration, self.n)
        st["w"], st["iw"], st["nbk"] = w, 1.0 / w, nbk
        st["cur"] = int(math.floor(t_now / w))
        if self.BH.size != nbk:
            self.BH = _alloc(nbk, np.int64, fill=-1)
        self.Q[:, QB] = NONE
        _build_queue(self.EV, self.Q, self.HK, self.HI, self.BH, self.S)

    def _restart(self) -> None:
        """Advance everybody to now, renumber in space order, predict afresh."""
        t, x, v = self._now()
        perm = self._space_order(x)
        self.ident = self.ident[perm]
        self.M = _alloc(self.n, fill=self.M[perm])
        self.R = self.R[perm]
        if self.inelastic:
            self.TL = _alloc(self.n, fill=self.TL[perm])
        self._load(x[perm], v[perm], t)
        self._start(t)
        self.restarts += 1

    def _now(self) -> tuple[float, np.ndarray, np.ndarray]:
        """(now on the kernels' clock, positions, velocities) in row order, wrapped if periodic
        (the wraps counted in ``images``: the caller loads these rows afresh)."""
        t = float(self.st["tnow"])
        x, v = self._state_internal(t)
        return t, (self._fold_images(x) if self.periodic else x), v

    def _rebase(self) -> None:
        """Move the kernels' time origin to now: everybody advanced to now, every prediction
        made afresh from there (as a restart does), so that event times keep their digits."""
        self._flush()  # the buffered rows carry times on the old origin
        t, x, v = self._now()
        if self.inelastic:
            self.TL -= t
        self.origin += t
        self.guard.shift(t)
        self._load(x, v, 0.0)
        self._start(0.0)
        self._rebased_at = int(self.st["events"])
        self.rebases += 1

    def _chunk_cap(self) -> int:
        """Rows a buffer may hold before the kernel hands them over: BUFFER_ROWS, tapered near
        the run's end, where it halves the rows expected to come at the pace so far (down to
        TAIL_ROWS), so that the last chunk is small: a run into a SQLite file inserts each chunk
        from a thread while the engine computes the next, and the user waits for the last one
        (gaz_cli.results.sqlite._EarlyInsert). When the kernel returns changes no event."""
        st = self.st
        now = float(st["tnow"]) + self.origin
        elapsed = now - self.start_time
        rows = max(self.handed[0] + int(st["nbb"]), self.handed[1] + int(st["ncb"]))
        if elapsed <= 0.0 or rows == 0:
            return self.buffer_rows
        expected = rows / elapsed * (self.t_end - now)
        return int(min(self.buffer_rows, max(TAIL_ROWS, expected / 2)))

    def _flush(self) -> None:
        st = self.st
        nb = int(st["nbb"])
        self.handed[0] += nb
        self.handed[1] += int(st["ncb"])
        if nb:
            self.rec.add_bounces(self.bt[:nb] + self.origin, self.bp[:nb].copy(), self.bw[:nb].copy(),
                                 self.bs[:nb].copy(), self.bv[:nb].copy())
            st["nbb"] = 0
        nc = int(st["ncb"])
        if nc:
            self.rec.add_collisions(self.ct[:nc] + self.origin, self.ci[:nc].copy(),
                                    self.cj[:nc].copy(), self.cimp[:nc].copy())
            st["ncb"] = 0

    def _run_to(self, t_stop: float) -> None:
        """Run the event loop up to the absolute time t_stop (s)."""
        st = self.st
        while True:
            budget = max(1, min(self._check_at, self._rebased_at + self.rebase_every)
                         - int(st["events"]))
            if self.restart_every:
                budget = min(budget, max(1, self._since_restart + self.restart_every
                                         - int(st["events"])))
            if self.rec.wants_progress:
                budget = min(budget, EVENTS_PER_REPORT)
            st["bufcap"] = self._chunk_cap()
            status = self._loop(t_stop - self.origin, min(budget, SIGNAL_EVENTS))
            self.rec.progress(float(self.st["tnow"]) + self.origin, int(st["coll"] + st["bounce"]))
            if status == DONE:
                return
            if status == PAUSE and budget > SIGNAL_EVENTS:
                continue  # back from Python, where a signal took effect if one came
            if int(st["events"]) >= self._check_at:  # a chunk's worth, whatever ended the call
                self.guard.check(float(self.st["tnow"]), int(st["events"]), self.origin)
                self._check_at = int(st["events"]) + CHUNK
            if status == BUFFER_FULL:
                self._flush()
            elif status == CELL_FULL:
                self._grow_cells()
                self.cell_growths += 1
            elif status == NL_FULL:
                self._grow_lists()
            elif status == PAUSE:
                if self.restart_every and (int(st["events"]) - self._since_restart
                                           >= self.restart_every):
                    self._restart()
                    continue
                if int(st["events"]) - self._rebased_at >= self.rebase_every:
                    self._rebase()
                    continue
                t_now = float(self.st["tnow"])
                w, nbk = sizing.calendar_size(self.EV[:, KEY], t_now, self.duration, self.n)
                if not 0.5 <= w / self.st["w"] <= 2.0:
                    self._tune_calendar(t_now)
                self._tuned = True
            else:
                raise EngineError(f"event kernel returned unknown status {status}")

    def _stops(self) -> list[tuple[float, bool, bool]]:
        """The times (s from the start) the loop stops at, in order, each with whether a
        snapshot (``snapshot_every``) and a profile sample (``profile_samples``, at
        (k + 1/2) duration / samples) is taken there; the last is the duration."""
        stops: dict[float, list[bool]] = {}
        every = getattr(self.rec, "snapshot_every", None)
        if every:
            kmax = int(math.floor(self.duration / every * (1.0 + 1e-12)))
            for k in range(kmax + 1):
                stops.setdefault(min(k * every, self.duration), [False, False])[0] = True
        samples = int(getattr(self.rec, "profile_samples", 0) or 0)
        for k in range(samples):
            stops.setdefault((k + 0.5) * self.duration / samples, [False, False])[1] = True
        stops.setdefault(self.duration, [False, False])
        return [(t, snap, sample) for t, (snap, sample) in sorted(stops.items())]

    def run(self, start_time: float = 0.0) -> RunStats:
        compile_s = self._warm_up()
        t0 = time.perf_counter()
        self.origin = start_time  # the kernels' clock reads t - origin (see _rebase)
        self.start_time, self.t_end = start_time, start_time + self.duration
        self.handed = [0, 0]  # bounce, collision rows handed to the recorder so far
        self.rebase_every = (REBASE_EVENTS_PER_PARTICLE_GRAVITY if self.g != 0.0
                             else REBASE_EVENTS_PER_PARTICLE) * self.n
        self._rebased_at = 0
        self._tuned = False
        self._check_at = FIRST_CHUNK
        self.guard = RunawayGuard(self.duration, self.t_end, self.inelastic)
        self._start(0.0)
        self.rec.progress(start_time, 0)  # compiled and set up: the run starts
        t_init = time.perf_counter()

        for t_stop, snap, sample in self._stops():
            self._run_to(start_time + t_stop)
            if snap or t_stop == self.duration:  # a sample alone leaves the rows buffered
                self._flush()
            if snap:
                x, v, images = self.snapshot_at(start_time + t_stop)
                hand_snapshot(self.rec, start_time + t_stop, x, v, images)
            if sample:  # a density profile's sample: positions only, O(N)
                self.rec.add_profile_sample(start_time + t_stop, self.state_at(start_time + t_stop)[0])
        x, v = self.state_at(self.t_end)
        t_end = time.perf_counter()

        st = self.st
        final = State(x, v, np.asarray(self.scene.kinds()).copy())
        extras = {
            "cell_crossings": int(st["cross"]),
            "stale_predictions": int(st["stale"]),
            "overlapping_collisions": int(st["overlap"]),
            "second_predictions_used": int(st["second"]),
            "queue_events": int(st["events"]),
            "pair_tests": int(st["pairs"]),
            "dilute_scanned": int(st["scanned"]),
            "calendar_steps": int(st["steps"]),
            "cells_per_axis": self.nc if self.D > 1 else 0,
            "neighbour_lists": self.use_nl,
            "size_classes": self.mix is not None,
            "coarse_cells_per_axis": self.mix.ncl if self.mix is not None else 0,
            "dilute_scan": self.dilute,
            "wide_cells": self.wide,
            "list_rebuilds": int(st["rebuild"]),
            "restarts": self.restarts,
            "rebases": self.rebases,
            "cell_growths": self.cell_growths,
            "prefetch": bool(st["pf"]),
            "bucket_width_s": float(self.st["w"]),
            "buckets": int(st["nbk"]),
            "compile_s": compile_s,
            "init_s": t_init - t0,
            "loop_s": t_end - t_init,
        }
        return RunStats(events=int(st["coll"] + st["bounce"]),
                        wall_bounces=int(st["bounce"]), collisions=int(st["coll"]),
                        wall_time_s=t_end - t0, final=final, virial=float(self.st["virial"]),
                        extras=extras)
