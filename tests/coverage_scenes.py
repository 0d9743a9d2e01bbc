"""Scene classes for the coverage of analyse's error bars (tests/test_coverage.py, benchmarks/error_coverage.py).

Each class is a small scene run over many seeds; ``run_class`` returns, per
seed and quantity, (measured, error, theory) from :func:`gaz_cli.analysis.report`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import pandas as pd

from gaz_cli.analysis import errorbars
from gaz_cli.analysis import report as analysis
from gaz_cli.run import runner
from gaz_cli.constants import K_B
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import Species, lookup

KT = 1.0


def _radius(dim, n, packing, length=1.0):
    unit = {1: 2.0, 2: math.pi, 3: 4.0 * math.pi / 3.0}[dim]
    return (packing * length ** dim / (n * unit)) ** (1.0 / dim)


def _argon_side(dim, n, packing):
    """Box side (m) of n argon atoms at ``packing``."""
    return lookup("Ar").radius / _radius(dim, n, packing)


def _reduced(dim, n, packing, duration, **kw) -> Callable[[int], Scene]:
    species = Species("X", 1.0, _radius(dim, n, packing))
    return lambda seed: Scene(dim=dim, length=1.0, duration=duration, components=((species, n),),
                              temperature=KT / K_B, seed=seed, **kw)


@dataclass(frozen=True)
class SceneClass:
    description: str
    make: Callable[[int], Scene]
    reference: str
    """'theory': analyse's own theory is exact for the scene; 'seed mean': it is not, compare with the seeds' mean."""
    in_test: bool = True
    periodic: bool = False
    """No walls: the pressure is the virial's, and there are no wall-hit speeds."""
    dev: bool = False
    """The pressures' theory carries an error of its own (the EOS at the measured middle density of a
    box with walls): their z is analyse's DEV_SIGMA, which holds both errors (NaN where withheld)."""


def _mixture(dim, species, packing, duration, length_unit=1.0, **kw) -> Callable[[int], Scene]:
    """A mixture of built-in species (name, count) at ``packing``, SI units."""
    comps = tuple((lookup(name), k) for name, k in species)
    volume = sum(k * {1: 2.0, 2: math.pi, 3: 4.0 * math.pi / 3.0}[dim] * sp.radius ** dim for sp, k in comps)
    length = (volume / packing) ** (1.0 / dim)
    return lambda seed: Scene(dim=dim, length=length, duration=duration, components=comps, seed=seed, **kw)


CLASSES = {
    # the exam's own scene, issue 14: about 2 collisions per particle
    "exam": SceneClass("3D argon, N = 200, L = 1e-7 m, T = 4e-8 s (about 2 collisions per particle)",
                       lambda seed: Scene(dim=3, length=1e-7, duration=4e-8, components=((lookup("Ar"), 200),),
                                          seed=seed), "theory", in_test=False),
    "collisionless-3d": SceneClass("3D box, N = 100, packing 1e-5, 40 wall crossings, ~0.1 collision per particle",
                                   _reduced(3, 100, 1e-5, 40.0), "theory"),
    "dilute-3d": SceneClass("3D box, N = 150, packing 0.02, ~50 collisions per particle",
                            _reduced(3, 150, 0.02, 6.0), "seed mean"),
    "dense-2d": SceneClass("2D box, N = 120, packing 0.45, ~300 collisions per particle",
                           _reduced(2, 120, 0.45, 1.5), "seed mean"),
    # issue 38's classes (done-when), reduced units unless named
    "rods-ring-1d": SceneClass("1D periodic rods, N = 100, packing 0.3, --record all (exact finite-N ring)",
                               _reduced(1, 100, 0.3, 2.0, boundary="periodic", record="all"), "seed mean",
                               in_test=False, periodic=True),
    "rods-walls-1d": SceneClass("1D rods between walls, N = 100, packing 0.3 (Tonks, exact)",
                                _reduced(1, 100, 0.3, 5.0), "seed mean", in_test=False),
    "arxe-1d": SceneClass("1D Ar:Xe 50:50 between walls, packing 0.2, T = 2e-9 s",
                          _mixture(1, (("Ar", 50), ("Xe", 50)), 0.2, 2e-9), "seed mean", in_test=False),
    "hexe-3d-walls": SceneClass("3D He:Xe 100:100 at walls, packing 0.05, T = 1e-9 s (mixture at walls: "
                                "pressures refused, hit speeds judged)",
                                _mixture(3, (("He", 100), ("Xe", 100)), 0.05, 1e-9), "seed mean", in_test=False),
    "box-2d-n200": SceneClass("2D box with walls, N = 200, packing 0.2, ~1400 collisions per particle, against "
                              "the EOS at the measured middle density",
                              _reduced(2, 200, 0.2, 40.0), "theory", in_test=False, dev=True),
    "periodic-2d": SceneClass("2D periodic fluid, N = 500, packing 0.3, --record all",
                              _reduced(2, 500, 0.3, 1.0, boundary="periodic", record="all"), "seed mean",
                              in_test=False, periodic=True),
    "periodic-3d-dense": SceneClass("3D periodic fluid, N = 256, packing 0.45, --record all",
                                    _reduced(3, 256, 0.45, 1.0, boundary="periodic", record="all"), "seed mean",
                                    in_test=False, periodic=True),
    "crystal-3d": SceneClass("3D periodic FCC start, N = 500, packing 0.53, --record all (a solid)",
                             _reduced(3, 500, 0.53, 0.3, boundary="periodic", record="all"), "seed mean",
                             in_test=False, periodic=True),
    "mixture-3d-periodic": SceneClass("3D periodic He:Xe 60:60, packing 0.35, --record all, T = 1e-10 s "
                                      "(against KLM mapped onto the mixture)",
                                      _mixture(3, (("He", 60), ("Xe", 60)), 0.35, 1e-10, boundary="periodic",
                                               record="all"), "theory", in_test=False, periodic=True),
    "walls-2d-middle": SceneClass("2D argon box with walls, N = 500, packing 0.2, T = 2e-9 s (issue 38's), "
                                  "against the EOS at the measured middle density",
                                  lambda seed: Scene(dim=2, length=_argon_side(2, 500, 0.2), duration=2e-9,
                                                     components=((lookup("Ar"), 500),), seed=seed),
                                  "theory", in_test=False, dev=True),
    "periodic-3d": SceneClass("3D periodic fluid, N = 108, packing 0.3, --record all, ~60 collisions per particle",
                              _reduced(3, 108, 0.3, 1.0, boundary="periodic", record="all"), "seed mean",
                              periodic=True),
}


def run_class(name: str, seeds, db: str) -> pd.DataFrame:
    """Simulate every seed of class ``name`` into ``db``; one row per (seed, quantity) with measured, error, theory."""
    klass = CLASSES[name]
    rows = []
    for k, seed in enumerate(seeds, start=1):
        runner.simulate(klass.make(seed), db=db)
        frames = analysis.report(db, sim=k)
        models = frames["pressure against theory"]
        p = models.iloc[0]
        # theory: a model of the kinetic energy alone (the middle density's model has a noise of its own,
        # in DEV_SIGMA): the seeds' mean of measured/theory then tests P_ERR alone
        plain = models[~models.MODEL.str.contains("middle density")]
        ref = float(plain.P_THEORY.iloc[0]) if len(plain) else float(p.P_THEORY)
        rows.append({"seed": seed, "quantity": "mean pressure", "measured": p.P_MEASURED, "error": p.P_ERR,
                     "theory": ref, "dev": p.DEV_SIGMA, "dof": p.DOF})
        for w in frames["Q36 momentum and pressure per wall"].itertuples():
            rows.append({"seed": seed, "quantity": "wall pressure", "measured": w.P_MEASURED, "error": w.P_ERR,
                         "theory": ref if len(plain) and run_is_uniform(klass) else w.P_THEORY,
                         "wall": w.RE_DIR, "dev": w.DEV_SIGMA, "dof": w.DOF})
        speeds = frames.get("mean wall-hit speed against theory")
        if speeds is not None and len(speeds):
            everyone = speeds[speeds.SPECIES == "all (Q35)"]      # a mixture: Q35's mean over all the hits
            s = (everyone if len(everyone) else speeds).iloc[0]
            rows.append({"seed": seed, "quantity": "wall-hit speed", "measured": s.VITESSE_MOYENNE,
                         "error": s.ERR, "theory": s.THEORY, "dof": s.DOF})
        contact = frames.get("contact values per pair of species")
        if contact is not None and "G_ERR" in contact:
            for c in contact.itertuples():     # a periodic mixture with --record all: g_ij per pair
                rows.append({"seed": seed, "quantity": f"contact value {c.PAIR}", "measured": c.G_MEASURED,
                             "error": c.G_ERR, "theory": c.G_THEORY, "dof": c.DOF})
        coll = frames["collision rate against Enskog"].iloc[0]
        if math.isfinite(coll.RATE_ERR_HZ):
            rows.append({"seed": seed, "quantity": "collision rate", "measured": coll.RATE_PER_PARTICLE_HZ,
                         "error": coll.RATE_ERR_HZ, "theory": coll.THEORY_HZ, "dof": coll.DOF})
    frame = pd.DataFrame(rows)
    frame["class"] = name
    frame["reference"] = klass.reference
    frame["by_dev"] = klass.dev
    return frame


def run_is_uniform(klass: SceneClass) -> bool:
    """No gravity: every wall has the mean pressure's theory."""
    return klass.make(1).gravity <= 0.0


def z_scores(frame: pd.DataFrame, reference: str | None = None) -> pd.DataFrame:
    """Add column z = (measured - reference)/error; reference 'theory' or 'seed mean' (per quantity and wall)."""
    reference = reference or frame.reference.iloc[0]
    out = frame.copy()
    if reference == "theory":
        out["z"] = (out.measured - out.theory) / out.error
        if "dev" in out and "by_dev" in out and out.by_dev.iloc[0]:   # the theory's own error: analyse's deviation
            pressures = out.quantity.isin(PRESSURES)
            out.loc[pressures, "z"] = out.dev[pressures]
    else:
        # the seeds differ in total energy: compare measured/theory with its mean over the seeds
        key = ["quantity"] + (["wall"] if "wall" in out else [])
        keyed = out.fillna({"wall": 0}) if "wall" in out else out
        ratio = keyed.measured / keyed.theory
        n = ratio.groupby([keyed[k] for k in key]).transform("size")
        mean = ratio.groupby([keyed[k] for k in key]).transform("mean")
        out["z"] = (ratio - mean) * keyed.theory / out.error * np.sqrt(n / (n - 1))
    if "dof" in out:
        # judged as analyse judges a deviation: Student's t on the error's degrees of freedom, as the
        # normal deviate of the same tail probability (NaN below 4 degrees of freedom: withheld)
        by_dev = out.by_dev.astype(bool) if "by_dev" in out else False
        dev = ((reference == "theory") & by_dev & out.quantity.isin(PRESSURES)).to_numpy(dtype=bool)
        dof = out.dof.astype(float).fillna(np.inf).to_numpy()
        out.loc[~dev, "z"] = np.asarray(errorbars.normal_equivalent(out.z.to_numpy(dtype=float), dof))[~dev]
    return out


PRESSURES = ("mean pressure", "wall pressure")


def coverage_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Per quantity and reference: samples, fraction within 1 sigma and its binomial error, within 2 sigma, mean,
    rms and largest size of z."""
    rows = []
    for reference in ("theory", "seed mean"):
        z = z_scores(frame, reference)
        groups = list(z.groupby("quantity", sort=False))
        if "wall" in z:   # each wall on its own as well as pooled
            walls = z[z.quantity == "wall pressure"]
            groups += [(f"wall {int(w):+d} pressure", g) for w, g in walls.groupby("wall")]
        for q, g in groups:
            a = g.z.abs().dropna()
            p1 = float((a < 1).mean()) if a.size else float("nan")
            rows.append({"quantity": q, "reference": reference, "samples": a.size,
                         "within_1": p1, "binomial_1": math.sqrt(p1 * (1 - p1) / a.size) if a.size else p1,
                         "within_2": float((a < 2).mean()),
                         "mean_z": float(g.z.mean()), "rms_z": float(np.sqrt((g.z ** 2).mean())),
                         "max_abs_z": float(a.max()) if a.size else float("nan")})
    return pd.DataFrame(rows)
