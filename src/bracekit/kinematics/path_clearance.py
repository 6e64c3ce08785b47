"""A path's capsule clearance at once: whether it runs compiled, and the capsule frames of every configuration.

:meth:`bracekit.kinematics.clearance.Clearance.minima` places the capsule frames of a whole path with
:func:`path_placements` (Pinocchio's forward kinematics, one configuration at a time) and searches them with
:mod:`bracekit.kinematics._clearance_path` (compiled) or its own Python search; :func:`path_search` says which,
for the run's ``geometry`` line.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Sequence
from functools import cache
from types import ModuleType

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.model.robot import Robot

Array = NDArray[np.float64]

__all__ = ["compiled_path", "numba_installed", "path_placements", "path_search"]


@cache
def numba_installed() -> bool:
    """Whether numba can be imported (the ``[fast]`` extra); looked up once per process."""
    return importlib.util.find_spec("numba") is not None


def compiled_path() -> ModuleType | None:
    """The compiled search over a path (:mod:`bracekit.kinematics._clearance_path`), None without numba."""
    if not numba_installed():
        return None
    module = importlib.import_module("bracekit.kinematics._clearance_path")
    return module if module.COMPILED else None


def path_search() -> str:
    """How a path's capsule clearance is searched: "compiled" (numba, the ``[fast]`` extra) or in Python."""
    return "compiled" if compiled_path() is not None else "Python (numba not installed)"


def path_placements(robot: Robot, data: pin.Data, qs: Sequence[Array], frames: Sequence[int]) -> Array:
    """⁰M (4×4) of the Pinocchio frames `frames` at each configuration of a path (N, F, 4, 4).

    Pinocchio's forward kinematics with `data` (``forwardKinematics``, then ``updateFramePlacement`` of each
    frame asked for: cheaper than ``framesForwardKinematics``, which places every frame of the model).
    """
    model, n = robot.model, robot.n
    out = np.empty((len(qs), len(frames), 4, 4))
    kinematics, place = pin.forwardKinematics, pin.updateFramePlacement
    for i, q in enumerate(qs):
        kinematics(model, data, q if _plain(q, n) else robot.check_q(q))
        out[i] = [place(model, data, f).homogeneous for f in frames]
    return out


def _plain(q: object, n: int) -> bool:
    """Whether q is already what ``Robot.check_q`` returns: a finite float64 array (n,)."""
    return type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (n,) and bool(np.isfinite(q).all())
