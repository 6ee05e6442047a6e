"""One writer per results file: `with one_writer(path): ...` holds an exclusive lock on `path` for the
whole block, so that a second process appending to or resuming the same file (a second terminal, a
cluster job array, a re-run while the first is still going) is refused at once with WriterBusy, which
names the file and the holder's process id, instead of both writing duplicated rows.

The lock is the operating system's on a sidecar file `<path>.lock` holding the holder's pid:
fcntl.flock on POSIX, msvcrt.locking on Windows (the standard library only: the core install stays
numpy-only). The kernel releases it when the holder dies, however it dies, so a lock left by a killed
process (SIGKILL, a power cut) is no obstacle: the next run takes it and resumes the file. The sidecar
is removed on a normal release; one left by a killed process is just an unlocked file, reused.

Every command and function that appends to or resumes a file takes this lock (ibvs.study.sweep.sweep,
hence `ibvs sweep`); a new writer of that kind uses it too.
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Optional, Union

__all__ = ["WriterBusy", "one_writer"]


class WriterBusy(RuntimeError):
    """Another process holds the lock of `path` (its pid, None when it could not be read)."""

    def __init__(self, path: Path, pid: Optional[int]):
        self.path, self.pid = path, pid
        who = f"process {pid}" if pid is not None else "another process"
        super().__init__(f"{path} is being written by {who} (lock {lock_path(path)}); wait for it to finish, "
                         f"stop it, or write another file")


def lock_path(path: Union[str, os.PathLike]) -> Path:
    """The sidecar lock file of `path`: `<path>.lock`."""
    return Path(os.fspath(path) + ".lock")


if sys.platform == "win32":  # pragma: no cover - the CI runs on Linux
    import msvcrt

    #: The byte locked on Windows, past the pid written at the start (a locked range cannot be read there).
    _WINDOWS_BYTE = 1 << 20

    def _try_lock(fd: int) -> bool:
        os.lseek(fd, _WINDOWS_BYTE, os.SEEK_SET)
        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            return False
        return True

    def _unlock(fd: int) -> None:
        os.lseek(fd, _WINDOWS_BYTE, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)
else:
    import fcntl

    def _try_lock(fd: int) -> bool:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return False
        return True

    def _unlock(fd: int) -> None:
        fcntl.flock(fd, fcntl.LOCK_UN)


#: The descriptors of the locks this process holds: a process forked while one is held (a sweep's local
#: workers) closes its copies, so that the lock goes with this process (killed, it frees the file even
#: while its workers finish their batch). Closing a copy does not release the lock; unlocking would.
_held: set = set()


def _close_inherited() -> None:
    for fd in list(_held):
        try:
            os.close(fd)
        except OSError:
            pass
    _held.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_close_inherited)


def _holder(lock: Path) -> Optional[int]:
    """The pid written in the sidecar (None if there is none yet, or it cannot be read)."""
    try:
        text = lock.read_text(encoding="ascii", errors="replace").split()
        return int(text[0]) if text else None
    except (OSError, ValueError):
        return None


@contextmanager
def one_writer(path: Union[str, os.PathLike]) -> Iterator[Path]:
    """Hold the exclusive lock of `path` for the block (yields the sidecar's path); WriterBusy at once
    (no waiting) when another process holds it. OSError when the sidecar cannot be created (the
    file's directory is not writable)."""
    path = Path(path)
    lock = lock_path(path)
    while True:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
        if not _try_lock(fd):
            os.close(fd)
            raise WriterBusy(path, _holder(lock))
        # The holder before us may have removed the sidecar between our open and our lock: then we hold a
        # lock on a file nobody else will see; start again on the current one.
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(lock))
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    _held.add(fd)
    try:
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        yield lock
    finally:
        _held.discard(fd)
        try:
            os.unlink(lock)  # still holding it: no one can take it on the old file after this
        except OSError:
            pass  # Windows cannot remove an open file: it stays, unlocked
        try:
            _unlock(fd)
        finally:
            os.close(fd)
