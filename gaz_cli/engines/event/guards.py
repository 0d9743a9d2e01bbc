"""Runaway guards: a run that stops moving in time, whose event rate runs away or that slows
down beyond any sensible length ends with an EngineError instead of a hang."""

from __future__ import annotations

import math

from gaz_cli.errors import EngineError

STALL_CHUNKS = 3
STALL_RATE = 1e7
"""Runaway guard, checked every chunk of events whatever ended the kernel call (a full record
buffer, a snapshot, the chunk's budget): STALL_CHUNKS chunks in a row whose event rate (events
per simulated second) exceeds STALL_RATE times the reference rate (that of the first chunk
during which simulated time moved), or during which simulated time does not move at all,
end the run with an EngineError instead of a hang."""

SLOW_RATE = 100.0
MAX_PROJECTED_EVENTS = 2e9
"""Slow-down guard for inelastic scenes: once the event rate exceeds SLOW_RATE times the
reference rate and, at that rate, the simulated time left would take more than
MAX_PROJECTED_EVENTS events (20-40 minutes of this engine at 1-2 million events per second),
the run ends with an EngineError naming the simulated time reached. A granular bed that
has settled under gravity does this: the TC model keeps it from collapsing, but each
particle still collides every contact time. Elastic scenes are left alone (their rate can
grow, by compression under gravity, but stays bounded)."""


class RunawayGuard:
    """The event rate of one run, chunk by chunk, against the rate at its start."""

    def __init__(self, duration: float, t_end: float, inelastic: bool):
        self.duration, self.t_end, self.inelastic = duration, t_end, inelastic
        self._t = 0.0  # kernels' clock and events at the last check
        self._n = 0
        self._moved_n = 0  # events when simulated time last moved
        self._stalled = 0  # chunks in a row that stalled or ran away
        self._rate0: float | None = None

    def shift(self, t: float) -> None:
        """The kernels' time origin moved forward by t (a rebase)."""
        self._t -= t

    def check(self, t: float, events: int, origin: float) -> None:
        """Raise EngineError when simulated time stops, when the event rate runs away
        (inelastic collapse) or when an inelastic run slows down beyond any sensible length;
        t on the kernels' clock (origin + t absolute), once a chunk of events (see
        STALL_RATE, SLOW_RATE)."""
        dt = t - self._t
        moved = dt > 1e-12 * max(abs(t), self.duration)
        rate = (events - self._n) / dt if moved else math.inf
        self._t, self._n = t, events
        t_abs = t + origin
        if not moved:
            self._stalled += 1
        elif self._rate0 is None:
            self._rate0 = rate
            self._stalled = 0
        elif rate > STALL_RATE * self._rate0:
            self._stalled += 1
        else:
            self._stalled = 0
        if self._stalled >= STALL_CHUNKS:
            if not moved:
                raise EngineError(
                    f"simulated time stopped at t = {t_abs:.6g} s: {events} events, the last "
                    f"{events - self._moved_n} of them at one instant (particles jammed: "
                    "rods filling the box, a particle at rest on the floor, or an inelastic "
                    "collapse); loosen the packing, give the particles speed, or give --tc")
            raise EngineError(
                f"the event rate ran away at t = {t_abs:.6g} s ({events} events, {rate:.3g} per "
                f"simulated second, {rate / self._rate0:.3g} times the rate at the start): "
                "inelastic collapse, particles colliding ever faster; give a contact time "
                "--tc (TC model) or raise --restitution")
        if moved:
            self._moved_n = events
        left = self.t_end - t_abs
        if (self.inelastic and moved and self._rate0 is not None
                and rate > SLOW_RATE * self._rate0 and rate * left > MAX_PROJECTED_EVENTS):
            raise EngineError(
                f"the run slowed down at t = {t_abs:.6g} s of {self.t_end:.6g} s: {rate:.3g} "
                f"events per simulated second ({rate / self._rate0:.3g} times the rate at the "
                f"start), so the {left:.3g} s left would take about {rate * left:.2g} events "
                "(the inelastic particles have settled into a bed, colliding every contact "
                "time); shorten --duration, raise --restitution or --tc")
