"""The placed brace's Jacobian and its derivatives in the posture q and the place θ = (s, φ).

A brace at a link point p (link frame) moves with the link: with o_b the world position of a reference point
p0 of the same link (the template brace's frame {b}, whose Jacobian J_b0 is LOCAL_WORLD_ALIGNED at o_b) and
d = ⁰R_link (p − p0) (world), the pad point's Jacobian is (eq:J1: the brace Jacobian shifted along the link)

    J_b(p) = [I, −[d]×; 0, I] J_b0,          linear in p.

Its derivatives (J_ω = J_b0's angular rows, the link's):

    ∂J_b/∂q_k = [I, −[d]×; 0, I] ∂J_b0/∂q_k + [J_ω × (ω_k × d); 0],      ω_k = J_ω[:, k]  (∂d/∂q_k = ω_k × d)
    ∂J_b/∂θ_j = [J_ω × (⁰R_link ∂p/∂θ_j); 0]

(``J_ω × w`` column by column). The pad point b = o_b + d (world, m) and the inward normal
n_w = ⁰R_link n(φ) move as ∂b/∂q = J_b(p)[:3], ∂b/∂θ = ⁰R_link ∂p/∂θ, ∂n_w/∂q_k = ω_k × n_w,
∂n_w/∂θ = ⁰R_link ∂n/∂θ.
"""

from __future__ import annotations

from typing import NamedTuple, cast

import numpy as np
from numpy.typing import NDArray

from bracekit.kinematics import BracedState
from bracekit.model.robot import Robot
from bracekit.studies.place.surface import PadSurface

Array = NDArray[np.float64]


class PlacedBrace(NamedTuple):
    """The brace at the place θ = (s, φ) and posture q. World axes; m, rad.

    Attributes:
        b: the pad point (3,). n: the inward normal n_w (3,).
        J_b: its Jacobian (6×n). dJ_dq: ∂J_b/∂q (6, n, n). dJ_dtheta: ∂J_b/∂θ (6, n, 2).
        db_dtheta: ∂b/∂θ (3×2). dn_dq: ∂n_w/∂q (3×n). dn_dtheta: ∂n_w/∂θ (3×2).
    """

    b: Array
    n: Array
    J_b: Array
    dJ_dq: Array
    dJ_dtheta: Array
    db_dtheta: Array
    dn_dq: Array
    dn_dtheta: Array


def _cross_columns(a: Array, w: Array) -> Array:
    """The cross product a × w along the first axis (3, ...), the other axes broadcast (columns: a[:, i] × w[:, i]).

    Written out (NumPy's ``cross`` moves the axes on every call, several times the arithmetic here).
    """
    return np.stack([a[1] * w[2] - a[2] * w[1], a[2] * w[0] - a[0] * w[2], a[0] * w[1] - a[1] * w[0]])


def link_axes_in_brace(robot: Robot, link: str, frame: str) -> Array:
    """ᵇR_link (3×3): the link frame's axes in those of the brace frame {b} (both fixed to the same joint)."""
    model = robot.model
    r_b = np.asarray(model.frames[robot.frame_id(frame)].placement.rotation)
    r_l = np.asarray(model.frames[robot.frame_id(link)].placement.rotation)
    return cast(Array, r_b.T @ r_l)


def placed_brace(
    state: BracedState, surface: PadSurface, p0: Array, theta: Array, link_in_b: Array, index: int = 0
) -> PlacedBrace:
    """The brace `index` of `state` (a point frame of `surface.link` at p0, link frame, m) moved to θ = (s, φ).

    `link_in_b`: :func:`link_axes_in_brace` of that frame (its axes may be turned to a pad axis).
    """
    contact = state.contacts[index]
    if contact.dJ_b is None:
        raise ValueError("the state needs hessians=True")
    s, phi = float(theta[0]), float(theta[1])
    rot = contact.R_b @ link_in_b  # ⁰R_link
    d = rot @ (surface.point(s, phi) - p0)
    j0, dj0 = contact.J_b, contact.dJ_b
    j_w = j0[3:]
    n = j0.shape[1]
    w = _cross_columns(j_w, d[:, None])  # ω_k × d, column k
    jb = j0.copy()
    jb[:3] += w
    dj = dj0.copy()
    dj[:3] += _cross_columns(dj0[3:], d[:, None, None]) + _cross_columns(j_w[:, :, None], w[:, None, :])
    db = rot @ surface.point_derivative(s, phi)
    dth = np.zeros((6, n, 2))
    dth[:3] = _cross_columns(j_w[:, :, None], db[:, None, :])
    nw = rot @ surface.normal(s, phi)
    return PlacedBrace(
        b=contact.b + d,
        n=nw,
        J_b=jb,
        dJ_dq=dj,
        dJ_dtheta=dth,
        db_dtheta=db,
        dn_dq=_cross_columns(j_w, nw[:, None]),
        dn_dtheta=rot @ surface.normal_derivative(s, phi),
    )
