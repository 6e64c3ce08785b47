"""The xArm7 of example-robot-data braced at its forearm on a post: the scenario the viewer and figure tests run.

The same arm, post and task as docs/tutorial-xarm7.md, with the URDF and its meshes found through
`package_dirs` (the test extra's share folder) and a short task.
"""

from __future__ import annotations

from geometry_refs import xarm_share

XARM_POST = """
name = "xarm7-post"
description = "The UFactory xArm7 braced at its forearm on a post"
[robot]
urdf = "{urdf}"
package_dirs = ["{share}"]
tip = "link_eef"
[brace]
link = "link4"
surface = {{ fraction = 0.5, angle = 225.0 }}
point = [0.3, 0.0, 0.47]
normal = [0.0, 0.0, 1.0]
region_radius = 0.05
surface_radius = 0.05
[task]
type = "circle"
centre = [0.47, 0.0, 0.28]
radius = 0.03
normal = [0.0, 0.0, 1.0]
start_direction = [1.0, 0.0, 0.0]
period = 2.0
space = "position"
[simulation]
dt = 0.1
[start]
guess = [0.0, 0.3, 0.0, 1.27, 0.0, 1.57, 0.0]
"""


def xarm_post_text() -> str:
    """The scenario's TOML text (skips the test when example-robot-data is not installed)."""
    share = xarm_share()
    urdf = share / "example-robot-data/robots/xarm_description/urdf/xarm7.urdf"
    return XARM_POST.format(urdf=urdf, share=share)
