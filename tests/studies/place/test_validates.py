"""`bracekit place` on a small budget (the paper robot, the Panda), then `bracekit validate` on its best.toml (slow).

The independent reference is the validation itself: MuJoCo's settled static deflection and the nonlinear
static solve against the constrained model at the written scenario's start.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bracekit.cli.main import main

pytestmark = pytest.mark.slow

PAPER = 'base = "paper"\n[axes]\nlink = ["link2", "link4"]\n[brace]\nnormal = [0.0, 0.0, 1.0]\nregion_radius = 0.15\n'
PANDA = (
    'base = "panda"\n[axes]\nlink = ["panda_link3"]\n[brace]\nnormal = [0.0, 0.0, 1.0]\nregion_radius = 0.10\n'
    "surface_radius = 0.12\n"
)


@pytest.mark.parametrize(("spec_text", "best_link"), [(PAPER, "link4"), (PANDA, "panda_link3")])
def test_the_best_place_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], spec_text: str, best_link: str
) -> None:
    spec = tmp_path / "spec.toml"
    spec.write_text(f'name = "place-small"\n{spec_text}[feasibility]\nk_max = 25.0\n', encoding="utf-8")
    out = tmp_path / "place"
    assert main(["place", str(spec), "--out", str(out), "--refine", "0", "--no-figures"]) == 0
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["best"]["link"] == best_link
    capsys.readouterr()
    code = main(["validate", str(out / "best.toml"), "--configs", "1", "--tracking-points", "0", "--json"])
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["n_failed"] == 0 and data["n_ok"] > 0
    assert data["constrained"]["median_rel_err_mujoco"] < 0.01
