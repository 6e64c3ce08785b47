"""How close the mesh clearance is to the STL meshes themselves (the table "How well" of docs/geometry.md).

Run from a clone with the test extra (example-robot-data) installed::

    python benchmarks/bench_clearance_accuracy.py

The xArm7 braced at its forearm on a post of radius 0.12 m under the pad (the setup of bench_clearance.py), 60
configurations within ±0.25 rad of the start; every link within 0.1 m of the post (the braced link without its
pad's ball). Each link's clearance minus two brute-force references, the signed distance from the post's solid
of (a) the STL vertices and (b) the STL surface sampled 2 mm apart, in mm, over the links clear of the post and
over those inside it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "tests")]

from bench_clearance import Q0, _braced, _xarm7  # noqa: E402

from bracekit.kinematics.clearance import Clearance  # noqa: E402
from geometry_refs import read_stl, solid_distance, surface_points  # noqa: E402

#: The post's radius (m) in bench_clearance's setup.
POST = 0.12


def main(seed: int = 0) -> None:
    """Print the ranges of clearance − reference (mm) for the links clear of the post and inside it."""
    robot = _xarm7()
    if robot is None:
        sys.exit("install the test extra (example-robot-data) to run this benchmark")
    braced = _braced(robot, robot)
    clearance = Clearance(braced)
    surface = braced.brace.surface
    meshes = {e.link: read_stl(e.source) for e in robot.geometry if e.joint > 0}
    references = {link: (tri.reshape(-1, 3), surface_points(tri, 0.002)) for link, tri in meshes.items()}
    rng = np.random.default_rng(seed)
    data = braced.robot.model.createData()
    rows: dict[str, list[tuple[float, float]]] = {"clear of the post": [], "inside the post": []}
    for q in [Q0 + rng.uniform(-0.25, 0.25, 7) for _ in range(60)]:
        pin.framesForwardKinematics(braced.robot.model, data, q)
        pad = np.array(data.oMf[braced.brace_id].translation)
        found = {d.joint: d.clearance for d in clearance.links(q, gradient=False, below=0.1)}
        for link, refs in references.items():
            joint = braced.robot.frame_joint(link)
            if joint not in found:
                continue
            place = data.oMf[braced.robot.frame_id(link)]
            values = []
            for points in refs:
                world = points @ np.array(place.rotation).T + np.array(place.translation)
                if link == "link4":
                    world = world[np.linalg.norm(world - pad, axis=1) >= braced.brace.pad_radius]
                values.append(float(solid_distance(world, surface.point, surface.normal, POST).min()))
            key = "inside the post" if found[joint] < 0.0 else "clear of the post"
            rows[key].append((found[joint] - values[0], found[joint] - values[1]))
    print("| links | samples | clearance − STL vertices, mm | clearance − STL surface (2 mm), mm |")
    print("|---|---|---|---|")
    for key, found_rows in rows.items():
        d = 1e3 * np.array(found_rows).reshape(-1, 2)
        ranges = [f"{d[:, i].min():+.1f} … {d[:, i].max():+.1f}" for i in (0, 1)]
        print(f"| {key} | {len(d)} | {ranges[0]} | {ranges[1]} |")


if __name__ == "__main__":
    main()
