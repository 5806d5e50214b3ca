"""Files written whole or not at all: a temp file in the target's folder, fsynced, renamed over the target,
then the folder fsynced so the rename itself survives a power loss.

The temp file is created with ``O_EXCL`` (``mkstemp``) and the rename replaces whatever is at the target,
a planted symlink included, without following it: a write never lands outside the folder it names.
"""

from __future__ import annotations

import glob
import os
import tempfile
from collections.abc import Callable
from typing import BinaryIO, TextIO

TEMP_PREFIX = ".tmp_"


def write_atomic(path: str, write: Callable[[BinaryIO], None], suffix: str = "") -> None:
    """Call ``write(fh)`` on a temp file next to ``path``, then rename it to ``path``; on any failure the
    temp file is removed and ``path`` keeps what it held."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=TEMP_PREFIX, suffix=suffix, dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; these are ordinary files
        os.replace(tmp, path)
    except BaseException:
        if os.path.lexists(tmp):
            os.unlink(tmp)
        raise
    fsync_dir(folder)


def write_text_atomic(path: str, text: str) -> None:
    """``text`` (UTF-8) written through :func:`write_atomic`."""
    write_atomic(path, lambda fh: fh.write(text.encode("utf-8")))


def fsync_dir(folder: str) -> None:
    """Flush a folder's entries (a rename) to disk; a file system that cannot (some network ones) is skipped."""
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def remove_stale_temps(folder: str) -> list[str]:
    """Remove the temp files a killed writer left in ``folder`` (``.tmp_*``); returns the ones removed."""
    removed = []
    for path in glob.glob(os.path.join(glob.escape(folder), TEMP_PREFIX + "*")):
        try:
            if os.path.isfile(path) or os.path.islink(path):
                os.unlink(path)
                removed.append(path)
        except OSError:
            pass  # another process's file, or already gone
    return removed


def open_append(path: str) -> TextIO:
    """``path`` opened for appending text, never through a symlink (a link planted at a run file's place is
    an OSError naming it, not a write elsewhere)."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_APPEND | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags, 0o666)
    except OSError as exc:
        if os.path.islink(path):
            raise OSError(f"'{path}' is a symlink; a run writes into its own files only") from None
        raise exc
    return os.fdopen(fd, "a", newline="", encoding="utf-8")
