"""braced_qp on arms bracekit does not ship: the xArm7 planar guess and the iiwa-like forearm brace.

Both starts put a link inside the surface's solid, where the hard clearance rows (a link inside may not go
deeper) leave the QP without a solution as soon as the task drives that link down: the rows become soft and
the run goes on, saying so. References: minimum norm's path on the same task (its least link clearance), the
task and contact rows checked on the QP's own q̇, and the region radius written out here.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bracekit.errors import ClearanceWarning
from bracekit.resolution.qp import BracedQP, region_rows
from bracekit.simulation.run import run_scenario
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.scenario_model import STRATEGIES
from bracekit.simulation.start import solve_start
from geometry_refs import xarm_planar
from helpers import iiwa_like_urdf, iiwa_scenario_text

pytest.importorskip("qpsolvers")

CIRCLE = (
    'type = "circle"\ncentre = [0.66, 0.0, 0.50]\nradius = 0.04\nnormal = [0.0, 0.0, 1.0]\n'
    'start_direction = [1.0, 0.0, 0.0]\nperiod = 4.0\nspace = "{space}"\n'
)


def _iiwa(tmp_path: Path, space: str) -> Path:
    """The iiwa-like arm braced at its forearm, a 4 cm circle in `space`, every strategy."""
    (tmp_path / "iiwa.urdf").write_text(iiwa_like_urdf(), encoding="utf-8")
    text = iiwa_scenario_text(True)
    text = text[: text.index('type = "line"')] + CIRCLE.format(space=space) + text[text.index("[start]") :]
    names = ", ".join(f'"{s}"' for s in STRATEGIES)
    text = text.replace("dt = 0.05\n", f"dt = 0.05\nstrategies = [{names}]\n")
    path = tmp_path / "iiwa.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _run(path: Path) -> tuple[dict[str, Any], list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_scenario(path, both_models=False)
    return result.summary["strategies"], [str(w.message) for w in caught if issubclass(w.category, ClearanceWarning)]


def _check_every_strategy_completes(out: dict[str, Any]) -> None:
    assert set(out) == set(STRATEGIES)
    assert all(o["completed"] for o in out.values()), {k: o["failure"] for k, o in out.items()}
    qp = out["braced_qp"]
    assert qp["max_contact_violation_m"] < 1e-9 and qp["max_joint_limit_violation_rad"] == 0.0
    for o in out.values():  # a link starts inside the solid: no run may call itself valid
        assert o["min_link_clearance_m"] < 0.0 and o["valid"] is False


@pytest.mark.slow
def test_the_xarm7_planar_case_completes_with_every_strategy(tmp_path: Path) -> None:
    out, said = _run(xarm_planar(tmp_path, STRATEGIES))
    _check_every_strategy_completes(out)
    assert any("clearance rows are soft" in s for s in said)  # the fallback is said
    # gathered into one note of the run (its notes are warned too): the count of steps it was soft
    assert any(re.match(r"braced_qp: at \d+ evaluation\(s\) braced_qp: .*clearance rows are soft", s) for s in said)
    assert out["braced_qp"]["max_region_radius_m"] <= 0.05 + 1e-9  # the region row (minimum norm leaves it)
    assert out["braced_min_norm"]["max_region_radius_m"] > 0.05


@pytest.mark.parametrize("space", ["position", "position+axis"])
def test_the_iiwa_forearm_case_completes_with_every_strategy(tmp_path: Path, space: str) -> None:
    out, _ = _run(_iiwa(tmp_path, space))
    _check_every_strategy_completes(out)


def test_a_soft_step_keeps_the_equalities_and_takes_the_link_out_no_slower_than_the_hard_rows_allow(
    tmp_path: Path,
) -> None:
    """At the iiwa's start (link 3 inside the table), with the task driving it deeper, the hard QP has no
    solution; the soft step keeps every contact and task row (written out here) and the limits."""
    sc = load_scenario(_iiwa(tmp_path, "position"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, space=sc.task_space)
    st = sc.braced.state(start.q)
    qp = BracedQP(None, dt=0.05, space=sc.task_space)
    xdot = np.array([0.0, 0.0, -0.3, 0.0, 0.0, 0.0])  # straight down: link 3 goes deeper with the tip
    with pytest.warns(ClearanceWarning, match="soft"):
        qdot = qp.velocity(st, xdot)
    g = np.vstack([x.T @ c.J_b for x, c in zip(st.X_i, st.contacts, strict=True)])
    assert np.max(np.abs(g @ qdot + 0.5 / 0.05 * _plane_offsets(st))) < 1e-9
    np.testing.assert_allclose(st.J_e[:3] @ qdot, xdot[:3], atol=1e-9)
    vmax = np.asarray(sc.robot.model.velocityLimit)
    assert np.all(np.abs(qdot) <= vmax + 1e-9)


def _plane_offsets(st: Any) -> np.ndarray:
    out = []
    for brace, b in zip(st.braced.braces, st.b_i, strict=True):
        n = brace.surface.normal
        rho = np.concatenate([n * float(n @ (b - brace.surface.point)), np.zeros(3)])
        out.append(brace.X().T @ rho)
    return np.concatenate(out)


def test_the_region_row_is_the_rate_of_the_in_plane_radius(tmp_path: Path) -> None:
    """∂r/∂q q̇ of the region row against a central difference of r = ‖(I − n̂n̂ᵀ)(b − p)‖ written out here."""
    sc = load_scenario(_iiwa(tmp_path, "position"))
    brace = sc.braced.braces[0]
    n = brace.surface.normal

    def radius(q: np.ndarray) -> float:
        off = sc.braced.state(q).b_i[0] - brace.surface.point
        return float(np.linalg.norm(off - n * float(n @ off)))

    rng = np.random.default_rng(2)
    q = np.asarray(sc.guess, dtype=float)
    for _ in range(50):  # a configuration with b beyond half the region's radius
        trial = np.asarray(sc.guess, dtype=float) + 0.2 * rng.standard_normal(sc.robot.n)
        if 0.5 * brace.region_radius < radius(trial) < brace.region_radius:
            q = trial
            break
    assert radius(q) > 0.5 * brace.region_radius
    rows = region_rows(sc.braced.state(q), 10.0)
    assert rows is not None and rows.M.shape == (1, sc.robot.n)
    qdot = rng.standard_normal(sc.robot.n)
    h = 1e-6
    fd = (radius(q + h * qdot) - radius(q - h * qdot)) / (2 * h)
    assert rows.M[0] @ qdot == pytest.approx(fd, rel=1e-6, abs=1e-9)
    assert rows.v[0] == pytest.approx(10.0 * (brace.region_radius - radius(q)), rel=1e-12)


def test_the_region_rows_of_two_braces_are_the_rates_of_their_radii() -> None:
    """Two braces: a row for each brace beyond half its region's radius, each against a central difference."""
    sc = load_scenario("two-braces")
    braces = sc.braced.braces

    def radii(q: np.ndarray) -> list[float]:
        out = []
        for brace, b in zip(braces, sc.braced.state(q).b_i, strict=True):
            n = brace.surface.normal
            off = b - brace.surface.point
            out.append(float(np.linalg.norm(off - n * float(n @ off))))
        return out

    rng = np.random.default_rng(7)
    seen = set()
    for _ in range(400):
        q = np.asarray(sc.guess, dtype=float) + 0.3 * rng.standard_normal(sc.robot.n)
        r = radii(q)
        far = [i for i, (ri, b) in enumerate(zip(r, braces, strict=True)) if ri > 0.5 * b.region_radius]
        rows = region_rows(sc.braced.state(q), 10.0)
        assert (rows is None) == (not far)
        if rows is None:
            continue
        assert rows.M.shape == (len(far), sc.robot.n)
        qdot = rng.standard_normal(sc.robot.n)
        h = 1e-6
        fd = (np.array(radii(q + h * qdot)) - np.array(radii(q - h * qdot))) / (2 * h)
        np.testing.assert_allclose(rows.M @ qdot, fd[far], rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(rows.v, [10.0 * (braces[i].region_radius - r[i]) for i in far], rtol=1e-12)
        seen.update(far)
        if seen == {0, 1}:
            break
    assert seen == {0, 1}


def test_the_soft_step_of_two_braces_is_the_soft_qp_solved_by_scipy() -> None:
    """Two braces, where braced minimum norm has taken link 8 inside braces[0]'s solid: the soft step (every
    clearance row soft) against the same QP in [q̇; s] solved by SciPy's SLSQP from the rows written here."""
    import dataclasses

    from scipy.optimize import minimize

    from bracekit.resolution.qp import SOFT_CLEARANCE_WEIGHT, clearance_rows

    sc = load_scenario("two-braces")
    short = dataclasses.replace(sc, strategies=["braced_min_norm"], task=dataclasses.replace(sc.task, turns=0.3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = run_scenario(short, both_models=False).trajectories["constrained"]["braced_min_norm"]
    q = run.q[int(np.argmin(run.measures["link_clearance"]))]
    qp = BracedQP(None, dt=0.05, space=sc.task_space)
    rows = clearance_rows(sc.braced, q, 0.05)
    assert min(r.clearance for r in rows) < -0.01  # a link inside
    st = sc.braced.state(q)
    xdot = np.concatenate([sc.task.velocity(0.0), np.zeros(3)])
    sets = qp.constraint_sets(st, xdot)
    n, m = q.size, len(rows)
    with pytest.warns(ClearanceWarning, match="soft"):
        qdot = qp._soften(st, sets, np.eye(n), np.zeros(n))
    assert qdot is not None
    g = np.vstack([x.T @ c.J_b for x, c in zip(st.X_i, st.contacts, strict=True)])
    s_j = sc.task_space.selection(st.R_e) @ st.J_e
    grad = np.array([r.gradient for r in rows])
    target = np.array([0.5 * (0.002 - r.clearance) / 0.05 for r in rows])
    vmax = np.asarray(sc.robot.model.velocityLimit)
    upper = np.minimum(vmax, 0.5 * (sc.robot.upper - q) / 0.05)
    lower = np.maximum(-vmax, 0.5 * (sc.robot.lower - q) / 0.05)
    offsets = _plane_offsets(st)

    def cost(x: np.ndarray) -> float:
        return 0.5 * float(x[:n] @ x[:n]) + 0.5 * SOFT_CLEARANCE_WEIGHT * float(x[n:] @ x[n:])

    cons = [
        {"type": "eq", "fun": lambda x: g @ x[:n] + 0.5 / 0.05 * offsets},
        {"type": "eq", "fun": lambda x: s_j @ x[:n] - sc.task_space.selection(st.R_e) @ xdot},
        {"type": "ineq", "fun": lambda x: grad @ x[:n] + x[n:] - target},
    ]
    bounds = list(zip(lower, upper, strict=True)) + [(0.0, None)] * m
    ref = minimize(cost, np.zeros(n + m), constraints=cons, bounds=bounds, method="SLSQP", options={"ftol": 1e-14})
    assert ref.success
    regions = region_rows(st, 0.5 / 0.05)  # left out of the reference: it must not bind there
    assert regions is None or np.all(regions.M @ ref.x[:n] < regions.v - 1e-6)
    np.testing.assert_allclose(qdot, ref.x[:n], atol=1e-5 * max(1.0, float(np.max(np.abs(ref.x[:n])))))
