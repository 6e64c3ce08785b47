"""Directional compliances that say what they measure, beside the paper's index (docs/model.md, section 11).

A tip compliance C (6×6) maps a wrench [f; m] (N, N·m) at e to a deflection [Δp; Δθ] (m, rad), world axes.
Three scalars are read from it along a direction β_x:

* C_i = ‖β_xᵀ C‖ (eq:compliance_index), the paper's index. For a translational β_x = [β; 0] the row β_xᵀ C holds
  three entries in m/N (force columns) and three in 1/N (moment columns), and the norm adds them: mixed units.
  It is the objective of the paper and the number of Table I.
* c_t = βᵀ C_tt β (m/N), the translational compliance along β: C_tt = C[:3, :3] is the force → displacement
  block, so c_t is the tip displacement along β per newton of force along β (what a probe measures).
* β_xᵀ C β_w (eq:directional_compliance_result), the deflection along β_x per unit wrench along β_w, for a known
  load direction β_w; with β_w = [β; 0] and β_x = [β; 0] it is c_t.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array
from bracekit.compliance.first_order import (
    check_finite,
    compliance_index,
    compliance_matrix,
    directional_compliance,
    unit6,
)
from bracekit.errors import InputError
from bracekit.spatial import unit

Array = NDArray[np.float64]

__all__ = [
    "CI_LABEL",
    "CT_LABEL",
    "CW_LABEL",
    "DirectionalCompliances",
    "directional_compliances",
    "directional_keys",
    "translational_compliance",
    "translational_direction",
]

#: How reports name each measure (tables, figures, CLI text).
CI_LABEL = "C_i = ‖β_xᵀC_e‖, mixed units, the paper's index"
CT_LABEL = "c_t = β_xᵀC_ttβ_x, m/N, translational compliance along β_x"
CW_LABEL = "β_xᵀC_eβ_w, deflection along β_x per unit wrench along β_w"

#: A rotational part of β_x up to this fraction of its norm is round-off (a translational direction).
_ROTATION_TOL = 1e-12


def translational_direction(beta_x: ArrayLike) -> Array:
    """The unit translation β (3,) of a translational β_x: 3 numbers, or 6 numbers [β; 0] (a twist [v; ω]).

    Raises InputError when β_x is zero, not finite, or has a rotational part (c_t is defined along a
    translation; use :func:`~bracekit.compliance.first_order.directional_compliance` for a general twist).
    """
    a = as_array(beta_x, "beta_x", finite=False).reshape(-1)
    if a.size == 3:
        return unit(a, "beta_x")
    b = unit6(a, "beta_x")
    if np.linalg.norm(b[3:]) > _ROTATION_TOL:
        raise InputError(
            f"the translational compliance c_t needs a translational β_x = [β; 0, 0, 0], got rotational part "
            f"{np.round(b[3:], 6).tolist()}; use directional_compliance(C, beta_x, beta_w) for a general twist"
        )
    return unit(b[:3], "beta_x")


def translational_compliance(c: ArrayLike, beta_x: ArrayLike) -> float:
    """c_t = βᵀ C_tt β (m/N): the tip displacement along the unit translation β per newton along β.

    `c` is a 6×6 tip compliance (any model; a non-symmetric preloaded C is read as it is), β_x 3 numbers or
    a translational twist [β; 0] (6), scaled to unit length.
    """
    m = compliance_matrix(c)
    beta = translational_direction(beta_x)
    with np.errstate(all="ignore"):
        return float(check_finite(beta @ m[:3, :3] @ beta, "the translational compliance c_t"))


class DirectionalCompliances(NamedTuple):
    """The three directional readings of one tip compliance along β_x.

    Attributes:
        Ci: C_i = ‖β_xᵀ C‖, the paper's index (eq:compliance_index), mixed m/N and 1/N.
        c_t: βᵀ C_tt β, m/N, or None when β_x has a rotational part.
        c_w: β_xᵀ C β_w (eq:directional_compliance_result) for the given wrench direction β_w, or None.
    """

    Ci: float
    c_t: float | None
    c_w: float | None


def directional_compliances(c: ArrayLike, beta_x: ArrayLike, beta_w: ArrayLike | None = None) -> DirectionalCompliances:
    """C_i, c_t and (with β_w) β_xᵀ C β_w of a 6×6 compliance along the unit twist β_x (6,)."""
    beta = unit6(beta_x, "beta_x")
    translational = bool(np.linalg.norm(beta[3:]) <= _ROTATION_TOL)
    return DirectionalCompliances(
        Ci=compliance_index(c, beta),
        c_t=translational_compliance(c, beta) if translational else None,
        c_w=None if beta_w is None else directional_compliance(c, beta, beta_w),
    )


def directional_keys(
    compliances: dict[str, Array | None], beta_x: ArrayLike, beta_w: ArrayLike | None = None
) -> dict[str, object]:
    """The report keys of the directional readings of each named compliance (None stays None).

    ``ct_<model>`` (m/N; None if β_x rotates) and, with β_w, ``beta_w`` and ``Cw_<model>``; ``measures`` names them.
    """
    out: dict[str, object] = {}
    for name, c in compliances.items():
        r = None if c is None else directional_compliances(c, beta_x, beta_w)
        out[f"ct_{name}"] = None if r is None else r.c_t
        if beta_w is not None:
            out[f"Cw_{name}"] = None if r is None else r.c_w
    if beta_w is not None:
        out["beta_w"] = unit6(beta_w, "beta_w")
    out["measures"] = {"Ci": CI_LABEL, "ct": CT_LABEL, **({"Cw": CW_LABEL} if beta_w is not None else {})}
    return out
