"""Checks of a sweep row read back from ``OUT/.sweep/rows``: schema, types, finite numbers, the candidate's inputs.

A row that does not pass is not reused: its candidate runs again (the summary counts them as
``rerun_invalid_rows``). The row's shape is :func:`bracekit.studies.sweep.evaluate.empty_row` filled by
:func:`bracekit.studies.sweep.evaluate.summary_columns` (SI units: C_i in m/N, lengths in m, angles in rad).
"""

from __future__ import annotations

import math
from typing import Any

from bracekit.studies.sweep.candidates import Candidate
from bracekit.studies.sweep.evaluate import RESULT_COLUMNS, input_values
from bracekit.studies.sweep.spec import SweepSpec

#: Columns holding a finite number or null; the second set must also be ≥ 0.
NUMBERS = (
    "point_x",
    "point_y",
    "point_z",
    "screen_clearance_m",
    "screen_Ci_mean",
    "screen_k_max",
    "Ci_reduction_gp",
    "min_link_clearance_m",
    "max_joint_limit_violation_rad",
    "min_liftoff_margin",
    "min_slip_margin",
    "min_torque_margin",
)
NON_NEGATIVE = ("Ci_mean_free_space", "Ci_mean_min_norm", "Ci_mean_gp", "max_region_radius_m", "wall_s")
#: Condition numbers k ≥ 1 (or null).
CONDITION = ("k_mean_min_norm", "k_mean_gp")
FLAGS = ("completed", "feasible")
#: True, false or null (a candidate that failed before its runs).
MAYBE_FLAGS = ("completed_min_norm", "holds", "valid")
TEXTS = ("failure_min_norm", "failure", "invalid_reasons")
COUNTS = ("unstable_samples", "warnings")


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def row_problem(spec: SweepSpec, candidate: Candidate, row: Any) -> str | None:
    """Why a saved row cannot be reused for `candidate` (the first reason), or None when it passes."""
    if not isinstance(row, dict):
        return f"not a JSON object ({type(row).__name__})"
    if row.get("candidate") != candidate.id:
        return f"candidate {row.get('candidate')!r} is not {candidate.id!r}"
    if row.get("index") != candidate.index or isinstance(row.get("index"), bool):
        return f"index {row.get('index')!r} is not {candidate.index}"
    inputs = input_values(spec, candidate)
    missing = [k for k in (*inputs, *RESULT_COLUMNS) if k not in row]
    if missing:
        return f"missing columns {', '.join(missing[:5])}"
    for key, value in inputs.items():
        if row[key] != value or type(row[key]) is bool:
            return f"input {key} = {row[key]!r} is not the candidate's {value!r}"
    if row["screened_out"] is not False:
        return "a saved row is never screened out"
    for key in NUMBERS:
        if row[key] is not None and not _number(row[key]):
            return f"{key} = {row[key]!r} is not a finite number"
    for key in NON_NEGATIVE:
        if row[key] is not None and not (_number(row[key]) and row[key] >= 0.0):
            return f"{key} = {row[key]!r} is not a finite number ≥ 0"
    for key in CONDITION:
        if row[key] is not None and not (_number(row[key]) and row[key] >= 1.0):
            return f"{key} = {row[key]!r} is not a condition number (finite, ≥ 1)"
    for key in FLAGS:
        if not isinstance(row[key], bool):
            return f"{key} = {row[key]!r} is not true or false"
    for key in MAYBE_FLAGS:
        if row[key] is not None and not isinstance(row[key], bool):
            return f"{key} = {row[key]!r} is not true, false or null"
    for key in TEXTS:
        if row[key] is not None and not isinstance(row[key], str):
            return f"{key} = {row[key]!r} is not text"
    for key in COUNTS:
        if row[key] is not None and not (
            isinstance(row[key], int) and not isinstance(row[key], bool) and row[key] >= 0
        ):
            return f"{key} = {row[key]!r} is not a count"
    if row["completed"] and (row["Ci_mean_gp"] is None or row["k_mean_gp"] is None):
        return "a completed run without C_i or k"
    return None
