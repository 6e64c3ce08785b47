"""Everything the model says at one configuration, as one JSON-able dict (``bracekit evaluate``)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from bracekit.compliance.first_order import (
    compliance_ellipsoids,
    compliance_index,
    end_effector_compliance,
    free_space_compliance,
)
from bracekit.compliance.measures import frobenius_condition, singular_value_measures, theta_z
from bracekit.contact import Brace, Surface, contact_type
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot


def _ellipsoids(c: np.ndarray) -> dict[str, Any]:
    e = compliance_ellipsoids(c)
    return {
        "translational": {"semi_axes": e.translational.semi_axes, "axes": e.translational.axes},
        "rotational": {"semi_axes": e.rotational.semi_axes, "axes": e.rotational.axes},
    }


def _reduction(braced: float, free: float) -> float | None:
    """1 − braced/free, or None when the free compliance along β_x is (numerically) zero."""
    return None if free <= 1e-15 else 1.0 - braced / free


def evaluate(
    robot: Robot,
    brace_frame: str,
    q: ArrayLike,
    *,
    normal: ArrayLike = (0.0, 0.0, 1.0),
    contact: str = "frictionless_point",
    beta_x: ArrayLike | None = None,
) -> dict[str, Any]:
    """The braced model at q with a surface through b of the given normal (world).

    Keys (SI; matrices as nested lists row-major; twists [v; ω] and wrenches [f; m] at the tip point,
    world axes): J, J1, J2, H, X, A, J_braced, C_free, C_e_projection, C_e_constrained, k, k_braced,
    b, e, theta_z, the compliance index along β_x (default [n̂; 0]) in each model and the ellipsoids.
    """
    qa = robot.check_q(q)
    probe = BracedRobot(robot, Brace(brace_frame, Surface(np.zeros(3), normal)))
    b = probe.state(qa).b
    braced = BracedRobot(robot, Brace(brace_frame, Surface(b, normal), contact_type(contact)))
    st = braced.state(qa)
    beta = np.concatenate([braced.brace.surface.normal, np.zeros(3)]) if beta_x is None else np.asarray(beta_x)
    if beta.size != 6:
        raise InputError(f"--beta-x must have 6 numbers [vx, vy, vz, wx, wy, wz], got {beta.size}")
    c_free = free_space_compliance(st)
    c_con = end_effector_compliance(st, "constrained")
    c_proj = end_effector_compliance(st, "projection")
    ci = {
        name: compliance_index(c, beta)
        for name, c in (("free", c_free), ("constrained", c_con), ("projection", c_proj))
    }
    sv = singular_value_measures(st.J_braced)
    return {
        "n": robot.n,
        "n1": braced.n1,
        "n2": braced.n2,
        "joint_names": list(robot.joint_names),
        "brace_frame": brace_frame,
        "tip_frame": robot.tip,
        "contact": contact,
        "q": qa,
        "b": st.b,
        "e": st.e,
        "R_b": st.R_b,
        "R_e": st.R_e,
        "normal": braced.brace.surface.normal,
        "J": st.J,
        "J1": st.J1,
        "J2": st.J2,
        "H": st.H,
        "X": st.X,
        "A": st.A,
        "J_braced": st.J_braced,
        "C_free": c_free,
        "C_e_constrained": c_con,
        "C_e_projection": c_proj,
        "k": frobenius_condition(st.J),
        "k_braced": frobenius_condition(st.J_braced),
        **{f.name: getattr(sv, f.name) for f in dataclasses.fields(sv)},
        "theta_z": theta_z(braced.brace.surface.normal, st.z_b),
        "beta_x": beta / np.linalg.norm(beta),
        "Ci_free": ci["free"],
        "Ci_constrained": ci["constrained"],
        "Ci_projection": ci["projection"],
        "Ci_reduction_constrained": _reduction(ci["constrained"], ci["free"]),
        "Ci_reduction_projection": _reduction(ci["projection"], ci["free"]),
        "max_translational_free": float(np.linalg.eigvalsh(c_free[:3, :3])[-1]),
        "max_translational_constrained": float(np.linalg.eigvalsh(c_con[:3, :3])[-1]),
        "ellipsoid_free": _ellipsoids(c_free),
        "ellipsoid_constrained": _ellipsoids(c_con),
        "ellipsoid_projection": _ellipsoids(c_proj),
        "units": "m, rad, N, N·m; compliances in m/N, 1/N, rad/N, rad/(N·m)",
    }
