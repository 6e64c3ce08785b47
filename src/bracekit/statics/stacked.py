"""The preloaded equilibrium with every brace of a braced robot (N ≥ 1) and its first-order load response.

The conventions and the physics are those of :mod:`bracekit.statics.equilibrium`, with one load contact per
brace stacked in the KKT system (docs/model.md, "Several braces"). :func:`contact_responses` serves any number
of braces; :func:`contact_response` is one brace's view at one configuration (:class:`ContactResponse`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, finite_math, show
from bracekit.errors import (
    ContactError,
    InputError,
    NumericalError,
    RedundantContactWarning,
    UnloadedContactWarning,
    UnstableEquilibriumError,
)
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.braced import contact_null_space
from bracekit.kinematics.constraint import _independent_rows
from bracekit.kinematics.hessian import ensure_hessian_layout, frame_hessian
from bracekit.statics.equilibrium import (
    ContactResponse,
    LoadResponse,
    _check_size,
    check_friction,
    check_preload,
    configurations,
    load_contact_wrenches,
)

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ContactResponses(LoadResponse):
    """The preloaded equilibrium with B ≥ 1 braces at N configurations and its first-order response to a tool wrench.

    Brace i carries f_c0,i = [P_i n̂_i; 0] without tool load (at b_i, world axes); under a tool wrench w its
    wrench is f_c,i = f_c0,i + contact_gain[:, i] @ w (first order, set points fixed).

    Attributes:
        q: the commanded configurations (N×n), rad.
        q_s: spring set points (N×n), rad: q + K⁻¹ τ0.
        tau0: actuator torques without tool load (N×n), N·m: g(q) − Σ_i J_b_iᵀ f_c0,i.
        f_c0: contact wrench of each brace without tool load (N×B×6), N and N·m.
        contact_gain: δf_c,i per unit tool wrench (N×B×6×6).
        torque_gain: δτ per unit tool wrench (N×n×6).
        joint_gain: δq per unit tool wrench (N×n×6), rad per N or N·m.
        X: the load contact's constraint wrenches X_L,i of each brace (6×c_i, world axes).
        normals: n̂_i of each brace (B×3), toward the robot.
        preloads: P_i of each brace (N).
        frictions: μ_i of each brace, None where none was given.
    """

    X: tuple[Array, ...]
    normals: Array
    preloads: tuple[float, ...]
    frictions: tuple[float | None, ...]

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def at(self, i: int, brace: int | None = None) -> ContactResponse:
        """Brace `brace`'s view at configuration i: its f_c0 and contact gain, the shared τ and q responses.

        `brace` None: the only brace (ContactError with several braces: name the brace, from 0).
        """
        b = brace_index(brace, len(self.preloads))
        return ContactResponse(
            q=self.q[i],
            q_s=self.q_s[i],
            tau0=self.tau0[i],
            f_c0=self.f_c0[i, b],
            contact_gain=self.contact_gain[i, b],
            torque_gain=self.torque_gain[i],
            joint_gain=self.joint_gain[i],
            X=self.X[b],
            normal=self.normals[b].copy(),
            preload=self.preloads[b],
            friction=self.frictions[b],
        )


def brace_index(brace: int | None, count: int) -> int:
    """The index of one brace among `count`: `brace`, or 0 for the only one; ContactError / InputError otherwise."""
    if brace is None:
        if count != 1:
            raise ContactError(
                f"the response of one brace: this robot has {count} braces, name one with brace=i (from 0)"
            )
        return 0
    if isinstance(brace, bool) or not isinstance(brace, (int, np.integer)) or not 0 <= int(brace) < count:
        raise InputError(f"brace must be an index from 0 to {count - 1}, got {show(brace)}")
    return int(brace)


def per_brace(values: object, count: int, check: Callable[[object], Any], what: str) -> tuple[Any, ...]:
    """One value for every brace: a single value repeated, or a list of `count` values, each through `check`."""
    if isinstance(values, (list, tuple)) or (isinstance(values, np.ndarray) and values.ndim > 0):
        if len(values) != count:
            raise InputError(f"give {what} for each of the {count} braces (a list of {count}), got {len(values)}")
        return tuple(check(v) for v in values)
    return (check(values),) * count


def contact_responses(
    braced: BracedRobot,
    qs: ArrayLike,
    *,
    preload: float | Sequence[float] = 0.0,
    gravity: bool = False,
    friction: float | Sequence[float | None] | None = None,
    geometric: bool = True,
) -> ContactResponses:
    """The preloaded equilibrium and its load response with every brace of `braced` (N ≥ 1).

    τ0 = g(q) − Σ_i J_b_iᵀ [P_i n̂_i; 0] and q_s = q + K⁻¹ τ0. Under a tool wrench w, with the set points
    fixed and every load contact closed (X_L,i: :func:`load_contact_wrenches` with μ_i), the first-order KKT
    system over the stacked load constraint A = [J_b_1ᵀ X_L,1, J_b_2ᵀ X_L,2, …] (n×c):

        K_t δq − A δλ = J_eᵀ w,   Aᵀ δq + C δλ = 0,

    C = diag(1/k_env of each row's brace) (0 rigid), gives δf_c,i = X_L,i δλ_i and δτ = −K δq. K_t = K + ∂g/∂q
    − Σ_i ∂(J_b_iᵀ f_c0,i)/∂q (``geometric``) or K. Rigid rows of A that depend on earlier ones (or carry no load)
    are dropped as in :func:`bracekit.kinematics.constraint.stacked_constraint`, so their force is carried by the
    rows they depend on (one RedundantContactWarning or UnloadedContactWarning for the stack).

    Args:
        braced: the braced robot (any number of braces).
        qs: configurations (N×n, or one (n,)), rad, with every {b_i} on its surface.
        preload: P_i ≥ 0 (N): one for every brace or a list with one per brace.
        gravity: include g(q).
        friction: μ_i ≥ 0 or None per brace (or one for all); μ_i > 0 makes a frictionless point stick.
        geometric: use the tangent stiffness (True) or K alone.

    Raises:
        InputError: bad preloads, frictions or configurations.
        UnstableEquilibriumError: K_t + A_c C_c⁻¹ A_cᵀ (compliant rows) is not positive definite on the motions
            the rigid rows allow.
        NumericalError: a result that is not finite.
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    for flag, name in ((gravity, "gravity"), (geometric, "geometric")):
        if not isinstance(flag, bool):
            raise InputError(f"{name} must be True or False, got {show(flag)}")
    robot, braces = braced.robot, braced.braces
    count = len(braces)
    p = per_brace(preload, count, check_preload, "the preload P_i (N)")
    mu = per_brace(friction, count, check_friction, "the friction coefficient μ_i")
    q_all = configurations(robot, qs)
    n, samples = robot.n, q_all.shape[0]
    normals = np.array([b.surface.normal for b in braces], dtype=float)
    f0 = np.zeros((count, 6))
    f0[:, :3] = np.asarray(p)[:, None] * normals
    x_l = tuple(load_contact_wrenches(b, m) for b, m in zip(braces, mu, strict=True))
    widths = [x.shape[1] for x in x_l]
    starts = np.concatenate([[0], np.cumsum(widths)])
    comp = np.concatenate(
        [
            np.full(w, 0.0 if b.environment_stiffness is None else 1.0 / float(b.environment_stiffness))
            for b, w in zip(braces, widths, strict=True)
        ]
    )
    rigid = [r for r in range(comp.size) if comp[r] == 0.0]
    k = robot.stiffness
    hessians = geometric and any(v > 0.0 for v in p)
    if gravity or hessians:
        _check_size(robot, "gravity torques and geometric stiffness")
    model = robot.model
    data = model.createData()
    if hessians:
        ensure_hessian_layout(model, data, tuple(braced.brace_ids))
    out_q_s = np.empty((samples, n))
    out_tau0 = np.empty((samples, n))
    out_gain = np.zeros((samples, count, 6, 6))
    out_joint = np.empty((samples, n, 6))
    dropped: set[tuple[int, int]] = set()
    unloaded_rows: set[tuple[int, int]] = set()
    for s, q in enumerate(q_all):
        st = braced.state(q)
        k_t = np.diag(k).astype(float)
        g = np.zeros(n)
        if gravity:
            g = np.asarray(pin.computeGeneralizedGravity(model, data, q), dtype=float).copy()
            if geometric:
                k_t += np.asarray(pin.computeGeneralizedGravityDerivatives(model, data, q), dtype=float)
        if hessians:
            pin.computeJointJacobians(model, data, q)
            pin.computeJointKinematicHessians(model, data)
            for i, fid in enumerate(braced.brace_ids):
                if p[i] > 0.0:
                    k_t -= np.einsum("r,rik->ik", f0[i], frame_hessian(model, data, fid))
        with finite_math("the contact response"):
            k_t = 0.5 * (k_t + k_t.T)
            tau0 = g - sum((j_b.T @ f for j_b, f in zip(st.J_b_i, f0, strict=True)), np.zeros(n))
            a = np.hstack([j_b.T @ x for j_b, x in zip(st.J_b_i, x_l, strict=True)])  # n×c
            traces = [float(np.sum(j_b * j_b / k)) for j_b, b in zip(st.J_b_i, braces, strict=True)]
            rows_of = [i for i, w in enumerate(widths) for _ in range(w)]
            trace = max((traces[rows_of[r]] for r in rigid), default=0.0)
            kept, unloaded, redundant = _independent_rows((a / np.sqrt(k)[:, None]).T, rigid, trace)
            label = [(i, r - int(starts[i])) for r, i in enumerate(rows_of)]
            unloaded_rows.update(label[r] for r in unloaded)
            dropped.update(label[r] for r, _ in redundant)
            use = sorted(set(kept) | {r for r in range(comp.size) if comp[r] > 0.0})
            a_k, c_k = a[:, use], comp[use]
            _check_stable(k_t, a_k, c_k, s)
            m = len(use)
            kkt = np.block([[k_t, -a_k], [a_k.T, np.diag(c_k)]])
            rhs = np.vstack([st.J_e.T, np.zeros((m, 6))])
            sol = np.linalg.solve(kkt, rhs)
            lam = np.zeros((comp.size, 6))
            lam[use] = sol[n:]
            for i, x in enumerate(x_l):
                out_gain[s, i] = x @ lam[starts[i] : starts[i + 1]]
            out_joint[s] = sol[:n]
            out_tau0[s] = tau0
            out_q_s[s] = q + tau0 / k
    for rows, head, tail, category in (
        (
            unloaded_rows,
            "the contact carries no load along ",
            ": no joint can push {b} there, so those rows get no force",
            UnloadedContactWarning,
        ),
        (
            dropped,
            "dependent load contacts (two contacts constrain the same motion): ",
            " get no force, the rows they depend on carry it",
            RedundantContactWarning,
        ),
    ):
        if rows:
            listed = ", ".join(f"braces[{i}] row {r}" for i, r in sorted(rows))
            warnings.warn(head + listed + tail, category, stacklevel=2)
    torque_gain = -k[None, :, None] * out_joint
    for arr in (out_q_s, out_gain, torque_gain, out_joint):
        if not np.all(np.isfinite(arr)):
            raise NumericalError("the contact response is not finite; use SI units and moderate values")
    return ContactResponses(
        q=q_all,
        q_s=out_q_s,
        tau0=out_tau0,
        f_c0=np.broadcast_to(f0, (samples, count, 6)).copy(),
        contact_gain=out_gain,
        torque_gain=torque_gain,
        joint_gain=out_joint,
        X=x_l,
        normals=normals,
        preloads=tuple(float(v) for v in p),
        frictions=tuple(mu),
    )


def _check_stable(k_t: Array, a: Array, comp: Array, sample: int) -> None:
    """UnstableEquilibriumError unless K_t + A_c C_c⁻¹ A_cᵀ is positive definite on the null space of A_rᵀ."""
    if np.linalg.eigvalsh(k_t)[0] > 0.0:
        return
    soft = comp > 0.0
    m = k_t + (a[:, soft] / comp[soft]) @ a[:, soft].T
    rigid = a[:, ~soft]
    z = contact_null_space(rigid.T) if rigid.shape[1] else np.eye(k_t.shape[0])
    scale = float(np.max(np.abs(k_t)))
    low = float(np.linalg.eigvalsh(z.T @ m @ z)[0]) if z.shape[1] else np.inf
    if not low > 1e-9 * scale:
        raise UnstableEquilibriumError(
            f"the braced equilibrium is unstable at configuration {sample}: the tangent stiffness K + ∂g/∂q − "
            f"Σ ∂(J_b_iᵀ f_c0,i)/∂q (smallest eigenvalue {low:.3g} N·m/rad on the motions the contacts allow) is "
            "not positive; use stiffer joints or smaller preloads"
        )


def contact_response(braced: BracedRobot, q: ArrayLike, *, brace: int | None = None, **options: Any) -> ContactResponse:
    """Brace `brace`'s view of :func:`contact_responses` at one configuration q (n,) (module docstring).

    `q` is the commanded configuration (n,), rad, with every {b_i} on its surface; `brace` which brace's contact
    wrench the record holds (from 0; None: the only brace); `options` those of :func:`contact_responses`:
    ``preload`` P ≥ 0 (N, or one per brace), ``gravity``, ``friction`` μ ≥ 0 (with μ > 0 a frictionless point
    brace sticks under load, a 3-D force; None: no friction) and ``geometric`` (the tangent stiffness
    K + ∂g/∂q − ∂(J_bᵀ f_c0)/∂q, or K alone).

    Raises:
        InputError: a negative or non-finite preload or μ, or a configuration that is not n finite numbers.
        ContactError: several braces and no `brace` index.
        NumericalError: the tangent stiffness is not positive definite (gravity or the preload buckles the
            springs), or the result is not finite.
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    which = brace_index(brace, len(braced.braces))
    q_row = as_array(q, "the configuration (rad)").reshape(1, -1)
    return contact_responses(braced, q_row, **options).at(0, which)
