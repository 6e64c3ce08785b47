"""What the fused gradient-projection step gives an objective term: one Pinocchio pass and shared factors.

:class:`FusedKinematics` holds the frame Jacobians of {e} and {b} and their placements at q, with the factors
several terms share computed once (the Frobenius condition factors of J_e, the compliance factor Ĵ of each
model). A term adds its gradient to :class:`FusedGradient` as coefficients of the kinematic Hessians
(one contraction per Hessian for all terms). Shortcuts that are not certified raise :class:`NotCertified`,
and the fused step then takes the reference path.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import inverse
from bracekit.compliance.first_order import loaded_gain, warn_unloaded
from bracekit.spatial import twist_shift
from bracekit.tolerances import UNLOADED_TOL

Array = NDArray[np.float64]


class NotCertified(Exception):  # noqa: N818 - a control-flow signal, not an error a user sees
    """A shortcut is not certified here: the fused step uses the reference path."""


@dataclass
class FusedKinematics:
    """J_e, J_b (6×n, world axes), ⁰M_b, ⁰M_e (4×4) at q and the braced robot's constants.

    Attributes:
        n, n1: joints in all and in chain 1.
        kinv, k1inv: 1/K (n,) and its chain-1 part (n1,).
        X: constraint wrenches (6×(6−l)); t_proj: I − P (6×6).
        k_env: environment stiffness or None; normal: n̂ (3,) as a list; cert2: the certified condition, squared.
        q: the joint values (n,) of the placements, or None where the step does not give them.
    """

    je: Array
    jb: Array
    mb: Array
    me: Array
    n: int
    n1: int
    kinv: Array
    k1inv: Array
    X: Array
    t_proj: Array
    k_env: float | None
    normal: list[float]
    cert2: float
    q: Array | None = None
    _s1: Array | None = None
    _cache: dict[str, Any] = field(default_factory=dict)

    def at(self, je: Array, jb: Array, mb: Array, me: Array, s1: Array | None = None) -> FusedKinematics:
        """This object moved to a new configuration's Jacobians and placements (the shared factors reset)."""
        self.je, self.jb, self.mb, self.me, self._s1 = je, jb, mb, me, s1
        self.q = None  # the step sets it after the move
        self._cache.clear()
        return self

    @property
    def s1(self) -> Array:
        """S_t1 (eq:twists) at q."""
        if self._s1 is None:
            self._s1 = twist_shift(self.mb[:3, 3], self.me[:3, 3])
        return self._s1

    def frobenius(self) -> tuple[float, float, Array]:
        """tr(JJᵀ), tr((JJᵀ)⁻¹) and (JJᵀ)⁻² J of eq:manip for J_e, certified far from singular.

        With Y = (JJᵀ)⁻¹ J, tr((JJᵀ)⁻¹) = ‖J⁺‖²_F = ‖Y‖²_F since J⁺ = Jᵀ(JJᵀ)⁻¹. (JJᵀ)⁻¹ is formed
        (getrf + getri) and applied by products, not by getrs: SciPy's OpenBLAS runs getrs' triangular
        solves with several right-hand sides on its thread pool, which stalls for milliseconds (a scheduler
        tick) whenever every core is busy.
        """
        if "frobenius" not in self._cache:
            je = self.je
            inv = inverse(je.dot(je.T))
            if inv is None:
                raise NotCertified
            y = inv.dot(je)
            a, bb = float(np.vdot(je, je)), float(np.vdot(y, y))
            if not a * bb < self.cert2:  # a·bb = 36 k² ≥ cond(J)²; also nan
                raise NotCertified
            self._cache["frobenius"] = (a, bb, inv.dot(y))
        out: tuple[float, float, Array] = self._cache["frobenius"]
        return out

    def compliance(self, model: str) -> tuple[Array, Array, Array]:
        """S_t1 T, T J1 and Ĵ = [S_t1 T J1, J_e2] (6×n) with C̃1 = T C1 Tᵀ, so that C_e = Ĵ K⁻¹ Ĵᵀ (eq:Ce).

        T = I − P for the projection model (eq:C1wave_detail) and I − P_C = I − C1 X G Xᵀ for the
        constrained one (docs/model.md; T C1 Tᵀ = C1 − C1 X G Xᵀ C1 because G Xᵀ C1 X G = G). S_t2 C2 S_t2ᵀ =
        J_e2 K2⁻¹ J_e2ᵀ since S_t2 J2 = J_e[:, n1:].
        """
        key = f"compliance/{model}"
        if key not in self._cache:
            n1, je, jb = self.n1, self.je, self.jb
            j1 = jb[:, :n1]
            if model == "projection":
                t = self.t_proj
            else:
                if self.k_env is not None:  # C1 − C1 X G Xᵀ C1 ≠ T C1 Tᵀ with a compliant environment
                    raise NotCertified
                j1k = j1 * self.k1inv
                x = self.X
                cx = j1k.dot(j1.T.dot(x))  # C1 X
                m = x.T.dot(cx)
                trace_c1 = float(np.vdot(j1k, j1))
                if m.shape == (1, 1) and m[0, 0] > UNLOADED_TOL * trace_c1:  # one loaded direction: G = 1/m
                    t = np.eye(6) - np.multiply.outer(cx[:, 0] / m[0, 0], x[:, 0])
                else:  # as compliance.constraint_gain
                    g, unloaded = loaded_gain(m, trace_c1)
                    if unloaded:
                        warn_unloaded(int(unloaded), stacklevel=5)
                    t = np.eye(6) - cx.dot(g).dot(x.T)
            s1t = self.s1.dot(t)
            self._cache[key] = (s1t, t.dot(j1), np.concatenate((s1t.dot(j1), je[:, n1:]), axis=1))
        out: tuple[Array, Array, Array] = self._cache[key]
        return out


class FusedGradient:
    """∂g/∂q accumulated as Hessian coefficients: grad = ∂J_e·ue + ∂J_b·ub + J_bᵀ y[:6] + J_e[:3]ᵀ y[6:].

    ``ue`` (6×n) multiplies ∂J_e[r, i]/∂q_k, ``ub`` (6×n1) multiplies ∂J_b[r, i]/∂q_k (chain 1), ``y`` (9,) is
    applied to the Jacobians themselves; ``extra`` (n,) takes gradients computed otherwise.
    """

    def __init__(self, n: int, n1: int) -> None:
        self.n, self.n1 = n, n1
        self.ue: Array | None = None
        self.ub: Array | None = None
        self.y = [0.0] * 9
        self.extra: Array | None = None

    def add_ue(self, part: Array) -> None:
        """Ue += part (6×n)."""
        self.ue = part if self.ue is None else self.ue + part

    def add_ue_columns(self, start: int, part: Array) -> None:
        """ue[:, start:] += part (6×(n − start)), in place."""
        if self.ue is None:
            self.ue = np.zeros((6, self.n))
            self.ue[:, start:] = part
        else:
            self.ue[:, start:] += part

    def add_ub(self, part: Array) -> None:
        """Ub += part (6×n1)."""
        self.ub = part if self.ub is None else self.ub + part

    def add_extra(self, part: Array) -> None:
        """A gradient (n,) computed by other means."""
        self.extra = part if self.extra is None else self.extra + part

    def total(self, kin: FusedKinematics, he: Array, hb: Array) -> Array:
        """∂g/∂q (n,) with the Hessian rows he, hb (n×6n, :func:`bracekit.kinematics.frame_hessian_rows`)."""
        grad: Array = np.concatenate((kin.jb, kin.je[:3])).T.dot(self.y)
        if self.ue is not None:
            grad += he.dot(self.ue.T.ravel())
        if self.ub is not None:
            grad += hb[:, : 6 * self.n1].dot(self.ub.T.ravel())
        return grad if self.extra is None else grad + self.extra
