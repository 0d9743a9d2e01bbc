"""Studies across runs: a measured quantity against a swept key, averaged over seeds,
beside theory (``gaz analyse --vs KEY``).

The per-run numbers come from the packaged SQL file ``sweep_runs.sql`` (one
row per simulation: what it was, the momentum its walls received, its
collisions and virial); this module turns them into each run's pressure,
compressibility factor Z = P V/(N k_B T) and collision rate per particle,
groups the runs by the key, and gives for each value the mean over its runs,
its standard error, and theory for the same scene. The error of Z in a
periodic box recorded with ``record = "all"`` comes from within each run: the
collision virial in :data:`gaz_cli.analysis.errorbars.BINS` time bins (``collision_bins.sql``),
its error from the autocorrelation window (:func:`gaz_cli.analysis.errorbars.autocorrelation_error`), the runs' errors combined as
sqrt(sum e_i^2)/k -- stable with few seeds, where the spread of k = 3 seeds gives an
error that is itself uncertain by 50 % (Student's t with 2 degrees of freedom puts
10 % of points beyond 3 of its sigmas). Otherwise, and for P and the rate, the error
is the spread over the runs, std/sqrt(k) (column Z_ESTIMATOR says which). Theory:

- pressure: with walls, :func:`gaz_cli.theory.hard_sphere_wall_pressure` (the
  bulk equation of state -- Tonks in 1D, Kolafa-Rottner in 2D, KLM in 3D --
  at the density of the volume the centres reach); in a periodic box the
  bulk equation of state itself; the ideal gas beside;
- collision rate: Enskog's (exact in 1D).

The temperature of each run is its kinetic temperature (mean of the start and
end kinetic energies), as in the run's own summary.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from gaz_cli import theory
from gaz_cli.analysis import stored
from gaz_cli.errors import GazError, SceneError

KEYS = {
    "packing": "packing fraction eta of the run",
    "temperature": "temperature asked for (SCENE.SC_TEMPERATURE), K",
    "n": "number of particles (SI_N)",
    "length": "box side (SI_L), m",
    "density": "number density N/L^D, 1/m^D",
}
"""Keys ``--vs`` accepts, and what each is."""


def runs(store) -> pd.DataFrame:
    """One row per simulation with its key values, measured and theoretical numbers."""
    frame = store.query("sweep_runs")
    if frame.empty:
        return frame
    dim = frame.SI_DIM.to_numpy()
    n = frame.SI_N.to_numpy(dtype=float)
    length = frame.SI_L.to_numpy(dtype=float)
    volume = length ** dim
    periodic = (frame.SC_BOUNDARY == "periodic").to_numpy()
    radius = frame.PA_R.to_numpy(dtype=float)
    out = pd.DataFrame({"SI_NUM": frame.SI_NUM, "DIM": dim, "BOUNDARY": frame.SC_BOUNDARY,
                        "SEED": frame.SC_SEED, "n": n, "length": length,
                        "temperature": frame.SC_TEMPERATURE.astype(float), "density": n / volume,
                        "duration": frame.SI_DUR.astype(float)})
    out = out.merge(_scenes(store), on="SI_NUM", how="left")
    out["packing"] = [float(theory.packing_fraction(d, rho, 2.0 * r)) if np.isfinite(r) else math.nan
                      for d, rho, r in zip(dim, out.density, radius)]
    ke = 0.5 * (frame.RS_KE_START.to_numpy(dtype=float) + frame.RS_KE_END.to_numpy(dtype=float))
    drift = [stored.drift_energy(f, k0) if p else 0.0      # an explicit state's conserved momentum
             for f, k0, p in zip(out.scene_file, frame.RS_KE_START.to_numpy(dtype=float), periodic)]
    t_kin = np.array([_kinetic_temperature(d, k, nn, p, e) for d, k, nn, p, e in zip(dim, ke, n, periodic, drift)])
    out["T_KIN"] = t_kin
    duration = frame.SI_DUR.to_numpy(dtype=float)
    wall = frame.MOMENTUM.to_numpy(dtype=float) / (2 * dim * duration * length ** (dim - 1))
    wall[(frame.SC_RECORD == "none").to_numpy()] = math.nan  # no bounce stored: not measured (not 0)
    virial = np.array([_virial(d, nn, t, v, w, tau) for d, nn, t, v, w, tau in
                       zip(dim, n, t_kin, volume, frame.RS_VIRIAL.to_numpy(dtype=float), duration)])
    out["P"] = np.where(periodic, virial, wall)
    out["P_THEORY"] = [_pressure_theory(d, L, t, nn, r, p) for d, L, t, nn, r, p in
                       zip(dim, length, t_kin, n, radius, periodic)]
    out["SYST_REL"] = [_wall_systematic(d, L, nn, r) if not p else 0.0 for d, L, nn, r, p in
                       zip(dim, length, n, radius, periodic)]
    out["P_IDEAL"] = n * theory.K_B * t_kin / volume
    out["Z"] = out.P / out.P_IDEAL
    out["Z_THEORY"] = out.P_THEORY / out.P_IDEAL
    out["Z_RUN_ERR"] = [_z_error_within(store, int(si), d, nn, tau, t, r) if p else math.nan
                        for si, d, nn, tau, t, r, p in zip(frame.SI_NUM, dim, n, duration, t_kin, radius, periodic)]
    out["RATE"] = 2.0 * frame.RS_COLLISIONS.to_numpy(dtype=float) / (n * duration)
    mass = frame.PA_M.to_numpy(dtype=float)
    out["RATE_THEORY"] = [_rate_theory(d, nn, L, r, t, m) for d, nn, L, r, t, m in
                          zip(dim, n, length, radius, t_kin, mass)]
    out["NO_THEORY"] = [_no_theory(r) for r in out.itertuples()]
    off = out.NO_THEORY != ""
    out.loc[off, ["P_THEORY", "Z_THEORY", "RATE_THEORY", "SYST_REL"]] = math.nan
    return out


def _no_theory(run) -> str:
    """Why the uniform equilibrium theories of this module do not describe a run ('' when they do)."""
    if run.gravity > 0:
        return (f"gravity {run.gravity:g} m/s^2: a stratified gas, not the uniform one of this table's "
                "theory; gaz analyse --sim N compares each run with the barometric theory")
    if run.restitution < 1 or run.wall_restitution < 1:
        return "restitution < 1: the gas cools, it has no equilibrium pressure or rate"
    if run.drag > 0:
        return f"drag {run.drag:g} 1/s slows the gas: no equilibrium"
    if run.pair_gravity > 0:
        return "pair gravity: not a hard-sphere gas"
    if run.planes:
        return f"{run.planes} extra plane wall(s): the space is not the box [0, L]^D of this table's theory"
    return ""


SETTINGS = {"SC_GRAVITY": "gravity", "SC_RESTITUTION": "restitution", "SC_TC": "tc",
            "SC_WALL_RESTITUTION": "wall_restitution", "SC_DT": "dt", "SC_DRAG": "drag",
            "SC_PAIR_GRAVITY": "pair_gravity"}
"""The settings of SCENE that make two runs different scenes (beside dimension, boundary,
species and counts, box, duration and temperature). Not the seed, nor how a scene is run or
what is stored of it (engine, placement, record): runs differing in those are repeats."""

SCENE_KEYS = ("DIM", "BOUNDARY", "names", "species", "n", "length", "temperature", "duration", *SETTINGS.values(),
              "planes")
"""What one scene is, apart from its seed: runs that agree on all of these are its repeats."""

FREE = {"packing": ("length",), "density": ("length",), "length": ("length",),
        "temperature": ("temperature",), "n": ("n", "species", "length")}  # names held
"""What may change along one series against each key, with the key: a sweep over packing
changes the box (the counts held), over n the counts (and the box, at a packing held)."""

HOLDS = {"n": (("packing",), ("length",))}
"""Against n, what one series holds beside the scene keys not in FREE: its packing fraction
(a sweep of n at packings held, the box growing with n) or its box (a sweep at a box held, the
packing growing with n); whichever splits the runs into fewer series (packing on a tie)."""

LEFT_OUT = {"packing": "a mixture has no single packing fraction (its species differ in size)"}
"""Why a run may have no value of a key."""


def _scenes(store) -> pd.DataFrame:
    """Per SI_NUM: ``species`` (``Ar``, or ``Ar:500,He:500`` for a mixture), ``names``
    (``Ar``, ``Ar+He``) and the :data:`SETTINGS` that tell scenes apart."""
    from gaz_cli.results.store import composition, particule, scene_table

    scenes = store.table(scene_table)
    parts = store.table(composition).merge(store.table(particule)[["PA_NUM", "PA_NOM"]], on="PA_NUM")
    parts = parts.sort_values(["SI_NUM", "CO_RANK" if "CO_RANK" in parts else "PA_NUM", "PA_NUM"])
    mix = pd.DataFrame([{"SI_NUM": si, "names": "+".join(g.PA_NOM),
                         "species": g.PA_NOM.iloc[0] if len(g) == 1 else
                         ",".join(f"{a}:{k}" for a, k in zip(g.PA_NOM, g.CO_N))}
                        for si, g in parts.groupby("SI_NUM")], columns=["SI_NUM", "names", "species"])
    out = scenes[["SI_NUM", *SETTINGS]].rename(columns=SETTINGS)
    out["scene_file"] = scenes.SC_FILE if "SC_FILE" in scenes else None
    out["planes"] = [stored.plane_count(f) for f in out.scene_file]  # extra walls make another scene
    return out.merge(mix, on="SI_NUM", how="left")


def _same(values: pd.Series) -> pd.Series:
    """Values to group by: numbers to 12 significant digits (the repeats of a scene agree to
    the last bit; a box computed from a packing may differ in the 16th), missing ones as ''."""
    if pd.api.types.is_numeric_dtype(values):
        return values.map(lambda v: "" if pd.isna(v) else f"{float(v):.12g}")
    return values.fillna("").astype(str)


def versus(store, key: str) -> pd.DataFrame:
    """Per scene and value of ``key``: runs (its seeds), mean and standard error over them,
    theory, deviation in sigma.

    Only repeats of one scene are averaged: runs are grouped by every scene key
    (:data:`SCENE_KEYS`) but the seed. Scenes that differ in more than ``key`` (and what
    changes with it, :data:`FREE`) are told apart by a column SCENE naming what differs
    (absent when the database holds one series, as after a sweep of one scene file over one
    key). Against n a series holds its packing or its box (:data:`HOLDS`). Runs without a value of ``key`` (a mixture's packing) are left out, said in one
    warning (:class:`~gaz_cli.errors.GazWarning`).
    """
    import warnings

    from gaz_cli.errors import GazWarning

    if key not in KEYS:
        raise GazError(f"--vs {key!r} is not a key gaz can tabulate; use one of {', '.join(KEYS)}")
    table = runs(store)
    if table.empty:
        raise GazError("the database holds no simulation to tabulate; run 'gaz sweep' or 'gaz simulate' first")
    missing = table[key].isna().to_numpy()
    if missing.any():
        why = LEFT_OUT.get(key, f"no {key} stored")
        if missing.all():
            raise GazError(f"--vs {key}: none of the {len(table)} runs has a {key} ({why}); "
                           f"tabulate against another key ({', '.join(k for k in KEYS if k != key)})")
        warnings.warn(GazWarning(f"--vs {key}: {int(missing.sum())} of {len(table)} runs left out, "
                                 f"having no {key}: {why}"))
        table = table[~missing].reset_index(drop=True)
    series = [k for k in SCENE_KEYS if k not in FREE[key]]
    ids = pd.DataFrame({k: _same(table[k]) for k in (*SCENE_KEYS, "packing")})
    if key in HOLDS:   # fewest series; min keeps the first of equals
        series = min(([*series, *held] for held in HOLDS[key]),
                     key=lambda keys: len(ids[keys].drop_duplicates()))
    ids["SERIES_ID"] = ids[series].apply(tuple, axis=1)
    ids["SCENE_ID"] = ids[list(SCENE_KEYS)].apply(tuple, axis=1)
    ids["X_ID"] = table[key].round(12)
    crowded = ids.groupby(["SERIES_ID", "X_ID"])["SCENE_ID"].transform("nunique") > 1  # scenes alike but in FREE
    several = ids["SERIES_ID"].nunique() > 1 or crowded.any()
    differ = [k for k in (*SCENE_KEYS[2:], "packing") if ids[k].nunique() > 1]  # beyond DIM and BOUNDARY
    groups = table.groupby([table.DIM, table.BOUNDARY, ids["SERIES_ID"], ids["X_ID"], ids["SCENE_ID"]], sort=True)
    rows = []
    for (dim, boundary, _, x, _), g in groups:
        row = {"DIM": dim, "BOUNDARY": boundary}
        if several:  # what tells this row's scene from the others'
            first = g.iloc[0]
            named = [k for k in differ if k in series or (k != key and crowded[g.index[0]])]
            if "species" in named and "names" in named:
                named.remove("names")
            row["SCENE"] = " ".join(f"{'species' if k == 'names' else k}={_shown(first[k])}" for k in named
                                    if not (isinstance(first[k], float) and math.isnan(first[k])))  # a mixture's packing
        row.update({key.upper(): int(x) if key == "n" else x, "RUNS": len(g)})  # N = 5, not 5.0
        for name in ("P", "Z", "RATE"):
            mean, err = _mean_err(g[name])
            if name == "Z":
                within = g.Z_RUN_ERR.to_numpy(dtype=float)
                row["Z_ESTIMATOR"] = "spread over runs"
                if np.all(np.isfinite(within)):
                    err = float(np.sqrt(np.sum(within ** 2)) / len(within))
                    row["Z_ESTIMATOR"] = "autocorrelation window within runs"
            measured = np.isfinite(g[name].to_numpy(dtype=float))  # theory of the runs averaged
            theory_ = g[f"{name}_THEORY"][measured].mean() if measured.any() else g[f"{name}_THEORY"].mean()
            row.update({name: mean, f"{name}_ERR": err, f"{name}_THEORY": theory_,
                        f"{name}_DEV_SIGMA": (mean - theory_) / err if err > 0 else math.nan})
        row["P_IDEAL"] = g.P_IDEAL.mean()
        row["SYST_REL"] = g.SYST_REL.mean()
        row["NOTE"] = "" if len(g) > 1 else "one run: no error bar (give --seeds 2 or more)"
        if g.NO_THEORY.iloc[0]:     # the scene's settings: the same for all its runs
            row["NOTE"] = "; ".join(filter(None, [g.NO_THEORY.iloc[0], row["NOTE"]]))
        elif not row["SYST_REL"] <= row["Z_ERR"] / row["Z_THEORY"]:
            # the wall theory's own error (next order: wall adsorption) exceeds the measurement's:
            # a deviation in sigma would measure the model, not the run (as in gaz analyse)
            for name in ("P", "Z"):
                row[f"{name}_DEV_SIGMA"] = math.nan
            row["NOTE"] = (f"no theory for this scene within its error: the wall model's systematic error "
                           f"(up to {row['SYST_REL']:.2g} relative) exceeds the error bar; a periodic box "
                           "compares with the bulk equation of state")
        rows.append(row)
    return pd.DataFrame(rows)


def _shown(value) -> str:
    """A scene key's value as a user would write it: 20, 300.0 K as 300, 1e-07."""
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        return f"{_integral(value):.6g}" if isinstance(_integral(value), float) else str(_integral(value))
    return str(value)


def _integral(x):
    """``x`` as an int when it is a whole number (N = 5, not 5.0), else as it is."""
    try:
        return int(x) if float(x).is_integer() else x
    except (TypeError, ValueError, OverflowError):
        return x


def _mean_err(values: pd.Series) -> tuple[float, float]:
    """Mean and standard error of independent runs (NaN error for a single run)."""
    v = values.to_numpy(dtype=float)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return math.nan, math.nan
    if len(v) == 1:
        return float(v[0]), math.nan
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v)))


def _z_error_within(store, si_num: int, dim: int, n: float, duration: float, t: float,
                    radius: float) -> float:
    """Standard error of a periodic run's Z from its collision virial per time bin, reblocked;
    NaN without CHOC rows (record = "all") or for a mixture."""
    from gaz_cli.analysis import errorbars

    if not (np.isfinite(radius) and np.isfinite(t) and t > 0):
        return math.nan
    bins = store.query("collision_bins", si_num=si_num, bins=errorbars.BINS, duration=duration)
    bins = bins[bins.BIN.notna()]
    if bins.NB_CHOCS.sum() == 0:
        return math.nan
    per_bin = np.zeros(errorbars.BINS)
    index = np.clip(bins.BIN.to_numpy(dtype=np.int64), 0, errorbars.BINS - 1)
    np.add.at(per_bin, index, bins.SUM_IMP.to_numpy(dtype=float))
    # Z in each bin: 1 + W_b / (D dt N k_B T), W_b = sum |J| sigma over the bin's collisions
    z = 1.0 + per_bin * 2.0 * radius / (dim * (duration / errorbars.BINS) * n * theory.K_B * t)
    return errorbars.autocorrelation_error(z)[0]


def _kinetic_temperature(dim, ke, n, periodic, drift=0.0) -> float:
    try:
        return float(theory.kinetic_temperature(dim, ke, n, periodic=bool(periodic), drift_energy=drift))
    except SceneError:
        return math.nan


def _virial(dim, n, t, volume, w, tau) -> float:
    if not (np.isfinite(t) and t > 0):
        return math.nan
    return float(theory.virial_pressure(dim, n, t, volume, w, tau))


def _pressure_theory(dim, length, t, n, radius, periodic) -> float:
    """The scene's pressure by theory; NaN where no theory applies (mixtures, beyond a model's range)."""
    if not (np.isfinite(radius) and np.isfinite(t) and t > 0):
        return math.nan
    try:
        if periodic:
            return float(theory.hard_sphere_pressure(dim, n / length ** dim, 2.0 * radius, t))
        return float(theory.hard_sphere_wall_pressure(dim, length, t, n, radius))
    except SceneError:
        return math.nan


def _wall_systematic(dim, length, n, radius) -> float:
    """Bound on the wall theory's relative error (the next order, wall adsorption); 0 in 1D
    (Tonks is exact), NaN without a single radius."""
    if dim == 1:
        return 0.0
    if not np.isfinite(radius):
        return math.nan
    try:
        return abs(float(theory.wall_adsorption_shift(dim, length, n, radius)))
    except SceneError:
        return math.nan


def _rate_theory(dim, n, length, radius, t, mass) -> float:
    if not (np.isfinite(radius) and np.isfinite(t) and t > 0 and np.isfinite(mass) and n > 1):
        return math.nan
    try:
        if dim == 1:
            return float(theory.rods_collision_frequency(n, length, radius, t, mass))
        return float(theory.enskog_collision_frequency(dim, n / length ** dim, 2.0 * radius, t, mass))
    except SceneError:
        return math.nan


def plot(table: pd.DataFrame, key: str, folder: str) -> list[str]:
    """Draw Z against ``key`` with error bars beside theory, one figure per dimension and
    boundary (:func:`figure`); return the files written."""
    import os

    from gaz_cli.analysis import plots

    plots.make_folder(folder)
    written = []
    for (dim, boundary), whole in table.groupby(["DIM", "BOUNDARY"]):
        path = os.path.join(folder, f"vs_{key}_{int(dim)}d_{boundary}.png")
        plots.save(figure(whole, key), path, dpi=120)
        written.append(path)
    return written


def figure(whole: pd.DataFrame, key: str):
    """The figure of :func:`plot` for the rows of one dimension and boundary (a matplotlib Figure).

    One series per scene (column SCENE), in its own colour: measured Z (filled
    circles, error bars) and each point's own finite-box theory (open squares).
    Against the packing fraction the equation of state's curve Z(eta) (Tonks,
    Kolafa-Rottner or KLM) in the theory style (:data:`gaz_cli.analysis.plots.THEORY`,
    black dashed) and the ideal gas Z = 1 (:data:`gaz_cli.analysis.plots.IDEAL`).
    """
    from gaz_cli.analysis import plots

    plt = plots._pyplot()
    col = key.upper()
    dim, boundary = int(whole.DIM.iloc[0]), whole.BOUNDARY.iloc[0]
    fig, (ax, dev) = plt.subplots(2, 1, figsize=(6, 5.6), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    lo, hi = int(whole.RUNS.min()), int(whole.RUNS.max())
    seeds = f"{lo}" if lo == hi else f"{lo}-{hi}"
    series = list(whole.groupby("SCENE", sort=False)) if "SCENE" in whole else [("", whole)]
    for k, (name, g) in enumerate(series):  # one scene apart from the key: one series
        color = plots.series_color(k)
        ax.errorbar(g[col], g.Z, yerr=g.Z_ERR.fillna(0), fmt="o", color=color, capsize=3,
                    label=f"{name}: measured" if name else f"measured (mean of {seeds} seeds, ±1σ)")
        ax.plot(g[col], g.Z_THEORY, "s", mfc="none", color=color,
                label=f"{name}: theory" if name else "theory for each scene")
        dev.plot(g[col], g.Z_DEV_SIGMA, "o", color=color)
    if key == "packing":
        eta = np.linspace(0.0, float(whole[col].max()) * 1.05, 200)
        model = {1: "Tonks", 2: "Kolafa-Rottner", 3: "KLM"}[dim]
        ax.plot(eta, theory.compressibility_factor(dim, eta), **plots.THEORY, label=f"{model} (bulk)")
        dev.set_xlabel("packing fraction η")
    else:
        dev.set_xlabel(f"{key} ({KEYS[key]})")
    ax.axhline(1.0, **plots.IDEAL, label="ideal gas")
    ax.set_ylabel(r"$Z = PV/(N k_\mathrm{B} T)$")
    ax.set_title(f"{dim}D, {boundary}: compressibility factor against {key}")
    ax.legend(fontsize=8)
    dev.axhspan(-3, 3, color="0.85", alpha=0.5, lw=0, label="±3σ")
    dev.axhline(0.0, color="grey", lw=0.8)
    dev.set_ylabel("(Z − theory)/σ")
    top = float(np.nanmax(np.abs(whole.Z_DEV_SIGMA.to_numpy(dtype=float)), initial=0.0))
    dev.set_ylim(-max(4.0, 1.2 * top), max(4.0, 1.2 * top))
    dev.legend(fontsize=8, loc="upper right")
    return fig
