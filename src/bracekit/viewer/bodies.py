"""The solid bodies drawn under the scene, so that the arm does not float: the surface's body and the robot's mount.

* The surface's body: with a surface radius r_max (a post or a table top) the solid below the surface disk is a
  cylinder of radius r_max, as the clearance counts it (:mod:`bracekit.geometry.obstacles`); it is drawn down to
  the floor z = 0 of the base frame (a surface below the floor or facing sideways: 0.1 m deep). Without a radius
  (the plane) a slab of the drawn radius and 0.03 m thickness.
* The robot's mount: a robot drawn by its capsules has no base body, so a puck of radius 0.07 m and height
  0.05 m under the base frame's origin is drawn; a robot with meshes has its base link's own mesh.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Depth of a body whose surface does not face up above the floor, and of the plane's slab, m.
SIDE_DEPTH = 0.1
SLAB_DEPTH = 0.03
#: The capsule robot's mount (radius, height), m.
MOUNT = (0.07, 0.05)


class Cylinder(NamedTuple):
    """A solid cylinder of axis [top, bottom] (m, base frame) and radius (m)."""

    top: Array
    bottom: Array
    radius: float


def surface_body(point: Array, normal: Array, surface_radius: float | None, drawn_radius: float) -> Cylinder:
    """The body below a surface disk of unit `normal` about `point` (see the module docstring)."""
    c, n = np.asarray(point, dtype=float), np.asarray(normal, dtype=float)
    if surface_radius is None:
        return Cylinder(c, c - SLAB_DEPTH * n, drawn_radius)
    depth = float(c[2] / n[2]) if n[2] > 0.1 and c[2] > 0.0 else SIDE_DEPTH
    return Cylinder(c, c - max(depth, SLAB_DEPTH) * n, surface_radius)


def mount() -> Cylinder:
    """The capsule robot's mount under the base frame's origin."""
    radius, height = MOUNT
    return Cylinder(np.zeros(3), np.array([0.0, 0.0, -height]), radius)
