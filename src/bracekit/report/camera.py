"""The orthographic camera of a run's figures: the view that shows the robot's links overlapping least."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.path import Path as MplPath
from numpy.typing import NDArray

from bracekit.report.projection import OrthoCamera, capsule_outlines

Array = NDArray[np.float64]


def choose_camera(ends: tuple[Array, Array], radius: Array, task_path: Array) -> OrthoCamera:
    """The view from the task's side of the robot in which its links overlap least.

    Candidates: azimuths 0°, ±30° and ±60° about the horizontal direction across the robot's long horizontal
    axis (toward the task's side), elevations 15°, 25° and 35°. Each is scored by the share of the links'
    drawn area that another link covers, on a few samples (a coarse raster); ties go to 30° toward the task.

    Args:
        ends: the capsules' end points a and b (N, m, 3), world m, over the samples to judge.
        radius: the capsules' radii (m,), m.
        task_path: the task's positions (p, 3), world m.
    """
    a, b = ends
    points = np.concatenate([a, b], axis=1).reshape(-1, 3)
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, _, vt = np.linalg.svd(xy, full_matrices=False)
    axis = vt[0]
    task = task_path[:, :2].mean(axis=0) - points[:, :2].mean(axis=0)
    if float(axis @ task) < 0.0:
        axis = -axis  # along the robot toward the task
    side = np.array([-axis[1], axis[0]])
    if float(side @ task) < 0.0:
        side = -side  # the viewer stands on the task's side of the robot
    base = math.degrees(math.atan2(side[1], side[0]))
    # the sense in which the azimuth turns toward the task
    turn = 1.0 if float(side[0] * axis[1] - side[1] * axis[0]) > 0.0 else -1.0
    samples = np.unique(np.linspace(0, a.shape[0] - 1, 3).astype(int))
    best: tuple[float, OrthoCamera] | None = None
    for offset in (30.0, 0.0, 60.0, -30.0, -60.0):
        for elevation in (25.0, 15.0, 35.0):
            cam = OrthoCamera(base + turn * offset, elevation)
            score = float(np.mean([_overlap(cam, a[k], b[k], radius) for k in samples]))
            score += 0.01 * (abs(offset - 30.0) / 30.0 + abs(elevation - 25.0) / 10.0)
            if best is None or score < best[0]:
                best = (score, cam)
    assert best is not None
    return best[1]


def _overlap(cam: OrthoCamera, a: Array, b: Array, radius: Array, cells: int = 48) -> float:
    """Share of the capsules' drawn area (summed one by one) that more than one capsule covers, on a raster."""
    outlines = capsule_outlines(cam.project(a), cam.project(b), radius, 5)
    lo, hi = outlines.reshape(-1, 2).min(axis=0), outlines.reshape(-1, 2).max(axis=0)
    gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], cells), np.linspace(lo[1], hi[1], cells))
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    count = np.zeros(grid.shape[0], dtype=np.intp)
    for outline in outlines:
        count += MplPath(outline).contains_points(grid)
    total = int(count.sum())
    return 0.0 if total == 0 else 1.0 - int(np.count_nonzero(count)) / total
