"""The figures are drawn, not only written: link volumes where the robot is, units, legends, no overlapping text."""

from __future__ import annotations

import itertools
import re
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from matplotlib.path import Path as MplPath
from matplotlib.text import Text
from PIL import Image

import bracekit as bk
from bracekit.report import figures
from bracekit.report.output import run_files
from bracekit.report.projection import OrthoCamera, capsule_outlines, ellipsoid_outline

SCENARIOS = Path(bk.__file__).parent / "simulation" / "scenarios"
STRATEGIES = ("free_space_min_norm", "braced_min_norm", "braced_gradient_projection")


def _short(name: str, folder: Path, turns: float = 0.05) -> bk.RunResult:
    """Shipped scenario `name` cut to `turns` of its task with dt = 0.1 s, run model only."""
    text = (SCENARIOS / f"{name}.toml").read_text(encoding="utf-8")
    text = re.sub(r"(?m)^turns = .*$", f"turns = {turns}", text, count=1)
    text = re.sub(r"(?m)^dt = .*$", "dt = 0.1", text, count=1)
    path = folder / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", bk.BracekitWarning)
        return bk.run_scenario(path, both_models=False)


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory) -> bk.RunResult:
    return _short("paper", tmp_path_factory.mktemp("sc"), turns=0.1)


def _capsule_midpoints(result: bk.RunResult, q: np.ndarray) -> np.ndarray:
    """Reference: the middle of every link capsule (k, 3), world m, from Pinocchio's own forward kinematics."""
    robot = result.scenario.robot
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    return np.array([data.oMi[c.joint].act(0.5 * (c.a + c.b)) for c in robot.link_capsules()])


def _pixels(fig) -> np.ndarray:
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()


def _at(img: np.ndarray, ax, camera: OrthoCamera, world: np.ndarray) -> np.ndarray:
    """The RGB pixels (k, 3) where world points (k, 3) are drawn in `ax` (display y counts from the bottom)."""
    xy = ax.transData.transform(camera.project(world))
    cols = np.clip(np.round(xy[:, 0]).astype(int), 0, img.shape[1] - 1)
    rows = np.clip(img.shape[0] - 1 - np.round(xy[:, 1]).astype(int), 0, img.shape[0] - 1)
    return img[rows, cols].astype(int)


def _not_white(rgb: np.ndarray) -> np.ndarray:
    return rgb.min(axis=-1) < 235


def _drawn_texts(fig) -> list[Text]:
    """The figure's visible, non-empty texts that are drawn: titles, labels, legends, in-view tick labels."""
    texts = list(fig.texts)  # the suptitle among them
    for legend in fig.legends:
        texts += legend.get_texts()
    for ax in fig.axes:
        texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label, *ax.texts]
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            span = hi - lo
            for tick in axis.get_major_ticks():
                if lo - 1e-9 * span <= tick.get_loc() <= hi + 1e-9 * span:
                    texts.append(tick.label1)
    unique = {id(t): t for t in texts}
    return [t for t in unique.values() if t.get_visible() and t.get_text().strip()]


def _texts_overlap(fig) -> list[tuple[str, str]]:
    """Pairs of drawn texts of the figure whose boxes intersect."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in _drawn_texts(fig)]
    return [(a, b) for (a, ba), (b, bb) in itertools.combinations(boxes, 2) if ba.overlaps(bb)]


# --- the projection ------------------------------------------------------------------------------------
def test_axis_views_keep_world_coordinates() -> None:
    front, top = OrthoCamera(-90.0, 0.0), OrthoCamera(-90.0, 90.0)
    p = np.array([[0.3, -0.7, 1.1], [-2.0, 0.5, 0.25]])
    assert np.allclose(front.project(p), p[:, [0, 2]]) and np.allclose(front.depth(p), -p[:, 1])
    assert np.allclose(top.project(p), p[:, [0, 1]]) and np.allclose(top.depth(p), p[:, 2])
    cam = OrthoCamera(37.0, 21.0)
    assert np.allclose(cam.basis @ cam.basis.T, np.eye(3))
    assert np.allclose(np.cross(cam.basis[0], cam.basis[1]), cam.toward)  # right × up = toward the viewer
    az, el = np.radians(37.0), np.radians(21.0)
    assert np.allclose(cam.toward, [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def _support(points: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    return (points @ dirs.T).max(axis=0)


def test_capsule_and_ellipsoid_outlines_are_the_silhouettes() -> None:
    rng = np.random.default_rng(4)
    dirs = np.column_stack([np.cos(a := np.linspace(0, 2 * np.pi, 90)), np.sin(a)])
    sphere = rng.normal(size=(20000, 3))
    sphere /= np.linalg.norm(sphere, axis=1)[:, None]
    for _ in range(5):
        cam = OrthoCamera(float(rng.uniform(-180, 180)), float(rng.uniform(-90, 90)))
        a3, b3, r = rng.normal(size=3), rng.normal(size=3), float(rng.uniform(0.05, 0.5))
        t = np.concatenate([np.zeros((7000, 1)), np.ones((7000, 1)), rng.uniform(size=(6000, 1))])
        body = a3 + t * (b3 - a3) + r * sphere  # points of the capsule's surface (brute force)
        outline = capsule_outlines(cam.project(a3)[None], cam.project(b3)[None], [r], k=181)[0]
        assert np.allclose(_support(outline, dirs), _support(cam.project(body), dirs), atol=5e-3 * r)
        shape = rng.normal(size=(3, 3))
        centre = rng.normal(size=3)
        solid = centre + sphere @ shape.T
        ell = ellipsoid_outline(cam, centre, shape, k=720)
        assert np.allclose(_support(ell, dirs), _support(cam.project(solid), dirs), rtol=2e-3, atol=2e-3)


# --- Fig. 2 and the animation ----------------------------------------------------------------------------
def test_film_strip_draws_the_link_volumes_of_every_strategy_where_the_robot_is(paper_run) -> None:
    frames = 3
    fig = figures.film_strip(paper_run, frames)
    camera = figures._scene(paper_run).camera
    runs = paper_run.trajectories[paper_run.compliance_model]
    assert list(runs) == list(STRATEGIES) and len(fig.axes) == len(runs) * frames
    img = _pixels(fig)
    times = np.linspace(0.0, max(tr.t[-1] for tr in runs.values()), frames)
    for i, (name, tr) in enumerate(runs.items()):
        for c, t in enumerate(times):
            ax = fig.axes[i * frames + c]
            q = tr.q[int(np.argmin(np.abs(tr.t - t)))]
            on = _at(img, ax, camera, _capsule_midpoints(paper_run, q))
            assert _not_white(on).all(), f"{name} at t = {t}: a link is not drawn"
            brace = paper_run.scenario.braced.braces[0]
            inside = brace.surface.point + 0.8 * brace.obstacle_radius * brace.surface.frame[:, 0]
            assert _not_white(_at(img, ax, camera, inside[None])).all()  # the brace surface's top is drawn
            x0, x1 = ax.get_xlim()
            y0, y1 = ax.get_ylim()
            box = ax.transData.transform([[x0, y0], [x1, y1]]).round().astype(int)
            panel = img[img.shape[0] - box[1, 1] : img.shape[0] - box[0, 1], box[0, 0] : box[1, 0]]
            drawn = _not_white(panel).mean()
            assert 0.08 < drawn < 0.9  # the robot and the scene fill the panel, which is not a blot
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"PUMA 560 (joints 1–6)", "HEBI X8-16 modules (joints 7–11)", "bracing region", "task path"} <= set(legend)
    first = [ax for ax in fig.axes[:frames]]
    assert all(ax.get_title() for ax in first)  # a time above every column


def test_film_strip_draws_the_tip_traces_in_the_colour_of_their_strategy(paper_run) -> None:
    from matplotlib.colors import to_rgb

    frames = 2
    fig = figures.film_strip(paper_run, frames)
    img = _pixels(fig).astype(int)
    for i, name in enumerate(STRATEGIES):
        ax = fig.axes[i * frames + frames - 1]  # the last instant: the whole trace
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        box = ax.transData.transform([[x0, y0], [x1, y1]]).round().astype(int)
        panel = img[img.shape[0] - box[1, 1] : img.shape[0] - box[0, 1], box[0, 0] : box[1, 0]]
        want = np.array(to_rgb(figures.COLORS[name])) * 255
        near = np.abs(panel - want).max(axis=-1) < 30
        assert near.sum() > 15, f"no {name} trace"


def test_a_scene_view_made_for_its_samples_draws_what_the_view_for_any_sample_draws(paper_run) -> None:
    """Reference: the same panel drawn by a view with an artist for every possible link piece (pixel equality)."""
    from bracekit.report.figure_common import _new_figure
    from bracekit.report.scene import SceneView

    scene = figures._scene(paper_run)
    for name in STRATEGIES:
        last = paper_run.trajectories[paper_run.compliance_model][name].t.size - 1
        for k in (0, last):
            images, patches = [], []
            for samples in (None, [k]):
                fig = _new_figure(3.0, 3.0)
                ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
                SceneView(ax, scene, name, samples=samples).show(k)
                images.append(_pixels(fig))
                patches.append(ax.patches)
            assert np.array_equal(images[0], images[1]), f"{name} at sample {k}"
            assert all(p.get_visible() for p in patches[1])  # no artist made for a piece it never draws
            assert len(patches[1]) == sum(p.get_visible() for p in patches[0])


def test_animation_shows_every_strategy_side_by_side_frame_by_frame(paper_run, tmp_path: Path) -> None:
    anim = figures.RunAnimation(paper_run, frames=4)
    images = anim.images()
    camera = figures._scene(paper_run).camera
    assert len(images) == 4 and len(anim.views) == 3
    assert [v.name for v in anim.views] == list(STRATEGIES)
    lefts = [v.ax.get_position().x0 for v in anim.views]
    assert lefts == sorted(lefts)  # side by side, in the run's order
    for i, im in enumerate(images):
        img = np.asarray(im)
        for view, k in zip(anim.views, anim.samples(i), strict=True):
            q = paper_run.trajectories[paper_run.compliance_model][view.name].q[k]
            assert _not_white(_at(img, view.ax, camera, _capsule_midpoints(paper_run, q))).all()
    assert not np.array_equal(np.asarray(images[0]), np.asarray(images[-1]))  # the robots move
    path = tmp_path / "animation.gif"
    figures.animate(paper_run, path, frames=4, fps=10)
    with Image.open(path) as gif:
        assert gif.n_frames == 4 and gif.size == images[0].size
        gif.seek(3)
        last = np.asarray(gif.convert("RGB")).astype(int)
    assert np.abs(last - np.asarray(images[-1]).astype(int)).max(axis=-1).mean() < 8  # palette close to RGB


# --- Fig. 3 and Fig. 4 -----------------------------------------------------------------------------------
def test_ellipsoid_figure_has_metric_axes_and_no_overlapping_text(paper_run) -> None:
    points = 3
    fig = figures.ellipsoid_figure(paper_run, points)
    assert len(fig.axes) == 2 * 3  # two views of each strategy
    for ax in fig.axes:
        assert re.fullmatch(r"[xyz] \[m\]", ax.get_xlabel()) and re.fullmatch(r"[xyz] \[m\]", ax.get_ylabel())
        assert len(ax.patches) == 2 * points  # each ellipse filled and outlined
    assert _texts_overlap(fig) == []


def test_ellipses_are_the_projected_compliance_ellipsoids(paper_run) -> None:
    from bracekit.compliance.first_order import compliance_ellipsoids, end_effector_compliance
    from bracekit.compliance.preloaded import simulated_model

    fig = figures.ellipsoid_figure(paper_run, points=2)
    tr = paper_run.trajectories[paper_run.compliance_model]["braced_min_norm"]
    st = paper_run.scenario.braced.state(tr.q[0])
    ell = compliance_ellipsoids(end_effector_compliance(st, simulated_model(paper_run.compliance_model)))
    semi = ell.translational.semi_axes
    ax = fig.axes[1]  # braced minimum norm, first view
    outline = ax.patches[0].get_xy()[:-1]
    scale = float(re.search(r"drawn at ([0-9.]+) m per m/N", fig.get_suptitle()).group(1))
    cam = OrthoCamera(-90.0, 0.0)  # the circle's plane is x–z: the view along y
    shape = ell.translational.axes * semi
    ref = ellipsoid_outline(cam, st.e, scale * shape, k=720)
    dirs = np.column_stack([np.cos(a := np.linspace(0, 2 * np.pi, 60)), np.sin(a)])
    assert np.allclose(_support(outline, dirs), _support(ref, dirs), atol=2e-3 * scale * semi.max() + 1e-4)
    assert MplPath(outline).contains_point(cam.project(st.e))


def test_measures_figure_has_units_on_every_axis_one_shared_legend_and_the_runs_data(paper_run) -> None:
    from bracekit.compliance.first_order import end_effector_compliance
    from bracekit.compliance.preloaded import simulated_model

    fig = figures.measures_figure(paper_run)
    runs = paper_run.trajectories[paper_run.compliance_model]
    assert len(fig.axes) == 4
    units = [re.search(r"\[(.+)\]", ax.get_ylabel()).group(1) for ax in fig.axes]
    assert units == ["m/N", "m³/rad³", "1", "1"]
    assert all(ax.get_xlabel() == "time along the task [s]" for ax in fig.axes[2:])
    assert all(ax.get_legend() is None for ax in fig.axes) and len(fig.legends) == 1
    assert [t.get_text() for t in fig.legends[0].get_texts()] == [figures._label(n) for n in runs]
    for ax, key in zip(fig.axes, ("Ci", "prod_sigma_t", "prod_sigma_o", "k"), strict=True):
        lines = [line for line in ax.get_lines() if line.get_linestyle() == "-"]
        assert len(lines) == len(runs)
        for line, tr in zip(lines, runs.values(), strict=True):
            want = tr.measures[tr.ci_key(paper_run.compliance_model) if key == "Ci" else key]
            assert np.array_equal(line.get_ydata(), want) and np.array_equal(line.get_xdata(), tr.t)
    # panel (a) also draws c_t = β_xᵀC_ttβ_x (dashed), from the run's compliance: checked at a few samples
    assert "mixed units" in fig.axes[0].get_title() and "c_t" in fig.axes[0].get_title()
    dashed = [line for line in fig.axes[0].get_lines() if line.get_linestyle() == "--"]
    assert len(dashed) == len(runs)
    sc = paper_run.scenario
    model = simulated_model(paper_run.compliance_model)
    for line, tr in zip(dashed, runs.values(), strict=True):
        assert np.array_equal(line.get_xdata(), tr.t)
        for i in (0, tr.t.size // 3, tr.t.size - 1):
            st = sc.braced.state(tr.q[i])
            c = end_effector_compliance(st, model) if tr.braced else bk.free_space_compliance(st)
            r = sc.beta_x(float(tr.t[i]))[:3]
            assert line.get_ydata()[i] == pytest.approx(r @ c[:3, :3] @ r / (r @ r), rel=1e-12)
            assert line.get_ydata()[i] < tr.measures[tr.ci_key(paper_run.compliance_model)][i]
    assert _texts_overlap(fig) == []


# --- every shipped scenario ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["paper", "panda", "panda-holding", "two-braces"])
def test_every_shipped_scenario_is_drawn(name: str, tmp_path: Path) -> None:
    result = _short(name, tmp_path, turns=0.02)
    runs = result.trajectories[result.compliance_model]
    camera_scene = figures._scene(result)
    fig = figures.film_strip(result, frames=2)
    assert len(fig.axes) == 2 * len(runs)
    img = _pixels(fig)
    for i, tr in enumerate(runs.values()):
        ax = fig.axes[2 * i + 1]
        on = _at(img, ax, camera_scene.camera, _capsule_midpoints(result, tr.q[-1]))
        assert _not_white(on).all()
    anim = figures.RunAnimation(result, frames=2)
    assert len(anim.images()) == 2
    ell = figures.ellipsoid_figure(result, points=2)
    assert _texts_overlap(ell) == []
    measures = figures.measures_figure(result)
    assert all(re.search(r"\[.+\]", ax.get_ylabel()) for ax in measures.axes)
    if figures.has_capacity(result):
        cap = figures.capacity_figure(result)
        assert all(re.search(r"\[.+\]", ax.get_ylabel()) for ax in cap.axes) and len(cap.legends) == 1
        assert _texts_overlap(cap) == []
    assert (name == "panda-holding") == figures.has_capacity(result)


def test_a_run_that_stopped_early_and_a_single_strategy_are_drawn(paper_run) -> None:
    import dataclasses

    model = paper_run.compliance_model
    runs = dict(paper_run.trajectories[model])
    tr = runs["braced_min_norm"]
    cut = tr.t.size // 2
    runs["braced_min_norm"] = dataclasses.replace(
        tr, t=tr.t[:cut], q=tr.q[:cut], measures={k: v[:cut] for k, v in tr.measures.items()}, completed=False
    )
    stopped = dataclasses.replace(paper_run, trajectories={**paper_run.trajectories, model: runs})
    fig = figures.film_strip(stopped, frames=3)
    notes = [t.get_text() for ax in fig.axes for t in ax.texts if t.get_text().startswith("run stopped")]
    times = np.linspace(0.0, tr.t[-1], 3)
    after = int(np.sum(times > tr.t[cut - 1] + 0.05))  # instants after the stop (dt = 0.1 s)
    assert after >= 1 and notes == [f"run stopped at t = {tr.t[cut - 1]:.1f} s"] * after
    anim = figures.RunAnimation(stopped, frames=3)
    assert anim.samples(2)[1] == cut - 1 and len(anim.images()) == 3
    single = dataclasses.replace(paper_run, trajectories={model: {"braced_min_norm": tr}})
    assert len(figures.film_strip(single, frames=2).axes) == 2
    assert len(figures.RunAnimation(single, frames=2).views) == 1
    assert len(figures.ellipsoid_figure(single, points=2).axes) == 2
    assert len(figures.measures_figure(single).legends[0].get_texts()) == 1


# --- the animation drawn beside the figures --------------------------------------------------------------
def test_the_animation_drawn_in_a_child_process_is_the_one_drawn_in_process(paper_run, tmp_path: Path, monkeypatch):
    from bracekit.report import forked, write_run

    written = write_run(paper_run, tmp_path / "out")
    assert [p.name for p in written][len(run_files(False)) :] == figures.figure_files(paper_run)
    reference = tmp_path / "reference.gif"
    figures.animate(paper_run, reference)
    assert (tmp_path / "out" / "animation.gif").read_bytes() == reference.read_bytes()
    monkeypatch.setattr(forked, "available", lambda: False)  # one process: the same files
    names = []
    paths = figures.write_figures(paper_run, tmp_path, progress=names.append)
    assert names == figures.figure_files(paper_run) and all(p.stat().st_size > 0 for p in paths)
    assert (tmp_path / "animation.gif").read_bytes() == reference.read_bytes()


@pytest.mark.parametrize(
    ("error", "kind"), [(RuntimeError("no frames"), bk.BracekitError), (OSError(28, "full"), None)]
)
def test_a_failure_in_the_child_is_raised_and_nothing_is_written(paper_run, tmp_path: Path, monkeypatch, error, kind):
    from bracekit.errors import OutputError
    from bracekit.report import forked, write_run

    if not forked.available():
        pytest.skip("no fork or a single core here: the animation is drawn in process")

    def boom(*_a, **_k):
        raise error

    monkeypatch.setattr(figures, "animate", boom)
    want = kind or OutputError
    with pytest.raises(want, match=r"animation\.gif") as info:
        write_run(paper_run, tmp_path / "never")
    assert type(error).__name__ in str(info.value)
    assert not (tmp_path / "never").exists() and list(tmp_path.iterdir()) == []


def test_a_child_no_longer_wanted_is_stopped(tmp_path: Path) -> None:
    import os
    import time

    from bracekit.report import forked

    if not forked.available():
        pytest.skip("no fork or a single core here")
    job = forked.ForkedJob(lambda: time.sleep(60), "nothing")
    pid = job.pid
    start = time.perf_counter()
    job.stop()
    assert time.perf_counter() - start < 5 and job.pid is None
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, os.WNOHANG)  # reaped
