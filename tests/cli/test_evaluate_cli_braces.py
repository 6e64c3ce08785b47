"""`bracekit evaluate` with several --brace and statics flags, against Pinocchio's rnea and the one-brace output."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin

from bracekit.cli import main
from bracekit.model.shipped import load_model

Q = "0,0.194,-2.598,0,-0.737,-2.498,-1.898,3.142,2.106,2.438,0.867"
LINKS = ["--brace-link", "link3", "--brace-link", "link9", "--brace-offset", "0.05,0.02,0.1", "--brace-offset", "0,0,0"]
NORMALS = np.array([[0.3, -0.2, 1.0], [-1.0, 0.4, 0.2]])


def _evaluate(capsys, *flags: str) -> tuple[int, dict, str]:
    """(exit code, the JSON report or {"text": the output}, stderr)."""
    code = main(["evaluate", "--model", "paper-robot", "--q", Q, *flags])
    out, err = capsys.readouterr()
    return code, (json.loads(out) if code == 0 and "--json" in flags else {"text": out}), err


def test_two_braces_take_the_statics_flags_and_hold_gravity_and_the_preloads_as_rnea_says(capsys) -> None:
    flags = [*LINKS, "--brace", "pad_a", "--brace", "pad_b", "--normal", "0.3,-0.2,1", "--normal", "-1,0.4,0.2"]
    statics = ["--gravity", "--preload", "6", "--friction", "0.5", "--wrench", "0,0,-10,0,0,0"]
    code, r, err = _evaluate(capsys, *flags, *statics, "--json")
    assert code == 0, err
    robot = load_model("paper-robot").with_point_frames(
        [("pad_a", "link3", (0.05, 0.02, 0.1), None), ("pad_b", "link9", (0.0, 0.0, 0.0), None)]
    )
    model = robot.model
    data = model.createData()
    q = np.array([float(x) for x in Q.split(",")])
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    for frame, nh in zip(("pad_a", "pad_b"), NORMALS, strict=True):
        fid = model.getFrameId(frame)
        f = 6.0 * nh / np.linalg.norm(nh)
        joint = model.frames[fid].parentJoint
        fext[joint] = fext[joint] + data.oMi[joint].actInv(pin.Force(f, np.cross(data.oMf[fid].translation, f)))
    tau = pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv), fext)
    np.testing.assert_allclose(r["tau0"], tau, rtol=0, atol=1e-10 * np.abs(tau).max())
    assert [b["preload_N"] for b in r["braces"]] == [6.0, 6.0] and [b["friction"] for b in r["braces"]] == [0.5, 0.5]
    lifts = [b["liftoff_margin"] for b in r["braces"]]
    assert r["liftoff_margin"] == min((x for x in lifts if x is not None), default=None)
    assert "C_e_preloaded" in r and "contact_wrench" not in r  # each brace's wrench is in its own entry
    code, text, err = _evaluate(capsys, *flags, *statics)  # the text output names each brace's statics
    assert code == 0, err
    assert "statics: gravity on, preload 6 N, μ = 0.5; preload 6 N, μ = 0.5;" in text["text"]


def test_one_brace_given_as_a_list_of_one_reports_the_one_brace_keys(capsys) -> None:
    code, one, err = _evaluate(capsys, "--brace", "brace", "--gravity", "--preload", "4", "--json")
    assert code == 0, err
    assert "n1" in one and "braces" not in one and one["preload_N"] == 4.0 and len(one["contact_wrench"]) == 6
