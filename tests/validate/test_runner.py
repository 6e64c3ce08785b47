"""Tests of bracekit.validate.runner: the first-order compliance models against MuJoCo and the static solve."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bracekit.errors import InputError
from bracekit.report.validation_figures import figure_preload, figure_validation
from bracekit.simulation.scenario import Scenario, load_scenario
from bracekit.validate import (
    ValidationReport,
    preload_study,
    run_validation,
    validation_configurations,
)
from bracekit.validate.runner import run_preloaded_validation

pytestmark = pytest.mark.slow  # MuJoCo simulations

MODELS = ("constrained", "projection", "free_space")
STAT_KEYS = ("median_rel_err_mujoco", "max_rel_err_mujoco", "median_rel_err_static", "max_rel_err_static")
# a few loads that keep the contact closed under a 1 N preload on the paper scenario
DIRECTIONS = [
    ("force +x", [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
    ("force -z", [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]),
    ("force oblique", [-1.0, 1.0, -1.0, 0.0, 0.0, 0.0]),
    ("moment", [0.0, 0.0, 0.0, 0.0, 1.0, 1.0]),
]


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    return load_scenario("paper")


@pytest.fixture(scope="module")
def configs(scenario: Scenario) -> list[np.ndarray]:
    return validation_configurations(scenario, 2)


@pytest.fixture(scope="module")
def report(scenario: Scenario, configs: list[np.ndarray]) -> ValidationReport:
    return run_validation(scenario, configs, force=0.5, moment=0.05, preload=1.0, directions=DIRECTIONS)


def _no_nan(obj: object) -> None:
    json.dumps(obj, allow_nan=False)  # raises ValueError on NaN / inf


def test_configurations_are_braced_and_distinct(scenario: Scenario, configs: list[np.ndarray]) -> None:
    assert len(configs) == 2
    surface = scenario.braced.brace.surface
    for q in configs:
        assert q.shape == (scenario.robot.n,)
        assert abs(surface.signed_distance(scenario.braced.state(q).b_i[0])) < 1e-9
    assert np.linalg.norm(configs[1] - configs[0]) > 1e-2


def test_constrained_agrees_with_both_references(report: ValidationReport) -> None:
    assert [c["status"] for c in report.cases] == ["ok"] * len(report.cases)
    assert len(report.cases) == 2 * len(DIRECTIONS)
    st = report.model_stats("constrained")
    assert st["median_rel_err_mujoco"] < 0.01
    assert st["median_rel_err_static"] < 0.01
    assert st["max_rel_err_static"] < 0.02
    agree = report.mujoco_vs_static()
    assert agree["max_rel_err"] < 1e-4  # MuJoCo reproduces the nonlinear statics
    for c in report.cases:
        assert c["contact_force_static"] > 0.0 and c["contact_force_mujoco"] > 0.0
        assert c["mujoco_steps"] > 0 and not c["opened"]


def test_projection_and_free_space_are_worse(report: ValidationReport) -> None:
    con = report.model_stats("constrained")
    for model in ("projection", "free_space"):
        other = report.model_stats(model)
        for key in STAT_KEYS:
            assert other[key] > 5.0 * con[key], (model, key)


def test_json_has_required_keys_and_no_nan(report: ValidationReport) -> None:
    js = report.to_json()
    assert isinstance(js["cases"], list) and len(js["cases"]) == len(report.cases)
    for model in MODELS:
        for key in STAT_KEYS:
            assert isinstance(js[model][key], float), (model, key)
    assert {"mujoco_vs_static", "settings"} <= set(js)
    _no_nan(js)
    assert json.loads(json.dumps(js))["constrained"] == js["constrained"]
    text = report.table_text()
    assert all(m in text for m in MODELS) and "MuJoCo vs static" in text


def test_figure_written(report: ValidationReport, tmp_path: Path) -> None:
    out = figure_validation(report, tmp_path / "sub" / "validation.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("bad", [0, -1, 2.5, True, "3", [], None])
def test_bad_configs(scenario: Scenario, bad: object) -> None:
    with pytest.raises(InputError):
        run_validation(scenario, bad)  # type: ignore[arg-type]
    if isinstance(bad, int) and not isinstance(bad, bool):
        with pytest.raises(InputError):
            validation_configurations(scenario, bad)


def test_bad_loads_and_unbraced_configuration(scenario: Scenario, configs: list[np.ndarray]) -> None:
    with pytest.raises(InputError):
        run_validation(scenario, configs[:1], force=0.0)
    with pytest.raises(InputError):
        run_validation(scenario, configs[:1], preload=float("nan"))
    with pytest.raises(InputError):
        run_validation(scenario, configs[:1], directions=[[0.0] * 6])
    with pytest.raises(InputError, match="from the surface"):
        run_validation(scenario, [configs[0] + 0.05], directions=DIRECTIONS[:1])


def test_opened_contact_is_reported_not_compared(scenario: Scenario, configs: list[np.ndarray]) -> None:
    lift = [("force +z", [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]), DIRECTIONS[1]]
    rep = run_validation(scenario, configs[:1], preload=0.1, directions=lift)
    opened, pressed = rep.cases
    assert opened["status"] == "contact_opened" and opened["opened"] and opened["message"]
    assert opened["contact_force_static"] == 0.0 and opened["contact_force_mujoco"] == 0.0
    assert pressed["status"] == "ok"
    assert rep.model_stats("constrained")["n_cases"] == 1
    assert rep.counts() == {"ok": 1, "contact_opened": 1, "failed": 0}


def test_mujoco_failure_is_a_failed_case(scenario: Scenario, configs: list[np.ndarray]) -> None:
    rep = run_validation(scenario, configs[:1], directions=DIRECTIONS[:2], max_steps=20)
    assert [c["status"] for c in rep.cases] == ["failed", "failed"]
    assert all("MuJoCo" in c["message"] for c in rep.cases)
    js = rep.to_json()
    _no_nan(js)
    assert js["constrained"]["median_rel_err_mujoco"] is None
    assert "failed cases" in rep.table_text()


def test_preload_study_error_grows_with_preload(scenario: Scenario, configs: list[np.ndarray], tmp_path: Path) -> None:
    study = preload_study(
        scenario, preloads=(0.5, 5.0, 50.0), loads=(0.05,), config=configs[0], directions=DIRECTIONS[:3]
    )
    _no_nan(study)
    first = [row[0] for row in study["median_rel_err"]]
    worst = [row[0] for row in study["max_rel_err"]]
    corrected = [row[0] for row in study["max_rel_err_corrected"]]
    assert first[0] < first[1] < first[2] and worst[0] < worst[1] < worst[2]
    assert first[2] > 3.0 * first[0]
    # the preload's geometric stiffness explains the growth: with it the error stays at the load's level
    assert max(corrected) < 1.05 * min(corrected) and max(corrected) < 0.5 * worst[2]
    assert study["failed"] == [[0], [0], [0]]
    out = figure_preload(study, tmp_path / "preload.png")
    assert out.stat().st_size > 10_000


def test_more_configurations_than_the_path_has_samples_is_an_input_error_stating_the_maximum(
    scenario: Scenario,
) -> None:
    from bracekit.validate.runner import path_samples

    most = path_samples(scenario)
    assert most == round(scenario.task.duration / scenario.dt) + 1
    with pytest.raises(InputError, match=f"at most {most}") as info:
        validation_configurations(scenario, most + 1)
    assert "\n" not in str(info.value)
    with pytest.raises(InputError, match=f"at most {most}"):
        run_validation(scenario, 10 * most)


def test_validation_accepts_a_scenario_path_of_any_os_pathlike(tmp_path: Path) -> None:
    from helpers import PAPER_TOML

    class Fspath:
        def __fspath__(self) -> str:
            return str(PAPER_TOML)

    assert len(validation_configurations(Fspath(), 1)) == 1  # type: ignore[arg-type]
    with pytest.raises(InputError):
        validation_configurations(3.5, 1)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def preloaded_reports(scenario: Scenario, configs: list[np.ndarray]) -> dict[float, dict]:
    """The preloaded validation with gravity at P = 20 and 50 N, at the default load size and ten times smaller."""
    out = {}
    for force in (0.5, 0.05):
        rep = run_preloaded_validation(
            scenario, configs[:1], preloads=(20.0, 50.0), force=force, moment=force / 10.0, directions=DIRECTIONS[:3]
        )
        out[force] = json.loads(json.dumps(rep.to_json(), allow_nan=False))
    return out


def test_preloaded_compliance_with_gravity_matches_mujoco_and_the_statics_where_the_constrained_model_does_not(
    preloaded_reports: dict[float, dict],
) -> None:
    big, small = preloaded_reports[0.5], preloaded_reports[0.05]
    for js in (big, small):
        assert js["gravity"] is True and js["counts"] == {"ok": 6, "contact_opened": 0, "failed": 0}
        assert js["n_cases"] == 6 and js["constrained"]["n_cases"] == 6
        assert js["mujoco_vs_static"]["max_rel_err"] < 1e-3  # both references carry gravity and the preload
        for entry in js["by_preload"]:
            pre, con = entry["preloaded"], entry["constrained"]
            for ref in ("mujoco", "static"):
                assert pre[f"median_rel_err_{ref}"] < 0.2 * con[f"median_rel_err_{ref}"], (entry["preload_N"], ref)
                assert pre[f"max_rel_err_{ref}"] < 0.5 * con[f"max_rel_err_{ref}"], (entry["preload_N"], ref)
                assert con[f"median_rel_err_{ref}"] > 0.01  # gravity's and the preload's geometric stiffness
    # the preloaded model's error is the load's own nonlinearity: about ten times smaller at a tenth of the load
    for ref in ("mujoco", "static"):
        assert big[f"max_rel_err_{ref}"] < 0.008 and small[f"max_rel_err_{ref}"] < 0.001
        assert small[f"max_rel_err_{ref}"] < 0.2 * big[f"max_rel_err_{ref}"]
    # the constrained model's error does not shrink with the load: it is the neglected stiffness
    assert small["constrained"]["median_rel_err_static"] > 0.5 * big["constrained"]["median_rel_err_static"]


def test_preloaded_validation_refuses_bad_preloads_and_gravity(scenario: Scenario, configs: list[np.ndarray]) -> None:
    with pytest.raises(InputError, match="preload"):
        run_preloaded_validation(scenario, configs[:1], preloads=(-1.0,))
    with pytest.raises(InputError, match="preloads"):
        run_preloaded_validation(scenario, configs[:1], preloads=())
    with pytest.raises(InputError, match="gravity"):
        run_preloaded_validation(scenario, configs[:1], gravity="yes")  # type: ignore[arg-type]
