"""Checks of a scene's own fields, each raising a :class:`SceneError` that names the field, the
value, the allowed range and the fix; and the ranges double precision carries.

:func:`check_fields` is the model's part of the door (:func:`gaz_cli.scenes.validate.validate`):
types and ranges of every field of a :class:`~gaz_cli.model.scene.Scene`, with no engine, no
placement and no disk. A message names fields between backquotes (:func:`field_error`), so
that the CLI can show its flags instead.
"""

from __future__ import annotations

import math
import numbers
import re
import sys

import numpy as np

from gaz_cli.constants import K_B
from gaz_cli.errors import SceneError
from gaz_cli.model.scene import ALL, OPTIONS, Scene
from gaz_cli.model.species import NAME_MAX, NAME_SEPARATORS, Species, builtin_named

# --- what double precision carries through the formulas --------------------------------------

# --- what double precision carries through the formulas --------------------------------------
HEADROOM = 1e16
"""Margin kept below overflow and above underflow: sums over up to 10^16 terms (energies,
momenta) and a product or two beyond the ones checked stay finite and normal."""

HUGE = sys.float_info.max / HEADROOM
"""Largest value (about 1.8e292) a checked square or product may reach."""

TINY = sys.float_info.min * HEADROOM
"""Smallest nonzero value (about 2.2e-292) a checked square or product may reach: below
sys.float_info.min numbers lose precision (subnormal), then round to 0."""

SPEED_TAIL = 10.0
"""Largest speed considered, in units of sqrt(k_B T / m): a Maxwell sample of 10^20
particles stays below it."""

MAX_COUNT = 2 ** 63 - 1
"""Largest particle count: the engines index particles with int64."""

_MARK = re.compile(r"`([^`]+)`")


def field_error(marked: str) -> SceneError:
    """A SceneError whose message names scene fields between backquotes: `drag`.

    ``str()`` shows the field names as they are (the keys of a scene file, the arguments of
    :class:`Scene`); ``err.marked`` keeps the marks, so that the CLI can show its flags
    instead (gaz_cli.scenes.options.FLAGS, in one place).
    """
    err = SceneError(_MARK.sub(r"\1", marked))
    err.marked = marked
    return err


def render(err: BaseException, names: dict) -> str:
    """The message of ``err`` with each marked field renamed through ``names`` (others kept)."""
    marked = getattr(err, "marked", None)
    if marked is None:
        return str(err)
    return _MARK.sub(lambda m: names.get(m.group(1), m.group(1)), marked)


def is_real(name: str, value) -> bool:
    """A real number (int or float, not bool)?"""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def check_number(name: str, value, unit: str = "") -> None:
    if not is_real(name, value):
        raise field_error(f"`{name}` {value!r} is not a number" + (f" ({unit})" if unit else ""))


def check_positive(name: str, value, hint: str = "") -> None:
    check_number(name, value)
    if not np.isfinite(value) or value <= 0:
        raise field_error(f"`{name}` must be a positive number, got {value}{hint}")


def check_at_least_zero(name: str, value, unit: str) -> None:
    check_number(name, value, unit)
    if not math.isfinite(value) or value < 0:
        raise field_error(f"`{name}` {value} is outside [0, inf) {unit}; give a finite number >= 0")


def check_unit_interval(name: str, value, what: str) -> None:
    check_number(name, value)
    if not 0.0 <= value <= 1.0:
        raise field_error(f"`{name}` {value} is outside [0, 1] ({what}: 1 elastic, 0 fully damped)")


def check_one_of(name: str, value, allowed) -> None:
    if value not in allowed:
        raise field_error(f"`{name}` {value!r} is not one of {', '.join(allowed)}")


def check_option(name: str, value) -> None:
    """``value`` within the range of scene option ``name`` (its :class:`~gaz_cli.model.scene.Option`
    row's rule); SceneError naming the field, the value, the range and the fix. An option
    whose rule is None has a check of its own (dim, seed, gravity, planes)."""
    rule = OPTIONS[name].rule
    if rule is None:
        return
    kind, *args = rule
    if kind == "positive":
        check_positive(name, value, *args)
    elif kind == "at least zero":
        check_at_least_zero(name, value, *args)
    elif kind == "unit interval":
        check_unit_interval(name, value, *args)
    elif kind == "one of":
        check_one_of(name, value, *args)
    elif kind == "whole at least zero":
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
            raise field_error(f"`{name}` {value!r} is not a whole number >= 0 ({args[0]})")
    elif kind == "bool":
        if not isinstance(value, bool):
            raise field_error(f"`{name}` {value!r} is not true or false")
    else:
        raise ValueError(f"scene option {name!r}: unknown rule {kind!r}")


def check_fields(scene: Scene) -> None:
    """The scene's own fields, each in its range; raise :class:`SceneError` naming the field, the
    value, the allowed range and the fix. No engine, placement or disk is consulted: the door
    (:func:`gaz_cli.scenes.validate.validate`) adds those checks after this one.

    In order: dimension, engine name, placement; counts, species, box, duration, temperature;
    boundary, recording, restitution, gravity, seed; then every other option of
    :data:`~gaz_cli.model.scene.OPTIONS` that applies to every engine, by its rule
    (:func:`check_option`).
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"expected a Scene, got {type(scene).__name__}")
    if isinstance(scene.dim, bool) or scene.dim not in (1, 2, 3):
        raise field_error(f"`dim` {scene.dim!r} is not 1, 2 or 3")
    check_option("engine", scene.engine)
    check_option("placement", scene.placement)
    if scene.placement == "rapid" and scene.dim != 1:
        raise field_error("`placement` rapid works in 1D only (the exam's Q10); use rejection, grow or lattice")
    if not isinstance(scene.components, (tuple, list)) or not scene.components:
        raise field_error("no particles: give `n` and `species` (or `radius` and `mass`)")
    for item in scene.components:
        if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], Species)):
            raise field_error(f"`species` entry {item!r} is not a (Species, count) pair")
    for sp, k in scene.components:
        check_count(k, None if len(scene.components) == 1 else sp.name)
    for name in ("length", "duration", "temperature"):
        check_option(name, getattr(scene, name))
    for sp, k in scene.components:
        check_species_name(sp.name)
        if not is_real("mass", sp.mass) or not np.isfinite(sp.mass) or sp.mass <= 0:
            raise field_error(f"`mass` of {sp.name} must be a positive number, got {sp.mass!r} (kg)")
        check_number("radius", sp.radius, "m")
        if not np.isfinite(sp.radius) or sp.radius < 0:
            raise field_error(f"`radius` of {sp.name} must be >= 0, got {sp.radius}")
        check_builtin_clash(sp)
        if 2 * sp.radius >= scene.length:
            raise field_error(f"a {sp.name} particle (diameter {2 * sp.radius:g} m) does not fit in "
                              f"the box of side {scene.length:g} m; raise `length`")
    for name in ("boundary", "record", "restitution"):
        check_option(name, getattr(scene, name))
    check_number("gravity", scene.gravity, "m/s^2")
    if not np.isfinite(scene.gravity) or scene.gravity < 0:
        raise field_error(f"`gravity` {scene.gravity} must be >= 0 (m/s^2, pulling towards -axis {scene.dim - 1})")
    if scene.gravity > 0 and scene.boundary == "periodic":
        raise field_error("`gravity` needs hard walls; drop `boundary` periodic")
    if scene.seed is not None:
        if not isinstance(scene.seed, numbers.Integral) or isinstance(scene.seed, bool):
            raise field_error(f"`seed` {scene.seed!r} is not a whole number")
        if not 0 <= scene.seed < 2 ** 63:
            raise field_error(f"`seed` {scene.seed} must be between 0 and 2^63 - 1")
    for name, row in OPTIONS.items():  # the rest, in the table's order (a new option is checked here)
        if row.engines == ALL:
            check_option(name, getattr(scene, name))


# --- the checks validate() composes --------------------------------------------------------------


def check_count(n, species: str | None = None) -> None:
    """A particle count is an integer in [1, MAX_COUNT]. ``species``: the name of the species
    counted, one of a mixture (None: the scene's one count, `n`)."""
    what = "`n`" if species is None else f"the `n` of {species}"
    if isinstance(n, bool) or not isinstance(n, numbers.Integral):
        raise field_error(f"{what} {n!r} is not a whole number")
    if n < 1:
        raise field_error(f"{what} must be at least 1, got {n}")
    if n > MAX_COUNT:
        raise field_error(f"{what} {n} is above {MAX_COUNT:.3g} (2^63 - 1), the largest count the "
                          f"engines' int64 indices hold; lower {what}")


def check_species_name(name) -> None:
    """A species name is 1 to NAME_MAX printable characters: what PARTICULE.PA_NOM holds on
    both backends (PostgreSQL refuses a longer one, and any NUL, at the end of the run)."""
    shown = repr(name) if len(repr(name)) <= 40 else repr(name)[:37] + "..."
    if not isinstance(name, str):
        raise field_error(f"species name {shown} is not text")
    if not name.strip():
        raise field_error(f"species name {shown} is empty; give the species a name")
    if len(name) > NAME_MAX:
        raise field_error(f"species name {shown} has {len(name)} characters, more than the {NAME_MAX} "
                          "the database's PARTICULE.PA_NOM holds; shorten it")
    if not name.isprintable():
        raise field_error(f"species name {shown} holds a control character (newline, tab, NUL...); "
                          "use printable characters only")
    if any(c in name for c in NAME_SEPARATORS):
        raise field_error(f"species name {shown} holds ',' or ':', which separate the entries of a mixture "
                          "(Ar:500,He:500); use another character, such as '-' or '_'")


def check_builtin_clash(sp: Species) -> None:
    """A custom species may not take a built-in species' name (PARTICULE would hold two rows of
    that name, and 'Ar' in a query or --species would be ambiguous) unless it is that species:
    the same mass and radius to the 1e-12 the stores match PARTICULE rows with."""
    builtin = builtin_named(sp.name)
    if builtin is None or (math.isclose(sp.mass, builtin.mass, rel_tol=1e-12, abs_tol=0)
                           and math.isclose(sp.radius, builtin.radius, rel_tol=1e-12, abs_tol=0)):
        return
    raise field_error(f"species name {sp.name!r} is the built-in {builtin.name} ({builtin.mass:.4g} kg, radius "
                      f"{builtin.radius:.3g} m), but this one has mass {sp.mass:.4g} kg and radius "
                      f"{sp.radius:.3g} m; give it another name, e.g. '{builtin.name}-custom', or drop "
                      "its mass and radius to use the built-in one")


def check_outside(what: str, value: float, lo: float, hi: float, unit: str, why: str, fix: str) -> None:
    if not lo <= value <= hi:
        side = "below" if value < lo else "above"
        raise field_error(f"{what} {value:.3g} {unit} is {side} the range [{lo:.2g}, {hi:.2g}] {unit} {why}; {fix}")


def length_range(dim: int) -> tuple[float, float]:
    """(lo, hi) box side, m: L^D and |dr|^2 within [TINY, HUGE]."""
    p = 1.0 / max(dim, 2)
    return TINY ** p, HUGE ** p


def radius_range() -> tuple[float, float]:
    """(lo, hi) nonzero radius, m: sigma^2 = (2R)^2 within [TINY, HUGE]."""
    return math.sqrt(TINY) / 2.0, math.sqrt(HUGE) / 2.0


def mass_range() -> tuple[float, float]:
    """(lo, hi) mass, kg: m_i m_j (the reduced mass m_i m_j / (m_i + m_j)) within [TINY, HUGE]."""
    return math.sqrt(TINY), math.sqrt(HUGE)


def speed_range(length: float, radii) -> tuple[float, float]:
    """(lo, hi) particle speed, m/s, that the pair and wall times carry in double precision.

    hi: v^2 and (L v)^2 (the |dr.dv|^2 of the pair-time discriminant) at most HUGE;
    lo: v^2 and (sigma v)^2 at least TINY, sigma the smallest nonzero diameter (else L).
    """
    sizes = [2.0 * r for r in radii if r > 0] or [length]
    return math.sqrt(TINY) / min(1.0, min(sizes)), math.sqrt(HUGE) / max(1.0, length)


def check_magnitudes(scene: Scene) -> None:
    """Box, radii, masses, temperature and gravity within what double precision carries.

    The ranges come from the formulas' squares and products: L^D, |dr|^2, sigma^2, m_i m_j,
    v^2, |dr.dv|^2 (see :data:`HUGE`, :data:`TINY`); speeds are the Maxwell tail
    SPEED_TAIL sqrt(k_B T / m) plus a fall across the box sqrt(2 g L).
    """
    lo, hi = length_range(scene.dim)
    check_outside("`length`", scene.length, lo, hi, "m",
             f"where L^{scene.dim} and |dr|^2 stay within double precision", "change `length`")
    rlo, rhi = radius_range()
    mlo, mhi = mass_range()
    for sp, _ in scene.components:
        if sp.radius > 0:
            check_outside(f"radius of {sp.name}", sp.radius, rlo, rhi, "m",
                     "where the contact distance squared stays within double precision",
                     "change the radius (or use 0 for point particles)")
        check_outside(f"mass of {sp.name}", sp.mass, mlo, mhi, "kg",
                 "where m_i m_j (the reduced mass of a collision) stays within double precision",
                 "change the mass")
    vlo, vhi = speed_range(scene.length, [sp.radius for sp, _ in scene.components])
    masses = [sp.mass for sp, _ in scene.components]
    # k_B T / m between vlo^2 (heaviest) and (vhi / SPEED_TAIL)^2 (lightest)
    tlo, thi = max(masses) * vlo ** 2 / K_B, min(masses) * (vhi / SPEED_TAIL) ** 2 / K_B
    check_outside("`temperature`", scene.temperature, tlo, thi, "K",
             f"where the particles' speeds (times the box, {scene.length:.3g} m) stay within double "
             "precision", "change `temperature`")
    ghi = (vhi / SPEED_TAIL) ** 2 / (2.0 * scene.length)
    if scene.gravity > ghi:
        check_outside("`gravity`", scene.gravity, 0.0, ghi, "m/s^2",
                 "where the speed of a fall across the box stays within double precision", "lower `gravity`")
