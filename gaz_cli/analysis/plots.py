"""Figures of ``gaz analyse --plot`` and ``gaz place --histogram`` (matplotlib, Agg backend, PNG).

Each function takes plain arrays (SI units) already computed by
:mod:`gaz_cli.analysis.figures`, draws one figure and writes it to ``path``; none
reads the database or computes physics beyond evaluating a theory curve from
:mod:`gaz_cli.theory`.

Readable by rule (issue 42): legends outside the axes (:func:`legend_outside`), never over
the data; times in the unit that keeps tick labels short (ns, ps...: :func:`time_unit`),
no offset printed beside an axis; counts compared as points with error bars on an axis
that does not start at 0; symbols typeset by matplotlib's mathtext (``$k_\\mathrm{B}$``).
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli import theory
from gaz_cli.errors import GazError

WALL_NAMES = {1: "x", 2: "y", 3: "z"}

THEORY = {"color": "black", "ls": "--", "lw": 1.4}
"""Style of a theory curve in every figure: black, dashed. Measured data take the colour
cycle (C0, C1, ...: never black), so a theory never looks like a data series."""

IDEAL = {"color": "tab:gray", "ls": ":", "lw": 1.2}
"""Style of the ideal-gas (or any limiting) line drawn beside the theory."""


def series_color(k: int) -> str:
    """Colour of the k-th data series (the colour cycle: never the theory's black)."""
    return f"C{k % 10}"


TIME_UNITS = ((1.0, "s"), (1e-3, "ms"), (1e-6, "µs"), (1e-9, "ns"), (1e-12, "ps"), (1e-15, "fs"))
"""Units of a time axis, largest first: (seconds per unit, name)."""


def time_unit(longest: float) -> tuple[float, str]:
    """(seconds per unit, name) of the largest unit in which ``longest`` (s) is at least 1:
    a run of 2e-9 s is drawn in ns (0 to 2), not in s with an offset 1e-9."""
    for scale, name in TIME_UNITS:
        if math.isfinite(longest) and longest >= scale:
            return scale, name
    return TIME_UNITS[-1]


def legend_outside(fig, ax, ncols: int = 2) -> None:
    """The legend of ``ax`` above the axes (below any suptitle), never over the data; the
    figure needs ``layout="constrained"`` (as :func:`_figure` makes it) to leave it room."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside upper center", ncols=ncols, fontsize=8, frameon=False)


def _figure(*args, **kwargs):
    """``plt.subplots`` with constrained layout (room for :func:`legend_outside`)."""
    return _pyplot().subplots(*args, layout="constrained", **kwargs)


def _plain_numbers(ax) -> None:
    """Tick labels without an offset ('+1.06e5' printed beside the axis): each label reads as
    the value itself (a power-of-ten factor may remain for very large or small values)."""
    for axis in (ax.xaxis, ax.yaxis):
        formatter = axis.get_major_formatter()
        if hasattr(formatter, "set_useOffset"):
            formatter.set_useOffset(False)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def make_folder(path: str) -> None:
    """Create the folder of ``--plot DIR`` (and its parents); GazError in one line if it cannot be."""
    from pathlib import Path

    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise GazError(f"cannot create --plot folder {path!r}: {err.strerror}") from None


def save(fig, path: str, dpi: int = 110) -> None:
    """Write ``fig`` to ``path`` and close it; GazError in one line if it cannot be written."""
    from gaz_cli import atomic

    plt = _pyplot()
    try:
        if fig.get_layout_engine() is None:
            fig.tight_layout()
        with atomic.replacing(path) as name:  # whole or not at all: the old figure kept
            fig.savefig(name, dpi=dpi)
    except OSError as err:
        raise GazError(f"cannot write figure {path!r}: {err.strerror}") from None
    finally:
        plt.close(fig)


def wall_label(code: int, dim: int) -> str:
    """'x = 0' for RE_DIR -1, 'z = L' for +3; under gravity the last axis is the height."""
    axis = WALL_NAMES[abs(code)]
    return f"{axis} = {'L' if code > 0 else '0'}"


# --- gaz place --histogram ----------------------------------------------------------
def placement_histogram(path: str, edges, counts, exact, repeat: int, title: str) -> None:
    """Q12: histogram of centre positions (as a density, 1/m) with the exact density if known.

    ``edges`` (B+1,) m; ``counts`` (B,); ``exact`` callable x -> density or None.
    """
    edges = np.asarray(edges, dtype=float)
    counts = np.asarray(counts, dtype=float)
    width = np.diff(edges)
    total = counts.sum()
    density = counts / (total * width) if total else counts
    fig, ax = _figure(figsize=(7.5, 4.4))
    ax.bar(edges[:-1], density, width=width, align="edge", color="tab:blue", alpha=0.55,
           edgecolor="white", linewidth=0.4, label=f"{repeat} placements")
    if total:
        # one standard deviation of a bin's count (binomial), as a density
        p = counts / total
        err = np.sqrt(np.maximum(counts * (1 - p), 0.0)) / (total * width)
        ax.errorbar(0.5 * (edges[1:] + edges[:-1]), density, yerr=err, fmt="none", ecolor="tab:blue",
                    elinewidth=0.8, alpha=0.8)
    if exact is not None:
        x = np.linspace(edges[0], edges[-1], 2000)
        ax.plot(x, exact(x), **THEORY, label="exact density, uniform placement")
    ax.set_xlabel("x of a centre (m)")
    ax.set_ylabel("probability density (1/m)")
    ax.set_title(title, fontsize=10)
    ax.set_ylim(bottom=0)
    legend_outside(fig, ax)
    save(fig, path)


# --- gaz analyse --plot ------------------------------------------------------------
def wall_hit_speeds(path: str, dim: int, speeds, normal_speeds, temperature: float, species,
                    title: str) -> None:
    """Histograms of |v| and |v_perp| of the wall hits over the flux-weighted theory.

    ``speeds``, ``normal_speeds`` (k,) m/s (RE_VIT, RE_VP); ``species`` list of
    (name, mass kg, share of the hits, share of the particles); ``temperature`` K.
    """
    speeds = np.asarray(speeds, dtype=float)
    normal_speeds = np.asarray(normal_speeds, dtype=float)
    fig, axes = _figure(1, 2, figsize=(11, 4.6))
    known = math.isfinite(temperature) and temperature > 0 and species
    for ax, data, normal in ((axes[0], speeds, False), (axes[1], normal_speeds, True)):
        top = float(np.quantile(data, 0.999)) * 1.15 if data.size else 1.0
        bins = np.linspace(0.0, top, 60)
        ax.hist(data, bins=bins, density=True, color="tab:blue", alpha=0.55,
                label=f"{data.size} wall hits")
        if known:
            v = np.linspace(0.0, top, 400)
            hit = sum(w * (theory.wall_hit_normal_speed_pdf(v, temperature, m) if normal
                           else theory.wall_hit_speed_pdf(dim, v, temperature, m))
                      for _, m, w, _ in species)
            ax.plot(v, hit, **THEORY, label="flux-weighted Maxwell-Boltzmann")
            if not normal:
                gas = sum(c * theory.speed_pdf(dim, v, temperature, m) for _, m, _, c in species)
                ax.plot(v, gas, **IDEAL, label="speeds in the gas (not weighted)")
                mean_hit = sum(w * theory.wall_hit_mean_speed(dim, temperature, m) for _, m, w, _ in species)
                ax.axvline(mean_hit, color="k", ls=":", lw=1.0, label=f"theory's mean, {mean_hit:.4g} m/s")
                if data.size:
                    ax.axvline(float(data.mean()), color="tab:red", ls=":", lw=1.2,
                               label=f"measured mean, {data.mean():.4g} m/s")
        ax.set_xlabel(r"normal speed $|v_\perp|$ of a wall hit (m/s)" if normal
                      else "speed $|v|$ of a wall hit (m/s)")
        ax.set_ylabel("probability density (s/m)")
        ax.set_xlim(0, top)
    axes[0].set_title("speeds of the particles hitting a wall (Q35)", fontsize=10)
    axes[1].set_title("normal speed: Rayleigh, any dimension", fontsize=10)
    # one legend for both panels (the left one holds every kind of line), above them
    handles, labels = axes[0].get_legend_handles_labels()
    fig.suptitle(title + (f"  [T = {temperature:.4g} K]" if known else "  [no theory: T unknown]"), fontsize=9)
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncols=3, fontsize=8, frameon=False)
    save(fig, path)


def bounces_per_wall(path: str, dim: int, walls, counts, expected, title: str, gravity: bool = False) -> None:
    """The bounces recorded on each wall as points with their Poisson error bars (± √count),
    beside the expected counts (or None), on an axis fitted to them (not from 0): the walls'
    differences, a few per cent, stay visible."""
    labels = [wall_label(w, dim) for w in walls]
    x = np.arange(len(walls))
    fig, ax = _figure(figsize=(max(5.0, 1.3 * len(walls) + 2), 4.2))
    counts = np.asarray(counts, dtype=float)
    ax.errorbar(x, counts, yerr=np.sqrt(counts), fmt="o", color="tab:blue", ms=6, elinewidth=1.2,
                capsize=4, label=r"recorded (REBOND), $\pm\sqrt{\mathrm{count}}$")
    if expected is not None:
        ax.scatter(x, expected, marker="_", s=700, color=THEORY["color"], linewidths=1.8, zorder=3,
                   label=r"theory: $P A t/\sqrt{2\pi m k_\mathrm{B} T}$")
    ax.set_xticks(x, labels)
    ax.set_xlim(-0.5, len(walls) - 0.5)
    ax.set_ylabel("number of bounces")
    ax.set_xlabel("wall" + (f" (gravity pulls towards {WALL_NAMES[dim]} = 0)" if gravity else ""))
    ax.set_title(title, fontsize=9)
    ax.margins(y=0.15)
    _plain_numbers(ax)
    legend_outside(fig, ax)
    save(fig, path)


def pressure_against_time(path: str, times, running, band, block_times, block_values, theory,
                          theory_label: str, what: str, title: str, others=(), unit: str = "Pa") -> None:
    """Running mean of the pressure with its error band, the block values, and theory as a line.

    ``others``: (label, value) of further models, drawn dotted (kept in view).
    """
    scale, tname = time_unit(float(np.max(times)) if np.size(times) else math.nan)
    times = np.asarray(times, dtype=float) / scale
    running = np.asarray(running, dtype=float)
    fig, ax = _figure(figsize=(8, 4.8))
    ax.plot(times, running, color="tab:blue", lw=1.6, label=f"running mean of the {what}")
    if band is not None:
        ax.fill_between(times, running - band, running + band, color="tab:blue", alpha=0.2,
                        label="± 1 standard error (from the blocks)")
    bv = np.asarray(block_values, dtype=float)
    ax.plot(np.asarray(block_times, dtype=float) / scale, bv, "o", color="tab:orange", ms=4, alpha=0.8,
            label=f"pressure in each of {bv.size} time blocks")
    if theory is not None:
        ax.axhline(theory, **THEORY, label=f"theory: {theory_label}")
    styles = iter([("tab:red", ":"), ("tab:purple", "-."), ("tab:green", ":")])
    for label, value in others:
        color, ls = next(styles, ("tab:gray", ":"))
        ax.axhline(value, color=color, lw=1.3, ls=ls, label=label)
    # keep the early, noisy part of the running mean from hiding the comparison
    finite = np.concatenate([running[len(running) // 10:], bv[np.isfinite(bv)]]
                            + ([np.array([theory])] if theory is not None else [])
                            + [np.array([v for _, v in others])])
    if finite.size:
        lo, hi = float(np.min(finite)), float(np.max(finite))
        pad = 0.15 * (hi - lo) if hi > lo else 0.05 * abs(hi) or 1.0
        ax.set_ylim(lo - pad, hi + pad)
    ax.set_xlabel(f"simulated time ({tname})")
    ax.set_ylabel(f"pressure ({unit})")
    ax.set_title(title, fontsize=9)
    _plain_numbers(ax)
    legend_outside(fig, ax)
    save(fig, path)


def density_profile(path: str, heights, measured, expected, scale_height: float, title: str) -> None:
    """Number of centres per unit height against height, with the barometric law."""
    fig, ax = _figure(figsize=(7.5, 4.6))
    heights = np.asarray(heights, dtype=float)
    ax.step(heights, measured, where="mid", color="tab:blue", lw=1.5,
            label="rebuilt from the floor hits (free flights)")
    ax.plot(heights, expected, **THEORY, label=rf"barometric law, $k_\mathrm{{B}}T/(mg)$ = {scale_height:.3g} m")
    ax.set_xlabel("height of a centre above the floor (m)")
    ax.set_ylabel("centres per unit height (1/m)")
    ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    legend_outside(fig, ax)
    save(fig, path)


def cooling(path: str, times, temperatures, haff, t_end: float, title: str) -> None:
    """Temperature of a cooling granular gas against time, with Haff's law."""
    fig, ax = _figure(figsize=(7.5, 4.6))
    scale, tname = time_unit(float(np.max(times)) if np.size(times) else math.nan)
    times = np.asarray(times, dtype=float) / scale
    ax.plot(times, temperatures, color="tab:blue", lw=1.6, label="from the collision impulses (CHOC)")
    if haff is not None:
        ax.plot(times, haff, **THEORY, label=r"Haff: $T_0/(1 + t/t_0)^2$, Enskog rate")
    ax.plot([times[-1]], [t_end], "o", color="tab:red", label="final kinetic energy (RESULTAT)")
    ax.set_xlabel(f"simulated time ({tname})")
    ax.set_ylabel("kinetic temperature (K)")
    ax.set_yscale("log")
    ax.set_title(title, fontsize=9)
    legend_outside(fig, ax)
    save(fig, path)
