"""Running scenes: :mod:`.runner` (one scene: state, engine, recorders, store, summary) and
:mod:`.sweeps` (a scene file over a grid of values and seeds, on Dask). This ``__init__``
imports nothing.
"""
