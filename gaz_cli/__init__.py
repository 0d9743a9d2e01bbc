"""gaz: hard-sphere gases in a box, every wall bounce in a SQL database.

The Python API (docs/tutorials/python.md): :func:`make_scene`, :func:`load_scene`,
:func:`write_scene`, :func:`simulate`, :func:`open_store`, :func:`analyse`, :func:`sweep`,
:func:`versus`; :mod:`theory` (``gaz.theory``: the equations of state, wall models and rates
that ``analyse`` compares with, SI units); the types
:class:`Scene`, :class:`Species`, :class:`State`, :class:`Run`, and the exceptions of
:mod:`gaz_cli.errors` (:class:`GazError`, the base of :class:`SceneError`,
:class:`StoreError`, :class:`PlacementError`, :class:`OutputError`, :class:`EngineError`,
:class:`QueryError`; :class:`Interrupted`; the warning :class:`GazWarning`). They load on first use (PEP 562), so
``import gaz_cli`` itself imports nothing heavy (no numpy, pandas, SQLAlchemy, matplotlib).
"""

__version__ = "0.1.0"

_LAZY = {
    "make_scene": "gaz_cli.api", "load_scene": "gaz_cli.api", "write_scene": "gaz_cli.api",
    "scene_text": "gaz_cli.api", "simulate": "gaz_cli.api", "open_store": "gaz_cli.api",
    "analyse": "gaz_cli.api", "sweep": "gaz_cli.api", "versus": "gaz_cli.api", "Run": "gaz_cli.run.runner", "Scene": "gaz_cli.model.scene", "State": "gaz_cli.model.scene",
    "Species": "gaz_cli.model.species",
    **{name: "gaz_cli.errors" for name in ("GazError", "SceneError", "StoreError", "PlacementError", "OutputError",
                                           "EngineError", "QueryError", "Interrupted", "GazWarning")},
}
__all__ = ["__version__", "theory", *_LAZY]


def __getattr__(name):
    if name == "theory":  # a module, not a name in one
        import importlib

        return importlib.import_module("gaz_cli.theory")
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'gaz_cli' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
