"""Parsing and errors shared by the commands of ``bracekit``: number lists, the one-line parser, SIGTERM, extras."""

from __future__ import annotations

import argparse
import importlib.util
import signal
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from types import FrameType
from typing import Any, NamedTuple

import numpy as np

from bracekit.errors import InputError, MissingDependencyError

#: Signals that stop a command like Ctrl-C (its output folder and lock cleaned up).
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))
LIST_OPTIONS = ("--q", "--stiffness", "--normal", "--beta-x", "--brace-offset", "--first-normal", "--second-normal")
OUT_HELP = (
    "checked before any computation and written whole: a previous bracekit output there is replaced, "
    "a folder holding other files is refused"
)
OVERWRITE_HELP = (
    "write into an --out that holds files bracekit did not write: bracekit's earlier files there are replaced, "
    "the other files are kept (never deleted or replaced)"
)


#: Most local Dask worker processes of --workers.
MAX_WORKERS = 256


def check_count(flag: str, value: int, least: int, most: int | None = None) -> None:
    """InputError unless the whole number `value` of `flag` is from `least` to `most` (no upper bound for None)."""
    if value < least or (most is not None and value > most):
        bound = f"at least {least}" if most is None else f"from {least} to {most}"
        raise InputError(f"{flag} must be {bound}, got {value}")


class CountFlag(NamedTuple):
    """A command's flag that takes a count: its default and range (checked by :meth:`check`, exit 2)."""

    flag: str
    default: int
    least: int
    most: int | None
    help: str

    def add(self, parser: argparse.ArgumentParser) -> None:
        """Declare the flag on `parser`."""
        parser.add_argument(self.flag, type=int, default=self.default, help=self.help)

    def check(self, args: argparse.Namespace) -> None:
        """InputError when the parsed value is out of range."""
        check_count(self.flag, getattr(args, self.flag.lstrip("-").replace("-", "_")), self.least, self.most)


def floats(text: str, what: str) -> np.ndarray:
    """The finite numbers of a comma-separated flag value; InputError naming the flag otherwise."""
    parts = [p for p in text.replace(" ", "").split(",") if p != ""]
    if not parts:
        raise InputError(f"{what} is empty; give comma-separated numbers, e.g. {what} 0.1,-0.2")
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise InputError(f"{what} must be comma-separated numbers, got '{text}'") from None
    if not np.all(np.isfinite(values)):
        raise InputError(f"{what} must be finite numbers, got '{text}'")
    return values


def join_negative(argv: Sequence[str]) -> list[str]:
    """Let `--q -0.5,1.2` work: argparse would take '-0.5,1.2' for an option."""
    out: list[str] = []
    it = iter(range(len(argv)))
    for i in it:
        tok = argv[i]
        if tok in LIST_OPTIONS and i + 1 < len(argv) and argv[i + 1].startswith("-") and len(argv[i + 1]) > 1:
            nxt = argv[i + 1]
            if nxt[1].isdigit() or nxt[1] == ".":
                out.append(f"{tok}={nxt}")
                next(it, None)
                continue
        out.append(tok)
    return out


class Parser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line and exit 2."""

    def error(self, message: str) -> Any:
        """Print one line and exit 2."""
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def one(text: str, what: str) -> float:
    """The single number of a flag; InputError for a list."""
    values = floats(text, what)
    if values.size != 1:
        raise InputError(f"{what} takes one number, got {values.size} ('{text}')")
    return float(values[0])


def pct(x: float | None) -> str:
    """A fraction as a percentage with one decimal ("–" for None)."""
    return "–" if x is None else f"{100 * x:.1f} %"


def needs(module: str, extra: str, what: str) -> None:
    """MissingDependencyError unless `module` can be imported (an optional extra of bracekit)."""
    if importlib.util.find_spec(module) is None:
        raise MissingDependencyError(f"{what} needs {module}, which is not installed: pip install 'bracekit[{extra}]'")


def needs_sweep_extra(command: str, figures: bool) -> None:
    """The optional packages of a Dask command (``bracekit sweep``, ``bracekit place``): the 'sweep' extra.

    Dask's distributed and pyarrow always; matplotlib when the command draws figures.
    """
    needs("distributed", "sweep", command)
    needs("pyarrow", "sweep", command)
    if figures:
        needs("matplotlib", "sweep", f"{command} with figures (or pass --no-figures)")


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM and SIGHUP raise KeyboardInterrupt while a command runs: it cleans up like Ctrl-C (exit 130)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    previous = {s: signal.signal(s, interrupt) for s in STOP_SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)


def as_cli(message: str) -> str:
    """A library message in the command line's words (its argument names become the flags)."""
    return (
        message.replace("overwrite=True", "--overwrite")
        .replace("another output folder", "another --out")
        .replace("points_per_link", "--points-per-link")
    )


def load_robot(args: argparse.Namespace) -> tuple[Any, str | None]:
    """The robot of --model or --urdf/--tip with --stiffness, and the model's own bracing frame."""
    from bracekit.model.robot import Robot
    from bracekit.model.shipped import MODELS, default_brace_frame, load_model

    stiffness = floats(args.stiffness, "--stiffness")
    k: float | np.ndarray = float(stiffness[0]) if stiffness.size == 1 else stiffness
    if args.model is not None:
        if args.model not in MODELS:
            raise InputError(f"unknown model '{args.model}'; choose one of {', '.join(MODELS)}")
        return load_model(args.model, stiffness=k, tip=args.tip), default_brace_frame(args.model)
    if args.tip is None:
        raise InputError("--tip is needed with --urdf: name the end-effector frame")
    return Robot.from_urdf(args.urdf, tip=args.tip, stiffness=k), None


def add_limits_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--allow-outside-limits`` (joint values beyond the URDF limits are refused without it)."""
    parser.add_argument(
        "--allow-outside-limits",
        action="store_true",
        help="accept joint values outside the URDF joint limits (refused by default)",
    )


def joint_values(args: argparse.Namespace, robot: Any) -> np.ndarray:
    """The joint values of --q for `robot`: n finite numbers within its URDF limits (unless allowed)."""
    q = robot.check_q(floats(args.q, "--q"))
    why = None if args.allow_outside_limits else robot.outside_limits(q)
    if why is not None:
        raise InputError(f"--q: {why}; give values within the limits or pass --allow-outside-limits")
    return np.asarray(q, dtype=float)
