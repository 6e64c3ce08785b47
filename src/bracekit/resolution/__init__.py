"""Redundancy resolution (Section V): the strategies, and the fused steps that accelerate gradient projection.

``strategies``: the reference :class:`FreeSpaceMinNorm`, :class:`BracedMinNorm` and
:class:`BracedGradientProjection`. ``fused``: :class:`GradientProjectionStep`, the same gradient-projection step
fused into one call (NumPy, or the numba kernel of ``_numba_step``), tested equal to the reference. Every braced
strategy resolves over the state's braced motions (:mod:`bracekit.kinematics.motions`), for any number of braces.
"""

from bracekit.resolution.fused import GradientProjectionStep, numba_available
from bracekit.resolution.strategies import (
    GRADIENT_MODES,
    BracedGradientProjection,
    BracedMinNorm,
    FreeSpaceMinNorm,
    GradientMode,
    Strategy,
    with_beta_x,
)
from bracekit.resolution.task_space import TASK_SPACES, TaskSpace

__all__ = [
    "GRADIENT_MODES",
    "TASK_SPACES",
    "BracedGradientProjection",
    "BracedMinNorm",
    "FreeSpaceMinNorm",
    "GradientMode",
    "GradientProjectionStep",
    "Strategy",
    "TaskSpace",
    "numba_available",
    "with_beta_x",
]


def __getattr__(name: str) -> object:
    """``ControlStep`` of :mod:`bracekit.control`, imported on first use (it builds on this package)."""
    if name == "ControlStep":
        from bracekit.control.step import ControlStep

        return ControlStep
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
