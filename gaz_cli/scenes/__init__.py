"""How a scene is written, read and admitted.

:mod:`.validate` is the one door every scene goes through (:func:`~gaz_cli.scenes.validate.validate`);
:mod:`.files` reads and writes TOML scene files; :mod:`.options` turns ``gaz simulate``'s
flags into a scene document; :mod:`.presets` are the packaged scene files (``comet.toml``,
``marbles.toml`` in this folder). This ``__init__`` imports nothing.
"""
