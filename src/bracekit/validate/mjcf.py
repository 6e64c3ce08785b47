"""The MJCF of a braced chain for MuJoCo (docs/validation.md, "MuJoCo settings"; docs/model.md).

A MuJoCo model mirrors a Pinocchio chain of 1-DoF revolute joints: nested bodies at the Pinocchio joint
placements, hinge joints with springs (stiffness k_i, springref), a small sphere at every brace point {b_i}
touching its own plane, and a site at the tip point {e}. Settings that matter for ~1e-7 agreement with the
Pinocchio statics (measured, see the tests):

* ``<compiler angle="radian"/>`` (springref is in degrees otherwise);
* the preload shifts the springs' rest (springref) exactly as the statics do; a dead force at b instead
  would differ at second order (estimated relative error ~ P·|∂J_b/∂q|/k, not small enough);
* a small sphere: a sphere rolls on the plane, so its centre, not b, is constrained; the discrepancy with a
  point contact is proportional to the radius (about 4e-4 relative per metre of radius here: 2e-6 at
  5 mm, 5e-8 at 0.1 mm). Default radius 0.1 mm;
* stiff contact: condim 1, solref "0.002 1", solimp "0.9999 0.9999 0.001", timestep ≤ 1 ms (MuJoCo
  clamps the solref time constant to ≥ 2 timesteps); bodies of 1 kg / 0.01 kg·m² (the contact's
  steady-state softness scales with the inverse constraint-space mass); a finite surface stiffness k_env
  is a soft contact of exactly that stiffness (:func:`soft_contact_solref`);
* the sphere on a massless body of its own at the contact point: MuJoCo regularises a contact with the
  ``body_invweight0`` (the mobility at its centre of mass, at qpos0) of the sphere's body. On a link whose
  centre of mass cannot translate (link 2 of an arm whose joint-1 and joint-2 axes meet at its origin), that
  mobility is 0 and the regulariser R falls to MuJoCo's floor 1e-15: the contact is a hard constraint whose
  penetration at rest, f R / stiffness, is ~1e-16 m, so the sphere sits on the collision threshold, drops out
  of contact on round-off (45 steps in 20 000 on link 2 of the paper robot) and is kicked back in: the chain
  never settles. On its own body R is the mobility of the contact point (penetration ~5e-11 m at 1 N);
* quasi-static settling: implicitfast integrator and joint damping d_i = τ k_i with τ = 2√λ_max(K⁻¹M(q0)),
  which damps the heaviest mode critically and every other mode faster than e^(−t/τ).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal, cast
from xml.sax.saxutils import quoteattr

import mujoco
import numpy as np
import pinocchio as pin

from bracekit.errors import InputError
from bracekit.validate.lagrange import _check_model
from bracekit.validate.plane_contact import PlaneContact, _unit, contact_set_points

__all__ = [
    "BRACE_GEOM",
    "SOFT_IMPEDANCE",
    "SURFACE_GEOM",
    "TIP_SITE",
    "brace_geom_names",
    "build_mujoco_model",
    "soft_contact_solref",
]

TIP_SITE = "tip"
#: Prefix of the contact spheres' geom names (``brace_sphere_i``) and of the planes' (``surface_i``).
BRACE_GEOM = "brace_sphere"
SURFACE_GEOM = "surface"

_MAX_TIMESTEP = 1e-3  # s; solref's time constant 0.002 must stay >= 2 timesteps (MuJoCo clamps it otherwise)
_MAX_BRACES = 31  # one collision bit per contact in MuJoCo's 32-bit contype/conaffinity
_LINK_MASS = 1.0  # kg, mass of each moving body when gravity is off
_LINK_INERTIA = 1e-2  # kg·m², principal inertias of each moving body when gravity is off
_SOLREF = "0.002 1"  # stiff, critically damped contact
_SOLIMP = "0.9999 0.9999 0.001"  # maximal impedance from zero penetration on (MuJoCo caps it at 0.9999)
#: Constant impedance d of a soft (finite k_env) contact: solimp "d d 0.001"; any d in (0, 1) gives the same
#: static stiffness (the solref below compensates), 0.9 keeps the regulariser R well above MuJoCo's floor.
SOFT_IMPEDANCE = 0.9


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
    return cast(np.ndarray, q / np.linalg.norm(q))


def _joint_axis(model: pin.Model, jid: int) -> np.ndarray:
    """Rotation axis of joint jid in its own frame, from its motion subspace (RX/RY/RZ/RevoluteUnaligned)."""
    jm = model.joints[jid]
    jd = jm.createData()
    jm.calc(jd, np.zeros(1))
    S = np.asarray(jd.S).reshape(6)
    return cast(np.ndarray, S[3:] / np.linalg.norm(S[3:]))


@dataclass(frozen=True)
class _Chain:
    """The spring-jointed chain of an MJCF and its contact options.

    model, q0 (rad), K (N·m/rad), the set points ``rest`` (rad), the tip frame, the contacts' sphere radius (m),
    gravity, and μ, MuJoCo's cone and impratio.
    """

    model: pin.Model
    q0: np.ndarray
    K: np.ndarray
    rest: np.ndarray
    tip_frame_id: int
    sphere_radius: float
    gravity: bool
    friction: float | None
    cone: str
    impratio: float


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


def _mjcf_contacts(chain: _Chain, contacts: list[_ContactGeoms], damping_time: float, timestep: float) -> str:
    """MJCF text: the spring-jointed chain, a sphere per contact fixed to {b_i}'s body and its plane in the world.

    Each sphere sits on a massless body of its own at its centre: MuJoCo's contact regulariser then uses the
    mobility of the contact point, never 0 on a link whose centre of mass cannot move. Sphere i has
    contype = bit_i and plane i conaffinity = bit_i (all other bits 0), so each sphere only collides with its
    own plane.
    """
    model, q0, K, rest, tip_frame_id = chain.model, chain.q0, chain.K, chain.rest, chain.tip_frame_id
    sphere_radius, gravity, friction, cone, impratio = (
        chain.sphere_radius, chain.gravity, chain.friction, chain.cone, chain.impratio,
    )  # fmt: skip
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
                f'{indent}  <body name={quoteattr(geoms.sphere)} pos="{_vec(centre_local)}">'
                f'<geom name={quoteattr(geoms.sphere)} type="sphere" size="{_fmt(sphere_radius)}" '
                f'contype="{geoms.bit}" conaffinity="0" {contact_attrs(geoms)}/></body>'
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
    return float(2.0 * np.sqrt(mu))


def brace_geom_names(index: int) -> tuple[str, str]:
    """(sphere, plane) geom names of contact ``index`` in :func:`build_mujoco_model`."""
    return f"{BRACE_GEOM}_{index}", f"{SURFACE_GEOM}_{index}"


def build_mujoco_model(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    tip_frame_id: int,
    contacts: Sequence[PlaneContact],
    *,
    sphere_radius: float = 1e-4,
    gravity: bool = False,
    damping_time: float | None = None,
    timestep: float | None = None,
    friction: float | None = None,
    cone: Literal["elliptic", "pyramidal"] = "elliptic",
    impratio: float = 1.0,
    set_points: np.ndarray | None = None,
) -> str:
    """MJCF string of the spring-jointed chain with a sphere contact at every {b_i} on its plane.

    Bodies mirror ``model.jointPlacements`` (MuJoCo qpos = Pinocchio q). Hinge i has stiffness k_i (N·m/rad),
    damping τ·k_i (N·m·s/rad) and springref = q_s: by default the set points that make q0 the equilibrium under the
    contacts' preloads P_i (:func:`~bracekit.validate.plane_contact.contact_set_points`, no gravity), the spring
    model of :func:`bracekit.validate.statics.solve_statics`. Contact i is a sphere (geom ``brace_sphere_i``, radius
    ``sphere_radius``) on a massless body of the same name fixed to b_i's parent body with its origin at the
    sphere's centre b_i + r n̂_i at q0, and a plane (geom ``surface_i``) through the contact's point with normal
    n̂_i; sphere i has contype 2^i and plane i conaffinity 2^i, so each sphere collides with its own plane only (at
    most 31 contacts). The contact is MuJoCo's frictionless point (condim 1), or condim 3 with ``friction``; stiff
    (solref 0.002 1, solimp 0.9999 0.9999 0.001) or, with the contact's k_env, a spring of stiffness k_env
    (:func:`soft_contact_solref`) whose plane is pressed in by P_i / k_env at q0. Site ``tip`` is at the tip frame,
    same orientation. Bodies get 1 kg and 0.01 kg·m² unless ``gravity``, which uses Pinocchio's inertias (floored at
    1 g, 1e-6 kg·m²) and g = 9.81 m/s² along −z; with gravity, give the set points that hold it (``set_points``,
    e.g. from :func:`bracekit.statics.contact_response`).

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, the (preloaded) equilibrium; every b_i lies on its plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        tip_frame_id: Pinocchio frame id of {e}.
        contacts: the contacts (:class:`~bracekit.validate.plane_contact.PlaneContact`: frame, plane, preload,
            k_env; MuJoCo's sphere models the point contact, so X must be the default).
        sphere_radius: radius of the contact spheres, m.
        gravity: use Pinocchio's inertias and gravity along −z.
        damping_time: τ (s); default 2√λ_max(K⁻¹M(q0)) (heaviest mode critically damped).
        timestep: s; default min(1 ms, τ/20) (and 1/10 of a soft contact's time constant).
        friction: Coulomb coefficient μ ≥ 0 of every sphere–plane contact: condim 3 (sliding friction only,
            ``friction="μ 0 0"``) instead of the frictionless condim 1.
        cone: MuJoCo's friction cone with ``friction``: ``"elliptic"`` is the Coulomb cone ‖f_t‖ ≤ μ f_n
            bracekit models; ``"pyramidal"`` approximates it with 4 facets.
        impratio: MuJoCo's ratio of frictional to normal constraint impedance (> 1 reduces tangential creep),
            used with ``friction``.
        set_points: spring set points (springref) q_s (n,), rad, instead of those derived from the preloads,
            e.g. ``bracekit.statics.contact_response(...).q_s`` for a preload with gravity.

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
    if not 1 <= len(contacts) <= _MAX_BRACES:
        raise InputError(f"give between 1 and {_MAX_BRACES} contacts, got {len(contacts)}")
    for i, c in enumerate(contacts):
        if not isinstance(c, PlaneContact):
            raise InputError(f"contacts[{i}] must be a PlaneContact, got {type(c).__name__}")
        if c.X is not None:
            raise InputError("MuJoCo's sphere models the point contact: leave the PlaneContact's X at its default")
        if not (np.isfinite(c.preload) and c.preload >= 0.0):
            raise InputError(f"preload must be a finite force >= 0 N, got {c.preload}")
        _stiffness(c.k_env)
    for fid in (*(int(c.frame_id) for c in contacts), int(tip_frame_id)):
        if not 0 <= fid < model.nframes:
            raise InputError(f"frame id {fid} out of range (model has {model.nframes} frames)")
        if model.frames[fid].parentJoint == 0:
            raise InputError(f"frame {model.frames[fid].name!r} is fixed to the world; it must move with a joint")
    if friction is not None and not (np.isfinite(friction) and friction >= 0.0):
        raise InputError(f"friction must be a coefficient μ >= 0, got {friction}")
    if cone not in ("elliptic", "pyramidal"):
        raise InputError(f"cone must be 'elliptic' or 'pyramidal', got {cone!r}")
    if cone == "pyramidal" and friction and any(c.k_env is not None for c in contacts):
        raise InputError(
            "a soft contact (k_env) with friction needs cone='elliptic': its solref is set for one normal row, and "
            "the pyramid's rows make the contact stiffer than k_env"
        )
    if not (np.isfinite(impratio) and impratio >= 1.0):
        raise InputError(f"impratio must be a finite number >= 1, got {impratio}")
    normals = [
        _unit(c.normal, "surface_normal" if len(contacts) == 1 else f"surfaces[{i}] normal")
        for i, c in enumerate(contacts)
    ]
    if set_points is not None:
        rest = np.asarray(set_points, dtype=float).reshape(-1)
        if rest.size != n or not np.all(np.isfinite(rest)):
            raise InputError(f"set_points must be {n} finite joint values (rad), got shape {rest.shape}")
    elif any(c.preload > 0.0 for c in contacts):
        rest = contact_set_points(model, q0, K, contacts)
    else:
        rest = q0
    geoms = []
    for i, (c, nh) in enumerate(zip(contacts, normals, strict=True)):
        pt = np.asarray(c.point, dtype=float).reshape(3)
        k = _stiffness(c.k_env)
        plane = pt if k is None else pt + nh * (c.preload / k)  # a soft surface is pressed in by P / k_env at q0
        geoms.append(_ContactGeoms(int(c.frame_id), plane, nh, *brace_geom_names(i), 1 << i, k))
    chain = _Chain(model, q0, K, rest, int(tip_frame_id), sphere_radius, gravity, friction, cone, impratio)
    return _assemble(chain, geoms, damping_time, timestep)


def _stiffness(k_env: float | None) -> float | None:
    if k_env is not None and not (isinstance(k_env, int | float) and np.isfinite(k_env) and k_env > 0.0):
        raise InputError(f"environment_stiffness must be a finite stiffness > 0 N/m (or None if rigid), got {k_env!r}")
    return None if k_env is None else float(k_env)


def _assemble(chain: _Chain, contacts: list[_ContactGeoms], damping_time: float | None, timestep: float | None) -> str:
    """The MJCF in two passes: a rigid draft gives τ and each sphere body's inverse weight A, then the final text.

    A soft contact (k_env set) gets :func:`soft_contact_solref` and solimp "d d 0.001"; the default timestep
    resolves its time constant 1/√s (s = k_env (1 − d) A) with 10 steps.
    """
    rigid = [replace(c, solref=_SOLREF, solimp=_SOLIMP) for c in contacts]
    draft = _mjcf_contacts(chain, rigid, 0.0, _MAX_TIMESTEP)
    if damping_time is None:
        damping_time = _slowest_time_constant(draft, chain.q0, chain.K)
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
    return _mjcf_contacts(chain, soft, damping_time, timestep)
