"""The seeds' ready-made scenes, as Python calls: ``PRESETS[name](**keys) -> (Scene, State)``.

A preset is a packaged scene file (``gaz_cli/scenes/NAME.toml``, read by
:mod:`gaz_cli.scenes.files`; ``gaz simulate --preset NAME``): comet (seed 003, the Earth and a
comet, an explicit initial state) and marbles (seed 002, marbles dropped on a ramp, placed
in the upper half of the box). The keyword arguments override the file's top-level keys
(``seed``, ``duration``, ``dt``...) and ``n`` the count of a single-species preset; the
state is :func:`gaz_cli.placement.initial.initial_state` of the scene, so it follows the seed.
"""

from __future__ import annotations

from gaz_cli.scenes import files as scenefile
from gaz_cli.model.scene import Scene, State
from gaz_cli.placement.initial import initial_state

G_NEWTON = 6.674e-11
"""Newtonian constant of gravitation, m^3 kg^-1 s^-2 (CODATA 2018: 6.67430e-11); comet.toml's pair_gravity."""


def preset(name: str, n: int | None = None, **keys) -> tuple[Scene, State]:
    """(Scene, initial State) of the packaged scene file ``name``, with ``keys`` over its own."""
    doc = scenefile.preset_doc(name)
    doc.update(keys)
    if n is not None:
        doc["species"] = [{**doc["species"][0], "count": n}] if len(doc["species"]) == 1 else doc["species"]
    scene, _ = scenefile.build(doc)
    return scene, initial_state(scene)


PRESETS = {name: (lambda name: lambda **keys: preset(name, **keys))(name) for name in scenefile.presets()}
"""Preset name -> callable(**keys) returning (Scene, State)."""
