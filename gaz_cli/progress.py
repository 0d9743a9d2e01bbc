"""Progress of a long run on a terminal: a one-line notice while the engine compiles, then
a bar of simulated time done, events per second and time left.

:class:`Progress` is a :class:`~gaz_cli.model.recording.Recorder` that wants no rows, only
the engines' progress reports: an engine calls ``progress(t, events)`` once its
kernels are compiled (or loaded from Numba's cache) and then after each kernel
call (about every :data:`EVENTS_PER_REPORT` events, or the step engine's time
slice). Nothing shows for a run shorter than :data:`AFTER_S`.

The bar is click's (``click.progressbar``): click is already gaz's CLI, the bar
computes the time left and draws on one line, and it needs no new dependency
(rich and tqdm would each add one for the same line).

The compile notice is time-based: it is printed when the engine has not started
:data:`AFTER_S` seconds after the run was handed to it, which on a warm cache
(kernels loaded in ~0.1-0.3 s) does not happen and on a cold one (10-40 s of
compilation for each kind of scene) does. Asking Numba whether this
specialisation is cached would mean reading its cache index, a private format
that the engine's module names (being split now) also change.

The caller decides whether to show anything at all: only when stderr is a
terminal and ``--quiet`` was not given (:func:`wanted`).
"""

from __future__ import annotations

import os
import sys
import threading
import time

import click

from gaz_cli.model.recording import Recorder

AFTER_S = float(os.environ.get("GAZ_PROGRESS_AFTER", "1.0"))
"""Seconds before the bar (or the compile notice) appears. GAZ_PROGRESS_AFTER overrides
it (the tests set 0, to see the bar on a run of a fraction of a second)."""

EVENTS_PER_REPORT = 1 << 18
"""At most this many events between two reports of the event engine (~0.1-1 s of work)."""

STEPS = 1000
"""The bar's resolution: simulated time in thousandths of the duration."""

NOTICE = "gaz: compiling the engine for this kind of scene (first run only)..."


def wanted(quiet: bool, stream=None) -> bool:
    """Whether to show progress: not ``--quiet``, and ``stream`` (stderr) is a terminal."""
    stream = sys.stderr if stream is None else stream
    try:
        return not quiet and stream.isatty()
    except (AttributeError, ValueError):  # closed or file-like without isatty
        return False


class Progress(Recorder):
    """A progress bar of one run of ``duration`` simulated seconds, on ``stream`` (stderr).

    Call :meth:`close` at the end (also on failure): it ends the bar's line.
    """

    wants_progress = True

    def __init__(self, duration: float, stream=None, after_s: float | None = None):
        self.duration = float(duration)
        self.stream = sys.stderr if stream is None else stream
        self.after_s = AFTER_S if after_s is None else float(after_s)
        self.bar = None
        self.started = None  # wall clock when the engine reported first (compilation over)
        self.notice_shown = False
        self._t0 = self._events0 = None
        self._rate = 0.0
        self._lock = threading.Lock()
        self._timer = threading.Timer(self.after_s, self._notice)
        self._timer.daemon = True
        self._timer.start()

    def _notice(self) -> None:
        with self._lock:
            if self.started is None and self.bar is None:
                click.echo(NOTICE, file=self.stream)
                self.notice_shown = True

    def progress(self, t: float, events: int) -> None:
        now = time.perf_counter()
        if self.started is None:
            with self._lock:
                self._timer.cancel()
                self.started, self._t0, self._events0 = now, float(t), int(events)
            return
        elapsed = now - self.started
        if elapsed > 0:
            self._rate = (int(events) - self._events0) / elapsed
        if self.bar is None:
            if elapsed < self.after_s:
                return
            self.bar = click.progressbar(length=STEPS, label="simulating", file=self.stream,
                                         show_eta=True, show_percent=True, update_min_steps=1,
                                         item_show_func=self._describe)
            self.bar.__enter__()
        done = STEPS if self.duration <= 0 else int(STEPS * min(1.0, (t - self._t0) / self.duration))
        if done > self.bar.pos:
            self.bar.update(done - self.bar.pos, current_item=t)

    def _describe(self, t) -> str | None:
        if t is None:
            return None
        return f"t = {t:.3g} of {self._t0 + self.duration:.3g} s, {self._rate:,.0f} events/s"

    def close(self, complete: bool = False) -> None:
        """Stop the notice's timer and end the bar's line (at 100 % if ``complete``: the run
        reached its duration); idempotent."""
        self._timer.cancel()
        with self._lock:
            bar, self.bar = self.bar, None
            self.started = self.started or time.perf_counter()
        if bar is not None:
            if complete and bar.pos < STEPS:
                bar.update(STEPS - bar.pos, current_item=self._t0 + self.duration)
            bar.__exit__(None, None, None)
