"""The fast exact engine: event-driven hard rods, disks and spheres.

``run(scene, state, recorder) -> RunStats`` is the whole interface (the same
as every engine's). :mod:`gaz_cli.engine.driver` is the Python layer
(validation, allocation, recording, snapshots); :mod:`gaz_cli.engine.kernels`
holds the Numba kernels (cell lists, calendar queue, event loop).
"""

from gaz_cli.engine.driver import run

__all__ = ["run"]
