"""What a run records at each sample, as typed records, and their names in the output files.

:class:`Sample` holds one sample's measures (a :class:`ContactSample` per brace); :class:`Samples` the run's
measures as arrays over its samples. :meth:`Samples.as_dict` gives them under the names of trajectories.npz
(a file format: one brace keeps the paper's names; several braces add each brace's series with the suffix
``_<i>`` and the worst over the braces under the plain name).

k and the singular-value measures Πσ, σ_min are those of the braced task Jacobian (eq:manip): J̃ for one
brace (eq:J_wave, the paper's), J_e N over the braced motions N for several (docs/model.md, "Several braces").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import angle_between
from bracekit.compliance.first_order import compliance_index, end_effector_compliance, free_space_compliance
from bracekit.compliance.measures import frobenius_condition, singular_value_measures
from bracekit.errors import ContactError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.kinematics.clearance import link_clearance

Array = NDArray[np.float64]

__all__ = ["ContactSample", "ContactSeries", "Sample", "Samples", "compliance_models", "measure"]


class ContactSample(NamedTuple):
    """One brace at a sample.

    Attributes:
        theta_z: ∠(n̂_i, ẑ_b_i), rad (eq:theta; meaningful for a brace with a pad axis).
        region_radius: ‖b_i − p_i‖ from its region centre (the surface point), m.
        surface_distance: signed distance of b_i from its surface plane, m (negative: below it).
    """

    theta_z: float
    region_radius: float
    surface_distance: float


class ContactSeries(NamedTuple):
    """One brace over a run's samples: the fields of :class:`ContactSample` as arrays (N,)."""

    theta_z: Array
    region_radius: Array
    surface_distance: Array


class Sample(NamedTuple):
    """The measures of one sample (SI units).

    Attributes:
        Ci: compliance index C_i (eq:compliance_index) by model: ``free`` (J K⁻¹ Jᵀ), ``constrained`` and, with
            one brace, ``projection``.
        prod_sigma_t, prod_sigma_o, sigma_t_min, sigma_o_min: singular-value measures of the braced task
            Jacobian (translational rows m/rad, rotational rows rad/rad).
        k: condition number of the braced task Jacobian (eq:manip); k_free: of J_e.
        joint_limit_violation: largest excursion beyond a URDF limit, rad (m for a prismatic joint).
        task_error: ‖p_d − e‖, m. joint_step: largest |Δq_i| since the previous sample (0 at the start).
        link_clearance: least clearance of the links from the surfaces as solid obstacles, m (each surface with
            its own braced link left out; :mod:`bracekit.kinematics.clearance`).
        sigma_ratio: σ_min/σ_max of each matrix the run watches (keys of ``kinematics.motions.MATRIX_LABELS``).
        contacts: each brace's :class:`ContactSample`, in brace order.
    """

    Ci: dict[str, float]
    prod_sigma_t: float
    prod_sigma_o: float
    sigma_t_min: float
    sigma_o_min: float
    k: float
    k_free: float
    joint_limit_violation: float
    task_error: float
    joint_step: float
    link_clearance: float
    sigma_ratio: dict[str, float]
    contacts: tuple[ContactSample, ...]


def compliance_models(braced: BracedRobot) -> tuple[str, ...]:
    """The first-order compliance models with a meaning for the robot: ``projection`` needs the chain split."""
    return ("constrained", "projection") if len(braced.braces) == 1 else ("constrained",)


def measure(
    state: BracedState, beta_x: Array, task_error: float, sigma_ratio: dict[str, float], joint_step: float = 0.0
) -> Sample:
    """The measures of a sample at the state: β_x (6,) the unit twist of C_i; σ ratios from the run's guard."""
    braced = state.braced
    jac = state.motions.task_jacobian
    sv = singular_value_measures(jac)
    lower, upper = braced.robot.lower, braced.robot.upper
    ci = {"free": compliance_index(free_space_compliance(state), beta_x)}
    for model in compliance_models(braced):
        ci[model] = compliance_index(end_effector_compliance(state, model), beta_x)  # type: ignore[arg-type]
    try:
        clearance = link_clearance(state)[0]
    except ContactError:  # the clearance model has one surface as obstacle
        clearance = np.inf
    contacts = tuple(
        ContactSample(
            theta_z=angle_between(brace.surface.normal, c.z_b),
            region_radius=float(np.linalg.norm(c.b - brace.surface.point)),
            surface_distance=brace.surface.signed_distance(c.b),
        )
        for brace, c in zip(braced.braces, state.contacts, strict=True)
    )
    return Sample(
        Ci=ci,
        prod_sigma_t=sv.prod_sigma_t,
        prod_sigma_o=sv.prod_sigma_o,
        sigma_t_min=sv.sigma_t_min,
        sigma_o_min=sv.sigma_o_min,
        k=frobenius_condition(jac),
        k_free=frobenius_condition(state.J_e),
        joint_limit_violation=float(np.max(np.maximum(0.0, np.maximum(lower - state.q, state.q - upper)))),
        task_error=task_error,
        joint_step=joint_step,
        link_clearance=clearance,
        sigma_ratio=sigma_ratio,
        contacts=contacts,
    )


_SCALARS = (
    "prod_sigma_t",
    "prod_sigma_o",
    "sigma_t_min",
    "sigma_o_min",
    "k",
    "k_free",
    "joint_limit_violation",
    "task_error",
    "joint_step",
    "link_clearance",
)


@dataclass(frozen=True)
class Samples:
    """A run's measures over its samples: each field of :class:`Sample` as an array (N,).

    Attributes:
        braced: the braced robot of the run.
        series: each scalar measure (N,) by its field name.
        Ci: C_i (N,) by model.
        sigma_ratio: σ_min/σ_max (N,) by matrix key.
        contacts: per brace, (theta_z, region_radius, surface_distance) (N,) each.
    """

    braced: BracedRobot
    series: dict[str, Array]
    Ci: dict[str, Array]
    sigma_ratio: dict[str, Array]
    contacts: tuple[ContactSeries, ...]

    @classmethod
    def stack(cls, braced: BracedRobot, rows: Sequence[Sample]) -> Samples:
        """The arrays of a sequence of samples (at least one)."""
        first = rows[0]
        return cls(
            braced=braced,
            series={key: np.array([getattr(r, key) for r in rows]) for key in _SCALARS},
            Ci={key: np.array([r.Ci[key] for r in rows]) for key in first.Ci},
            sigma_ratio={key: np.array([r.sigma_ratio[key] for r in rows]) for key in first.sigma_ratio},
            contacts=tuple(
                ContactSeries(*(np.array([r.contacts[i][f] for r in rows]) for f in range(3)))
                for i in range(len(first.contacts))
            ),
        )

    @classmethod
    def concat(cls, parts: Sequence[Samples]) -> Samples:
        """The samples of `parts` (at least one, of one braced robot) one after the other."""
        first = parts[0]
        return cls(
            braced=first.braced,
            series={key: np.concatenate([p.series[key] for p in parts]) for key in first.series},
            Ci={key: np.concatenate([p.Ci[key] for p in parts]) for key in first.Ci},
            sigma_ratio={key: np.concatenate([p.sigma_ratio[key] for p in parts]) for key in first.sigma_ratio},
            contacts=tuple(
                ContactSeries(*(np.concatenate([p.contacts[i][f] for p in parts]) for f in range(3)))
                for i in range(len(first.contacts))
            ),
        )

    def as_dict(self) -> dict[str, Array]:
        """The measures under their names in trajectories.npz (``Ci_<model>``, ``sigma_ratio_<key>``, …).

        One brace: ``theta_z``, ``region_radius``, ``surface_distance`` and ``contact_violation`` (= |distance|)
        of its contact. Several: the same of brace i with the suffix ``_<i>`` (θ_z only for a brace with a pad
        axis), and under the plain names the largest over the braces (the smallest surface distance; θ_z 0
        without a pad axis).
        """
        out = {f"Ci_{key}": value for key, value in self.Ci.items()} | dict(self.series)
        braces = self.braced.braces
        if len(braces) == 1:
            (c,) = self.contacts
            out |= {
                "theta_z": c.theta_z,
                "region_radius": c.region_radius,
                "contact_violation": np.abs(c.surface_distance),
                "surface_distance": c.surface_distance,
            }
        else:
            for i, (brace, c) in enumerate(zip(braces, self.contacts, strict=True)):
                if brace.pad_axis:
                    out[f"theta_z_{i}"] = c.theta_z
                out[f"region_radius_{i}"] = c.region_radius
                out[f"surface_distance_{i}"] = c.surface_distance
                out[f"contact_violation_{i}"] = np.abs(c.surface_distance)
            pads = [c.theta_z for b, c in zip(braces, self.contacts, strict=True) if b.pad_axis]
            size = self.contacts[0].region_radius.size
            out["theta_z"] = np.max(pads, axis=0) if pads else np.zeros(size)
            out["region_radius"] = np.max([c.region_radius for c in self.contacts], axis=0)
            out["contact_violation"] = np.max([np.abs(c.surface_distance) for c in self.contacts], axis=0)
            out["surface_distance"] = np.min([c.surface_distance for c in self.contacts], axis=0)
        return out | {f"sigma_ratio_{key}": value for key, value in self.sigma_ratio.items()}
