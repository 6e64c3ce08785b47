"""Per-sample cost of the link clearance: today's capsules against coal on the URDF's meshes (the xArm7).

Run from a clone with the test extra (example-robot-data) installed::

    python benchmarks/bench_clearance.py

The xArm7 is braced at its forearm (link4, the pad on its surface at fraction 0.3, angle 90°) on a post under
the pad; the samples are configurations within ±`spread` rad of the start. Both geometries are timed in one
process, in turn (least of the rounds): ``Clearance.minimum`` (what each sample of a run records) and
``Clearance.links`` with gradients below the barrier's margin (what a gradient-projection step with the clearance
term asks). The capsules are what the same robot got before collision meshes were read (default capsules, the
braced link left out). Timings are the process's CPU time (less sensitive to the machine's load than wall time).
``bracekit bench`` (part "core") prints the same rows (:func:`add_to`).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import sys
import time
import timeit
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from bracekit.contact import Brace, Surface
from bracekit.geometry.pad import pad_on_surface
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance, geometry_of
from bracekit.model.robot import Robot
from bracekit.spatial import rotation_with_z

Q0 = np.array([0.0, 0.3, 0.0, 0.8, 0.0, 0.5, 0.0])


def _braced(robot: Robot, pad_robot: Robot) -> BracedRobot:
    pad = pad_on_surface(pad_robot, "link4", 0.3, 90.0)
    braced = robot.with_point_frame("brace", "link4", pad.point, rotation_with_z(pad.axis, "pad"))
    data = braced.model.createData()
    pin.framesForwardKinematics(braced.model, data, Q0)
    place = data.oMf[braced.frame_id("brace")]
    axis = np.array(place.rotation[:, 2])
    normal = axis + 0.05 * np.cross(axis, [0.0, 0.0, 1.0])
    surface = Surface(np.array(place.translation), normal)
    return BracedRobot(braced, Brace("brace", surface, region_radius=0.1, surface_radius=0.12))


def _xarm7() -> Robot | None:
    """The xArm7 with its STL meshes from example-robot-data, or None without the test extra."""
    try:
        share = Path(str(importlib.metadata.distribution("example-robot-data").locate_file("cmeel.prefix/share")))
    except importlib.metadata.PackageNotFoundError:
        return None
    urdf = share / "example-robot-data/robots/xarm_description/urdf/xarm7.urdf"
    return Robot.from_urdf(urdf, tip="link_eef", package_dirs=[share])


def clearance_benchmarks(quick: bool = False, spread: float = 0.02, samples: int = 20) -> dict[str, Any]:
    """µs per sample of both geometries (keys ``clearance_{capsules,meshes}_{minimum,links}_us``), or why skipped."""
    meshes = _xarm7()
    if meshes is None:
        return {"clearance_skipped": "example-robot-data not installed: pip install 'bracekit[test]'"}
    capsules = dataclasses.replace(meshes, geometry=(), collisions=())  # what it was before meshes were read
    rng = np.random.default_rng(2)
    qs = [Q0 + rng.uniform(-spread, spread, 7) for _ in range(samples)]
    rounds, repeat = (2, 3) if quick else (5, 7)
    clearances = {}
    out: dict[str, Any] = {}
    for name, robot in (("capsules", capsules), ("meshes", meshes)):
        braced = _braced(robot, meshes)
        clearances[name] = clearance = Clearance(braced)
        out[f"clearance_{name}_geometry"] = geometry_of(braced)
        out[f"clearance_{name}_least_m"] = min(clearance.minimum(q)[0] for q in qs)
    times: dict[str, list[float]] = {}
    for _ in range(repeat):  # the geometries in turn, so that a change of the machine's load hits both
        for name, c in clearances.items():
            times.setdefault(f"{name}_minimum", []).append(
                timeit.Timer(lambda c=c: [c.minimum(q) for q in qs], timer=time.process_time).timeit(rounds)
            )
            times.setdefault(f"{name}_links", []).append(
                timeit.Timer(lambda c=c: [c.links(q, True, 0.1) for q in qs], timer=time.process_time).timeit(rounds)
            )
    for key, values in times.items():
        out[f"clearance_{key}_us"] = min(values) * 1e6 / (rounds * samples)
    return out


def clearance_table(res: dict[str, Any]) -> str:
    """The rows of :func:`clearance_benchmarks`' result for ``bracekit bench``'s table."""
    if "clearance_skipped" in res:
        return f"link clearance per sample: skipped ({res['clearance_skipped']})"
    rows = [
        "| link clearance per sample (xArm7 on a post) | least value | µs | ∂/∂q below 0.1 m, µs |",
        "|---|---|---|---|",
    ]
    for name in ("capsules", "meshes"):
        rows.append(
            f"| {res[f'clearance_{name}_geometry']} | {res[f'clearance_{name}_least_m']:.4f} m "
            f"| {res[f'clearance_{name}_minimum_us']:.0f} | {res[f'clearance_{name}_links_us']:.0f} |"
        )
    return "\n".join(rows)


def add_to(results: dict[str, Any], quick: bool, parts: tuple[str, ...]) -> None:
    """With the part "core": the clearance per sample into `results` and its rows at the end of its table."""
    if "core" not in parts:
        return
    found = clearance_benchmarks(quick)
    results.update(found)
    results["table"] = "\n\n".join(t for t in (results.get("table", ""), clearance_table(found)) if t)


def main() -> None:
    """Print µs per sample for both geometries."""
    found = clearance_benchmarks()
    if "clearance_skipped" in found:
        sys.exit("install the test extra (example-robot-data) to run this benchmark")
    print(clearance_table(found))


if __name__ == "__main__":
    main()
