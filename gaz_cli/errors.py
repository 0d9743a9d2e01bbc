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


class Interrupted(KeyboardInterrupt):
    """A run stopped by SIGINT or SIGTERM after rolling back.

    ``signum`` is the signal (the exit code is 128 + signum); ``left`` says
    what the run left on disk, for the one-line message.
    """

    def __init__(self, signum: int = 2, left: str = "nothing was written for the interrupted run"):
        super().__init__(left)
        self.signum = signum
        self.left = left


class QueryError(GazError, ValueError):
    """``gaz query``: an unknown query name, or a parameter missing, unknown or malformed."""
