"""`bracekit cobot`: bad input in one line with exit 2, nothing written."""

from pathlib import Path

from bracekit.cli.main import main


def test_unknown_scenario_is_one_line(capsys, tmp_path: Path) -> None:
    out = tmp_path / "o"
    code = main(["cobot", "no-such-cobot", "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "cobot scenario not found" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_bad_key_is_named(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('scenario = "panda"\n[operator]\ntargets = [[0, 0, 0]]\nstiffness = -1\n', encoding="utf-8")
    code = main(["cobot", str(bad), "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "operator" in err and len(err.strip().splitlines()) == 1
