"""Numba settings in one place."""

import numba

njit = numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")
"""Decorator for serial kernels: compiled once, cached on disk, no fastmath (exactness first)."""

pnjit = numba.njit(parallel=True, cache=True, nogil=True, fastmath=False, error_model="numpy")
"""Decorator for kernels parallel over particles (prange); use only where it pays (measure)."""
