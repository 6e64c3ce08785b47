"""MuJoCo cross-check of the braced statics (docs/model.md; the settings are in docs/validation.md).

A MuJoCo model mirrors a Pinocchio chain of 1-DoF revolute joints: nested bodies at the Pinocchio joint
placements, hinge joints with springs (stiffness k_i, springref), a small frictionless sphere at the brace
point {b} touching a plane, and a site at the tip point {e}. :func:`mujoco_static_deflection` preloads the
contact, settles, adds a dead tip wrench (applied at the tip point with ``mj_applyFT``), settles again and
returns the tip deflection relative to the preloaded state, in the conventions of
:mod:`bracekit.validate.statics`: Δx = [Δp; Δθ], Δθ = log3(R_e R_e,preᵀ) (world axes; m, rad).
With ``friction`` (condim 3, elliptic Coulomb cone), ``gravity`` and ``set_points`` the same model serves the
check of the holding statics, :mod:`bracekit.validate.holding_check`.

Settings that matter for ~1e-7 agreement with the Pinocchio statics (measured, see the tests):

* ``<compiler angle="radian"/>`` (springref is in degrees otherwise);
* the preload shifts the springs' rest (springref) exactly as the statics do; a dead force at b instead
  would differ at second order (estimated relative error ~ P·|∂J_b/∂q|/k, not small enough);
* a small sphere: a sphere rolls on the plane, so its centre, not b, is constrained; the discrepancy with a
  point contact is proportional to the radius (about 4e-4 relative per metre of radius here: 2e-6 at
  5 mm, 5e-8 at 0.1 mm). Default radius 0.1 mm;
* stiff contact: condim 1, solref "0.002 1", solimp "0.9999 0.9999 0.001", timestep ≤ 1 ms (MuJoCo
  clamps the solref time constant to ≥ 2 timesteps); bodies of 1 kg / 0.01 kg·m² (the contact's
  steady-state softness scales with the inverse constraint-space mass);
* quasi-static settling: implicitfast integrator and joint damping d_i = τ k_i with τ = 2√λ_max(K⁻¹M(q0)),
  which damps the heaviest mode critically and every other mode faster than e^(−t/τ); a few thousand
  steps, 0.06–0.15 s wall time per load case on 8- and 11-joint arms.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal
from xml.sax.saxutils import quoteattr

import mujoco
import numpy as np
import pinocchio as pin

from bracekit.errors import InputError, MujocoValidationError
from bracekit.validate.statics import (
    _check_model,
    _per_brace,
    _unit,
    multi_preload_set_points,
    preload_rest_configuration,
)

__all__ = [
    "MujocoResult",
    "MujocoValidationError",
    "MultiMujocoResult",
    "brace_geom_names",
    "build_mujoco_model",
    "build_mujoco_model_multi",
    "mujoco_static_deflection",
    "mujoco_static_deflection_multi",
]

TIP_SITE = "tip"
BRACE_GEOM = "brace_sphere"
SURFACE_GEOM = "surface"

_MAX_TIMESTEP = 1e-3  # s; solref's time constant 0.002 must stay >= 2 timesteps (MuJoCo clamps it otherwise)
_LINK_MASS = 1.0  # kg, mass of each moving body when gravity is off
_LINK_INERTIA = 1e-2  # kg·m², principal inertias of each moving body when gravity is off
_SOLREF = "0.002 1"  # stiff, critically damped contact
_SOLIMP = "0.9999 0.9999 0.001"  # maximal impedance from zero penetration on (MuJoCo caps it at 0.9999)
#: Constant impedance d of a soft (finite k_env) contact: solimp "d d 0.001"; any d in (0, 1) gives the same
#: static stiffness (the solref below compensates), 0.9 keeps the regulariser R well above MuJoCo's floor.
SOFT_IMPEDANCE = 0.9
_CHUNK = 10  # steps between updates of the tip-wrench application point and settling checks


@dataclass(frozen=True, eq=False)
class MujocoResult:
    """Result of :func:`mujoco_static_deflection`.

    Attributes:
        q: settled joint configuration under preload + wrench (n,), rad.
        deflection: Δx = [Δp; Δθ] (6,) of the tip site relative to the settled preloaded state (m, rad).
        contact_force: normal force the surface pushes on the sphere at the end (N; 0 if opened).
        converged: True when both settling phases met the tolerance (otherwise an error is raised).
        steps: simulation steps used (both phases).
        contact_opened: True when no active sphere–surface contact remains at the end.
        q_preloaded: settled configuration under the preload alone (n,), rad (≈ q0).
        settle_time: the damping time constant τ used (s of simulated time).
    """

    q: np.ndarray
    deflection: np.ndarray
    contact_force: float
    converged: bool
    steps: int
    contact_opened: bool
    q_preloaded: np.ndarray
    settle_time: float


# --------------------------------------------------------------------------------------------------
# MJCF
# --------------------------------------------------------------------------------------------------
def _fmt(x: float) -> str:
    return repr(float(x))


def _vec(v: np.ndarray | list[float]) -> str:
    return " ".join(_fmt(x) for x in np.asarray(v, dtype=float).reshape(-1))


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    c = pin.Quaternion(np.asarray(R, dtype=float)).coeffs()  # x, y, z, w
    return np.array([c[3], c[0], c[1], c[2]])


def _quat_z_to(nhat: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation taking the z axis to the unit vector nhat."""
    c = float(nhat[2])
    if c < -1.0 + 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])
    q = np.array([1.0 + c, -nhat[1], nhat[0], 0.0])  # (1 + z·n, z × n)
    return q / np.linalg.norm(q)


def _joint_axis(model: pin.Model, jid: int) -> np.ndarray:
    """Rotation axis of joint jid in its own frame, from its motion subspace (RX/RY/RZ/RevoluteUnaligned)."""
    jm = model.joints[jid]
    jd = jm.createData()
    jm.calc(jd, np.zeros(1))
    S = np.asarray(jd.S).reshape(6)
    return S[3:] / np.linalg.norm(S[3:])


@dataclass(frozen=True)
class _ContactGeoms:
    """One sphere–plane contact of the MJCF: {b_i}'s frame, its plane, geom names and collision bit."""

    frame_id: int
    point: np.ndarray
    normal: np.ndarray
    sphere: str
    surface: str
    bit: int
    k_env: float | None = None
    solref: str = _SOLREF
    solimp: str = _SOLIMP


def soft_contact_solref(k_env: float, inverse_weight: float, impedance: float = SOFT_IMPEDANCE) -> tuple[float, float]:
    """MuJoCo's direct-form solref (−s, −b) that makes a frictionless contact a spring of stiffness k_env (N/m).

    At rest (v = 0, zero constraint acceleration) MuJoCo's contact force is f = aref / R with
    aref = −K·d·r, K = s / d_w², R = (1 − d) A / d (d the impedance, d_w = solimp[1], A the contact's
    ``efc_diagApprox`` = the body's ``body_invweight0``; engine_core_constraint.c). With a constant impedance
    d = d_w this is f = −s r / ((1 − d) A), a spring of stiffness s / ((1 − d) A) on the penetration −r, so
    s = k_env (1 − d) A. The damping b = 2√s is the direct form of MuJoCo's critically damped reference
    (timeconst 1/√s, dampratio 1). docs/validation.md derives it.

    Args:
        k_env: the environment stiffness, N/m (> 0).
        inverse_weight: A, ``m.body_invweight0[body, 0]`` of the body carrying the sphere (1/kg).
        impedance: the constant impedance d of solimp "d d 0.001", in (0, 1).
    """
    s = float(k_env) * (1.0 - impedance) * float(inverse_weight)
    return s, 2.0 * float(np.sqrt(s))


def _mjcf_contacts(
    model: pin.Model,
    q0: np.ndarray,
    K: np.ndarray,
    rest: np.ndarray,
    contacts: list[_ContactGeoms],
    tip_frame_id: int,
    sphere_radius: float,
    gravity: bool,
    damping_time: float,
    timestep: float,
    friction: float | None = None,
    cone: str = "pyramidal",
    impratio: float = 1.0,
) -> str:
    """MJCF text: the spring-jointed chain, a sphere per contact on {b_i}'s body and its plane in the world.

    Sphere i has contype = bit_i and plane i conaffinity = bit_i (all other bits 0), so each sphere only
    collides with its own plane.
    """
    tjid = model.frames[tip_frame_id].parentJoint
    data = model.createData()
    pin.framesForwardKinematics(model, data, q0)
    spheres: dict[int, list[tuple[_ContactGeoms, np.ndarray]]] = {}
    for geoms in contacts:
        bjid = model.frames[geoms.frame_id].parentJoint
        p_b = data.oMf[geoms.frame_id].translation
        centre = p_b + sphere_radius * geoms.normal
        spheres.setdefault(bjid, []).append((geoms, data.oMi[bjid].actInv(centre)))
    tip_placement = model.frames[tip_frame_id].placement

    children: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        children[model.parents[j]].append(j)
    if friction is None:
        condim = 'condim="1"'
    else:  # sliding friction μ only; condim 3 has no torsional or rolling friction
        condim = f'condim="3" friction="{_fmt(friction)} 0 0"'

    def contact_attrs(geoms: _ContactGeoms) -> str:
        return f'{condim} solref="{geoms.solref}" solimp="{geoms.solimp}"'

    lines: list[str] = []

    def body(jid: int, indent: str) -> None:
        M = model.jointPlacements[jid]
        name = quoteattr(f"body_{model.names[jid]}")
        lines.append(f'{indent}<body name={name} pos="{_vec(M.translation)}" quat="{_vec(_quat_wxyz(M.rotation))}">')
        iv = model.joints[jid].idx_v
        lines.append(
            f'{indent}  <joint name={quoteattr(model.names[jid])} type="hinge" axis="{_vec(_joint_axis(model, jid))}" '
            f'stiffness="{_fmt(K[iv])}" springref="{_fmt(rest[iv])}" damping="{_fmt(damping_time * K[iv])}"/>'
        )
        if gravity:
            Y = model.inertias[jid]
            I = np.asarray(Y.inertia)
            ev, V = np.linalg.eigh(0.5 * (I + I.T))
            if np.linalg.det(V) < 0:
                V[:, 0] = -V[:, 0]
            lines.append(
                f'{indent}  <inertial pos="{_vec(Y.lever)}" quat="{_vec(_quat_wxyz(V))}" '
                f'mass="{_fmt(max(float(Y.mass), 1e-3))}" diaginertia="{_vec(np.maximum(ev, 1e-6))}"/>'
            )
        else:
            lines.append(
                f'{indent}  <inertial pos="0 0 0" mass="{_fmt(_LINK_MASS)}" diaginertia="{_vec([_LINK_INERTIA] * 3)}"/>'
            )
        for c in children[jid]:  # visual link segments; they never collide
            t = model.jointPlacements[c].translation
            if np.linalg.norm(t) > 1e-9:
                lines.append(
                    f'{indent}  <geom type="capsule" fromto="0 0 0 {_vec(t)}" size="0.01" '
                    'contype="0" conaffinity="0" group="1"/>'
                )
        for geoms, centre_local in spheres.get(jid, []):
            lines.append(
                f'{indent}  <geom name={quoteattr(geoms.sphere)} type="sphere" size="{_fmt(sphere_radius)}" '
                f'pos="{_vec(centre_local)}" contype="{geoms.bit}" conaffinity="0" {contact_attrs(geoms)}/>'
            )
        if jid == tjid:
            lines.append(
                f'{indent}  <site name="{TIP_SITE}" pos="{_vec(tip_placement.translation)}" '
                f'quat="{_vec(_quat_wxyz(tip_placement.rotation))}" size="0.01"/>'
            )
        for c in children[jid]:
            body(c, indent + "  ")
        lines.append(f"{indent}</body>")

    for c in children[0]:
        body(c, "    ")
    g = "0 0 -9.81" if gravity else "0 0 0"
    cone_attrs = 'cone="pyramidal" ' if friction is None else f'cone="{cone}" impratio="{_fmt(impratio)}" '
    head = [
        '<mujoco model="bracekit_brace_check">',
        '  <compiler angle="radian" inertiafromgeom="false"/>',
        (
            f'  <option timestep="{_fmt(timestep)}" gravity="{g}" integrator="implicitfast" '
            f'solver="Newton" {cone_attrs}tolerance="1e-14" iterations="200" ls_iterations="100"/>'
        ),
        "  <worldbody>",
    ]
    planes = [
        f'    <geom name={quoteattr(geoms.surface)} type="plane" size="0 0 1" pos="{_vec(geoms.point)}" '
        f'quat="{_vec(_quat_z_to(geoms.normal))}" contype="0" conaffinity="{geoms.bit}" {contact_attrs(geoms)}/>'
        for geoms in contacts
    ]
    return "\n".join([*head, *planes, *lines, "  </worldbody>", "</mujoco>"]) + "\n"


def _slowest_time_constant(xml: str, q0: np.ndarray, K: np.ndarray) -> float:
    """τ = 2√λ_max(K⁻¹ M(q0)) (s): damping τK makes the heaviest spring mode critically damped."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    Kh = 1.0 / np.sqrt(K)
    mu = float(np.linalg.eigvalsh(Kh[:, None] * M * Kh[None, :]).max())
    return 2.0 * np.sqrt(mu)


def build_mujoco_model(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_id: int,
    tip_frame_id: int,
    surface_point: np.ndarray,
    surface_normal: np.ndarray,
    *,
    sphere_radius: float = 1e-4,
    gravity: bool = False,
    preload: float = 0.0,
    damping_time: float | None = None,
    timestep: float | None = None,
    friction: float | None = None,
    cone: Literal["elliptic", "pyramidal"] = "elliptic",
    impratio: float = 1.0,
    set_points: np.ndarray | None = None,
    environment_stiffness: float | None = None,
) -> str:
    """MJCF string of the spring-jointed chain with a sphere contact at {b} on a plane (frictionless by default).

    Bodies mirror ``model.jointPlacements`` (MuJoCo qpos = Pinocchio q). Hinge i has stiffness k_i
    (N·m/rad), damping τ·k_i (N·m·s/rad) and springref = q0_i — or, when ``preload`` P > 0 (N), the
    shifted rest q0 − K⁻¹ J_b,v(q0)ᵀ n̂ P, so that q0 is the equilibrium under the contact force P (the
    spring model of :func:`bracekit.validate.statics.solve_static_equilibrium`).
    The sphere (radius ``sphere_radius``, m) is fixed to b's parent body with its centre at b + r n̂ at q0,
    so it touches the plane at b; the plane passes through ``surface_point`` with unit normal n̂ (toward the
    robot). Only sphere and plane collide (condim 1, or condim 3 with ``friction``; solref 0.002 1, solimp
    0.9999 0.9999 0.001). Site ``tip`` is at the tip frame, same orientation. Bodies get 1 kg and 0.01 kg·m²
    unless ``gravity``, which uses Pinocchio's inertias (floored at 1 g, 1e-6 kg·m²) and g = 9.81 m/s² along
    −z; with gravity, give the set points that hold it (``set_points``, e.g. from
    :func:`bracekit.statics.contact_response`), as :mod:`bracekit.validate.holding_check` does.

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, the (preloaded) equilibrium; b lies on the plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        brace_frame_id: Pinocchio frame id of {b}.
        tip_frame_id: Pinocchio frame id of {e}.
        surface_point: (3,) m, a point of the plane (world).
        surface_normal: (3,) unit normal, toward the robot.
        sphere_radius: radius of the contact sphere, m.
        gravity: use Pinocchio's inertias and gravity along −z.
        preload: contact force P ≥ 0 at q0, N.
        damping_time: τ (s); default 2√λ_max(K⁻¹M(q0)) (heaviest mode critically damped).
        timestep: s; default min(1 ms, τ/20).
        friction: Coulomb coefficient μ ≥ 0 of the sphere–plane contact: condim 3 (sliding friction only,
            ``friction="μ 0 0"``) instead of the frictionless condim 1.
        cone: MuJoCo's friction cone with ``friction``: ``"elliptic"`` is the Coulomb cone ‖f_t‖ ≤ μ f_n
            bracekit models; ``"pyramidal"`` approximates it with 4 facets.
        impratio: MuJoCo's ratio of frictional to normal constraint impedance (> 1 reduces tangential creep),
            used with ``friction``.
        set_points: spring set points (springref) q_s (n,), rad, instead of those derived from ``preload``,
            e.g. ``bracekit.statics.contact_response(...).q_s`` for a preload with gravity.
        environment_stiffness: k_env (N/m) of a soft surface, None (default) for the stiff contact: the contact
            becomes a spring of stiffness k_env (:func:`soft_contact_solref`) and the plane is pressed in by
            P / k_env at q0, so that the contact carries the preload there.

    Raises:
        InputError: unsupported joints, bad shapes, or a brace/tip frame fixed to the world.
    """
    _check_model(model)
    n = model.nv
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    nhat = _unit(surface_normal, "surface_normal")
    s = np.asarray(surface_point, dtype=float).reshape(3)
    if q0.size != n or K.size != n:
        raise InputError(f"q0 and stiffness must have shape ({n},), got {q0.shape} and {K.shape}")
    if not np.all(np.isfinite(K)) or np.any(K <= 0.0):
        raise InputError("joint stiffnesses must be finite and > 0")
    if not (np.isfinite(sphere_radius) and sphere_radius > 0.0):
        raise InputError("sphere_radius must be > 0 m")
    if not (np.isfinite(preload) and preload >= 0.0):
        raise InputError(f"preload must be a finite force >= 0 N, got {preload}")
    for fid in (brace_frame_id, tip_frame_id):
        if not 0 <= fid < model.nframes:
            raise InputError(f"frame id {fid} out of range (model has {model.nframes} frames)")
        if model.frames[fid].parentJoint == 0:
            raise InputError(f"frame {model.frames[fid].name!r} is fixed to the world; it must move with a joint")

    if friction is not None and not (np.isfinite(friction) and friction >= 0.0):
        raise InputError(f"friction must be a coefficient μ >= 0, got {friction}")
    if cone not in ("elliptic", "pyramidal"):
        raise InputError(f"cone must be 'elliptic' or 'pyramidal', got {cone!r}")
    if not (np.isfinite(impratio) and impratio >= 1.0):
        raise InputError(f"impratio must be a finite number >= 1, got {impratio}")
    if set_points is not None:
        rest = np.asarray(set_points, dtype=float).reshape(-1)
        if rest.size != n or not np.all(np.isfinite(rest)):
            raise InputError(f"set_points must be {n} finite joint values (rad), got shape {rest.shape}")
    elif preload > 0:
        rest = preload_rest_configuration(model, q0, K, brace_frame_id, nhat, preload)
    else:
        rest = q0
    k_env = _stiffness(environment_stiffness)
    plane = s if k_env is None else s + nhat * (preload / k_env)  # the soft surface is pressed in by P / k_env at q0
    contact = _ContactGeoms(brace_frame_id, plane, nhat, BRACE_GEOM, SURFACE_GEOM, 1, k_env)
    return _assemble(
        model, q0, K, rest, [contact], tip_frame_id, sphere_radius, gravity, damping_time, timestep, friction, cone,
        impratio,
    )  # fmt: skip


def _stiffness(k_env: float | None) -> float | None:
    if k_env is not None and not (isinstance(k_env, int | float) and np.isfinite(k_env) and k_env > 0.0):
        raise InputError(f"environment_stiffness must be a finite stiffness > 0 N/m (or None if rigid), got {k_env!r}")
    return None if k_env is None else float(k_env)


def _assemble(
    model: pin.Model,
    q0: np.ndarray,
    K: np.ndarray,
    rest: np.ndarray,
    contacts: list[_ContactGeoms],
    tip_frame_id: int,
    sphere_radius: float,
    gravity: bool,
    damping_time: float | None,
    timestep: float | None,
    friction: float | None = None,
    cone: str = "pyramidal",
    impratio: float = 1.0,
) -> str:
    """The MJCF in two passes: a rigid draft gives τ and each sphere body's inverse weight A, then the final text.

    A soft contact (k_env set) gets :func:`soft_contact_solref` and solimp "d d 0.001"; the default timestep
    resolves its time constant 1/√s (s = k_env (1 − d) A) with 10 steps.
    """
    rigid = [replace(c, solref=_SOLREF, solimp=_SOLIMP) for c in contacts]
    draft = _mjcf_contacts(model, q0, K, rest, rigid, tip_frame_id, sphere_radius, gravity, 0.0, _MAX_TIMESTEP,
                           friction, cone, impratio)  # fmt: skip
    if damping_time is None:
        damping_time = _slowest_time_constant(draft, q0, K)
    soft: list[_ContactGeoms] = []
    fastest = np.inf
    m = mujoco.MjModel.from_xml_string(draft) if any(c.k_env is not None for c in contacts) else None
    for c in rigid:
        if c.k_env is None or m is None:
            soft.append(c)
            continue
        body = int(m.geom_bodyid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, c.sphere)])
        sref, bref = soft_contact_solref(c.k_env, float(m.body_invweight0[body, 0]))
        fastest = min(fastest, 1.0 / np.sqrt(sref))
        d = _fmt(SOFT_IMPEDANCE)
        soft.append(replace(c, solref=f"{_fmt(-sref)} {_fmt(-bref)}", solimp=f"{d} {d} 0.001"))
    if timestep is None:
        timestep = min(_MAX_TIMESTEP, damping_time / 20.0, fastest / 10.0)
    if not (damping_time > 0.0 and timestep > 0.0):
        raise InputError("damping_time and timestep must be > 0 s")
    return _mjcf_contacts(model, q0, K, rest, soft, tip_frame_id, sphere_radius, gravity, damping_time, timestep,
                          friction, cone, impratio)  # fmt: skip


# --------------------------------------------------------------------------------------------------
# Simulation
# --------------------------------------------------------------------------------------------------
_BAD_WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQPOS: "bad qpos",
    mujoco.mjtWarning.mjWARN_BADQVEL: "bad qvel",
    mujoco.mjtWarning.mjWARN_BADQACC: "bad qacc",
    mujoco.mjtWarning.mjWARN_CONTACTFULL: "contact buffer full",
    mujoco.mjtWarning.mjWARN_CNSTRFULL: "constraint buffer full",
    mujoco.mjtWarning.mjWARN_INERTIA: "bad inertia",
}


def _check_warnings(d: mujoco.MjData, phase: str, messages: list[str]) -> None:
    hits = [txt for w, txt in _BAD_WARNINGS.items() if d.warning[int(w)].number > 0]
    if hits or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
        detail = f" MuJoCo said: {messages[0].strip()}" if messages else ""
        raise MujocoValidationError(
            f"MuJoCo simulation went unstable during {phase} ({', '.join(hits) or 'non-finite state'}); "
            f"reduce the load or the timestep.{detail}"
        )


def _contact_force(m: mujoco.MjModel, d: mujoco.MjData, sphere: int, plane: int) -> tuple[float, int]:
    """Total normal force (N) of the active sphere–plane contacts, and their number."""
    total, count = 0.0, 0
    f6 = np.zeros(6)
    for i in range(d.ncon):
        c = d.contact[i]
        if {int(c.geom1), int(c.geom2)} != {sphere, plane} or c.exclude != 0 or c.efc_address < 0:
            continue
        mujoco.mj_contactForce(m, d, i, f6)
        total += float(f6[0])
        count += 1
    return total, count


def _settle(
    m: mujoco.MjModel,
    d: mujoco.MjData,
    wrench: np.ndarray,
    tip_site: int,
    tip_body: int,
    tau: float,
    max_steps: int,
    tol: float,
    phase: str,
    messages: list[str],
) -> tuple[int, bool]:
    """Step until the remaining motion max|q̇|·τ falls below tol (rad). Returns (steps, settled).

    The wrench is re-applied at the current tip-site position every ``_CHUNK`` steps (exact at rest).
    """
    steps = 0
    f, tq = wrench[:3].copy(), wrench[3:].copy()
    loaded = bool(np.any(wrench != 0.0))
    while steps < max_steps:
        d.qfrc_applied[:] = 0.0
        if loaded:
            mujoco.mj_kinematics(m, d)
            mujoco.mj_applyFT(m, d, f, tq, d.site_xpos[tip_site].copy(), tip_body, d.qfrc_applied)
        nstep = min(_CHUNK, max_steps - steps)
        mujoco.mj_step(m, d, nstep)
        steps += nstep
        _check_warnings(d, phase, messages)
        if float(np.max(np.abs(d.qvel))) * tau < tol:
            return steps, True
    return steps, False


def mujoco_static_deflection(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_id: int,
    tip_frame_id: int,
    surface_point: np.ndarray,
    surface_normal: np.ndarray,
    wrench: np.ndarray,
    *,
    preload: float,
    max_steps: int = 100_000,
    tol: float = 1e-11,
    sphere_radius: float = 1e-4,
    gravity: bool = False,
    timestep: float | None = None,
    environment_stiffness: float | None = None,
) -> MujocoResult:
    """Tip deflection of the braced chain under a dead tip wrench, settled in MuJoCo.

    Phase 1: the springs' rest is shifted so that q0 is the equilibrium under the contact force
    ``preload`` (N), as in the Pinocchio statics, and the chain settles against the plane from q0.
    Phase 2: the wrench w = [f; m] (N, N·m, world axes) is applied at the tip point with ``mj_applyFT``
    (re-applied at the moving tip: a dead load) and the chain settles again. Settling stops when the
    remaining motion max|q̇|·τ < ``tol`` (rad); the loop runs on a step counter.

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, the (preloaded) equilibrium; b lies on the plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        brace_frame_id: Pinocchio frame id of {b}.
        tip_frame_id: Pinocchio frame id of {e}.
        surface_point: (3,) m, a point of the plane (world).
        surface_normal: (3,) unit normal, toward the robot.
        wrench: (6,) [f; m] at the tip, world axes (N, N·m).
        preload: contact force P ≥ 0 (N) at q0. A unilateral MuJoCo contact needs P > 0 to hold a pull.
        max_steps: step budget for both phases together.
        tol: settling tolerance, rad.
        sphere_radius: m; the rolling sphere differs from a point contact in proportion to it.
        gravity: gravity along −z with the URDF's masses and inertias; the set points then hold q0 under
            gravity and the preload, q_s = q0 + K⁻¹ (g(q0) − J_b,vᵀ n̂ P), as in the static solve with
            ``gravity=True``.
        timestep: MuJoCo timestep (s); default min(1 ms, τ/20) (and 1/10 of a soft contact's time constant).
        environment_stiffness: k_env (N/m) of a soft surface (:func:`build_mujoco_model`); None: stiff.

    Returns:
        :class:`MujocoResult` (deflection relative to the settled preloaded state).

    Raises:
        MujocoValidationError: unstable simulation (MuJoCo warnings or non-finite state), no settling within
            ``max_steps``, a model MuJoCo rejects, or no contact under a positive preload.
        InputError: bad inputs.
    """
    w = np.asarray(wrench, dtype=float).reshape(-1)
    if w.size != 6 or not np.all(np.isfinite(w)):
        raise InputError(f"wrench must be a finite (6,) vector, got shape {w.shape}")
    if max_steps < 1:
        raise InputError("max_steps must be >= 1")
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    nhat = _unit(surface_normal, "surface_normal")
    if not isinstance(gravity, bool):
        raise InputError(f"gravity must be True or False, got {gravity!r}")
    set_points = None
    if gravity:
        set_points = preload_rest_configuration(model, q0, K, brace_frame_id, nhat, preload, gravity=True)
    xml = build_mujoco_model(
        model,
        q0,
        K,
        brace_frame_id,
        tip_frame_id,
        surface_point,
        nhat,
        sphere_radius=sphere_radius,
        preload=preload,
        gravity=gravity,
        set_points=set_points,
        timestep=timestep,
        environment_stiffness=environment_stiffness,
    )
    try:
        m = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:
        raise MujocoValidationError(f"MuJoCo rejected the generated model: {exc}") from exc
    tau = float(m.dof_damping[0] / K[0])  # damping = τ k_i
    # MuJoCo's own warning handler prints and appends to MUJOCO_LOG.TXT in the working directory:
    # collect the messages instead (d.warning still counts them) and restore the handler afterwards.
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        return _simulate(m, q0, w, preload, tau, max_steps, tol, messages)
    finally:
        mujoco.set_mju_user_warning(previous)


def _simulate(
    m: mujoco.MjModel,
    q0: np.ndarray,
    w: np.ndarray,
    preload: float,
    tau: float,
    max_steps: int,
    tol: float,
    messages: list[str],
) -> MujocoResult:
    """The two settling phases of :func:`mujoco_static_deflection`."""
    out = _settle_phases(m, q0, w, [(BRACE_GEOM, SURFACE_GEOM, preload)], tau, max_steps, tol, messages)
    force, ncon = out.forces[0], out.counts[0]
    opened = ncon == 0 or force <= 0.0
    return MujocoResult(
        q=out.q,
        deflection=out.deflection,
        contact_force=0.0 if opened else force,
        converged=True,
        steps=out.steps,
        contact_opened=bool(opened),
        q_preloaded=out.q_preloaded,
        settle_time=tau,
    )


@dataclass(frozen=True)
class _Settled:
    """What the two settling phases give: final q, tip deflection, per-contact forces and counts, steps."""

    q: np.ndarray
    deflection: np.ndarray
    forces: list[float]
    counts: list[int]
    steps: int
    q_preloaded: np.ndarray


def _settle_phases(
    m: mujoco.MjModel,
    q0: np.ndarray,
    w: np.ndarray,
    contacts: list[tuple[str, str, float]],
    tau: float,
    max_steps: int,
    tol: float,
    messages: list[str],
) -> _Settled:
    """Settle under the preloads, then under the tip wrench; contacts are (sphere, plane, preload) names/N."""
    d = mujoco.MjData(m)
    tip_site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, TIP_SITE)
    tip_body = int(m.site_bodyid[tip_site])
    ids = [
        (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, sph), mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, pl))
        for sph, pl, _ in contacts
    ]
    d.qpos[:] = q0
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)

    zero = np.zeros(6)
    steps1, ok = _settle(m, d, zero, tip_site, tip_body, tau, max_steps, tol, "preload settling", messages)
    if not ok:
        raise MujocoValidationError(
            f"MuJoCo did not settle under the preload within {max_steps} steps (tol {tol:.1e} rad)"
        )
    mujoco.mj_forward(m, d)
    for i, ((sphere, plane), (_, _, preload)) in enumerate(zip(ids, contacts, strict=True)):
        _, ncon = _contact_force(m, d, sphere, plane)
        if preload > 0.0 and ncon == 0:
            which = "" if len(contacts) == 1 else f" of brace {i}"
            raise MujocoValidationError(
                f"no sphere–surface contact{which} under the preload: does b lie on the plane at q0?"
            )
    q_pre = d.qpos.copy()
    p0 = d.site_xpos[tip_site].copy()
    R0 = d.site_xmat[tip_site].reshape(3, 3).copy()

    budget = max_steps - steps1
    steps2, ok = _settle(m, d, w, tip_site, tip_body, tau, budget, tol, "loaded settling", messages)
    if not ok:
        raise MujocoValidationError(
            f"MuJoCo did not settle under the tip wrench within {max_steps} steps in total (tol {tol:.1e} rad)"
        )
    d.qfrc_applied[:] = 0.0
    mujoco.mj_applyFT(m, d, w[:3].copy(), w[3:].copy(), d.site_xpos[tip_site].copy(), tip_body, d.qfrc_applied)
    mujoco.mj_forward(m, d)
    measured = [_contact_force(m, d, sphere, plane) for sphere, plane in ids]
    R1 = d.site_xmat[tip_site].reshape(3, 3)
    return _Settled(
        q=d.qpos.copy(),
        deflection=np.concatenate([d.site_xpos[tip_site] - p0, pin.log3(R1 @ R0.T)]),
        forces=[f for f, _ in measured],
        counts=[c for _, c in measured],
        steps=steps1 + steps2,
        q_preloaded=q_pre,
    )


# --------------------------------------------------------------------------------------------------
# Several braces
# --------------------------------------------------------------------------------------------------
_MAX_BRACES = 31  # one collision bit per contact in MuJoCo's 32-bit contype/conaffinity


@dataclass(frozen=True, eq=False)
class MultiMujocoResult:
    """Result of :func:`mujoco_static_deflection_multi`.

    Attributes:
        q: settled joint configuration under preloads + wrench (n,), rad.
        deflection: Δx = [Δp; Δθ] (6,) of the tip site relative to the settled preloaded state (m, rad).
        contact_forces: normal force each surface pushes on its sphere at the end (N; 0 where opened), in the
            order of the braces.
        contact_opened: per brace, True when no active sphere–surface contact remains at the end.
        steps: simulation steps used (both phases).
        q_preloaded: settled configuration under the preloads alone (n,), rad (≈ q0).
        settle_time: the damping time constant τ used (s of simulated time).
    """

    q: np.ndarray
    deflection: np.ndarray
    contact_forces: np.ndarray
    contact_opened: tuple[bool, ...]
    steps: int
    q_preloaded: np.ndarray
    settle_time: float


def brace_geom_names(index: int) -> tuple[str, str]:
    """(sphere, plane) geom names of brace ``index`` in :func:`build_mujoco_model_multi`."""
    return f"{BRACE_GEOM}_{index}", f"{SURFACE_GEOM}_{index}"


def build_mujoco_model_multi(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_ids: Sequence[int],
    tip_frame_id: int,
    surfaces: Sequence[tuple[np.ndarray, np.ndarray]],
    *,
    preload: float | Sequence[float] | np.ndarray = 0.0,
    sphere_radius: float = 1e-4,
    damping_time: float | None = None,
    timestep: float | None = None,
    environment_stiffness: float | Sequence[float | None] | None = None,
) -> str:
    """MJCF string of the spring-jointed chain with a frictionless sphere contact at every {b_i}.

    As :func:`build_mujoco_model` (same bodies, springs, damping, contact settings and tip site, no gravity),
    with one sphere per brace i (geom ``brace_sphere_i``, centre b_i + r n̂_i at q0, on b_i's parent body) and
    one plane per brace (geom ``surface_i`` through point_i with normal n̂_i). Sphere i has contype 2^i and
    plane i conaffinity 2^i, so each sphere collides with its own plane only. The springs' rest is
    q_s = q0 − K⁻¹ Σ_i J_b_i(q0)ᵀ [P_i n̂_i; 0] (:func:`~bracekit.validate.statics.multi_preload_set_points`),
    so each contact carries P_i at q0.

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, the preloaded equilibrium; each b_i lies on its plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        brace_frame_ids: Pinocchio frame id of each {b_i} (at most 31 braces).
        tip_frame_id: Pinocchio frame id of {e}.
        surfaces: (point (3,) m, unit normal n̂_i toward the robot) of each brace's plane, world.
        preload: P_i ≥ 0 (N): one for all braces or one per brace.
        sphere_radius: radius of the contact spheres, m.
        damping_time: τ (s); default 2√λ_max(K⁻¹M(q0)) (heaviest mode critically damped).
        timestep: s; default min(1 ms, τ/20).
        environment_stiffness: k_env (N/m) of each brace's soft surface (one for all or one per brace; None:
            stiff), as in :func:`build_mujoco_model`.

    Raises:
        InputError: unsupported joints, bad shapes or counts, or a brace/tip frame fixed to the world.
    """
    _check_model(model)
    n = model.nv
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    if q0.size != n or K.size != n:
        raise InputError(f"q0 and stiffness must have shape ({n},), got {q0.shape} and {K.shape}")
    if not np.all(np.isfinite(K)) or np.any(K <= 0.0):
        raise InputError("joint stiffnesses must be finite and > 0")
    if not (np.isfinite(sphere_radius) and sphere_radius > 0.0):
        raise InputError("sphere_radius must be > 0 m")
    ids = [int(f) for f in brace_frame_ids]
    if not 1 <= len(ids) <= _MAX_BRACES:
        raise InputError(f"give between 1 and {_MAX_BRACES} brace frame ids, got {len(ids)}")
    if len(surfaces) != len(ids):
        raise InputError(f"give one surface (point, normal) per brace: {len(ids)} braces, {len(surfaces)} surfaces")
    for fid in (*ids, tip_frame_id):
        if not 0 <= fid < model.nframes:
            raise InputError(f"frame id {fid} out of range (model has {model.nframes} frames)")
        if model.frames[fid].parentJoint == 0:
            raise InputError(f"frame {model.frames[fid].name!r} is fixed to the world; it must move with a joint")
    normals = [_unit(nh, f"surfaces[{i}] normal") for i, (_, nh) in enumerate(surfaces)]
    points = [np.asarray(pt, dtype=float).reshape(3) for pt, _ in surfaces]
    P = _per_brace(preload, len(ids))
    rest = multi_preload_set_points(model, q0, K, ids, normals, P)
    ks = _per_brace_stiffness(environment_stiffness, len(ids))
    contacts = [
        _ContactGeoms(fid, pt if k is None else pt + nh * (p / k), nh, *brace_geom_names(i), 1 << i, k)
        for i, (fid, pt, nh, p, k) in enumerate(zip(ids, points, normals, P, ks, strict=True))
    ]
    return _assemble(model, q0, K, rest, contacts, tip_frame_id, sphere_radius, False, damping_time, timestep)


def _per_brace_stiffness(value: float | Sequence[float | None] | None, count: int) -> list[float | None]:
    """One k_env (N/m, None: rigid) per brace from one value or a sequence."""
    if value is None or isinstance(value, int | float):
        return [_stiffness(value)] * count
    ks = [_stiffness(v) for v in value]
    if len(ks) != count:
        raise InputError(f"give one environment stiffness (or None) per brace ({count}), got {len(ks)}")
    return ks


def mujoco_static_deflection_multi(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_ids: Sequence[int],
    tip_frame_id: int,
    surfaces: Sequence[tuple[np.ndarray, np.ndarray]],
    wrench: np.ndarray,
    *,
    preload: float | Sequence[float] | np.ndarray,
    max_steps: int = 100_000,
    tol: float = 1e-11,
    sphere_radius: float = 1e-4,
    timestep: float | None = None,
    environment_stiffness: float | Sequence[float | None] | None = None,
) -> MultiMujocoResult:
    """Tip deflection of the chain braced at several points under a dead tip wrench, settled in MuJoCo.

    The two phases of :func:`mujoco_static_deflection` on :func:`build_mujoco_model_multi`'s model: settle
    with the preloads P_i (springs' rest shifted so that q0 is the equilibrium), then apply w = [f; m] (N, N·m,
    world axes) at the tip point and settle again (max|q̇|·τ < ``tol`` rad). The contacts are unilateral: one
    that would pull more than its preload opens (``contact_opened``).

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, the preloaded equilibrium; each b_i lies on its plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        brace_frame_ids: Pinocchio frame id of each {b_i}.
        tip_frame_id: Pinocchio frame id of {e}.
        surfaces: (point (3,) m, unit normal n̂_i toward the robot) of each brace's plane, world.
        wrench: (6,) [f; m] at the tip, world axes (N, N·m).
        preload: P_i ≥ 0 (N): one for all braces or one per brace.
        max_steps: step budget for both phases together.
        tol: settling tolerance, rad.
        sphere_radius: m; the rolling spheres differ from point contacts in proportion to it.
        timestep: MuJoCo timestep (s); default min(1 ms, τ/20). Several stiff contacts may keep bouncing in a
            limit cycle at one timestep and settle at another (seen at 1 ms and at 0.5 ms, never at both):
            :func:`bracekit.validate.multi_brace.validate_several_braces` retries at half the step.
        environment_stiffness: k_env (N/m) of each brace's soft surface (one for all or one per brace; None:
            stiff), as in :func:`build_mujoco_model`.

    Returns:
        :class:`MultiMujocoResult` (deflection relative to the settled preloaded state).

    Raises:
        MujocoValidationError: unstable simulation, no settling within ``max_steps``, a model MuJoCo rejects,
            or a brace without contact under a positive preload.
        InputError: bad inputs.
    """
    w = np.asarray(wrench, dtype=float).reshape(-1)
    if w.size != 6 or not np.all(np.isfinite(w)):
        raise InputError(f"wrench must be a finite (6,) vector, got shape {w.shape}")
    if max_steps < 1:
        raise InputError("max_steps must be >= 1")
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    xml = build_mujoco_model_multi(
        model,
        q0,
        K,
        brace_frame_ids,
        tip_frame_id,
        surfaces,
        preload=preload,
        sphere_radius=sphere_radius,
        timestep=timestep,
        environment_stiffness=environment_stiffness,
    )
    P = _per_brace(preload, len(surfaces))
    try:
        m = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:
        raise MujocoValidationError(f"MuJoCo rejected the generated model: {exc}") from exc
    tau = float(m.dof_damping[0] / K[0])  # damping = τ k_i
    contacts = [(*brace_geom_names(i), float(p)) for i, p in enumerate(P)]
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        q0a = np.asarray(q0, dtype=float).reshape(-1)
        out = _settle_phases(m, q0a, w, contacts, tau, max_steps, tol, messages)
    finally:
        mujoco.set_mju_user_warning(previous)
    opened = tuple(c == 0 or f <= 0.0 for f, c in zip(out.forces, out.counts, strict=True))
    return MultiMujocoResult(
        q=out.q,
        deflection=out.deflection,
        contact_forces=np.array([0.0 if o else f for f, o in zip(out.forces, opened, strict=True)]),
        contact_opened=opened,
        steps=out.steps,
        q_preloaded=out.q_preloaded,
        settle_time=tau,
    )
