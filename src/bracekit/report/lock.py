"""The lock of an output folder: a file ``.OUT.lock`` beside OUT holding the writer's pid, flock-ed while held."""

from __future__ import annotations

import errno
import os
import stat
import sys
from pathlib import Path

from bracekit.errors import OutputError


def reason(exc: OSError) -> str:
    """An OSError as a short reason: its text and the file it names."""
    where = f" ({Path(exc.filename).name})" if exc.filename else ""
    return f"{exc.strerror or exc}{where}"


def lock_path(path: Path) -> Path:
    """The lock file of OUT: ``.OUT.lock`` beside it."""
    return path.parent / f".{path.name}.lock"


def _busy(shown: str, pid: str, lock: Path) -> OutputError:
    who = f" (pid {pid})" if pid.isdigit() else ""
    return OutputError(
        f"another bracekit process{who} is writing to {shown} (lock {lock.name}); "
        "wait for it or choose another output folder"
    )


def lock_output(path: Path, shown: str) -> int:
    """Take the lock of OUT: a file `.OUT.lock` beside it holding the pid, flock-ed while the plan is open."""
    lock = lock_path(path)
    if sys.platform == "win32":  # no flock: a lock file made with O_EXCL, removed on close
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            raise _busy(shown, lock.read_text(encoding="ascii", errors="replace").strip(), lock) from None
        except OSError as exc:
            raise OutputError(f"cannot write beside {shown}: {reason(exc)}; choose another output folder") from exc
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        return fd
    import fcntl

    while True:
        try:  # never through a symbolic link: the lock is written, and nothing is written outside OUT's folder
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o666)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise OutputError(
                    f"{lock} is a symbolic link, not bracekit's lock file; remove it or choose another output folder"
                ) from None
            raise OutputError(f"cannot write beside {shown}: {reason(exc)}; choose another output folder") from exc
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise OutputError(f"{lock} is not a file; remove it or choose another output folder")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise _busy(shown, os.pread(fd, 32, 0).decode("ascii", "replace").strip(), lock) from None
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(lock))
            except FileNotFoundError:
                same = False
            if same:
                held = os.pread(fd, 64, 0).decode("ascii", "replace").strip()
                if held and not held.isdigit():
                    raise OutputError(
                        f"{lock} is not bracekit's lock file; move it away or choose another output folder"
                    )
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
                return fd
        except OSError as exc:
            os.close(fd)
            raise OutputError(f"cannot lock {shown}: {reason(exc)}; choose another output folder") from exc
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)  # its holder removed it between our open and flock: take the new one


def unlock_output(fd: int, lock: Path) -> None:
    """Release and remove the lock taken by :func:`lock_output`."""
    if sys.platform == "win32":
        os.close(fd)
        lock.unlink(missing_ok=True)
        return
    try:  # removed while still held: a process that opened the old file sees it is gone and opens the new one
        lock.unlink(missing_ok=True)
    finally:
        os.close(fd)


def alive(pid: int) -> bool:
    """Whether process `pid` runs (True when unsure: a folder of a live process is never removed)."""
    if pid == os.getpid() or sys.platform == "win32":  # os.kill(pid, 0) would end the process on Windows
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True
