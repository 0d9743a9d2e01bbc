"""Numba settings in one place: the decorators of gaz's kernels.

``njit`` (serial kernels) and ``pnjit`` (kernels parallel over particles,
prange) compile once and keep the machine code in Numba's disk cache, with
no fastmath (exactness first).

Warm start. On its first cache load in a process, Numba's stock cache
"refreshes" the whole CPU context: it imports every extension registry
Numba ships (NumPy linear algebra, which imports ``scipy.linalg`` when SciPy
is installed; random generators; typed containers; jitclass...) and installs
them in its typing and lowering tables: 0.17 s, 0.35 s with SciPy (measured
on a 2-core machine, in warm starts of 0.45-0.8 s). Loading machine code
from the cache needs none of that: it is compiled already, and links only
against Numba's runtime (NRT), its C helpers and the math library (both
registered when the context is created) and the hash secret symbols of
``numba.cpython.hashing``. So gaz's dispatchers carry :class:`_WarmCache`,
the stock cache (same files, same keys) whose load starts the runtime,
registers those symbols and skips the refresh. A cache miss compiles as
before: Numba's compiler refreshes the context itself. Were the Numba
internals used here missing (another Numba version), the dispatchers get the
stock cache.
"""

from __future__ import annotations

import numba

_OPTIONS = {"nogil": True, "fastmath": False, "error_model": "numpy"}

try:  # Numba internals (0.59 to 0.68 at least); without them, the stock cache
    from numba.core.caching import FunctionCache
    from numba.core.dispatcher import Dispatcher
    from numba.core.runtime import rtsys

    for _owner, _name in ((FunctionCache, "_guard_against_spurious_io_errors"),
                          (FunctionCache, "_load_overload"), (rtsys, "initialize")):
        getattr(_owner, _name)
except (ImportError, AttributeError):  # pragma: no cover - depends on the Numba version
    FunctionCache = Dispatcher = None


if FunctionCache is not None:
    class _WarmCache(FunctionCache):
        """Numba's function cache, loading without the context refresh (see the module docstring)."""

        def load_overload(self, sig, target_context):
            rtsys.initialize(target_context)  # a no-op once the runtime is up
            import numba.cpython.hashing  # noqa: F401  (registers the hash secret symbols)

            with self._guard_against_spurious_io_errors():
                return self._load_overload(sig, target_context)
            return None  # an IO error was swallowed: compile instead


def _decorator(**options):
    """A decorator like ``numba.njit(cache=True, **options)``, with :class:`_WarmCache` as the cache."""
    jit = numba.njit(cache=False, **options)

    def decorate(fn):
        disp = jit(fn)
        if Dispatcher is not None and isinstance(disp, Dispatcher):
            disp._cache = _WarmCache(disp.py_func)
        elif hasattr(disp, "enable_caching"):  # the stock cache
            disp.enable_caching()
        return disp  # (with NUMBA_DISABLE_JIT, the plain function)

    return decorate


njit = _decorator(**_OPTIONS)
"""Decorator for serial kernels: compiled once, cached on disk, no fastmath (exactness first)."""

pnjit = _decorator(parallel=True, **_OPTIONS)
"""Decorator for kernels parallel over particles (prange); use only where it pays (measure)."""
