"""docs/tutorial-xarm7.md as printed: its shell commands run in bash in an empty folder, its quoted numbers are
the run's (table.md and summary.json), and the folder it views opens with the xArm7's meshes."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from bracekit.cli.main import build_parser
from bracekit.viewer import load_scene

pytestmark = [pytest.mark.docs, pytest.mark.slow]

PAGE = Path(__file__).resolve().parents[1] / "docs" / "tutorial-xarm7.md"
FENCE = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```", re.S | re.M)


def _blocks(language: str) -> list[tuple[str, str]]:
    out = []
    for lang, attrs, body in FENCE.findall(PAGE.read_text(encoding="utf-8")):
        if lang == language:
            title = re.search(r'title="([^"]+)"', attrs)
            out.append((title.group(1) if title else "", body))
    return out


def test_the_xarm7_tutorial_runs_as_printed(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from geometry_refs import xarm_share

    xarm_share()  # skips without example-robot-data (the test extra)
    files = {title: body for title, body in _blocks("toml") if title}
    assert set(files) == {"xarm7-post.toml"}
    for name, body in files.items():
        (tmp_path / name).write_text(body, encoding="utf-8")
    install, *steps = [body for _, body in _blocks("bash")]
    assert install.strip().startswith("pip install") and "example-robot-data" in install
    lines = [line for body in steps for line in body.splitlines() if line.strip()]
    served = [line for line in lines if line.startswith("bracekit view ")]
    script = "\n".join(["set -euo pipefail", *[line for line in lines if line not in served]])
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    env.pop("ROS_PACKAGE_PATH", None)  # the tutorial sets it
    done = subprocess.run(["bash", "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]

    # the quoted output: the geometry line of summary.json, the constrained rows of table.md and their checks
    out = tmp_path / "xarm7-out"
    geometry, rows, checks = (body.strip() for _, body in _blocks("text"))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["geometry"] == geometry
    table = (out / "table.md").read_text(encoding="utf-8").splitlines()
    for row in [*rows.splitlines(), *checks.splitlines()]:
        assert row in table, row
    # a valid braced run with the clearance barrier on: every link out of the post, the brace in its region
    runs = summary["strategies"]
    assert runs["braced_min_norm"]["valid"] and runs["braced_gradient_projection"]["valid"]
    assert not runs["free_space_min_norm"]["valid"]  # it does not know the post
    assert "clearance = 0.0" not in PAGE.read_text(encoding="utf-8")
    assert (out / "meshes.npz").is_file() and (out / "fig2_film_strip.png").is_file()

    # `bracekit view`: the command parses and its folder opens with the arm's meshes
    assert len(served) == 1
    args = build_parser().parse_args(shlex.split(served[0])[1:])
    scene = load_scene(tmp_path / args.out_dir)
    assert scene.name == "xarm7-post" and {m.link for m in scene.meshes} >= {"link_base", "link4"}
