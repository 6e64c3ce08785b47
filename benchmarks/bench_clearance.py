"""Per-sample cost of the link clearance: today's capsules against coal on the URDF's meshes (the xArm7).

Run from a clone with the test extra (example-robot-data) installed::

    python benchmarks/bench_clearance.py

The xArm7 is braced at its forearm (link4, the pad on its surface at fraction 0.3, angle 90°) on a post under
the pad; the samples are configurations within ±`spread` rad of the start, where every link is clear. Both
geometries are timed side by side in one process (best of five rounds): ``Clearance.minimum`` (what each sample
of a run records) and ``Clearance.links`` with gradients below the barrier's margin (what a gradient-projection
step with the clearance term asks). The capsules are what the same robot got before collision meshes were read
(default capsules, the braced link left out). Timings depend on the machine and its load.
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import sys
import timeit
from pathlib import Path

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


def main(spread: float = 0.02, samples: int = 20) -> None:
    """Print µs per sample for both geometries."""
    try:
        share = Path(str(importlib.metadata.distribution("example-robot-data").locate_file("cmeel.prefix/share")))
    except importlib.metadata.PackageNotFoundError:
        sys.exit("install the test extra (example-robot-data) to run this benchmark")
    urdf = share / "example-robot-data/robots/xarm_description/urdf/xarm7.urdf"
    meshes = Robot.from_urdf(urdf, tip="link_eef", package_dirs=[share])
    capsules = dataclasses.replace(meshes, geometry=(), collisions=())  # what it was before meshes were read
    rng = np.random.default_rng(2)
    qs = [Q0 + rng.uniform(-spread, spread, 7) for _ in range(samples)]
    for robot in (capsules, meshes):
        braced = _braced(robot, meshes)
        clearance = Clearance(braced)
        best = min(clearance.minimum(q)[0] for q in qs)
        rounds = 5
        minimum = min(timeit.repeat(lambda c=clearance: [c.minimum(q) for q in qs], number=rounds, repeat=5))
        links = min(timeit.repeat(lambda c=clearance: [c.links(q, True, 0.1) for q in qs], number=rounds, repeat=5))
        per = 1e6 / (rounds * samples)
        print(
            f"{geometry_of(braced)}: minimum {minimum * per:.0f} µs/sample, links with ∂/∂q below 0.1 m "
            f"{links * per:.0f} µs/sample (least clearance over the samples {best:.4f} m)"
        )


if __name__ == "__main__":
    main()
