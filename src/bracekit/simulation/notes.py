"""What a run tells its reader besides its numbers: the notes (and warnings) and each brace's contact summary."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import numpy as np

from bracekit.errors import (
    ClearanceWarning,
    JointLimitWarning,
    NoRedundancyWarning,
    RedundantContactWarning,
    RegionWarning,
    UnloadedContactWarning,
)
from bracekit.geometry.collision import solids_of
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import geometry_of
from bracekit.resolution.strategies import BracedGradientProjection, Strategy
from bracekit.resolution.task_space import TaskSpace
from bracekit.simulation.correction import kernel
from bracekit.simulation.guards import point_label
from bracekit.simulation.samples import Samples

__all__ = ["CORRECTION_BACKEND_NOTE", "run_notes"]

#: The run's note when the correction's point ran in NumPy because numba cannot be imported (the same
#: corrected states to rounding, slower).
CORRECTION_BACKEND_NOTE = (
    "the pose/contact correction ran in NumPy (numba cannot be imported; `pip install bracekit[fast]` gives the "
    "compiled correction)"
)

#: The warnings a run gathers into one note each (with the count of evaluations that raised them).
GATHERED = (UnloadedContactWarning, RedundantContactWarning, ClearanceWarning)


def run_notes(
    braced: BracedRobot,
    strategy: Strategy,
    samples: Samples,
    caught: Sequence[warnings.WarningMessage],
    counts: Mapping[str, int],
    free_dims: int,
    space: TaskSpace,
) -> tuple[list[str], list[dict[str, float]] | None]:
    """The run's notes, each also warned, and with several braces each brace's contact summary.

    `caught`: the warnings raised during the run (the gathered kinds become one note each, the others are
    passed on unchanged); `counts`: ``substeps`` and ``limited`` (steps whose null-space motion was scaled).
    """
    name = strategy.name
    notes: list[str] = []
    one = len(braced.braces) == 1

    def note(text: str, category: type[Warning] | None = None) -> None:
        notes.append(f"{name}: {text}")
        if category is not None:
            warnings.warn(notes[-1], category, stacklevel=4)

    for category in GATHERED:
        found = [w for w in caught if issubclass(w.category, category)]
        if found:
            note(f"at {len(found)} evaluation(s) {found[0].message}", category)
    for w in caught:  # pass on anything else unchanged
        if not issubclass(w.category, GATHERED):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    m = samples.series
    limit = float(m["joint_limit_violation"][0])
    if limit > 0:
        note(f"the start exceeds the joint limits by {limit:.3g} rad", JointLimitWarning)
    if counts["limited"]:
        note(
            f"{counts['limited']} step(s) had their null-space motion scaled down to keep the joints inside their "
            "limits"
        )
    for i, (brace, c) in enumerate(zip(braced.braces, samples.contacts, strict=True)):
        inside = np.asarray(c.region_radius) < (brace.region_radius if brace.region_radius is not None else np.inf)
        depth = float(np.min(c.surface_distance, initial=0.0, where=inside))
        if depth < -1e-6:
            note(
                f"{point_label(braced, i)} passes {-depth:.3g} m below the bracing surface inside the region (this "
                "run ignores the surface)"
            )
    clearance = m["link_clearance"]
    if float(np.min(clearance)) < 0:
        note(
            f"a link reaches {-float(np.min(clearance)):.3g} m into {solids_of(braced)} (at "
            f"{int(np.sum(clearance < 0))} of {clearance.size} samples; the link geometry: {geometry_of(braced)})",
            ClearanceWarning,
        )
    if counts["substeps"]:
        where = "the bracing point in the region" if one else "the bracing points in their regions"
        note(f"{counts['substeps']} step(s) were split to keep {where}")
    if free_dims == 0 and isinstance(strategy, BracedGradientProjection):
        note(
            f"the task space '{space.kind}' leaves no redundancy ({space.rows} task rows take every braced "
            "coordinate): gradient projection cannot act and equals braced minimum norm; free task rows (space "
            "'position' or 'position+axis') leave it room",
            NoRedundancyWarning,
        )
    if not kernel().COMPILED:
        note(CORRECTION_BACKEND_NOTE)
    per_brace = []
    for i, (brace, c) in enumerate(zip(braced.braces, samples.contacts, strict=True)):
        radius = float(np.max(c.region_radius))
        per_brace.append(
            {"max_contact_violation_m": float(np.max(np.abs(c.surface_distance))), "max_region_radius_m": radius}
        )
        if brace.region_radius is not None and radius >= brace.region_radius:
            region = "the bracing region" if one else "its bracing region"
            note(
                f"{point_label(braced, i)} left {region} (max r = {radius:.4f} m > r_max = "
                f"{brace.region_radius:.4f} m)",
                RegionWarning,
            )
    return notes, (None if one else per_brace)
