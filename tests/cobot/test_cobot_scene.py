"""`bracekit cobot`'s replay: the folder opens in the viewer, with MuJoCo's q(t) and the tool where MuJoCo had it."""

import json
import tomllib
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from bracekit.cli.cobot import COBOT_FILES
from bracekit.cli.main import main
from bracekit.cobot.config import shipped_cobots
from bracekit.cobot.scene import MODEL, SAMPLE_TICKS
from bracekit.viewer.frames import run_frames
from bracekit.viewer.scene import load_scene

pytestmark = [pytest.mark.slow, pytest.mark.mujoco]

_STRATEGIES = ("free_space_min_norm", "braced_min_norm")


def _toml(data: dict) -> str:
    lines = [f"{k} = {json.dumps(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for name, table in data.items():
        if isinstance(table, dict):
            lines += [f"[{name}]"] + [f"{k} = {json.dumps(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


@cache
def _folder(root: str) -> Path:
    """panda-cobot with its first two holes and two strategies, written by the command line without figures."""
    data = tomllib.loads(shipped_cobots()["panda-cobot"].read_text(encoding="utf-8"))
    data["operator"]["targets"] = data["operator"]["targets"][:2]
    data["control"]["strategies"] = list(_STRATEGIES)
    path = Path(root) / "short.toml"
    path.write_text(_toml(data), encoding="utf-8")
    out = Path(root) / "out"
    assert main(["cobot", str(path), "--out", str(out), "--quiet", "--no-figures"]) == 0
    return out


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _folder(str(tmp_path_factory.mktemp("cobot-replay")))


def test_files_listed_and_written_whole(folder: Path) -> None:
    manifest = json.loads((folder / ".bracekit-output.json").read_text())
    want = {f for f in COBOT_FILES if f != "cobot.png"}
    assert {"scene.json", "trajectories.npz"} <= want <= set(manifest["files"])
    assert all((folder / f).is_file() for f in manifest["files"])


def test_scene_loads_with_the_series_joint_positions(folder: Path) -> None:
    scene = load_scene(folder)
    assert scene.models == (MODEL,) and scene.strategies == _STRATEGIES
    assert scene.braced.robot.n == 7 and len(scene.braces) == 1
    targets = json.loads((folder / "summary.json").read_text())["operator"]["targets_m"]
    np.testing.assert_array_equal(scene.path, np.array(targets))
    with np.load(folder / "series.npz") as series:
        for name in _STRATEGIES:
            run = scene.runs[MODEL][name]
            t = series[f"{name}/t"][::SAMPLE_TICKS]
            np.testing.assert_array_equal(run.t, t)
            np.testing.assert_array_equal(run.q, series[f"{name}/qpos"][: t.size])
            assert run.braced == (name != "free_space_min_norm")
            assert np.all(np.any(run.q != 0.0, axis=1))  # every stored sample is a MuJoCo state (no unfilled row)


def test_viewer_frames_put_the_tool_where_mujoco_had_it(folder: Path) -> None:
    """The viewer's tip at sample k against MuJoCo's tool site read at the next tick (after the stored step)."""
    scene = load_scene(folder)
    with np.load(folder / "series.npz") as series:
        for name in _STRATEGIES:
            frames = run_frames(scene, scene.runs[MODEL][name])
            e = series[f"{name}/e"]
            ticks = np.arange(frames.tip.shape[0]) * SAMPLE_TICKS + 1
            keep = ticks < e.shape[0]
            gap = np.linalg.norm(frames.tip[keep] - e[ticks[keep]], axis=1)
            # MuJoCo's site is computed before the tick's last step (a quarter tick) moved q: the gap is at most
            # the tool's motion over one tick; at rest (the settle) the two agree to the MJCF's precision
            tick_motion = np.linalg.norm(e[ticks[keep]] - e[ticks[keep] - 1], axis=1)
            assert np.all(gap <= tick_motion + 1e-8), (name, np.max(gap - tick_motion))
            assert gap.min() < 1e-9 and 0.0 < gap.max() < 1e-4


def test_view_serves_the_replay_and_its_slider_moves_the_tool(folder: Path) -> None:
    pytest.importorskip("viser")
    from bracekit.viewer.server import serve

    viewer = serve(folder, port=0)
    try:
        n = viewer.nodes
        assert n["model"].value == MODEL and n["strategy"].value == "free_space_min_norm"
        braced = viewer.scene.runs[MODEL]["braced_min_norm"]
        with np.load(folder / "series.npz") as series:
            normal = series["braced_min_norm/normal"][::SAMPLE_TICKS]
        np.testing.assert_array_equal(braced.measures["contact_force_N"], normal)  # MuJoCo's brace force: the arrow
        run = viewer.scene.runs[MODEL]["free_space_min_norm"]
        frames = run_frames(viewer.scene, run)
        for k in (1, len(run.t) // 2, len(run.t) - 1):
            n["time"].value = float(run.t[k])
            np.testing.assert_allclose(n["ellipsoid"].position, frames.tip[k], atol=1e-12)
    finally:
        viewer.stop()
