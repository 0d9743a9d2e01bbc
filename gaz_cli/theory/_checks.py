"""Argument checks shared by the theory modules: each raises SceneError with a one-line message."""

from __future__ import annotations

import numpy as np

from gaz_cli.errors import SceneError


# --------------------------------------------------------------------- checks


def _out(value):
    """A 0-d result as a Python float, arrays unchanged."""
    value = np.asarray(value, dtype=float)
    return float(value) if value.ndim == 0 else value


def _show(value) -> str:
    a = np.asarray(value)
    if a.size == 1:
        return f"{float(a.reshape(-1)[0]):.6g}"
    return f"values in [{np.nanmin(a):g}, {np.nanmax(a):g}] (NaN: {bool(np.isnan(a).any())})"


def _dim(dim) -> int:
    if isinstance(dim, bool) or not isinstance(dim, (int, np.integer)) or dim not in (1, 2, 3):
        raise SceneError(f"dimension must be the integer 1, 2 or 3, got {dim!r}")
    return int(dim)


def _positive(name: str, value, unit: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(a) & (a > 0.0)):
        raise SceneError(f"{name} must be a finite number > 0 {unit}, got {_show(value)}")
    return a


def _nonnegative(name: str, value, unit: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(a) & (a >= 0.0)):
        raise SceneError(f"{name} must be a finite number >= 0 {unit}, got {_show(value)}")
    return a

def _accessible(name: str, length, radius) -> np.ndarray:
    """The span a centre can reach, length - 2 radius, refused unless > 0 (``name``: the
    box's dimension as the message says it, e.g. "box length")."""
    inner = length - 2.0 * radius
    if not np.all(inner > 0.0):
        raise SceneError(f"{name} must exceed the particle diameter")
    return inner


def _packing(value, upper: float, inclusive: bool, what: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    ok = (a >= 0.0) & ((a <= upper) if inclusive else (a < upper))
    if not np.all(ok):
        bound = f"<= {upper:.5g}" if inclusive else f"< {upper:.5g}"
        raise SceneError(f"packing fraction must be >= 0 and {bound} for {what}, got {_show(value)}")
    return a


def _species(counts, radii) -> tuple[np.ndarray, np.ndarray]:
    """Per-species counts and radii as two 1-D arrays of equal length."""
    c = np.atleast_1d(_nonnegative("count", counts, "particles")).ravel()
    r = np.atleast_1d(_nonnegative("radius", radii, "m")).ravel()
    if c.size != r.size:
        raise SceneError(f"{c.size} counts for {r.size} radii: give one count per species")
    return c, r
