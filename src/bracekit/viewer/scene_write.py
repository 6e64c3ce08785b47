"""scene.json's content from a robot, its braces, named joint trajectories and a task path (world m, SI units).

One writer serves every command whose output the viewer replays: ``bracekit run`` (:func:`~bracekit.viewer.scene
.scene_data`) and ``bracekit cobot`` (:mod:`bracekit.cobot.scene`) build a :class:`SceneInput` and call
:func:`scene_content`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.geometry.obstacles import obstacle_mesh
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.viewer.link_meshes import MESH_FILE

Array = NDArray[np.float64]

#: The format tag and version of scene.json.
SCENE_FORMAT = "bracekit-scene"
SCENE_VERSION = 1


class SceneRun(NamedTuple):
    """One run as the scene checks it: joint values q (N×n, chain order) and whether it is braced."""

    q: Array
    braced: bool


@dataclass(frozen=True)
class SceneInput:
    """What scene.json describes.

    Attributes:
        name, description: the scenario's.
        compliance_model: the model of the summary ('constrained', 'projection', 'preloaded').
        braced: the braced robot (its brace frames, braces and joint stiffnesses).
        duration: the task's duration, s.
        path: the task path (k×3), m, world.
        runs: the runs by compliance model, then by strategy.
        gravity, preloads: the statics of the preloaded compliance (gravity on/off, P_i per brace in N).
        meshes: the folder carries the robot's link meshes (meshes.npz).
    """

    name: str
    description: str
    compliance_model: str
    braced: BracedRobot
    duration: float
    path: Array
    runs: dict[str, dict[str, SceneRun]]
    gravity: bool = False
    preloads: tuple[float, ...] = ()
    meshes: bool = False


def _vec(a: Any) -> list[float]:
    return [float(x) for x in np.asarray(a, dtype=float).reshape(-1)]


def tip_position(robot: Robot, q: Array) -> Array:
    """The tip e (3,), m, world, at q (Pinocchio's forward kinematics)."""
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
    return np.array(data.oMf[robot.tip_id].translation)


def scene_content(scene: SceneInput) -> dict[str, Any]:
    """The JSON-ready content of scene.json (:mod:`bracekit.viewer.scene`'s docstring)."""
    robot = scene.braced.robot
    braces = [
        {
            "frame": b.frame,
            "point": _vec(b.surface.point),
            "normal": _vec(b.surface.normal),
            "tangent": _vec(b.surface.tangent),
            "contact": b.contact.name if not isinstance(b.contact, str) else b.contact,
            "region_radius": b.region_radius,
            "surface_radius": b.surface_radius,
            "environment_stiffness": b.environment_stiffness,
            "pad_axis": b.pad_axis,
        }
        for b in scene.braced.braces
    ]
    checks: dict[str, Any] = {}
    for model, runs in scene.runs.items():
        for name, run in runs.items():
            if run.q.shape[0] == 0:
                continue
            checks[f"{model}/{name}"] = {
                "braced": bool(run.braced),
                "tip_first_last": [_vec(tip_position(robot, q)) for q in (run.q[0], run.q[-1])],
            }
    return {
        "format": SCENE_FORMAT,
        "version": SCENE_VERSION,
        "scenario": scene.name,
        "description": scene.description,
        "compliance_model": scene.compliance_model,
        "robot": {
            "name": str(robot.model.name),
            "pinocchio_model": robot.model.saveToString(),
            "tip": robot.tip,
            "stiffness": _vec(robot.stiffness),
            "joint_names": list(robot.joint_names),
            "capsules": [
                {"joint": c.joint, "a": _vec(c.a), "b": _vec(c.b), "radius": c.radius, "link": c.link}
                for c in robot.link_capsules()
            ],
            **({"meshes": MESH_FILE} if scene.meshes else {}),
        },
        "braces": braces,
        **({"obstacles": _obstacles(scene.braced)} if scene.braced.obstacles else {}),
        "holding": {"gravity": scene.gravity, "preloads": list(scene.preloads)},
        "task": {"duration": scene.duration, "path": [_vec(p) for p in scene.path]},
        "runs": checks,
    }


def _obstacles(braced: BracedRobot) -> list[dict[str, Any]]:
    """The environment's further solids as triangle meshes (base frame, m) for scene.json."""
    out = []
    for o in braced.obstacles:
        vertices, faces = obstacle_mesh(o)
        out.append({"name": o.name, "vertices": vertices.tolist(), "faces": faces.tolist()})
    return out
