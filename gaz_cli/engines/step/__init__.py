"""The time-stepped engine of seeds 002 (C++ particles) and 003 (numpy tutorial).

``run(scene, state, recorder) -> RunStats`` advances the particles with a fixed
step ``scene.dt`` (velocity Verlet, kick-drift-kick) under uniform gravity,
linear friction ``scene.drag`` and optional Plummer-softened attraction
between bodies ``scene.pair_gravity``; contacts are found with a cell list
and resolved by going back to the contact time (the seed-002 collision
operator, repeated passes); box walls (restitution ``scene.wall_restitution``)
and extra planes ``scene.planes``. The order of operations inside a step is in
:mod:`gaz_cli.engines.step.loop`.

What reaches the recorder is what the exact engine sends: wall bounces
(time of contact, RE_DIR, |v| and |v_perp| just before; a particle hopping
on a floor within a step records each bounce of the series, up to
codes.MAX_HOP_ROWS a contact; one that comes to rest within the step
records one bounce whose (1 + e_w) m |v_perp| is the momentum the floor gave
it in the step, its weight included: see :func:`wall_contact._wall_contact`), collisions (time of
contact, i, j, |J|) when wanted, snapshots at t = 0, every, 2 every, ...
(linear interpolation between the two step ends around each snapshot time),
and, every ``scene.print_every`` steps, a diagnostic dict (time, step,
kinetic, potential and total energy, largest speed, particle count,
collisions, bounces).

Exactness: kick-drift-kick is exact for uniform gravity, walls are met on
the exact parabola and pairs on their exact straight relative path, so
binary collisions and bounces come out at their exact times; the errors of a
finite dt are contacts missed inside a step (grazing or passing through),
several contacts of one particle inside a step (resolved by passes, earliest
first), pair forces (velocity Verlet, O(dt^2); a contact inside a step is met
with the velocities at its time and, on a wall, along the parabola of the
step's constant acceleration, so contacts of attracting bodies keep the
energy error O(dt^2): tests/test_stepper.py measures the ratio 4 between dt
and dt/2) and friction mixed with walls (a bounce under friction and a
constant acceleration changes the velocity with an O(dt^2) error; the hops of
a series within one step fly without friction). A bounce's row holds the
velocity at its contact time (wall_contact._velocity_at), as a collision's impulse
does, not the drift velocity of the step's middle, which is off by O(dt). A
ball resting on a floor is held there until the end of the step: an impact
on it is found and met on its true path (at rest), not on its drift line
(contacts._held_root; a ball merely resting on it is held by it in turn, the
contact stopping their approach on the drift lines whatever the restitution,
its weight passed down to the floor's row within the step: resting._rest_on,
so a stack stands exactly; a ball resting on several at once, in a pile,
still settles by repeated collisions each step); one that a
collision takes off it flies freely from the contact (resting._release: it
ends the step on the free parabola, and its floor row loses the support of
the time left), friction aside; one that a collision pushes along the floor,
or into it and to rest again within the step, stays held, the floor taking
the push (resting._wall_takes: one contact a step, its row the momentum).

Limitations: hard walls only (periodic boundaries raise SceneError); pair
forces are an O(N^2) sum (threads from PARALLEL_PAIR_MIN bodies on); bounces
on the extra planes are counted (extras['plane_bounces']) but not recorded,
having no RE_DIR; static piles of inelastic particles (a settled ``marbles``
preset) can need more passes than MAX_PASSES in a step: extras
['pass_limit_hits'] counts those steps, whose leftover approaching overlaps
are taken up by the next step.
"""

from __future__ import annotations

import math
import os
import time
import warnings

import numba
import numpy as np

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
"""Threads waiting at the end of a parallel region sleep instead of spinning (read when Numba
starts OpenMP, its usual threading layer). The step engine opens several short regions a step:
on a shared machine (load 6 on 2 cores) spinning threads took the cores from the working
ones, 2 threads ran 6x slower than 1 (24 s for 4 s on issue 40's scene); passive, 1.2x slower
there. Set OMP_WAIT_POLICY=ACTIVE on a dedicated machine to spin."""

from gaz_cli.errors import EngineError, GazWarning, SceneError
from gaz_cli.interrupts import interrupt_in
from gaz_cli.model.recording import Recorder, RunStats
from gaz_cli.engines.step.accepts import check_in_front_of_planes, check_step_scene
from gaz_cli.model.scene import Scene, State
from gaz_cli.engines.step import codes as _c
from gaz_cli.engines.step.loop import _run_steps, workspace
from gaz_cli.engines.step.push import _pair_acc, _pair_potential
from gaz_cli.engines.step import ranks

DETECTIONS = ("overlap", "swept")
"""Contact detection: 'overlap' is seed 002's rule (overlapping and approaching at the end of
the step); 'swept' also catches the pairs that touched during the step and already separate
(grazing contacts the overlap rule misses), at the price of a wider neighbour search."""

DEFAULT_DETECTION = "overlap"
"""Seed 002's rule: on the benchmark scene (docs/explanation/run_time_vs_error.md) halving dt with it
buys more accuracy per second than switching to 'swept'."""

PATCH_MIN = 5000
"""Particles a patch holds at least, by default: one patch a thread, but no more patches than
N / PATCH_MIN (a small scene runs as one patch, without parallel regions, whose start costs
more than its work). The numbers do not depend on it."""

MAX_PASSES = 100
"""Collision passes per step before giving up (counted in extras['pass_limit_hits'])."""

FLUSH_AT = 65536
"""Events kept in the kernel's buffers before they are handed to the recorder."""

SLICE_S = 0.1
"""Wall-clock seconds a kernel call runs before it hands control back to Python, where Ctrl-C
(KeyboardInterrupt) is seen; a step is never cut, so a call lasts at least one step."""

MAX_STEPS_PER_CALL = None
"""Optional cap on the steps of one kernel call (None: the SLICE_S deadline only). On a
platform without CLOCK_MONOTONIC the deadline is off and this cap is what bounds a call;
tests set it to cut a run into many calls."""

_CLOCK = getattr(time, "CLOCK_MONOTONIC", -1)
_NO_CLOCK_STEP_WORK = 1 << 22
"""Without a clock: particle-steps per kernel call (steps = this / N)."""

MPI_STEP_WORK = 1 << 20
"""In an MPI run: particle-steps per kernel call (steps = this / N, at least 1). The ranks' calls
must end at the same steps (:mod:`.ranks`), so a call ends by this count, not by the
SLICE_S deadline of each rank's own clock; about 0.1-0.4 s a call (100-365 ns a particle-step)."""


def _deadline() -> float:
    """End of the next kernel call's slice on the kernel's clock, s (inf without a clock)."""
    return time.clock_gettime(_CLOCK) + SLICE_S if _CLOCK >= 0 else math.inf


def forces(scene: Scene) -> tuple[str, ...]:
    """The force terms a scene switches on, in kernel order: 'drag', 'gravity', 'pair'.

    An empty tuple means the kick is skipped entirely (free flight between contacts).
    """
    out = []
    if scene.drag > 0:
        out.append("drag")
    if scene.gravity > 0:
        out.append("gravity")
    if scene.pair_gravity > 0:
        out.append("pair")
    return tuple(out)


def check(scene: Scene) -> None:
    """Raise SceneError when the step engine cannot run ``scene`` (its options: the rest of the
    scene was admitted by the one door, :func:`gaz_cli.scenes.validate.validate`)."""
    check_step_scene(scene)


def planes_array(scene: Scene) -> np.ndarray:
    """(P, 2D+1) float64: point (m), unit inward normal, restitution of each extra plane."""
    d = scene.dim
    out = np.zeros((len(scene.planes), 2 * d + 1))
    for p, (point, normal, e) in enumerate(scene.planes):
        nrm = np.asarray(normal, dtype=float)
        norm = float(np.linalg.norm(nrm))
        if norm == 0 or not math.isfinite(norm):
            raise SceneError("a plane has a zero normal")
        out[p, :d] = point
        out[p, d: 2 * d] = nrm / norm
        out[p, 2 * d] = e
    return out


def energies(scene: Scene, positions: np.ndarray, velocities: np.ndarray) -> tuple[float, float]:
    """(kinetic, potential) energy, J; potential = uniform gravity + pair attraction."""
    masses = scene.masses()
    kinetic = float(0.5 * np.sum(masses * np.sum(velocities ** 2, axis=1)))
    potential = 0.0
    if scene.gravity > 0:
        potential += float(scene.gravity * np.sum(masses * positions[:, scene.dim - 1]))
    if scene.pair_gravity > 0:
        potential += float(_pair_potential(np.ascontiguousarray(positions), masses,
                                              scene.pair_gravity, scene.softening ** 2))
    return kinetic, potential


def run(scene: Scene, state: State, recorder: Recorder, *, detection: str = DEFAULT_DETECTION,
        max_passes: int = MAX_PASSES, patches: int | None = None) -> RunStats:
    """Simulate ``scene`` from ``state`` with fixed steps scene.dt; events go to ``recorder``.

    ``detection``: 'overlap' (default, seed 002's rule) or 'swept', see
    :data:`DETECTIONS`. ``max_passes``: collision passes allowed per step. ``patches``: about
    how many patches the box is cut into (default: one per thread, Numba's
    ``get_num_threads()``, set by NUMBA_NUM_THREADS or ``gaz simulate --threads``, and at
    most N / PATCH_MIN); the numbers do not depend on it nor on the threads.
    The caller's arrays are not modified. RunStats.extras holds 'steps',
    'passes', 'max_passes_per_step', 'pass_limit_hits', 'plane_bounces',
    'folded_bounces' (bounces of hop series longer than codes.MAX_HOP_ROWS
    that share their series' last row),
    'pair_force_evaluations', 'phase_times' (s: push, collisions, walls,
    exchange, output; in an MPI run also share, the allgather of :mod:`.ranks`, which
    collisions leaves out), 'forces', 'detection', 'dt', and the overlaps the steps left:
    'overlap_steps' (steps that ended with a pair closer than (1 -
    codes.OVERLAP_TOL) sigma), 'overlapping_pairs_max' (most such pairs at
    one step end), 'closest_pair' (smallest |dr| / sigma at a step end),
    'dt_without_overlaps' (s, or None). The first step that leaves such a
    pair raises a GazWarning (once a run) naming a dt that avoids them.
    """
    check(scene)
    check_in_front_of_planes(scene, state.positions)
    if detection not in DETECTIONS:
        raise SceneError(f"detection {detection!r} is not one of {', '.join(DETECTIONS)}")
    return _Stepper(scene, state, recorder, detection, int(max_passes), patches).run()


class _Stepper:
    """The arrays of one run and the loop that hands blocks of steps to the kernel."""

    def __init__(self, scene: Scene, state: State, recorder: Recorder, detection: str, max_passes: int,
                 patches: int | None = None):
        self.scene = scene
        self.recorder = recorder
        self.pos = np.array(state.positions, dtype=np.float64, order="C", copy=True)
        self.vel = np.array(state.velocities, dtype=np.float64, order="C", copy=True)
        self.kinds = np.array(state.kinds, copy=True)
        n, d = self.pos.shape
        if d != scene.dim or n != scene.n:
            raise SceneError(f"state has shape {self.pos.shape}, scene wants ({scene.n}, {scene.dim})")
        self.mass = np.ascontiguousarray(scene.masses(), dtype=np.float64)
        self.radius = np.ascontiguousarray(scene.radii(), dtype=np.float64)
        self.planes = planes_array(scene)
        self.acc = np.zeros_like(self.pos)
        self.age = np.zeros(n)
        self.tlast = np.full(n, -np.inf)
        self.swept = detection == "swept"
        self.detection = detection
        self.max_passes = max(1, max_passes)
        self.nthreads = int(numba.get_num_threads())
        self.rank, self.nranks = ranks.rank(), ranks.size()
        if patches is None:  # an MPI run: at least a patch a rank (the ranks' threads: guessed like ours)
            patches = max(min(self.nranks * self.nthreads, max(1, n // PATCH_MIN)), self.nranks)
        self.patches = max(1, int(patches))
        self.steps_per_call = MAX_STEPS_PER_CALL
        if self.nranks > 1 and self.steps_per_call is None:
            self.steps_per_call = max(1, MPI_STEP_WORK // max(1, n))
        self.want_b = bool(recorder.want_bounces)
        self.want_c = bool(recorder.want_collisions)
        self.bf = np.empty((1024, 3))
        self.bi = np.empty((1024, 2), dtype=np.int64)
        self.cf = np.empty((1024, 2))
        self.ci = np.empty((1024, 2), dtype=np.int64)
        self.nb = 0
        self.nc = 0
        self.ws = workspace(d, n)
        self.counters = np.zeros(_c.N_COUNTERS, dtype=np.int64)
        self.clocks = np.zeros(_c.N_TIMERS)
        self.virial = np.zeros(1)
        self.overlap = np.array([1.0, np.nan])  # codes.G_CLOSEST, G_FIRST_TIME
        self.warned = False
        self.output_time = 0.0
        # the schedule: n_full steps of dt, then one shorter step to land on the duration
        dt = float(scene.dt)
        self.dt = dt
        self.n_full = int(math.floor(scene.duration / dt * (1 + 1e-12)))
        rest = scene.duration - self.n_full * dt
        self.dt_last = rest if rest > 1e-9 * dt else 0.0
        self.total = self.n_full + (1 if self.dt_last > 0 else 0)
        self.step = 0
        every = recorder.snapshot_every
        if every is not None and not (math.isfinite(every) and every > 0):
            raise SceneError(f"--every must be a positive number of seconds, got {every}")
        self.every = every
        self.next_snap = 0  # index k of the next snapshot time k * every

    # --- time bookkeeping
    def time_at(self, k: int) -> float:
        """Simulated time at the end of k steps, s."""
        if k <= self.n_full:
            return k * self.dt
        return self.scene.duration

    def _snap_time(self, k: int) -> float:
        return k * self.every

    def _snap_pending(self) -> bool:
        return self.every is not None and self._snap_time(self.next_snap) <= self.scene.duration * (1 + 1e-12)

    def _snap_step(self) -> int:
        """Index of the step whose end is the first at or after the next snapshot time."""
        t = self._snap_time(self.next_snap)
        k = int(math.ceil(t / self.dt * (1 - 1e-12)))
        return min(max(k, 0), self.total)

    # --- kernel calls
    def _run_steps(self, nsteps: int) -> None:
        """Run ``nsteps`` steps (fewer if the buffers ask for a flush, then continue)."""
        sc = self.scene
        cap = self.steps_per_call
        if cap is None and _CLOCK < 0:
            cap = max(1, _NO_CLOCK_STEP_WORK // max(1, self.pos.shape[0]))
        while nsteps > 0:
            if self.step < self.n_full:
                # step k ends at (k + 1) dt: t0 = 0 and k0 = k, whatever the calls' lengths
                count, t0, k0, dt = min(nsteps, self.n_full - self.step), 0.0, self.step, self.dt
            else:
                count, t0, k0, dt = 1, self.time_at(self.step), 0, self.dt_last
            if cap is not None:
                count = min(count, int(cap))
            try:
                (status, done, self.bf, self.bi, self.nb, self.cf, self.ci, self.nc, self.ws) = _run_steps(
                    count, t0, k0, dt, self.pos, self.vel, self.acc, self.mass, self.radius, self.age,
                    self.tlast, self.planes, float(sc.length), float(sc.gravity), float(sc.drag),
                    float(sc.pair_gravity), float(sc.softening) ** 2, float(sc.restitution),
                    float(sc.wall_restitution), float(sc.tc), self.max_passes, self.swept,
                    self.want_b, self.want_c, self.bf, self.bi, self.nb, self.cf, self.ci, self.nc,
                    FLUSH_AT, self.counters, self.clocks, self.virial, self.overlap, _CLOCK, self.nthreads,
                    _deadline() if self.nranks == 1 else math.inf, self.patches, self.ws, self.rank, self.nranks)
            except SystemError as err:
                interrupt = interrupt_in(err)
                if interrupt is not None:  # a signal seen as the kernel returned: the same
                    raise interrupt from None  # interrupt (SIGTERM stays SIGTERM)
                raise
            self.step += done
            nsteps -= done
            c = self.counters
            self.recorder.progress(self.time_at(self.step), int(c[_c.C_BOUNCES] + c[_c.C_COLLISIONS]))
            if status == _c.FLUSH:
                self._flush()
            if not self.warned and self.counters[_c.C_OVERLAP_STEPS] > 0:
                self._warn_overlaps()

    def dt_without_overlaps(self) -> float:
        """A time step, s, that should leave no pair overlapping by more than OVERLAP_TOL.

        Depths grow at least linearly with dt (grazing misses as dt^2, pass-throughs as dt),
        so dt x OVERLAP_TOL / (deepest overlap seen, in sigma) is on the safe side; halved,
        since the rare grazing misses just beyond the tolerance need a shorter step too.
        Measured (2D, 1000 disks, area fraction 0.5, seed 1, tau the Enskog mean free
        time): overlaps left in 50 of 50 steps at dt = 5 tau (up to 334 pairs, the closest
        0.005 sigma apart; suggested 0.025 tau), 50 of 50 at 1 tau (suggested 0.010 tau), 46
        of 667 at 0.3 tau (suggested 0.022 tau); none at 0.1, 0.05, 0.03, 0.01 tau.
        """
        depth = max(1.0 - float(self.overlap[_c.G_CLOSEST]), _c.OVERLAP_TOL)
        return 0.5 * self.dt * _c.OVERLAP_TOL / depth

    def _warn_overlaps(self) -> None:
        """Warn (once a run) that a step ended with pairs overlapping, and suggest a dt."""
        self.warned = True
        c = self.counters
        warnings.warn(GazWarning(
            f"the step engine left {int(c[_c.C_OVERLAP_MAX])} pair(s) overlapping by more than "
            f"{_c.OVERLAP_TOL:.0%} of their contact distance at the end of a step (first at "
            f"t = {self.overlap[_c.G_FIRST_TIME]:.3g} s, the closest {self.overlap[_c.G_CLOSEST]:.3g} sigma "
            f"apart): --dt {self.dt:.3g} s is too long for this scene; --dt "
            f"{self.dt_without_overlaps():.2g} s or shorter should avoid them (or use --engine event)"),
            stacklevel=1)

    def _flush(self) -> None:
        t0 = time.perf_counter()
        if self.rank > 0:  # an MPI run: rank 0 alone records
            self.nb = self.nc = 0
            return
        if self.nb:
            t = self.bf[: self.nb, 0]
            o = np.argsort(t, kind="stable")
            self.recorder.add_bounces(t[o].copy(), self.bi[: self.nb, 0][o], self.bi[: self.nb, 1][o],
                                      self.bf[: self.nb, 1][o], self.bf[: self.nb, 2][o])
            self.nb = 0
        if self.nc:
            t = self.cf[: self.nc, 0]
            o = np.argsort(t, kind="stable")
            self.recorder.add_collisions(t[o].copy(), self.ci[: self.nc, 0][o], self.ci[: self.nc, 1][o],
                                         self.cf[: self.nc, 1][o])
            self.nc = 0
        self.output_time += time.perf_counter() - t0

    def _diagnostic(self) -> None:
        if self.rank > 0:  # an MPI run: rank 0 alone records
            return
        t0 = time.perf_counter()
        kinetic, potential = energies(self.scene, self.pos, self.vel)
        self.recorder.diagnostic({
            "time": self.time_at(self.step),
            "step": self.step,
            "kinetic": kinetic,
            "potential": potential,
            "energy": kinetic + potential,
            "max_speed": float(np.sqrt(np.max(np.sum(self.vel ** 2, axis=1)))),
            "n": int(self.pos.shape[0]),
            "collisions": int(self.counters[_c.C_COLLISIONS]),
            "bounces": int(self.counters[_c.C_BOUNCES]),
            "passes": int(self.counters[_c.C_PASSES]),
        })
        self.output_time += time.perf_counter() - t0

    def _snapshot_step(self) -> None:
        """Advance one step and send every snapshot whose time falls inside it (interpolated)."""
        xp, vp, tp = self.pos.copy(), self.vel.copy(), self.time_at(self.step)
        self._run_steps(1)
        t0 = time.perf_counter()
        t = self.time_at(self.step)
        while self._snap_pending() and self._snap_time(self.next_snap) <= t * (1 + 1e-12):
            ts = self._snap_time(self.next_snap)
            f = min(max((ts - tp) / (t - tp), 0.0), 1.0)
            if f == 1.0:
                x, v = self.pos.copy(), self.vel.copy()
            else:
                x, v = xp + f * (self.pos - xp), vp + f * (self.vel - vp)
            self.recorder.add_snapshot(ts, x, v)
            self.next_snap += 1
        self.output_time += time.perf_counter() - t0

    def job(self) -> dict:
        """What another rank of an MPI run needs to run the same steps (:func:`.mpi.serve`)."""
        return {"scene": self.scene, "state": State(self.pos, self.vel, self.kinds), "detection": self.detection,
                "max_passes": self.max_passes, "patches": self.patches, "steps_per_call": self.steps_per_call,
                "threads": self.nthreads,
                "want_bounces": self.want_b, "want_collisions": self.want_c, "every": self.every}

    def run(self) -> RunStats:
        sc = self.scene
        if self.rank == 0 and self.nranks > 1:
            ranks.start(self.job())  # the other ranks run the same steps from here on
        # compile (or load from the cache) before the clock starts
        _run_steps(0, 0.0, 0, self.dt, self.pos, self.vel, self.acc, self.mass, self.radius, self.age,
                    self.tlast, self.planes, float(sc.length), 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1,
                    self.swept, False, False, self.bf, self.bi, 0, self.cf, self.ci, 0, FLUSH_AT,
                    np.zeros_like(self.counters), np.zeros_like(self.clocks), np.zeros(1),
                    self.overlap.copy(), _CLOCK, self.nthreads, math.inf, self.patches, self.ws, 0, 1)
        if sc.pair_gravity > 0 and sc.print_every:
            _pair_potential(self.pos[:2], self.mass[:2], 0.0, 0.0)  # compile the pair potential
        ranks.barrier()  # an MPI run: every rank compiled, the clocks start together
        self.recorder.progress(0.0, 0)  # compiled: the run starts
        start = time.perf_counter()
        if sc.pair_gravity > 0:
            _pair_acc(self.pos, self.mass, float(sc.pair_gravity), float(sc.softening) ** 2, self.acc,
                         self.nthreads)
        if self._snap_pending() and self._snap_time(0) == 0.0:
            t0 = time.perf_counter()
            self.recorder.add_snapshot(0.0, self.pos.copy(), self.vel.copy())
            self.next_snap = 1
            self.output_time += time.perf_counter() - t0
        pe = int(sc.print_every or 0)
        if pe > 0:
            self._diagnostic()
        while self.step < self.total:
            target = self.total
            if pe > 0:
                target = min(target, (self.step // pe + 1) * pe)
            if self._snap_pending():
                crossing = self._snap_step()
                if crossing <= self.step + 1:
                    self._snapshot_step()
                    if pe > 0 and self.step % pe == 0:
                        self._diagnostic()
                    continue
                target = min(target, crossing - 1)
            self._run_steps(target - self.step)
            if pe > 0 and self.step % pe == 0:
                self._diagnostic()
        ranks.finish()  # an MPI run: no exchange between ranks from here on
        if pe > 0 and self.step % pe != 0:
            self._diagnostic()
        self._flush()
        wall = time.perf_counter() - start
        if not (np.all(np.isfinite(self.pos)) and np.all(np.isfinite(self.vel))):
            raise EngineError("the step engine produced non-finite positions or velocities; "
                              "lower --dt or add --softening")
        c = self.counters
        bounces, collisions = int(c[_c.C_BOUNCES]), int(c[_c.C_COLLISIONS])
        steps = int(c[_c.C_STEPS])
        extras = {
            "steps": steps,
            "dt": self.dt,
            "detection": self.detection,
            "forces": ",".join(forces(sc)) or "none",
            "passes": int(c[_c.C_PASSES]),
            "max_passes_per_step": int(c[_c.C_MAX_PASSES]),
            "pass_limit_hits": int(c[_c.C_PASS_LIMIT]),
            "plane_bounces": int(c[_c.C_PLANE]),
            "folded_bounces": int(c[_c.C_FOLDED]),
            "pair_force_evaluations": int(c[_c.C_PAIR_EVALS]),
            "overlap_steps": int(c[_c.C_OVERLAP_STEPS]),
            "overlapping_pairs_max": int(c[_c.C_OVERLAP_MAX]),
            "closest_pair": float(self.overlap[_c.G_CLOSEST]),
            "dt_without_overlaps": self.dt_without_overlaps() if c[_c.C_OVERLAP_STEPS] else None,
            "phase_times": {
                "push": float(self.clocks[_c.T_PUSH]),
                "collisions": float(self.clocks[_c.T_COLLISIONS]) - ranks.share_time() * (self.nranks > 1),
                "walls": float(self.clocks[_c.T_WALLS]),
                "exchange": float(self.clocks[_c.T_EXCHANGE]),
                "output": float(self.output_time),
            },
        }
        if self.nranks > 1:  # the candidates' allgather, waits for the slowest rank included
            extras["phase_times"]["share"] = ranks.share_time()
        final = State(self.pos.copy(), self.vel.copy(), self.kinds.copy())
        return RunStats(events=bounces + collisions, wall_bounces=bounces, collisions=collisions,
                        wall_time_s=wall, final=final, virial=float(self.virial[0]), extras=extras)
