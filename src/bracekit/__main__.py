"""``python -m bracekit``: the command line."""

from bracekit.cli.main import console_main

console_main()
