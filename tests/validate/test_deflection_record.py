"""The load-case record of the deflection checks against the L-weighted error computed by hand."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bracekit.validate.deflection_record import case_record, failed_record


def _ref(deflection: list[float], opened: bool = False) -> SimpleNamespace:
    return SimpleNamespace(
        deflection=np.array(deflection),
        contact_opened=opened,
        contact_force=3.0,
        contact_forces=np.array([3.0]),
        steps=7,
    )


def _l_err(pred: np.ndarray, ref: np.ndarray, length: float) -> float:
    w = np.array([1.0, 1.0, 1.0, length, length, length])
    return float(np.sqrt(np.sum((w * (pred - ref)) ** 2) / np.sum((w * ref) ** 2)))


def test_compared_case_matches_hand_errors() -> None:
    st = _ref([1e-3, 0.0, 2e-3, 0.01, 0.0, 0.0])
    mj = _ref([1.1e-3, 0.0, 2e-3, 0.01, 1e-3, 0.0])
    pred = {"a": np.array([1e-3, 1e-4, 2e-3, 0.0, 0.0, 0.02])}
    w = np.arange(6.0)
    rec = case_record(
        {"config": 2, "label": "x"}, w, pred, {"static": st, "mujoco": mj, "timestep": None}, [], 0.3, "n"
    )
    assert list(rec)[:4] == ["config", "label", "wrench", "status"]
    assert rec["status"] == "ok" and rec["message"] is None and rec["wrench"] == w.tolist()
    for key, ref in (("static", st), ("mujoco", mj)):
        assert rec["rel_err"]["a"][key] == pytest.approx(_l_err(pred["a"], ref.deflection, 0.3), rel=1e-14)
    assert rec["rel_err_mujoco_vs_static"] == pytest.approx(_l_err(mj.deflection, st.deflection, 0.3), rel=1e-14)
    assert rec["mujoco_steps"] == 7 and rec["opened"] is False and rec["opened_mujoco"] is False


def test_opened_and_failed_cases() -> None:
    st, mj = _ref([1.0] * 6, opened=True), None
    refs = {"static": st, "mujoco": mj, "timestep": 5e-4}
    opened = case_record({"config": 0}, np.ones(6), {"a": np.ones(6)}, refs, [], 1.0, "it opened")
    assert opened["status"] == "contact_opened" and opened["message"] == "it opened" and opened["opened_static"]
    failed = case_record({"config": 0}, np.ones(6), {"a": np.ones(6)}, refs, ["MuJoCo failed: x"], 1.0, "it opened")
    assert failed["status"] == "failed" and failed["message"] == "MuJoCo failed: x"
    blank = failed_record({"config": 0}, np.ones(6), ("a",), None, "why")
    assert set(blank) == set(opened) and blank["status"] == "failed" and blank["message"] == "why"
    assert blank["rel_err"] == {"a": {"mujoco": None, "static": None}}
