"""`bracekit run two-braces` with every feature switched on: analytic gradients, the preloaded model, and the k,
clearance, brace-margin and joint-limit-barrier terms, through the one step loop."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from bracekit.objective import BraceMargin
from bracekit.simulation.run import run_scenario
from bracekit.simulation.scenario import load_scenario, shipped_scenarios
from helpers import pin_frame_placement

EXTRA = """
[loads]
wrenches = [[0.0, 0.0, -2.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0, 0.0, 0.0]]
"""


def every_feature_toml(tmp_path: Path, turns: float = 0.1) -> Path:
    """The shipped two-braces scenario with the preloaded model, gravity, P_i and μ_i, loads and every weight.

    The wall pad sits 5 cm from link 9's joint, where no link capsule touches the wall (clearance > 0).
    """
    text = shipped_scenarios()["two-braces"].read_text(encoding="utf-8")
    text = text.replace('model = "constrained"', 'model = "preloaded"')
    text = text.replace("stiffness = 170.0", "stiffness = 170.0\ngravity = true")
    text = text.replace("region_radius = 0.15", "region_radius = 0.15\npreload = 5.0\nfriction = 0.6")
    text = text.replace("region_radius = 0.20", "region_radius = 0.20\npreload = 3.0\nfriction = 0.5")
    text = re.sub(
        r"(?m)^weights = .*$",
        "weights = { Ci = 100.0, d = 0.2, k = 0.05, clearance = 0.001, brace_margin = 0.001, "
        "joint_limit_barrier = 0.01 }",
        text,
    )
    text = text.replace("turns = 1.0", f"turns = {turns}")
    # the wall pad 5 cm along link 9's −x: at its joint's origin, link 8's capsule would touch the wall there too
    text = text.replace("offset = [0.0, 0.0, 0.0]", "offset = [-0.05, 0.0, 0.0]")
    path = tmp_path / "every-feature.toml"
    path.write_text(text + EXTRA, encoding="utf-8")
    return path


def test_two_braces_run_every_feature_and_keep_every_contact(tmp_path: Path) -> None:
    sc = load_scenario(every_feature_toml(tmp_path))
    assert sc.gradient == "analytic" and sc.compliance_model == "preloaded"
    objective = sc.objective()
    names = set(objective.names)
    assert {"k", "Ci", "d_0", "d_1", "clearance_0", "clearance_1", "brace_margin", "joint_limit_barrier"} <= names
    margin = next(t for t in objective.terms if isinstance(t, BraceMargin))
    assert margin.preload == (5.0, 3.0) and margin.friction == (0.6, 0.5)  # each brace its own P_i, μ_i
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_scenario(sc)
    gp = result.trajectories["preloaded"]["braced_gradient_projection"]
    assert gp.completed, gp.failure
    assert not any("left out" in w for w in gp.warnings)  # no term is dropped with several braces
    summary = result.summary["strategies"]["braced_gradient_projection"]
    assert summary["Ci_mean"] is not None and np.isfinite(gp.measures["Ci_preloaded"]).all()
    assert "liftoff_margin_0" in gp.measures and "liftoff_margin_1" in gp.measures
    # independent: Pinocchio's placement of every {b_i} stays on its plane along the run
    model = sc.robot.model
    for q in gp.q[:: max(1, len(gp.q) // 5)]:
        for brace in sc.braced.braces:
            b = pin_frame_placement(model, brace.frame, q).translation
            assert abs(brace.surface.normal @ (b - brace.surface.point)) < 1e-9


def test_the_whole_two_brace_circle_with_every_feature_completes(tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_scenario(every_feature_toml(tmp_path, turns=1.0))
    assert all(tr.completed for tr in result.trajectories["preloaded"].values())
