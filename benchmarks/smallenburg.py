"""gaz against F. Smallenburg's C event-driven code (issue 15 items 2 and 5).

Not a test: it prints numbers. The C code is the "Single" variant of
https://github.com/FSmallenburg/EDMD (neighbour lists, one event per particle;
F. Smallenburg, Eur. Phys. J. E 45, 22, 2022), or with ``--variant Cell`` its "Cell"
variant (cell lists with crossing events, every predicted collision queued; the one for
gases). Give a copy of that repository (a work tree, or a bare git directory: its
``Single/`` or ``Cell/`` is read from HEAD); the script patches the run's parameters
into its globals, builds it with ``--cc`` and ``--cflags`` and runs it in a temporary
directory. Run from the repository root:

    python benchmarks/smallenburg.py --edmd PATH_TO_EDMD            # 5 pairs, N = 10^4
    python benchmarks/smallenburg.py --edmd PATH --pairs 3 --per-particle 50
    python benchmarks/smallenburg.py --edmd PATH --variant Cell --gaz-search auto --walled \
        --packing 0.01 --per-particle 12 --equilibrate 3 --pairs 6     # a dilute gas

gaz searches with neighbour lists unless ``--gaz-search`` says 'auto' (a periodic gas:
cells with crossing events) or 'cells'; the equilibration uses the same search.
``--walled`` adds to each pair a gaz run on the same gas in a box with walls (Scene's
default boundary, search 'auto': wide cells below packing 0.05), melted the same way from
gaz's own start: its collisions per second (wall bounces not counted, though its time
includes them) beside the periodic ones, its beta P not measured (NaN).

The scene, the same for both: 3D periodic cube, N hard spheres of diameter sigma = 1,
mass m = 1, k_B T = 1 (the C code's units: lengths in sigma, times in
tau = sigma sqrt(m / k_B T)); packing fraction 0.45; both start from the same
positions (gaz's lattice placement melted by a gaz run of ``--equilibrate`` collisions
per particle, written as the C code's ``init.sph``); gaz keeps that run's velocities,
the C code draws Maxwell velocities of zero total momentum with its own generator; both
run for the same simulated time, about ``--per-particle`` collisions per particle
(N ``--per-particle`` collisions in all, from the Enskog rate with KLM's contact value). Neighbour lists of the same shell: the C code lists
the pairs within 1.5 (R_i + R_j) (``shellsize`` 1.5) and rebuilds a particle's
list when it has moved 0.5 R = 0.25 sigma; gaz lists the pairs within
R_i + R_j + 2h and rebuilds at h, h = 0.25 sigma (``NEIGHBOUR_SKIN``), so the
same lists. The C code's thermostat is switched off (gaz's runs are
microcanonical) and it prints every ``--write`` tau (O(N) each).

Each pair runs both codes one after the other (the order alternates from pair to
pair), and prints for each the collisions per second of wall time and of CPU time,
and gaz/C. C: the whole process (reading 10^4 lines and building its lists are a few
ms); CPU from the child's rusage. gaz: RunStats.wall_time_s (set-up, including the
first lists, and the event loop; the JIT compile is done once before the pairs and
excluded) and this process's CPU time over engine.run less the compile time. Both
give beta P sigma^3 from their collision virials, beside KLM's (a check that both
simulate the same fluid). With ``--count`` the C code is also built with counters
(pair tests, list rebuilds, stale events per collision; Cell: pair tests, cell crossings,
events processed and events queued; not timed) to compare the work per collision with
gaz's. With another variant, search or ``--walled`` the last pair's gaz runs also print
their work per collision (queue events, crossings, pair tests; wall bounces).

Figures (2026-11-23, 2 cores shared, load 4.4, ``--pairs 6 --baseline`` a git archive of
e7fa32c, CPU time): gaz/C per pair 1.305 1.274 1.243 1.211 1.218 1.199, median **1.231**
(wall 1.249); e7fa32c/C 1.048 1.019 1.043 1.008 1.008 1.049, median 1.031; gaz/e7fa32c
1.205. Both codes give beta P sigma^3 8.07-8.09 (KLM 8.08). What changed: the calendar's
operations (``_sift_up``, ``_heap_push``, ``_heap_remove``, ``_q_insert``, ``_q_remove``,
``_next_bucket``) inlined into the loop at Numba-IR level (``_inline``) instead of called
(``_helper``): each call passed borrowed arrays through NRT incref/decref calls (no-ops,
but calls: 1.8 % of the process) and LLVM left them as calls. A perf profile of e7fa32c
(cpu-clock, the loop's machine code dumped from memory and annotated) had the list scan
~30 % of the loop's samples, the rebuilds' gather ~15 %, the calendar's helpers ~15 %;
after, no call is left in the hot path (scan ~32 %, gather ~20 %). Per step, alternating
child processes: inlining the queue's operations 1.114x (6 pairs, load 5.6), then
``_next_bucket`` 1.057x (6 pairs, load 7-9). Not kept: unsigned indices in the list scan and
gather 1.005x; EVENTS_PER_BUCKET 16, 1.001x and 1.016x; MAX_BUCKETS 4096 (64 KB of bucket
heads to 32 KB) 1.045x at N = 10^4, unmeasured at 10^5-10^6; no prefetch at 10^4, 1.026x.

Until 2026-11-23 ``--baseline`` timed this checkout twice: ``python -c`` puts the working
directory ahead of PYTHONPATH, so the baseline's worker imported the current tree. Earlier
gaz/baseline figures (and the "inlined calendar: 1.004x" once written here) measured nothing;
each worker now runs in its own tree. Earlier gaz/C figures stand (2026-11-23, load 13-15,
7 pairs: median 1.059; 0.84-0.97 in later runs that day). The work per collision is the C
code's (``--count``: pair tests 30.52 against 30.54, list rebuilds 0.206 against 0.217, stale
0.348 against 0.349, queue events 1.554 against 1.556). gaz's skin (scene.extras 'skin', in
diameters; in-process runs taken in turn, CPU): 0.15 and 0.2 run 0.78x and 0.85x of 0.25, 0.3
1.07x and 1.00x, 0.35 0.95x, 0.4 0.89x, so NEIGHBOUR_SKIN stays 0.25, the C code's shell.

Figures on a dilute gas (issue 15 item 2: is scene (b)'s 3x beyond the state of the art?;
2026-11-23, 2 cores shared, load 2.6-3.1 from ``uptime``, N = 10^4, 12 collisions per
particle, start melted over 3, collisions per second, CPU time). Packing 0.01, ``--variant
Cell --gaz-search auto --walled --pairs 3``: C 311,350 309,884 282,615; gaz (cells, 28 an
axis) 290,887 317,702 277,005; gaz/C 0.934 1.025 0.980, median **0.980** (wall 0.993); gaz
walled (wide cells, 9 an axis) 393,007 446,160 407,636, walled/C median 1.440 (wall 1.465).
Again with ``--pairs 6``: gaz/C median 1.002 (wall 1.008), walled/C 1.302 (wall 1.310; per
pair 1.311 1.229 1.317 1.308 1.230 1.295). Work per collision (``--count``): C 17.11 cell
crossings, 18.11 events processed, 20.58 queued, 32.4 pair tests; gaz periodic 11.93
crossings, 13.08 queue events, 80.3 pair tests; gaz walled 3.41 crossings, 5.24 queue
events, 2.9 pair tests and 0.446 wall bounces. beta P sigma^3: C 0.019881, gaz 0.019882
(KLM 0.019882). The C code's own tuning is its best here (the binary alone, same run from a
grid, user CPU, 2 runs each): its queue (maxscheduletime 1, 10, 50 tau,
eventlisttimemultiplier 1, 10, 100; 6600 events in its overflow list at 1 tau) 0.34-0.41 s
against 0.36-0.37 s as published; its cells (at most 8N, so 40 an axis, 2 sigma) against
at most 1, 2, 4, 16, 64 N (64: 75 an axis, its MAXCEL): 0.55, 0.46, 0.39, 0.38, 0.46 s
against 0.36-0.38 s.
``--variant Single`` (neighbour lists, 91.4 rebuilds per collision) runs 51,336-54,317 a CPU
second, gaz (auto) 5.71x that (walled 7.67x); gaz with lists (``--gaz-search lists``, the
same work: 19.56 pair tests, 91.3 rebuilds per collision) 0.314x the C code (17,431-17,755
a CPU second). Packing 0.05, ``--variant Cell``, 20 collisions per particle, start melted
over 5: C 737,381 680,031 750,996; gaz (cells, 28 an axis) 627,986 566,456 605,024, gaz/C
0.852 0.833 0.806, median **0.833** (wall 0.834); gaz walled (cells: wide cells only below
0.05) median 0.890 of C; work per collision C 5.57 crossings, 13.0 pair tests, gaz 3.68
crossings, 45.8 pair tests. gaz with the C code's finer cells (sizing.CELLS_PER_PARTICLE
set in one process to 4 and 8 against 2; 4 alternating rounds, load 1.3-1.9): packing 0.01,
35 and 44 an axis, 0.932x and 0.826x (pair tests 49 and 31 per collision, crossings 15.0
and 18.8); packing 0.05, 1.028x and 0.958x: a crossing costs gaz more than a pair test, its
2N cells stand. So on the dilute gas the best C code (Cell) and gaz's periodic cells run at
the same rate, and gaz with walls (wide cells, scene (b)'s search) 1.3-1.4x it.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.engines.event import sizing
from gaz_cli.model.recording import Recorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species
from gaz_cli.theory import contact_value, z_klm

C_SHELL = 1.5
"""The C code's ``shellsize`` (1 + alpha): lists hold pairs within C_SHELL (R_i + R_j)."""

PARAMS = {
    # global of mdSingle.c -> its new definition ({} filled by format)
    r"double maxtime = [^;]*;": "double maxtime = {maxtime!r};",
    r"int makesnapshots = [^;]*;": "int makesnapshots = 0;",
    r"double writeinterval = [^;]*;": "double writeinterval = {write!r};",
    r"double snapshotinterval = [^;]*;": "double snapshotinterval = {write!r};",
    r"int initialconfig = [^;]*;": "int initialconfig = 0;",
    r"const int usethermostat = [^;]*;": "const int usethermostat = 0;",
    r"const double shellsize = [^;]*;": "const double shellsize = {shell!r};",
}

VARIANTS = {
    # --variant -> (directory of the EDMD repository, its three files, PARAMS' keys it has)
    "Single": ("Single", ("mdSingle.c", "mdSingle.h", "mt19937ar.c"), tuple(PARAMS)),
    # cell lists with crossing events, every predicted collision queued: no list shell
    "Cell": ("Cell", ("mdCell.c", "mdCell.h", "mt19937ar.c"),
             tuple(k for k in PARAMS if "shellsize" not in k)),
}

COUNTERS = [
    # (after this line of mdSingle.c, insert) -- work counters for --count
    (r"unsigned int colcounter = 0;[^\n]*\n",
     "long long cnt_pairs = 0, cnt_rebuilds = 0, cnt_stale = 0, cnt_events = 0;\n"),
    (r"int findcollision\(particle\* p1, particle\* p2, double\* tmin\)\n\{\n", "    cnt_pairs++;\n"),
    (r"void makeneighborlist\(particle\* p1\)\n\{\n", "    cnt_rebuilds++;\n"),
    (r"    if \(p1->counter2 != p2->counter\)\n    \{\n", "        cnt_stale++;\n"),
    (r"    removeevent\(ev\);\n", "    cnt_events++;\n"),
    (r"    printstuff\(\);\n",
     '    printf("COUNTS pairs %lld rebuilds %lld stale %lld events %lld\\n", cnt_pairs, '
     "cnt_rebuilds, cnt_stale, cnt_events);\n"),
]


COUNTERS_CELL = [
    # the same for mdCell.c (no lists, no stale events: a collision deletes its pair's events)
    (r"unsigned int colcounter = 0;[^\n]*\n",
     "long long cnt_pairs = 0, cnt_cross = 0, cnt_events = 0, cnt_created = 0;\n"),
    (r"void findcollision\(particle\* p1, particle\* p2\)\n\{\n", "    cnt_pairs++;\n"),
    (r"    simtime = ev->eventtime;\n", "    cnt_events++;\n"),
    (r"        default:\n", "            cnt_cross++;\n"),
    (r"void createevent\(double time, particle\* p1, particle\* p2, int type\)\n\{\n",
     "    cnt_created++;\n"),
    (r"    printstuff\(\);\n",
     '    printf("COUNTS pairs %lld crossings %lld events %lld created %lld\\n", cnt_pairs, '
     "cnt_cross, cnt_events, cnt_created);\n"),
]


def single_source(edmd: Path, variant: str = "Single") -> tuple[str, str, str]:
    """The variant's three files (Single: mdSingle.c, mdSingle.h and mt19937ar.c) from a work
    tree or a bare git directory."""
    sub, names, _ = VARIANTS[variant]
    if (edmd / sub / names[0]).is_file():
        return tuple((edmd / sub / f).read_text() for f in names)
    if (edmd / "repo" / "HEAD").is_file():  # a mirror's directory holding the bare repo
        edmd = edmd / "repo"
    try:
        return tuple(subprocess.run(["git", "--git-dir", str(edmd), "show", f"HEAD:{sub}/{f}"],
                                    check=True, capture_output=True, text=True).stdout
                     for f in names)
    except (OSError, subprocess.CalledProcessError) as exc:
        sys.exit(f"smallenburg.py: no {sub}/{names[0]} in {edmd} ({exc}); give --edmd a copy "
                 "of github.com/FSmallenburg/EDMD")


def patch_params(src: str, name: str, patterns: tuple, maxtime: float, write: float) -> str:
    """``src`` (the C file ``name``) with the run's parameters written into the globals
    matched by ``patterns`` (keys of PARAMS); exits in one line if one is not there once."""
    for pat in patterns:
        src, k = re.subn(pat, PARAMS[pat].format(maxtime=maxtime, write=write, shell=C_SHELL),
                         src)
        if k != 1:
            sys.exit(f"smallenburg.py: {name} has no line matching {pat!r} (another "
                     "version of the C code?)")
    return src


def build(edmd: Path, where: Path, maxtime: float, write: float, cc: str, cflags: str,
          count: bool, variant: str = "Single") -> Path:
    """The patched C code built in ``where``; returns the binary."""
    _, names, patterns = VARIANTS[variant]
    src, hdr, rng = single_source(edmd, variant)
    src = patch_params(src, names[0], patterns, maxtime, write)
    if count:
        for pat, add in COUNTERS if variant == "Single" else COUNTERS_CELL:
            src, k = re.subn(pat, lambda m, add=add: m.group(0) + add, src)
            if k != 1:
                sys.exit(f"smallenburg.py: cannot place a counter after {pat!r}")
    for name, text in zip(names, (src, hdr, rng)):
        (where / name).write_text(text)
    binary = where / "md"
    cmd = [cc, *cflags.split(), names[0], "-o", "md", "-lm"]
    res = subprocess.run(cmd, cwd=where, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit(f"smallenburg.py: {' '.join(cmd)} failed:\n{res.stderr}")
    return binary


def write_sph(path: Path, x: np.ndarray, length: float, radius: float) -> None:
    """Positions (N, 3) in the C code's .sph format (type, x, y, z, radius)."""
    with open(path, "w") as f:
        f.write(f"{len(x)}\n{length:.17g} {length:.17g} {length:.17g}\n")
        for p in x:
            f.write(f"a {p[0]:.17g} {p[1]:.17g} {p[2]:.17g} {radius:.17g}\n")


def run_c(binary: Path, where: Path) -> dict:
    """One run of the C code in ``where`` (holding init.sph): its wall and CPU time, collisions,
    pressure (and the counters if built with them)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run([str(binary)], cwd=where, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        sys.exit(f"smallenburg.py: the C code failed ({res.returncode}):\n{res.stdout[-2000:]}")
    cols = [int(c) for c in re.findall(r"Collisions: (\d+)", res.stdout)]
    press = re.search(r"Measured pressure\s*: \S+ \+ \S+ = (\S+)", res.stdout)
    out = {"wall": wall, "cpu": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
           "collisions": cols[-1], "beta_p": float(press.group(1))}
    counts = re.search(r"COUNTS pairs (\d+) rebuilds (\d+) stale (\d+) events (\d+)", res.stdout)
    if counts:
        out.update(zip(("pairs", "rebuilds", "stale", "events"), map(int, counts.groups())))
    counts = re.search(r"COUNTS pairs (\d+) crossings (\d+) events (\d+) created (\d+)",
                       res.stdout)
    if counts:
        out.update(zip(("pairs", "crossings", "events", "created"), map(int, counts.groups())))
    return out


_WORKER = """
import dataclasses, json, sys, time
import numpy as np
from gaz_cli.engines import event as engine
from gaz_cli.model.recording import Recorder, State
from gaz_cli.model.scene import Scene
from gaz_cli.constants import K_B
from gaz_cli.model.species import Species
a = np.load(sys.argv[1])
n, length, duration = int(a["n"]), float(a["length"]), float(a["duration"])
search, boundary = (sys.argv[3], sys.argv[4]) if len(sys.argv) > 4 else ("lists", "periodic")
scene = Scene(dim=3, length=length, duration=duration,
              components=((Species("X", 1.0, 0.5), n),), temperature=1.0 / K_B,
              boundary=boundary, record="none", extras={"neighbours": search})
state = State(a["x"], a["v"], np.zeros(n, dtype=np.int64))
# a short run first: compiled kernels loaded, memory touched (as in a long-lived process)
engine.run(dataclasses.replace(scene, duration=duration * 1e-3), state, Recorder())
if sys.argv[2] == "warm":
    sys.exit(0)
c0 = time.process_time()
rs = engine.run(scene, state, Recorder())
cpu = time.process_time() - c0 - rs.extras["compile_s"]
m = scene.masses()
kT = float(np.sum(m * np.sum(rs.final.velocities ** 2, 1))) / (3 * (n - 1))
beta_p = n / length ** 3 + rs.virial / (3.0 * length ** 3 * duration) / kT
ex = rs.extras
path = ("lists" if ex["neighbour_lists"] else "dilute" if ex.get("dilute_scan") else
        "wide" if ex.get("wide_cells") else "cells")
print(json.dumps({"wall": rs.wall_time_s, "cpu": cpu, "collisions": rs.collisions,
                  "beta_p": beta_p if boundary == "periodic" else float("nan"),
                  "pairs": ex["pair_tests"], "rebuilds": ex["list_rebuilds"],
                  "stale": ex["stale_predictions"], "events": ex["queue_events"],
                  "lists": ex["neighbour_lists"], "crossings": ex["cell_crossings"],
                  "bounces": rs.wall_bounces, "search": f"{path}, {ex['cells_per_axis']} an axis"}))
"""
"""A gaz run in its own process, gaz_cli imported from the tree given (PYTHONPATH): the
state from an .npz, the search ('auto', 'cells', 'lists') and the boundary from argv
(default lists, periodic), the figures as JSON on stdout. A walled run's beta_p is NaN (its
virial misses the walls')."""


def run_gaz(tree: Path, state_file: Path, what: str = "run", search: str = "lists",
            boundary: str = "periodic") -> dict:
    """One run of gaz from ``tree`` (a checkout of this repository) in a child process: wall
    (RunStats.wall_time_s), CPU (the child's, over engine.run less the compile), collisions,
    pressure and its work counters."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    # cwd=tree: ``python -c`` puts the working directory before PYTHONPATH on sys.path, so
    # run from another checkout's root every tree ran that checkout's gaz_cli
    res = subprocess.run([sys.executable, "-c", _WORKER, str(state_file), what, search,
                          boundary], env=env, cwd=tree, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit(f"smallenburg.py: gaz from {tree} failed:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.splitlines()[-1]) if what == "run" else {}


SEARCHES = ("auto", "cells", "lists")
"""gaz's searches --gaz-search may force (scene.extras['neighbours'])."""


def check_args(variant: str, search: str) -> str | None:
    """The one-line complaint about --variant or --gaz-search, or None if both are known."""
    if variant not in VARIANTS:
        return f"--variant {variant!r} is not one of {', '.join(VARIANTS)}"
    if search not in SEARCHES:
        return f"--gaz-search {search!r} is not one of {', '.join(SEARCHES)}"
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--edmd", type=Path, required=True,
                    help="copy of github.com/FSmallenburg/EDMD (work tree or bare git dir)")
    ap.add_argument("--variant", default="Single",
                    help="the C code: Single (neighbour lists, the default) or Cell (cell lists "
                         "with crossing events)")
    ap.add_argument("--gaz-search", default="lists",
                    help="gaz's search on the periodic box: lists (the default), cells or auto")
    ap.add_argument("--walled", action="store_true",
                    help="also time gaz in the same pairs on the same gas in a box with walls "
                         "(search 'auto'; its own start, melted the same way)")
    ap.add_argument("--n", type=int, default=10_000)
    ap.add_argument("--packing", type=float, default=0.45)
    ap.add_argument("--per-particle", type=float, default=100.0,
                    help="collisions per particle of each run (sets the simulated time)")
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--write", type=float, default=None,
                    help="C code's output interval, tau (default: a tenth of the run)")
    ap.add_argument("--cc", default="gcc")
    ap.add_argument("--cflags", default="-O3 -march=native")
    ap.add_argument("--count", action="store_true",
                    help="also run a C build with work counters once (not timed; Single: pair "
                         "tests, rebuilds, stale and queue events; Cell: pair tests, crossings, "
                         "events processed and queued)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--baseline", type=Path, default=None,
                    help="another checkout of gaz (e.g. git archive of an older commit) run "
                         "in the same pairs: before and after side by side")
    ap.add_argument("--equilibrate", type=float, default=30.0,
                    help="collisions per particle run by gaz from the lattice before the pairs")
    args = ap.parse_args()
    bad = check_args(args.variant, args.gaz_search)
    if bad:
        sys.exit(f"smallenburg.py: {bad}")

    n, eta = args.n, args.packing
    sigma = 1.0
    length = (n * math.pi / 6.0 * sigma ** 3 / eta) ** (1.0 / 3.0)
    rho = n / length ** 3
    # Enskog collision rate per particle: 4 sqrt(pi) rho sigma^2 g(sigma) sqrt(kT/m)
    rate = 4.0 * math.sqrt(math.pi) * rho * sigma ** 2 * float(contact_value(3, eta))
    # a collision involves two particles: N rate t / 2 collisions in a run of t
    duration = 2.0 * args.per_particle / rate
    write = args.write if args.write else duration / 10.0
    scene = Scene(dim=3, length=length, duration=duration,
                  components=((Species("X", 1.0, 0.5 * sigma), n),), temperature=1.0 / K_B,
                  seed=args.seed, boundary="periodic", placement="lattice", record="none",
                  extras={"neighbours": args.gaz_search})
    # equilibrate from the lattice (which melts, its pressure low at first) with gaz; both
    # codes start from the melted fluid's positions (and gaz from its velocities)
    eq = engine.run(dataclasses.replace(scene, duration=args.equilibrate / rate * 2.0),
                    initial_state(scene), Recorder())
    state = eq.final
    if args.variant == "Single":
        search = (f"neighbour lists: C shellsize {C_SHELL} (R_i + R_j), gaz skin h = "
                  f"{sizing.NEIGHBOUR_SKIN} sigma (reach sigma + 2h = "
                  f"{sigma + 2 * sizing.NEIGHBOUR_SKIN * sigma:g} sigma)")
    else:
        search = "C: cell lists with crossing events (its Cell/ variant)"
    if args.gaz_search != "lists":
        search += f"; gaz: search {args.gaz_search!r}"
    print(f"scene: 3D periodic, N = {n:,}, packing {eta}, L = {length:.4f} sigma, sigma = m = "
          f"k_B T = 1, simulated time {duration:.4g} tau (~{args.per_particle:g} collisions per "
          f"particle), lattice start melted by gaz over ~{args.equilibrate:g} collisions per "
          f"particle; {search}")
    print(f"machine: {os.cpu_count()} cores (os.cpu_count), load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}; C: {args.cc} {args.cflags}", flush=True)

    here = Path(__file__).resolve().parent.parent
    trees = {"gaz": here}
    if args.baseline is not None:
        trees["gaz-base"] = args.baseline.resolve()
    print("gaz trees: " + ", ".join(f"{k} = {v}" for k, v in trees.items()))
    with tempfile.TemporaryDirectory(prefix="edmd-") as tmp:
        where = Path(tmp)
        binary = build(args.edmd, where, duration, write, args.cc, args.cflags, False,
                       args.variant)
        write_sph(where / "init.sph", np.asarray(state.positions), length, 0.5 * sigma)
        state_file = where / "state.npz"
        np.savez(state_file, x=np.asarray(state.positions), v=np.asarray(state.velocities), n=n,
                 length=length, duration=duration)
        # each gaz run: name -> (tree, state file, search, boundary)
        runs = {name: (tree, state_file, args.gaz_search, "periodic")
                for name, tree in trees.items()}
        if args.walled:
            # the same gas in a box with walls, melted the same way from gaz's own start
            walled = dataclasses.replace(scene, boundary="walls", placement="auto",
                                         extras={"neighbours": "auto"})
            weq = engine.run(dataclasses.replace(walled, duration=args.equilibrate / rate * 2.0),
                             initial_state(walled), Recorder())
            walls_file = where / "state-walls.npz"
            np.savez(walls_file, x=np.asarray(weq.final.positions),
                     v=np.asarray(weq.final.velocities), n=n, length=length, duration=duration)
            runs["gaz-walls"] = (here, walls_file, "auto", "walls")
        for tree, sfile, srch, bnd in runs.values():  # compile (or load) kernels before timing
            run_gaz(tree, sfile, "warm", srch, bnd)
        if args.count:
            cdir = where / "count"
            cdir.mkdir()
            cbin = build(args.edmd, cdir, duration, write, args.cc, args.cflags, True,
                         args.variant)
            shutil.copy(where / "init.sph", cdir / "init.sph")
            counted = {"C": run_c(cbin, cdir)}
            counted.update({name: run_gaz(t, f, "run", sr, b)
                            for name, (t, f, sr, b) in runs.items()})
            print("work per collision (C built with counters, untimed; gaz's RunStats):")
            for name, r in counted.items():
                col = r["collisions"]
                if "created" in r:  # the Cell variant: no lists, no stale events
                    print(f"  {name:>8}: {col:,} collisions; per collision: pair tests "
                          f"{r['pairs'] / col:.2f}, cell crossings {r['crossings'] / col:.3f}, "
                          f"events processed {r['events'] / col:.3f}, events queued "
                          f"{r['created'] / col:.3f}")
                    continue
                print(f"  {name:>8}: {col:,} collisions; per collision: pair tests "
                      f"{r['pairs'] / col:.2f}, list rebuilds {r['rebuilds'] / col:.3f}, stale "
                      f"{r['stale'] / col:.3f}, queue events {r['events'] / col:.3f}"
                      + (f", cell crossings {r['crossings'] / col:.3f}"
                         if args.variant != "Single" else ""))
        names = ["C", *runs]
        ratios = {name: ([], []) for name in runs}
        fastest = {name: [0.0, 0.0] for name in names}
        head = "pair  order" + "".join(f"  {nm:>8} wall/s  {nm:>8} CPU/s" for nm in names)
        head += "".join(f"  {nm}/C wall  {nm}/C CPU" for nm in runs)
        print("collisions per second (wall, CPU) and ratios to C:")
        print(head + "  collisions  beta P sigma^3")
        for i in range(args.pairs):
            # each code first in turn; every other round of turns backwards
            order = names[i % len(names):] + names[:i % len(names)]
            if (i // len(names)) % 2:
                order = order[::-1]
            res = {}
            for who in order:
                res[who] = run_c(binary, where) if who == "C" else run_gaz(
                    runs[who][0], runs[who][1], "run", *runs[who][2:])
            rate_w = {nm: r["collisions"] / r["wall"] for nm, r in res.items()}
            rate_c = {nm: r["collisions"] / r["cpu"] for nm, r in res.items()}
            for nm in names:
                fastest[nm] = [max(fastest[nm][0], rate_w[nm]), max(fastest[nm][1], rate_c[nm])]
            line = f"{i + 1:>4}  {','.join(order):>5}"
            line += "".join(f"  {rate_w[nm]:>15,.0f}  {rate_c[nm]:>14,.0f}" for nm in names)
            for nm in runs:
                ratios[nm][0].append(rate_w[nm] / rate_w["C"])
                ratios[nm][1].append(rate_c[nm] / rate_c["C"])
                line += f"  {ratios[nm][0][-1]:>{len(nm) + 7}.3f}  {ratios[nm][1][-1]:>{len(nm) + 6}.3f}"
            line += "  " + " / ".join(f"{res[nm]['collisions']:,}" for nm in names)
            line += "  " + " / ".join(f"{res[nm]['beta_p']:.5g}" for nm in names)
            print(line, flush=True)
        for nm, (w, c) in ratios.items():
            print(f"{nm}/C median over {args.pairs} pairs: wall {np.median(w):.3f}, CPU "
                  f"{np.median(c):.3f}; fastest run against fastest run (a busy host only "
                  f"slows a run down): wall {fastest[nm][0] / fastest['C'][0]:.3f}, CPU "
                  f"{fastest[nm][1] / fastest['C'][1]:.3f}")
        if len(trees) > 1:
            w, c = (np.array(ratios["gaz"][i]) / np.array(ratios["gaz-base"][i]) for i in (0, 1))
            print(f"gaz/gaz-base median over the pairs: wall {np.median(w):.3f}, CPU "
                  f"{np.median(c):.3f}; fastest against fastest: wall "
                  f"{fastest['gaz'][0] / fastest['gaz-base'][0]:.3f}, CPU "
                  f"{fastest['gaz'][1] / fastest['gaz-base'][1]:.3f}")
        if args.variant != "Single" or args.gaz_search != "lists" or args.walled:
            print("work of the last pair's gaz runs, per collision:")
            for nm in runs:
                r = res[nm]
                col = r["collisions"]
                print(f"  {nm:>9} ({r['search']}): queue events {r['events'] / col:.3f}, "
                      f"cell crossings {r['crossings'] / col:.3f}, list rebuilds "
                      f"{r['rebuilds'] / col:.3f}, stale {r['stale'] / col:.3f}, pair tests "
                      f"{r['pairs'] / col:.2f}; wall bounces {r['bounces']:,} "
                      f"({r['bounces'] / col:.3f} a collision)")
        print(f"KLM beta P sigma^3 = {rho * float(z_klm(eta)):.5g}; gaz used neighbour lists: "
              f"{res['gaz']['lists']}")

if __name__ == "__main__":
    main()
