"""Start-up of a tiny run (issue 15 item 4): process start to exit, against `import numpy, numba`.

Not a test: it prints medians. Alternating runs of
  (base)  python -c "import numpy, numba"
  (nodb)  gaz simulate --dim 3 --n 100 --length 1e-8 --duration 1e-12 --seed 1 --no-db
  (db)    the same into a new SQLite file
after one warm-up run (Numba's cache filled). Wall and CPU (user + sys of the child).

    python benchmarks/startup.py [ROUNDS]      # default 7
"""
import os, subprocess, sys, time, statistics, resource, tempfile
py = sys.executable
base = [py, "-c", "import numpy, numba"]
sim = [py, "-m", "gaz_cli", "simulate", "--dim", "3", "--n", "100", "--length", "1e-8", "--duration", "1e-12", "--seed", "1"]
def cpu_of(cmd):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN); t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    w = time.perf_counter() - t; r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return w, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
subprocess.run(sim + ["--no-db"], check=True, capture_output=True)  # warm the cache
res = {"base": [], "nodb": [], "db": []}
for k in range(int(sys.argv[1]) if len(sys.argv) > 1 else 7):
    res["base"].append(cpu_of(base))
    res["nodb"].append(cpu_of(sim + ["--no-db"]))
    d = tempfile.mkdtemp()
    res["db"].append(cpu_of(sim + ["--db", os.path.join(d, "x.db")]))
for key in res:
    w = statistics.median(x[0] for x in res[key]); c = statistics.median(x[1] for x in res[key])
    print(f"{key:5s} wall {w:.3f} s  cpu {c:.3f} s")
bw = statistics.median(x[0] for x in res["base"]); bc = statistics.median(x[1] for x in res["base"])
for key in ("nodb", "db"):
    print(key, "ratio wall", round(statistics.median(x[0] for x in res[key]) / bw, 2), "cpu", round(statistics.median(x[1] for x in res[key]) / bc, 2))
