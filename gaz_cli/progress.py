"""Progress of long commands: one kind of bar, rich's, on a terminal and in a Jupyter notebook.

:func:`bar` makes the bar every long command draws (``gaz simulate``'s, through
:class:`Progress`, and ``gaz sweep``'s, in :mod:`gaz_cli.run.sweeps`): a
:class:`rich.progress.Progress` on :func:`console`, stderr on a terminal, the cell's
output in a notebook (rich draws there through ipywidgets: ``pip install 'gaz[notebook]'``;
without it rich warns 'install "ipywidgets" for Jupyter support' and draws nothing).

:class:`Progress` is a :class:`~gaz_cli.model.recording.Recorder` that wants no rows, only
the engines' progress reports: an engine calls ``progress(t, events)`` once its
kernels are compiled (or loaded from Numba's cache) and then after each kernel
call (about every :data:`EVENTS_PER_REPORT` events, or the step engine's time
slice). Nothing shows for a run shorter than :data:`AFTER_S`. Its bar shows the simulated
time done, events per second and the time left.

The compile notice is time-based: it is printed when the engine has not started
:data:`AFTER_S` seconds after the run was handed to it, which on a warm cache
(kernels loaded in ~0.1-0.3 s) does not happen and on a cold one (:data:`COMPILE_S` of
compilation for each kind of scene) does. Asking Numba whether this
specialisation is cached would mean reading its cache index, a private format
that the engine's module names (being split now) also change.

The caller decides whether to show anything at all: the CLI when stderr is a terminal and
``--quiet`` was not given, the API when asked (``progress=True``) or, for a sweep, in a
terminal or a notebook (:func:`wanted`).
"""

from __future__ import annotations

import os
import sys
import threading
import time

from gaz_cli.model.recording import Recorder

AFTER_S = float(os.environ.get("GAZ_PROGRESS_AFTER", "1.0"))
"""Seconds before the bar (or the compile notice) appears. GAZ_PROGRESS_AFTER overrides
it (the tests set 0, to see the bar on a run of a fraction of a second)."""

EVENTS_PER_REPORT = 1 << 18
"""At most this many events between two reports of the event engine (~0.1-1 s of work)."""

STEPS = 1000
"""The bar's resolution: simulated time in thousandths of the duration."""

COMPILE_S = "10 to 40 s"
"""How long the engines' first compile for a new kind of scene usually takes (cold Numba
cache; then it is cached on disk and a run starts in under a second)."""

NOTICE = (f"gaz: compiling the engine for this kind of scene (first run only, usually {COMPILE_S}; "
          "then cached)...")


def in_notebook() -> bool:
    """Whether this process is a Jupyter kernel (rich's own test; False without IPython loaded)."""
    if "IPython" not in sys.modules:
        return False
    from rich.console import Console

    return Console().is_jupyter


def wanted(quiet: bool, stream=None) -> bool:
    """Whether to show progress: not ``--quiet``, and ``stream`` (stderr) is a terminal or this
    is a notebook."""
    if quiet:
        return False
    stream = sys.stderr if stream is None else stream
    try:
        if stream.isatty():
            return True
    except (AttributeError, ValueError):  # closed or file-like without isatty
        pass
    return in_notebook()


def console(stream=None):
    """The :class:`rich.console.Console` bars draw on: ``stream``, else stderr (in a notebook,
    rich draws in the cell's output instead)."""
    from rich.console import Console

    return Console(stderr=True) if stream is None else Console(file=stream)


def bar(label: str, *columns, stream=None):
    """A rich progress bar (not started): ``label``, the bar, its percentage, the given
    ``columns`` (rich columns or format strings of the task's fields), the time left."""
    from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeRemainingColumn

    return Progress(TextColumn(label), BarColumn(), TaskProgressColumn(),
                    *(TextColumn(c) if isinstance(c, str) else c for c in columns),
                    TimeRemainingColumn(), console=console(stream), transient=False)


class Progress(Recorder):
    """A progress bar of one run of ``duration`` simulated seconds, on ``stream`` (stderr).

    Call :meth:`close` at the end (also on failure): it ends the bar's line.
    """

    wants_progress = True

    def __init__(self, duration: float, stream=None, after_s: float | None = None):
        self.duration = float(duration)
        self.stream = stream
        self.after_s = AFTER_S if after_s is None else float(after_s)
        self.bar = None
        self.started = None  # wall clock when the engine reported first (compilation over)
        self.notice_shown = False
        self._task = None
        self._t0 = self._events0 = None
        self._rate = 0.0
        self._lock = threading.Lock()
        self._timer = threading.Timer(self.after_s, self._notice)
        self._timer.daemon = True
        self._timer.start()

    def _notice(self) -> None:
        with self._lock:
            if self.started is None and self.bar is None:
                console(self.stream).print(NOTICE, markup=False, highlight=False, soft_wrap=True)
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
            self.bar = bar("simulating", "{task.fields[detail]}", stream=self.stream)
            self._task = self.bar.add_task("simulating", total=STEPS, detail="")
            self.bar.start()
        done = STEPS if self.duration <= 0 else int(STEPS * min(1.0, (t - self._t0) / self.duration))
        self.bar.update(self._task, completed=done, detail=self._describe(t))

    def _describe(self, t: float) -> str:
        return f"t = {t:.3g} of {self._t0 + self.duration:.3g} s, {self._rate:,.0f} events/s"

    def close(self, complete: bool = False) -> None:
        """Stop the notice's timer and end the bar's line (at 100 % if ``complete``: the run
        reached its duration); idempotent."""
        self._timer.cancel()
        with self._lock:
            progress, self.bar = self.bar, None
            self.started = self.started or time.perf_counter()
        if progress is not None:
            if complete:
                progress.update(self._task, completed=STEPS,
                                detail=self._describe(self._t0 + self.duration))
            progress.stop()
