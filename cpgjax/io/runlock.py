"""One writer per run file: an exclusive OS lock on a sidecar, ``RUN.h5.lock``, held for the whole run.

Why a sidecar: the writer opens and closes the HDF5 file between chunks (:mod:`cpgjax.io.results`), so a
lock on the file itself would lapse between chunks, and ``--overwrite`` replaces the file.  The sidecar is
locked with ``flock(LOCK_EX)`` BEFORE anything is created, replaced or deleted, and holds the holder's
pid, host and command line (for the one-line error a second writer gets).

- A second writer: :class:`~cpgjax.errors.ResultsError` at once, naming the file and the holder; nothing
  is changed.
- ``kill -9``: the kernel drops a ``flock`` with its process, so a lock file left behind is unlocked and
  the next run takes it (and writes its own pid into it).
- At the end of a run the sidecar is deleted while still locked.  A process that opened it just before
  then locks a deleted file: it notices (the path is gone or is another file) and starts over.
- Readers (plot, best, report, transfer) never take the lock; :func:`holder` only *probes* it (a shared
  lock, let go at once) to say that a run is still being written.  A writer whose lock attempt meets such
  a probe retries for :data:`PROBE_GRACE` seconds before it reports a holder.

The lock is advisory and local to one kernel: on a network file system (NFS) ``flock`` is as good as
that file system's locking (recent Linux NFS clients map it to byte-range locks the server enforces).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import socket
import sys
import time
from collections.abc import Iterator

from cpgjax.errors import ResultsError

SUFFIX = ".lock"
PROBE_GRACE = 1.0       # seconds a writer retries a busy lock (a reader's probe lasts microseconds)


def lock_path(path: str | os.PathLike[str]) -> str:
    """The sidecar of a run file: ``RUN.h5.lock`` beside it."""
    return os.fspath(path) + SUFFIX


def _me() -> dict:
    return {"pid": os.getpid(), "host": socket.gethostname(), "command": " ".join([os.path.basename(sys.argv[0])]
                                                                                   + sys.argv[1:])[:300]}


def is_mine(info: dict | None) -> bool:
    """Whether a :func:`holder`'s info is this very process (this pid on this host)."""
    return info is not None and info.get("pid") == os.getpid() and info.get("host") == socket.gethostname()


def _read_info(fd: int) -> dict:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        data = os.read(fd, 4096)
        info = json.loads(data.decode() or "{}")
        return info if isinstance(info, dict) else {}
    except (OSError, ValueError):
        return {}


def describe(info: dict) -> str:
    """``pid 123 on host (cpgjax evolve ...)``, or ``another process`` when the lock file says nothing yet."""
    if not info.get("pid"):
        return "another process"
    cmd = f" ({info['command']})" if info.get("command") else ""
    return f"pid {info['pid']} on {info.get('host', '?')}{cmd}"


def acquire(path: str | os.PathLike[str]) -> int:
    """Lock ``path``'s sidecar (created if missing); returns its descriptor for :func:`release`.

    :class:`ResultsError` naming the file and the holder when another process holds it.
    """
    p = os.fspath(path)
    lp = lock_path(p)
    d = os.path.dirname(lp)
    if d:
        os.makedirs(d, exist_ok=True)
    deadline = time.monotonic() + PROBE_GRACE
    while True:
        try:
            fd = os.open(lp, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise ResultsError(f"{lp}: cannot create the run's lock file ({e.strerror}); "
                               "check the folder's permissions, or name another --out") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            info = _read_info(fd)
            os.close(fd)
            if e.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise ResultsError(f"{lp}: cannot lock the run's lock file ({e.strerror})") from None
            if time.monotonic() < deadline:
                time.sleep(0.05)
                continue
            raise ResultsError(f"{p}: another process is writing this run: {describe(info)}; wait for it to "
                               f"end (or stop it), or name another --out") from None
        try:                                    # the holder before us deleted it: lock the path's new file
            same = os.stat(lp).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if not same:
            os.close(fd)
            continue
        os.ftruncate(fd, 0)
        os.write(fd, json.dumps(_me()).encode())
        return fd


def release(path: str | os.PathLike[str], fd: int) -> None:
    """Delete the sidecar (still locked, so nobody takes a file about to vanish) and let go."""
    with contextlib.suppress(OSError):
        if os.stat(lock_path(path)).st_ino == os.fstat(fd).st_ino:
            os.remove(lock_path(path))
    os.close(fd)


@contextlib.contextmanager
def hold(path: str | os.PathLike[str] | None) -> Iterator[None]:
    """Hold the run's lock within (``path=None``: nothing on disk, nothing to lock)."""
    if path is None:
        yield
        return
    fd = acquire(path)
    try:
        yield
    finally:
        release(path, fd)


@contextlib.contextmanager
def hold_all(paths) -> Iterator[None]:
    """Hold the locks of several run files within (all or none: a busy one lets go of those taken)."""
    with contextlib.ExitStack() as stack:
        for p in paths:
            stack.enter_context(hold(p))
        yield


def holder(path: str | os.PathLike[str]) -> dict | None:
    """Who is writing ``path`` now: ``{"pid", "host", "command"}`` (maybe empty), or None when nobody is.

    Never blocks and never creates the lock file; a lock file left by a killed writer reads as nobody.
    """
    try:
        fd = os.open(lock_path(path), os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            return _read_info(fd)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)
