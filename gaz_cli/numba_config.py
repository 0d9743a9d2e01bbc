"""Numba settings in one place: the decorators of gaz's kernels.

``njit`` (serial kernels) and ``pnjit`` (kernels parallel over particles,
prange) compile once and keep the machine code in Numba's disk cache
(``cache=True``), with no fastmath (exactness first) and NumPy's error model
(a division by zero gives inf or nan, which the kernels test for, instead of
raising inside a loop).

Only Numba's public options are used. (An earlier version swapped in a
subclass of Numba's private cache class to skip the context refresh of the
first cache load, 0.2-0.35 s of a warm start; it tied gaz to one Numba
version and is gone.)
"""

from __future__ import annotations

import numba

_OPTIONS = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy"}

njit = numba.njit(**_OPTIONS)
"""Decorator for serial kernels: compiled once, cached on disk, no fastmath (exactness first)."""

pnjit = numba.njit(parallel=True, **_OPTIONS)
"""Decorator for kernels parallel over particles (prange); use only where it pays (measure)."""
