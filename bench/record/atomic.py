"""Files written aside and renamed into place (SQLite's journal, git's lock files): a reader sees
the old file or the new one, never half of one, and a writer that fails (a full disk, an
exception, a kill) leaves the old file as it was and no temporary file behind (except after a
kill: the temporary name starts with a dot and ends ``.tmp``).

    with written_aside(path) as tmp:      # tmp: a new name in path's folder
        write_something(tmp)              # any writer that takes a path
    # here path is the complete new file

    copy_aside(src, dest)                 # a copy that is whole at dest or not there at all
"""
from __future__ import annotations

import errno
import os
import shutil
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator


def aside_name(path: Path) -> Path:
    """A temporary name beside ``path`` (same folder, so os.replace is a rename on one file
    system), unique to this process and call."""
    return path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")


@contextmanager
def written_aside(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; when the block ends normally, the temporary file
    replaces ``path`` (os.replace); when it raises, the temporary file is removed and ``path`` is
    untouched."""
    path = Path(path)
    tmp = aside_name(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def write_bytes_aside(path: str | os.PathLike, data: bytes) -> None:
    with written_aside(path) as tmp:
        tmp.write_bytes(data)


def write_text_aside(path: str | os.PathLike, text: str) -> None:
    write_bytes_aside(path, text.encode())


def copy_aside(src: str | os.PathLike, dest: str | os.PathLike) -> None:
    """Copy ``src`` to ``dest`` (any file system): ``dest`` is the whole copy or absent (a copy
    that fails, e.g. on a full disk, leaves no partial or empty file)."""
    with written_aside(dest) as tmp:
        shutil.copyfile(src, tmp)


def move_aside(src: str | os.PathLike, dest: str | os.PathLike) -> None:
    """Move ``src`` to ``dest``: a rename on one file system, else a copy written aside and then
    ``src`` removed. ``src`` stays where it was if the move fails."""
    try:
        os.replace(src, dest)
        return
    except OSError as exc:
        if exc.errno != errno.EXDEV:      # another file system: copy instead
            raise
    copy_aside(src, dest)
    os.unlink(src)


__all__ = ["aside_name", "written_aside", "write_bytes_aside", "write_text_aside", "copy_aside",
           "move_aside"]
