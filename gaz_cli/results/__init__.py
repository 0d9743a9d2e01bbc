"""The database, and nothing of physics.

:mod:`.schema` (tables, columns, versions), :mod:`.migrations`, :mod:`.rows` (the one
mapping from a run to its rows, used by both writers), :mod:`.sqlite` and
:mod:`.postgres` (the writers), :mod:`.staging` (a run's rows until its commit),
:mod:`.store` (open by path or URL, read back), :mod:`.writer`, :mod:`.queries` (the
packaged SQL), :mod:`.budgets` (disk space and 32-bit row numbers, checked before a run).
This ``__init__`` imports nothing.
"""
