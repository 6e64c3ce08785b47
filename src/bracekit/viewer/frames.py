"""Per-sample poses of a run for drawing: joint placements, tip, brace points and the tip's compliance ellipsoid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.compliance.first_order import compliance_ellipsoids
from bracekit.compliance.preloaded import run_compliance
from bracekit.viewer.scene import Run, Scene

Array = NDArray[np.float64]


@dataclass(frozen=True)
class RunFrames:
    """What a run looks like at each of its N samples.

    Attributes:
        joints: ⁰M of each joint of the chain (N×n×4×4), world; joint i + 1 of Pinocchio is ``joints[:, i]``.
        tip: tip positions e (N×3), m.
        brace_points: each brace frame's origin b_i (N×k×3), m.
        semi_axes: the tip's translational compliance ellipsoid (N×3), m/N, ascending (eigenvalues of C_e's force
            block: the free-space compliance for an unbraced run, else the run's compliance model).
        axes: its principal directions (N×3×3), ``axes[k][:, i]`` along ``semi_axes[k, i]``, world.
    """

    joints: Array
    tip: Array
    brace_points: Array
    semi_axes: Array
    axes: Array


def tip_compliance(scene: Scene, model: str, braced: bool, q: Array) -> Array:
    """The 6×6 tip compliance C_e at q of a run under `model` (free space for an unbraced run).

    The same choice as the run's figures: 'preloaded' uses the preloaded compliance (gravity and the preload of
    the scene), the others :func:`end_effector_compliance` (the stacked model with several braces).
    """
    b = scene.braced
    state = b.state(q)
    preload = scene.preloads[0] if scene.preloads else 0.0
    return run_compliance(state, model, braced, preload=preload, gravity=scene.gravity)


def run_frames(scene: Scene, run: Run) -> RunFrames:
    """The per-sample poses and ellipsoids of one run (one kinematics pass and one C_e per sample)."""
    robot = scene.braced.robot
    model = robot.model
    data = model.createData()
    brace_ids = [robot.frame_id(b.frame) for b in scene.braced.braces]
    count = run.q.shape[0]
    joints = np.empty((count, robot.n, 4, 4))
    tip = np.empty((count, 3))
    points = np.empty((count, len(brace_ids), 3))
    semi = np.empty((count, 3))
    axes = np.empty((count, 3, 3))
    for k, q in enumerate(run.q):
        pin.framesForwardKinematics(model, data, q)
        for j in range(1, model.njoints):
            joints[k, j - 1] = data.oMi[j].homogeneous
        tip[k] = data.oMf[robot.tip_id].translation
        for i, f in enumerate(brace_ids):
            points[k, i] = data.oMf[f].translation
        ell = compliance_ellipsoids(tip_compliance(scene, run.model, run.braced, q)).translational
        semi[k], axes[k] = ell.semi_axes, ell.axes
    return RunFrames(joints, tip, points, semi, axes)
