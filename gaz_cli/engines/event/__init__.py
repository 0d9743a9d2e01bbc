"""The fast exact engine: event-driven hard rods, disks and spheres.

``run(scene, state, recorder) -> RunStats`` is the whole interface (the same
as every engine's). :mod:`gaz_cli.engines.event.driver` is the Python layer (checks, the
pump of kernel calls, restarts, recording, snapshots) with :mod:`.rows` (the arrays),
:mod:`.sizing` (cells, lists, calendar) and :mod:`.guards` (runaway runs); the Numba
kernels live by concept (:mod:`.layout`, :mod:`.dynamics`, :mod:`.interactions`,
:mod:`.boundaries`, :mod:`.neighbours`, :mod:`.calendar`, :mod:`.predict`,
:mod:`.records`, :mod:`.prefetch`, :mod:`.memory`) and :mod:`.loop` composes them into
the event loop; docs/architecture.md maps them.

``run`` loads the driver on first use (PEP 562): a module importing one kernel module
(placement takes the calendar's heap) does not load the whole engine.
"""

__all__ = ["run"]


def __getattr__(name):
    if name == "run":
        from gaz_cli.engines.event.driver import run

        globals()["run"] = run
        return run
    raise AttributeError(f"module 'gaz_cli.engines.event' has no attribute {name!r}")
