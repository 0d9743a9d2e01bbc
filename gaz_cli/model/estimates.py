"""What a run will cost, estimated from theory before it starts: its events, rows, steps and
memory, and the bounds past which the door refuses it without ``force``.

Figures measured for the constants here are in
docs/explanation/engine_measurements.md#model-estimates.
"""

from __future__ import annotations

import math
import os
import sys

from gaz_cli.constants import K_B
from gaz_cli.geometry import DENSEST
from gaz_cli.model.checks import field_error
from gaz_cli.model.scene import Scene

# --- work and memory -------------------------------------------------------------------------

# --- work and memory -------------------------------------------------------------------------
MAX_EVENTS = 1e11
"""Largest estimated number of events (collisions + wall bounces) run without --force:
about a day at a million events a second."""

NARROW_BOX = 0.1
"""A box is narrow when a particle's centre moves in less than this fraction of it (L - 2R < 0.1 L):
its wall bounces come L / (L - 2R) > 10 times as often as a point's, and a box 10 % longer
more than doubles the free length, halving them. The work refusal then says to raise `length`."""

MAX_STEP_WORK = 1e11
"""Step engine: largest steps x particles (x N/2 more with pair gravity) run without --force."""

MAX_REFERENCE_WORK = 1e10
"""Reference engine (pure Python, every event shifts every particle's catalogue): largest
events x particles run without --force."""

MAX_SNAPSHOTS = 10_000
"""Most trajectory snapshots written without `force` (a run of 10^6 particles at that
is 0.5 TB of H5MD)."""

BYTES_PER_PARTICLE = {"event": 480, "step": 370, "reference": 700, "ideal": 200, "place": 90}
"""Peak memory per particle of a run (placement, state and the engine's arrays), bytes.

Measured as the growth of the peak resident memory between two runs in 3D, rounded up;
1D and 2D need less (measurements: docs/explanation/engine_measurements.md#model-estimates)."""


def physical_memory() -> int | None:
    """This machine's memory, bytes (None when the system does not say)."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def memory_needed(n: int, engine: str, dim: int = 3) -> float:
    """Peak memory, bytes, of placing and running ``n`` particles with ``engine`` ('place': placement only).

    BYTES_PER_PARTICLE[engine] x n, measured in 3D (the largest).
    """
    return BYTES_PER_PARTICLE.get(engine, BYTES_PER_PARTICLE["event"]) * float(n)


def format_bytes(x: float) -> str:
    for unit, size in (("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if x >= size:
            return f"{x / size:.3g} {unit}"
    return f"{x:.0f} bytes"


def check_memory(n: int, engine: str, dim: int = 3) -> None:
    """Refuse, before any allocation, a run that needs more memory than this machine has."""
    have = physical_memory()
    need = memory_needed(n, engine, dim)
    if have is not None and need > have:
        raise field_error(f"N = {n:.3g} needs about {format_bytes(need)} of memory ({engine} engine); this "
                         f"machine has {format_bytes(have)}; lower `n`" if engine != "place" else
                         f"placing N = {n:.3g} particles needs about {format_bytes(need)} of memory; this "
                         f"machine has {format_bytes(have)}; lower `n`")


def work_estimate(scene: Scene) -> dict:
    """The run's expected work: events per second and in all, steps, work units and their bound.

    Events: collisions N omega / 2 (Enskog, at the mean diameter and mass), wall bounces
    (theory.wall_hit_rate over the 2D walls of the box a species' centres reach, side
    L - 2R: a box barely wider than its particle is crossed most often; under gravity the
    floor is hit every 2 v / g, v = sqrt(k_B T / m)). Step engine: work = steps x N (x N / 2 with pair gravity);
    reference engine: events x N + N^2 (its initCat). Returns a dict: events_per_s, events
    (of which bounces and collisions), work, limit, what (the estimate in words), fix.

    An estimate, checked against the events the event engine counts: it falls short of them,
    most under gravity (measurements: docs/explanation/engine_measurements.md#model-estimates).
    """
    from gaz_cli import theory

    n, dim, length = scene.n, scene.dim, scene.length
    sigma, mass = 2.0 * scene.mean_radius(), scene.mean_mass()
    density = n / scene.volume
    rate = collision_rate = 0.0
    if n > 1 and sigma > 0:
        # Tonks (1D) is exact up to a full segment, which validate refuses; 2D and 3D closed
        # forms diverge at a packing placement cannot reach
        eta = scene.packing_fraction if dim == 1 else min(scene.packing_fraction, 0.99 * DENSEST[dim])
        closed_form = {1: "tonks", 2: "henderson", 3: "carnahan-starling"}[dim]
        omega = float(theory.enskog_collision_frequency(dim, density * eta / scene.packing_fraction,
                                                        sigma, scene.temperature, mass, model=closed_form))
        rate += n * omega / 2.0
    collision_rate = rate
    if scene.boundary == "walls":
        for species, count in scene.components:
            # a centre moves in the free length L - 2R: a box barely wider than its particle
            # is crossed, and its walls hit, at |v| / (L - 2R)
            free = max(length - 2.0 * species.radius, length * sys.float_info.epsilon)
            rate += (float(theory.wall_hit_rate(count / free ** dim, scene.temperature, species.mass))
                     * 2 * dim * free ** (dim - 1))
        if scene.gravity > 0:
            rate += n * scene.gravity / (2.0 * math.sqrt(K_B * scene.temperature / mass))
    events = rate * scene.duration
    # a centre with under NARROW_BOX of the box to move in hits the walls L / (L - 2R) times as
    # often as a point would: there, a slightly longer box is the cheapest fix
    free = min(length - 2.0 * species.radius for species, _ in scene.components) / length
    wider = (f" or raise `length` (a centre has {100 * free:.2g} % of the box's side to move in)"
             if scene.boundary == "walls" and free < NARROW_BOX else "")
    rows = {"bounces": (rate - collision_rate) * scene.duration, "collisions": collision_rate * scene.duration}
    if scene.engine == "step":
        steps = scene.duration / scene.dt if scene.dt else 0.0
        work = steps * n * (n / 2.0 if scene.pair_gravity > 0 else 1.0)
        pairs = scene.pair_gravity > 0
        return {"events_per_s": rate, "events": events, **rows, "steps": steps, "work": work, "limit": MAX_STEP_WORK,
                "what": f"{steps:.3g} steps x {n} particles" + (f" x {n / 2:g} pairs" if pairs else ""),
                "fix": "raise `dt`, or lower `duration` or `n`"}
    if scene.engine == "reference":
        return {"events_per_s": rate, "events": events, **rows, "work": events * n + n * n, "limit": MAX_REFERENCE_WORK,
                "what": f"{events:.3g} events x {n} particles + {n}^2 for the initial catalogue (the "
                        "reference engine updates every particle's catalogue entry at each event)",
                "fix": "use `engine` event, or lower `duration` or `n`" + wider}
    return {"events_per_s": rate, "events": events, **rows, "work": events, "limit": MAX_EVENTS,
            "what": f"{events:.3g} events ({rate:.3g} per simulated second over {scene.duration:.3g} s)",
            "fix": "lower `duration`, `n`, `temperature`" + (" or `gravity`" if scene.gravity > 0 else "")
                   + wider}


def check_work(scene: Scene) -> None:
    """Refuse a run whose estimated work is beyond its bound (unless scene.force)."""
    est = work_estimate(scene)
    if not est["work"] <= est["limit"]:
        raise field_error(f"this run would take about {est['what']}, beyond the {est['limit']:.0e} allowed "
                         f"without `force`; {est['fix']}, or add `force` to run it anyway")


def recorded_rows(scene: Scene) -> dict[str, float] | None:
    """The rows a run records, by kind ({"bounces": ..., "collisions": ...}, the latter 0 unless
    ``record`` all), from :func:`work_estimate`; None when not estimated: ``record`` none,
    ``force``, the step engine (its bounces against damped walls and planes), a preset's state
    (its speeds are not ``temperature``'s)."""
    if scene.record == "none" or scene.force or scene.engine == "step" or scene.initial is not None:
        return None
    est = work_estimate(scene)
    return {"bounces": est["bounces"], "collisions": est["collisions"] if scene.record == "all" else 0.0}


def default_tc(scene: Scene) -> float:
    """TC-model contact time: 1e-4 of the mean free time 1/omega (Enskog, closed-form EOS)."""
    from gaz_cli import theory

    sigma = 2.0 * scene.mean_radius()
    if sigma == 0:
        return 0.0
    closed_form = {1: "tonks", 2: "henderson", 3: "carnahan-starling"}[scene.dim]
    omega = theory.enskog_collision_frequency(scene.dim, scene.n / scene.volume, sigma, scene.temperature,
                                              scene.mean_mass(), model=closed_form)
    return 1e-4 / float(omega)
