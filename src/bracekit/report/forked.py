"""A function run in a forked child process while the parent goes on (Linux with more than one core).

The child inherits the parent's memory (nothing is pickled), runs the function, reports a failure as one
line through a pipe and leaves with ``os._exit`` (no clean-up of the parent's state runs twice). Where fork
is not offered, or only one core is free, :func:`start` returns None and the caller runs the function itself.
"""

from __future__ import annotations

import os
import signal
import sys
import warnings
from collections.abc import Callable

from bracekit.errors import BracekitError, OutputError


def available() -> bool:
    """Whether a job may run in a forked child: Linux, os.fork, and more than one core for this process."""
    if not sys.platform.startswith("linux") or not hasattr(os, "fork"):
        return False
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return cores > 1


class ForkedJob:
    """`fn` running in a forked child; :meth:`wait` for it, :meth:`stop` it if it is no longer wanted.

    Args:
        fn: the work; its return value is ignored, an exception it raises is reported by :meth:`wait`.
        what: what the job makes, for messages (e.g. "animation.gif").
    """

    def __init__(self, fn: Callable[[], object], what: str) -> None:
        self.what = what
        read, write = os.pipe()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # Python ≥ 3.12 warns about fork with threads
            pid = os.fork()
        if pid == 0:  # the child
            os.close(read)
            code = 0
            try:
                fn()
            except BaseException as exc:  # every failure goes to the parent, which raises it
                kind = "os" if isinstance(exc, OSError) else "other"
                text = f"{kind}\t{type(exc).__name__}: {exc}".replace("\n", " ")
                os.write(write, text.encode("utf-8", "replace")[:4000])
                code = 1
            finally:
                os._exit(code)
        os.close(write)
        self.pid: int | None = pid
        self._read = read

    def wait(self) -> None:
        """Wait for the child to finish.

        Raises:
            OutputError: the job failed writing its file (an OSError in the child).
            BracekitError: the job failed otherwise, or the child was killed.
        """
        if self.pid is None:
            return
        message = self._message()
        _, status = os.waitpid(self.pid, 0)
        self.pid = None
        if os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0:
            return
        kind, _, text = message.partition("\t")
        if not text:
            text = f"the process drawing it ended with status {status}"
        if kind == "os":
            raise OutputError(f"cannot write {self.what}: {text}")
        raise BracekitError(f"cannot draw {self.what}: {text}")

    def stop(self) -> None:
        """End the child if it still runs and reap it (after a failure elsewhere); no error is raised."""
        if self.pid is None:
            return
        try:
            os.kill(self.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        try:
            os.waitpid(self.pid, 0)
        except ChildProcessError:
            pass
        self.pid = None
        self._message()

    def _message(self) -> str:
        """The child's failure line (empty when it reported none); closes the pipe."""
        if self._read < 0:
            return ""
        chunks = []
        try:
            while chunk := os.read(self._read, 4096):
                chunks.append(chunk)
        finally:
            os.close(self._read)
            self._read = -1
        return b"".join(chunks).decode("utf-8", "replace")


def start(fn: Callable[[], object], what: str) -> ForkedJob | None:
    """`fn` started in a forked child (:class:`ForkedJob`), or None where that is not available."""
    return ForkedJob(fn, what) if available() else None
