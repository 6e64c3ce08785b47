"""Directional readings of a tip compliance: C_i (the paper's mixed-unit index), c_t and β_xᵀCβ_w.

References: the definitions written out here on random symmetric compliances, and a static probe on the
paper's robot (the nonlinear static solve's deflection along β per newton along β is c_t, not C_i).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bracekit.compliance.directional import (
    directional_compliances,
    translational_compliance,
    translational_direction,
)
from bracekit.compliance.first_order import end_effector_compliance
from bracekit.errors import InputError
from bracekit.simulation import load_scenario, solve_start
from bracekit.validate.plane_contact import PlaneContact
from bracekit.validate.statics import solve_static_equilibrium


def random_compliance(seed: int) -> np.ndarray:
    a = np.random.default_rng(seed).normal(size=(6, 6))
    return a @ a.T


@pytest.mark.parametrize("seed", range(5))
def test_readings_match_their_definitions(seed: int) -> None:
    c = random_compliance(seed)
    rng = np.random.default_rng(100 + seed)
    beta, w = rng.normal(size=3), rng.normal(size=6)
    b = beta / np.linalg.norm(beta)
    r = directional_compliances(c, np.concatenate([2 * beta, np.zeros(3)]), w)
    assert r.c_t == pytest.approx(b @ c[:3, :3] @ b, rel=1e-13)
    assert r.Ci == pytest.approx(np.linalg.norm(np.concatenate([b, np.zeros(3)]) @ c), rel=1e-13)
    assert r.c_w == pytest.approx(np.concatenate([b, np.zeros(3)]) @ c @ (w / np.linalg.norm(w)), rel=1e-13)
    assert translational_compliance(c, beta) == pytest.approx(r.c_t, rel=1e-14)
    assert r.c_t <= r.Ci


def test_a_rotational_direction_has_no_c_t() -> None:
    c = random_compliance(9)
    r = directional_compliances(c, [1.0, 0, 0, 0, 1.0, 0])
    assert r.c_t is None and r.c_w is None
    with pytest.raises(InputError, match="translational"):
        translational_compliance(c, [1.0, 0, 0, 0, 1.0, 0])
    with pytest.raises(InputError):
        translational_direction([0.0, 0.0, 0.0])


def test_c_t_is_what_a_static_probe_measures_on_the_paper_robot() -> None:
    sc = load_scenario("paper")
    braced = sc.braced
    q = solve_start(braced, sc.task.position(0.0), sc.guess).q
    robot, surface = braced.robot, braced.brace.surface
    c = end_effector_compliance(braced.state(q))
    beta = np.array([0.0, 0.0, 1.0])
    h = 1e-2  # N along β, both ways
    defl = [
        solve_static_equilibrium(
            robot.model,
            q,
            robot.stiffness,
            braced.brace_id,
            robot.tip_id,
            surface.point,
            surface.normal,
            np.concatenate([s * h * beta, np.zeros(3)]),
            constraint_wrenches=braced.split.X,
        ).deflection
        for s in (1.0, -1.0)
    ]
    probe = float(beta @ (defl[0] - defl[1])[:3]) / (2 * h)
    r = directional_compliances(c, np.concatenate([beta, np.zeros(3)]))
    assert r.c_t == pytest.approx(probe, rel=1e-6)
    assert abs(r.Ci - probe) > 1e-3 * probe  # the index is not the probe's number


def _scenario(name: str, tmp_path: Path) -> Any:
    """A shipped scenario, or "xarm7-post": the xArm7 of example-robot-data (its STL meshes) braced on a post."""
    if name != "xarm7-post":
        return load_scenario(name)
    from xarm_post import xarm_post_text

    path = tmp_path / "xarm7-post.toml"
    path.write_text(xarm_post_text(), encoding="utf-8")
    return load_scenario(str(path))


@pytest.mark.parametrize("scenario", ["paper", "panda", "xarm7-post"])
def test_c_t_is_what_mujoco_measures_along_beta_x(scenario: str, tmp_path: Path) -> None:
    """MuJoCo's settled tool deflection along β per newton pushed along β (central differences, ±0.1 N) is c_t:
    the first-order c_t to 1 %, the preloaded one (the preload's geometric stiffness) to 0.1 %; C_i is not."""
    mujoco_check = pytest.importorskip("bracekit.validate.mujoco_check")
    from bracekit.compliance import preloaded_compliance

    sc = _scenario(scenario, tmp_path)
    braced = sc.braced
    q = solve_start(braced, sc.task.position(0.0), sc.guess).q
    robot, surface = braced.robot, braced.brace.surface
    beta6 = sc.beta_x(0.0)
    beta = beta6[:3] / np.linalg.norm(beta6[:3])
    force, preload = 0.1, 5.0
    along = []
    for sign in (1.0, -1.0):
        res = mujoco_check.mujoco_static_deflection(
            robot.model,
            q,
            robot.stiffness,
            robot.tip_id,
            [PlaneContact(braced.split.brace_id, surface.point, surface.normal, preload=preload)],
            np.concatenate([sign * force * beta, np.zeros(3)]),
        )
        assert res.converged and not res.contact_opened
        along.append(float(beta @ res.deflection[:3]))
    measured = (along[0] - along[1]) / (2 * force)
    first = directional_compliances(end_effector_compliance(braced.state(q)), beta6)
    loaded = directional_compliances(preloaded_compliance(braced, q, preload), beta6)
    assert first.c_t == pytest.approx(measured, rel=1e-2)
    assert loaded.c_t == pytest.approx(measured, rel=1e-3)
    assert abs(first.Ci - measured) > 0.5 * measured  # the index is several times the measured compliance
