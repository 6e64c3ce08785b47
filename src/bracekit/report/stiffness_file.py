"""The tool-stiffness JSON file of ``bracekit evaluate --stiffness-out``: written whole or not at all."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

from bracekit.errors import InputError, OutputError
from bracekit.report.output import to_json

#: The key that marks a file as bracekit's stiffness export (only such a file is replaced).
MARKER = "bracekit_tool_stiffness"


def _ours(path: Path) -> bool:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return False
    return isinstance(data, dict) and MARKER in data


def write_stiffness_json(path: Path, report: dict[str, Any], version: str) -> None:
    """Write `report` (``stiffness_report``) to `path` atomically (a temporary file, fsync, rename).

    An existing file is replaced only if it is an earlier stiffness export; anything else is refused with an
    InputError (bracekit never overwrites a user's file), as is a folder that does not exist.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"--stiffness-out {path} is a folder; give a file name such as K.json")
    if not path.parent.is_dir():
        raise InputError(f"--stiffness-out: the folder {path.parent} does not exist; create it or choose another path")
    if path.exists() and not _ours(path):
        raise InputError(f"--stiffness-out {path} exists and is not a bracekit stiffness export; choose a new path")
    text = to_json({MARKER: version, **report}) + "\n"
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise OutputError(f"cannot write --stiffness-out {path}: {exc.strerror}") from None
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise OutputError(f"cannot write --stiffness-out {path}: {exc.strerror}") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
