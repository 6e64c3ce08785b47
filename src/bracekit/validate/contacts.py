"""What MuJoCo and the static solve model of each contact type, and the contacts of a braced robot.

A contact type says how the physics references model it through :func:`register_mujoco_contact`: MuJoCo's
geometry at the brace point (a small sphere on the plane) and its ``condim``. The checks never branch on a
contact type's name: :func:`plane_contacts` turns every brace of a :class:`~bracekit.kinematics.BracedRobot`
into a :class:`~bracekit.validate.plane_contact.PlaneContact` (frame, plane, preload, k_env) and refuses by name a
contact type that has no MuJoCo model registered, saying how to add one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bracekit.contact.base import ContactType
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot
from bracekit.validate.plane_contact import PlaneContact

__all__ = ["MujocoContact", "mujoco_contact", "plane_contacts", "register_mujoco_contact"]


@dataclass(frozen=True)
class MujocoContact:
    """MuJoCo's model of a contact type at the brace point.

    Attributes:
        condim: MuJoCo's contact dimensionality without friction (1: a frictionless point); a friction
            coefficient μ makes it 3 (sliding friction, the sticking point of the holding checks).
        geometry: what MuJoCo builds, in words (reports and error messages).
    """

    condim: int
    geometry: str


_REGISTRY: dict[str, MujocoContact] = {}


def register_mujoco_contact(name: str, contact: MujocoContact) -> None:
    """Register MuJoCo's model of the contact type ``name`` (the name of its :class:`ContactType`)."""
    if not isinstance(contact, MujocoContact):
        raise InputError(f"expected a MujocoContact, got {type(contact).__name__}")
    _REGISTRY[name] = contact


register_mujoco_contact(
    "frictionless_point",
    MujocoContact(condim=1, geometry="a 0.1 mm sphere at b on the plane, frictionless (condim 1; 3 with μ)"),
)


def mujoco_contact(kind: ContactType) -> MujocoContact:
    """MuJoCo's model of a contact type; InputError naming the type when none is registered."""
    found = _REGISTRY.get(kind.name)
    if found is None:
        raise InputError(
            f"the validation has no MuJoCo model of the contact type '{kind.name}' (registered: "
            f"{', '.join(sorted(_REGISTRY))}); register one with bracekit.validate.contacts.register_mujoco_contact"
        )
    return found


def plane_contacts(
    braced: BracedRobot, preload: float | Sequence[float] = 0.0, *, environment: bool = True
) -> list[PlaneContact]:
    """The contacts of every brace of ``braced`` (in order) for the static solve and MuJoCo.

    Args:
        braced: the braced robot (one or several braces), each of a contact type MuJoCo models.
        preload: P_i ≥ 0 (N): one for every brace or one per brace.
        environment: keep each brace's environment stiffness k_env (False: every surface rigid).

    Raises:
        InputError: a contact type without a MuJoCo model, or bad preloads.
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    braces = braced.braces
    p = np.asarray(preload, dtype=float).reshape(-1)
    if p.size == 1:
        p = np.full(len(braces), float(p[0]))
    if p.size != len(braces) or not np.all(np.isfinite(p)) or np.any(p < 0.0):
        raise InputError(f"preload must be one finite force >= 0 N or one per brace ({len(braces)}), got {preload!r}")
    out = []
    for brace, fid, pi in zip(braces, braced.brace_ids, p, strict=True):
        mujoco_contact(brace.kind)
        k_env = brace.environment_stiffness if environment else None
        out.append(PlaneContact(int(fid), brace.surface.point, brace.surface.normal, float(pi), None, k_env))
    return out
