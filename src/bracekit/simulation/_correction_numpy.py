"""One point of the Gauss–Newton correction in NumPy: the correction's point where numba cannot be imported.

:func:`evaluate` takes the arguments and gives the results of the compiled
:func:`bracekit.simulation._correction_kernel.evaluate` (the same residual, stopping test, rows and minimum-norm
step, to rounding) with Pinocchio's ``log3`` / ``Jlog3`` and NumPy's products and ``lstsq`` on whole arrays: the
kernel's loops run as Python are about five times slower. A run that takes it says so in its notes
(:data:`bracekit.simulation.notes.CORRECTION_BACKEND_NOTE`).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.simulation import _correction_kernel as kernel

Array = NDArray[np.float64]

__all__ = ["evaluate"]


def _task_residual(tip: Array, position: Array, target: Array, kind: int, axis: Array, res: Array) -> int:
    """The task rows of the residual into res[:rows]; their count (6, 3 or 5)."""
    if kind == kernel.POSITION_AXIS:  # five rows of small loops: the kernel's own code, as Python
        return int(kernel._task_residual(tip, position, target, kind, axis, res))
    res[:3] = position - tip[:3, 3]
    if kind == kernel.POSITION:
        return 3
    res[3:6] = pin.log3(target @ tip[:3, :3].T)
    return 6


def _task_rows(tip: Array, j_e: Array, kind: int, axis: Array, rows: Array) -> None:
    """The task rows S J_e into rows[:6], rows[:3] or rows[:5]."""
    if kind == kernel.POSITION_AXIS:
        rows[:3] = j_e[:3]
        rows[3:5] = kernel._perpendicular(tip[:3, :3] @ axis) @ j_e[3:]
    else:
        top = 6 if kind == kernel.POSE else 3
        rows[:top] = j_e[:top]


def evaluate(
    mats: Array,
    jacs: Array,
    q: Array,
    position: Array,
    target: Array,
    anchors: Array,
    xs: Array,
    widths: NDArray[np.int64],
    scale: Array,
    kind: int,
    axis: Array,
    accept: float,
    roundoff: float,
    tol: float,
    previous: float,
    res: Array,
    rows: Array,
    step: Array,
) -> tuple[int, float, float]:
    """:func:`bracekit.simulation._correction_kernel.evaluate` (its arguments, results and status) in NumPy."""
    start = task = _task_residual(mats[0], position, target, kind, axis, res)
    braces = []
    for i in range(anchors.shape[0]):
        m, anchor, x = mats[1 + i], anchors[i], xs[i, :, : widths[i]]
        d = np.zeros(6)
        d[:3] = m[:3, 3] - anchor[:3, 3]
        turn = m[:3, :3] @ anchor[:3, :3].T if x[3:].any() else None  # R_b_i R_b0_iᵀ where X_i has moments
        if turn is not None:
            d[3:] = pin.log3(turn)
        res[start : start + x.shape[1]] = -(x.T @ d)
        braces.append((start, x, turn))
        start += x.shape[1]
    scaled = res / scale
    size, norm = float(np.abs(scaled).max()), math.sqrt(float(scaled @ scaled))
    if size < tol or (size < accept and size > 0.5 * previous):
        return kernel.DONE, size, norm
    _task_rows(mats[0], jacs[0], kind, axis, rows[:task])
    for i, (begin, x, turn) in enumerate(braces):
        j_b = jacs[1 + i]
        if turn is None:
            rows[begin : begin + x.shape[1]] = x.T @ j_b
        else:
            rows[begin : begin + x.shape[1]] = x[:3].T @ j_b[:3] + x[3:].T @ (pin.Jlog3(turn) @ turn.T @ j_b[3:])
    big = max(1.0, float(np.abs(q).max()))
    if size < roundoff * big * float(np.linalg.norm(rows / scale[:, None])):
        return kernel.FLOOR, size, norm
    step[:] = rows.T @ np.linalg.lstsq(rows @ rows.T, res, rcond=None)[0]
    return kernel.STEP, size, norm
