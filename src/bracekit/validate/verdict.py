"""The pass/fail rule of ``bracekit validate``: one typed verdict over every check that ran.

A validation fails when a case of any check failed (a reference did not run or did not settle), when a
holding check's outcome disagrees with the predicted margin, when a capacity ramp fails otherwise than
predicted, when the tracking check's ranking or values disagree (:meth:`TrackingReport.disagreements`), when
no compliance case could be compared, or when the constrained model's median error against MuJoCo exceeds 1 % in
the compliance block or in a finite-stiffness row.
"""

from __future__ import annotations

from typing import Any, NamedTuple

__all__ = ["MEDIAN_BOUND", "Verdict", "validation_verdict"]

#: The bound on a median relative error that the k_env rows and the several-brace block state (1 %).
MEDIAN_BOUND = 0.01


class Verdict(NamedTuple):
    """Whether the validation passed, the number of failed cases and one reason per failing block."""

    passed: bool
    failed: int
    reasons: tuple[str, ...]

    def message(self) -> str:
        """One line for stderr: the count and the reasons."""
        return f"{self.failed} validation case(s) failed" + (f" ({'; '.join(self.reasons)})" if self.reasons else "")


def validation_verdict(
    report: Any,
    preloaded: Any,
    *,
    holding: Any | None = None,
    capacity: Any | None = None,
    tracking: Any | None = None,
    environment: Any | None = None,
) -> Verdict:
    """The verdict of a one-brace ``validate``: the reports of :mod:`bracekit.validate`'s checks (None: not run).

    Args:
        report: :class:`~bracekit.validate.runner.ValidationReport` (the first-order models).
        preloaded: :class:`~bracekit.validate.runner.PreloadedValidationReport`.
        holding: :class:`~bracekit.validate.runner.HoldingValidationReport` or None.
        capacity: :class:`~bracekit.validate.runner.CapacityValidationReport` or None.
        tracking: :class:`~bracekit.validate.tracking.TrackingReport` or None.
        environment: :class:`~bracekit.validate.environment_check.EnvironmentValidationReport` or None.
    """
    parts: list[tuple[str, int]] = [
        ("compliance", report.counts().get("failed", 0)),
        ("preloaded", preloaded.counts()["failed"]),
    ]
    median = report.model_stats("constrained")["median_rel_err_mujoco"]
    if holding is not None:
        s = holding.summary()
        parts.append(("holding", s["counts"]["failed"] + len(s["margin_disagreements"])))
    if capacity is not None:
        parts.append(("capacity", capacity.counts()["failed"] + capacity.counts()["disagrees"]))
    if tracking is not None:
        parts.append(("tracking", len(tracking.disagreements())))
    if environment is not None:
        bad = environment.counts().get("failed", 0)
        for row in environment.rows:
            median = row.report.model_stats("constrained")["median_rel_err_mujoco"]
            if median is None or median > MEDIAN_BOUND:
                bad += 1
        parts.append(("finite surface stiffness", bad))
    failed = sum(n for _, n in parts)
    reasons = [f"{name}: {n}" for name, n in parts if n > 0]
    if report.model_stats("constrained")["n_cases"] == 0:
        reasons.append("no compliance case compared")
    elif median is None or median > MEDIAN_BOUND:
        reasons.append("the constrained model's median error against MuJoCo exceeds 1 %")
    return Verdict(passed=failed == 0 and len(reasons) == 0, failed=failed, reasons=tuple(reasons))
