"""A TOML table being read for a scenario: typed values, its path in messages, unknown keys refused.

:func:`read_source` opens the TOML files of scenarios, cobot scenarios and sweep specs: a shipped name or a path.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit._io import read_toml
from bracekit._linalg import show
from bracekit.errors import InputError, ScenarioError

Array = NDArray[np.float64]

__all__ = ["Table", "read_source"]


class Table:
    """A TOML table being read: tracks its path for messages and rejects unknown keys."""

    def __init__(self, data: Any, path: str, allowed: tuple[str, ...]) -> None:
        if not isinstance(data, dict):
            if not path:
                raise ScenarioError(f"a scenario must be a TOML table of keys, got {show(data)}")
            raise ScenarioError(f"'{path}' must be a table ([{path}] and its keys), got {show(data)}")
        unknown = sorted(set(data) - set(allowed))
        if unknown:
            where = f"[{path}]" if path else "the top level"
            keys = ", ".join(allowed)
            raise ScenarioError(f"unknown key '{_join(path, unknown[0])}'; allowed keys in {where}: {keys}")
        self.data, self.path = data, path

    def key(self, name: str) -> str:
        """The dotted path of a key of this table, for messages."""
        return _join(self.path, name)

    def has(self, name: str) -> bool:
        """Whether the key is given."""
        return name in self.data

    def raw(self, name: str, default: Any = ...) -> Any:
        """The value as read (ScenarioError if missing without a default)."""
        if name not in self.data:
            if default is ...:
                raise ScenarioError(f"missing key '{self.key(name)}'")
            return default
        return self.data[name]

    def number(self, name: str, default: Any = ..., positive: bool = False) -> float:
        """A finite number (positive if asked)."""
        v = self.raw(name, default)
        x = _float(v)
        if x is None:
            raise ScenarioError(f"'{self.key(name)}' must be a number, got {show(v)}")
        if positive and x <= 0:
            raise ScenarioError(f"'{self.key(name)}' must be positive, got {show(v)}")
        return x

    def vector(self, name: str, size: int | None = None, default: Any = ...) -> Array:
        """A list of finite numbers (of `size` if given)."""
        v = self.raw(name, default)
        values = [_float(x) for x in v] if isinstance(v, list) else [None]
        if None in values or (size is not None and len(values) != size) or (size is None and not values):
            want = f"{size} numbers" if size else "a list of numbers"
            raise ScenarioError(f"'{self.key(name)}' must be {want}, got {show(v)}")
        return np.asarray(values, dtype=float)

    def points(self, name: str, width: int = 3) -> Array:
        """A list of at least two [x, y, z] points (k×3); with width 6, of at least one [fx, fy, fz, mx, my, mz]."""
        v = self.raw(name)
        rows: list[list[float | None]] = [[None]]
        if isinstance(v, list):
            rows = [[_float(x) for x in p] if isinstance(p, list) and len(p) == width else [None] for p in v]
        least = 2 if width == 3 else 1
        if len(rows) < least or any(None in r for r in rows):
            want = (
                "a list of at least two [x, y, z] points (m)"
                if width == 3
                else "a list of wrenches [fx, fy, fz, mx, my, mz] (N, N·m, world axes)"
            )
            raise ScenarioError(f"'{self.key(name)}' must be {want}, got {show(v)}")
        return np.asarray(rows, dtype=float)

    def string(self, name: str, choices: tuple[str, ...] | None = None, default: Any = ...) -> str:
        """A string (one of `choices` if given)."""
        v = self.raw(name, default)
        if not isinstance(v, str):
            raise ScenarioError(f"'{self.key(name)}' must be a string, got {show(v)}")
        if choices is not None and v not in choices:
            raise ScenarioError(f"'{self.key(name)}' = {show(v)} is not one of: {', '.join(choices)}")
        return v

    def table(self, name: str, allowed: tuple[str, ...], default: Any = ...) -> Table:
        """A sub-table with its allowed keys."""
        return Table(self.raw(name, default), self.key(name), allowed)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _float(v: object) -> float | None:
    """A TOML number as a finite float; None for anything else (booleans, strings, inf, nan, huge integers)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return None
    try:
        x = float(v)
    except OverflowError:
        return None
    return x if math.isfinite(x) else None


def read_source(
    source: object,
    shipped: Mapping[str, Path],
    what: str,
    error: type[InputError] = ScenarioError,
    folder: Path | None = None,
) -> tuple[Path, dict[str, Any]]:
    """The path and TOML data of ``source``: a shipped name (a key of ``shipped``) or a .toml path.

    A relative path is taken from ``folder`` when given (else from the working directory). ``what`` names the
    file in messages ("scenario", "sweep spec", …); a missing, unreadable or non-TOML file raises ``error``
    with one line naming it and the shipped names.
    """
    names = ", ".join(sorted(shipped))
    if isinstance(source, str) and source in shipped:
        path = shipped[source]
    elif isinstance(source, str | os.PathLike) and isinstance(os.fspath(source), str) and os.fspath(source):
        path = Path(os.fspath(source))
        path = path if folder is None or path.is_absolute() else folder / path
    else:
        raise error(f"a {what} must be a .toml path or a shipped name ({names}), got {show(source)}")
    try:
        found = path.is_file()
    except (OSError, ValueError):  # a name the file system cannot hold
        found = False
    if not found:
        raise error(f"{what} not found: {show(str(source), 200)}; give a .toml file or one of: {names}")
    try:
        return path, read_toml(path, what)
    except InputError as exc:
        raise error(str(exc)) from None
