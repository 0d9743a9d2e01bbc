"""What a run is, with no engine and no disk.

:mod:`.scene` (the :class:`~gaz_cli.model.scene.Scene`, its table of options
:data:`~gaz_cli.model.scene.OPTIONS`, the :class:`~gaz_cli.model.scene.State`),
:mod:`.species` (the gases), :mod:`.checks` (each field in its range, and the ranges
double precision carries), :mod:`.estimates` (events, rows, steps and memory a run will
cost, from theory), :mod:`.recording` (the recorder interface every engine writes to).

Nothing here imports an engine, a store, an output or the placement; this ``__init__``
imports nothing, so that importing one module of the folder loads only that module.
"""
