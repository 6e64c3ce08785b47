"""Where numba keeps bracekit's compiled kernels: a user cache directory, never the source tree.

numba's ``cache=True`` writes next to the module's source unless ``NUMBA_CACHE_DIR`` names another directory.
:mod:`bracekit` imports this module first, before anything imports numba, and the import calls :func:`configure`:
``NUMBA_CACHE_DIR`` becomes ``$XDG_CACHE_HOME/bracekit/numba`` (``~/.cache/bracekit/numba`` without
XDG_CACHE_HOME) unless the user already set it; if numba was imported earlier, its live configuration is updated
too. Nothing is created here: numba makes the directory when it first writes a kernel (one subdirectory per
source tree, so two clones or versions never share a kernel).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

#: The environment variable numba reads at import for its cache directory.
ENV = "NUMBA_CACHE_DIR"


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/bracekit/numba``, or ``~/.cache/bracekit/numba`` (XDG base directories)."""
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    base = Path(xdg) if os.path.isabs(xdg) else Path.home() / ".cache"  # XDG: a relative value is ignored
    return base / "bracekit" / "numba"


def configure() -> str:
    """Set numba's cache directory unless the user chose one (``NUMBA_CACHE_DIR``); the directory in use."""
    chosen = os.environ.get(ENV)
    if not chosen:
        chosen = str(default_cache_dir())
        os.environ[ENV] = chosen
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba was imported before bracekit: its configuration was read already
        config.CACHE_DIR = chosen  # type: ignore[attr-defined]
    return chosen


configure()
