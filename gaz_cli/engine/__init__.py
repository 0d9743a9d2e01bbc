"""The fast exact engine: event-driven hard rods, disks and spheres.

``run(scene, state, recorder) -> RunStats`` is the whole interface (the same
as every engine's). :mod:`gaz_cli.engine.driver` is the Python layer (checks, the
pump of kernel calls, restarts, recording, snapshots) with :mod:`.rows` (the arrays),
:mod:`.sizing` (cells, lists, calendar) and :mod:`.guards` (runaway runs); the Numba
kernels live by concept (:mod:`.layout`, :mod:`.dynamics`, :mod:`.interactions`,
:mod:`.boundaries`, :mod:`.neighbours`, :mod:`.calendar`, :mod:`.predict`,
:mod:`.records`, :mod:`.prefetch`, :mod:`.memory`) and :mod:`.loop` composes them into
the event loop; docs/architecture.md maps them.
"""

from gaz_cli.engine.driver import run

__all__ = ["run"]
