"""The one report helper of the checks: relative errors in the weighted norm, statistics and aligned tables.

Δx = [Δp; Δθ] mixes metres and radians: deflections are compared in ‖Δx‖_L = ‖[Δp; L·Δθ]‖ (m), L the lever
from the brace to the tip (docs/validation.md, "Error measure"). Statistics are ``None`` (never NaN) when no
case contributes; :func:`aligned` lays out every check's text table.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bracekit.validate.inputs import Array

__all__ = ["aligned", "fmt_rel"]


def _weighted(dx: Array, length: float) -> Array:
    return np.concatenate([dx[:3], length * dx[3:]])


def _rel_err(pred: Array, ref: Array | None, length: float) -> float | None:
    """‖pred − ref‖_L / ‖ref‖_L with ‖[Δp; Δθ]‖_L = ‖[Δp; L Δθ]‖; None if there is no reference."""
    if ref is None:
        return None
    den = float(np.linalg.norm(_weighted(ref, length)))
    if not np.isfinite(den) or den <= 1e-300:
        return None
    val = float(np.linalg.norm(_weighted(pred - ref, length))) / den
    return val if np.isfinite(val) else None


def _stats(values: list[float | None]) -> tuple[float | None, float | None]:
    v = [x for x in values if x is not None and np.isfinite(x)]
    if not v:
        return None, None
    return float(np.median(v)), float(np.max(v))


def fmt_rel(x: float | None) -> str:
    """A relative error as a percentage (3 significant digits), 'n/a' when missing."""
    return "n/a" if x is None else f"{100.0 * x:.3g} %"


def aligned(cols: Sequence[str], rows: Sequence[Sequence[str]], left: Sequence[int] = (0,)) -> list[str]:
    """Header, rule and rows of a text table: columns ``left`` left-aligned, the others right-aligned."""
    widths = [max(len(r[i]) for r in (cols, *rows)) for i in range(len(cols))]

    def fmt(r: Sequence[str]) -> str:
        return "  ".join(c.ljust(widths[i]) if i in left else c.rjust(widths[i]) for i, c in enumerate(r))

    head = fmt(cols)
    return [head, "-" * len(head), *(fmt(r) for r in rows)]
