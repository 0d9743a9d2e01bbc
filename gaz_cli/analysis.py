"""What ``gaz analyse`` and ``gaz place --repeat`` compute from placements and the database.

The store runs the packaged SQL; this module puts the results beside theory
(:mod:`gaz_cli.theory`) and draws figures.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError, StoreError


# --- placement (gaz place) --------------------------------------------------------
def _check_place_args(dim, n, radius, length):
    if dim not in (1, 2, 3):
        raise SceneError(f"--dim {dim} is not 1, 2 or 3")
    if n is None or n < 1:
        raise SceneError(f"--n must be at least 1, got {n}")
    if not (radius > 0 and math.isfinite(radius)):
        raise SceneError(f"--radius must be > 0, got {radius}")
    if not (length > 0 and math.isfinite(length)):
        raise SceneError(f"--length must be > 0, got {length}")
    from gaz_cli.scene import DENSEST, ball_volume

    eta = n * float(ball_volume(dim, radius)) / length ** dim
    if 2 * radius >= length or eta >= DENSEST[dim]:
        raise SceneError(f"{n} particles of radius {radius:g} m cannot fit in a box of side {length:g} m "
                         f"(packing fraction {eta:.3g}, densest {DENSEST[dim]:.4g}); "
                         "lower --n or --radius, or raise --length")


def place_once(dim: int, n: int, radius: float, length: float, method: str = "auto",
               seed: int | None = None) -> np.ndarray:
    """(N, D) centres of one placement, m."""
    from gaz_cli import placement

    _check_place_args(dim, n, radius, length)
    rng = np.random.default_rng(seed)
    return placement.place(dim, np.full(n, float(radius)), float(length), rng, method=method)


def placement_histogram(dim: int, n: int, radius: float, length: float, method: str,
                        seed: int | None, repeat: int, bins: int,
                        plot: str | None = None) -> pd.DataFrame:
    """The exam's Q12 study: histogram of centre positions along x over ``repeat`` placements.

    Returns a DataFrame bin_start, bin_end, count (bins over [0, L]); with
    ``plot`` also draws it (with the exact density in 1D when known).
    """
    from gaz_cli import placement

    _check_place_args(dim, n, radius, length)
    rng = np.random.default_rng(seed)
    radii = np.full(n, float(radius))
    edges = np.linspace(0.0, length, bins + 1)
    counts = np.zeros(bins, dtype=np.int64)
    for _ in range(repeat):
        x = placement.place(dim, radii, float(length), rng, method=method)[:, 0]
        counts += np.histogram(x, bins=edges)[0]
    frame = pd.DataFrame({"bin_start": edges[:-1], "bin_end": edges[1:], "count": counts})
    if plot:
        _plot_placement_histogram(frame, dim, n, radius, length, repeat, plot)
    return frame


def _plot_placement_histogram(frame, dim, n, radius, length, repeat, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    width = frame.bin_end - frame.bin_start
    density = frame["count"] / (frame["count"].sum() * width)
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.bar(frame.bin_start, density, width=width, align="edge", alpha=0.6, label=f"{repeat} placements")
    exact = _exact_centre_density(dim, n, radius, length)
    if exact is not None:
        x = np.linspace(0, length, 1000)
        ax.plot(x, exact(x), "k-", lw=1.5, label="exact density")
    ax.set_xlabel("x of a centre (m)")
    ax.set_ylabel("probability density (1/m)")
    ax.set_title(f"Q12: {n} particle(s) of radius {radius:g} in [0, {length:g}], {dim}D")
    ax.legend()
    fig.tight_layout()
    try:
        fig.savefig(path, dpi=120)
    except OSError as err:
        raise SceneError(f"cannot write --histogram {path!r}: {err.strerror}") from None
    finally:
        plt.close(fig)


def _exact_centre_density(dim, n, radius, length):
    """Exact density of one rod's centre for the uniform 1D placement, or None."""
    if dim != 1:
        return None
    try:
        from gaz_cli import theory
    except ImportError:
        return None
    func = getattr(theory, "rod_centre_density", None)
    if func is None:
        return None
    return lambda x: func(x, n, radius, length)


# --- pressure -------------------------------------------------------------------
def kinetic_temperature(kinetic_energy: float, dim: int, n: int, periodic: bool = False) -> float:
    """Temperature from kinetic energy, K: kT = 2K/(D N), or 2K/(D (N-1)) periodic."""
    dof = dim * (n - 1 if periodic and n > 1 else n)
    return 2.0 * kinetic_energy / (dof * K_B)


def ideal_wall_pressure(dim: int, length: float, counts, radii, temperature: float) -> float:
    """Ideal-gas pressure on a wall per unit of its full measure L^(D-1), Pa.

    A particle of radius R pushes each wall with the time-averaged force
    kT/(L - 2R), so P = sum_s N_s kT / ((L - 2R_s) L^(D-1)).
    """
    counts = np.asarray(counts, dtype=float)
    radii = np.asarray(radii, dtype=float)
    return float(np.sum(counts * K_B * temperature / (length - 2.0 * radii)) / length ** (dim - 1))


def run_pressure(scene, stats, ke_start: float, ke_end: float, wall_momentum=None):
    """The summary's pressure: mean wall pressure, or the virial pressure in a periodic box."""
    if scene.boundary == "periodic":
        temperature = kinetic_temperature(0.5 * (ke_start + ke_end), scene.dim, scene.n, periodic=True)
        return float((scene.n * K_B * temperature + stats.virial / (scene.dim * scene.duration))
                     / scene.volume)
    if wall_momentum is None:
        return None
    return float(np.mean(wall_momentum) / (scene.duration * scene.length ** (scene.dim - 1)))


# --- gaz analyse ----------------------------------------------------------------
def report(db: str, sim: int | None = None, plot_dir: str | None = None) -> dict:
    """Every packaged query, and measured pressure beside theory; a dict of DataFrames."""
    from gaz_cli import store as st

    store = st.Store(db, create=False)
    numbers = store.simulation_numbers()
    if not numbers:
        raise StoreError(f"{db!r} holds no simulation yet; run 'gaz simulate --db {db}' first")
    if sim is not None and sim not in numbers:
        raise StoreError(f"simulation {sim} is not in {db!r}; it holds SI_NUM {_ranges(numbers)}")
    chosen = [sim] if sim is not None else numbers
    q34 = store.query("q34_simulations_per_dimension")
    q35 = store.query("q35_bounces_per_simulation")
    q35 = q35[q35.SI_NUM.isin(chosen)].reset_index(drop=True)
    walls, versus = [], []
    for number in chosen:
        per_wall = store.query("pressure_per_wall", si_num=number)
        per_wall.insert(0, "SI_NUM", number)
        walls.append(per_wall)
        versus.append(_pressure_vs_ideal(store, number, per_wall))
    frames = {
        "Q34 simulations per dimension": q34,
        "Q35 wall bounces and mean speed of wall hits": q35,
        "Q36 momentum and pressure per wall": pd.concat(walls, ignore_index=True),
        "pressure against the ideal gas": pd.DataFrame(versus),
    }
    return frames


def _pressure_vs_ideal(store, number: int, per_wall: pd.DataFrame) -> dict:
    from gaz_cli import store as st

    sim = store.table(st.simulation, number).iloc[0]
    dim, n, length, duration = int(sim.SI_DIM), int(sim.SI_N), float(sim.SI_L), float(sim.SI_DUR)
    row = {"SI_NUM": number, "SI_DIM": dim, "SI_N": n, "SI_L": length, "SI_DUR": duration}
    res = store.table(st.resultat, number)
    comp = store.table(st.composition, number)
    scene = store.table(st.scene_table, number)
    periodic = len(scene) and scene.iloc[0].SC_BOUNDARY == "periodic"
    row["BOUNDARY"] = "periodic" if periodic else "walls"
    if len(res):
        ke = 0.5 * (float(res.iloc[0].RS_KE_START) + float(res.iloc[0].RS_KE_END))
        temperature = kinetic_temperature(ke, dim, n, periodic=bool(periodic))
    else:
        temperature = float("nan")
    row["T_KIN_K"] = temperature
    if periodic:
        virial = float(res.iloc[0].RS_VIRIAL) if len(res) else float("nan")
        row["P_MEASURED_PA"] = (n * K_B * temperature + virial / (dim * duration)) / length ** dim
        row["P_IDEAL_PA"] = n * K_B * temperature / length ** dim
    else:
        row["P_MEASURED_PA"] = float(per_wall.PRESSION.sum() / (2 * dim)) if len(per_wall) else float("nan")
        if len(comp):
            particles = store.table(st.particule)
            radii = comp.merge(particles, on="PA_NUM").PA_R.to_numpy()
            counts = comp.merge(particles, on="PA_NUM").CO_N.to_numpy()
            row["P_IDEAL_PA"] = ideal_wall_pressure(dim, length, counts, radii, temperature)
        else:
            row["P_IDEAL_PA"] = float("nan")
    row["RATIO"] = row["P_MEASURED_PA"] / row["P_IDEAL_PA"] if row["P_IDEAL_PA"] else float("nan")
    return row


def _ranges(numbers: list[int]) -> str:
    """'1-3, 7' from [1, 2, 3, 7]."""
    out, start, prev = [], None, None
    for k in numbers:
        if start is None:
            start = prev = k
        elif k == prev + 1:
            prev = k
        else:
            out.append(f"{start}-{prev}" if prev != start else f"{start}")
            start = prev = k
    out.append(f"{start}-{prev}" if prev != start else f"{start}")
    return ", ".join(out)
