"""The silhouettes of a robot's link meshes in an orthographic view, as convex blocks drawn far to near.

A link mesh (:mod:`bracekit.viewer.link_meshes`: every element of the URDF's collision geometry, in its joint's
frame) is cut into blocks: its triangles grouped by the cube of edge :data:`BLOCK` their centre falls in, each
block kept as the extreme points of its triangles' corners (the vertices of their convex hull). A block's
outline in a view is the convex polygon of its projected points' supports in :data:`DIRECTIONS` screen
directions (inside the projected hull, touching it at each of those directions). The union of the outlines
covers the mesh's silhouette up to that polygon's chord and departs from it by at most a block's concavity
(the tests compare with the projected vertices). Robots without meshes are drawn with their capsules.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bracekit.geometry.pieces import extreme_points
from bracekit.viewer.link_meshes import link_meshes

if TYPE_CHECKING:
    from bracekit.model.robot import Robot
    from bracekit.report.projection import OrthoCamera

Array = NDArray[np.float64]

#: Edge of the cubes a mesh's triangles are grouped by, m.
BLOCK = 0.05
#: Screen directions whose supports make a block's outline.
DIRECTIONS = 32
_ANGLES = np.linspace(0.0, 2.0 * np.pi, DIRECTIONS, endpoint=False)
_DIRS = np.column_stack([np.cos(_ANGLES), np.sin(_ANGLES)])


@dataclass(frozen=True, eq=False)
class Blocks:
    """A robot's mesh blocks, each fixed to a joint.

    Attributes:
        joint: Pinocchio joint index of each block (b,) (0: the base).
        points: each block's extreme points (b, k, 3) in its joint's frame, m (a block with fewer repeats its
            first).
        centre: each block's centre (b, 3), joint frame, m.
    """

    joint: NDArray[np.intp]
    points: Array
    centre: Array

    def world(self, rotations: Array, origins: Array) -> tuple[Array, Array]:
        """Points (b, k, 3) and centres (b, 3), world m, for the joints' poses (rotations (J, 3, 3), origins (J, 3)).

        Joint 0 (the base) is rotations[0], origins[0].
        """
        rot, org = rotations[self.joint], origins[self.joint]
        pts = np.einsum("bij,bkj->bki", rot, self.points) + org[:, None, :]
        return pts, np.einsum("bij,bj->bi", rot, self.centre) + org

    @staticmethod
    def outlines(camera: OrthoCamera, points: Array) -> Array:
        """Each block's outline (b, DIRECTIONS, 2), screen m, counter-clockwise, of its world points (b, k, 3)."""
        screen = camera.project(points)  # (b, k, 2)
        best = np.argmax(screen @ _DIRS.T, axis=1)  # (b, DIRECTIONS): the support point of each direction
        return np.take_along_axis(screen, best[:, :, None], axis=1)


def _blocks_of(vertices: Array, triangles: NDArray[np.uint32]) -> list[Array]:
    corners = vertices[triangles]  # (t, 3, 3)
    cells = np.floor(corners.mean(axis=1) / BLOCK).astype(np.int64)
    _, group = np.unique(cells, axis=0, return_inverse=True)
    return [extreme_points(corners[group.ravel() == g].reshape(-1, 3)) for g in range(int(group.max()) + 1)]


def mesh_blocks(robot: Robot) -> Blocks | None:
    """The blocks of the robot's link meshes; None when it is drawn with capsules (no meshes, or over the caps)."""
    meshes = link_meshes(robot)
    if not meshes:
        return None
    joints, blocks = [], []
    for m in meshes:
        found = _blocks_of(m.vertices.astype(float), m.triangles)
        blocks += found
        joints += [m.joint] * len(found)
    size = max(len(b) for b in blocks)
    points = np.array([np.vstack([b, np.repeat(b[:1], size - len(b), axis=0)]) for b in blocks])
    centre = np.array([0.5 * (b.min(axis=0) + b.max(axis=0)) for b in blocks])
    return Blocks(np.array(joints, dtype=np.intp), points, centre)


def block_pieces(
    blocks: Blocks, planes: Sequence[Any], camera: OrthoCamera, rotations: Array, origins: Array
) -> tuple[Array, NDArray[np.intp], NDArray[np.intp], Array, NDArray[np.intp]]:
    """The blocks at the joints' poses as :meth:`RunScene.pieces` gives pieces.

    Returns:
        Outlines (b, DIRECTIONS, 2), the block of each (b,), its layer (b,) (2j + 1: its centre in front of the j
        farthest planes), depth (b,) and the drawing order (far to near within a layer).
    """
    points, centre = blocks.world(rotations, origins)
    layer = np.ones(centre.shape[0], dtype=np.intp)
    for j, plane in enumerate(planes):
        facing = 1.0 if float(plane.normal @ camera.toward) >= 0.0 else -1.0
        front = facing * ((centre - plane.point) @ plane.normal) >= 0.0
        layer = np.where(front, 2 * (j + 1) + 1, layer)
    depth = camera.depth(centre)
    order = np.lexsort((depth, layer))
    return Blocks.outlines(camera, points), np.arange(centre.shape[0], dtype=np.intp), layer, depth, order
