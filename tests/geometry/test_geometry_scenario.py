"""Tests of the ``[brace]`` keys that place a pad on a link's surface, read from a scenario file.

References: the same pads computed directly (bracekit.geometry.pad, tested against the STL triangles).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from bracekit.errors import PadPlacementWarning, ScenarioError
from bracekit.geometry.pad import pad_on_surface
from bracekit.simulation.scenario import load_scenario
from geometry_refs import xarm7, xarm_share

SCENARIO = """
name = "xarm7"
[robot]
urdf = "{urdf}"
package_dirs = ["{share}"]
tip = "link_eef"
[brace]
link = "link4"
{brace}
point = [0.3, 0.0, 0.3]
normal = [0.0, 0.0, 1.0]
region_radius = 0.1
surface_radius = 0.12
[task]
type = "circle"
centre = [0.4, 0.2, 0.5]
radius = 0.03
normal = [0.0, 0.0, 1.0]
start_direction = [1.0, 0.0, 0.0]
period = 10.0
space = "position"
[start]
guess = [0.0, 0.3, 0.0, 0.8, 0.0, 0.5, 0.0]
[gradient_projection]
weights = {{ k = 0.0, Ci = 0.0, theta_z = 0.0, d = 0.0 }}
"""


def _write(tmp_path: Path, brace: str) -> Path:
    share = xarm_share()
    urdf = share / "example-robot-data/robots/xarm_description/urdf/xarm7.urdf"
    path = tmp_path / "xarm7.toml"
    path.write_text(SCENARIO.format(urdf=urdf, share=share, brace=brace), encoding="utf-8")
    return path


def _brace_frame(scenario) -> pin.SE3:
    robot = scenario.braced.robot
    return robot.model.frames[robot.frame_id("brace")].placement


def test_surface_places_the_pad_and_its_axis(tmp_path: Path) -> None:
    scenario = load_scenario(_write(tmp_path, "surface = { fraction = 0.3, angle = 90.0 }\npad_radius = 0.015"))
    pad = pad_on_surface(xarm7(), "link4", 0.3, 90.0)
    frame = _brace_frame(scenario)
    np.testing.assert_allclose(frame.translation, pad.point, atol=1e-12)  # link4's frame is its joint's
    np.testing.assert_allclose(frame.rotation[:, 2], pad.axis, atol=1e-12)
    assert scenario.braced.brace.pad_axis and scenario.braced.brace.pad_radius == 0.015


def test_an_offset_snapped_inside_the_link_warns_with_its_depth(tmp_path: Path) -> None:
    pad = pad_on_surface(xarm7(), "link4", 0.3, 90.0)
    inside = (pad.point + 0.01 * pad.axis).tolist()
    text = f"offset = {inside}\nsnap = {(-pad.axis).tolist()}"
    with pytest.warns(PadPlacementWarning, match=r"0\.0100 m inside"):
        scenario = load_scenario(_write(tmp_path, text))
    np.testing.assert_allclose(_brace_frame(scenario).translation, pad.point, atol=1e-9)
    with pytest.warns(PadPlacementWarning, match=r"inside the collision geometry of link 'link4'; place the pad"):
        load_scenario(_write(tmp_path, f"offset = {inside}"))  # a bare offset is kept, with the warning


@pytest.mark.parametrize(
    ("brace", "message"),
    [
        ("surface = { fraction = 0.3, side = 2 }", "brace.surface.*must be a table"),
        ("surface = { fraction = 0.3 }\noffset = [0.0, 0.0, 0.0]", "brace.surface.*not both"),
        ("snap = [0.0, 0.0, 1.0]", "snap needs the offset"),
        ("surface = { fraction = 0.9, angle = 90.0 }", "brace.surface.*spans the fractions"),
        ("surface = { fraction = 0.3 }\npad_radius = -1.0", "brace.pad_radius"),
    ],
)
def test_bad_surface_keys_are_one_scenario_error(tmp_path: Path, brace: str, message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        load_scenario(_write(tmp_path, brace))
