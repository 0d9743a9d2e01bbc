"""Numba settings in one place."""

import numba

njit = numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")
"""Decorator for serial kernels: compiled once, cached on disk, no fastmath (exactness first)."""
