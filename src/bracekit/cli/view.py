"""``bracekit view OUT_DIR``: serve a run's output folder as an interactive 3D scene (viser) until Ctrl-C.

Also the ``--view`` and ``--view-port`` flags of ``bracekit run`` (serve the output folder once it is written).
"""

from __future__ import annotations

import argparse
import importlib.util
import signal
import sys
import threading
from pathlib import Path
from types import FrameType
from typing import Any

from bracekit.cli.common import STOP_SIGNALS
from bracekit.errors import InputError, MissingDependencyError

DEFAULT_PORT = 8080
DEFAULT_HOST = "127.0.0.1"


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a port is a number from 0 to 65535, got '{text}'") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"a port is a number from 0 to 65535, got {value}")
    return value


def add_parser(subparsers: Any) -> None:
    """Add the ``view`` command to the subparsers of ``bracekit``."""
    p = subparsers.add_parser(
        "view", help="an interactive 3D view of a run's output folder in the browser (viser; Ctrl-C stops it)"
    )
    p.add_argument("out_dir", type=Path, help="the output folder of `bracekit run` (holds scene.json)")
    p.add_argument("--port", type=_port, default=DEFAULT_PORT, help=f"TCP port (default {DEFAULT_PORT}; 0: any)")
    p.add_argument(
        "--host",
        default=DEFAULT_HOST,
        help=f"address to listen on (default {DEFAULT_HOST}, this machine only; from another one use ssh -L)",
    )


def add_run_flags(run_parser: argparse.ArgumentParser) -> None:
    """Add ``--view`` and ``--view-port`` to the ``run`` command."""
    run_parser.add_argument(
        "--view", action="store_true", help="after writing the outputs, serve them as a 3D scene (bracekit view)"
    )
    run_parser.add_argument(
        "--view-port", type=_port, default=DEFAULT_PORT, help=f"TCP port of --view (default {DEFAULT_PORT})"
    )


def needs_viser() -> None:
    """MissingDependencyError unless viser can be imported."""
    if importlib.util.find_spec("viser") is None:
        raise MissingDependencyError("bracekit view needs viser, which is not installed: pip install 'bracekit[view]'")


def check_run_flags(args: argparse.Namespace) -> None:
    """Before `bracekit run --view` computes anything: viser is installed and the port is free."""
    if not getattr(args, "view", False):
        return
    from bracekit.viewer.server import port_free

    needs_viser()
    if args.view_port != 0 and not port_free(DEFAULT_HOST, args.view_port):
        raise InputError(f"port {args.view_port} on {DEFAULT_HOST} is in use; choose another with --view-port")


def serve_until_stopped(out_dir: Path, port: int = DEFAULT_PORT, host: str = DEFAULT_HOST) -> int:
    """Serve `out_dir` and block until Ctrl-C or SIGTERM; return 0."""
    needs_viser()
    from bracekit.viewer.server import serve

    viewer = serve(out_dir, port=port, host=host)
    print(f"bracekit view: {out_dir} at {viewer.url} (Ctrl-C to stop)", flush=True)
    stop = threading.Event()
    previous: dict[int, Any] = {}
    if threading.current_thread() is threading.main_thread():

        def terminate(signum: int, frame: FrameType | None) -> None:
            stop.set()

        previous = {s: signal.signal(s, terminate) for s in STOP_SIGNALS}
    try:
        while not stop.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        viewer.stop()
        for s, handler in previous.items():
            signal.signal(s, handler)
    print("bracekit view: stopped", file=sys.stderr)
    return 0


def run(args: argparse.Namespace) -> int:
    """``bracekit view OUT_DIR [--port P] [--host H]``."""
    return serve_until_stopped(args.out_dir, port=args.port, host=args.host)
