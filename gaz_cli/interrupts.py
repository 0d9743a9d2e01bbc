"""SIGINT and SIGTERM during a run: an exception that is not lost, and held over writes
that must not be cut in half.

- :func:`catching` (around a whole run, :func:`gaz_cli.run.runner.simulate`):
  both signals raise :class:`~gaz_cli.errors.Interrupted`, so that the run
  unwinds and rolls back as for Ctrl-C. A signal landing while Python runs a
  weakref callback or a ``__del__`` sees its exception printed and dropped
  ("Exception ignored in ..."); the signal stays recorded, and
  :func:`check`, called by the recorders at every chunk, raises it again.
- :func:`held` (around a commit, a trajectory snapshot): a signal arriving
  inside the block is recorded and raised when the block has ended, so the
  block is done whole or not started.
- :func:`from_the_start` (the command line's first act): SIGTERM raises
  Interrupted wherever it lands, as SIGINT raises KeyboardInterrupt, where its
  default action would end the process without a word (the imports of NumPy,
  pandas, SQLAlchemy... take about a second before a command's own handling).
  :func:`saying` gives the words for a step (e.g. analyse's imports).

Handlers are installed from the main thread only (Python's rule); elsewhere
these are no-ops.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading

from gaz_cli.errors import Interrupted

SIGNALS = (signal.SIGINT, signal.SIGTERM)

_pending: list[int] = []
_state = {"catching": 0, "holding": 0}
_received: list[int] = []
"""The signals a handler of this module took during the current command (cleared when a command
or a run starts: :func:`from_the_start`, :func:`catching`): an exception that follows one (a
library that swallowed the Interrupted raised in its callback, then failed) is reported as the
interruption, not as an internal error (:func:`signal_of`)."""


def _handler(signum, _frame):
    _pending.append(signum)
    _received.append(signum)
    if not _state["holding"]:
        raise Interrupted(signum)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def catching():
    """SIGINT and SIGTERM raise Interrupted inside the block; the old handlers come back after."""
    if not _main_thread():
        yield
        return
    previous = {s: signal.signal(s, _handler) for s in SIGNALS}
    if not _state["catching"]:
        _received.clear()  # a new run: an earlier one's signal (in this process) is not its
    hook = sys.unraisablehook
    sys.unraisablehook = _quiet_unraisable
    _pending.clear()
    _state["catching"] += 1
    try:
        yield
    finally:
        _state["catching"] -= 1
        for s, h in previous.items():
            signal.signal(s, h)
        sys.unraisablehook = hook
        _pending.clear()


def _quiet_unraisable(unraisable) -> None:
    """An Interrupted that Python could not raise (in a ``__del__``, a weakref or a ctypes
    callback: Numba's compiler) is recorded in :data:`_pending` already, and raised again by
    :func:`check` or reported by the CLI: no "Exception ignored" traceback on stderr; anything
    else goes to Python's own hook."""
    if isinstance(unraisable.exc_value, Interrupted):
        return
    sys.__unraisablehook__(unraisable)


def check() -> None:
    """Raise Interrupted if a signal came (again, if its first exception was dropped)."""
    if _pending and not _state["holding"]:
        raise Interrupted(_pending[0])


def pending() -> int | None:
    """The signal received and not raised yet (inside a :func:`held` block, where it waits
    for the block's end), else None: a block that has not started writing may stop at once."""
    return _pending[0] if _pending else None


@contextlib.contextmanager
def held():
    """Run the block whole: a SIGINT or SIGTERM arriving inside it is raised after it."""
    if not _main_thread():
        yield
        return
    installed = None if _state["catching"] else {s: signal.signal(s, _handler) for s in SIGNALS}
    _state["holding"] += 1
    try:
        yield
    finally:
        _state["holding"] -= 1
        if installed is not None:
            for s, h in installed.items():
                signal.signal(s, h)
    if _pending:
        signum = _pending[0]
        if installed is not None:
            _pending.clear()
        raise Interrupted(signum)


@contextlib.contextmanager
def from_the_start():
    """SIGTERM raises Interrupted inside the block (the command line's whole command), as SIGINT
    raises KeyboardInterrupt; the old handler comes back after. A SIGTERM ignored stays ignored.

    :func:`catching` and :func:`held` install their handler over it and put it back after.
    """
    previous = signal.getsignal(signal.SIGTERM) if _main_thread() else signal.SIG_IGN
    _received.clear()  # a new command
    if previous is signal.SIG_IGN:
        yield
        return
    signal.signal(signal.SIGTERM, _handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)
        _pending.clear()    # the command is over: no later held() block of this process raises it


STOPPED_ANALYSIS = "the analysis stopped before printing its tables"
"""What ``gaz analyse`` left when a signal stopped it (:func:`saying`, analysis.interruptible)."""


@contextlib.contextmanager
def saying(left: str):
    """A SIGINT or SIGTERM inside the block ends the command with ``left`` as what it left
    (Interrupted(signum, left), the one line the command line prints)."""
    try:
        yield
    except KeyboardInterrupt as exc:
        raise Interrupted(getattr(exc, "signum", signal.SIGINT), left) from None


def interrupt_in(exc: BaseException) -> KeyboardInterrupt | None:
    """The KeyboardInterrupt (Interrupted included) anywhere in ``exc``'s chain of causes, else
    None. A signal landing while a Numba function boxes its result reaches Python as a
    SystemError whose cause is the interrupt."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def signal_of(exc: BaseException) -> int | None:
    """The signal behind ``exc`` (see :func:`interrupt_in`), else the last signal this process
    took, if any (a SIGINT landing in Numba's compiler: llvmlite prints and drops the Interrupted
    raised in its callback, then fails with a RuntimeError of its own), else None."""
    found = interrupt_in(exc)
    if found is not None:
        return getattr(found, "signum", signal.SIGINT)
    return _received[-1] if _received else None
