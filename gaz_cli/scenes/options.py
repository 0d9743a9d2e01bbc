"""``gaz simulate``'s options, turned into a scene: the CLI layer's half of the scene.

The command line, a scene file and a preset (a packaged scene file) all become one scene
document (the dict of :mod:`gaz_cli.scenes.files`): the file's (or preset's) keys, then the
flags given on the command line over them. That document goes through
:func:`gaz_cli.scenes.files.build`, hence :func:`gaz_cli.scenes.validate.validate`, like any other.

The library's messages name scene fields (`drag`); :data:`FLAGS` maps them to this
command line's flags, here and nowhere else (:func:`message`).
"""

from __future__ import annotations

import math

from gaz_cli.scenes import files as scenefile
from gaz_cli.errors import SceneError
from gaz_cli.model.checks import render
from gaz_cli.model.scene import OPTIONS, Scene
from gaz_cli.model.species import DEFAULT_SPECIES, parse_mixture, split_list

FLAGS = {**{name: row.flag for name, row in OPTIONS.items()},
         "n": "--n", "packing": "--packing", "species": "--species", "radius": "--radius", "mass": "--mass",
         "trajectory": "--trajectory", "every": "--every"}
"""Scene field -> ``gaz simulate`` flag (the one place the CLI names fields its own way): the
table of scene options (:data:`gaz_cli.model.scene.OPTIONS`), and the keys that are not Scene fields."""

SCALAR_FLAGS = tuple(name for name in scenefile.SCALARS if name != "force")
"""Flags that set the scene key of the same name (``--force`` and ``--plane`` are passed apart)."""

def message(err: BaseException, given=None) -> str:
    """An error's one line in the CLI's words: each marked field as its flag.

    ``given``: the fields set by flags when a scene file was read too; the others take their
    file key names (the user wrote them in the file: `n` is its [[species]] count). None:
    every field is a flag.
    """
    names = FLAGS if given is None else {**scenefile.FIELD_KEYS, **{k: v for k, v in FLAGS.items() if k in given}}
    return render(err, names)


def parse_plane(text: str, dim: int) -> tuple:
    """Parse ``--plane X,Y[,Z]:NX,NY[,NZ][:E]`` into (point, unit inward normal, restitution)."""
    parts = text.split(":")
    example = f"{','.join(['0'] * dim)}:{','.join(['0'] * (dim - 1) + ['1'])}:0.9"
    lists = [split_list(part, f"--plane {text!r}", example) for part in parts[:2]]
    try:
        point = tuple(float(v) for v in lists[0])
        normal = tuple(float(v) for v in lists[1])
        restitution = float(parts[2]) if len(parts) > 2 else 1.0
    except (IndexError, ValueError):
        raise SceneError(f"--plane {text!r} is not X,Y[,Z]:NX,NY[,NZ][:E]") from None
    if len(point) != dim or len(normal) != dim or len(parts) > 3:
        raise SceneError(f"--plane {text!r} needs {dim} coordinates for the point and the normal")
    norm = math.sqrt(sum(c * c for c in normal))
    if norm == 0 or not math.isfinite(norm):
        raise SceneError(f"--plane {text!r} has a zero normal")
    if not 0.0 <= restitution <= 1.0:
        raise SceneError(f"--plane {text!r}: restitution {restitution} is outside [0, 1]")
    return point, tuple(c / norm for c in normal), restitution


def _species_entries(base: list, n, species, radius, mass) -> list:
    """[[species]] after --n, --species, --radius/--mass over the file's (``base``)."""
    if (radius is None) != (mass is None):
        raise SceneError("--radius and --mass go together (a custom particle); or use --species")
    if radius is not None:
        if species is not None:
            raise SceneError("give either --species or --radius with --mass, not both")
        count = n if n is not None else (base[0]["count"] if len(base) == 1 else None)
        if count is None:
            raise SceneError("--n is required with --radius and --mass")
        return [{"name": "custom", "count": count, "mass": float(mass), "radius": float(radius)}]
    if species is not None:
        if n is None and "," not in species and ":" not in species and len(base) == 1:
            n = base[0]["count"]
        return [{"name": sp.name, "count": k} for sp, k in parse_mixture(species, n)]
    if n is not None:
        if not base:
            return [{"name": DEFAULT_SPECIES, "count": n}]
        if len(base) > 1:
            raise SceneError(f"--n {n} with a mixture of {len(base)} species: give the counts with "
                             "--species NAME:COUNT,...")
        return [{**base[0], "count": n}]
    if not base:
        raise SceneError("--n is required (or give counts, e.g. --species Ar:500,He:500)")
    return base


def document(*, scene_file=None, preset=None, n=None, species=None, radius=None, mass=None,
             planes=(), force=False, **flags) -> tuple[dict, set, str]:
    """The scene document of a command line: (doc, the fields the flags set, message prefix).

    ``flags``: the scalar options (:data:`SCALAR_FLAGS`), None when not given. With
    ``scene_file`` or ``preset`` the flags given override the file's keys; a scene with an
    initial state of its own (the presets) refuses the flags its state depends on.
    """
    unknown = set(flags) - set(SCALAR_FLAGS)
    if unknown:
        raise TypeError(f"unknown options {sorted(unknown)}")
    if scene_file is not None and preset is not None:
        raise SceneError("give a scene file or --preset NAME, not both")
    given = {k for k, v in flags.items() if v is not None}
    given |= {k for k, v in (("n", n), ("species", species), ("radius", radius), ("mass", mass)) if v is not None}
    if planes:
        given.add("planes")
    if force:
        given.add("force")
    if preset is not None:
        base, where = scenefile.preset_doc(preset), ""
    elif scene_file is not None:
        base, where = scenefile.read(scene_file), f"{scene_file}: "
    else:
        base, where, given = {}, "", None
    scenefile.check(base, where)
    if given:
        fixed = [FLAGS[k] for k in scenefile.fixed_by_initial(base, given)]
        if fixed:
            what = f"--preset {preset}" if preset else f"scene file {scene_file}"
            raise SceneError(f"{what} sets {', '.join(fixed)} itself (its initial state depends on "
                             f"{'it' if len(fixed) == 1 else 'them'}); drop {'it' if len(fixed) == 1 else 'them'}, "
                             "or describe the scene without its initial state")
    doc = dict(base)
    for key, value in flags.items():
        if value is not None:
            doc[key] = value
    if flags.get("length") is not None and flags.get("packing") is not None:
        raise SceneError("give --length or --packing, not both")
    if flags.get("length") is not None:
        doc.pop("packing", None)
    if flags.get("packing") is not None:
        doc.pop("length", None)
    if base and not base.get("species") and n is None and species is None and radius is None:
        raise SceneError(f"{where}no [[species]]: give at least one (name and count), or --n / --species")
    doc["species"] = _species_entries(list(base.get("species", [])), n, species, radius, mass)
    if "dim" not in doc or "duration" not in doc or ("length" not in doc and "packing" not in doc):
        missing = [FLAGS[k] + (" (or --packing)" if k == "length" else "") for k in ("dim", "length", "duration")
                   if k not in doc and not (k == "length" and "packing" in doc)]
        raise SceneError(f"missing {', '.join(missing)}; e.g. gaz simulate --dim 3 --n 1000 "
                         "--length 1e-7 --duration 1e-9")
    if planes:
        parsed = [parse_plane(p, doc["dim"]) for p in planes]
        doc["planes"] = [{"point": list(p), "normal": list(nrm), "restitution": e} for p, nrm, e in parsed]
    if force:
        doc["force"] = True
    if doc.get("engine", "event") == "step" and "dt" not in doc:
        raise SceneError("--engine step needs a time step --dt (seconds)")
    return doc, given, where


def from_options(**options) -> tuple[Scene, dict]:
    """Build and validate a Scene from ``gaz simulate``'s options; returns (scene, outputs).

    ``outputs``: the scene file's [output] table (db, trajectory, every, save_state), which
    the command line's own output flags override. Errors name the command line's flags for
    what the flags set, and the file's keys for what the file set.
    """
    doc, given, where = document(**options)
    try:
        return scenefile.build(doc, where)
    except SceneError as err:
        raise SceneError(message(err, given)) from None
