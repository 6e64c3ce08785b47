"""Pinocchio's frame kinematic Hessians ∂J/∂q, read with their memory layout checked at run time.

Pinocchio 4.1.0 returns ``getFrameKinematicHessian`` as a (6, n, n) array whose memory is column-major although
its strides claim C order (docs/model.md). bracekit reads the memory as the column-major tensor and checks it
once per model and frame against central differences of the frame Jacobian, so a change upstream cannot make
the analytic gradients silently wrong.
"""

from __future__ import annotations

import weakref
from typing import cast

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import NumericalError

Array = NDArray[np.float64]
#: Pinocchio's LOCAL_WORLD_ALIGNED frame: reference point at the frame origin, world axes (the paper's J).
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


#: id(model) → (weak reference to the model, frames whose Hessian layout has been checked).
_LAYOUT_CHECKED: dict[int, tuple[weakref.ref[pin.Model], set[int]]] = {}


def _hessian_buffer(model: pin.Model, data: pin.Data, frame_id: int) -> Array:
    """Pinocchio's frame kinematic Hessian as its raw memory, flat: element r + 6 i + 6 n k is ∂J[r, i]/∂q_k.

    Pinocchio 4.1.0 returns a (6, n, n) array whose memory is column-major although its strides claim C
    order (docs/model.md); the memory itself is the column-major tensor. The first call for a frame of a model
    checks this against finite differences (:func:`check_hessian_layout`).
    """
    if not _checked(model, frame_id):
        check_hessian_layout(model, frame_id)
        _mark_checked(model, frame_id)
    return _raw_hessian(model, data, frame_id)


def _checked(model: pin.Model, frame_id: int) -> bool:
    entry = _LAYOUT_CHECKED.get(id(model))
    return entry is not None and entry[0]() is model and frame_id in entry[1]


def _mark_checked(model: pin.Model, frame_id: int) -> None:
    entry = _LAYOUT_CHECKED.get(id(model))
    if entry is None or entry[0]() is not model:  # (a WeakKeyDictionary lookup costs microseconds)
        key = id(model)
        entry = _LAYOUT_CHECKED[key] = (weakref.ref(model, lambda _: _LAYOUT_CHECKED.pop(key, None)), set())
    entry[1].add(frame_id)


def ensure_hessian_layout(model: pin.Model, data: pin.Data, frame_ids: tuple[int, ...]) -> None:
    """Check the Hessian layout of each frame not yet checked, using (and overwriting) the caller's `data`.

    For callers that evaluate their own configuration afterwards: it spares the second Data (n³ in size)
    that :func:`check_hessian_layout` would otherwise create.
    """
    for frame_id in frame_ids:
        if not _checked(model, frame_id):
            check_hessian_layout(model, frame_id, data=data)
            _mark_checked(model, frame_id)


def _raw_hessian(model: pin.Model, data: pin.Data, frame_id: int) -> Array:
    return cast(Array, pin.getFrameKinematicHessian(model, data, frame_id, LWA).ravel(order="C"))


def check_hessian_layout(model: pin.Model, frame_id: int, step: float = 1e-6, data: pin.Data | None = None) -> None:
    """NumericalError unless :func:`frame_hessian` equals central differences of the frame's Jacobian.

    Evaluated at a fixed generic configuration with its own data (or `data`, which it then overwrites), so it
    does not disturb the caller's. Guards the memory layout of Pinocchio's kinematic Hessian that bracekit reads
    (docs/model.md): another layout would make every analytic gradient wrong without any other symptom.
    """
    n = model.nv
    data = model.createData() if data is None else data
    q = pin.integrate(model, pin.neutral(model), np.random.default_rng(0).uniform(-1.0, 1.0, n))
    pin.computeJointJacobians(model, data, q)
    pin.computeJointKinematicHessians(model, data)
    ours = _raw_hessian(model, data, frame_id).reshape((6, n, n), order="F")  # as frame_hessian reads it
    fd = np.empty((6, n, n))
    for k in range(n):
        dq = np.zeros(n)
        dq[k] = step
        plus = pin.computeFrameJacobian(model, data, pin.integrate(model, q, dq), frame_id, LWA)
        minus = pin.computeFrameJacobian(model, data, pin.integrate(model, q, -dq), frame_id, LWA)
        fd[:, :, k] = (plus - minus) / (2.0 * step)
    err = float(np.max(np.abs(ours - fd), initial=0.0))
    if not err <= 1e-6 * (1.0 + float(np.max(np.abs(fd), initial=0.0))):
        raise NumericalError(
            f"Pinocchio {pin.__version__}'s kinematic Hessian of frame '{model.frames[frame_id].name}' differs from "
            f"finite differences of its Jacobian by {err:.3g}: its memory layout is not Pinocchio 4.1.0's, which "
            "bracekit reads (docs/model.md), so analytic gradients would be wrong; use gradient='finite-difference'"
        )


def frame_hessian(model: pin.Model, data: pin.Data, frame_id: int) -> Array:
    """∂J/∂q of a frame's LOCAL_WORLD_ALIGNED Jacobian, shape (6, n, n): H[:, i, k] = ∂J[:, i]/∂q_k.

    Needs ``computeJointJacobians`` and ``computeJointKinematicHessians`` at q first. Pinocchio 4.1.0
    returns a (6, n, n) array whose memory is column-major although its strides claim C order
    (docs/model.md); the reshape below undoes that, and :func:`check_hessian_layout` guards it at run time.
    """
    n = model.nv
    return np.ascontiguousarray(_hessian_buffer(model, data, frame_id).reshape((6, n, n), order="F"))


def frame_hessian_rows(model: pin.Model, data: pin.Data, frame_id: int) -> Array:
    """The same Hessian as an (n, 6n) matrix, no copy: R[k, r + 6 i] = ∂J[r, i]/∂q_k.

    Contractions Σ_{r,i} U[i, r] ∂J[r, i]/∂q_k (U of shape (n, 6)) are then one product ``R @ U.ravel()``.
    """
    n = model.nv
    return _hessian_buffer(model, data, frame_id).reshape(n, 6 * n)
