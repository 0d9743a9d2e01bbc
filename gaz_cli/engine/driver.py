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

from gaz_cli.engine import kernels as K
from gaz_cli.engine.layout import Tables
from gaz_cli.engine.memory import HUGE_PAGE, _alloc, _morton  # noqa: F401 (HUGE_PAGE: tests)
from gaz_cli.errors import EngineError, SceneError
from gaz_cli.progress import EVENTS_PER_REPORT
from gaz_cli.recording import Recorder, RunStats
from gaz_cli.scene import Scene, State

BUFFER_ROWS = 1 << 16
"""Rows of each record buffer (bounces, collisions): memory stays bounded on any run."""

CELLS_PER_PARTICLE = 2.0
"""At most this many cells per particle (dilute gases); cells stay at least one diameter wide."""

EVENTS_PER_BUCKET = 4.0
"""Calendar tuning: mean number of events per bucket of the calendar."""

MAX_BUCKETS = 1 << 13
"""Calendar tuning: at most this many buckets (their heads, 64 KB, stay in the cache; larger
systems get wider buckets, hence more events a bucket). Every event inserts into a bucket
at random: with one bucket per particle, as EVENTS_PER_BUCKET alone gives, each insertion
of a system of 10^5-10^6 particles missed the cache (measured: 12% of the event loop's
time at 10^6; capped, 10^5 and 10^6 run 11-12% faster, 10^4 the same)."""

NEIGHBOUR_SKIN = 0.25
"""Neighbour lists: a particle may move this many largest diameters from its list's centre."""

NEIGHBOUR_LIST_FROM = {2: 0.55, 3: 0.33}
"""'auto' uses neighbour lists from this packing fraction on (cell crossings below);
crossovers measured on periodic fluids of N = 4000 with each search forced."""

RESTART_FROM_N = 20_000
RESTART_EVERY = 20
"""Systems of RESTART_FROM_N particles or more are renumbered in space order every
RESTART_EVERY events per particle (memory locality; small systems fit in cache)."""

PREFETCH_FROM_N = 20_000
"""Systems of this many particles or more prefetch the cells and rows of each scan, and
the rows of the next events (their data no longer fits in the caches; below, the hints
cost more than they save)."""

PREFETCH_LISTS_FROM_N = 5_000
"""The same with neighbour lists, whose scans read the rows of a list at random (3D,
packing 0.45, prefetch on/off, CPU time, alternating: 1.20x at N = 10^4, 1.00x at 4000,
0.95x at 2000)."""

FIRST_CHUNK = 50_000
CHUNK = 1 << 22
"""Events per kernel call between two checks of the calendar's tuning."""

STALL_CHUNKS = 3
STALL_RATE = 1e7
"""Runaway guard, checked every chunk of events whatever ended the kernel call (a full record
buffer, a snapshot, the chunk's budget): STALL_CHUNKS chunks in a row whose event rate (events
per simulated second) exceeds STALL_RATE times the reference rate (that of the first chunk
during which simulated time moved), or during which simulated time does not move at all,
end the run with an EngineError instead of a hang."""

SLOW_RATE = 100.0
MAX_PROJECTED_EVENTS = 2e9
"""Slow-down guard for inelastic scenes: once the event rate exceeds SLOW_RATE times the
reference rate and, at that rate, the simulated time left would take more than
MAX_PROJECTED_EVENTS events (20-40 minutes of this engine at 1-2 million events per second),
the run ends with an EngineError naming the simulated time reached. A granular bed that
has settled under gravity does this: the TC model keeps it from collapsing, but each
particle still collides every contact time. Elastic scenes are left alone (their rate can
grow, by compression under gravity, but stays bounded)."""

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
    crossings, stale predictions, compile and set-up times.

    ``scene.extras`` may hold 'neighbours' ('auto', 'cells' or 'lists') and
    'skin' (neighbour-list skin in largest diameters) for benchmarks.
    """
    recorder = recorder if recorder is not None else Recorder()
    start_time = float(start_time)
    if not (math.isfinite(start_time) and start_time >= 0.0):
        raise SceneError(f"start time {start_time} must be a finite number >= 0")
    sim = _Simulation(scene, state, recorder)
    return sim.run(start_time)


def _cell_capacity(per_cell: float) -> int:
    """Initial room of a cell for ``per_cell`` particles a cell on average (grown when full)."""
    return int(max(4, math.ceil(2.0 * per_cell + 3.0 * math.sqrt(per_cell) + 2)))


def _cell_width(cap: int) -> int:
    """Row width of the cell table for ``cap`` particles a cell: the count, then the
    particles, rounded up to whole 16-byte blocks (a cell's row never straddles more
    cache lines than it must)."""
    return max(4 * ((cap + 1 + 3) // 4), K.GATHER_SLOTS + 1)


class _Simulation:
    """One run's arrays and the calls around the kernels."""

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

        # neighbour search: cells with crossing events, or neighbour lists
        sigma = 2.0 * rmax
        skin = scene.extras.get("skin", NEIGHBOUR_SKIN) if scene.extras else NEIGHBOUR_SKIN
        h = float(skin) * sigma
        use_nl = self._neighbour_lists(scene, pairs, sigma, h)
        nc = 1
        if pairs and D > 1:
            reach = sigma + 2.0 * h if use_nl else sigma
            by_size = int(math.floor(L / (reach * (1.0 + 1e-9))))
            by_count = int(math.ceil((CELLS_PER_PARTICLE * n) ** (1.0 / D)))
            nc = max(1, min(by_size, by_count))
            if use_nl and periodic:
                # a list gathers from 3 cells an axis, each once: fewer would list a
                # neighbour once per image (by_size >= 3 here, see _neighbour_lists)
                nc = max(nc, 3)
        self.nc, self.use_nl, self.h = nc, use_nl, h
        self.kern = K.build(D, periodic, g > 0.0, pairs, use_nl, periodic and nc < 4)
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

        self.IS = np.zeros(K.IS_SIZE, dtype=np.int64)
        self.FS = np.zeros(K.FS_SIZE)
        IS, FS = self.IS, self.FS
        IS[K.S_BUFCAP] = BUFFER_ROWS
        IS[K.S_RECB] = int(self.want_b)
        IS[K.S_RECC] = int(self.want_c)
        IS[K.S_NC] = nc
        IS[K.S_N] = n
        pf_from = min(PREFETCH_FROM_N, PREFETCH_LISTS_FROM_N) if use_nl else PREFETCH_FROM_N
        IS[K.S_PF] = int(n >= pf_from)
        FS[K.F_L] = L
        FS[K.F_G] = g
        FS[K.F_E] = e
        FS[K.F_TC] = float(scene.tc)
        FS[K.F_H] = h
        FS[K.F_W] = 1.0
        FS[K.F_IW] = 1.0
        IS[K.S_NBK] = 16
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
        if periodic and D > 1 and pairs:
            x = self._wrap(x)
        self.ident = self._space_order(x)
        self.M = _alloc(n, fill=masses[self.ident])
        self.R = radii[self.ident]
        self.TL = _alloc(n if self.inelastic else 1, fill=-np.inf)
        self._load(x[self.ident], vel[self.ident], 0.0)

    # --- set-up ---------------------------------------------------------------
    def _neighbour_lists(self, scene: Scene, pairs: bool, sigma: float, h: float) -> bool:
        """Whether this run uses neighbour lists (dense 2D/3D) or cell-crossing events.

        ``scene.extras['neighbours']`` may force 'lists' or 'cells'; 'auto'
        picks lists from NEIGHBOUR_LIST_FROM on. Periodic boxes need three
        list-sized cells per axis (one image per neighbour).
        """
        D, L = self.D, self.L
        choice = scene.extras.get("neighbours", "auto") if scene.extras else "auto"
        if choice not in ("auto", "lists", "cells"):
            raise SceneError(f"neighbours {choice!r} is not one of auto, lists, cells")
        if not pairs or D == 1 or choice == "cells":
            return False
        if self.periodic and L < 3.0 * (sigma + 2.0 * h) * (1.0 + 1e-9):
            return False
        if choice == "lists":
            return True
        return scene.packing_fraction >= NEIGHBOUR_LIST_FROM[D]

    def _wrap(self, x: np.ndarray) -> np.ndarray:
        x = x - self.L * np.floor(x / self.L)
        x[x >= self.L] = 0.0
        return x

    def _space_order(self, x: np.ndarray) -> np.ndarray:
        """Row order: along the line in 1D, cells along a Z-order curve in 2D/3D (stable).

        The Z (Morton) order keeps the 3^D cells around a particle within a
        few runs of rows, whichever axis they lie along; row-major cell order
        put the neighbours along the first axis nc^(D-1) cells away.
        """
        if self.D == 1:
            return np.argsort(x[:, 0], kind="stable")
        if not self.pairs:
            return np.arange(self.n)
        return np.argsort(_morton(self._cell_coords(x)), kind="stable")

    def _cell_coords(self, x: np.ndarray) -> np.ndarray:
        """Integer cell coordinates (N, D) of positions x, rounded as the kernels round them."""
        a = self.L / self.nc
        return np.clip(np.floor(x / a).astype(np.int64), 0, self.nc - 1)

    def _load(self, x: np.ndarray, v: np.ndarray, t: float) -> None:
        """Fill the particle rows, cells and lists from positions x and velocities v at time t."""
        n, D, L, nc = self.n, self.D, self.L, self.nc
        P = _alloc((n, K.P_WIDTH), fill=0.0)
        P[:, :D] = x
        P[:, K.PV:K.PV + D] = v
        P[:, K.PT] = t
        P[:, K.PR] = self.R
        I = _alloc((n, K.I_WIDTH), np.int32, fill=0)
        I[:, K.PART] = -1
        I[:, K.PART2] = -1
        self.P, self.I = P, I
        self.EV = _alloc((n, K.EV_WIDTH), fill=np.inf)
        self.Q = _alloc((n, 4), np.int32, fill=0)
        self.Q[:, K.QB] = K.NONE
        # 1D: rows are in line order, so row k has rank k
        self.order = np.arange(n, dtype=np.int64) if D == 1 else np.zeros(1, dtype=np.int64)
        if D == 1:
            I[:, K.RANK] = np.arange(n)
        self.XN = _alloc((n if self.use_nl else 1, 3), fill=0.0)
        if self.use_nl:
            self.XN[:, :D] = x
        if self.pairs and D > 1:
            c = self._cell_coords(x)
            key = c[:, 0]
            for d in range(1, D):
                key = key * nc + c[:, d]
            fullest = int(np.bincount(key, minlength=nc ** D).max())
            cap = max(self.cap, _cell_capacity(n / nc ** D), fullest)
            while True:  # (the kernel's rounding decides; the loop is a safety net)
                self.cells = _alloc((nc ** D, _cell_width(cap)), np.int32)
                if K._assign_cells(P, I, self.cells, nc, L / nc, D) == K.DONE:
                    break
                cap *= 2
            self.cap = self.cells.shape[1] - 1
        else:
            self.cells = np.zeros((1, K.GATHER_SLOTS + 1), dtype=np.int32)
        self._gather_buffers()
        if self.use_nl:
            while True:
                self.NB = _alloc((n, self.nb_width), np.int32)
                self.NN = _alloc(n, np.int32, fill=0)
                self.SCR = np.empty(self.nb_width, dtype=np.int32)
                if K._build_nl(P, self.XN, I, self.cells, self.NB, self.NN,
                               self.SCR, nc, L, self.h, D, self.periodic) == K.DONE:
                    break
                self.nb_width *= 2
        else:
            self.NB = np.zeros((1, 1), dtype=np.int32)
            self.NN = np.zeros(1, dtype=np.int32)
            self.SCR = np.zeros(1, dtype=np.int32)

    # --- kernel calls ---------------------------------------------------------
    def _loop(self, t_stop: float, max_events: int) -> int:
        T = Tables(self.P, self.M, self.TL, self.XN, self.I, self.EV, self.Q, self.HK, self.HI,
                   self.BH, self.cells, self.GB, self.GS, self.NB, self.NN, self.SCR, self.order,
                   self.edges, self.ident, self.bt, self.bp, self.bw, self.bs, self.bv, self.ct,
                   self.ci, self.cj, self.cimp)
        return self.kern.loop(T, self.IS, self.FS, float(t_stop), int(max_events))

    def _predict(self, t: float) -> None:
        """Every particle's first predictions from time t (the loop in prediction mode)."""
        if self._loop(t, -1) != K.DONE:
            raise EngineError("prediction pass did not complete")

    def _warm_up(self) -> float:
        """Compile (or load from the cache) every kernel of this run; seconds spent.

        Each kernel is called once on empty input (a loop with t_stop < 0
        returns at once), so compilation stays out of the measured time.
        """
        t0 = time.perf_counter()
        self._loop(-1.0, 0)
        K._build_queue(self.EV[:0], self.Q[:0], self.HK, self.HI, self.BH, self.IS, self.FS)
        out = np.empty((0, self.D))
        K._state_at(self.P[:0], 0.0, self.g, self.D, out, out)
        return time.perf_counter() - t0

    def _start(self, t: float) -> None:
        """Predict every particle's next event from time t and build the calendar."""
        self._predict(t)
        self._tune_calendar(t)
        self.FS[K.F_TNOW] = t
        self._since_restart = int(self.IS[K.S_EVENTS])

    def _calendar_size(self, t_now: float) -> tuple[float, int]:
        """(bucket width, bucket count) for the pending keys: EVENTS_PER_BUCKET events per bucket
        (more when MAX_BUCKETS caps the count).

        Each particle's next event comes at a rate ~ ln 2 / median(delay);
        the median ignores bursts of simultaneous events (a lattice start
        puts whole planes of particles on cell faces). The buckets span the
        90th percentile of the delays.
        """
        keys = self.EV[:, K.KEY]
        finite = keys[np.isfinite(keys)] - t_now
        if finite.size == 0:
            return self.duration / 1024.0, 16
        med = float(np.median(finite))
        if not med > 0.0:
            med = float(np.mean(finite))
        if not med > 0.0:
            med = self.duration * 1e-9
        w = EVENTS_PER_BUCKET * med / (finite.size * math.log(2.0))
        if not (w > 0.0 and math.isfinite(w)):
            return self.duration / 1024.0, 16
        horizon = float(np.quantile(finite, 0.9))
        want = max(16, min(1 << 22, int(horizon / w) + 1, 4 * self.n))
        nbk = 1 << int(math.ceil(math.log2(want)))
        if nbk > MAX_BUCKETS:
            w *= nbk / MAX_BUCKETS
            nbk = MAX_BUCKETS
        return w, nbk

    def _tune_calendar(self, t_now: float) -> None:
        """Size the calendar for the pending keys (see _calendar_size) and rebuild it."""
        IS, FS = self.IS, self.FS
        w, nbk = self._calendar_size(t_now)
        FS[K.F_W] = w
        FS[K.F_IW] = 1.0 / w
        IS[K.S_NBK] = nbk
        IS[K.S_CUR] = int(math.floor(t_now / w))
        if self.BH.size != nbk:
            self.BH = _alloc(nbk, np.int64, fill=-1)
        self.Q[:, K.QB] = K.NONE
        K._build_queue(self.EV, self.Q, self.HK, self.HI, self.BH, IS, FS)

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
        """(now on the kernels' clock, positions, velocities) in row order, wrapped if periodic."""
        t = float(self.FS[K.F_TNOW])
        x, v = self._state_internal(t)
        return t, (self._wrap(x) if self.periodic else x), v

    def _rebase(self) -> None:
        """Move the kernels' time origin to now: everybody advanced to now, every prediction
        made afresh from there (as a restart does), so that event times keep their digits."""
        self._flush()  # the buffered rows carry times on the old origin
        t, x, v = self._now()
        if self.inelastic:
            self.TL -= t
        self.origin += t
        self._stall_t -= t
        self._load(x, v, 0.0)
        self._start(0.0)
        self._rebased_at = int(self.IS[K.S_EVENTS])
        self.rebases += 1

    def _flush(self) -> None:
        IS = self.IS
        nb = int(IS[K.S_NBB])
        if nb:
            self.rec.add_bounces(self.bt[:nb] + self.origin, self.bp[:nb].copy(), self.bw[:nb].copy(),
                                 self.bs[:nb].copy(), self.bv[:nb].copy())
            IS[K.S_NBB] = 0
        nc = int(IS[K.S_NCB])
        if nc:
            self.rec.add_collisions(self.ct[:nc] + self.origin, self.ci[:nc].copy(),
                                    self.cj[:nc].copy(), self.cimp[:nc].copy())
            IS[K.S_NCB] = 0

    def _grow_lists(self) -> None:
        old = self.NB
        self.nb_width = 2 * old.shape[1]
        nb = _alloc((old.shape[0], self.nb_width), np.int32)
        nb[:, :old.shape[1]] = old
        self.NB = nb
        self.SCR = np.empty(self.nb_width, dtype=np.int32)

    def _grow_cells(self) -> None:
        old = self.cells
        cells = _alloc((old.shape[0], _cell_width(2 * (old.shape[1] - 1))), np.int32)
        cells[:, :old.shape[1]] = old
        self.cells = cells
        self.cap = cells.shape[1] - 1
        self._gather_buffers()

    def _gather_buffers(self) -> None:
        """Room for two scans (a collision's partners) to gather every particle of 3^D full cells
        (GB) and their image shifts (GS)."""
        if self.cells.shape[1] < K.GATHER_SLOTS + 1:
            raise EngineError(f"cell rows of width {self.cells.shape[1]}: the scans copy "
                              f"{K.GATHER_SLOTS} slots a cell")
        room = 3 ** self.D * (self.cells.shape[1] - 1) + K.GATHER_SLOTS + 1
        self.GB = np.empty(2 * room, dtype=np.int32)
        self.GS = np.empty(2 * room if self.periodic else 1, dtype=np.int32)

    def _state_internal(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        x = np.empty((self.n, self.D))
        v = np.empty((self.n, self.D))
        K._state_at(self.P, float(t), self.g, self.D, x, v)
        return x, v

    def state_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(positions, velocities) (N, D) at time t in the caller's order, wrapped if periodic."""
        xi, vi = self._state_internal(t - self.origin)
        x = np.empty_like(xi)
        v = np.empty_like(vi)
        x[self.ident] = xi
        v[self.ident] = vi
        if self.periodic:
            x = self._wrap(x)
        return x, v

    def _run_to(self, t_stop: float) -> None:
        """Run the event loop up to the absolute time t_stop (s)."""
        IS = self.IS
        while True:
            budget = max(1, min(self._check_at, self._rebased_at + self.rebase_every)
                         - int(IS[K.S_EVENTS]))
            if self.restart_every:
                budget = min(budget, max(1, self._since_restart + self.restart_every
                                         - int(IS[K.S_EVENTS])))
            if self.rec.wants_progress:
                budget = min(budget, EVENTS_PER_REPORT)
            status = self._loop(t_stop - self.origin, budget)
            self.rec.progress(float(self.FS[K.F_TNOW]) + self.origin, int(IS[K.S_COLL] + IS[K.S_BOUNCE]))
            if status == K.DONE:
                return
            if int(IS[K.S_EVENTS]) >= self._check_at:  # a chunk's worth, whatever ended the call
                self._check_stall()
                self._check_at = int(IS[K.S_EVENTS]) + CHUNK
            if status == K.BUFFER_FULL:
                self._flush()
            elif status == K.CELL_FULL:
                self._grow_cells()
                self.cell_growths += 1
            elif status == K.NL_FULL:
                self._grow_lists()
            elif status == K.PAUSE:
                if self.restart_every and (int(IS[K.S_EVENTS]) - self._since_restart
                                           >= self.restart_every):
                    self._restart()
                    continue
                if int(IS[K.S_EVENTS]) - self._rebased_at >= self.rebase_every:
                    self._rebase()
                    continue
                t_now = float(self.FS[K.F_TNOW])
                w, nbk = self._calendar_size(t_now)
                if not 0.5 <= w / self.FS[K.F_W] <= 2.0:
                    self._tune_calendar(t_now)
                self._tuned = True
            else:
                raise EngineError(f"event kernel returned unknown status {status}")

    def _check_stall(self) -> None:
        """Raise EngineError when simulated time stops, when the event rate runs away
        (inelastic collapse) or when an inelastic run slows down beyond any sensible length,
        instead of hanging; called once a chunk of events (see STALL_RATE, SLOW_RATE)."""
        t = float(self.FS[K.F_TNOW])
        events = int(self.IS[K.S_EVENTS])
        dt = t - self._stall_t
        moved = dt > 1e-12 * max(abs(t), self.duration)
        rate = (events - self._stall_n) / dt if moved else math.inf
        self._stall_t, self._stall_n = t, events
        t_abs = t + self.origin
        if not moved:
            self._stalled += 1
        elif self._rate0 is None:
            self._rate0 = rate
            self._stalled = 0
        elif rate > STALL_RATE * self._rate0:
            self._stalled += 1
        else:
            self._stalled = 0
        if self._stalled >= STALL_CHUNKS:
            if not moved:
                raise EngineError(
                    f"simulated time stopped at t = {t_abs:.6g} s: {events} events, the last "
                    f"{events - self._moved_n} of them at one instant (particles jammed: "
                    "rods filling the box, a particle at rest on the floor, or an inelastic "
                    "collapse); loosen the packing, give the particles speed, or give --tc")
            raise EngineError(
                f"the event rate ran away at t = {t_abs:.6g} s ({events} events, {rate:.3g} per "
                f"simulated second, {rate / self._rate0:.3g} times the rate at the start): "
                "inelastic collapse, particles colliding ever faster; give a contact time "
                "--tc (TC model) or raise --restitution")
        if moved:
            self._moved_n = events
        left = self.t_end - t_abs
        if (self.inelastic and moved and self._rate0 is not None
                and rate > SLOW_RATE * self._rate0 and rate * left > MAX_PROJECTED_EVENTS):
            raise EngineError(
                f"the run slowed down at t = {t_abs:.6g} s of {self.t_end:.6g} s: {rate:.3g} "
                f"events per simulated second ({rate / self._rate0:.3g} times the rate at the "
                f"start), so the {left:.3g} s left would take about {rate * left:.2g} events "
                "(the inelastic particles have settled into a bed, colliding every contact "
                "time); shorten --duration, raise --restitution or --tc")

    def run(self, start_time: float = 0.0) -> RunStats:
        compile_s = self._warm_up()
        t0 = time.perf_counter()
        self.origin = start_time  # the kernels' clock reads t - origin (see _rebase)
        self.t_end = start_time + self.duration
        self.rebase_every = (REBASE_EVENTS_PER_PARTICLE_GRAVITY if self.g != 0.0
                             else REBASE_EVENTS_PER_PARTICLE) * self.n
        self._rebased_at = 0
        self._tuned = False
        self._check_at = FIRST_CHUNK
        self._stall_t = 0.0
        self._stall_n = 0
        self._moved_n = 0
        self._stalled = 0
        self._rate0 = None
        self._start(0.0)
        self.rec.progress(start_time, 0)  # compiled and set up: the run starts
        t_init = time.perf_counter()

        every = getattr(self.rec, "snapshot_every", None)
        stops: list[tuple[float, bool]] = []
        if every:
            kmax = int(math.floor(self.duration / every * (1.0 + 1e-12)))
            stops = [(min(k * every, self.duration), True) for k in range(kmax + 1)]
        if not stops or stops[-1][0] < self.duration:
            stops.append((self.duration, False))
        for t_stop, snap in stops:
            self._run_to(start_time + t_stop)
            self._flush()
            if snap:
                x, v = self.state_at(start_time + t_stop)
                self.rec.add_snapshot(start_time + t_stop, x, v)
        x, v = self.state_at(self.t_end)
        t_end = time.perf_counter()

        IS = self.IS
        final = State(x, v, np.asarray(self.scene.kinds()).copy())
        extras = {
            "cell_crossings": int(IS[K.S_CROSS]),
            "stale_predictions": int(IS[K.S_STALE]),
            "overlapping_collisions": int(IS[K.S_OVERLAP]),
            "second_predictions_used": int(IS[K.S_SECOND]),
            "queue_events": int(IS[K.S_EVENTS]),
            "pair_tests": int(IS[K.S_PAIRS]),
            "calendar_steps": int(IS[K.S_STEPS]),
            "cells_per_axis": self.nc if self.D > 1 else 0,
            "neighbour_lists": self.use_nl,
            "list_rebuilds": int(IS[K.S_REBUILD]),
            "restarts": self.restarts,
            "rebases": self.rebases,
            "cell_growths": self.cell_growths,
            "prefetch": bool(IS[K.S_PF]),
            "bucket_width_s": float(self.FS[K.F_W]),
            "buckets": int(IS[K.S_NBK]),
            "compile_s": compile_s,
            "init_s": t_init - t0,
            "loop_s": t_end - t_init,
        }
        return RunStats(events=int(IS[K.S_COLL] + IS[K.S_BOUNCE]),
                        wall_bounces=int(IS[K.S_BOUNCE]), collisions=int(IS[K.S_COLL]),
                        wall_time_s=t_end - t0, final=final, virial=float(self.FS[K.F_VIRIAL]),
                        extras=extras)
