"""`bracekit view` on damaged output folders and unusable hosts: one error line and exit 2, nothing served."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bracekit.cli import main
from bracekit.errors import InputError
from bracekit.viewer.scene import SCENE_FILE, load_scene

RUN = "constrained/braced_gradient_projection"


def _edit_json(name: str, change: Callable[[Any], Any]) -> Callable[[Path], None]:
    def damage(folder: Path) -> None:
        path = folder / name
        data = json.loads(path.read_text(encoding="utf-8"))
        path.write_text(json.dumps(change(data)), encoding="utf-8")

    return damage


def _scene(change: Callable[[dict[str, Any]], None]) -> Callable[[Path], None]:
    def edit(data: dict[str, Any]) -> dict[str, Any]:
        change(data)
        return data

    return _edit_json(SCENE_FILE, edit)


def _npz(change: Callable[[dict[str, np.ndarray]], None]) -> Callable[[Path], None]:
    def damage(folder: Path) -> None:
        path = folder / "trajectories.npz"
        with np.load(path) as npz:
            arrays = {k: npz[k] for k in npz.files}
        change(arrays)
        np.savez_compressed(path, **arrays)

    return damage


def _truncate(folder: Path) -> None:
    path = folder / "trajectories.npz"
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _not_a_zip(folder: Path) -> None:
    (folder / "trajectories.npz").write_bytes(b"PK\x03\x04 not really a zip archive")


def _put(arrays: dict[str, np.ndarray], key: str, value: np.ndarray) -> None:
    arrays[key] = value


DAMAGE: dict[str, Callable[[Path], None]] = {
    "truncated npz": _truncate,
    "npz that is not a zip": _not_a_zip,
    "q one joint short": _npz(lambda a: _put(a, f"{RUN}/q", a[f"{RUN}/q"][:, :-1])),
    "t and q of different lengths": _npz(lambda a: _put(a, f"{RUN}/t", a[f"{RUN}/t"][:-1])),
    "t not increasing": _npz(lambda a: _put(a, f"{RUN}/t", a[f"{RUN}/t"][::-1].copy())),
    "t as text": _npz(lambda a: _put(a, f"{RUN}/t", np.array(["x"] * len(a[f"{RUN}/t"])))),
    "a run without samples": _npz(lambda a: a.update({k: v[:0] for k, v in a.items() if k.startswith(f"{RUN}/")})),
    "q not finite": _npz(lambda a: _put(a, f"{RUN}/q", np.full_like(a[f"{RUN}/q"], np.nan))),
    "a measure of the wrong length": _npz(lambda a: _put(a, f"{RUN}/contact_force_N", np.zeros(3))),
    "no task": _scene(lambda d: d.pop("task")),
    "task a list": _scene(lambda d: d.update(task=[1.0])),
    "task without path": _scene(lambda d: d["task"].pop("path")),
    "ragged path": _scene(lambda d: d["task"]["path"][0].pop()),
    "path of 2-vectors": _scene(lambda d: d["task"].update(path=[p[:2] for p in d["task"]["path"]])),
    "path not finite": _scene(lambda d: d["task"]["path"][0].__setitem__(0, None)),
    "empty path": _scene(lambda d: d["task"].update(path=[])),
    "runs a list": _scene(lambda d: d.update(runs=[])),
    "a run entry a list": _scene(lambda d: d["runs"].update({RUN: []})),
    "braced as text": _scene(lambda d: d["runs"][RUN].update(braced="yes")),
    "one stored tip": _scene(lambda d: d["runs"][RUN]["tip_first_last"].pop()),
    "stored tips of 2-vectors": _scene(lambda d: d["runs"][RUN].update(tip_first_last=[[0.0, 0.0]] * 2)),
    "holding a list": _scene(lambda d: d.update(holding=[])),
    "gravity as text": _scene(lambda d: d["holding"].update(gravity="no")),
    "preloads as text": _scene(lambda d: d["holding"].update(preloads="five")),
    "one preload too few": _scene(lambda d: d["holding"].update(preloads=[])),
    "robot a list": _scene(lambda d: d.update(robot=[])),
    "model text a number": _scene(lambda d: d["robot"].update(pinocchio_model=3)),
    "a capsule on joint 999": _scene(lambda d: d["robot"]["capsules"][0].update(joint=999)),
    "a capsule on the universe": _scene(lambda d: d["robot"]["capsules"][0].update(joint=0)),
    "a capsule radius not finite": _scene(lambda d: d["robot"]["capsules"][0].update(radius=float("nan"))),
    "ragged brace point": _scene(lambda d: d["braces"][0].update(point=[0.0, [1.0], 2.0])),
    "a brace a number": _scene(lambda d: d.update(braces=[3])),
    "region radius as text": _scene(lambda d: d["braces"][0].update(region_radius="wide")),
    "scenario name a list": _scene(lambda d: d.update(scenario=["paper"])),
    "compliance model a number": _scene(lambda d: d.update(compliance_model=3)),
    "summary a list": _edit_json("summary.json", lambda d: [d]),
    "summary model a number": _edit_json("summary.json", lambda d: {**d, "compliance_model": 3}),
    "summaries a list": _edit_json("summary_all_models.json", lambda d: [d]),
    "summaries of a model a list": _edit_json("summary_all_models.json", lambda d: {**d, "constrained": []}),
    "strategies a list": _edit_json(
        "summary_all_models.json", lambda d: {**d, "constrained": {**d["constrained"], "strategies": []}}
    ),
}


@pytest.fixture
def nothing_served(monkeypatch: pytest.MonkeyPatch) -> None:
    """A viser server that fails the test if the viewer starts one (the command would otherwise serve forever)."""
    viser = pytest.importorskip("viser")

    def refuse(*_: Any, **__: Any) -> None:
        raise AssertionError("a server was started")

    monkeypatch.setattr(viser, "ViserServer", refuse)


def _one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bracekit: error: "), err
    return err[0]


@pytest.mark.parametrize("damage", DAMAGE.values(), ids=DAMAGE.keys())
def test_a_damaged_output_is_one_error_line(
    damage: Callable[[Path], None], short_run, tmp_path: Path, capsys, nothing_served
) -> None:
    _, out = short_run
    folder = tmp_path / "out"
    shutil.copytree(out, folder)
    load_scene(folder)  # the undamaged copy loads
    damage(folder)
    with pytest.raises(InputError, match="re-run `bracekit run`"):
        load_scene(folder)
    assert main(["view", str(folder), "--port", "0"]) == 2
    assert "re-run `bracekit run`" in _one_error_line(capsys)


@pytest.mark.parametrize("host", ["999.1.1.1", "192.0.2.1"])  # not an address; an address of no machine here
def test_a_host_that_cannot_be_listened_on_is_one_error_line(host: str, short_run, capsys, nothing_served) -> None:
    _, out = short_run
    assert main(["view", str(out), "--host", host, "--port", "0"]) == 2  # port 0: any free port
    line = _one_error_line(capsys)
    assert f"cannot listen on {host}" in line or f"cannot listen on host '{host}'" in line
