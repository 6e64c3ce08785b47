"""The paper's run: all three strategies complete and the paper's qualitative result holds."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from bracekit import load_scenario, run_scenario
from bracekit.errors import RegionWarning


@pytest.fixture(scope="module")
def paper_run():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RegionWarning)  # braced minimum norm leaves the region, as reported
        return run_scenario("paper")


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_paper_result_mean_compliance_falls_from_free_space_to_braced_to_gradient_projection(paper_run, model) -> None:
    s = paper_run.summaries[model]["strategies"]
    free, mn, gp = s["free_space_min_norm"], s["braced_min_norm"], s["braced_gradient_projection"]
    assert free["completed"] and mn["completed"] and gp["completed"]
    assert free["Ci_mean"] > mn["Ci_mean"] > gp["Ci_mean"]
    assert free["Ci_min"] >= gp["Ci_min"]


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_paper_result_gradient_projection_has_the_lowest_mean_condition_number_of_J_braced(paper_run, model) -> None:
    s = paper_run.summaries[model]["strategies"]
    assert s["braced_gradient_projection"]["k_mean"] < min(
        s["braced_min_norm"]["k_mean"], s["free_space_min_norm"]["k_mean"]
    )


def test_paper_run_reports_reductions_runs_checks_and_region_exit(paper_run) -> None:
    summary = paper_run.summary
    assert summary["compliance_model"] == "constrained" and summary["gradient"] == "analytic"
    red = summary["Ci_mean_reduction_vs_free_space"]
    assert 0.3 < red["braced_min_norm"] < red["braced_gradient_projection"] < 0.9
    s = summary["strategies"]
    for name in ("braced_min_norm", "braced_gradient_projection"):
        assert s[name]["max_contact_violation_m"] < 1e-9
        assert s[name]["max_task_error_m"] < 1e-9
    assert s["braced_gradient_projection"]["max_region_radius_m"] < 0.15  # the barrier keeps it inside
    expected = {
        "Ci_mean",
        "Ci_min",
        "prod_sigma_t_mean",
        "prod_sigma_o_mean",
        "sigma_t_min",
        "sigma_o_min",
        "k_mean",
        "k_free_mean",
        "max_task_error_m",
        "max_contact_violation_m",
        "max_region_radius_m",
        "steps",
        "completed",
    }
    for values in s.values():
        assert expected <= set(values)
        assert values["steps"] == 400


def test_minimum_norm_runs_are_shared_between_compliance_models(paper_run) -> None:
    a = paper_run.trajectories["constrained"]["braced_min_norm"]
    b = paper_run.trajectories["projection"]["braced_min_norm"]
    assert a is b
    gp_c = paper_run.trajectories["constrained"]["braced_gradient_projection"].q
    gp_p = paper_run.trajectories["projection"]["braced_gradient_projection"].q
    assert not np.allclose(gp_c, gp_p)  # the objective differs with the model


def test_finite_difference_gradient_run_matches_the_analytic_run(short_scenario_file) -> None:
    sc = load_scenario(short_scenario_file)
    a = run_scenario(sc, gradient="analytic", both_models=False)
    f = run_scenario(sc, gradient="finite-difference", both_models=False)
    qa = a.trajectories["constrained"]["braced_gradient_projection"].q
    qf = f.trajectories["constrained"]["braced_gradient_projection"].q
    # the start has θ_z ≈ 5e-5 rad: central differences (δq = 1e-5) straddle θ_z's kink at 0 there, so the
    # first step differs by ~1e-4 rad; the runs then stay together (gradients agree to 1e-6 away from the kink,
    # see test_resolution)
    assert np.max(np.abs(qa - qf)) < 1e-3
    assert np.max(np.abs(qa[-5:] - qf[-5:])) < 2e-5
    sa = a.summary["strategies"]["braced_gradient_projection"]
    sf = f.summary["strategies"]["braced_gradient_projection"]
    assert sa["Ci_mean"] == pytest.approx(sf["Ci_mean"], rel=1e-3)


def test_paper_run_reproduces_the_readme_table(paper_run) -> None:
    """Golden values of the README's Table I (constrained and projection), to 0.5 %: a regression guard."""
    readme = {
        "constrained": {
            "free_space_min_norm": (0.01651, 10.09),
            "braced_min_norm": (0.00793, 6.40),
            "braced_gradient_projection": (0.00659, 5.47),
        },
        "projection": {"braced_min_norm": (0.01128, 6.40), "braced_gradient_projection": (0.00946, 5.57)},
    }
    for model, rows in readme.items():
        s = paper_run.summaries[model]["strategies"]
        for name, (ci_mean, k_mean) in rows.items():
            assert s[name]["Ci_mean"] == pytest.approx(ci_mean, rel=5e-3), (model, name)
            assert s[name]["k_mean"] == pytest.approx(k_mean, rel=5e-3), (model, name)


def test_run_scenario_accepts_a_pathlib_path_as_its_docstring_promises(short_scenario_file) -> None:
    from pathlib import Path

    result = run_scenario(Path(short_scenario_file), both_models=False)
    assert result.completed and result.scenario.source == Path(short_scenario_file)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"scenario": None},
        {"scenario": 3},
        {"scenario": "no-such-scenario.toml"},
        {"gradient": "exact"},
        {"gradient": ["analytic"]},
        {"compliance_model": 1},
        {"both_models": "yes"},
        {"progress": 3},
    ],
)
def test_run_scenario_refuses_bad_arguments_with_one_line_input_errors(short_scenario_file, kwargs) -> None:
    from bracekit.errors import InputError

    args = {"scenario": short_scenario_file, **kwargs}
    with pytest.raises(InputError) as info:
        run_scenario(**args)
    assert "\n" not in str(info.value)


def test_paper_run_reports_the_pose_task_space_and_its_redundancy(paper_run) -> None:
    # 11 joints, brace after joint 6 (l = 5 for the frictionless point, n2 = 5), a 6-D pose task
    expected = {"free_space_min_norm": 11 - 6, "braced_min_norm": 5 + 5 - 6, "braced_gradient_projection": 5 + 5 - 6}
    for name, s in paper_run.summary["strategies"].items():
        assert s["task_space"] == "pose" and s["redundancy"] == expected[name]
    assert not any("no redundancy" in w for w in paper_run.summary["warnings"])


def _panda_text(tmp_path: Path, pad_axis: str | None = None) -> Path:
    import re

    from bracekit.simulation.scenario import shipped_scenarios

    text = shipped_scenarios()["panda"].read_text(encoding="utf-8")
    text = re.sub(r"(?m)^turns = .*$", "turns = 0.05", text, count=1)
    if pad_axis is not None:
        text = re.sub(r"(?m)^pad_axis = .*$", f"pad_axis = {pad_axis}", text, count=1)
    path = tmp_path / "panda.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_pad_axis_pointing_away_from_the_surface_warns_at_the_start(tmp_path: Path) -> None:
    from bracekit.errors import PadAxisWarning

    with pytest.warns(PadAxisWarning, match="flip its sign"):
        flipped = run_scenario(_panda_text(tmp_path, "[0.01, 0.98, -0.21]"), both_models=False)
    assert any("θ_z at the start" in w for w in flipped.summary["warnings"])
    with warnings.catch_warnings():
        warnings.simplefilter("error", PadAxisWarning)
        right = run_scenario(_panda_text(tmp_path), both_models=False)  # the shipped sign: no warning
    assert not any("θ_z at the start" in w for w in right.summary["warnings"])


def test_a_redundant_gradient_projection_on_minimum_norms_path_says_so(tmp_path: Path) -> None:
    """iiwa-like arm braced at the forearm, a 4 cm circle in 'position+axis': the one redundant motion is joint 7
    spinning the tool about its axis, which no weighted term sees (reference: the two runs' joint paths)."""
    from helpers import iiwa_like_urdf, iiwa_scenario_text

    (tmp_path / "iiwa.urdf").write_text(iiwa_like_urdf(), encoding="utf-8")
    text = iiwa_scenario_text(True)
    circle = (
        'type = "circle"\ncentre = [0.66, 0.0, 0.50]\nradius = 0.04\nnormal = [0.0, 0.0, 1.0]\n'
        'start_direction = [1.0, 0.0, 0.0]\nperiod = 2.0\nspace = "position+axis"\n'
    )
    text = text[: text.index('type = "line"')] + circle + text[text.index("[start]") :]
    (tmp_path / "s.toml").write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_scenario(tmp_path / "s.toml", both_models=False)
    runs = result.trajectories["constrained"]
    gp, mn = runs["braced_gradient_projection"], runs["braced_min_norm"]
    assert gp.completed and mn.completed and gp.redundancy == 1
    gap = float(np.max(np.abs(gp.q - mn.q)))
    assert gap < 1e-6
    notes = [w for w in gp.warnings if "its path is braced minimum norm's" in w]
    assert len(notes) == 1 and f"max |Δq| {gap:.1e} rad" in notes[0]
    assert not [w for w in mn.warnings if "its path is" in w]
