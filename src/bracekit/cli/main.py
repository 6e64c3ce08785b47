"""The command line: a thin layer over the public API. Input errors exit with 2, numerical ones with 1.

One module per command (``bracekit.cli.evaluate``, ``study``, ``run``, ``validate``, ``bench``, ``sweep``,
``view``), each with ``add_parser(subparsers)`` and ``run(args) -> exit code``; this module assembles the parser,
dispatches, and maps bracekit's typed errors to one line on stderr and the exit code.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import Any

from bracekit._version import __version__
from bracekit.cli import bench, evaluate, run, study, sweep, validate, view
from bracekit.cli.common import Parser, as_cli, join_negative
from bracekit.errors import BracekitError, InputError

COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "evaluate": evaluate.run,
    "study": study.run,
    "run": run.run,
    "validate": validate.run,
    "bench": bench.run,
    "sweep": sweep.run,
    "view": view.run,
}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of `bracekit`."""
    p = Parser(prog="bracekit", description="Braced serial robots: kinematics, compliance, redundancy resolution.")
    p.add_argument("--version", action="version", version=f"bracekit {__version__}")
    sub = p.add_subparsers(dest="command", parser_class=Parser, metavar="COMMAND")
    for module in (evaluate, study, run, validate, bench, sweep, view):
        module.add_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `bracekit` console script; returns the exit code."""
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
        return COMMANDS[args.command](args)
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
        sys.stderr.close()
        return 0
    finally:
        warnings.showwarning = saved


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
