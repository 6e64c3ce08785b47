"""Figures 2–4 of the paper and the animation of the gradient-projection run (matplotlib, Agg)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation
from mpl_toolkits.mplot3d import Axes3D
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from numpy.typing import NDArray

from bracekit.compliance.first_order import compliance_ellipsoids, end_effector_compliance, free_space_compliance
from bracekit.compliance.preloaded import loaded_free_space_compliance, preloaded_compliance, simulated_model
from bracekit.kinematics import BracedState, skeleton
from bracekit.report.table import STRATEGY_LABELS

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult
    from bracekit.simulation.simulate import Trajectory

Array = NDArray[np.float64]
COLORS = {"free_space_min_norm": "tab:red", "braced_min_norm": "tab:blue", "braced_gradient_projection": "tab:green"}


def _circle(centre: Array, normal: Array, radius: float, start: Array | None = None, k: int = 100) -> Array:
    n = normal / np.linalg.norm(normal)
    u = start if start is not None else (np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0]))
    u = u - n * (n @ u)
    u /= np.linalg.norm(u)
    w = np.cross(n, u)
    a = np.linspace(0, 2 * np.pi, k)
    return centre + radius * (np.outer(np.cos(a), u) + np.outer(np.sin(a), w))


def _scene(ax: Axes3D, result: RunResult) -> None:
    """Bracing region of each brace (blue, on its surface) and task path (black)."""
    sc = result.scenario
    for i, brace in enumerate(sc.braced.braces):
        r_max = brace.region_radius or 0.15
        reg = _circle(brace.surface.point, brace.surface.normal, r_max)
        ax.add_collection3d(Poly3DCollection([reg], facecolor="tab:blue", alpha=0.15, edgecolor="none"))
        label = f"bracing region (r_max = {r_max:.2f} m)" if i == 0 else None
        ax.plot(*reg.T, color="tab:blue", lw=1.5, label=label)
    ts = np.linspace(0.0, sc.task.duration, 200)
    path = np.array([sc.task.position(t) for t in ts])
    ax.plot(*path.T, color="k", lw=1.5, label="task")


def _equal(ax: Axes3D, pts: Array) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    c, r = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 0.05) * 1.05
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")


def _draw_robot(ax: Axes3D, result: RunResult, q: Array, color: str = "0.25", alpha: float = 1.0) -> list:
    robot = result.scenario.robot
    pts = skeleton(robot, q)
    arts = ax.plot(*pts.T, "-o", color=color, ms=2.5, lw=2, alpha=alpha)
    for b in _brace_points(result, q):
        arts += ax.plot(*b, "o", color="tab:orange", ms=5, alpha=alpha)
    return arts


def _state(result: RunResult, q: Array) -> Any:
    """The braced state at q: the one-brace BracedState, or the stacked state of several braces."""
    braced = result.scenario.braced
    return braced.stacked_state(q) if len(braced.braces) > 1 else braced.state(q)


def _brace_points(result: RunResult, q: Array) -> list[Array]:
    """Each {b_i} (3,) at q."""
    st = _state(result, q)
    return list(st.b_i) if len(result.scenario.braced.braces) > 1 else [st.b]


def _all_points(result: RunResult, tr: Trajectory, stride: int = 10) -> Array:
    robot = result.scenario.robot
    pts = [skeleton(robot, q) for q in tr.q[::stride]]
    return np.vstack(pts)


def figure_film_strip(result: RunResult, path: Path, frames: int = 5) -> None:
    """Fig. 2: film strip of the gradient-projection run with the bracing region and the task."""
    tr = _main_run(result)
    idx = np.linspace(0, tr.q.shape[0] - 1, frames).astype(int)
    pts = _all_points(result, tr)
    fig = plt.figure(figsize=(4.0 * frames, 4.6))
    for i, k in enumerate(idx):
        ax = fig.add_subplot(1, frames, i + 1, projection="3d")
        _scene(ax, result)
        _draw_robot(ax, result, tr.q[k])
        _equal(ax, pts)
        ax.view_init(elev=20, azim=-60)
        ax.set_title(f"t = {tr.t[k]:.1f} s")
        if i == 0:
            ax.legend(loc="upper left", fontsize=7)
    fig.suptitle(
        f"Fig. 2: {STRATEGY_LABELS[tr.strategy]} ({_model_of(result, tr)} compliance), orange: bracing point b"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _tip_compliance(result: RunResult, st: BracedState, braced: bool) -> Array:
    """The tip compliance (6×6) of the run's model at a state (free space for the unbraced run)."""
    model = result.compliance_model
    if model == "preloaded":
        h = result.scenario.holding
        if braced:
            return preloaded_compliance(st.braced, st.q, h.preload, gravity=h.gravity)
        return loaded_free_space_compliance(st.braced, st.q, gravity=h.gravity)
    return end_effector_compliance(st, simulated_model(model)) if braced else free_space_compliance(st)


def _model_of(result: RunResult, tr: Trajectory) -> str:
    return result.compliance_model if tr.braced else "free-space"


def _main_run(result: RunResult) -> Trajectory:
    runs = result.trajectories[result.compliance_model]
    return runs.get("braced_gradient_projection") or next(iter(runs.values()))


def _ellipsoid_mesh(centre: Array, axes: Array, semi: Array, scale: float, k: int = 16) -> tuple[Array, Array, Array]:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, k), np.linspace(0, np.pi, k // 2))
    sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    pts = centre + scale * (sphere * semi) @ axes.T
    return pts[..., 0], pts[..., 1], pts[..., 2]


def figure_ellipsoids(result: RunResult, path: Path, points: int = 6) -> None:
    """Fig. 3: translational compliance ellipsoids at representative points, one panel per strategy."""
    runs = result.trajectories[result.compliance_model]
    semis = []
    cases = []
    for name, tr in runs.items():
        idx = np.linspace(0, tr.q.shape[0] - 1, points + 1).astype(int)[:-1]
        items = []
        for k in idx:
            st = _state(result, tr.q[k])
            c = _tip_compliance(result, st, tr.braced)
            ell = compliance_ellipsoids(c).translational
            items.append((st.e, ell))
            semis.append(ell.semi_axes.max())
        cases.append((name, items))
    radius = getattr(result.scenario.task, "radius", 0.1)
    scale = 0.5 * radius / max(semis)
    fig = plt.figure(figsize=(5.0 * len(cases), 5.0))
    for i, (name, items) in enumerate(cases):
        ax = fig.add_subplot(1, len(cases), i + 1, projection="3d")
        ts = np.linspace(0.0, result.scenario.task.duration, 200)
        path_pts = np.array([result.scenario.task.position(t) for t in ts])
        ax.plot(*path_pts.T, color="k", lw=1)
        for e, ell in items:
            ax.plot_wireframe(
                *_ellipsoid_mesh(e, ell.axes, ell.semi_axes, scale), color=COLORS.get(name, "C0"), lw=0.4, alpha=0.8
            )
        _equal(ax, np.vstack([path_pts, path_pts.mean(axis=0) + 1.3 * (path_pts - path_pts.mean(axis=0))]))
        ax.view_init(elev=15, azim=-80)
        ax.set_title(f"({'abc'[i]}) {STRATEGY_LABELS.get(name, name)}", fontsize=10)
    fig.suptitle(
        f"Fig. 3: translational compliance ellipsoids along the task (semi-axes = eigenvalues of C_e's force block, "
        f"drawn at {scale:.1f} m per m/N; {result.compliance_model} model)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def figure_measures(result: RunResult, path: Path) -> None:
    """Fig. 4: C_i, Πσ_t, Πσ_o and k of J̃ along the task for the three strategies."""
    runs = result.trajectories[result.compliance_model]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    panels = [
        ("Ci", "(a) compliance index C_i [m/N]"),
        ("prod_sigma_t", "(b) Πσ_t of J̃ (translational)"),
        ("prod_sigma_o", "(c) Πσ_o of J̃ (rotational)"),
        ("k", "(d) Frobenius condition number k of J̃"),
    ]
    for ax, (key, title) in zip(axes.flat, panels, strict=True):
        for name, tr in runs.items():
            y = tr.measures[tr.ci_key(result.compliance_model)] if key == "Ci" else tr.measures[key]
            ax.plot(tr.t, y, color=COLORS.get(name), label=STRATEGY_LABELS.get(name, name))
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("time along the task [s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"Fig. 4: measures along the task ({result.compliance_model} compliance model for the braced runs)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def has_capacity(result: RunResult) -> bool:
    """Whether the run computed statics (gravity, a preload or tool loads): then it has a capacity figure."""
    return any("torque_ratio" in tr.measures for runs in result.trajectories.values() for tr in runs.values())


def figure_capacity(result: RunResult, path: Path) -> None:
    """Capacity along the task: the load margins of each braced run and the peak |τ_i|/effort_i of every run.

    Margins are scales of the listed tool wrenches (> 1: the brace holds the listed load), on a log axis clipped
    to [0.01, 100]; the dashed line is 1. Margins beyond 100 (or infinite: nothing limits the load) are drawn at
    the top of the axis.
    """
    runs = result.trajectories[result.compliance_model]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    panels = [
        ("liftoff_margin", "(a) lift-off margin (scale of the listed load)"),
        ("slip_margin", "(b) slip margin (scale of the listed load)"),
        ("torque_margin", "(c) actuator margin (scale of the listed load)"),
        ("torque_ratio", "(d) peak |τ_i| / effort_i, no tool load"),
    ]
    for ax, (key, title) in zip(axes.flat, panels, strict=True):
        margin = key != "torque_ratio"
        for name, tr in runs.items():
            if key not in tr.measures:
                continue
            y = np.clip(tr.measures[key], 1e-2, 1e2) if margin else tr.measures[key]
            ax.plot(tr.t, y, color=COLORS.get(name), label=STRATEGY_LABELS.get(name, name))
        ax.axhline(1.0, color="0.3", linestyle="--", linewidth=0.8)
        if margin:
            ax.set_yscale("log")
            ax.set_ylim(1e-2, 1.2e2)
        else:
            ax.set_ylim(0.0, max(1.2, *(float(np.max(tr.measures[key])) * 1.1 for tr in runs.values())))
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("time along the task [s]")
    axes[1, 1].legend(fontsize=8)
    h = result.scenario.holding
    mu = "frictionless" if h.friction is None else f"μ = {h.friction:g}"
    fig.suptitle(
        f"Brace capacity along the task: gravity {'on' if h.gravity else 'off'}, preload {h.preload:g} N, {mu}, "
        f"{0 if h.wrenches is None else len(h.wrenches)} listed tool wrench(es)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def animate(result: RunResult, path: Path, frames: int = 60, fps: int = 12) -> None:
    """The gradient-projection run as an animated GIF (Pillow writer)."""
    tr = _main_run(result)
    idx = np.linspace(0, tr.q.shape[0] - 1, min(frames, tr.q.shape[0])).astype(int)
    pts = _all_points(result, tr)
    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="3d")
    arts: list = []

    def draw(i: int) -> list:
        for a in arts:
            a.remove()
        arts.clear()
        arts.extend(_draw_robot(ax, result, tr.q[idx[i]]))
        ax.set_title(f"{STRATEGY_LABELS[tr.strategy]}  t = {tr.t[idx[i]]:.1f} s")
        return arts

    _scene(ax, result)
    _equal(ax, pts)
    ax.view_init(elev=20, azim=-60)
    ax.legend(loc="upper left", fontsize=7)
    anim = animation.FuncAnimation(fig, draw, frames=len(idx), blit=False)
    anim.save(str(path), writer=animation.PillowWriter(fps=fps))
    plt.close(fig)
