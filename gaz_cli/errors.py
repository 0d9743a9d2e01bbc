"""The library's exceptions.

The library raises these; ``cli.py`` turns every one of them into a one-line
message on stderr and a non-zero exit, in one place.
"""


class GazError(Exception):
    """Base class of every error the library reports to a user."""


class GazWarning(UserWarning):
    """A run that completes but whose numbers deserve doubt (the CLI prints it as one line)."""


class SceneError(GazError, ValueError):
    """A scene that cannot be simulated: bad size, unknown species, impossible packing."""


class PlacementError(GazError, RuntimeError):
    """Placement gave up after its bounded effort."""


class StoreError(GazError, RuntimeError):
    """The database cannot be opened, is not a gaz database, or lacks a simulation."""


class OutputError(GazError, OSError):
    """An output cannot be written: a full disk, an unsupported file format."""


class EngineError(GazError, RuntimeError):
    """An engine reported a state it cannot continue from (queue overflow, invalid state)."""


def interrupted(exc: BaseException) -> bool:
    """True when ``exc`` is, or was caused by, a KeyboardInterrupt (Ctrl-C).

    A Ctrl-C that arrives while a Numba kernel runs is raised when the kernel's result is
    boxed, inside a helper Numba calls; Python then reports a SystemError ("returned a result
    with an exception set") whose cause is the KeyboardInterrupt.
    """
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False
