"""The command line ``bracekit``: a thin layer over the public API."""

from bracekit.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
