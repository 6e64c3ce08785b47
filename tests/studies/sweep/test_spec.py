from __future__ import annotations

from pathlib import Path

import pytest

from bracekit.cli.main import main
from bracekit.studies.sweep.spec import SpecError, load_spec, shipped_specs

from .conftest import SPEC


def write(folder: Path, text: str) -> Path:
    path = folder / "s.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_shipped_spec_loads() -> None:
    assert "paper-links" in shipped_specs()
    spec = load_spec("paper-links")
    assert spec.base_name == "paper"
    assert spec.axis_names == ("link", "fraction")
    assert len(spec.axis("link").grid()) == 8


@pytest.mark.parametrize(
    ("change", "key"),
    [
        (("fraction = [0.3, 0.7]", "fraction = [0.3, 1.7]"), "axes.fraction"),
        (('link = ["link4", "link8"]', 'link = ["link4", "nolink"]'), "axes.link"),
        (("[screen]", "[screen]\nspeed = 3"), "screen.speed"),
        (("keep_fraction = 0.5", "keep_fraction = 2"), "screen.keep_fraction"),
        (('base = "short.toml"', 'base = "missing.toml"'), "base"),
        (("fraction = [0.3, 0.7]", "fraction = { range = [0.2, 0.2] }"), "axes.fraction.range"),
        (("fraction = [0.3, 0.7]", "fraction = [0.3, 0.3]"), "axes.fraction"),
        (("[axes]", '[sampling]\nmode = "grid"\nsamples = 4\n[axes]'), "sampling.samples"),
        (("[refine]", "[refine]\nfoo = 1"), "refine.foo"),
    ],
)
def test_bad_specs_name_the_key_in_one_line(tiny_spec: Path, tmp_path: Path, change: tuple[str, str], key: str) -> None:
    (tmp_path / "short.toml").write_text((tiny_spec.parent / "short.toml").read_text())
    text = SPEC.replace(*change)
    assert text != SPEC
    with pytest.raises(SpecError) as info:
        load_spec(write(tmp_path, text))
    message = str(info.value)
    assert key in message
    assert "\n" not in message


def test_bad_spec_through_the_cli_exits_2_with_one_line(
    tiny_spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "short.toml").write_text((tiny_spec.parent / "short.toml").read_text())
    path = write(tmp_path, SPEC.replace("top = 1", "top = -1"))
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "refine.top" in err[0]
    assert not (tmp_path / "out").exists()


def test_missing_spec_and_bad_flags_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sweep", str(tmp_path / "none.toml"), "--out", str(tmp_path / "o")]) == 2
    assert "not found" in capsys.readouterr().err
    assert main(["sweep", "paper-links", "--out", str(tmp_path / "o"), "--limit", "0"]) == 2
    assert "--limit" in capsys.readouterr().err


def test_an_out_with_another_specs_rows_is_refused_in_one_line(
    tiny_spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from bracekit.studies.sweep.store import RowStore

    RowStore(tmp_path / "out", load_spec("paper-links"))
    assert main(["sweep", str(tiny_spec), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another sweep spec" in err[0]


def test_an_out_with_user_files_is_refused_without_overwrite(
    tiny_spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(["sweep", str(tiny_spec), "--out", str(out), "--quiet"]) == 2
    assert "notes.txt" in capsys.readouterr().err
    assert (out / "notes.txt").read_text() == "mine" and not (out / ".sweep").exists()


def test_a_missing_dask_is_one_line_exit_2(
    tiny_spec: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "distributed" else real(name, *a))
    assert main(["sweep", str(tiny_spec), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bracekit[sweep]" in err[0]
