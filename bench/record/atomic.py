"""Files written aside and renamed into place; names taken by an exclusive create and a lock.

A reader of a path the bench writes sees the old file or the new one, never half of one; a writer
that fails (a full disk, an exception, a kill) leaves nothing at the path (what it wrote stays
beside it under a name that says so, or is removed); two writers never share a name (SQLite's
journal, git's lock files, ``os.replace``)::

    with written_aside(path) as tmp:      # tmp: a new name in path's folder
        write_something(tmp)              # any writer that takes a path
    # here path is the complete new file

    copy_aside(src, dest)                 # a copy that is whole at dest or not there at all

* :func:`written_aside` / :func:`write_aside` (a path, or an open file): a unique temporary name
  in the same folder, renamed into place when complete; :func:`publish`: the rename, which with
  ``replace=False`` never overwrites (a hard link, which fails if the target exists, then the
  temporary name removed; ``os.replace`` after a look where the file system has no hard links).
* :func:`partial_path` ``.<name>.partial``: the name a long writer (the recorder, a capture)
  works under; :func:`take_exclusive` creates it with O_EXCL and holds an ``flock`` on it while
  the writer lives, so it is the claim on the name, and :func:`abandoned` tells a partial file
  whose writer died (no lock) from one being written; :func:`keep_abandoned` keeps a dead
  writer's file under a name that says so.
* :func:`move_to_replaced`: an existing file a ``--force`` run replaces goes to
  ``.<name>.replaced`` before the run starts (never over an older one there), so a run that fails
  never leaves the old file at its path.
* :func:`same_file` / :func:`refuse_output_is_input`: is an output one of the command's inputs
  (the same path, or the same file through a symbolic or hard link)?
"""
from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import shutil
import tempfile
import uuid
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO

from hil_bench.errors import OutputIsInput


def partial_path(path: Path) -> Path:
    """``.<name>.partial`` beside ``path``: the name it is written under until complete."""
    path = Path(path)
    return path.with_name(f".{path.name}.partial")


def replaced_path(path: Path) -> Path:
    """``.<name>.replaced`` beside ``path``: where a file a ``--force`` run replaces waits until
    the new one is in place."""
    path = Path(path)
    return path.with_name(f".{path.name}.replaced")


def numbered(path: Path, n: int) -> Path:
    """``x.mcap`` -> ``x-<n>.mcap``: the n-th other name for a name that is taken."""
    path = Path(path)
    return path.with_name(f"{path.stem}-{n}{path.suffix}")


def take_exclusive(path: Path) -> int | None:
    """Create ``path`` empty (O_EXCL) and hold an exclusive ``flock`` on it: the returned
    descriptor is the writer's claim on the name, held while it (or a copy a child process
    inherited) is open. None if a file has that name."""
    try:
        fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_RDWR, 0o644)
    except FileExistsError:
        return None
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)   # a file no one else has: never blocks
    return fd


#: a partial file this young with no data and no lock is a writer between its exclusive create
#: and its lock, not one that died
FRESH_PARTIAL_S = 5.0


def abandoned(path: Path) -> bool:
    """True if ``path`` (a partial file) is no live writer's: no process holds its lock (its
    writer died: killed, a crash, a power cut) and it is not one just created."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            return False                       # held: a writer is at work
        st = os.fstat(fd)
        import time

        return st.st_size > 0 or time.time() - st.st_mtime > FRESH_PARTIAL_S
    finally:
        os.close(fd)


def publish(tmp: Path, target: Path, *, replace: bool) -> None:
    """Rename the complete ``tmp`` to ``target``. ``replace``: over an existing target
    (``os.replace``, atomic); else FileExistsError if the target exists (checked atomically
    with a hard link where the file system has them)."""
    if replace:
        os.replace(tmp, target)
        return
    try:
        os.link(tmp, target)
    except FileExistsError:
        raise
    except OSError as exc:   # no hard links here (some network and FUSE file systems)
        if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EXDEV,
                             errno.EMLINK):
            raise
        if os.path.lexists(target):
            raise FileExistsError(errno.EEXIST, "file exists", str(target)) from None
        os.replace(tmp, target)
        return
    os.unlink(tmp)


def fsync_dir(path: Path) -> None:
    """Make a rename in ``path``'s folder durable (best effort: not every file system can)."""
    try:
        fd = os.open(Path(path).parent or ".", os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextlib.contextmanager
def write_aside(path: Path, mode: str = "w", *, replace: bool = True,
                encoding: str | None = "utf-8", newline: str | None = None) -> Iterator[IO]:
    """``with write_aside(p) as f: f.write(...)``: written under a unique temporary name in
    ``p``'s folder and renamed to ``p`` when the block ends without an exception (else removed).
    ``replace=False``: FileExistsError if ``p`` exists by then."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=folder)
    binary = "b" in mode
    try:
        with os.fdopen(fd, mode, **({} if binary else {"encoding": encoding,
                                                        "newline": newline})) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        publish(Path(tmp), path, replace=replace)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def aside_name(path: Path) -> Path:
    """A temporary name beside ``path`` (same folder, so os.replace is a rename on one file
    system), unique to this process and call."""
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")


@contextlib.contextmanager
def written_aside(path: str | os.PathLike, *, replace: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; when the block ends normally, the temporary file
    becomes ``path`` (:func:`publish`; ``replace=False``: FileExistsError if ``path`` exists by
    then); when it raises, the temporary file is removed and ``path`` is untouched."""
    path = Path(path)
    tmp = aside_name(path)
    try:
        yield tmp
        publish(tmp, path, replace=replace)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def write_bytes_aside(path: str | os.PathLike, data: bytes, *, replace: bool = True) -> None:
    with written_aside(path, replace=replace) as tmp:
        tmp.write_bytes(data)


def write_text_aside(path: str | os.PathLike, text: str, *, replace: bool = True) -> None:
    write_bytes_aside(path, text.encode(), replace=replace)


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


def keep_abandoned(partial: Path, target: Path) -> Path | None:
    """Rename the partial file of a writer that died to ``<stem>.abandoned<suffix>`` beside
    ``target`` (``-<n>`` when taken): visible, readable (``bench check`` says the run did not
    finish, ``bench recover`` copies its chunks), never lost. None if it went meanwhile."""
    target = Path(target)
    for n in range(1000):
        dest = target.with_name(f"{target.stem}.abandoned{'' if n == 0 else f'-{n}'}{target.suffix}")
        try:
            publish(Path(partial), dest, replace=False)
            return dest
        except FileExistsError:
            continue
        except FileNotFoundError:
            return None
    raise FileExistsError(errno.EEXIST, "1000 abandoned files already", str(target))


def move_to_replaced(path: Path) -> Path | None:
    """Rename an existing ``path`` to ``.<name>.replaced`` (``.<name>.replaced-<n>`` when an
    older one is there: a file moved aside by a run that failed stays until its owner removes
    it); returns where it went, None if there was nothing."""
    path = Path(path)
    if not os.path.lexists(path):
        return None
    for n in range(1000):
        dest = replaced_path(path)
        if n:
            dest = dest.with_name(f"{dest.name}-{n}")
        try:
            publish(path, dest, replace=False)
            return dest
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "1000 files moved aside already", str(replaced_path(path)))


def same_file(a: Path, b: Path) -> bool:
    """``a`` and ``b`` are the same file: the same inode (a hard or symbolic link included) when
    both exist, else the same path once resolved (symbolic links followed)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        pass
    try:
        return Path(a).resolve() == Path(b).resolve()
    except (OSError, RuntimeError):
        return False


def find_output_input(output: Path, inputs: Iterable[tuple[str, Path | None]]) -> str | None:
    """The description of the first input (``(what, path)``) that is ``output``, or None."""
    for what, path in inputs:
        if path is not None and str(path) and same_file(output, path):
            return what
    return None


def refuse_output_is_input(outputs: Iterable[Path | None], inputs: Iterable[tuple[str, Path | None]],
                           option: str = "--out") -> None:
    """OutputIsInput if any of ``outputs`` (the files a command writes, or would) is one of its
    ``inputs`` (``(what, path)``): with or without ``--force``, a command never writes over what
    it reads."""
    inputs = list(inputs)
    for out in outputs:
        if out is None:
            continue
        for what, path in inputs:
            if path is not None and str(path) and same_file(out, path):
                how = "" if Path(out) == Path(path) else f" ({path}, the same file)"
                raise OutputIsInput(f"{option} {out}: is the command's own {what}{how}; writing "
                                    f"it would destroy what the command reads: choose another "
                                    f"{option}")
