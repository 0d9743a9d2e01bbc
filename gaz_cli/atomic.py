"""Write a file whole or not at all: to a temporary name in its folder, renamed into place.

:func:`replacing` yields the temporary name; when its block ends without an exception the
file is renamed over the target (``os.replace``, atomic on one file system), and otherwise
deleted, so a failure, a full disk or an interrupt leaves the old file as it was. A target
reached through symbolic links is the file they lead to (the link stays a link). A name
that is not a regular file (``/dev/null``, ``/dev/stdout``, a FIFO) is written in place:
renaming over it would replace the device.

Temporary names: ``.NAME.tmp-XXXXXXXX.SUFFIX`` beside the target (the suffix kept: some
writers choose their format by it, matplotlib and Pillow among them).
"""

from __future__ import annotations

import contextlib
import os
import secrets
import stat
from pathlib import Path


def target(path) -> Path:
    """The file that writing ``path`` changes: user folder expanded, links resolved."""
    return Path(os.path.realpath(os.path.expanduser(os.fspath(path))))


def in_place(path) -> bool:
    """Whether ``path`` names something other than a regular file or nothing (a device, a FIFO),
    which is written in place, not replaced."""
    try:  # (the name itself, followed: /dev/stdout leads to a pipe whose "path" is no file)
        return not stat.S_ISREG(os.stat(os.path.expanduser(os.fspath(path))).st_mode)
    except OSError:
        return False


def temporary_name(path) -> Path:
    """A fresh temporary name beside ``path``'s target (see the module docstring)."""
    final = target(path)
    return final.parent / f".{final.name}.tmp-{secrets.token_hex(4)}{final.suffix}"


def commit(temporary, path) -> None:
    """Rename ``temporary`` over ``path``'s target (atomic), keeping the old file's permission
    bits when it had one, else those a new file takes under the process's umask (a library that
    wrote the temporary file may have chosen its own: the gsd package makes 0640 files)."""
    final = target(path)
    with contextlib.suppress(OSError):
        os.chmod(temporary, stat.S_IMODE(os.stat(final).st_mode) if final.exists() else 0o666 & ~_umask())
    os.replace(temporary, final)


def _umask() -> int:
    """The process's umask (read by setting it and setting it back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def discard(temporary) -> None:
    """Delete a temporary file if it is there (a failed or interrupted write)."""
    with contextlib.suppress(OSError):
        os.unlink(temporary)


@contextlib.contextmanager
def replacing(path):
    """Yield the name to write ``path`` under; rename it into place if the block succeeds,
    delete it if not (see the module docstring). A device or FIFO yields its own name."""
    if in_place(path):
        yield Path(os.path.expanduser(os.fspath(path)))
        return
    temporary = temporary_name(path)
    try:
        yield temporary
        commit(temporary, path)
    except BaseException:
        discard(temporary)
        raise


def write_text(path, text: str) -> None:
    """``Path(path).write_text(text)``, whole or not at all (UTF-8)."""
    with replacing(path) as name, open(name, "w", encoding="utf-8") as fh:
        fh.write(text)
