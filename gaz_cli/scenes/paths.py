"""Which files a run reads and writes, compared by identity: no output over an input, over the
database or over another output.

A file is known by its device and inode after its links are resolved (``os.stat``): two
names of one file (a hard link, a symbolic link, ``./a`` and ``a``) are the same file. A name
that does not exist yet is known by its folder's device and inode and its own name. Every
output is checked against every input and the database, and against the outputs before it,
before anything is written (:func:`check`).

A VTK trajectory (.pvd or .vtu) writes STEM.pvd and STEM_00000.vtu, STEM_00001.vtu...
beside it: each of those counts, the existing ones by identity, the ones to come by name.
A SQLite database counts with its journal, WAL and shared-memory files beside it. A device
or a FIFO (``/dev/null``, ``/dev/stdout``) is no file that writing destroys: never refused.
"""

from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path

from gaz_cli import atomic
from gaz_cli.errors import SceneError

SQLITE_SIDECARS = ("-journal", "-wal", "-shm")
"""Files SQLite keeps beside a database file, part of it while it is open."""


def identity(path) -> tuple:
    """('file', device, inode) of the file ``path`` leads to, or ('name', the folder's device
    and inode, name) when it does not exist (('path', text) when its folder does not either)."""
    real = os.path.realpath(os.path.expanduser(os.fspath(path)))
    try:
        st = os.stat(real)
        return ("file", st.st_dev, st.st_ino)
    except OSError:
        pass
    folder, name = os.path.split(real)
    try:
        st = os.stat(folder)
        return ("name", st.st_dev, st.st_ino, name)
    except OSError:
        return ("path", real)


def _folder(path) -> tuple | None:
    """(device, inode) of the folder ``path``'s resolved name is in, else None."""
    try:
        st = os.stat(os.path.dirname(os.path.realpath(os.path.expanduser(os.fspath(path)))))
        return (st.st_dev, st.st_ino)
    except OSError:
        return None


@dataclass
class Files:
    """What one option names: the identities of the files it is, and a test of names to come."""

    option: str
    given: str
    ids: set = field(default_factory=set)
    folder: tuple | None = None
    pattern: re.Pattern | None = None  # names (in ``folder``) it will write that do not exist yet

    def meets(self, other: "Files") -> bool:
        if self.ids & other.ids:
            return True
        for a, b in ((self, other), (other, self)):
            if a.pattern is None or a.folder is None:
                continue
            for ident in b.ids:
                if ident[0] == "name" and ident[1:3] == a.folder and a.pattern.fullmatch(ident[3]):
                    return True
        return False


def files_of(option: str, path, sqlite: bool = False) -> Files:
    """The files ``option`` names with ``path`` (see the module docstring)."""
    given = os.fspath(path)
    real = Path(os.path.realpath(os.path.expanduser(given)))
    try:
        mode = os.stat(os.path.expanduser(given)).st_mode
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            return Files(option, given)  # a device or FIFO (/dev/null, /dev/stdout): not a file to destroy
    except OSError:
        pass
    out = Files(option, given, {identity(given)})
    if sqlite:
        out.ids |= {identity(str(real) + s) for s in SQLITE_SIDECARS if os.path.exists(str(real) + s)}
        # names only when the file exists under another name too: the real file's own name
        out.ids.add(("name", *(_folder(real) or (None, None)), real.name))
    if option == "--trajectory" and real.suffix.lower() in (".pvd", ".vtu"):
        pvd = real.with_suffix(".pvd")
        out.ids |= {identity(pvd), ("name", *(_folder(pvd) or (None, None)), pvd.name)}
        out.folder = _folder(real)
        out.pattern = re.compile(re.escape(real.stem) + r"_\d{5,}\.vtu")
        try:
            for entry in os.scandir(real.parent):
                if out.pattern.fullmatch(entry.name):
                    out.ids.add(identity(entry.path))
        except OSError:
            pass
    else:
        out.ids.add(("name", *(_folder(real) or (None, None)), real.name))
    return out


def check(db: str | None = None, inputs: dict | None = None, outputs: dict | None = None) -> None:
    """Refuse (SceneError, one line) an output that is the database, an input or an earlier
    output. ``db``: the SQLite file (None: no file, or a server); ``inputs``: what each input
    is called ('the scene file') -> path; ``outputs``: option -> path (None or absent: not
    given). Nothing is written here."""
    taken: list[tuple[str, Files]] = []
    if db:
        taken.append(("the database", files_of("--db", db, sqlite=True)))
    for label, path in (inputs or {}).items():
        if path is None:
            continue
        files = files_of(label, path)
        if taken and taken[0][1].meets(files):
            raise SceneError(f"--db {taken[0][1].given!r} is also {label} {str(path)!r}: the run would "
                             f"write its database over its own input; give --db another file")
        taken.append((f"{label}, the run's own input", files))
    for option, path in (outputs or {}).items():
        if path is None:
            continue
        files = files_of(option, path)
        for what, other in taken:
            if other.meets(files):
                vtk = (" (a VTK trajectory writes STEM.pvd and STEM_00000.vtu, STEM_00001.vtu... "
                       "beside it)" if files.pattern is not None or other.pattern is not None else "")
                also = (f"--db {other.given!r}" if other.option == "--db" else
                        f"{other.option} {other.given!r}")
                raise SceneError(f"{option} {str(path)!r} is also {also}{vtk}: writing it would "
                                 f"destroy {what}; give {option} another file")
        taken.append((f"the {option} file", files))


def check_writable(path: str | None, option: str) -> None:
    """Refuse, before the database is opened, an output file that cannot be written: an empty
    name, its folder missing, or the path an existing folder (the command line's flags check
    that too; a scene file's [output] and the Python API come here)."""
    if path is not None and not isinstance(path, (str, os.PathLike)):
        raise SceneError(f"{option} {path!r} is not a file path; give a path (text or pathlib.Path), or None")
    if path is not None and not os.fspath(path).strip():
        raise SceneError(f"{option} {os.fspath(path)!r} names no file; give a file name, or leave {option} out")
    if path:
        check_name(path, option)
        where = Path(path).expanduser()
        parent = where.resolve().parent
        if not parent.is_dir():
            raise SceneError(f"{option} {str(path)!r}: folder {str(parent)!r} does not exist")
        if where.is_dir():
            example = {"--save-state": "state.csv", "--trajectory": "run.h5"}.get(option, "scene.toml")
            raise SceneError(f"{option} {str(path)!r} is a folder, not a file; give a file path "
                             f"(e.g. {str(Path(path) / example)!r})")


def check_name(path, option: str) -> None:
    """Refuse a name no file system takes: a NUL character, or a file name (with the temporary
    name it is written under first, :mod:`gaz_cli.atomic`) longer than its folder allows."""
    text = os.fspath(path)
    if "\0" in str(text):
        raise SceneError(f"{option} {text!r} holds a NUL character, which no file name may hold; "
                         "give another name")
    temporary = atomic.temporary_name(path)
    try:
        longest = os.pathconf(temporary.parent, "PC_NAME_MAX")
    except (OSError, ValueError):
        longest = 255
    if len(os.fsencode(temporary.name)) > longest:
        room = longest - (len(os.fsencode(temporary.name)) - len(os.fsencode(Path(text).name)))
        raise SceneError(f"{option} {text!r}: its file name is {len(os.fsencode(Path(text).name))} bytes "
                         f"long, more than the {room} this folder's file system takes (it holds at most "
                         f"{longest}, and gaz writes the file under a longer temporary name first); "
                         "give a shorter name")
