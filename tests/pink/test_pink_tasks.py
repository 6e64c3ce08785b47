"""bracekit.pink's tasks against central differences of their own errors and values, and pink's QP."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

pink = pytest.importorskip("pink")

from bracekit.kinematics import BracedRobot  # noqa: E402
from bracekit.pink import BraceTask, ComplianceTask  # noqa: E402


@pytest.mark.parametrize("which", ["panda", "two"])
def test_the_brace_task_jacobian_is_the_derivative_of_its_error(which: str, request: Any, config: Any, fd: Any) -> None:
    sc, q = request.getfixturevalue(which)
    rng = np.random.default_rng(0)
    q1 = q + rng.normal(scale=0.05, size=q.size)  # off the surface: a non-zero error
    task = BraceTask(sc.braced, config(sc, q))
    err = task.compute_error(config(sc, q1))
    assert err.shape == (len(sc.braced.braces),) and np.max(np.abs(err)) > 1e-4
    # the frictionless point's error is the signed distance of b_i from its plane
    dist = [
        b.surface.signed_distance(p) for b, p in zip(sc.braced.braces, sc.braced.state(q1).b_i, strict=True)
    ]
    assert np.allclose(err, dist, atol=1e-12)
    fd = fd(lambda x: task.compute_error(config(sc, x)), q1)
    assert np.max(np.abs(task.compute_jacobian(config(sc, q1)) - fd)) < 1e-7


@pytest.mark.parametrize("contact, rows", [("point_with_friction", 3), ("soft_finger", 4)])
def test_friction_contacts_hold_the_anchor_with_an_exact_jacobian(
    panda: Any, contact: str, rows: int, config: Any, fd: Any
) -> None:
    sc, q = panda
    braced = BracedRobot(sc.braced.robot, dataclasses.replace(sc.braced.brace, contact=contact))
    task = BraceTask(braced, config(sc, q))
    assert np.max(np.abs(task.compute_error(config(sc, q)))) < 1e-12  # anchored where it stands
    q1 = q + np.random.default_rng(1).normal(scale=0.05, size=q.size)
    err = task.compute_error(config(sc, q1))
    assert err.shape == (rows,) and np.max(np.abs(err)) > 1e-4
    fd = fd(lambda x: task.compute_error(config(sc, x)), q1)
    assert np.max(np.abs(task.compute_jacobian(config(sc, q1)) - fd)) < 1e-7


def test_the_compliance_task_gradient_is_the_derivative_of_c_i(panda: Any, config: Any, fd: Any) -> None:
    sc, q = panda
    task = ComplianceTask(sc.braced, sc.beta_x(0.0))
    fd = fd(lambda x: np.array([task.value(config(sc, x))]), q)
    jac = task.compute_jacobian(config(sc, q))
    assert np.max(np.abs(jac - fd)) < 1e-7 * max(1.0, np.max(np.abs(fd)))
    h, c = task.compute_qp_objective(config(sc, q))
    assert np.allclose(h, np.eye(q.size)) and np.allclose(c, jac[0])


def test_the_brace_task_is_a_hard_equality_in_solve_ik(panda: Any, config: Any) -> None:
    sc, q = panda
    config = config(sc, q)
    brace = BraceTask(sc.braced, config)
    tool = pink.tasks.FrameTask(sc.braced.robot.tip, position_cost=1.0, orientation_cost=0.0)
    target = config.get_transform_frame_to_world(sc.braced.robot.tip).copy()
    target.translation = target.translation + np.array([0.0, 0.0, 0.01])  # pull the tool 1 cm up
    tool.set_target(target)
    compliance = ComplianceTask(sc.braced, sc.beta_x(0.0), cost=5.0)
    dt = 0.002
    v = pink.solve_ik(config, [tool, compliance], dt, solver="daqp", constraints=[brace])
    jac, err = brace.compute_jacobian(config), brace.compute_error(config)
    assert np.max(np.abs(jac @ v * dt + err)) < 1e-12
    # without the constraint the same pull moves the brace off the post
    free = pink.solve_ik(config, [tool, compliance], dt, solver="daqp")
    assert np.max(np.abs(jac @ free * dt + err)) > 1e-6


def test_several_braces_give_one_row_each(two: Any, config: Any) -> None:
    sc, q = two
    task = ComplianceTask(sc.braced, [1.0, 0, 0, 0, 0, 0])
    c_i, grad = task.value(config(sc, q)), task.compute_jacobian(config(sc, q))
    assert c_i > 0 and grad.shape == (1, q.size)
