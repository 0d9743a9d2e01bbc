"""Run time against error: the exact event engine and the time-stepped engine.

Scene: 2D, N = 500 argon disks at 300 K, area fraction 0.2, hard elastic
walls; the same initial states (seeds) for every engine. Time unit: the
Enskog mean free time tau = 1/omega (about 1.1 ps here).

For each seed the exact engine (``gaz_cli.engines.event.run``) gives the reference;
the step engine (``gaz_cli.engines.step.run``) runs at dt = 1 ... 0.001 tau with
both contact detections ('swept', the default, and 'overlap', seed 002's
rule). Per run: wall-clock time; wall pressure (from the bounces) against the
exact run of the same initial state; kinetic energy error; collisions counted
against the exact run; and, per pair over the first mean free time (before
the trajectories have drifted apart), the fraction of the exact collisions the
step engine missed and of its collisions the exact engine does not have
(spurious or doubled), matched on the pair within max(dt, 0.01 tau).

The exact engine's own error is statistical: its curve is the spread of the
pressure over seeds against the run time, for durations T/16 ... 4 T.

The same scene with friction (10 tau, gamma = 1/(10 tau)): only the step
engine applies; its pressure is compared with the finest dt (0.001 tau) from
the same initial state, and its kinetic energy with the exact decay
E0 exp(-2 gamma T) (collisions and walls are elastic).

Writes docs/explanation/run_time_vs_error.png and docs/explanation/run_time_vs_error.md.

    python benchmarks/run_time_vs_error.py            # about 3 minutes on 2 cores
    python benchmarks/run_time_vs_error.py --quick --out /tmp/rt   # about 15 s
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from gaz_cli.engines import step as stepper
from gaz_cli.constants import K_B
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.model.scene import Scene
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import lookup

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "explanation"


def exact_engine():
    """gaz_cli.engines.event.run, or the reference engine as a stand-in (said in the output)."""
    try:
        from gaz_cli.engines.event import run

        return run, "gaz_cli.engines.event.run"
    except ImportError:  # pragma: no cover - development stand-in
        from gaz_cli.engines.reference import run

        return run, "gaz_cli.engines.reference.run (stand-in)"


def base_scene(n: int = 500, eta: float = 0.2, seed: int = 1) -> tuple[Scene, float]:
    """The benchmark scene and its Enskog mean free time tau (s)."""
    ar = lookup("Ar")
    length = math.sqrt(n * math.pi * ar.radius ** 2 / eta)
    sigma = 2 * ar.radius
    density = n / length ** 2
    g = (1 - 7 * eta / 16) / (1 - eta) ** 2  # Henderson contact value, physics.md section 2
    omega = 2 * density * sigma * g * math.sqrt(math.pi * K_B * 300.0 / ar.mass)
    scene = Scene(dim=2, length=length, duration=1.0, components=((ar, n),), temperature=300.0,
                  seed=seed, boundary="walls", record="all")
    return scene, 1.0 / omega


def pressure(scene: Scene, bounces: dict) -> float:
    """Mean pressure on the 2D walls, N/m: sum 2 m |v_perp| / (duration * 2D L^(D-1))."""
    m = scene.masses()[bounces["particle"]]
    area = 2 * scene.dim * scene.length ** (scene.dim - 1)
    return float(np.sum(2 * m * bounces["vperp"]) / (scene.duration * area))


def one_run(run, scene, state):
    rec = MemoryRecorder(collisions=True)
    t0 = time.perf_counter()
    stats = run(scene, state, rec)
    elapsed = time.perf_counter() - t0
    m = scene.masses()
    e0, e1 = state.kinetic_energy(m), stats.final.kinetic_energy(m)
    p = pressure(scene, rec.bounces())
    return {
        "time": stats.wall_time_s if stats.wall_time_s > 0 else elapsed,
        "pressure": p,
        # P V / E: the pressure freed of the seed-to-seed spread of the initial kinetic energy
        # (about sqrt(2 / (D N)) = 4.5 %; hard disks: P is proportional to E at fixed density)
        "z": p * scene.length ** scene.dim / e0,
        "energy0": e0,
        "energy1": e1,
        "collisions": stats.collisions,
        "coll": rec.collisions(),
        "extras": stats.extras,
    }


def match_collisions(exact: dict, step: dict, t_max: float, tol: float) -> tuple[float, float, int]:
    """(missed, spurious, count): fractions of collisions in [0, t_max] without a partner in the other run.

    A collision matches one of the same pair (i, j) whose time is within tol;
    each collision is used once.
    """
    def pairs(c):
        keep = c["t"] <= t_max
        i, j = np.minimum(c["i"][keep], c["j"][keep]), np.maximum(c["i"][keep], c["j"][keep])
        out: dict[tuple[int, int], list[float]] = {}
        for a, b, t in zip(i.tolist(), j.tolist(), c["t"][keep].tolist()):
            out.setdefault((a, b), []).append(t)
        return out, int(keep.sum())

    pe, ne = pairs(exact)
    ps, ns = pairs(step)
    matched = 0
    for key, times in pe.items():
        other = sorted(ps.get(key, []))
        used = [False] * len(other)
        for t in times:
            for k, u in enumerate(other):
                if not used[k] and abs(u - t) <= tol:
                    used[k] = True
                    matched += 1
                    break
    return 1 - matched / max(ne, 1), 1 - matched / max(ns, 1), ne


def median(values):
    return float(np.median(values))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer seeds, shorter runs, fewer dt (about 15 s)")
    parser.add_argument("--out", default=str(DOCS), help="folder for the figure and the table (default: docs/explanation/)")
    args = parser.parse_args(argv)
    out_dir = Path(args.out)
    exact_run, exact_name = exact_engine()
    if args.quick:
        seeds, span, fractions = [1, 2], 20.0, [1.0, 0.3, 0.1, 0.03, 0.01]
        exact_seeds = [1, 2, 3, 4, 5, 6]
    else:
        seeds, span, fractions = [1, 2, 3, 4, 5], 100.0, [1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005,
                                                           0.002, 0.001]
        exact_seeds = list(range(1, 17))
    scene0, tau = base_scene()
    duration = span * tau
    print(f"scene: 2D, N=500 Ar, eta=0.2, 300 K, L={scene0.length:.4g} m; tau={tau:.4g} s; "
          f"T={span:g} tau; seeds {seeds}; exact engine: {exact_name}", file=sys.stderr)
    states = {s: initial_state(replace(scene0, seed=s)) for s in set(seeds) | set(exact_seeds)}

    # warm-up (compile or load the numba caches) outside the timings
    warm = replace(scene0, duration=tau, seed=1)
    exact_run(warm, states[1], MemoryRecorder(collisions=True))
    stepper.run(replace(warm, engine="step", dt=0.1 * tau), states[1], MemoryRecorder(collisions=True))
    stepper.run(replace(warm, engine="step", dt=0.1 * tau, drag=1.0), states[1], MemoryRecorder())

    # --- exact engine: the paired references, a long-run reference pressure, and its own
    # (statistical) error against run time
    exact = {}
    for s in seeds:
        exact[s] = one_run(exact_run, replace(scene0, duration=duration, seed=s), states[s])
    long_p = [one_run(exact_run, replace(scene0, duration=8 * duration, seed=s), states[s])["z"]
              for s in exact_seeds]
    p_ref = float(np.mean(long_p))
    p_ref_se = float(np.std(long_p, ddof=1) / math.sqrt(len(long_p)))
    print(f"reference PV/E (exact engine, {len(exact_seeds)} runs of {8 * span:g} tau): "
          f"{p_ref:.5g} +- {p_ref_se / p_ref:.2%}", file=sys.stderr)
    scales = [1 / 16, 1 / 4, 1.0, 4.0] if not args.quick else [1 / 4, 1.0]
    curve = []
    for f in scales:
        runs = [one_run(exact_run, replace(scene0, duration=f * duration, seed=s), states[s]) for s in exact_seeds]
        err = np.array([r["z"] / p_ref - 1 for r in runs])
        curve.append((f, median([r["time"] for r in runs]), float(np.sqrt(np.mean(err ** 2)))))
    for f, t, err in curve:
        print(f"exact  T={f * span:7.3g} tau  time {t:8.4f} s  rms pressure error {err:.3%}", file=sys.stderr)

    # --- step engine, both detections, against the exact run of the same state
    rows = []
    for detection in stepper.DETECTIONS:
        for frac in fractions:
            dt = frac * tau
            res = []
            for s in seeds:
                sc = replace(scene0, duration=duration, seed=s, engine="step", dt=dt)
                rec_run = one_run(lambda a, b, c: stepper.run(a, b, c, detection=detection), sc, states[s])
                e = exact[s]
                missed, spurious, n_first = match_collisions(e["coll"], rec_run["coll"], tau,
                                                             max(dt, 0.01 * tau))
                res.append({
                    "time": rec_run["time"],
                    "dp": (rec_run["z"] - e["z"]) / e["z"],
                    "dref": rec_run["z"] / p_ref - 1,
                    "de": abs(rec_run["energy1"] - rec_run["energy0"]) / rec_run["energy0"],
                    "dc": rec_run["collisions"] / e["collisions"] - 1,
                    "missed": missed, "spurious": spurious,
                    "passes": rec_run["extras"]["passes"] / rec_run["extras"]["steps"],
                    "limit": rec_run["extras"]["pass_limit_hits"],
                    "phases": rec_run["extras"]["phase_times"],
                })
            dp = np.array([r["dp"] for r in res])
            row = {
                "detection": detection, "frac": frac, "dt": dt,
                "steps": int(round(duration / dt)),
                "time": median([r["time"] for r in res]),
                "dp_mean": float(dp.mean()),
                "dp_se": float(dp.std(ddof=1) / math.sqrt(dp.size)) if dp.size > 1 else float("nan"),
                "dp_rms": float(np.sqrt(np.mean(dp ** 2))),
                "ref_rms": float(np.sqrt(np.mean([r["dref"] ** 2 for r in res]))),
                "de": max(r["de"] for r in res),
                "dc": float(np.mean([r["dc"] for r in res])),
                "missed": float(np.mean([r["missed"] for r in res])),
                "spurious": float(np.mean([r["spurious"] for r in res])),
                "passes": float(np.mean([r["passes"] for r in res])),
                "limit": int(sum(r["limit"] for r in res)),
                "phases": {k: median([r["phases"][k] for r in res]) for k in res[0]["phases"]},
            }
            rows.append(row)
            print(f"step {detection:7s} dt={frac:6.3g} tau  time {row['time']:8.3f} s  dP {row['dp_mean']:+.3%}"
                  f" +- {row['dp_se']:.3%}  rms {row['dp_rms']:.3%}  dN/N {row['dc']:+.3%}  missed "
                  f"{row['missed']:.3%}  spurious {row['spurious']:.3%}  passes {row['passes']:.2f}",
                  file=sys.stderr)

    # --- friction: step engine only, against its finest dt. A short run (10 tau, gamma = 1/(10 tau))
    # keeps the runs at different dt on the same trajectory, so their difference is the dt error,
    # not the chaos of diverging trajectories.
    fric_span = 10.0
    fric_T = fric_span * tau
    gamma = 1.0 / fric_T
    fres = {}
    for frac in sorted(fractions):
        fres[frac] = [one_run(stepper.run, replace(scene0, duration=fric_T, seed=s, engine="step", dt=frac * tau,
                                                  drag=gamma), states[s]) for s in seeds]
    finest = min(fractions)
    fric = []
    for frac in fractions:
        out = fres[frac]
        dp = np.array([(r["pressure"] - f["pressure"]) / f["pressure"] for r, f in zip(out, fres[finest])])
        de = max(abs(r["energy1"] - r["energy0"] * math.exp(-2 * gamma * fric_T)) / r["energy1"] for r in out)
        fric.append({"frac": frac, "time": median([r["time"] for r in out]), "dp_mean": float(dp.mean()),
                     "dp_rms": float(np.sqrt(np.mean(dp ** 2))), "de": de})
        print(f"friction dt={frac:6.3g} tau  time {fric[-1]['time']:8.3f} s  dP vs finest "
              f"{fric[-1]['dp_mean']:+.3%} (rms {fric[-1]['dp_rms']:.3%})  dE {de:.1e}", file=sys.stderr)

    exact_time = median([exact[s]["time"] for s in seeds])
    exact_rms = float(np.sqrt(np.mean([(exact[s]["z"] / p_ref - 1) ** 2 for s in seeds])))
    write_table(out_dir, rows, curve, fric, exact_time, exact_rms, tau, span, seeds, exact_name, exact_seeds,
                args.quick, p_ref, p_ref_se, fric_span)
    plot(out_dir, rows, curve, fric, exact_time, tau, span, exact_name)
    return 0


def write_table(out, rows, curve, fric, exact_time, exact_rms, tau, span, seeds, exact_name, exact_seeds, quick,
                p_ref, p_ref_se, fric_span):
    out.mkdir(parents=True, exist_ok=True)
    cores = os.cpu_count()
    lines = [
        "# Run time against error: exact event engine vs time-stepped engine",
        "",
        f"Made by `python benchmarks/run_time_vs_error.py{' --quick' if quick else ''}` on "
        f"{platform.machine()} with {cores} cores (shared, timings noisy: compare ratios).",
        "",
        f"Scene: 2D, N = 500 argon disks, 300 K, area fraction 0.2, hard elastic walls. "
        f"tau = Enskog mean free time = {tau:.3e} s; simulated time T = {span:g} tau; "
        f"{len(seeds)} initial states (seeds {', '.join(map(str, seeds))}), the same for every engine. "
        f"Exact engine: `{exact_name}`. Run time = the engine's own `wall_time_s` (compile excluded), "
        "median over the seeds.",
        "",
        "Pressures are compared as P V / E (E the kinetic energy of the run, constant when elastic): "
        "at fixed density the hard-disk pressure is proportional to E, and the initial kinetic "
        "energies of the seeds differ by about 4.5 % (sqrt(2/(D N))). "
        f"Reference P_ref V / E = {p_ref:.5g} (+- {p_ref_se / p_ref:.2%}, i.e. Z = {p_ref:.4g} counting "
        f"E = N k T in 2D): mean of {len(exact_seeds)} exact runs of {8 * span:g} tau.",
        "",
        "Columns: **err vs P_ref** = rms over the seeds of P / P_ref - 1 (what a user gets: statistical "
        "plus systematic error); **dP** = pressure minus the exact run's of the same initial state, "
        "relative, mean +- standard error over the seeds (the systematic error of the step, as far as "
        "the noise lets it show), and its rms; "
        "**dE** = largest relative change of the kinetic energy (elastic: should stay 0); "
        "**dN** = collisions counted / exact - 1; **missed** / **spurious** = per pair, over the first "
        "tau, the exact collisions without a step-engine partner within max(dt, 0.01 tau), and the "
        "step-engine collisions without an exact partner; **passes** = collision passes per step.",
        "",
        "## Exact event engine: error of the pressure against run time (statistical only)",
        "",
        f"rms over {len(exact_seeds)} seeds of P / P_ref - 1.",
        "",
        "| T / tau | run time (s) | err vs P_ref |",
        "| ---: | ---: | ---: |",
    ]
    for f, t, err in curve:
        lines.append(f"| {f * span:g} | {t:.4f} | {err:.2%} |")
    lines += [
        "",
        f"Exact engine at T = {span:g} tau on the benchmark seeds: {exact_time:.4f} s per run, "
        f"err vs P_ref {exact_rms:.2%}.",
        "",
        "## Step engine against the exact engine (same initial states)",
        "",
        "| detection | dt / tau | steps | run time (s) | x exact | err vs P_ref | dP mean +- se | dP rms | dE | "
        "dN | missed | spurious | passes |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        lines.append(
            f"| {r['detection']} | {r['frac']:g} | {r['steps']} | {r['time']:.3f} | "
            f"{r['time'] / exact_time:.0f} | {r['ref_rms']:.2%} | {r['dp_mean']:+.2%} +- {r['dp_se']:.2%} | "
            f"{r['dp_rms']:.2%} | "
            f"{r['de']:.0e} | {r['dc']:+.2%} | {r['missed']:.2%} | {r['spurious']:.2%} | {r['passes']:.2f} |")
    lines += [
        "",
        "Time per phase of the step engine (median over seeds, s), swept detection:",
        "",
        "| dt / tau | push | collisions | walls | output |",
        "| ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        if r["detection"] == "swept":
            p = r["phases"]
            lines.append(f"| {r['frac']:g} | {p['push']:.3f} | {p['collisions']:.3f} | {p['walls']:.3f} | "
                         f"{p['output']:.3f} |")
    lines += [
        "",
        f"## With friction: step engine only (T = {fric_span:g} tau, gamma = 1/T = "
        f"{1 / (fric_span * tau):.3g} 1/s)",
        "",
        "dP = pressure against the run at the finest dt from the same initial state (a run this short "
        "keeps the trajectories together, so dP is the time-step error, not chaos); dE = kinetic energy "
        "against the exact decay E0 exp(-2 gamma T) (friction is integrated exactly between contacts, "
        "contacts are elastic).",
        "",
        "| dt / tau | run time (s) | dP vs finest, mean | dP rms | dE |",
        "| ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in fric:
        lines.append(f"| {r['frac']:g} | {r['time']:.3f} | {r['dp_mean']:+.2%} | {r['dp_rms']:.2%} | {r['de']:.0e} |")
    lines.append("")
    (out / "run_time_vs_error.md").write_text("\n".join(lines), encoding="utf-8")
    print(f"wrote {out / 'run_time_vs_error.md'}", file=sys.stderr)


def plot(out, rows, curve, fric, exact_time, tau, span, exact_name):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(16, 5.2), constrained_layout=True)
    styles = {"swept": ("C0", "s", (4, -10)), "overlap": ("C3", "^", (4, 5))}
    # (a) pressure error against run time: what a user gets from either engine
    t = [c[1] for c in curve]
    e = [c[2] for c in curve]
    ax1.plot(t, e, "k-o", label="exact event engine, T/16 ... 4T")
    for (f, ti, ei) in curve:
        ax1.annotate(f"T={f * span:g}τ", (ti, ei), textcoords="offset points", xytext=(5, 3), fontsize=8)
    for det, (colour, marker, offset) in styles.items():
        sub = [r for r in rows if r["detection"] == det]
        x = [r["time"] for r in sub]
        y = [r["ref_rms"] for r in sub]
        ax1.plot(x, y, "-", color=colour, marker=marker, label=f"step engine, {det} detection, T")
        for r, xi, yi in zip(sub, x, y):
            ax1.annotate(f"{r['frac']:g}", (xi, yi), textcoords="offset points", xytext=offset,
                         fontsize=7, color=colour)
    ax1.set_xlabel("run time (s)")
    ax1.set_ylabel("pressure error: rms over seeds of P/P_ref - 1")
    ax1.set_title(f"(a) pressure, T = {span:g}τ (labels: dt/τ)", fontsize=10)
    # (b) collisions missed
    for det, (colour, marker, offset) in styles.items():
        sub = [r for r in rows if r["detection"] == det]
        x = [r["time"] for r in sub]
        y = [max(r["missed"], 1e-4) for r in sub]
        ax2.plot(x, y, "-", color=colour, marker=marker, label=f"{det}: exact collisions missed (first τ)")
        ax2.plot(x, [max(r["spurious"], 1e-4) for r in sub], ":", color=colour, marker=marker, mfc="none",
                 label=f"{det}: step collisions not in the exact run")
        for r, xi, yi in zip(sub, x, y):
            ax2.annotate(f"{r['frac']:g}", (xi, yi), textcoords="offset points", xytext=offset,
                         fontsize=7, color=colour)
    ax2.axvline(exact_time, color="k", lw=0.8, ls="--", label="exact engine run time (T)")
    ax2.set_xlabel("run time (s)")
    ax2.set_ylabel("fraction (zeros drawn at 1e-4)")
    ax2.set_title("(b) collisions, per pair, over the first τ (labels: dt/τ)", fontsize=10)
    # (c) friction: step engine only
    coarse = [r for r in fric if r["frac"] != min(x["frac"] for x in fric)]
    ax3.plot([r["time"] for r in coarse], [max(r["dp_rms"], 1e-6) for r in coarse], "-", color="C2",
             marker="o", label="pressure, rms vs finest dt (0.001τ)")
    ax3.plot([r["time"] for r in coarse], [max(r["de"], 1e-16) for r in coarse], ":", color="C2",
             marker="o", mfc="none", label="kinetic energy vs E0 exp(-2γT)")
    for r in coarse:
        ax3.annotate(f"{r['frac']:g}", (r["time"], max(r["dp_rms"], 1e-6)), textcoords="offset points",
                     xytext=(4, 3), fontsize=7, color="C2")
    ax3.set_xlabel("run time (s)")
    ax3.set_ylabel("relative error")
    ax3.set_title("(c) with friction γ = 1/(10τ), T = 10τ: step engine only", fontsize=10)
    for ax in (ax1, ax2, ax3):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left" if ax is not ax3 else "center left")
    fig.suptitle(f"Run time against error: 2D, N = 500 argon, area fraction 0.2, 300 K, hard walls "
                 f"(τ = mean free time); exact engine: {exact_name}", fontsize=11)
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "run_time_vs_error.png", dpi=110)
    print(f"wrote {out / 'run_time_vs_error.png'}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
