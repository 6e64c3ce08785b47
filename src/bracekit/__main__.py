"""``python -m bracekit``: the command line."""

import sys

from bracekit.cli import main

sys.exit(main())
