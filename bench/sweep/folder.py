"""A sweep's folder: a default name no other sweep can take, and one writer at a time.

* Without ``--out`` a sweep writes to ``reports/sweeps/<name>-<YYYYmmdd-HHMMSS.mmm>-<pid>``,
  created with an exclusive mkdir (the next free ``-2``, ``-3`` ... if it exists): two sweeps
  started together, in one folder or two, never share one.
* Any sweep folder is locked while a sweep writes it (``flock`` on ``DIR/.sweep.lock``, released
  by the kernel when the process ends however it ends): a second ``bench sweep`` into the same
  ``--out`` is refused instead of running the same points twice into one table.
"""
from __future__ import annotations

import fcntl
import os
import socket
import time
from pathlib import Path

LOCK = ".sweep.lock"


class FolderBusy(RuntimeError):
    """Another sweep is writing this folder: the message is one line."""


def new_out_dir(root: Path, name: str) -> Path:
    """A new folder ``root/<name>-<time to the ms>-<pid>`` (created here, exclusively)."""
    now = time.time()
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(now)) + f".{int(now * 1000) % 1000:03d}"
    root.mkdir(parents=True, exist_ok=True)
    base = root / f"{name}-{stamp}-{os.getpid()}"
    for k in range(1, 10_000):
        cand = base if k == 1 else base.with_name(f"{base.name}-{k}")
        try:
            cand.mkdir()
            return cand
        except FileExistsError:
            continue
    raise FileExistsError(f"no free folder name like {base} in {root}")


class FolderLock:
    """``with FolderLock(out_dir):`` this process is the folder's only writer (FolderBusy if
    another holds it); ``command`` names the writer in the message ("bench sweep")."""

    def __init__(self, out_dir: Path, command: str = "bench sweep"):
        self.path = out_dir / LOCK
        self.command = command
        self.fd = -1

    def __enter__(self) -> "FolderLock":
        if self.fd >= 0:
            return self              # already held (claim_folder takes it before the ``with``)
        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                holder = os.pread(self.fd, 200, 0).decode(errors="replace").strip()
            except OSError:
                holder = ""
            os.close(self.fd)
            self.fd = -1
            raise FolderBusy(f"{self.path.parent}: another {self.command} is writing this folder"
                             f"{f' ({holder})' if holder else ''}; wait for it to end, or give "
                             f"another --out") from None
        try:
            os.ftruncate(self.fd, 0)
            os.pwrite(self.fd, f"pid {os.getpid()} on {socket.gethostname()} since "
                               f"{time.strftime('%Y-%m-%d %H:%M:%S')}\n".encode(), 0)
        except OSError:
            pass            # a full disk: the lock holds without its note
        return self

    def __exit__(self, *exc) -> None:
        if self.fd >= 0:
            os.close(self.fd)        # releases the lock; the file stays (removing it would race)
            self.fd = -1


def claim_folder(out: Path | None, default: Path, command: str) -> tuple[Path, FolderLock, str]:
    """The report folder of a ``bench claims`` or ``bench campaign`` run and its held lock.

    With ``--out`` (``out``) that folder, refused (FolderBusy) while another writer holds it.
    Without, the command's default folder (``reports/claims``, ``reports/campaigns/<name>``, the
    folder the docs name and ``--reuse`` finds), or, while another run holds it, a new folder
    beside it named as a sweep's (``<default>-<time to the ms>-<pid>``): two runs started together
    both finish, each in its own folder. The third value is a note for the console ("" if none).
    Release the lock with ``lock.__exit__()`` or use it as a context manager."""
    folder = out if out is not None else default
    folder.mkdir(parents=True, exist_ok=True)
    lock = FolderLock(folder, command)
    try:
        lock.__enter__()
        return folder, lock, ""
    except FolderBusy as busy:
        if out is not None:
            raise
        folder = new_out_dir(default.parent, default.name)
        lock = FolderLock(folder, command)
        lock.__enter__()
        return folder, lock, (f"{default} is being written by another {command} "
                              f"({str(busy).split('(', 1)[-1].split(')')[0]}); this one writes "
                              f"{folder}")


__all__ = ["FolderBusy", "FolderLock", "claim_folder", "new_out_dir", "LOCK"]
