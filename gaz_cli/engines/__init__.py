"""The engines: one contract, ``run(scene, state, recorder) -> RunStats``.

:mod:`.registry` names them and makes ``auto``'s choice, with its reason, and dispatches
to each engine's own checks of a scene (:func:`~gaz_cli.engines.registry.accepts`).
:mod:`.event` is the exact event-driven engine, :mod:`.step` the time-stepped one (seeds
002 and 003), :mod:`.ideal` wall bounces in closed form, :mod:`.reference` the exam's own
functions under their names. The engines know nothing of the database. This ``__init__``
imports nothing.
"""
