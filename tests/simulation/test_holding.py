"""Statics along a run: scenario keys, per-sample torques and margins, summary, warnings and Table I checks."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import bracekit as bk
from bracekit.errors import HoldingWarning, InputError, ScenarioError
from bracekit.report.table import table_markdown
from bracekit.simulation.holding import Holding, holding_measures, holds
from bracekit.statics import load_capacity
from helpers import scenario_text

LOADS = "\n[loads]\nwrenches = [[0.0, 0.0, -10.0, 0.0, 0.0, 0.0], [5.0, 0.0, 0.0, 0.0, 0.0, 0.5]]\n"


def _holding_text(gravity: bool = True, preload: float = 20.0, friction: float | None = 0.5, loads: str = LOADS) -> str:
    text = scenario_text(turns=0.05, dt=0.1)
    text = re.sub(r"(?m)^stiffness = .*$", f"stiffness = 170.0\ngravity = {str(gravity).lower()}", text, count=1)
    extra = f"preload = {preload}" + (f"\nfriction = {friction}" if friction is not None else "")
    text = re.sub(r"(?m)^region_radius = .*$", f"region_radius = 0.15\n{extra}", text, count=1)
    return text + loads


def _scenario(tmp_path: Path, text: str) -> bk.Scenario:
    path = tmp_path / "hold.toml"
    path.write_text(text, encoding="utf-8")
    return bk.load_scenario(path)


def test_scenario_keys_give_the_holding_and_the_paper_has_none(tmp_path: Path) -> None:
    sc = _scenario(tmp_path, _holding_text())
    h = sc.holding
    assert h.gravity and h.preload == 20.0 and h.friction == 0.5 and h.active
    assert np.array_equal(h.wrenches, [[0, 0, -10, 0, 0, 0], [5, 0, 0, 0, 0, 0.5]])
    assert not bk.load_scenario("paper").holding.active


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        ("gravity = true", "gravity = 1", "robot.gravity"),
        ("preload = 20.0", "preload = -1.0", "brace.preload"),
        ("friction = 0.5", "friction = -0.1", "brace.friction"),
        ("[5.0, 0.0, 0.0, 0.0, 0.0, 0.5]", "[5.0, 0.0]", "loads.wrenches"),
        ("wrenches =", "forces =", "forces"),
    ],
)
def test_bad_holding_keys_are_refused_naming_the_key(tmp_path: Path, old: str, new: str, match: str) -> None:
    text = _holding_text()
    assert old in text
    with pytest.raises(ScenarioError, match=match):
        _scenario(tmp_path, text.replace(old, new))


def test_holding_refuses_bad_values() -> None:
    with pytest.raises(InputError):
        Holding(preload=-1.0)
    with pytest.raises(InputError):
        Holding(wrenches=np.zeros((2, 5)))
    with pytest.raises(InputError):
        Holding(gravity="yes")  # type: ignore[arg-type]


def test_free_space_torques_match_pinocchio_rnea_with_the_tool_wrench_as_external_force(tmp_path: Path) -> None:
    sc = _scenario(tmp_path, _holding_text())
    robot, braced = sc.robot, sc.braced
    rng = np.random.default_rng(3)
    qs = sc.guess + rng.normal(scale=0.2, size=(4, robot.n))
    got = holding_measures(braced, qs, sc.holding, is_braced=False)
    model, data = robot.model, robot.model.createData()
    effort = np.asarray(model.effortLimit)
    tip = model.frames[robot.tip_id]
    for k, q in enumerate(qs):
        pin.framesForwardKinematics(model, data, q)
        ratios = []
        for w in sc.holding.wrenches:
            # the tool wrench (world axes, at the tip point) as a spatial force in the tip joint's frame
            oMj = data.oMi[tip.parentJoint]
            f_world_at_tip = pin.Force(w[:3], w[3:])
            at_origin = pin.SE3(np.eye(3), data.oMf[robot.tip_id].translation).act(f_world_at_tip)
            fext = [pin.Force.Zero() for _ in range(model.njoints)]
            fext[tip.parentJoint] = oMj.actInv(at_origin)
            tau = pin.rnea(model, data, q, np.zeros(robot.n), np.zeros(robot.n), fext)
            ratios.append(np.max(np.abs(tau) / effort))
        g = pin.computeGeneralizedGravity(model, data, q)
        assert got["torque_ratio"][k] == pytest.approx(np.max(np.abs(g) / effort), rel=1e-9)
        assert got["torque_ratio_loaded"][k] == pytest.approx(max(ratios), rel=1e-9)


def test_braced_measures_are_the_capacity_at_each_sample(tmp_path: Path) -> None:
    sc = _scenario(tmp_path, _holding_text())
    h = sc.holding
    st = bk.solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
    qs = np.vstack([st.q, st.q])
    got = holding_measures(sc.braced, qs, h, is_braced=True)
    one = load_capacity(sc.braced, st.q, h.wrenches, preload=h.preload, gravity=h.gravity, friction=h.friction)
    # the run's statics (the stacked response of every brace, here one) against the one-brace load capacity
    assert got["liftoff_margin"][0] == pytest.approx(one.liftoff_margin, rel=1e-12)
    assert got["slip_margin"][0] == pytest.approx(one.slip_margin, rel=1e-12)
    assert got["torque_margin"][0] == pytest.approx(one.torque_margin, rel=1e-12)
    assert got["torque_ratio"][0] == pytest.approx(one.peak_unloaded, rel=1e-12)
    forces = np.linalg.norm(one.contact_wrench[:, :3], axis=1)
    assert got["contact_force_N"][0] == pytest.approx(max(h.preload, float(np.max(forces))))


def test_a_run_reports_statics_in_summary_table_and_warns_when_the_brace_slips(tmp_path: Path) -> None:
    heavy = "\n[loads]\nwrenches = [[40.0, 0.0, 0.0, 0.0, 0.0, 0.0]]\n"  # a lateral push the friction cannot hold
    sc = _scenario(tmp_path, _holding_text(preload=5.0, loads=heavy))
    with pytest.warns(HoldingWarning, match="slips"):
        result = bk.run_scenario(sc, both_models=False)
    s = result.summary["strategies"]
    braced = s["braced_min_norm"]
    assert braced["holds"] is False and braced["min_slip_margin"] < 1.0
    assert braced["max_contact_force_N"] >= 5.0 and braced["max_torque_ratio"] > 0.0
    assert s["free_space_min_norm"]["min_liftoff_margin"] is None  # no contact in free space
    assert s["free_space_min_norm"]["max_torque_ratio"] > 0.0
    relief = braced["actuator_relief"]
    assert relief["best_braced_peak_torque_ratio"] <= relief["free_peak_torque_ratio"] + 1e-12
    assert any("slips" in w for w in result.summary["warnings"])
    md = table_markdown(result.summaries, sc.name)
    assert "min slip margin" in md and "max τ/effort" in md


def test_preloaded_ci_is_the_preloaded_compliance_along_beta(tmp_path: Path) -> None:
    sc = _scenario(tmp_path, _holding_text())
    st = bk.solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
    beta = np.array([sc.beta_x(0.0)])
    got = holding_measures(sc.braced, st.q[None, :], sc.holding, True, beta)["Ci_preloaded"][0]
    c = bk.preloaded_compliance(sc.braced, st.q, 20.0, gravity=True)
    assert got == pytest.approx(bk.compliance_index(c, beta[0]), rel=1e-12)
    assert got != pytest.approx(bk.compliance_index(bk.end_effector_compliance(st), beta[0]), rel=1e-3)
    none = holding_measures(sc.braced, st.q[None, :], Holding(friction=0.5), True, beta)
    assert "Ci_preloaded" not in none  # no preload, no gravity: the first-order models are exact


def test_holds_needs_every_margin_at_least_one() -> None:
    ok = {"torque_ratio": np.array([0.5]), "torque_margin": np.array([2.0]), "liftoff_margin": np.array([np.inf])}
    assert holds(ok) is True
    assert holds({**ok, "liftoff_margin": np.array([0.9])}) is False
    assert holds({**ok, "torque_ratio": np.array([1.2])}) is False
    assert holds({}) is None


def test_the_preloaded_model_reports_the_preloaded_ci_along_the_constrained_runs(tmp_path: Path) -> None:
    text = _holding_text(loads="").replace('model = "constrained"', 'model = "preloaded"', 1)
    sc = _scenario(tmp_path, text)
    assert sc.compliance_model == "preloaded"
    result = bk.run_scenario(sc, both_models=False)
    assert result.summary["compliance_model"] == "preloaded"
    runs = result.trajectories["preloaded"]
    assert runs is result.trajectories["constrained"]  # the same runs; C_i from the statics' series
    for name, s in result.summary["strategies"].items():
        assert s["Ci_mean"] == pytest.approx(float(np.mean(runs[name].measures["Ci_preloaded"])))
        assert s["Ci_mean"] != pytest.approx(result.summaries["constrained"]["strategies"][name]["Ci_mean"], rel=1e-4)


def test_the_preloaded_model_needs_gravity_or_a_preload(tmp_path: Path) -> None:
    text = _holding_text(gravity=False, preload=0.0, loads="")
    text = text.replace('model = "constrained"', 'model = "preloaded"', 1)
    with pytest.raises(ScenarioError, match="preloaded"):
        _scenario(tmp_path, text)
    with pytest.raises(InputError, match="gravity or a preload"):
        bk.run_scenario("paper", compliance_model="preloaded", both_models=False)


def test_an_unstable_loaded_equilibrium_is_reported_not_raised(tmp_path: Path) -> None:
    text = _holding_text(loads="").replace('model = "constrained"', 'model = "preloaded"', 1)
    text = re.sub(r"(?m)^stiffness = .*$", "stiffness = 10.0", text, count=1)  # too soft to hold the PUMA up
    sc = _scenario(tmp_path, text)
    with pytest.warns(HoldingWarning, match="unstable"):
        result = bk.run_scenario(sc, both_models=False)
    s = result.summary["strategies"]["braced_min_norm"]
    assert s["unstable_samples"] > 0 and s["holds"] is False and s["Ci_mean"] is None
    tr = result.trajectories["preloaded"]["braced_min_norm"]
    bad = tr.measures["unstable"] > 0
    assert np.all(np.isinf(tr.measures["Ci_preloaded"][bad]))
    assert np.all(tr.measures["slip_margin"][bad] == 0.0) and np.all(tr.measures["liftoff_margin"][bad] == 0.0)
    from bracekit.report.output import to_json

    to_json(result.summaries)  # no inf or NaN reaches the JSON
    lines = result.summary["warnings"]
    assert any("unstable" in w for w in lines) and not any("lifts off" in w for w in lines)  # reported once


def test_both_models_share_the_relief_of_a_shared_run_taken_once_per_run(tmp_path: Path, monkeypatch) -> None:
    """The LPs of a run both models show (not optimising) are solved once: the same relief as a direct call."""
    import bracekit.simulation.run as run_module
    from bracekit.simulation.holding import relief_summary

    sc = _scenario(tmp_path, _holding_text())
    calls: list[int] = []

    def counted(braced, qs, holding):  # type: ignore[no-untyped-def]
        calls.append(id(qs))
        return relief_summary(braced, qs, holding)

    monkeypatch.setattr(run_module, "relief_summary", counted)
    result = bk.run_scenario(sc)
    braced_runs = {id(tr) for runs in result.trajectories.values() for tr in runs.values() if tr.braced}
    assert len(calls) == len(braced_runs) < sum(tr.braced for r in result.trajectories.values() for tr in r.values())
    for model, runs in result.trajectories.items():
        for name, tr in runs.items():
            if tr.braced:
                got = result.summaries[model]["strategies"][name]["actuator_relief"]
                assert got == relief_summary(sc.braced, tr.q, sc.holding)
