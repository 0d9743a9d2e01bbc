"""Coverage of gaz analyse's error bars: the fraction of seeds within 1 and 2 sigma, per scene class.

For each scene class, runs SEEDS seeds (event engine, one process), analyses
each simulation, and prints, per quantity (mean pressure, each wall's
pressure pooled over the walls, mean wall-hit speed), the fraction of
|z| < 1 and |z| < 2 with z = (measured - reference)/error. The reference is
analyse's own theory ('theory') and the mean over the seeds ('seed mean',
z scaled by sqrt(n/(n - 1)) for the mean's own noise). A correct error bar
gives 0.683 and 0.954; binomial_1 is the binomial error of the fraction
within 1 sigma, sqrt(p (1 - p)/samples) (the pooled walls' samples are not
independent: opposite walls share an axis).

    python benchmarks/error_coverage.py                      # the test's four classes, 60 seeds each
    python benchmarks/error_coverage.py --class exam --seeds 30
    python benchmarks/error_coverage.py --class all --seeds 200
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))

from coverage_scenes import CLASSES, coverage_table, run_class  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--class", dest="klass", default="test",
                    help="a class name, 'test' (the test's four) or 'all'")
    ap.add_argument("--seeds", type=int, default=60)
    ap.add_argument("--first-seed", type=int, default=1)
    args = ap.parse_args()
    names = {"test": [k for k, v in CLASSES.items() if v.in_test], "all": list(CLASSES)}.get(args.klass, [args.klass])
    print(f"# {os.cpu_count()} cores; seeds {args.first_seed}..{args.first_seed + args.seeds - 1}")
    for name in names:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            z = run_class(name, range(args.first_seed, args.first_seed + args.seeds), os.path.join(tmp, "c.db"))
            took = time.perf_counter() - t0
        print(f"\n== {name}: {CLASSES[name].description} ({took:.0f} s) ==")
        print(coverage_table(z).to_string(index=False, float_format="{:.3f}".format))


if __name__ == "__main__":
    main()
