"""A scenario's further obstacles: its ``[[obstacle]]`` tables as coal solids (:mod:`bracekit.geometry.obstacles`).

Each table is one solid, fixed in the robot's base frame::

    [[obstacle]]
    name = "fixture"                          # optional, for messages (default "obstacle[i]")
    box = { size = [0.2, 0.1, 0.3] }          # edge lengths, m; or
    # cylinder = { radius = 0.05, length = 0.4 }   (its axis along the pose's z), or
    # sphere = { radius = 0.05 }, or
    # mesh = "fixture.stl"                     (relative to the scenario's folder; its convex hull), with
    # scale = 0.001                            (a mesh in mm)
    position = [0.4, 0.0, 0.15]               # the solid's centre (a mesh's frame), m (default the origin)
    rpy = [0.0, 0.0, 0.3]                     # roll, pitch, yaw (rad, URDF's convention; default 0)

Every link's clearance counts every obstacle like the bracing surface's solid (coal's signed distance; the
braced link but for its pad's neighbourhood). Inside an obstacle the value is coal's penetration depth (EPA)
of the link's convex piece: the least translation that separates it, at least its deepest point's depth. A
mesh is read by coal's loader (STL, DAE, OBJ); a file that is missing or unreadable is a ScenarioError naming
it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from bracekit.errors import BracekitError, ScenarioError
from bracekit.geometry.obstacles import Obstacle, box_obstacle, cylinder_obstacle, mesh_obstacle, sphere_obstacle
from bracekit.kinematics.braced import BracedRobot
from bracekit.simulation.toml_table import Table

#: The shape keys of an [[obstacle]] table (exactly one per table).
SHAPES = ("box", "cylinder", "sphere", "mesh")
#: Every key of an [[obstacle]] table.
KEYS = ("name", *SHAPES, "scale", "position", "rpy")


def with_obstacles(braced: BracedRobot, obstacles: Sequence[Obstacle]) -> BracedRobot:
    """A copy of `braced` whose environment holds `obstacles` too (its clearance counts them); itself if none."""
    if not obstacles:
        return braced
    out = BracedRobot(braced.robot, braced.braces)
    object.__setattr__(out, "obstacles", (*braced.obstacles, *obstacles))  # a frozen dataclass: set once, here
    return out


def obstacle_tables(raw: Any, base: Path) -> tuple[Obstacle, ...]:
    """The obstacles of a scenario's ``obstacle`` key (an array of tables; () when absent), base frame.

    Raises:
        ScenarioError: a malformed table (one line naming the key and what to give).
    """
    if raw is None:
        return ()
    if not isinstance(raw, list) or not all(isinstance(t, dict) for t in raw):
        raise ScenarioError("'obstacle' must be an array of tables: [[obstacle]] with box, cylinder, sphere or mesh")
    return tuple(_obstacle(Table(t, f"obstacle[{i}]", KEYS), i, base) for i, t in enumerate(raw, start=1))


def _obstacle(t: Table, index: int, base: Path) -> Obstacle:
    shapes = [k for k in SHAPES if t.has(k)]
    if len(shapes) != 1:
        raise ScenarioError(
            f"'{t.path}' needs exactly one shape: box = {{size = [x, y, z]}}, cylinder = {{radius, length}}, "
            f'sphere = {{radius}} or mesh = "file.stl" (got {", ".join(shapes) or "none"})'
        )
    kind = shapes[0]
    name = t.string("name", default=f"obstacle[{index}]")
    if t.has("scale") and kind != "mesh":
        raise ScenarioError(f"'{t.key('scale')}' goes with a mesh; give a {kind}'s sizes in m")
    pose = np.eye(4)
    pose[:3, 3] = t.vector("position", 3, default=[0.0, 0.0, 0.0])
    pose[:3, :3] = pin.rpy.rpyToMatrix(*t.vector("rpy", 3, default=[0.0, 0.0, 0.0]))
    try:
        if kind == "mesh":
            return mesh_obstacle(name, _mesh_vertices(t, base), pose)
        shape = t.table(kind, {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",)}[kind])
        if kind == "box":
            return box_obstacle(name, shape.vector("size", 3), pose)
        if kind == "cylinder":
            return cylinder_obstacle(name, shape.number("radius"), shape.number("length"), pose)
        return sphere_obstacle(name, shape.number("radius"), pose)
    except ScenarioError:
        raise
    except BracekitError as exc:
        raise ScenarioError(f"'{t.key(kind)}': {exc}") from exc


def _mesh_vertices(t: Table, base: Path) -> np.ndarray:
    """The mesh file's vertices (k, 3), m (scaled), read by coal's loader."""
    path = Path(t.string("mesh"))
    path = path if path.is_absolute() else base / path
    scale = t.number("scale", 1.0, positive=True)
    if not path.is_file():
        raise ScenarioError(
            f"'{t.key('mesh')}': the mesh file {os.fspath(path)} does not exist; give a path "
            "relative to the scenario's folder"
        )
    try:
        model = coal.MeshLoader().load(os.fspath(path), np.full(3, scale))
        vertices = np.array(model.vertices(), dtype=float).reshape(-1, 3)
    except Exception as exc:  # coal's loader raises its own C++ errors
        raise ScenarioError(
            f"'{t.key('mesh')}': cannot read the mesh {os.fspath(path)} ({type(exc).__name__}); give a valid STL, "
            "DAE or OBJ file"
        ) from exc
    if len(vertices) < 4:
        raise ScenarioError(f"'{t.key('mesh')}': the mesh {os.fspath(path)} has fewer than four vertices")
    return vertices
