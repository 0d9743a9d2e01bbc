"""Scene files: a run described in TOML, read and written; the packaged presets.

A scene file holds everything ``gaz simulate`` takes (docs/reference/scene-file.md)::

    dim = 2
    length = 1e-7          # m (or: packing = 0.3, the length then follows)
    duration = 1e-9        # simulated s
    temperature = 300.0    # K
    seed = 1
    [[species]]
    name = "Ar"
    count = 100

Top-level keys are the fields of :class:`gaz_cli.model.scene.Scene`; ``[[species]]`` (name,
count, and mass and radius for a custom species), ``[[planes]]`` (point, normal,
restitution), ``[initial]`` (an explicit or preset initial state), ``[search]`` (the event
engine's partner search: neighbours, skin, classes; :data:`gaz_cli.engines.event.search.SEARCH`, kept in
``Scene.extras``) and ``[output]`` (db, trajectory, every, save_state) are tables.

A stored run's scene file (SCENE.SC_FILE, :func:`dumps`) runs it again with the same rows:
every field, the seed, and the search the run took: the settings it was given, and what it
left on 'auto' as resolved (:func:`gaz_cli.run.runner.with_search`; each search is exact but
rounds its own way, and a gas is chaotic: the rows differ between them); not what the run
derived otherwise (``engine_reason``). Reading checks the keys and their types
(unknown key, wrong type: one line naming the key, the value and what is allowed), then
builds the scene and passes it through :func:`gaz_cli.scenes.validate.validate`, the one door.

Writing uses a small writer of our own (:func:`dumps`): a scene is flat tables of scalars
and arrays, and our writer puts the unit of each key in a comment beside it, which the
TOML writing libraries (tomli-w) do not; :func:`loads` of :func:`dumps` gives the scene
back exactly (floats are written with ``repr``, which round-trips).
"""

from __future__ import annotations

import difflib
import json
import math
import os
import numbers
import sys
from dataclasses import fields, replace
from importlib import resources
from pathlib import Path

from gaz_cli.errors import SceneError
from gaz_cli.geometry import DENSEST, DENSEST_NAME, packing_fraction
from gaz_cli.engines.event.search import SEARCH
from gaz_cli.model.checks import field_error, render
from gaz_cli.model.estimates import default_tc
from gaz_cli.model.scene import ALL, OPTIONS, Scene
from gaz_cli.scenes.validate import validate
from gaz_cli.model.species import BUILTIN, Species, lookup

REAL, INT, STR, BOOL = "a number", "a whole number", "a string", "true or false"

KIND_WORDS = {"real": REAL, "int": INT, "str": STR, "bool": BOOL}
"""A scene option's kind (:class:`gaz_cli.model.scene.Option`) in a message's words."""

PACKING = (REAL, "packing fraction; the box side follows from it (instead of length)")
"""The one top-level key that is not a Scene field: the box side follows from it."""


def _scalars() -> dict:
    """Top-level key -> (type, the comment beside it): the scene options of every engine in the
    Scene's order (``packing`` after ``length``), then the step engine's; ``planes`` is a table."""
    rows = [o for o in OPTIONS.values() if o.engines == ALL] + [o for o in OPTIONS.values() if o.engines != ALL]
    out = {}
    for o in rows:
        if o.kind in KIND_WORDS:
            out[o.name] = (KIND_WORDS[o.kind], o.unit)
        if o.name == "length":
            out["packing"] = PACKING
    return out


SCALARS = _scalars()
"""Top-level key -> (type, unit or allowed values, for the comment beside it): from the table of
scene options, :data:`gaz_cli.model.scene.OPTIONS`."""
SPECIES_KEYS = {"name": STR, "count": INT, "mass": REAL, "radius": REAL}
PLANE_KEYS = {"point": "an array of numbers", "normal": "an array of numbers", "restitution": REAL}
OUTPUT_KEYS = {"db": STR, "trajectory": STR, "every": REAL, "save_state": STR}
SEARCH_KEYS = {key: (REAL if key == "skin" else STR) for key in SEARCH}
TABLES = ("species", "planes", "initial", "search", "output")
_TABLE_HEADERS = {"species": "[[species]]", "planes": "[[planes]]", "initial": "[initial]",
                  "search": "[search]", "output": "[output]"}
STEP_KEYS = tuple(name for name, o in OPTIONS.items() if o.engines == ("step",) and o.kind in KIND_WORDS)
"""The step engine's top-level keys, written only with ``engine = "step"``."""


# --- reading ---------------------------------------------------------------------------------
def _type_ok(kind: str, value) -> bool:
    if kind == REAL:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == INT:
        return isinstance(value, int) and not isinstance(value, bool)
    if kind == STR:
        return isinstance(value, str)
    if kind == BOOL:
        return isinstance(value, bool)
    return isinstance(value, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)


def _shown(value, width: int = 60) -> str:
    """``repr(value)``, cut to ``width`` characters: a message stays one short line."""
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."


def unknown_name(name, known, noun: str = "key", value=...) -> str:
    """"unknown key 'lenght' (= 1e-08; did you mean 'length'?)": the words for a ``name`` not
    among ``known`` (``value``: what the file gave it, when there is one), with the closest of
    ``known`` (:func:`difflib.get_close_matches`). The one place that tells a misspelt name its
    fix: a scene file's keys and tables, ``gaz sweep --vary``'s keys."""
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1)
    said = [f"= {_shown(value)}"] if value is not ... else []
    if close:
        said.append(f"did you mean {close[0]!r}?")
    return f"unknown {noun} {_shown(name)}" + (f" ({'; '.join(said)})" if said else "")


def _check_keys(table: dict, allowed: dict, where: str, tables: tuple = ()) -> None:
    """SceneError on a key of ``table`` not in ``allowed`` (or of the wrong type); the message
    suggests the closest of ``allowed`` and of ``tables`` (the tables that may sit beside the
    keys: a misspelt ``[[specie]]`` is told ``species``) and lists both."""
    for key, value in table.items():
        if key not in allowed:
            listed = "; tables: " + ", ".join(_TABLE_HEADERS[t] for t in tables) if tables else ""
            raise SceneError(f"{where}{unknown_name(key, [*allowed, *tables], 'key', value)}; "
                             f"allowed: {', '.join(allowed)}{listed}")
        kind = allowed[key][0] if isinstance(allowed[key], tuple) else allowed[key]
        if not _type_ok(kind, value):
            raise SceneError(f"{where}{key} = {_shown(value)} must be {kind}")


MAX_SCENE_BYTES = 64 << 20
"""The most a scene file may hold (64 MiB: an explicit state of about a million particles);
reading stops there, so that ``gaz simulate /dev/zero`` or a wrong file fails at once
instead of filling the memory."""


def read(path) -> dict:
    """The parsed TOML of a scene file (a dict); SceneError if unreadable, larger than
    :data:`MAX_SCENE_BYTES` or not TOML."""
    if not isinstance(path, (str, os.PathLike)):
        raise SceneError(f"scene file {path!r} is not a file path; give a path (text or pathlib.Path)")
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_SCENE_BYTES + 1)
    except OSError as err:
        raise SceneError(f"cannot read scene file {str(path)!r}: {err.strerror}") from None
    if len(data) > MAX_SCENE_BYTES:
        raise SceneError(f"scene file {str(path)!r} holds more than {MAX_SCENE_BYTES >> 20} MiB, the most "
                         "a scene file may hold; is it the right file?")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError(f"scene file {str(path)!r} is not UTF-8 text") from None
    if "\0" in text:
        raise SceneError(f"scene file {str(path)!r} is not text (it holds NUL bytes); is it the right file?")
    return parse(text, str(path))


def parse(text: str, name: str = "scene") -> dict:
    """The parsed TOML of ``text``; SceneError naming the line on a syntax error."""
    # imported here: a run from options alone parses no TOML (start-up, issue 15 item 4)
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{name} is not valid TOML: {err}") from None
    except RecursionError:  # tomllib parses nested arrays and inline tables recursively
        raise SceneError(f"{name}: arrays or tables nested too deeply for a scene file "
                         "(a scene nests two levels at most)") from None


def check(doc: dict, where: str = "") -> None:
    """Unknown keys and wrong types of a scene document (one line naming key and value)."""
    top = {k: v for k, v in doc.items() if k not in TABLES}
    _check_keys(top, SCALARS, where, TABLES)
    for key in TABLES:
        if key not in doc:
            continue
        value = doc[key]
        if key in ("species", "planes"):
            if not (isinstance(value, list) and all(isinstance(t, dict) for t in value)):
                raise SceneError(f"{where}{key} must be an array of tables ([[{key}]])")
            for k, t in enumerate(value):
                _check_keys(t, SPECIES_KEYS if key == "species" else PLANE_KEYS, f"{where}{key}[{k}]: ")
        elif not isinstance(value, dict):
            raise SceneError(f"{where}{key} must be a table ([{key}])")
        elif key == "output":
            _check_keys(value, OUTPUT_KEYS, f"{where}output: ")
            for name, path in value.items():
                if OUTPUT_KEYS[name] == STR and not path.strip():
                    raise SceneError(f"{where}output: {name} = {path!r} names no file; give a path, "
                                     f"or drop {name}")
        elif key == "search":
            _check_keys(value, SEARCH_KEYS, f"{where}search: ")


def _components(entries: list, where: str) -> tuple:
    if not entries:
        raise SceneError(f"{where}no [[species]]: give at least one, e.g. name = \"Ar\", count = 100")
    out = []
    for k, t in enumerate(entries):
        if "name" not in t or "count" not in t:
            raise SceneError(f"{where}species[{k}] needs a name and a count")
        custom = [key for key in ("mass", "radius") if key in t]
        if len(custom) == 1:
            raise SceneError(f"{where}species[{k}] ({t['name']}): mass and radius go together (a custom "
                             "species), or give neither for a built-in one")
        try:
            sp = Species(t["name"], float(t["mass"]), float(t["radius"])) if custom else lookup(t["name"])
        except SceneError:  # lookup's words are the command line's (--radius and --mass)
            raise SceneError(f"{where}species[{k}]: unknown species {_shown(t['name'])}; built in: "
                             f"{', '.join(BUILTIN)}; or give it mass (kg) and radius (m), a species of "
                             "your own") from None
        out.append((sp, t["count"]))
    names = [sp.name for sp, _ in out]
    if len(set(names)) != len(names):
        raise SceneError(f"{where}a species appears twice in [[species]]; merge the counts")
    return tuple(out)


def build(doc: dict, where: str = "") -> tuple[Scene, dict]:
    """(Scene, outputs) of a scene document (a parsed file, with any overrides merged in),
    validated by :func:`gaz_cli.scenes.validate.validate`. ``where`` prefixes the messages."""
    check(doc, where)
    for key in ("dim", "duration"):
        if key not in doc:
            raise SceneError(f"{where}missing {key}; a scene needs dim, duration, [[species]], and length or packing")
    components = _components(doc.get("species", []), where)
    values = {k: v for k, v in doc.items() if k in SCALARS and k != "packing"}
    if "packing" in doc:
        if "length" in doc:
            raise SceneError(f"{where}give length or packing, not both")
        eta = doc["packing"]
        if not (math.isfinite(eta) and eta > 0) or doc["dim"] not in (1, 2, 3):
            raise in_file_terms(field_error(f"`packing` = {eta!r} must be a positive number (and `dim` 1, 2 "
                                            "or 3)"), where)
        if eta >= DENSEST[doc["dim"]]:  # (scene.validate would ask for a lower n or a larger box)
            raise in_file_terms(field_error(f"`packing` {eta:.3g} is at or above {DENSEST[doc['dim']]:.4g}, "
                                            f"{DENSEST_NAME[doc['dim']]}; lower `packing`"), where)
        covered = packing_fraction(doc["dim"], [sp.radius for sp, _ in components], 1.0,
                                   [k for _, k in components])  # in a box of side 1 m: the volume, m^D
        values["length"] = (covered / eta) ** (1.0 / doc["dim"])
    elif "length" not in doc:
        raise SceneError(f"{where}missing length (or packing)")
    planes = tuple((tuple(p.get("point", ())), tuple(p.get("normal", ())), p.get("restitution", 1.0))
                   for p in doc.get("planes", []))
    for key in (name for name, o in OPTIONS.items() if o.kind == "real"):
        if key in values:
            values[key] = float(values[key])
    initial = doc.get("initial")
    search = dict(doc.get("search", {}))
    if _type_ok(REAL, search.get("skin")):
        search["skin"] = float(search["skin"])
    scene = Scene(components=components, planes=planes, initial=dict(initial) if initial else None,
                  extras=search, **values)
    try:
        scene = validate(scene)
        if "tc" not in doc and scene.restitution < 1.0:
            scene = replace(scene, tc=default_tc(scene))
    except SceneError as err:
        raise in_file_terms(err, where) from None
    return scene, dict(doc.get("output", {}))


FIXED_BY_INITIAL = ("dim", "length", "packing", "species", "radius", "mass", "temperature", "placement")
"""What a scene with an explicit or preset initial state fixes: its state depends on them, or
ignores them (temperature, placement: the state's velocities and positions come from it)."""


def fixed_by_initial(doc: dict, fields) -> list[str]:
    """Those of ``fields`` (scene fields; ``n`` the count of particles) that the scene document
    ``doc``'s ``[initial]`` state fixes (:data:`FIXED_BY_INITIAL`; ``n`` too for an explicit
    state, whose arrays hold one row per particle), in that order: given another value, the run
    would ignore it or refuse it. Empty without ``[initial]``. ``gaz simulate``'s flags and
    ``gaz sweep``'s ``--vary`` keys are refused by this one rule."""
    initial = doc.get("initial")
    if not initial:
        return []
    fixed = [k for k in FIXED_BY_INITIAL if k in fields]
    if "n" in fields and isinstance(initial, dict) and initial.get("kind") == "explicit":
        fixed.insert(0, "n")
    return fixed


FIELD_KEYS = {"n": "[[species]] count"}
"""Scene fields that are no key of a scene file -> what a scene file calls them."""


def in_file_terms(err: SceneError, where: str = "") -> SceneError:
    """``err`` of :func:`gaz_cli.scenes.validate.validate`, prefixed by ``where``, its fields named as a
    scene file names them (:data:`FIELD_KEYS`: `n` is the count of [[species]]); the marks are
    kept (``marked``) for the command line, which names its own flags."""
    marked = where + getattr(err, "marked", str(err))
    out = SceneError(render(field_error(marked), FIELD_KEYS))
    out.marked = marked
    return out


DEFAULT_DB = "gaz.db"
"""Where a run is stored when neither --db nor the scene file's [output] db says."""


def database(given: str | None, outputs: dict) -> str:
    """The database a scene file's runs go to: ``given`` (--db) when given, else the file's
    ``[output] db``, else :data:`DEFAULT_DB` (gaz simulate and gaz sweep alike)."""
    return given or outputs.get("db") or DEFAULT_DB


def load(path) -> tuple[Scene, dict]:
    """(Scene, outputs) of the scene file at ``path``."""
    return build(read(path), f"{path}: ")


def loads(text: str) -> tuple[Scene, dict]:
    """(Scene, outputs) of scene-file text."""
    return build(parse(text), "")


# --- presets: packaged scene files -------------------------------------------------------------
def presets() -> list[str]:
    """Names of the packaged scene files (``gaz simulate --preset NAME``)."""
    return sorted(p.name[:-5] for p in resources.files("gaz_cli.scenes").iterdir() if p.name.endswith(".toml"))


def preset_doc(name: str) -> dict:
    """The parsed packaged scene file ``name``; SceneError naming the presets if unknown."""
    names = presets()
    if name not in names:
        raise SceneError(f"--preset {name!r} is not one of {', '.join(names)}")
    return parse(resources.files("gaz_cli.scenes").joinpath(f"{name}.toml").read_text(encoding="utf-8"),
                 f"preset {name}")


# --- writing ---------------------------------------------------------------------------------
def to_doc(scene: Scene, outputs: dict | None = None) -> dict:
    """The scene document of ``scene`` (what :func:`build` turns back into the same scene).

    The step engine's keys are written only with ``engine = "step"``; a built-in species
    by its name, a custom one with its mass and radius; the search settings of ``extras``
    that were set (:data:`gaz_cli.engines.event.search.SEARCH`), not the derived ones.
    """
    doc = {}
    for f in fields(Scene):
        if f.name in ("components", "planes", "initial", "extras"):
            continue
        value = getattr(scene, f.name)
        if f.name in STEP_KEYS and scene.engine != "step":
            continue
        if value is None:
            continue
        doc[f.name] = value
    doc["species"] = [{"name": sp.name, "count": int(k)} if BUILTIN.get(sp.name) == sp else
                      {"name": sp.name, "count": int(k), "mass": sp.mass, "radius": sp.radius}
                      for sp, k in scene.components]
    if scene.planes:
        doc["planes"] = [{"point": list(p), "normal": list(n), "restitution": e} for p, n, e in scene.planes]
    if scene.initial:
        doc["initial"] = {k: (_listed(v) if not isinstance(v, str) else v) for k, v in scene.initial.items()}
    search = {k: scene.extras[k] for k in SEARCH if k in (scene.extras or {})}
    if search:
        doc["search"] = search
    if outputs:
        doc["output"] = {k: v for k, v in outputs.items() if v is not None}
    return doc


def _listed(v):
    try:
        import numpy as np

        return np.asarray(v).tolist()
    except Exception:  # noqa: BLE001 - a scalar
        return v


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        v = float(v)
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # a JSON string is a TOML basic string
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} in a scene file")


def require_scene(scene, path=None) -> None:
    """Raise SceneError (a ValueError) naming what was expected when ``scene`` is no Scene
    (the Python API's write_scene and scene_text; the command line always hands one)."""
    if isinstance(scene, Scene):
        return
    if isinstance(path, Scene):
        raise SceneError(f"write_scene(path, scene) was given a {type(path).__name__} first and a "
                         f"{type(scene).__name__} second: the path comes first")
    raise SceneError(f"expected a Scene (from gaz.make_scene or gaz.load_scene), got "
                     f"{type(scene).__name__} {_shown(scene, 40)}")


def dumps(scene: Scene, outputs: dict | None = None, comment: str | None = None) -> str:
    """The scene file of ``scene`` (and its outputs), units in comments."""
    require_scene(scene)
    doc = to_doc(scene, outputs)
    lines = [f"# {line}" for line in (comment or "gaz scene file (docs/reference/scene-file.md)").splitlines()]
    lines.append(f"# packing fraction {scene.packing_fraction:.6g}, {scene.n} particles")
    for key, value in doc.items():
        if key in TABLES:
            continue
        unit = SCALARS[key][1]
        lines.append(f"{key} = {_value(value)}  # {unit}")
    for key in ("species", "planes"):
        for table in doc.get(key, []):
            lines += ["", f"[[{key}]]"] + [f"{k} = {_value(v)}" for k, v in table.items()]
    for key in ("initial", "search", "output"):
        if key in doc:
            lines += ["", f"[{key}]"] + [f"{k} = {_value(v)}" for k, v in doc[key].items()]
    return "\n".join(lines) + "\n"


def write(path, scene: Scene, outputs: dict | None = None, shown=None) -> None:
    """Write the scene file of ``scene`` to ``path``, whole or not at all (:mod:`gaz_cli.atomic`);
    SceneError if it cannot be written. ``shown``: the name the messages give (``path`` a
    temporary name; None: ``path``, or ``shown`` itself when ``path`` is None)."""
    from gaz_cli import atomic

    shown = path if shown is None else shown
    require_scene(scene, shown)
    text = dumps(scene, outputs)
    try:
        if path is None:
            Path(shown).write_text(text, encoding="utf-8")
        else:
            atomic.write_text(path, text)
    except OSError as err:
        raise SceneError(f"cannot write scene file {str(shown)!r}: {err.strerror}") from None


def without_builtin_clash(text: str) -> str:
    """A stored scene file that runs today: ``text`` itself, unless a custom species of it bears a
    built-in name with other values (stored by a gaz older than that check,
    :func:`gaz_cli.model.checks.check_builtin_clash`, which now refuses the file): then the file with
    that species renamed NAME-custom (NAME-custom2... if taken), said in its heading comment
    and in a :class:`~gaz_cli.errors.GazWarning`. The run is the same (a name moves nothing):
    the same seed gives the same rows, its PARTICULE row named anew."""
    import warnings

    from gaz_cli.errors import GazWarning
    from gaz_cli.model.species import builtin_named

    try:
        doc = parse(text)
    except SceneError:
        return text
    tables = doc.get("species")
    if not isinstance(tables, list):
        return text
    names = {str(t.get("name")) for t in tables if isinstance(t, dict)}
    renamed = []
    for t in tables:
        if not (isinstance(t, dict) and isinstance(t.get("name"), str) and _type_ok(REAL, t.get("mass"))
                and _type_ok(REAL, t.get("radius"))):
            continue
        builtin = builtin_named(t["name"])
        if builtin is None or (math.isclose(t["mass"], builtin.mass, rel_tol=1e-12, abs_tol=0)
                               and math.isclose(t["radius"], builtin.radius, rel_tol=1e-12, abs_tol=0)):
            continue
        new = next(f"{t['name']}-custom{k if k > 1 else ''}" for k in range(1, len(names) + 2)
                   if f"{t['name']}-custom{k if k > 1 else ''}" not in names)
        names.add(new)
        renamed.append(f"species {t['name']!r} (mass {t['mass']:g} kg, radius {t['radius']:g} m) renamed {new!r}")
        t["name"] = new
    if not renamed:
        return text
    try:
        scene, outputs = build(doc)
    except SceneError:  # refused for another reason too: the file as stored, and its own refusal
        return text
    said = "; ".join(renamed)
    warnings.warn(f"{said}: a custom species may no longer bear a built-in name (the run is the same)",
                  GazWarning, stacklevel=2)
    return dumps(scene, outputs, comment=f"gaz scene file (docs/reference/scene-file.md)\n{said}: stored by an older gaz "
                                         "under a built-in name, which a custom species may no longer bear")
