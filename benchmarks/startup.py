"""Start-up of a tiny run (issue 15 item 4): process start to exit, against `import numpy, numba`.

Not a test: it prints medians. Alternating runs of
  (base)  python -c "import numpy, numba"
  (nodb)  gaz simulate --dim 3 --n 100 --length 1e-8 --duration 1e-12 --seed 1 --no-db
  (db)    the same into a new SQLite file
after one warm-up run of each (Numba's cache filled, Python's bytecode written). Wall and
CPU (user + sys of the child; what a host shared with other work disturbs least); ratios
as the median of each round's ratio (and the ratio of the medians).

The children run with Python's default bytecode cache: PYTHONDONTWRITEBYTECODE is removed
from their environment (set, every run would compile gaz's ~40 modules from source again,
~0.15 s of CPU, which no installed gaz pays). ``--against DIR``: also time the same
commands with gaz taken from DIR (PYTHONPATH=DIR, e.g. an older commit's tree from
``git archive``), alternating with this one, and print new / old.

    python benchmarks/startup.py [--rounds 7] [--against /tmp/old]

The children run in an empty folder with PYTHONPATH set to the tree timed: run from a
checkout, ``python -m gaz_cli`` used to import the checkout whatever PYTHONPATH said, so
every "old" figure before 2026-11-23 timed the new tree twice.

2026-11-23, 2 cores at load 2 (a helper's benchmarks beside it), 7 rounds, against
8b6e7d9: the tiny run imports no Numba any more (placement's compiled methods are imported
at their first use): nodb / base 0.51 wall, 0.51 CPU; db / base 0.57 / 0.56; the old tree
1.09 / 1.03 and 1.17 / 1.01; new / old 0.47 and 0.54 wall.
"""
import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PY = sys.executable
HERE = Path(__file__).resolve().parents[1]
"""This checkout: the gaz timed (the one installed may be another)."""
NEUTRAL = tempfile.mkdtemp(prefix="gaz-startup-")
"""The children's working folder: no gaz_cli in it."""
BASE = [PY, "-c", "import numpy, numba"]
SIM = [PY, "-m", "gaz_cli", "simulate", "--dim", "3", "--n", "100", "--length", "1e-8", "--duration", "1e-12",
       "--seed", "1"]


def timed(cmd, env):
    """(wall s, CPU s) of one child process."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=env, cwd=NEUTRAL)
    w = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return w, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("rounds_pos", nargs="?", type=int, help=argparse.SUPPRESS)  # the old form: startup.py 7
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--against", metavar="DIR", help="also time gaz from DIR (PYTHONPATH), alternating")
    args = ap.parse_args()
    rounds = args.rounds_pos or args.rounds
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}

    def taking(tree):
        # gaz from ``tree`` first; the children run in an empty folder, since ``python -m``
        # puts its working folder first on sys.path (from a checkout, every tree was the checkout)
        return {**env, "PYTHONPATH": os.pathsep.join([str(tree), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)}

    trees = {"": taking(HERE)}
    if args.against:
        trees["old "] = taking(Path(args.against).resolve())
    series = {"base": (BASE, env)}
    for tag, e in trees.items():
        series[tag + "nodb"] = (SIM + ["--no-db"], e)
        series[tag + "db"] = (SIM + ["--db", "NEW"], e)

    def run(key):
        cmd, e = series[key]
        if "NEW" in cmd:
            cmd = [os.path.join(tempfile.mkdtemp(), "x.db") if c == "NEW" else c for c in cmd]
        return timed(cmd, e)

    for key in series:  # warm-up: Numba's cache, the bytecode
        run(key)
    print(f"gaz start-up: tiny scene (3D, N = 100, T = 1e-12 s); {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.2f}; {rounds} alternating rounds; medians")
    res = {key: [] for key in series}
    for _ in range(rounds):
        for key in series:
            res[key].append(run(key))
    med = {key: (statistics.median(x[0] for x in v), statistics.median(x[1] for x in v)) for key, v in res.items()}
    for key, (w, c) in med.items():
        print(f"{key:8s} wall {w:.3f} s  cpu {c:.3f} s")
    def ratio(a, b, i):
        """Median over the rounds of a / b within each round (runs a few seconds apart: a
        shared host's drift cancels), and the ratio of the medians."""
        per = statistics.median(x[i] / y[i] for x, y in zip(res[a], res[b]))
        return f"{per:.2f} (ratio of medians {med[a][i] / med[b][i]:.2f})"

    for key in series:
        if key != "base":
            print(f"{key:8s} / base: wall {ratio(key, 'base', 0)}  cpu {ratio(key, 'base', 1)}")
    if args.against:
        for key in ("nodb", "db"):
            print(f"{key:8s} new / old: wall {ratio(key, 'old ' + key, 0)}  cpu {ratio(key, 'old ' + key, 1)}")


if __name__ == "__main__":
    main()
