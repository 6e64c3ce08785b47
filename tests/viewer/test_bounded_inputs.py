"""`bracekit view` on hostile output folders: sizes and nesting capped before any work, one line, exit 2, fast."""

from __future__ import annotations

import io
import json
import shutil
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from bracekit.cli import main
from bracekit.viewer.scene import SCENE_FILE


def _copy(short_run, tmp_path: Path) -> Path:
    _, out = short_run
    folder = tmp_path / "out"
    shutil.copytree(out, folder)
    return folder


def _view(folder: Path, capsys) -> tuple[int, str, float]:
    began = time.perf_counter()
    code = main(["view", str(folder), "--port", "0"])
    return code, capsys.readouterr().err, time.perf_counter() - began


def _one_line(err: str, *fragments: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bracekit: error:") and "Traceback" not in err, err
    assert all(f in lines[0] for f in fragments), lines[0]


def _npy_header(shape: tuple[int, ...]) -> bytes:
    """A .npy file whose header declares `shape` (float64) and that holds no data."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return buffer.getvalue()


@pytest.mark.parametrize("name", [SCENE_FILE, "summary_all_models.json", "summary.json"])
def test_a_deeply_nested_json_is_one_line(short_run, tmp_path: Path, capsys, name: str) -> None:
    folder = _copy(short_run, tmp_path)
    (folder / name).write_text("[" * 200_000 + "]" * 200_000)
    code, err, _ = _view(folder, capsys)
    assert code == 2
    _one_line(err, name, "deeper than")


def test_an_npz_declaring_a_huge_array_is_refused_from_its_header(short_run, tmp_path: Path, capsys) -> None:
    folder = _copy(short_run, tmp_path)
    path = folder / "trajectories.npz"
    with zipfile.ZipFile(path, "a", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("constrained/braced_min_norm/Ci.npy", _npy_header((250_000_000,)))
    code, err, took = _view(folder, capsys)
    assert code == 2 and took < 5.0
    _one_line(err, "trajectories.npz", "more than")


def test_an_npz_of_python_objects_is_refused(short_run, tmp_path: Path, capsys) -> None:
    folder = _copy(short_run, tmp_path)
    buffer = io.BytesIO()
    np.save(buffer, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with zipfile.ZipFile(folder / "trajectories.npz", "a") as archive:
        archive.writestr("constrained/braced_min_norm/x.npy", buffer.getvalue())
    code, err, _ = _view(folder, capsys)
    assert code == 2
    _one_line(err, "Python objects")


@pytest.mark.parametrize(
    ("edit", "fragment"),
    [
        (lambda d: d["robot"].__setitem__("capsules", d["robot"]["capsules"] * 20_000), "larger than 8192 KiB"),
        (lambda d: d["robot"].__setitem__("capsules", d["robot"]["capsules"] * 100), "capsules"),
        (lambda d: d.__setitem__("braces", d["braces"] * 40), "braces"),
        (lambda d: d["task"].__setitem__("path", [[0.0, 0.0, 0.0]] * 100_001), "task.path"),
        (lambda d: d["robot"]["capsules"][0].__setitem__("radius", 1e308), "radius"),
        (lambda d: d["robot"]["capsules"][0].__setitem__("joint", 1e300), "out of range"),
    ],
    ids=["220k capsules", "1100 capsules", "many braces", "long path", "huge radius", "huge joint index"],
)
def test_a_scene_over_its_caps_is_refused_at_once(short_run, tmp_path: Path, capsys, edit, fragment: str) -> None:
    folder = _copy(short_run, tmp_path)
    data = json.loads((folder / SCENE_FILE).read_text())
    edit(data)
    (folder / SCENE_FILE).write_text(json.dumps(data))
    code, err, took = _view(folder, capsys)
    assert code == 2 and took < 10.0
    _one_line(err, fragment)


def test_a_folder_name_too_long_is_one_line(tmp_path: Path, capsys) -> None:
    code, err, _ = _view(tmp_path / ("a" * 300), capsys)
    assert code == 2
    _one_line(err, "File name too long")
