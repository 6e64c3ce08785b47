"""Reading a URDF into a Pinocchio model.

Continuous joints get finite parse limits, then are unbounded; Pinocchio's parser messages become one line.
"""

from __future__ import annotations

import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from bracekit._linalg import show
from bracekit.errors import InputError, ModelError
from bracekit.model.urdf_numbers import MAX_URDF_BYTES, check_urdf_numbers

#: The limit a continuous joint is given for the URDF parser (which refuses inf); the model then gets ±inf.
CONTINUOUS_PARSE_LIMIT = 1e30


@dataclass(frozen=True)
class UrdfJoints:
    """What bracekit rewrites or checks in a URDF before Pinocchio builds the model."""

    continuous: frozenset[str] = frozenset()
    mimic: tuple[tuple[str, str], ...] = ()  # (mimic joint, its leader)


def _rewrite_urdf(text: str) -> tuple[str, UrdfJoints]:
    """Continuous joints rewritten as revolute joints (q a plain angle) and the mimic joints listed.

    Pinocchio parses a continuous joint as (cos q, sin q) (nq = 2, nv = 1); as a revolute joint with limits
    ±CONTINUOUS_PARSE_LIMIT its q is the angle itself, and :func:`load_urdf` then makes the limits ±inf.
    Text that is not XML is returned unchanged (Pinocchio reports the error).
    """
    try:
        root = ET.fromstring(text)
    except (ET.ParseError, ValueError):
        return text, UrdfJoints()
    check_urdf_numbers(root)
    continuous: set[str] = set()
    mimic: list[tuple[str, str]] = []
    for joint in root.iter("joint"):
        name = joint.get("name", "")
        follow = joint.find("mimic")
        if follow is not None and joint.get("type") not in (None, "fixed", "floating", "planar"):
            mimic.append((name, follow.get("joint", "")))
        if joint.get("type") != "continuous":
            continue
        continuous.add(name)
        joint.set("type", "revolute")
        limit = joint.find("limit")
        if limit is None:
            limit = ET.SubElement(joint, "limit", {"effort": "0", "velocity": "0"})
        limit.set("lower", repr(-CONTINUOUS_PARSE_LIMIT))
        limit.set("upper", repr(CONTINUOUS_PARSE_LIMIT))
        limit.attrib.setdefault("effort", "0")
        limit.attrib.setdefault("velocity", "0")
    if not continuous:
        return text, UrdfJoints(mimic=tuple(mimic))
    return ET.tostring(root, encoding="unicode"), UrdfJoints(frozenset(continuous), tuple(mimic))


def _unbound(model: pin.Model, continuous: frozenset[str]) -> None:
    """Give the joints named in `continuous` the limits ±inf (in place)."""
    lower = np.asarray(model.lowerPositionLimit, dtype=float).copy()
    upper = np.asarray(model.upperPositionLimit, dtype=float).copy()
    for j in range(1, model.njoints):
        if model.names[j] in continuous and model.joints[j].nq == 1:
            i = model.joints[j].idx_q
            lower[i], upper[i] = -np.inf, np.inf
    model.lowerPositionLimit, model.upperPositionLimit = lower, upper


@contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence the C++ parser's own stderr lines (bracekit reports one line of its own)."""
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):  # no real file descriptor (e.g. captured)
        yield
        return
    sys.stderr.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


def load_urdf(source: str | os.PathLike[str]) -> tuple[pin.Model, UrdfJoints]:
    """The Pinocchio model of a URDF (continuous joints as revolute ones with limits ±inf) and its mimic joints."""
    if isinstance(source, str) and source.lstrip().startswith("<"):
        if len(source) > MAX_URDF_BYTES:
            raise ModelError(f"the URDF string is longer than {MAX_URDF_BYTES // 1024} KiB; give the URDF of a robot")
        text, joints = _rewrite_urdf(source)
        try:
            with _quiet_stderr():
                model = pin.buildModelFromXML(text)
            _unbound(model, joints.continuous)
            return model, joints
        except Exception as exc:  # pinocchio raises ValueError/RuntimeError with multi-line text
            why = first_line(exc)
            raise ModelError(f"cannot parse the URDF string: {why}; check that it is valid URDF XML") from exc
    path = as_path(source, "the URDF source", ModelError, "a .urdf file path or the URDF text (starting with '<')")
    shown = show(str(path), 200)
    try:
        found = path.is_file()
    except (OSError, ValueError):  # a name the file system cannot hold (too long, a NUL byte)
        found = False
    if not found:
        raise ModelError(f"URDF file not found: {shown}; give the path of an existing .urdf file")
    try:
        if path.stat().st_size > MAX_URDF_BYTES:
            raise ModelError(f"{shown} is larger than {MAX_URDF_BYTES // 1024} KiB; give a URDF file of a robot")
        head = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise ModelError(f"cannot read the URDF file {shown}: {exc.strerror}") from exc
    if "<robot" not in head:
        raise ModelError(f"{shown} is not a URDF file (no <robot> element); give a valid URDF file")
    text, joints = _rewrite_urdf(head)
    try:
        with _quiet_stderr():
            model = pin.buildModelFromXML(text) if joints.continuous else pin.buildModelFromUrdf(str(path))
        _unbound(model, joints.continuous)
        return model, joints
    except Exception as exc:
        raise ModelError(f"cannot parse the URDF file {shown}: {first_line(exc)}") from exc


def urdf_text(source: str | os.PathLike[str]) -> str:
    """The URDF text of a source that :func:`load_urdf` has read ("" if it cannot be read again)."""
    if isinstance(source, str) and source.lstrip().startswith("<"):
        return source
    try:
        return Path(os.fspath(source)).read_text(encoding="utf-8", errors="replace")
    except (OSError, ValueError, TypeError):
        return ""


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (at most 200 characters), or its type's name."""
    text = str(exc).strip()
    return show(text.splitlines()[0], 200) if text else type(exc).__name__


def as_path(source: object, what: str, error: type[InputError], want: str) -> Path:
    """`source` (a str or an os.PathLike naming a file) as a Path; `error` for anything else."""
    if isinstance(source, str | os.PathLike):
        name = os.fspath(source)
        if isinstance(name, str) and name:
            return Path(name)
    raise error(f"{what} must be {want}, got {show(source)}")
