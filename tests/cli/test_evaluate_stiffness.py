"""`bracekit evaluate --stiffness-out`, `--stiffness-frame` and `--beta-w`: the exported stiffness is the library's
(checked there against the nonlinear static solve), the file is written whole and never over a user's file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import bracekit as bk
from bracekit.cli.main import main
from bracekit.compliance import end_effector_compliance
from bracekit.compliance.stiffness import tool_stiffness

Q = "0,0.194,-2.598,0,-0.737,-2.498,-1.898,3.142,2.106,2.438,0.867"


def _run(args: list[str], capsys) -> tuple[int, str, str]:
    code = main(args)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _braced(b: list[float]) -> bk.BracedRobot:
    return bk.BracedRobot(
        bk.load_model("paper-robot"), bk.Brace("brace", bk.Surface(np.array(b), np.array([0, 0, 1.0])))
    )


def test_stiffness_export_is_the_inverse_compliance_in_the_tool_axes(capsys, tmp_path: Path) -> None:
    out = tmp_path / "K.json"
    flags = ["--stiffness-out", str(out), "--stiffness-frame", "tool", "--gravity", "--preload", "20"]
    code, text, _ = _run(["evaluate", "--model", "paper-robot", "--q", Q, *flags, "--json"], capsys)
    assert code == 0
    report = json.loads(text)
    assert "tool_stiffness" not in report  # the evaluate JSON keeps its keys; the stiffness goes to its file
    data = json.loads(out.read_text())
    st = _braced(report["b"]).state(np.array(report["q"]))
    first, loaded = data["first_order"], data["preloaded"]
    r = np.array(first["R"])
    np.testing.assert_allclose(r, st.R_e, atol=1e-15)
    t = np.kron(np.eye(2), r)
    c_tool = t.T @ end_effector_compliance(st) @ t
    np.testing.assert_allclose(np.array(first["K"]) @ c_tool, np.eye(6), atol=1e-9)
    ref = tool_stiffness(st, "tool", preload=20.0, gravity=True)
    np.testing.assert_allclose(np.array(loaded["K"]), ref.K, rtol=1e-12, atol=1e-9)
    assert loaded["asymmetry"] < 1e-9 and loaded["inverse_check"] < 1e-9 and loaded["gravity"] is True
    k_sym = np.array(loaded["K_sym"])
    np.testing.assert_array_equal(k_sym, k_sym.T)
    # a second export replaces the first
    code, _, _ = _run(["evaluate", "--model", "paper-robot", "--q", Q, "--stiffness-out", str(out)], capsys)
    assert code == 0 and "preloaded" not in json.loads(out.read_text())


def test_stiffness_export_refuses_a_users_file_and_a_bad_frame(capsys, tmp_path: Path) -> None:
    mine = tmp_path / "notes.json"
    mine.write_text('{"mine": 1}')
    code, _, err = _run(["evaluate", "--model", "paper-robot", "--q", Q, "--stiffness-out", str(mine)], capsys)
    assert code == 2 and "not a bracekit stiffness export" in err and mine.read_text() == '{"mine": 1}'
    for frame in ["flange", "1,0,0,0,1,0,0,0,-1", "1,2,3"]:
        out = tmp_path / "K.json"
        args = ["evaluate", "--model", "paper-robot", "--q", Q, "--stiffness-out", str(out), "--stiffness-frame", frame]
        code, _, err = _run(args, capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1 and not out.exists()
    code, _, err = _run(
        ["evaluate", "--model", "paper-robot", "--q", Q, "--stiffness-out", str(tmp_path / "no/K.json")], capsys
    )
    assert code == 2 and "does not exist" in err


def test_text_names_each_measure_and_beta_w_gives_the_directional_compliance(capsys) -> None:
    args = ["evaluate", "--model", "paper-robot", "--q", Q, "--beta-x", "1,0,0,0,0,0", "--beta-w", "0,0,2,0,0,0"]
    code, text, _ = _run(args, capsys)
    assert code == 0 and "mixed units, the paper's index" in text and "c_t = β_xᵀC_ttβ_x" in text
    code, out, _ = _run([*args, "--json"], capsys)
    data = json.loads(out)
    c = np.array(data["C_e_constrained"])
    assert data["ct_constrained"] == pytest.approx(c[0, 0], rel=1e-12)
    assert data["Cw_constrained"] == pytest.approx(c[0, 2], rel=1e-12)
    assert data["Ci_constrained"] == pytest.approx(np.linalg.norm(c[0]), rel=1e-12)
    assert set(data["measures"]) == {"Ci", "ct", "Cw"}
