"""One writer per run directory: an advisory lock on ``run.lock`` in the folder.

``run``, ``resume``, ``verify`` and every other command that writes into a run directory
hold :class:`RunDirLock` while they write: an exclusive :func:`fcntl.flock` on
``RUN_DIR/run.lock``, a file that names the holder (PID, host, command, start time). A second
writer does not wait: it raises :class:`RunDirectoryBusy`, one line naming the holder.
Readers (``report``, ``view``) take no lock; every file is replaced atomically, so they read
the last complete state.

The kernel drops the lock when its holder ends, however it ends, so a killed run leaves at
most a stale ``run.lock`` naming a dead process, which the next writer takes over. A process
that already holds the lock of a folder may take it again (a workflow calling another): the
inner lock is then a no-op. The holder removes the file when it releases the lock, after
checking, whenever it takes the lock, that the file it locked is still the one in the folder.

The lock file is opened without following a symbolic link: a ``run.lock`` that is a link (in a
run directory someone else made, it could lead to any file the user may write, which taking
the lock would overwrite) is refused with :class:`UnsafeLockFile`.
"""

from __future__ import annotations

import errno
import fcntl
import json
import logging
import os
import socket
import time
from pathlib import Path
from types import TracebackType

from whisker_opt.output.storage import UnsafeLink

logger = logging.getLogger(__name__)

LOCK_NAME = "run.lock"


class RunDirectoryBusy(Exception):
    """Another process writes into the run directory (a user error: wait, or use another folder)."""


class UnsafeLockFile(UnsafeLink):
    """``run.lock`` is a symbolic link, which taking the lock would write through (a user error)."""


def _holder_text(command: str) -> str:
    return json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "command": command,
                       "since": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime())}) + "\n"


def read_holder(path: Path) -> dict:
    """The holder recorded in a lock file (empty when unreadable)."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return d if isinstance(d, dict) else {}


def _describe(holder: dict) -> str:
    if not holder.get("pid"):
        return "another process"
    cmd = f"`whisker-opt {holder['command']}`, " if holder.get("command") else ""
    return f"{cmd}PID {holder['pid']} on host {holder.get('host', '?')} (since {holder.get('since', '?')})"


class RunDirLock:
    """Exclusive writer lock of a run directory (a context manager).

    Parameters
    ----------
    run_dir : Path
        An existing folder.
    command : str
        What holds it, written into the lock file (e.g. ``run``, ``resume``).

    Raises
    ------
    RunDirectoryBusy
        On entry, when another process holds the lock.
    UnsafeLockFile
        On entry, when ``run.lock`` is a symbolic link.
    FileNotFoundError
        On entry, when ``run_dir`` is not a folder.
    """

    def __init__(self, run_dir: Path, command: str = "") -> None:
        self.run_dir = Path(run_dir)
        self.path = self.run_dir / LOCK_NAME
        self.command = command
        self._fd: int | None = None

    def _held_by_me(self) -> bool:
        h = read_holder(self.path)
        return h.get("pid") == os.getpid() and h.get("host") == socket.gethostname()

    def acquire(self) -> "RunDirLock":
        """Take the lock (see the class docstring)."""
        if not self.run_dir.is_dir():
            raise FileNotFoundError(f"{self.run_dir}: no such run directory")
        for _ in range(20):
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o644)
            except OSError as exc:
                if exc.errno != errno.ELOOP and not self.path.is_symlink():
                    raise
                raise UnsafeLockFile(
                    f"{self.path}: a symbolic link (to {os.readlink(self.path)!r}), not a lock file; taking the lock "
                    f"would write into what it leads to: remove the link (nothing else of {self.run_dir} uses it)"
                ) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                os.close(fd)
                if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    logger.warning("%s: cannot lock (%s); writing without a lock", self.path, exc.strerror)
                    return self
                if self._held_by_me():
                    return self  # taken by this process further out: nothing to do here
                holder = read_holder(self.path)
                if not holder:  # the holder has just taken it and not yet written its name
                    time.sleep(0.05)
                    holder = read_holder(self.path)
                raise RunDirectoryBusy(f"{self.run_dir}: in use by {_describe(holder)}, which writes into it "
                                       f"({self.path}); wait until it ends, or choose another folder") from None
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if not same:  # removed by its previous holder between our open and our lock: take the new file
                os.close(fd)
                continue
            os.ftruncate(fd, 0)
            os.pwrite(fd, _holder_text(self.command).encode("utf-8"), 0)
            self._fd = fd
            return self
        raise RunDirectoryBusy(f"{self.run_dir}: its lock {self.path} keeps changing hands; try again")

    def release(self) -> None:
        """Give the lock up and remove the lock file (nothing when this instance did not take it)."""
        if self._fd is None:
            return
        try:
            os.unlink(self.path)
        except OSError:
            pass
        try:
            fcntl.flock(self._fd, fcntl.LOCK_UN)
        finally:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> "RunDirLock":
        return self.acquire()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.release()
