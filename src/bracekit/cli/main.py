"""The command line: a thin layer over the public API. Input errors exit with 2, numerical ones with 1.

One module per command (``bracekit.cli.evaluate``, ``study``, ``run``, ``validate``, ``bench``, ``sweep``,
``view``), each with ``add_parser(subparsers)`` and ``run(args) -> exit code``; this module assembles the parser,
dispatches, and maps bracekit's typed errors to one line on stderr and the exit code.
"""

from __future__ import annotations

import argparse
import atexit
import errno
import os
import sys
import threading
import warnings
from collections.abc import Callable, Sequence
from typing import Any

from bracekit._version import __version__
from bracekit.cli import bench, cobot, evaluate, place, run, study, sweep, validate, view
from bracekit.cli.common import Parser, as_cli, join_negative
from bracekit.errors import BracekitError, InputError

COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "evaluate": evaluate.run,
    "study": study.run,
    "run": run.run,
    "validate": validate.run,
    "bench": bench.run,
    "sweep": sweep.run,
    "place": place.run,
    "view": view.run,
    "cobot": cobot.run,
}


#: Commands whose process, when the command line is the process's own (the console script, ``python -m
#: bracekit``), ends as soon as they return (:func:`_end_process`): they leave no thread running, their outputs
#: are written whole before they return.
ENDS_AT_ONCE = frozenset({"place"})

#: Errors of writing the standard output (a full device, a quota, an I/O error) reported in one line.
OUTPUT_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO)


def _silence_stdout() -> None:
    """Point the standard output at /dev/null so that the unwritten buffer is not flushed again at exit."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no real file descriptor (e.g. captured by a test)
        pass


def _end_process(code: int) -> None:
    """End the process now with exit status `code`, after the exit handlers (``atexit``) and the streams' flush.

    What an ordinary exit does beyond that is freeing every module's objects one by one (NumPy's, Pinocchio's,
    numba's and LLVM's, Dask's): 0.1-0.2 s of a command that takes one or two, for memory the process gives back
    as it ends anyway. Returns (the ordinary exit follows) when a thread Python would wait for is still running.
    """
    main_thread = threading.main_thread()
    if any(t is not main_thread and t.is_alive() and not t.daemon for t in threading.enumerate()):
        return
    flushed = _flush_streams()
    atexit._run_exitfuncs()
    flushed = _flush_streams() and flushed
    os._exit(code if flushed or code else 120)  # 120: Python's own status when its final flush fails


def _flush_streams() -> bool:
    """Flush the standard output and error; whether the output was flushed (False if closed or on a full device)."""
    flushed = True
    for stream in (sys.stdout, sys.stderr):
        if stream is None:  # started with it closed: nothing to flush
            continue
        try:
            stream.flush()
        except (OSError, ValueError):
            flushed = flushed and stream is not sys.stdout
    return flushed


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of `bracekit`."""
    p = Parser(prog="bracekit", description="Braced serial robots: kinematics, compliance, redundancy resolution.")
    p.add_argument("--version", action="version", version=f"bracekit {__version__}")
    sub = p.add_subparsers(dest="command", parser_class=Parser, metavar="COMMAND")
    for module in (evaluate, study, run, validate, bench, sweep, place, view, cobot):
        module.add_parser(sub)
    return p


def main(argv: Sequence[str] | None = None, *, end_at_once: bool = False) -> int:
    """The command line on `argv` (sys.argv[1:] if None); returns the exit code.

    `end_at_once` (the console script's and ``python -m bracekit``'s, :func:`console_main`): a command of
    :data:`ENDS_AT_ONCE` ends the process as soon as it returns; a caller in Python keeps its process.
    """
    args_list = join_negative(list(sys.argv[1:] if argv is None else argv))
    parser = build_parser()
    args = parser.parse_args(args_list)
    if args.command is None:
        parser.print_help()
        return 2

    def show(message: Any, category: type[Warning], *_: Any, **__: Any) -> None:
        print(f"bracekit: warning: {message}", file=sys.stderr)

    saved = warnings.showwarning
    warnings.showwarning = show
    try:
        code = COMMANDS[args.command](args)
        if sys.stdout is not None:  # None: started with its standard output closed (print writes nothing)
            sys.stdout.flush()  # a full device or a closed pipe is found here, not at exit
        if end_at_once and args.command in ENDS_AT_ONCE:
            _end_process(code)
        return code
    except OSError as exc:
        if isinstance(exc, BrokenPipeError) or exc.filename is not None or exc.errno not in OUTPUT_ERRNOS:
            raise
        _silence_stdout()
        print(f"bracekit: error: cannot write the output: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except InputError as exc:
        print(f"bracekit: error: {as_cli(str(exc))}", file=sys.stderr)
        return 2
    except BracekitError as exc:
        print(f"bracekit: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("bracekit: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. piped into head
        _silence_stdout()
        sys.stderr.close()
        return 0
    finally:
        warnings.showwarning = saved


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


def console_main() -> None:
    """The `bracekit` console script and ``python -m bracekit``: :func:`main` on sys.argv, its code the exit status."""
    sys.exit(main(end_at_once=True))
