"""Reporting: the output folder is written whole or not at all; the table holds ours beside the paper's."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bracekit import load_scenario, run_scenario
from bracekit.report import output as out_mod
from bracekit.report import write_run
from bracekit.report.table import PAPER_TABLE_I, table_csv, table_markdown


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    from helpers import scenario_text

    p = tmp_path_factory.mktemp("sc") / "short.toml"
    p.write_text(scenario_text(turns=0.05, dt=0.1), encoding="utf-8")
    return run_scenario(load_scenario(p))


def test_write_run_writes_every_file_and_summary_matches_the_result(short_run, tmp_path: Path) -> None:
    out = tmp_path / "out"
    written = write_run(short_run, out)
    for p in written:
        assert p.is_file() and p.stat().st_size > 0
    names = {p.name for p in written}
    assert {
        "summary.json",
        "table.md",
        "table.csv",
        "trajectories.npz",
        "fig2_film_strip.png",
        "fig3_ellipsoids.png",
        "fig4_measures.png",
        "animation.gif",
    } <= names
    data = json.loads((out / "summary.json").read_text())
    assert set(data["strategies"]) == {"free_space_min_norm", "braced_min_norm", "braced_gradient_projection"}
    assert data["strategies"]["braced_min_norm"]["Ci_mean"] == pytest.approx(
        short_run.summary["strategies"]["braced_min_norm"]["Ci_mean"]
    )
    npz = np.load(out / "trajectories.npz")
    q = npz["constrained/braced_gradient_projection/q"]
    assert np.allclose(q, short_run.trajectories["constrained"]["braced_gradient_projection"].q)
    assert (out / "fig4_measures.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "animation.gif").read_bytes()[:3] == b"GIF"
    assert not list(tmp_path.glob(".out.tmp-*"))


def test_a_failure_while_writing_leaves_no_partial_output(short_run, tmp_path: Path, monkeypatch) -> None:
    from bracekit.report import figures

    def boom(*_a, **_k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(figures, "figure_ellipsoids", boom)
    out = tmp_path / "never"
    with pytest.raises(RuntimeError):
        write_run(short_run, out)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_json_refuses_non_finite_numbers() -> None:
    with pytest.raises(ValueError, match="non-finite"):
        out_mod.to_json({"a": float("nan")})
    assert json.loads(out_mod.to_json({"a": np.float64(1.5), "b": np.arange(2)})) == {"a": 1.5, "b": [0, 1]}


def test_table_holds_the_paper_rows_only_for_the_paper_scenario_and_ours_for_both_models(short_run) -> None:
    md = table_markdown(short_run.summaries, "paper")
    assert "0.02490" in md and "49.7 %" in md and "59.2 %" in md  # the paper's, converted to m/N
    other = table_markdown(short_run.summaries, "short")
    assert "0.02490" not in other and "| paper |" not in other and "| bracekit |" in other
    for text in (md, other):  # the run checks follow Table I, one row per model and strategy
        checks = text.split("## Run checks", 1)[1]
        assert checks.count("| constrained |") == 3 and checks.count("| projection |") == 3
        assert "redundancy" in checks and "min link clearance [m]" in checks
        assert "lift-off" not in checks  # no statics without gravity, preload or loads
    assert len(table_csv(short_run.summaries, "short").strip().splitlines()) == 1 + 3 * 2
    csv = table_csv(short_run.summaries)
    lines = csv.strip().splitlines()
    assert len(lines) == 1 + 3 + 3 * 2
    assert PAPER_TABLE_I["braced_gradient_projection"]["k_mean"] == 4.33
    ours = short_run.summaries["projection"]["strategies"]["braced_min_norm"]["Ci_mean"]
    assert any(line.startswith("bracekit,projection,braced_min_norm,") and str(ours) in line for line in lines)


def test_a_rerun_without_figures_removes_the_previous_runs_figures(short_run, tmp_path: Path) -> None:
    out = tmp_path / "out"
    write_run(short_run, out)
    assert (out / "fig2_film_strip.png").exists()
    (out / "notes.txt").write_text("mine")
    write_run(short_run, out, figures=False, overwrite=True)  # notes.txt is not bracekit's
    assert not (out / "fig2_film_strip.png").exists() and not (out / "animation.gif").exists()
    assert (out / "summary.json").exists() and (out / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("bad", ["", "."])
def test_the_current_folder_is_not_an_output_folder(short_run, bad: str) -> None:
    from bracekit import InputError

    with pytest.raises(InputError):
        write_run(short_run, Path(bad) if bad else bad)  # type: ignore[arg-type]


def test_capacity_figure_is_drawn_for_a_run_with_statics(tmp_path: Path) -> None:
    import re

    import matplotlib.image as mpimg

    import bracekit as bk
    from bracekit.report import figures
    from helpers import scenario_text

    text = scenario_text(turns=0.05, dt=0.1)
    text = re.sub(r"(?m)^stiffness = .*$", "stiffness = 170.0\ngravity = true", text, count=1)
    text = re.sub(r"(?m)^region_radius = .*$", "region_radius = 0.15\npreload = 20.0\nfriction = 0.5", text, count=1)
    path = tmp_path / "hold.toml"
    path.write_text(text + "\n[loads]\nwrenches = [[0.0, 0.0, -10.0, 0.0, 0.0, 0.0]]\n", encoding="utf-8")
    with pytest.warns(bk.BracekitWarning):
        result = bk.run_scenario(path, both_models=False)
    assert figures.has_capacity(result)
    png = tmp_path / "cap.png"
    figures.figure_capacity(result, png)
    img = mpimg.imread(png)[..., :3]
    h, w = img.shape[:2]
    for rows, cols in ((slice(0, h // 2), slice(0, w // 2)), (slice(h // 2, h), slice(w // 2, w))):
        panel = img[rows, cols]
        coloured = panel.max(axis=-1) - panel.min(axis=-1) > 0.3  # the strategies' coloured lines
        assert coloured.sum() > 200  # curves are drawn in the lift-off and the torque panels
