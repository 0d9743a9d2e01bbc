"""The event engine's partner-search settings a scene may hold (a scene file's ``[search]``),
and the scenes the event engine accepts. Pure Python: no compiled code is loaded.
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.model.checks import field_error, is_real
from gaz_cli.model.scene import Scene

SEARCH = {
    "neighbours": ("auto", "cells", "lists", "dilute", "wide"),
    "classes": ("auto", "off"),
    "skin": "neighbour-list skin, in largest diameters, > 0",
}
"""The event engine's search settings a scene may hold in ``extras`` (absent: 'auto' and
:data:`gaz_cli.engines.event.sizing.NEIGHBOUR_SKIN`): cell lists, neighbour lists or, with walls,
the dilute scan of every particle; size classes or one cell grid; the lists' skin."""

STRAIGHT_SEARCHES = ("dilute", "wide")
"""Searches built for straight flights, without gravity (their float32 pass bounds a flight up
to its horizon: the next wall bounce, or for wide cells in a periodic box the next wrap; see
gaz_cli.engines.event.neighbours.dilute and .wide). The dilute scan needs walls too; wide cells in a
periodic box need it 3 diameters wide or more (PERIODIC_WIDE_CELLS cells an axis). Forced on
another scene they used to give way to cells in silence; they are refused instead. (A 1D
run ignores ``[search]`` whatever it holds: rods only meet their two neighbours.)"""

PERIODIC_WIDE_CELLS = 3
"""Wide cells in a periodic box: at least this many an axis, each a diameter wide or more, so
that each of the 3^D cells around a particle is a different cell (gaz_cli.engines.event.sizing)."""


def search_given(extras: dict) -> list[str]:
    """The search settings of ``extras`` (:data:`SEARCH`) set to something other than 'auto'."""
    return [key for key in SEARCH if key in extras and extras[key] != "auto"]


def check_search(scene: Scene) -> None:
    """The event engine's search settings (a scene file's ``[search]`` table): each in its range,
    and only with ``engine`` event, the one engine that searches for partners (``auto`` takes
    it when one is set, :func:`gaz_cli.engines.registry.choose`)."""
    extras = scene.extras
    for key, allowed in SEARCH.items():
        if key not in extras:
            continue
        value = extras[key]
        if key == "skin":
            if not is_real("skin", value) or not math.isfinite(value) or value <= 0:
                raise field_error(f"[search] `skin` {value!r} must be a positive number ({allowed})")
        elif value not in allowed:
            raise field_error(f"[search] `{key}` {value!r} is not one of {', '.join(allowed)}")
    given = search_given(extras)
    if given and scene.engine != "event":
        key = given[0]
        raise field_error(f"[search] `{key}` {extras[key]!r} applies to `engine` event only (the {scene.engine} "
                          f"engine does not search for partners and would ignore it); set `engine` event, "
                          f"or drop `{key}` from [search]")
    chosen = extras.get("neighbours")
    if chosen in STRAIGHT_SEARCHES:
        periodic = scene.boundary == "periodic" and chosen == "dilute"
        unfit = [why for why, bad in (("periodic", periodic),
                                      ("under gravity", scene.gravity != 0)) if bad]
        if unfit:
            where = "a box with walls" if chosen == "dilute" else "straight flights"
            raise field_error(f"`neighbours` {chosen!r} searches {where} and without gravity; "
                              f"this scene is {' and '.join(unfit)}: "
                              "use 'auto', 'cells' or 'lists'")
        rmax = float(np.max(scene.radii()))
        # (the sizing's count of cells a diameter wide or more: engine.sizing._most_wide_cells)
        diameters = scene.length / (2.0 * rmax * (1.0 + 1e-9)) if rmax > 0.0 else math.inf
        if chosen == "wide" and scene.boundary == "periodic" and diameters < PERIODIC_WIDE_CELLS:
            raise field_error(f"`neighbours` 'wide' needs a periodic box {PERIODIC_WIDE_CELLS} "
                              f"particle diameters wide or more (a cell a diameter wide or more, "
                              f"{PERIODIC_WIDE_CELLS} an axis); this one is {diameters:.3g}: "
                              "use 'auto' or 'cells', or raise `length`")


def check_event_scene(scene: Scene) -> None:
    """What the event engine needs of a scene beyond its search settings: a periodic box wider
    than two particle diameters (the minimum image of a pair must be unique)."""
    if scene.boundary == "periodic" and scene.n > 1:
        rmax = max(sp.radius for sp, _ in scene.components)
        if rmax > 0 and 4.0 * rmax >= scene.length:
            raise field_error(f"a periodic box must be wider than two particle diameters "
                              f"({4 * rmax:g} m), got `length` {scene.length:g}; raise `length`")
