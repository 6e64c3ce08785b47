"""Bounded readers of the files bracekit reads (TOML, JSON, NPZ): size and nesting capped before use.

Every TOML or JSON file bracekit reads (a scenario, a sweep spec, a run's scene.json and summaries, a sweep's
saved rows, an output manifest) goes through :func:`read_toml` / :func:`read_json`: the file is read up to
`max_bytes` (a larger one is refused without reading it whole), parsed, and its nesting checked to be at most
`max_depth` levels (a deeper one — which would exhaust Python's recursion — is refused in one line). An NPZ
archive is checked by :func:`npz_shapes` from its members' headers, before any array is decompressed.
"""

from __future__ import annotations

import json
import math
import os
import tomllib
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from bracekit.errors import InputError

#: Largest TOML or JSON file read, bytes (a scene.json of the paper is ~40 kB, a sweep row < 4 kB).
MAX_TEXT_BYTES = 32 * 1024 * 1024
#: Deepest nesting of lists and tables accepted in a TOML or JSON file (bracekit's own files nest ≤ 6 levels).
MAX_DEPTH = 32
#: Largest number of elements of all arrays of an NPZ file together (a long run holds ~10⁶).
MAX_NPZ_ELEMENTS = 50_000_000
#: Largest number of arrays in an NPZ file.
MAX_NPZ_ARRAYS = 10_000


def _depth_ok(data: Any, max_depth: int) -> bool:
    """Whether `data` nests at most `max_depth` lists/dicts deep (iterative: never recurses)."""
    stack: list[tuple[Any, int]] = [(data, 1)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, dict):
            children: Any = value.values()
        elif isinstance(value, list):
            children = value
        else:
            continue
        if depth > max_depth:
            return False
        stack.extend((child, depth + 1) for child in children)
    return True


def read_text(path: str | os.PathLike[str], what: str, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of a file of at most `max_bytes`; InputError (one line) otherwise."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(f"cannot read {what} {os.fspath(path)}: {exc.strerror or exc}") from None
    if len(raw) > max_bytes:
        raise InputError(f"{what} {os.fspath(path)} is larger than {max_bytes // 1024} KiB; give a smaller file")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{what} {os.fspath(path)} is not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def _bounded(parse: Any, text: str, shown: str, what: str, max_depth: int, kind: str) -> Any:
    try:
        data = parse(text)
    except RecursionError:
        data = None
        deep = True
    except (ValueError, TypeError) as exc:  # JSONDecodeError and TOMLDecodeError are ValueErrors
        reason = " ".join(str(exc).split())[:200]
        raise InputError(f"{' '.join(filter(None, (what, shown)))} is not valid {kind}: {reason}") from None
    else:
        deep = not _depth_ok(data, max_depth)
    if deep:
        raise InputError(
            f"{' '.join(filter(None, (what, shown)))} nests lists or tables deeper than {max_depth} levels; "
            "give a flatter file"
        )
    return data


def loads_json(text: str | bytes, what: str, max_depth: int = MAX_DEPTH) -> Any:
    """JSON text parsed with its nesting capped; InputError for invalid or too deeply nested JSON."""
    if len(text) > MAX_TEXT_BYTES:
        raise InputError(f"{what} is larger than {MAX_TEXT_BYTES // 1024} KiB")
    return _bounded(
        json.loads, text if isinstance(text, str) else text.decode("utf-8", "replace"), "", what, max_depth, "JSON"
    )


def read_json(
    path: str | os.PathLike[str], what: str, max_bytes: int = MAX_TEXT_BYTES, max_depth: int = MAX_DEPTH
) -> Any:
    """The JSON value of a file, size and nesting capped; InputError (one line) for anything else."""
    text = read_text(path, what, max_bytes)
    return _bounded(json.loads, text, os.fspath(path), what, max_depth, "JSON")


def read_toml(
    path: str | os.PathLike[str], what: str, max_bytes: int = MAX_TEXT_BYTES, max_depth: int = MAX_DEPTH
) -> dict[str, Any]:
    """The table of a TOML file, size and nesting capped; InputError (one line) for anything else."""
    text = read_text(path, what, max_bytes)
    data: dict[str, Any] = _bounded(tomllib.loads, text, os.fspath(path), what, max_depth, "TOML")
    return data


def npz_shapes(
    path: str | os.PathLike[str], max_elements: int = MAX_NPZ_ELEMENTS, max_arrays: int = MAX_NPZ_ARRAYS
) -> dict[str, tuple[tuple[int, ...], np.dtype[Any]]]:
    """Name → (shape, dtype) of each array of an NPZ file, read from the .npy headers only (nothing decompressed).

    Raises:
        InputError: not a ZIP of .npy arrays, an object (pickled) array, too many arrays, or more than
            `max_elements` elements in all (so that loading it could not exhaust the memory).
    """
    shown = Path(os.fspath(path)).name
    out: dict[str, tuple[tuple[int, ...], np.dtype[Any]]] = {}
    total = 0
    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
            if len(members) > max_arrays:
                raise InputError(f"{shown} holds {len(members)} arrays (more than {max_arrays})")
            for info in members:
                if not info.filename.endswith(".npy"):
                    raise InputError(f"{shown} holds {info.filename!r}, not a .npy array")
                with archive.open(info) as fh:
                    version = np.lib.format.read_magic(fh)
                    if version == (1, 0):
                        shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
                    elif version == (2, 0):
                        shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
                    else:
                        raise InputError(f"{shown}: {info.filename} has .npy format {version}, not 1.0 or 2.0")
                if dtype.hasobject:
                    raise InputError(f"{shown}: {info.filename} holds Python objects, which bracekit never reads")
                count = math.prod(shape)
                total += count
                if total > max_elements:
                    raise InputError(
                        f"{shown} holds more than {max_elements} numbers ({info.filename} alone {count}); "
                        "bracekit does not load it"
                    )
                out[info.filename[: -len(".npy")]] = (tuple(shape), dtype)
    except InputError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error, RuntimeError, NotImplementedError) as exc:
        why = " ".join((str(exc) or type(exc).__name__).split())[:200]
        raise InputError(f"cannot read {shown} ({why})") from None
    return out
