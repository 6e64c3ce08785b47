"""Redundancy resolution (Section V): the strategies, and the fused steps that accelerate gradient projection.

``strategies``: the reference :class:`FreeSpaceMinNorm`, :class:`BracedMinNorm` and
:class:`BracedGradientProjection`. ``fused``: :class:`GradientProjectionStep`, the same gradient-projection step
fused into one call (NumPy, or the numba kernel of ``_numba_step``), tested equal to the reference. ``multi``: the
braced strategies with several braces, over the braced motions N, and their :class:`MultiBraceObjective`.
"""

from bracekit.resolution.fused import GradientProjectionStep, numba_available
from bracekit.resolution.multi import MultiBraceObjective
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
    "MultiBraceObjective",
    "Strategy",
    "TaskSpace",
    "numba_available",
    "with_beta_x",
]
