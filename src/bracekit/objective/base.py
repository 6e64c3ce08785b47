"""The objective g of the braced gradient projection (eq:objective): the term base class and the weighted sum.

Each term (one file each in this package) maps a :class:`BracedState` to a value and to ∂/∂q (n,), exact
through Pinocchio's kinematic Hessians (the state must be computed with ``hessians=True``). A term may also
give the fused step of :mod:`bracekit.resolution.fused` its value and gradient coefficients from one Pinocchio
pass (:meth:`Term.fused_value`, :meth:`Term.fused_gradient`) and the numba kernel its parameters
(:meth:`Term.numba_params`); a term without them makes those paths use its reference ``value``/``gradient``.
:func:`finite_difference_gradient` is the paper's reference (central differences, δq = 1e-5 rad);
:func:`braced_gradient` maps ∂g/∂q to ∇g = [(∂g/∂q1) dq1/db̃, ∂g/∂q2]ᵀ (eq:grad_g).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_number, show
from bracekit._registry import Registry
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot, BracedState

if TYPE_CHECKING:
    from bracekit.objective.fused import FusedGradient, FusedKinematics

Array = NDArray[np.float64]


class Term:
    """A scalar measure of the braced robot with its exact gradient (subclass it; one file per term).

    Subclasses implement :meth:`value` and :meth:`gradient`; they may implement the fused methods. ``key``
    is the name of the term's weight in a scenario's ``[gradient_projection.weights]`` table. An objective also
    accepts any object with ``name``, ``value(state)`` and ``gradient(state)``; the fused paths then use those.
    """

    name: str = "term"
    key: ClassVar[str] = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InputError(f"a term's name must be a non-empty string, got {show(self.name)}")

    def value(self, state: BracedState) -> float:
        """The measure at the state."""
        raise NotImplementedError

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,); needs the state's Hessians."""
        raise NotImplementedError

    def with_beta_x(self, beta_x: ArrayLike) -> Term:
        """The term with its task direction β_x replaced (itself when it has none)."""
        return self

    def fused_value(self, kin: FusedKinematics) -> float | None:
        """The value from the fused step's kinematics, or None to use :meth:`value` on a BracedState."""
        return None

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to `out` as Hessian coefficients; False to use :meth:`gradient` instead."""
        return False

    def numba_params(self, braced: BracedRobot, weight: float) -> tuple[str, list[float]] | None:
        """(kind, parameters) of the numba kernel's compiled copy of this term, or None if it has none."""
        return None

    @classmethod
    def from_scenario(cls, context: TermContext) -> Term:
        """The term as a scenario configures it."""
        raise NotImplementedError

    @classmethod
    def terms_from_scenario(cls, context: TermContext) -> tuple[Term, ...]:
        """The terms a scenario's weight of this key stands for: one, or one per brace for a per-brace term."""
        return (cls.from_scenario(context),)


@dataclass(frozen=True)
class TermContext:
    """What a scenario gives a term: the braced robot, β_x (6,), the compliance model and the statics.

    ``holding`` is the scenario's :class:`bracekit.simulation.holding.Holding` (gravity, preload, friction,
    tool wrenches) or None; ``space`` its :class:`bracekit.resolution.task_space.TaskSpace`, None for the pose.
    """

    braced: BracedRobot
    beta_x: Array
    compliance_model: str
    holding: Any = None
    space: Any = None


class BraceTerm(Term):
    """A term of one brace (its ``brace``, from 0).

    A scenario's weight stands for one term per brace that has what the term measures
    (:meth:`terms_from_scenario`); :meth:`from_scenario` is the first of them.
    """

    @classmethod
    def terms_from_scenario(cls, context: TermContext) -> tuple[Self, ...]:
        """One term per brace that has what it measures (InputError when none has)."""
        raise NotImplementedError

    @classmethod
    def from_scenario(cls, context: TermContext) -> Self:
        """The term of the first brace that has what it measures (its weight key is ``key``)."""
        return cls.terms_from_scenario(context)[0]


class JointTerm(Term):
    """A term of the joint values q alone (no contact kinematics): its value and gradient from q.

    Subclasses implement :meth:`of_q` and :meth:`gradient_of_q`; the term then serves a BracedState and the
    fused step alike (an extra gradient added to the step's accumulator).
    """

    def of_q(self, q: Array) -> float:
        """The term's value at the joint values q (n,)."""
        raise NotImplementedError

    def gradient_of_q(self, q: Array) -> Array:
        """∂value/∂q (n,) at q."""
        raise NotImplementedError

    def value(self, state: BracedState) -> float:
        """The term's value at the state's q."""
        return self.of_q(state.q)

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,) at the state's q (it needs no Hessians)."""
        return self.gradient_of_q(state.q)

    def fused_value(self, kin: FusedKinematics) -> float | None:
        """The value at the fused step's joint values (None when it has none)."""
        return None if kin.q is None else self.of_q(kin.q)

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to the fused step's accumulator; False when the step has no q."""
        if kin.q is None:
            return False
        out.add_extra(weight * self.gradient_of_q(kin.q))
        return True


#: weight key → term class, filled by :func:`register_term` (the keys of ``[gradient_projection.weights]``).
TERMS: Registry[type[Term]] = Registry("objective term", "key", "weight key")
#: Class decorator: make a term available to scenarios under its ``key``.
register_term = TERMS.register


def hessians(state: BracedState) -> tuple[Array, tuple[Array, ...]]:
    """(∂J_e/∂q, (∂J_b_i/∂q of each brace)) of the state; InputError if it was computed without Hessians."""
    if state.dJ_e is None or not state.has_hessians:
        raise InputError("analytic gradients need the kinematic Hessians: compute the state with hessians=True")
    return state.dJ_e, tuple(c.dJ_b for c in state.contacts)  # type: ignore[misc]


def contract(d_j: Array, u: Array) -> Array:
    """Σ_{r,i} u[r, i] ∂J[r, i]/∂q_k (n,) for a Hessian d_j (6, n, n) and coefficients u (6, n)."""
    n = d_j.shape[2]
    return u.ravel() @ d_j.reshape(-1, n)


@dataclass(frozen=True)
class Objective:
    """g = Σ α_i term_i (eq:objective): any terms, any non-negative weights."""

    terms: Sequence[Term]
    weights: Sequence[float]
    names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        for what, seq in (("terms", self.terms), ("weights", self.weights)):
            if isinstance(seq, str | bytes) or not (
                isinstance(seq, Sequence) or (isinstance(seq, np.ndarray) and seq.ndim == 1)
            ):
                raise InputError(f"an objective's {what} must be a list, got {show(seq)}")
        if len(self.terms) != len(self.weights):
            raise InputError(
                f"an objective needs one weight per term, got {len(self.terms)} terms and {len(self.weights)} weights"
            )
        for t, w in zip(self.terms, self.weights, strict=True):
            if not (callable(getattr(t, "value", None)) and callable(getattr(t, "gradient", None))):
                raise InputError(f"an objective term needs value() and gradient() (a bracekit Term), got {show(t)}")
            name = getattr(t, "name", type(t).__name__)
            as_number(w, f"the weight of term {show(name)}", nonnegative=True)
        object.__setattr__(self, "names", tuple(getattr(t, "name", type(t).__name__) for t in self.terms))

    def value(self, state: BracedState) -> float:
        """G at the state."""
        _check_state(state)
        return float(sum(w * t.value(state) for t, w in zip(self.terms, self.weights, strict=True) if w))

    def values(self, state: BracedState) -> dict[str, float]:
        """Each term's value (unweighted)."""
        _check_state(state)
        return {t.name: t.value(state) for t in self.terms}

    def with_beta_x(self, beta_x: ArrayLike) -> Objective:
        """The objective with β_x of every term that has one replaced (itself if none has)."""
        terms = [t.with_beta_x(beta_x) if isinstance(t, Term) else t for t in self.terms]
        if all(a is b for a, b in zip(terms, self.terms, strict=True)):
            return self
        return Objective(terms, self.weights)

    def gradient(self, state: BracedState) -> Array:
        """∂g/∂q (n,), analytic."""
        out = np.zeros(_check_state(state).q.size)
        for t, w in zip(self.terms, self.weights, strict=True):
            if w:
                out += w * t.gradient(state)
        return out


def _check_state(state: object) -> BracedState:
    if not isinstance(state, BracedState):
        raise InputError(f"expected a BracedState (from BracedRobot.state(q)), got {type(state).__name__}")
    return state


def central_difference(fn: Callable[[Array], float], q: Array, step: float = 1e-5) -> Array:
    """(fn(q + δ e_i) − fn(q − δ e_i)) / (2δ) for each joint i, δ = step (rad): the paper's ∂g/∂q."""
    out = np.empty(q.size)
    for i in range(q.size):
        dq = np.zeros(q.size)
        dq[i] = step
        out[i] = (fn(q + dq) - fn(q - dq)) / (2.0 * step)
    return out


def finite_difference_gradient(
    braced: BracedRobot, fn: Callable[[BracedState], float], q: ArrayLike, step: float = 1e-5
) -> Array:
    """Central differences of fn over q, δq = step (rad); the paper's ∂g/∂q."""
    return central_difference(lambda x: fn(braced.state(x)), braced.robot.check_q(q), step)


def braced_gradient(state: BracedState, dg_dq: ArrayLike) -> Array:
    """∇g over the braced coordinates from ∂g/∂q: one brace [(∂g/∂q1) dq1/db̃, ∂g/∂q2]ᵀ (eq:grad_g), (l + n2,).

    Several braces: Nᵀ ∂g/∂q over the braced motions N (``state.motions``).
    """
    return state.motions.gradient(np.asarray(dg_dq, dtype=float))
