"""A cobot run as a replay for ``bracekit view``: scene.json and trajectories.npz from the MuJoCo loop.

Each strategy's run is MuJoCo's joint positions q(t) every :data:`SAMPLE_TICKS` control ticks (series.npz's
``qpos``), under the one compliance model :data:`MODEL` ('constrained'); the task path is the worker's targets,
the holes, in order (m, world). The robot and its braces are the base scenario's, written by the writer of
``bracekit run`` (:func:`~bracekit.viewer.scene_write.scene_content`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit.cobot.loop import CobotRun
from bracekit.cobot.run import CobotResult
from bracekit.viewer.scene_write import SceneInput, SceneRun, scene_content

__all__ = ["MODEL", "SAMPLE_TICKS", "cobot_scene", "cobot_trajectories", "replay_samples"]

#: The compliance model the replay's runs are filed under.
MODEL = "constrained"
#: Control ticks between two stored joint positions (MuJoCo's qpos every 20 ms at 1 kHz).
SAMPLE_TICKS = 20


def replay_samples(run: CobotRun) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Times t (N,), s, and MuJoCo's joint positions q (N×n) of the ticks the loop stored (every SAMPLE_TICKS)."""
    t = run.t[::SAMPLE_TICKS]
    return t, run.qpos[: t.size]


def cobot_trajectories(result: CobotResult) -> dict[str, Any]:
    """trajectories.npz's arrays: '<model>/<strategy>/t', '.../q', the brace's and the worker's force (N) then."""
    arrays: dict[str, Any] = {"joint_names": np.array(result.scenario.base.robot.joint_names)}
    for run in result.runs:
        t, q = replay_samples(run)
        key = f"{MODEL}/{run.strategy}"
        arrays[f"{key}/t"], arrays[f"{key}/q"] = t, q
        # one brace: its normal force is the viewer's contact-force arrow; several: the least of them, by its name
        force = "contact_force_N" if len(result.scenario.base.braced.braces) == 1 else "brace_normal_force_min_N"
        arrays[f"{key}/{force}"] = run.normal[::SAMPLE_TICKS]
        arrays[f"{key}/worker_force_N"] = np.linalg.norm(run.force[::SAMPLE_TICKS], axis=1)
    return arrays


def cobot_scene(result: CobotResult, meshes: bool = False) -> dict[str, Any]:
    """scene.json's content for the cobot run (module docstring); `meshes`: the folder carries meshes.npz."""
    sc = result.scenario
    base = sc.base
    runs = {MODEL: {r.strategy: SceneRun(replay_samples(r)[1], r.braced) for r in result.runs}}
    count = len(base.braced.braces)
    return scene_content(
        SceneInput(
            name=sc.name,
            description=sc.description,
            compliance_model=MODEL,
            braced=base.braced,
            duration=float(result.runs[0].t[-1]) if result.runs else 0.0,
            path=np.asarray(sc.operator.targets, dtype=float),
            runs=runs,
            gravity=sc.gravity,
            preloads=(float(sc.preload),) * count,
            meshes=meshes,
        )
    )
