"""What moves particles between events: free flight, with uniform gravity along axis D-1.

Rows are stamped: particle k's row holds its state at P[k, PT] (lazy update).
"""

from __future__ import annotations

from gaz_cli.engines.event.intrinsics import _inline
from gaz_cli.engines.event.layout import PT, PV
from gaz_cli.numba_config import njit

@njit
def _state_at(P, t, g, D, out_x, out_v):
    """Positions and velocities of every particle at time t (no change to the rows)."""
    n = P.shape[0]
    for k in range(n):
        dt = t - P[k, PT]
        for d in range(D):
            out_x[k, d] = P[k, d] + P[k, PV + d] * dt
            out_v[k, d] = P[k, PV + d]
        if g != 0.0:
            out_x[k, D - 1] -= 0.5 * g * dt * dt
            out_v[k, D - 1] -= g * dt


@_inline
def _advance(P, k, t, g, D, GRAV):
    """Particle k's row moved along its path to time t (free flight, or a parabola along
    axis D-1 under gravity g); its stamp becomes t. A row already at t is left as is."""
    dta = t - P[k, PT]
    if dta != 0.0:
        for a in range(D):
            P[k, a] += P[k, PV + a] * dta
        if GRAV:
            P[k, D - 1] -= 0.5 * g * dta * dta
            P[k, PV + D - 1] -= g * dta
        P[k, PT] = t


@_inline
def _relative_at(P, m, t, xk0, xk1, xk2, vk0, vk1, vk2, g, D, GRAV):
    """Position and velocity (dx0, dx1, dx2, dv0, dv1, dv2) of particle m at time t relative
    to a particle at x_k, v_k at t (m's row moved along its path; no periodic image taken;
    components beyond D are 0)."""
    dtm = t - P[m, PT]
    dx0 = P[m, 0] + P[m, PV] * dtm - xk0
    dv0 = P[m, PV] - vk0
    dx1 = 0.0
    dv1 = 0.0
    dx2 = 0.0
    dv2 = 0.0
    if D > 1:
        dx1 = P[m, 1] + P[m, PV + 1] * dtm - xk1
        dv1 = P[m, PV + 1] - vk1
    if D > 2:
        dx2 = P[m, 2] + P[m, PV + 2] * dtm - xk2
        dv2 = P[m, PV + 2] - vk2
    if GRAV:
        if D == 3:
            dx2 -= 0.5 * g * dtm * dtm
            dv2 -= g * dtm
        elif D == 2:
            dx1 -= 0.5 * g * dtm * dtm
            dv1 -= g * dtm
        else:
            dx0 -= 0.5 * g * dtm * dtm
            dv0 -= g * dtm
    return dx0, dx1, dx2, dv0, dv1, dv2
