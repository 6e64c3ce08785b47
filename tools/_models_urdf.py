"""The small SE(3) helpers, the inertials and the deterministic URDF text writer of tools/build_models.py.

Transforms are 4x4 homogeneous matrices (m); URDF origins are xyz then roll-pitch-yaw with
R = Rz(yaw) Ry(pitch) Rx(roll), checked to round-trip; inertials are about the centre of mass in link axes
(kg, m, kg m^2), joined by the parallel-axis theorem and checked physically valid before they are written.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

PI = math.pi


# --- small SE(3) helpers --------------------------------------------------------
def rot_x(angle: float) -> np.ndarray:
    """Rotation matrix about x."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def homogeneous(rot: np.ndarray | None = None, xyz: tuple | None = None) -> np.ndarray:
    """4x4 transform from a rotation matrix and a translation."""
    out = np.eye(4)
    if rot is not None:
        out[:3, :3] = rot
    if xyz is not None:
        out[:3, 3] = xyz
    return out


def dh_constant(d: float, a: float, alpha: float) -> np.ndarray:
    """Constant part Tz(d) Tx(a) Rx(alpha) of a standard DH row."""
    return homogeneous(rot_x(alpha), (a, 0.0, d))


def rpy_from_rot(rot: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (R = Rz(y) Ry(p) Rx(r)) of a rotation matrix."""
    rot = np.where(np.abs(rot) < 1e-15, 0.0, rot) + 0.0  # no -0.0 signs
    sy = -rot[2, 0]
    if abs(abs(sy) - 1.0) < 1e-12:  # gimbal lock: put everything in roll
        pitch = math.copysign(PI / 2, sy)
        roll = math.atan2(0.0 - rot[1, 2], rot[1, 1])
        return roll, pitch, 0.0
    pitch = math.asin(max(-1.0, min(1.0, sy)))
    roll = math.atan2(rot[2, 1], rot[2, 2])
    yaw = math.atan2(rot[1, 0], rot[0, 0])
    return roll, pitch, yaw


def rot_from_rpy(rpy: tuple[float, float, float]) -> np.ndarray:
    """Rotation matrix R = Rz(y) Ry(p) Rx(r) (for the self-check)."""
    r, p, y = rpy
    cz, sz, cy, sy = math.cos(y), math.sin(y), math.cos(p), math.sin(p)
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    return rz @ ry @ rot_x(r)


def num(value: float) -> str:
    """Shortest exact text of a float; |v| < 1e-12 becomes 0."""
    value = float(value)
    if abs(value) < 1e-12:
        value = 0.0
    return repr(value)


def short(value: float) -> str:
    """Six significant digits, for inertial data (placeholders)."""
    return num(float(f"{float(value):.6g}"))


def vec(values: tuple | np.ndarray, fmt: Callable[[float], str] = num) -> str:
    """Space-separated numbers."""
    return " ".join(fmt(v) for v in values)


def placement(tf: np.ndarray) -> str:
    """Short text of a transform for comments: translation then rotation."""
    rpy = rpy_from_rot(tf[:3, :3])
    return f"translate ({vec(np.round(tf[:3, 3], 6))}), rpy ({vec(np.round(rpy, 6))})"


def origin_tag(tf: np.ndarray) -> str:
    """URDF <origin> of a 4x4 transform, checked to round-trip."""
    rpy = rpy_from_rot(tf[:3, :3])
    assert np.allclose(rot_from_rpy(rpy), tf[:3, :3], atol=1e-12), tf
    return f'<origin xyz="{vec(tf[:3, 3])}" rpy="{vec(rpy)}"/>'


# --- inertials ----------------------------------------------------------------
@dataclass(frozen=True)
class Inertial:
    """Mass, centre of mass and inertia about the CoM, in link axes."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def moved(self, tf: np.ndarray) -> Inertial:
        """Express the body in a frame in which this link frame has pose ``tf``."""
        rot = tf[:3, :3]
        return Inertial(self.mass, tf[:3, :3] @ self.com + tf[:3, 3], rot @ self.inertia @ rot.T)

    def __add__(self, other: Inertial) -> Inertial:
        """Rigidly joined bodies (parallel-axis theorem)."""
        mass = self.mass + other.mass
        com = (self.mass * self.com + other.mass * other.com) / mass
        total = np.zeros((3, 3))
        for part in (self, other):
            r = part.com - com
            total += part.inertia + part.mass * (r @ r * np.eye(3) - np.outer(r, r))
        return Inertial(mass, com, total)


def inertial(mass: float, com: tuple, inertia: tuple | np.ndarray) -> Inertial:
    """Build an Inertial; a flat 3-tuple of inertia means a diagonal tensor."""
    tensor = np.asarray(inertia, dtype=float)
    if tensor.ndim == 1:
        tensor = np.diag(tensor)
    return Inertial(mass, np.asarray(com, dtype=float), tensor)


def sphere(mass: float, com: tuple, radius: float = 0.06) -> Inertial:
    """Crude solid-sphere inertial (as hebi_description uses for brackets)."""
    return inertial(mass, com, (0.4 * mass * radius**2,) * 3)


def inertial_tag(body: Inertial, indent: str) -> list[str]:
    """URDF <inertial> lines; asserts a physically valid tensor."""
    eig = np.linalg.eigvalsh(body.inertia)
    assert body.mass > 0, body
    assert eig.min() > 0, body
    assert eig.sum() >= 2 * eig.max() - 1e-15, body  # triangle inequality
    t = body.inertia
    return [
        f"{indent}<inertial>",
        f'{indent}  <origin xyz="{vec(body.com, short)}" rpy="0.0 0.0 0.0"/>',
        f'{indent}  <mass value="{short(body.mass)}"/>',
        (
            f'{indent}  <inertia ixx="{short(t[0, 0])}" ixy="{short(t[0, 1])}" '
            f'ixz="{short(t[0, 2])}" iyy="{short(t[1, 1])}" '
            f'iyz="{short(t[1, 2])}" izz="{short(t[2, 2])}"/>'
        ),
        f"{indent}</inertial>",
    ]


# --- URDF writer ----------------------------------------------------------------
class Urdf:
    """Minimal deterministic URDF text builder."""

    def __init__(self, name: str, header: str) -> None:
        """Start a robot with a leading comment block."""
        assert "--" not in header
        self.lines = [
            '<?xml version="1.0"?>',
            "<!--",
            header.rstrip(),
            "-->",
            f'<robot name="{name}">',
        ]

    def comment(self, text: str) -> None:
        """Add an XML comment."""
        assert "--" not in text
        self.lines.append(f"  <!-- {text} -->")

    def link(self, name: str, body: Inertial | None = None) -> None:
        """Add a link, massless (pure frame) if ``body`` is None."""
        if body is None:
            self.lines.append(f'  <link name="{name}"/>')
            return
        self.lines.append(f'  <link name="{name}">')
        self.lines += inertial_tag(body, "    ")
        self.lines.append("  </link>")

    def joint(
        self,
        name: str,
        parent: str,
        child: str,
        tf: np.ndarray,
        limit: tuple[float, float, float, float] | None = None,
    ) -> None:
        """Add a revolute joint about +z (``limit`` given) or a fixed joint."""
        kind = "fixed" if limit is None else "revolute"
        self.lines += [
            f'  <joint name="{name}" type="{kind}">',
            f'    <parent link="{parent}"/>',
            f'    <child link="{child}"/>',
            f"    {origin_tag(tf)}",
        ]
        if limit is not None:
            lower, upper, effort, velocity = limit
            self.lines += [
                '    <axis xyz="0 0 1"/>',
                (
                    f'    <limit lower="{num(lower)}" upper="{num(upper)}" '
                    f'effort="{num(effort)}" velocity="{num(velocity)}"/>'
                ),
            ]
        self.lines.append("  </joint>")

    def text(self) -> str:
        """Finished document."""
        return "\n".join([*self.lines, "</robot>", ""])
