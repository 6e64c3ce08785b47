"""A path's capsule clearance at once: whether it runs compiled, and the capsule frames of every configuration.

:meth:`bracekit.kinematics.clearance.Clearance.minima` places the capsule frames of a whole path with
:func:`path_placements` (compiled forward kinematics where numba is installed, else Pinocchio per configuration)
and searches them with :mod:`bracekit.kinematics._clearance_path` (compiled) or its own Python search;
:func:`path_search` says which, for the run's ``geometry`` line.
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import weakref
from collections.abc import Sequence
from functools import cache
from types import ModuleType
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.model.chain import joint_axis
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

    Compiled forward kinematics where numba is installed (Pinocchio's values to rounding), else Pinocchio's
    forward kinematics with `data` and the frames' placements, one configuration at a time.
    """
    model, n = robot.model, robot.n
    out = np.empty((len(qs), len(frames), 4, 4))
    kernel = compiled_path()
    chain = _serial_chain(model) if kernel is not None else None
    if kernel is not None and chain is not None:
        qa = np.array([q if _plain(q, n) else robot.check_q(q) for q in qs], dtype=np.float64).reshape(-1, n)
        ids = list(frames)
        rot = np.array([model.frames[f].placement.rotation for f in ids], dtype=np.float64).reshape(-1, 3, 3)
        trans = np.array([model.frames[f].placement.translation for f in ids], dtype=np.float64).reshape(-1, 3)
        joints = np.array([int(model.frames[f].parentJoint) for f in ids], dtype=np.int64)
        kernel.place(qa, *chain, joints, rot, trans, out)
        return out
    for i, q in enumerate(qs):
        pin.forwardKinematics(model, data, q if _plain(q, n) else robot.check_q(q))
        for k, f in enumerate(frames):
            out[i, k] = pin.updateFramePlacement(model, data, f).homogeneous
    return out


def _plain(q: object, n: int) -> bool:
    """Whether q is already what ``Robot.check_q`` returns: a finite float64 array (n,)."""
    return type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (n,) and math.isfinite(q.sum())


#: pin.Model → its joints as arrays for the compiled forward kinematics, or None (a joint not 1-DoF R or P)
_CHAINS: weakref.WeakKeyDictionary[pin.Model, tuple[NDArray[Any], ...] | None] = weakref.WeakKeyDictionary()


def _serial_chain(model: pin.Model) -> tuple[NDArray[Any], ...] | None:
    """(parent, rot0, trans0, axis, revolute, column) of every joint of `model` (index 0 the universe), or None.

    None when a joint is not a 1-DoF revolute or prismatic joint (:func:`~bracekit.model.chain.joint_axis`).
    """
    try:
        return _CHAINS[model]
    except (KeyError, TypeError):
        pass
    nj = int(model.njoints)
    kinds = [joint_axis(model.joints[j]) for j in range(1, nj)]
    found: tuple[NDArray[Any], ...] | None = None
    if all(k is not None for k in kinds) and all(model.joints[j].nv == 1 for j in range(1, nj)):
        axes = [np.zeros(3)] + [np.asarray(k[1], dtype=np.float64) for k in kinds if k is not None]
        found = (
            np.array([int(p) for p in model.parents], dtype=np.int64),
            np.array([np.asarray(model.jointPlacements[j].rotation) for j in range(nj)], dtype=np.float64),
            np.array([np.asarray(model.jointPlacements[j].translation) for j in range(nj)], dtype=np.float64),
            np.array(axes, dtype=np.float64),
            np.array([0] + [int(k[0]) for k in kinds if k is not None], dtype=np.int64),
            np.array([0] + [int(model.joints[j].idx_v) for j in range(1, nj)], dtype=np.int64),
        )
    try:
        _CHAINS[model] = found
    except TypeError:
        pass
    return found
