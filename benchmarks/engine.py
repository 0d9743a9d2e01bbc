"""Figures of the event-driven engine (issue 3): speed, cost per event against N, start-up.

Not a test: it prints numbers. Run from the repository root:

    /work/venv/bin/python benchmarks/engine.py            # all figures, median of 3 runs
    /work/venv/bin/python benchmarks/engine.py --only a   # one figure
    /work/venv/bin/python benchmarks/engine.py --quick    # smaller runs

(a) standard scene: 3D periodic, N = 4000, packing 0.30, FCC start,
    sigma = m = k_B T = 1, simulated time 100: collisions and events per
    second, beta P sigma^3 from the collision virial (KLM 2.2827; the issue expects 2.27-2.28),
    relative energy drift;
(b) argon at 300 K, 3D box with walls, N = 10 000, packing 0.01;
(c) 2D, N = 1000 disks, area fraction 0.2, walls;
(d) 1D, N = 1000 rods, packing 0.5, walls;
(e) speed-up over gaz_cli.engines.reference on (c) at N = 200 and N = 1000;
(f) cost per event from N = 10^3 to 10^6 (3D periodic, packing 0.3; the sizes run in
    turn, --repeat rounds, so that a slow spell of the host falls on all), beside the work
    per event (pair times, calendar steps: flat) and the latency of one cache miss over
    as many bytes as the engine holds (what makes the time per event grow);
(g) JIT compile time from an empty cache, and process start to first event
    with a warm cache;
(h) a dense fluid (3D periodic, packing 0.45) at N = 10^4 and 10^6, with cell
    crossings and with neighbour lists (what 'auto' picks there);
(i) an ideal gas (point particles): the ideal path's closed-form bounces per second
    against the event engine's, on the same scene;
(j) the README example end to end (1000 argon atoms, 178 thousand wall bounces into a new
    SQLite file): start-up, engine and recording, as benchmarks/recording.py measures them
    (its alternating rounds, --repeat of them);
(k) the README example's engine alone (1000 argon atoms, 3D box with walls, 10 ns): cells
    (the search before the dilute scan, forced) against what 'auto' picks (the dilute scan:
    every particle scans all, no cells), alternating runs, CPU time; with the queue events,
    cell crossings and pair tests per physical event (also given for (b));
(l) a dilute periodic gas (argon at the README example's density, N = 10^4, 3D periodic,
    1 ns): cells (forced) against what 'auto' picks (wide cells), as (k).

--markdown prints, after the figures, the README's speed table from this one run.

Rates are given per wall-clock second (what a user waits) and per CPU second
of this process (what the code costs when the machine is shared); each is
the median of --repeat runs, and the fastest run is given beside it (a busy
host only ever slows a run down). Placement and compilation are excluded
(RunStats.wall_time_s).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

from gaz_cli.engines import event as engine
from gaz_cli.engines.event import layout as K
from gaz_cli.engines.event.memory import _alloc
from gaz_cli.constants import K_B
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species, lookup

UNIT_T = 1.0 / K_B

ROWS: dict[str, list[str]] = {}
"""Figure letter -> [scene, figure]: the README's speed table (--markdown), filled as the
figures run."""


def row(key: str, scene: str, figure: str) -> None:
    ROWS[key] = [scene, figure]


def _m(x: float) -> str:
    """A rate in millions, three significant figures."""
    return f"{x / 1e6:.3g}"


def _pow10(n: int) -> str:
    return "10" + str(round(math.log10(n))).translate(str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹"))


def unit_scene(dim, n, packing, duration, boundary="walls", placement="auto", seed=1):
    unit = {1: 1.0, 2: math.pi / 4.0, 3: math.pi / 6.0}[dim]
    length = (n * unit / packing) ** (1.0 / dim)
    return Scene(dim=dim, length=length, duration=duration,
                 components=((Species("X", 1.0, 0.5), n),), temperature=UNIT_T, seed=seed,
                 boundary=boundary, placement=placement, record="none")


def timed(scene, state, repeat):
    """Median wall and CPU rates over ``repeat`` runs: dict of figures and the last RunStats."""
    walls, cpus = [], []
    rs = None
    for _ in range(repeat):
        c0 = time.process_time()
        rs = engine.run(scene, state, Recorder())
        if rs.extras["compile_s"] > 0:  # compiled (wall seconds, not CPU): time a warm run instead
            c0 = time.process_time()
            rs = engine.run(scene, state, Recorder())
        cpu = time.process_time() - c0 - rs.extras["compile_s"]
        walls.append(rs.wall_time_s)
        cpus.append(cpu)
    return {"wall": float(np.median(walls)), "cpu": float(np.median(cpus)),
            "fastest": min(walls), "runs": repeat}, rs


def show(label, t, rs):
    n_ev = rs.events
    print(f"  {label}: {rs.collisions:,} collisions, {rs.wall_bounces:,} wall bounces, "
          f"{rs.extras['cell_crossings'] + rs.extras['list_rebuilds']:,} crossings/rebuilds "
          f"in {t['wall']:.2f} s wall / {t['cpu']:.2f} s CPU (median of {t['runs']})")
    print(f"    collisions/s: {rs.collisions / t['wall']:,.0f} wall, {rs.collisions / t['cpu']:,.0f} CPU"
          f" (fastest run {rs.collisions / t['fastest']:,.0f} wall);"
          f"  events/s (collisions + bounces): {n_ev / t['wall']:,.0f} wall, {n_ev / t['cpu']:,.0f} CPU")
    return (f"{_m(rs.collisions / t['wall'])} million collisions/s ({_m(rs.collisions / t['cpu'])} per CPU "
            f"second; fastest run {_m(rs.collisions / t['fastest'])}), {_m(n_ev / t['wall'])} million events/s")


def fig_a(args):
    print("(a) standard scene: 3D periodic, N = 4000, packing 0.30, FCC start, sigma = m = kT = 1, "
          f"simulated time {args.t_std:g}")
    sc = unit_scene(3, 4000, 0.30, args.t_std, boundary="periodic", placement="lattice")
    st = initial_state(sc)
    t, rs = timed(sc, st, args.repeat)
    rate = show("run", t, rs)
    m = sc.masses()
    e0 = 0.5 * float(np.sum(m * np.sum(st.velocities ** 2, 1)))
    e1 = 0.5 * float(np.sum(m * np.sum(rs.final.velocities ** 2, 1)))
    kT = 2.0 * e1 / (3 * (sc.n - 1))
    rho = sc.n / sc.volume
    beta_p = rho + rs.virial / (3.0 * sc.volume * sc.duration) / kT
    print(f"    beta P sigma^3 = {beta_p:.4f} (KLM fit to simulations 2.2827, Carnahan-Starling 2.2768;"
          " the issue expects 2.27-2.28);"
          f" relative energy drift {(e1 - e0) / e0:.1e}; neighbour lists: {rs.extras['neighbour_lists']}")
    row("a", f"(a) 3D periodic, N = 4000, packing 0.30, FCC start, σ = m = kT = 1, t = {args.t_std:g}",
        f"{rate}; βPσ³ = {beta_p:.4f} (KLM 2.2827; Carnahan–Starling 2.2768); energy drift {(e1 - e0) / e0:.1e}")


def fig_b(args):
    ar = lookup("Ar")
    n, eta = 10_000, 0.01
    length = (n * 4.0 / 3.0 * math.pi * ar.radius ** 3 / eta) ** (1 / 3)
    # about 5 collisions per particle: mean free time from kinetic theory
    speed = math.sqrt(8 * K_B * 300 / (math.pi * ar.mass))
    free_time = 1.0 / (math.sqrt(2) * math.pi * n / length ** 3 * (2 * ar.radius) ** 2 * speed)
    duration = args.scale * 10 * free_time
    print(f"(b) argon at 300 K, 3D walls, N = {n}, packing {eta}, L = {length:.3g} m, "
          f"duration {duration:.3g} s")
    sc = Scene(dim=3, length=length, duration=duration, components=((ar, n),), seed=2,
               record="none")
    t, rs = timed(sc, initial_state(sc), args.repeat)
    rate = show("run", t, rs)
    per_event(rs)
    row("b", "(b) argon, 300 K, 3D box with walls, N = 10⁴, packing 0.01", rate)


def per_event(rs) -> str:
    """The work per physical event (collision or wall bounce) of a run, printed and returned."""
    ex, ev = rs.extras, rs.events
    said = (f"{ex['queue_events'] / ev:.2f} queue events, "
            f"{(ex['cell_crossings'] + ex['list_rebuilds']) / ev:.2f} crossings/rebuilds, "
            f"{ex['pair_tests'] / ev:.0f} pair tests per physical event "
            f"({'dilute scan' if ex.get('dilute_scan') else str(ex['cells_per_axis']) + ' cells an axis'})")
    print(f"    {said}")
    return said


def cells_against_auto(key: str, sc: Scene, label: str, args) -> None:
    """Scene ``sc`` with cells (forced) against what 'auto' picks, alternating runs, CPU time;
    printed with the work per physical event, and kept as the table's row ``key``."""
    st = initial_state(sc)
    cpus = {"cells": [], "auto": []}
    last = {}
    for _ in range(args.repeat):
        for search in cpus:
            t, rs = timed(dataclasses.replace(sc, extras={"neighbours": search}), st, 1)
            cpus[search].append(t["cpu"])
            last[search] = rs
    said = []
    for search, v in cpus.items():
        rs = last[search]
        print(f"  {search}: {np.median(v):.3f} s CPU (median of {len(v)}; runs "
              f"{', '.join(f'{x:.3f}' for x in v)}), {rs.events / np.median(v) / 1e6:.3f} M events/CPU s")
        said.append(f"{search} {np.median(v):.2f} s CPU: {per_event(rs)}")
    ratios = [c / a for c, a in zip(cpus["cells"], cpus["auto"])]
    print(f"    cells / auto CPU time, pair by pair: {', '.join(f'{r:.2f}' for r in ratios)} "
          f"(median {np.median(ratios):.2f})")
    row(key, label, "; ".join(said) + f"; ×{np.median(ratios):.2f} (median of {len(ratios)} alternating pairs)")


def fig_k(args):
    ar = lookup("Ar")
    duration = 1e-8 * args.scale
    print(f"(k) the README example's engine: 1000 argon atoms, 300 K, L = 3.4e-8 m, walls, "
          f"duration {duration:.3g} s; cells (forced) against 'auto', alternating, CPU seconds")
    sc = Scene(dim=3, length=3.4e-8, duration=duration, components=((ar, 1000),), seed=1,
               record="none")
    cells_against_auto("k", sc, "(k) README example, engine only: 1000 argon atoms, 10 ns, cells against 'auto'",
                       args)


def fig_l(args):
    ar = lookup("Ar")
    n, eta = 10_000, 0.0005
    length = (n * 4.0 / 3.0 * math.pi * ar.radius ** 3 / eta) ** (1 / 3)
    duration = 1e-9 * args.scale
    print(f"(l) argon at 300 K, 3D periodic, N = {n}, packing {eta} (the README example's density), "
          f"L = {length:.3g} m, duration {duration:.3g} s; cells (forced) against 'auto', "
          "alternating, CPU seconds")
    sc = Scene(dim=3, length=length, duration=duration, components=((ar, n),), seed=1,
               boundary="periodic", record="none")
    cells_against_auto("l", sc, "(l) dilute periodic gas: argon, 300 K, 3D periodic, N = 10⁴, packing 0.0005, "
                       "1 ns, cells against 'auto'", args)


def fig_c(args):
    print("(c) 2D, N = 1000 disks, area fraction 0.2, walls, sigma = m = kT = 1")
    sc = unit_scene(2, 1000, 0.2, 200.0 * args.scale)
    t, rs = timed(sc, initial_state(sc), args.repeat)
    row("c", "(c) 2D, N = 1000 disks, area fraction 0.2, walls", show("run", t, rs))


def fig_d(args):
    print("(d) 1D, N = 1000 rods, packing 0.5, walls, sigma = m = kT = 1")
    sc = unit_scene(1, 1000, 0.5, 2000.0 * args.scale)
    t, rs = timed(sc, initial_state(sc), args.repeat)
    row("d", "(d) 1D, N = 1000 rods, packing 0.5", show("run", t, rs))


def fig_e(args):
    from gaz_cli.engines import reference
    print("(e) speed-up over gaz_cli.engines.reference on (c): events (collisions + bounces) per second")
    print("    the reference's catalogue keeps every prediction (exam Q30), so its rate falls as a run "
          "goes on: it is timed on a short and on a longer run")
    durations = {200: (6.0, 24.0), 1000: (0.3, 1.0)}
    said = []
    for n in (200, 1000):
        sc = unit_scene(2, n, 0.2, 200.0 * args.scale if n == 1000 else 1000.0 * args.scale)
        t, rs = timed(sc, initial_state(sc), args.repeat)
        fast_rate = rs.events / t["wall"]
        print(f"  N = {n}: engine {fast_rate:,.0f} events/s over {rs.events:,} events")
        for d in durations[n][:1] if args.quick else durations[n]:
            sc_ref = unit_scene(2, n, 0.2, d)
            rr = reference.run(sc_ref, initial_state(sc_ref), Recorder())
            ref_rate = rr.events / rr.wall_time_s
            print(f"    reference over t = {d:g} ({rr.events:,} events, {rr.wall_time_s:.1f} s): "
                  f"{ref_rate:,.0f} events/s; speed-up x{fast_rate / ref_rate:,.0f}")
            said.append(f"N = {n}: ×{fast_rate / ref_rate:,.0f} against the reference over {d:g} time "
                        f"units ({rr.events:,} events)")
    row("e", "(e) speed-up over the exam's algorithm on (c)", "; ".join(said))


@numba.njit(cache=False)
def _chase(nxt, steps):
    """Follow ``steps`` links of a cycle stored every 8th int64 of nxt (one link a cache line)."""
    i = 0
    for _ in range(steps):
        i = nxt[i * 8]
    return i


def _latency_ns(nbytes: int, loads: int = 2_000_000) -> float:
    """Nanoseconds per dependent load at random over ``nbytes`` (one load a 64-byte line, huge
    pages as the engine's arrays): what one cache miss costs when the data is that large."""
    lines = max(nbytes // 64, 16)
    nxt = _alloc(lines * 8, np.int64, fill=0)
    perm = np.random.default_rng(0).permutation(lines)
    nxt[perm * 8] = np.roll(perm, -1)  # one cycle through every line, in random order
    _chase(nxt, 1000)
    t0 = time.perf_counter()
    _chase(nxt, loads)
    return 1e9 * (time.perf_counter() - t0) / loads


def fig_f(args):
    print("(f) cost per event against N: 3D periodic, packing 0.3, lattice start, "
          "about 3 10^6 queue events each (collisions, crossings, stale predictions)")
    print("    ns/event: event loop only (the O(N) first predictions are set-up, given apart), "
          "the sizes run in turn --repeat times so that the machine's slow spells fall on all of "
          "them (median, and the fastest run); work per event: pair times computed, calendar "
          "buckets stepped; memory: ns per dependent load at random over as many bytes as the "
          "engine's arrays hold (one cache miss at this size)")
    sizes = [1000, 10_000, 100_000, 1_000_000] if not args.quick else [1000, 10_000, 100_000]
    scenes = {}
    for n in sizes:
        sc = unit_scene(3, n, 0.30, 3e6 / (n * 5.0) * args.scale, boundary="periodic",
                        placement="lattice")
        t0 = time.perf_counter()
        scenes[n] = (sc, initial_state(sc), time.perf_counter() - t0)
    loop_ns = {n: [] for n in sizes}
    last = {}
    for _ in range(args.repeat):
        for n in sizes:
            sc, st, _ = scenes[n]
            rs = engine.run(sc, st, Recorder())
            loop_ns[n].append(1e9 * rs.extras["loop_s"] / rs.extras["queue_events"])
            last[n] = rs
    med = {n: float(np.median(loop_ns[n])) for n in sizes}
    first = med[sizes[0]]
    for n in sizes:
        rs, ex = last[n], last[n].extras
        q = ex["queue_events"]
        lat = _latency_ns(n * ENGINE_BYTES_PER_PARTICLE)
        print(f"  N = {n:>9,}: {med[n]:6.0f} ns per queue event in the loop (x{med[n] / first:.2f}; "
              f"fastest {min(loop_ns[n]):.0f}), {1e9 * rs.wall_time_s / q:6.0f} with set-up; "
              f"work per event: {ex['pair_tests'] / q:.2f} pair times, "
              f"{ex['calendar_steps'] / q:.2f} buckets; memory latency {lat:5.1f} ns")
        print(f"               placement {scenes[n][2]:.1f} s, set-up {ex['init_s']:.2f} s, "
              f"restarts {ex['restarts']}")
    slope = math.log(med[sizes[-1]] / first) / math.log(sizes[-1] / sizes[0])
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"    time per event ~ N^{slope:.3f} over this range (medians); peak memory of this "
          f"process {rss:,.0f} MB")
    big = last[sizes[-1]].extras
    row("f", "(f) cost per queue event (loop only), N = " + " / ".join(_pow10(n) for n in sizes),
        " / ".join(f"{med[n] / 1e3:.2f}" for n in sizes) + f" µs, medians of {args.repeat} rounds over the "
        f"sizes in turn (about N^{slope:.3f}); {big['pair_tests'] / big['queue_events']:.1f} pair times per "
        f"event at the largest; peak memory {rss:,.0f} MB")


def fig_h(args):
    print("(h) dense fluid, cell crossings against neighbour lists: 3D periodic, packing 0.45, "
          "lattice start, 2-5 10^6 queue events each; ns per collision in the loop (the two "
          "searches process different queue events: crossings or list rebuilds), median of "
          "--repeat runs taken in turn")
    sizes = [10_000, 1_000_000] if not args.quick else [10_000, 100_000]
    for n in sizes:
        sc = unit_scene(3, n, 0.45, 3e6 / (n * 15.0) * args.scale, boundary="periodic",
                        placement="lattice")
        st = initial_state(sc)
        ns = {"cells": [], "lists": []}
        last = {}
        for _ in range(args.repeat):
            for search in ns:
                rs = engine.run(dataclasses.replace(sc, extras={"neighbours": search}), st,
                                Recorder())
                ns[search].append(1e9 * rs.extras["loop_s"] / rs.collisions)
                last[search] = rs
        auto = engine.run(dataclasses.replace(sc, duration=sc.duration * 1e-3), st,
                          Recorder()).extras["neighbour_lists"]
        line = ", ".join(f"{s} {np.median(v):,.0f} (fastest {min(v):,.0f}; "
                         f"{last[s].collisions:,} collisions)" for s, v in ns.items())
        print(f"  N = {n:>9,}: ns per collision: {line}; 'auto' picks "
              f"{'lists' if auto else 'cells'}")
        h = ROWS.setdefault("h", ["(h) dense fluid, 3D periodic, packing 0.45: ns per collision, cells "
                                  "against neighbour lists", ""])
        h[1] += (f"{'; ' if h[1] else ''}N = {n:,}: " + " against ".join(f"{np.median(v):,.0f}" for v in ns.values())
                 + f" ('auto' picks {'lists' if auto else 'cells'})")


ENGINE_BYTES_PER_PARTICLE = 8 * K.P_WIDTH + 4 * K.I_WIDTH + 8 * K.EV_WIDTH + 4 * 4 + 8 + 2 * 56
"""Bytes the event loop reads per particle (3D): rows P, I, EV, Q, the mass, and about
two cell rows' share (cells and calendar buckets)."""


_PROBE = """
import sys
if "--no-scipy" in sys.argv:
    sys.modules["scipy"] = None  # as on an install without the test extra
import time
from gaz_cli.engines import event as engine
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species
sc = Scene(dim=3, length=12.0, duration=1e-9, components=((Species("X", 1.0, 0.5), 500),),
           temperature=1.0 / 1.380649e-23, seed=1, boundary="periodic", record="none")
rs = engine.run(sc, initial_state(sc), Recorder())
print(time.time(), rs.extras["compile_s"], int("scipy.linalg" in sys.modules))
"""


def _probe(env, *flags):
    """(seconds from launching a fresh interpreter to the end of a first tiny run, compile s,
    whether scipy.linalg got imported)."""
    t0 = time.time()
    out = subprocess.run([sys.executable, "-c", _PROBE, *flags], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    return float(out[0]) - t0, float(out[1]), out[2] == "1"


def fig_g(args):
    print("(g) start-up: the standard scene's kernels (3D periodic, cells)")
    with tempfile.TemporaryDirectory() as cache:
        # Numba's cache and Python's bytecode cache both in the temporary directory: the
        # second run of a user (pyc files are written by default); PYTHONDONTWRITEBYTECODE,
        # if the caller set it, would recompile gaz's sources on every start
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPYCACHEPREFIX=os.path.join(cache, "pyc"))
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        start, compile_s, _ = _probe(env)
        print(f"  cold (empty cache): JIT compile of the engine {compile_s:.1f} s; process start "
              f"to first event {start:.1f} s (placement kernels compiled too)")
        warm_with = None
        for flags, what in (((), "with scipy installed"), (("--no-scipy",), "without scipy")):
            runs = [_probe(env, *flags) for _ in range(max(3, args.repeat))]
            warm = [r[0] for r in runs]
            scipy_loaded = "yes" if any(r[2] for r in runs) else "no"
            warm_with = warm_with or warm
            print(f"  warm cache, {what}: process start to first event {np.median(warm):.2f} s "
                  f"(median of {len(warm)}, range {min(warm):.2f}-{max(warm):.2f}; interpreter, "
                  f"numpy and numba imports, cache loads included; scipy.linalg imported: "
                  f"{scipy_loaded})")
        env["PYTHONDONTWRITEBYTECODE"] = "1"
        env.pop("PYTHONPYCACHEPREFIX")
        warm = [_probe(env)[0] for _ in range(max(3, args.repeat))]
        print(f"  warm Numba cache, with scipy, PYTHONDONTWRITEBYTECODE=1 (gaz's sources compiled "
              f"to bytecode at each start unless .pyc files sit beside them): "
              f"{np.median(warm):.2f} s (median of {len(warm)})")
    row("g", "(g) compilation from an empty cache; start-up with a warm cache",
        f"{compile_s:.1f} s; {np.median(warm_with):.2f} s from process start to the first event "
        f"(median of {len(warm_with)}, range {min(warm_with):.2f}–{max(warm_with):.2f})")


class _Count(Recorder):
    """Counts the bounces handed over, as a database writer would receive them."""

    want_bounces = True

    def __init__(self):
        self.k = 0

    def add_bounces(self, t, *rest):
        self.k += len(t)


def fig_i(args):
    from gaz_cli.engines import ideal

    n = 10_000
    duration = 2e-8 * args.scale
    print(f"(i) ideal gas: {n} point particles of argon's mass, 3D box L = 1e-7 m, walls, "
          f"duration {duration:.3g} s: the ideal path (closed-form bounces) against the event "
          "engine, alternating runs")
    sc = Scene(dim=3, length=1e-7, duration=duration, components=((Species("point", lookup("Ar").mass, 0.0), n),),
               seed=1, force=True)
    st = initial_state(sc)
    times = {"ideal": [], "event": []}
    counts = {}
    for _ in range(args.repeat):
        for name, run in (("ideal", ideal.run), ("event", engine.run)):
            rec = _Count()
            c0 = time.process_time()
            rs = run(sc, st, rec)
            if rs.extras.get("compile_s", 0.0) > 0:  # compiled: time a warm run instead
                rec = _Count()
                c0 = time.process_time()
                rs = run(sc, st, rec)
            times[name].append(time.process_time() - c0 - rs.extras.get("compile_s", 0.0))
            counts[name] = rec.k
    for name in times:
        cpu = float(np.median(times[name]))
        print(f"  {name}: {counts[name]:,} bounces, {counts[name] / cpu / 1e6:.2f} M bounces/s CPU "
              f"(median of {args.repeat})")
    print(f"    ratio ideal/event: {np.median(times['event']) / np.median(times['ideal']):.2f}x")
    cpu = {name: float(np.median(v)) for name, v in times.items()}
    row("i", f"(i) ideal gas: {n:,} point particles of argon's mass, 3D box with walls",
        f"ideal path {counts['ideal'] / cpu['ideal'] / 1e6:.2f} million bounces per CPU second, event engine "
        f"{counts['event'] / cpu['event'] / 1e6:.2f} (×{cpu['event'] / cpu['ideal']:.1f})")


def fig_j(args):
    import recording  # benchmarks/recording.py, beside this file

    print(f"(j) the README example end to end ({' '.join(recording.ARGS)} into a new SQLite file): "
          f"start-up, engine, recording; {args.repeat} alternating rounds of benchmarks/recording.py")
    med = recording.measure(args.repeat, "bounces", log=print)
    ratios = med["rounds"]["ratio_cpu"]
    print(f"  medians: start-up {med['startup']:.2f} s wall; engine {med['engine_cpu']:.3f} s CPU "
          f"({med['engine_wall']:.2f} s wall); recording {med['rec_cpu']:.3f} s CPU ({med['rec_wall']:.2f} s "
          f"wall) = {med['ratio_cpu']:.1%} of the engine (rounds {min(ratios):.1%}-{max(ratios):.1%}); end to "
          f"end {med['e2e_db']:.2f} s with the database, {med['e2e_nodb']:.2f} s without")
    row("j", f"(j) README example end to end: 1000 argon atoms, {med['bounces']:,} wall bounces into a new "
             "SQLite file", f"{med['e2e_db']:.2f} s end to end: start-up {med['startup']:.2f} s, engine "
        f"{med['engine_wall']:.2f} s ({med['engine_cpu']:.2f} s CPU), recording {med['rec_wall']:.2f} s "
        f"({med['rec_cpu']:.2f} s CPU, {med['ratio_cpu']:.0%} of the engine's; rounds "
        f"{min(ratios):.0%}–{max(ratios):.0%}); {med['e2e_nodb']:.2f} s with --no-db")


def markdown(args, load, seconds) -> str:
    """The README's speed table from this run's figures."""
    lines = [f"`python benchmarks/engine.py --repeat {args.repeat}{' --quick' if args.quick else ''} "
             f"--markdown`: {os.cpu_count()} shared cores, load average {load[0]:.1f} at the start, "
             f"{seconds / 60:.0f} min; medians of {args.repeat} runs", "",
             "| scene | figure |", "| --- | --- |"]
    lines += [f"| {scene} | {figure} |" for _, (scene, figure) in sorted(ROWS.items())]
    return "\n".join(lines)


FIGURES = {"a": fig_a, "b": fig_b, "c": fig_c, "d": fig_d, "e": fig_e, "f": fig_f, "g": fig_g,
           "h": fig_h, "i": fig_i, "j": fig_j, "k": fig_k, "l": fig_l}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", default="abcdefghijkl", help="figures to print, e.g. 'af'")
    ap.add_argument("--repeat", type=int, default=3, help="runs per figure (median)")
    ap.add_argument("--quick", action="store_true", help="shorter runs, N up to 10^5 in (f)")
    ap.add_argument("--markdown", action="store_true", help="then print the README's speed table")
    args = ap.parse_args()
    began = time.perf_counter()
    args.scale = 0.2 if args.quick else 1.0
    args.t_std = 20.0 if args.quick else 100.0
    load = os.getloadavg()
    print(f"gaz engine benchmark: {os.cpu_count()} cores, load average {load[0]:.2f} "
          f"{load[1]:.2f} {load[2]:.2f}, numba threads unused (serial engine)")
    # compile the kernels used below outside the timed runs
    engine.run(unit_scene(3, 100, 0.3, 1e-9, boundary="periodic"), initial_state(
        unit_scene(3, 100, 0.3, 1e-9, boundary="periodic")), Recorder())
    for key in args.only:
        FIGURES[key](args)
        sys.stdout.flush()
    if args.markdown:
        print()
        print(markdown(args, load, time.perf_counter() - began))


if __name__ == "__main__":
    main()
