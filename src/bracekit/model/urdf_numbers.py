"""The numbers of a URDF checked at load: lengths, masses, inertias, collision sizes and limits in range.

Pinocchio reads a mass "nan" as 0 kg and accepts an origin of 1e300 m; either would give a wrong answer or a
failure far from its cause. Every number is checked here, and the error names the link or joint and the value.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

from bracekit._linalg import show
from bracekit.errors import ModelError

#: Largest URDF accepted, bytes (the shipped ones are < 100 kB).
MAX_URDF_BYTES = 32 * 1024 * 1024
#: Deepest nesting of XML elements accepted in a URDF (a URDF nests 5 levels; the URDF parser recurses).
MAX_URDF_DEPTH = 64
#: Largest length accepted in a URDF (an origin's coordinate, a collision radius or length), m.
MAX_LENGTH = 1e3
#: Largest link mass accepted in a URDF, kg.
MAX_MASS = 1e5
#: Largest moment of inertia accepted in a URDF, kg·m².
MAX_INERTIA = 1e6
#: Largest effort (N·m or N) and velocity (rad/s or m/s) limit accepted in a URDF.
MAX_LIMIT = 1e9


def _urdf_numbers(element: ET.Element, attribute: str, where: str) -> list[float]:
    """The numbers of an attribute (space-separated); ModelError naming `where` if one is not a finite number."""
    text = element.get(attribute)
    if text is None:
        return []
    try:
        values = [float(x) for x in text.split()]
    except ValueError:
        raise ModelError(f"{where} {attribute}={show(text)} is not a list of numbers; fix it in the URDF") from None
    if not all(np.isfinite(values)):
        raise ModelError(f"{where} {attribute}={show(text)} is not finite (NaN or inf); give finite numbers")
    return values


def _check_range(values: list[float], low: float, high: float, where: str, what: str) -> None:
    for v in values:
        if not low <= v <= high:
            raise ModelError(f"{where} has {what} {v:g}, outside [{low:g}, {high:g}]; fix it in the URDF")


def check_urdf_numbers(root: ET.Element) -> None:
    """ModelError (one line naming the link or joint and the value) for a number of a URDF out of range.

    Checked: every <origin> (xyz within ±MAX_LENGTH m, rpy finite), each link's <mass> (0 … MAX_MASS kg) and
    <inertia> (finite, |I| ≤ MAX_INERTIA kg·m²), each collision <geometry> (radius, length, size 0 … MAX_LENGTH
    m), each joint's <axis> and <limit> (finite; effort and velocity 0 … MAX_LIMIT). Pinocchio reads a "nan"
    mass as 0 kg and accepts an origin of 1e300 m; both would give wrong answers or failures far from the cause.
    """
    stack = [(root, 1)]
    while stack:
        element, depth = stack.pop()
        if depth > MAX_URDF_DEPTH:
            raise ModelError(f"the URDF nests XML elements deeper than {MAX_URDF_DEPTH} levels; give a valid URDF")
        stack.extend((child, depth + 1) for child in element)
    for kind in ("link", "joint"):
        for element in root.iter(kind):
            name = f"{kind} {show(element.get('name', '?'))}"
            for origin in element.iter("origin"):
                _check_range(_urdf_numbers(origin, "xyz", f"{name} <origin>"), -MAX_LENGTH, MAX_LENGTH, name, "xyz")
                _urdf_numbers(origin, "rpy", f"{name} <origin>")
            if kind == "link":
                for mass in element.iter("mass"):
                    values = _urdf_numbers(mass, "value", f"{name} <mass>")
                    _check_range(values, 0.0, MAX_MASS, name, "mass (kg)")
                for inertia in element.iter("inertia"):
                    for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
                        values = _urdf_numbers(inertia, key, f"{name} <inertia>")
                        _check_range(values, -MAX_INERTIA, MAX_INERTIA, name, f"inertia {key} (kg·m²)")
                for collision in element.iter("collision"):
                    for shape in collision.iter():
                        for key in ("radius", "length", "size"):
                            values = _urdf_numbers(shape, key, f"{name} collision <{shape.tag}>")
                            _check_range(values, 0.0, MAX_LENGTH, name, f"collision {shape.tag} {key} (m)")
            else:
                for axis in element.iter("axis"):
                    _urdf_numbers(axis, "xyz", f"{name} <axis>")
                for limit in element.iter("limit"):
                    for key in ("lower", "upper"):
                        _urdf_numbers(limit, key, f"{name} <limit>")
                    for key in ("effort", "velocity"):
                        _check_range(_urdf_numbers(limit, key, f"{name} <limit>"), 0.0, MAX_LIMIT, name, key)


def check_model_numbers(model: pin.Model) -> None:
    """ModelError for a link mass or a joint origin of a Pinocchio model out of range (see check_urdf_numbers)."""
    for j in range(1, model.njoints):
        mass = float(model.inertias[j].mass)
        if not 0.0 <= mass <= MAX_MASS:
            raise ModelError(
                f"the body of joint {show(model.names[j])} has mass {mass:g} kg, outside [0, {MAX_MASS:g}]; "
                "fix its <mass> in the URDF"
            )
        offset = np.asarray(model.jointPlacements[j].translation, dtype=float)
        if np.all(np.isfinite(offset)) and float(np.max(np.abs(offset))) > MAX_LENGTH:
            raise ModelError(
                f"joint {show(model.names[j])} has an origin {show(offset.tolist())} m beyond ±{MAX_LENGTH:g} m; "
                "fix its <origin xyz> in the URDF"
            )
