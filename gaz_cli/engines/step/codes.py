"""Status codes, counters, phase clocks and round-off tolerances shared by the step kernels,
and the helpers any kernel may need: the monotonic clock and buffer growth.
"""

from __future__ import annotations

import numpy as np
from numba import types

from gaz_cli.numba_config import njit


# status codes of _run_steps
DONE = 0
"""All requested steps were run."""
FLUSH = 1
"""Stopped early: the event buffers are full enough to be handed to the recorder."""
PAUSE = 2
"""Stopped early: the call's wall-clock deadline passed (control goes back to Python, so that
Ctrl-C is seen within a slice)."""

# counters (int64 array) of _run_steps
C_BOUNCES, C_COLLISIONS, C_PASSES, C_PASS_LIMIT, C_PLANE, C_MAX_PASSES, C_PAIR_EVALS, C_STEPS = range(8)
C_OVERLAP_STEPS, C_OVERLAP_PAIRS, C_OVERLAP_MAX = range(8, 11)
"""Steps that ended with overlapping pairs, such pairs summed over the steps, the most at one
step end."""
C_FOLDED = 11
"""Bounces of long series of hops on a floor that got no row of their own (see MAX_HOP_ROWS)."""
N_COUNTERS = 12
MAX_HOP_ROWS = 1000
"""Rows a series of hops on a floor after one contact gets within a step, each bounce its own
row; a longer series (hops shorter than dt / 1000: a ball barely off an elastic floor, whose
hops round-off can make arbitrarily short) puts the bounces beyond in its last row, their
momentum summed (counted in C_FOLDED)."""
G_CLOSEST, G_FIRST_TIME = range(2)
"""The float overlap record (2,): smallest |dr| / sigma at a step end, time of the first step
end with an overlapping pair (s; initialise with 1.0 and nan)."""
OVERLAP_TOL = 0.01
"""A pair counts as left overlapping when, at the first contact pass of a step (all particles
drifted), it is closer than (1 - OVERLAP_TOL) sigma and the contact rule leaves it alone
(overlapping and separating): it stays so at the step's end unless a later pass moves one of
the two. Contacts
found are resolved to round-off, but the overlap rule misses grazing ones that enter and leave
the contact distance within one step, whatever dt: with a relative displacement l = |dv| dt per
step they end at most l^2 / (8 sigma) deep (a chord of length l), so a 1% overlap means the
particles move about 0.3 sigma relative to each other in a step: dt is too long."""
LIFT_ROUND_OFF = 64.0 * 2.220446049250313e-16
"""Round-off of the normal part of a line of centres, per (largest coordinate / centres'
distance): two balls a wall holds sit on it to a few ulps of their coordinates, so their line
of centres is parallel to it within a few eps x |x| / sigma (64 eps leaves room for the
projections and differences); a collision between them lifts neither (:func:`gaz_cli.engines.step.resting._wall_takes`)."""
SPEED_ROUND_OFF = 4.0 * 2.220446049250313e-16
"""Round-off of a relative velocity, per the particles' speeds |v_i| + |v_j|: the difference of
two velocities is exact to eps of their size, and an impulse below an ulp of them changes
nothing. A pair approaching no faster than that is at rest against each other (a stack's balls,
both held: with restitution 0 they met again pass after pass at 4e-19 m/s until the pass limit,
and the stack sank by 0.02 R in 1 s at dt 1e-3)."""
SWEEP_BOUNCES = 1 << 20
"""Box-wall bounces of one particle in the safety net after the pass limit (:func:`gaz_cli.engines.step.walls._walls_sweep`):
a particle crossing the box that many times in one step is put back on the wall."""
# phase clocks (float64 array, seconds)
T_PUSH, T_COLLISIONS, T_WALLS, T_EXCHANGE = range(4)
N_TIMERS = 4

_clock_gettime = types.ExternalFunction("clock_gettime", types.int32(types.int32, types.voidptr))


@njit
def _now(clock_id, buf):
    """Monotonic clock, s; ``buf`` (2,) int64 scratch; clock_id < 0 disables timing (returns 0)."""
    if clock_id < 0:
        return 0.0
    _clock_gettime(clock_id, buf.ctypes.data)
    return buf[0] + 1e-9 * buf[1]


@njit
def _grow_f(a):
    """Double the rows of a 2D float64 buffer, keeping its content."""
    out = np.empty((2 * a.shape[0] + 16, a.shape[1]), dtype=np.float64)
    out[: a.shape[0]] = a
    return out


@njit
def _grow_i(a):
    """Double the rows of a 2D int64 buffer, keeping its content."""
    out = np.empty((2 * a.shape[0] + 16, a.shape[1]), dtype=np.int64)
    out[: a.shape[0]] = a
    return out
