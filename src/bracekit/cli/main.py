"""The command line: a thin layer over the public API. Input errors exit with 2, numerical ones with 1."""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

from bracekit._version import __version__
from bracekit.cli import sweep as sweep_cli
from bracekit.cli import view as view_cli
from bracekit.errors import BracekitError, InputError, MissingDependencyError

LIST_OPTIONS = ("--q", "--stiffness", "--normal", "--beta-x", "--brace-offset", "--first-normal", "--second-normal")
OUT_HELP = (
    "checked before any computation and written whole: a previous bracekit output there is replaced, "
    "a folder holding other files is refused"
)
OVERWRITE_HELP = (
    "write into an --out that holds files bracekit did not write: bracekit's earlier files there are replaced, "
    "the other files are kept (never deleted or replaced)"
)


def _floats(text: str, what: str) -> np.ndarray:
    parts = [p for p in text.replace(" ", "").split(",") if p != ""]
    if not parts:
        raise InputError(f"{what} is empty; give comma-separated numbers, e.g. {what} 0.1,-0.2")
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise InputError(f"{what} must be comma-separated numbers, got '{text}'") from None
    if not np.all(np.isfinite(values)):
        raise InputError(f"{what} must be finite numbers, got '{text}'")
    return values


def _join_negative(argv: Sequence[str]) -> list[str]:
    """Let `--q -0.5,1.2` work: argparse would take '-0.5,1.2' for an option."""
    out: list[str] = []
    it = iter(range(len(argv)))
    for i in it:
        tok = argv[i]
        if tok in LIST_OPTIONS and i + 1 < len(argv) and argv[i + 1].startswith("-") and len(argv[i + 1]) > 1:
            nxt = argv[i + 1]
            if nxt[1].isdigit() or nxt[1] == ".":
                out.append(f"{tok}={nxt}")
                next(it, None)
                continue
        out.append(tok)
    return out


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> Any:  # one line, exit 2
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def contact_registry() -> tuple[str, ...]:
    """The names of the registered contact types (the choices of --contact)."""
    from bracekit.contact import REGISTRY

    return tuple(REGISTRY)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of `bracekit`."""
    p = _Parser(prog="bracekit", description="Braced serial robots: kinematics, compliance, redundancy resolution.")
    p.add_argument("--version", action="version", version=f"bracekit {__version__}")
    sub = p.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")

    ev = sub.add_parser("evaluate", help="the braced model at one configuration")
    src = ev.add_mutually_exclusive_group(required=True)
    src.add_argument("--urdf", type=Path, help="URDF file of the robot")
    src.add_argument("--model", help="a shipped robot: paper-robot, puma560 or panda")
    ev.add_argument(
        "--brace",
        action="append",
        help="bracing frame {b} (a frame of the model; default: the model's own); repeat for several braces",
    )
    ev.add_argument(
        "--brace-link",
        action="append",
        help="place {b} on this link instead, at --brace-offset (named --brace or brace_point); repeat for several",
    )
    ev.add_argument(
        "--brace-offset",
        action="append",
        help="offset of {b} in the link frame, m (with --brace-link; default 0,0,0; one per --brace-link)",
    )
    ev.add_argument("--tip", help="end-effector frame {e} (default: the model's own)")
    ev.add_argument("--q", required=True, help="joint values in chain order, base to tip: Q1,...,Qn (rad)")
    ev.add_argument("--stiffness", default="170", help="joint stiffness K or K1,...,Kn in N·m/rad (default 170)")
    ev.add_argument(
        "--normal",
        action="append",
        help="surface normal NX,NY,NZ (world), the surface passes through b (default 0,0,1); one per brace, in order",
    )
    ev.add_argument("--contact", default="frictionless_point", help=" | ".join(contact_registry()))
    ev.add_argument(
        "--beta-x", help="unit twist for the compliance index, 6 numbers (default: along the (first brace's) normal)"
    )
    ev.add_argument("--gravity", action="store_true", help="statics with gravity (URDF masses)")
    ev.add_argument("--preload", default="0", help="normal force the brace presses with, N (default 0)")
    ev.add_argument("--friction", help="friction coefficient μ of the contact (default: frictionless)")
    ev.add_argument(
        "--wrench",
        action="append",
        help="a tool wrench FX,FY,FZ,MX,MY,MZ to check (N, N·m, world axes; repeat for several)",
    )
    ev.add_argument("--json", action="store_true", help="print one JSON object (SI units)")

    st = sub.add_parser("study", help="where to brace: tip compliance for bracing points along the robot")
    src2 = st.add_mutually_exclusive_group(required=True)
    src2.add_argument("--urdf", type=Path, help="URDF file of the robot")
    src2.add_argument("--model", help="a shipped robot: paper-robot, puma560 or panda")
    st.add_argument("--tip", help="end-effector frame {e} (default: the model's own)")
    st.add_argument("--q", required=True, help="joint values in chain order: Q1,...,Qn (rad)")
    st.add_argument("--stiffness", default="170", help="joint stiffness K or K1,...,Kn in N·m/rad (default 170)")
    st.add_argument("--normal", help="surface normal NX,NY,NZ; the surface passes through each point (default 0,0,1)")
    st.add_argument("--beta-x", help="unit twist for the compliance index, 6 numbers (default: along the normal)")
    st.add_argument("--points-per-link", type=int, default=3, help="candidates per link (default 3)")
    st.add_argument(
        "--first-brace",
        help="rank second bracing points with this frame braced first (e.g. brace); C_i of both braces stacked",
    )
    st.add_argument("--first-normal", help="with --first-brace: normal of the first brace's surface (default 0,0,1)")
    st.add_argument(
        "--second-normal",
        help="with --first-brace: normal of each candidate's surface, through the point (default: the first normal)",
    )
    st.add_argument("--json", action="store_true", help="print one JSON object")

    run = sub.add_parser("run", help="run a scenario: Table I, Figures 2-4 and the animation")
    run.add_argument("scenario", help="a scenario TOML file or a shipped name (paper)")
    run.add_argument(
        "--out", type=Path, default=Path("bracekit-out"), help=f"output folder (default bracekit-out); {OUT_HELP}"
    )
    run.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    run.add_argument("--gradient", choices=("analytic", "finite-difference"), help="how ∇g is computed")
    run.add_argument(
        "--compliance-model",
        choices=("constrained", "projection", "preloaded"),
        help="model of summary.json (preloaded: with gravity or a preload, C_i of the preloaded compliance)",
    )
    run.add_argument("--no-figures", action="store_true", help="write the table, summary and trajectories only")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    view_cli.add_run_flags(run)

    va = sub.add_parser("validate", help="check the compliance models against MuJoCo and a nonlinear static solve")
    va.add_argument("scenario", nargs="?", default="paper", help="scenario file or shipped name (default paper)")
    va.add_argument("--configs", type=int, default=3, help="number of configurations along the path (default 3)")
    va.add_argument(
        "--tracking-points",
        type=int,
        default=5,
        help="check points per strategy of the dynamic tracking check in MuJoCo (default 5; 0: skip it)",
    )
    va.add_argument("--json", action="store_true", help="print one JSON object")
    va.add_argument(
        "--out", type=Path, help=f"also write validation.json and validation.png into this folder; {OUT_HELP}"
    )
    va.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)

    be = sub.add_parser("bench", help="measure the speed of the hot paths")
    be.add_argument("--json", action="store_true", help="print one JSON object")
    be.add_argument("--quick", action="store_true", help="fewer repetitions")
    be.add_argument(
        "--only",
        action="append",
        choices=("core", "sweep", "figures", "qp"),
        help="run only this part (repeat for several; default all: core hot paths, sweep throughput on 1 and 2 "
        "Dask workers, the figures' overhead, the braced_qp and bracekit.pink steps)",
    )
    sweep_cli.add_parser(sub)
    view_cli.add_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `bracekit` console script; returns the exit code."""
    args_list = _join_negative(list(sys.argv[1:] if argv is None else argv))
    parser = build_parser()
    args = parser.parse_args(args_list)
    if args.command is None:
        parser.print_help()
        return 2

    def show(message: Any, category: type[Warning], *_: Any, **__: Any) -> None:
        print(f"bracekit: warning: {message}", file=sys.stderr)

    saved = warnings.showwarning
    warnings.showwarning = show
    try:
        return _dispatch(args)
    except InputError as exc:
        print(f"bracekit: error: {_as_cli(str(exc))}", file=sys.stderr)
        return 2
    except BracekitError as exc:
        print(f"bracekit: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("bracekit: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. piped into head
        sys.stderr.close()
        return 0
    finally:
        warnings.showwarning = saved


def _as_cli(message: str) -> str:
    """A library message in the command line's words (its argument names become the flags)."""
    return (
        message.replace("overwrite=True", "--overwrite")
        .replace("another output folder", "another --out")
        .replace("points_per_link", "--points-per-link")
    )


def _dispatch(args: argparse.Namespace) -> int:
    commands = {"evaluate": _evaluate, "run": _run, "validate": _validate, "study": _study, "bench": _bench}
    commands["sweep"] = sweep_cli.run
    commands["view"] = view_cli.run
    return commands[args.command](args)


def _needs(module: str, extra: str, what: str) -> None:
    """MissingDependencyError unless `module` can be imported (an optional extra of bracekit)."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise MissingDependencyError(f"{what} needs {module}, which is not installed: pip install 'bracekit[{extra}]'")


# --- evaluate ------------------------------------------------------------------------------------
def _load_robot(args: argparse.Namespace) -> tuple[Any, str | None]:
    """The robot of --model or --urdf/--tip with --stiffness, and the model's own bracing frame."""
    from bracekit.model.robot import Robot
    from bracekit.model.shipped import MODELS, default_brace_frame, load_model

    stiffness = _floats(args.stiffness, "--stiffness")
    k: float | np.ndarray = float(stiffness[0]) if stiffness.size == 1 else stiffness
    if args.model is not None:
        if args.model not in MODELS:
            raise InputError(f"unknown model '{args.model}'; choose one of {', '.join(MODELS)}")
        return load_model(args.model, stiffness=k, tip=args.tip), default_brace_frame(args.model)
    if args.tip is None:
        raise InputError("--tip is needed with --urdf: name the end-effector frame")
    return Robot.from_urdf(args.urdf, tip=args.tip, stiffness=k), None


def _evaluate(args: argparse.Namespace) -> int:
    from bracekit.studies.evaluate import evaluate

    robot, own_brace = _load_robot(args)
    robot, frames = _brace_frames(args, robot, own_brace)
    normals = args.normal or ["0,0,1"]
    if len(frames) > 1 and args.normal is not None and len(normals) != len(frames):
        raise InputError(
            f"give one --normal per brace, in the order of the braces: {len(frames)} braces, {len(normals)} --normal"
        )
    if len(frames) == 1 and len(normals) > 1:
        raise InputError(f"give one --normal for the one brace, got {len(normals)}")
    q = _floats(args.q, "--q")
    beta = None if args.beta_x is None else _floats(args.beta_x, "--beta-x")
    holding = _holding(args)
    if len(frames) > 1 and holding is not None:
        raise InputError(
            "--gravity, --preload, --friction and --wrench (statics) are supported for one brace only; give one --brace"
        )
    if len(frames) == 1:
        normal = _floats(normals[0], "--normal")
        report = evaluate(robot, frames[0], q, normal=normal, contact=args.contact, beta_x=beta, holding=holding)
    else:
        vectors = [_floats(n, "--normal") for n in normals]
        if any(v.size != 3 for v in vectors):
            raise InputError("--normal needs 3 numbers NX,NY,NZ (world)")
        report = evaluate(
            robot,
            frames,
            q,
            normal=np.array(vectors) if len(vectors) > 1 else vectors[0],
            contact=args.contact,
            beta_x=beta,
        )
    if args.json:
        from bracekit.report.output import to_json

        print(to_json(report))
    else:
        print(_evaluate_text(report) if len(frames) == 1 else _evaluate_braces_text(report))
    return 0


def _one(text: str, what: str) -> float:
    """The single number of a flag; InputError for a list."""
    values = _floats(text, what)
    if values.size != 1:
        raise InputError(f"{what} takes one number, got {values.size} ('{text}')")
    return float(values[0])


def _brace_frames(args: argparse.Namespace, robot: Any, own_brace: str | None) -> tuple[Any, list[str]]:
    """The robot (with the link-point frames of --brace-link added) and the bracing frames, in order.

    Without --brace-link, each --brace is a frame of the model. With it, each --brace-link places a point at
    its --brace-offset (0,0,0 when no --brace-offset is given), named by the --brace in the same position, or
    brace_point, brace_point_2, ….
    """
    names = args.brace or []
    if args.brace_link is None:
        if not names and own_brace is None:
            raise InputError("name the bracing frame with --brace FRAME (or --brace-link LINK --brace-offset X,Y,Z)")
        return robot, names or [own_brace]
    links = args.brace_link
    offsets = args.brace_offset or ["0,0,0"] * len(links)
    if len(offsets) != len(links):
        raise InputError(
            f"give one --brace-offset per --brace-link, in the same order: {len(links)} --brace-link, "
            f"{len(offsets)} --brace-offset"
        )
    if names and len(names) != len(links):
        raise InputError(
            f"with --brace-link, each --brace names one link point: {len(links)} --brace-link, {len(names)} --brace"
        )
    names = names or ["brace_point" if i == 1 else f"brace_point_{i}" for i in range(1, len(links) + 1)]
    if len(links) == 1:
        return robot.with_point_frame(names[0], links[0], _floats(offsets[0], "--brace-offset")), names
    frames = [(n, link, _floats(o, "--brace-offset"), None) for n, link, o in zip(names, links, offsets, strict=True)]
    return robot.with_point_frames(frames), names


def _holding(args: argparse.Namespace) -> Any:
    """The statics of --gravity, --preload, --friction and --wrench (None when none is given)."""
    from bracekit.simulation.holding import Holding

    preload = _one(args.preload, "--preload")
    friction = None if args.friction is None else _one(args.friction, "--friction")
    wrenches = None if not args.wrench else np.array([_floats(w, "--wrench") for w in args.wrench], dtype=object)
    if wrenches is not None:
        if any(np.size(w) != 6 for w in wrenches):
            raise InputError("--wrench needs 6 numbers FX,FY,FZ,MX,MY,MZ (N, N·m, world axes)")
        wrenches = np.array([np.asarray(w, dtype=float) for w in wrenches])
    holding = Holding(gravity=bool(args.gravity), preload=preload, friction=friction, wrenches=wrenches)
    return holding if holding.active else None


def _scale(x: float | None) -> str:
    return "∞" if x is None else f"{x:.3g}"


def _statics_text(r: dict[str, Any]) -> str:
    """The statics lines of evaluate's text output."""
    mu = "frictionless" if r["friction"] is None else f"μ = {r['friction']:g}"
    lines = [
        f"statics: gravity {'on' if r['gravity'] else 'off'}, preload {r['preload_N']:g} N, {mu}; "
        f"peak |τ|/effort unloaded {r['torque_ratio']:.3f}",
        "τ0 [N·m] = " + ", ".join(f"{t:.3g}" for t in r["tau0"]),
    ]
    if "Ci_preloaded" in r:
        lines.append(
            f"C_i preloaded = {1e3 * r['Ci_preloaded']:.4f} mm/N (constrained {1e3 * r['Ci_constrained']:.4f})"
        )
    if "wrenches" in r:
        lines.append("largest scale of each tool wrench before the brace lifts off, slips or an actuator saturates:")
        slip = r["slip"] or [None] * len(r["liftoff"])
        for w, a, b, c in zip(r["wrenches"], r["liftoff"], slip, r["torque"], strict=True):
            sl = _scale(b) if r["slip"] else "– (no friction given)"
            lines.append(f"  {np.round(w, 3).tolist()}: lift-off {_scale(a)}, slip {sl}, torque {_scale(c)}")
    return "\n".join(lines)


def _evaluate_braces_text(r: dict[str, Any]) -> str:
    """The text output of evaluate for several braces (the constrained model)."""
    lines = [f"robot: {r['n']} joints, tip '{r['tip_frame']}', {len(r['braces'])} braces:"]
    for i, b in enumerate(r["braces"], start=1):
        lines.append(
            f"  {i}. {{b}} '{b['frame']}' at {np.round(b['b'], 4).tolist()} m, normal "
            f"{np.round(b['normal'], 3).tolist()}, {b['contact']}"
        )
    dependent = r["G_dependent_rows"]
    lines += [
        f"stacked constraint G: {len(r['G_rows'])} rows, rank {r['G_rank']}, {r['n'] - r['G_rank']} braced motions"
        + (f"; dependent rows {dependent} dropped" if dependent else ""),
        f"e = {np.round(r['e'], 4).tolist()} m",
        f"k (free-space J) = {r['k']:.3f}, k (braced J_e N) = "
        + ("singular" if r["k_braced"] is None else f"{r['k_braced']:.3f}"),
        "",
        "translational compliance ellipsoid (semi-axes in mm/N along world unit axes):",
    ]
    for label, key in (("free space", "ellipsoid_free"), ("braced, constrained", "ellipsoid_constrained")):
        ell = r[key]["translational"]
        axes = ", ".join(
            f"{1e3 * s:.3f} along {np.round(a, 3).tolist()}"
            for s, a in zip(ell["semi_axes"], np.array(ell["axes"]).T, strict=True)
        )
        lines.append(f"  {label:<20} {axes}")
    lines += [
        "",
        f"compliance index C_i along β_x = {np.round(r['beta_x'], 3).tolist()}:",
        f"  free space {1e3 * r['Ci_free']:.4f} mm/N, braced constrained {1e3 * r['Ci_constrained']:.4f} mm/N "
        f"({_pct(r['Ci_reduction_constrained'])} less); no projection model: {r['projection_reason']}",
        f"  largest translational compliance: free {1e3 * r['max_translational_free']:.4f} mm/N → braced "
        f"{1e3 * r['max_translational_constrained']:.4f} mm/N (constrained)",
    ]
    return "\n".join(lines)


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def _evaluate_text(r: dict[str, Any]) -> str:
    lines = [
        f"robot: {r['n']} joints, chain 1 = {r['n1']} (base → {{b}} '{r['brace_frame']}'), chain 2 = {r['n2']} "
        f"(→ tip '{r['tip_frame']}'); contact {r['contact']}",
        f"b = {np.round(r['b'], 4).tolist()} m, e = {np.round(r['e'], 4).tolist()} m, "
        f"θ_z = {np.degrees(r['theta_z']):.2f}°",
        f"k (free-space J) = {r['k']:.3f}, k (braced J̃) = {r['k_braced']:.3f}",
        f"chain 1: {r['braced_motions']} braced motions of {{b}}"
        + (
            "; J1 is singular (cond = "
            + ("inf" if r["J1_condition"] is None else f"{r['J1_condition']:.3g}")
            + "): A assumes motions chain 1 cannot make"
            if r["J1_singular"]
            else ""
        ),
        "",
        "translational compliance ellipsoid (semi-axes in mm/N along world unit axes):",
    ]
    for label, key in (
        ("free space", "ellipsoid_free"),
        ("braced, constrained", "ellipsoid_constrained"),
        ("braced, projection", "ellipsoid_projection"),
    ):
        ell = r[key]["translational"]
        axes = ", ".join(
            f"{1e3 * s:.3f} along {np.round(a, 3).tolist()}"
            for s, a in zip(ell["semi_axes"], np.array(ell["axes"]).T, strict=True)
        )
        lines.append(f"  {label:<20} {axes}")
    lines += [
        "",
        f"compliance index C_i along β_x = {np.round(r['beta_x'], 3).tolist()}:",
        f"  free space {1e3 * r['Ci_free']:.4f} mm/N, braced constrained {1e3 * r['Ci_constrained']:.4f} mm/N "
        f"({_pct(r['Ci_reduction_constrained'])} less), braced projection {1e3 * r['Ci_projection']:.4f} mm/N "
        f"({_pct(r['Ci_reduction_projection'])} less)",
        f"  largest translational compliance: free {1e3 * r['max_translational_free']:.4f} mm/N → braced "
        f"{1e3 * r['max_translational_constrained']:.4f} mm/N (constrained)",
    ]
    if "tau0" in r:
        lines += ["", _statics_text(r)]
    return "\n".join(lines)


# --- study ---------------------------------------------------------------------------------------
def _study(args: argparse.Namespace) -> int:
    from bracekit.report.output import to_json
    from bracekit.studies.brace_location import brace_location_study

    if args.first_brace is not None:
        return _study_pairs(args)
    for flag, value in (("--first-normal", args.first_normal), ("--second-normal", args.second_normal)):
        if value is not None:
            raise InputError(f"{flag} needs --first-brace FRAME (the brace the second points are added to)")
    robot, _ = _load_robot(args)
    beta = None if args.beta_x is None else _floats(args.beta_x, "--beta-x")
    cands = brace_location_study(
        robot,
        _floats(args.q, "--q"),
        normal=_floats("0,0,1" if args.normal is None else args.normal, "--normal"),
        beta_x=beta,
        points_per_link=args.points_per_link,
    )
    if args.json:
        print(to_json({"candidates": [c.__dict__ | {"reduction": c.reduction} for c in cands]}))
        return 0
    print("bracing candidates, best first (C_i in mm/N; k of J̃; fraction along the link to the next joint)")
    head = f"{'link':>10} {'n1':>3} {'frac':>5}  {'point [m]':<26} {'free':>8} {'constr.':>8} {'proj.':>8}"
    print(head + f" {'less':>7} {'k(J̃)':>8}")
    for c in cands:
        k = "singular" if c.k_braced is None else f"{c.k_braced:8.2f}"
        note = "  (no load: chain 1 cannot push b)" if c.unloaded else ""
        print(
            f"{c.link:>10} {c.n1:>3} {c.fraction:5.2f}  {np.round(c.point, 3).tolist()!s:<26} "
            f"{1e3 * c.Ci_free:8.3f} {1e3 * c.Ci_constrained:8.3f} {1e3 * c.Ci_projection:8.3f} "
            f"{_pct(c.reduction):>7} {k:>8}{note}"
        )
    return 0


def _study_pairs(args: argparse.Namespace) -> int:
    """`bracekit study --first-brace FRAME`: second bracing points ranked with the first brace fixed."""
    from bracekit.report.output import to_json
    from bracekit.studies.brace_location import brace_pair_study

    if args.normal is not None:
        raise InputError(
            "--normal is for the one-brace study; with --first-brace give --first-normal and --second-normal"
        )
    robot, _ = _load_robot(args)
    first = _floats("0,0,1" if args.first_normal is None else args.first_normal, "--first-normal")
    second = first if args.second_normal is None else _floats(args.second_normal, "--second-normal")
    beta = None if args.beta_x is None else _floats(args.beta_x, "--beta-x")
    cands = brace_pair_study(
        robot,
        _floats(args.q, "--q"),
        args.first_brace,
        first_normal=first,
        second_normal=second,
        beta_x=beta,
        points_per_link=args.points_per_link,
    )
    ci_first = cands[0].Ci_first if cands else None
    if args.json:
        print(
            to_json(
                {
                    "first_brace": {"frame": args.first_brace, "normal": first, "Ci": ci_first},
                    "second_normal": second,
                    "candidates": [c.__dict__ | {"gain": c.gain} for c in cands],
                }
            )
        )
        return 0
    alone = "" if ci_first is None else f"; C_i with it alone {1e3 * ci_first:.3f} mm/N"
    print(f"first brace '{args.first_brace}', normal {first.tolist()}{alone}")
    print(
        f"second bracing candidates (normal {second.tolist()}), best first (C_i of both braces in mm/N; "
        "gain over the first brace alone; k of J_e N; fraction along the link to the next joint)"
    )
    print(f"{'link':>10} {'joint':>5} {'frac':>5}  {'point [m]':<26} {'pair':>8} {'gain':>7} {'k(J_e N)':>9}")
    for c in cands:
        k = "singular" if c.k_pair is None else f"{c.k_pair:9.2f}"
        note = "  (redundant: adds no constraint to the first brace)" if c.redundant else ""
        note += "  (no load: no joint can push the point along the normal)" if c.unloaded else ""
        print(
            f"{c.link:>10} {c.joint:>5} {c.fraction:5.2f}  {np.round(c.point, 3).tolist()!s:<26} "
            f"{1e3 * c.Ci_pair:8.3f} {_pct(c.gain):>7} {k:>9}{note}"
        )
    return 0


# --- run -----------------------------------------------------------------------------------------
@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM raises KeyboardInterrupt while a command runs, so it cleans up like Ctrl-C (exit 130)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def _run(args: argparse.Namespace) -> int:
    from bracekit.report import write_run
    from bracekit.report.output import prepare_output, run_files
    from bracekit.report.table import table_markdown
    from bracekit.simulation.run import run_scenario, total_steps
    from bracekit.simulation.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    figures = not args.no_figures
    if figures:  # before any computation
        _needs("matplotlib", "viz", "bracekit run with figures (or pass --no-figures)")
    view_cli.check_run_flags(args)
    with (
        _sigterm_as_interrupt(),
        prepare_output(
            args.out, overwrite=args.overwrite, files=run_files(figures), command=f"bracekit run {args.scenario}"
        ) as plan,
    ):
        bar = None
        if not args.quiet:
            from tqdm import tqdm

            bar = tqdm(total=total_steps(scenario), desc=f"{scenario.name}: simulating", unit="step", file=sys.stderr)
        try:
            result = run_scenario(
                scenario,
                gradient=args.gradient,
                compliance_model=args.compliance_model,
                progress=None if bar is None else bar.update,
            )
        finally:
            if bar is not None:
                bar.close()
        written = write_run(
            result,
            plan,
            figures=figures,
            progress=None if args.quiet else (lambda name: print(f"writing {name}", file=sys.stderr)),
        )
    print(table_markdown(result.summaries, scenario.name))
    for name, s in result.summary["strategies"].items():
        if not s["completed"]:
            print(f"bracekit: warning: {name} did not complete: {s['failure']}", file=sys.stderr)
    print(f"wrote {len(written)} files to {args.out}/: " + ", ".join(p.name for p in written))
    if args.view:
        view_cli.serve_until_stopped(args.out, port=args.view_port)
    return 0 if result.completed else 1


# --- validate ------------------------------------------------------------------------------------
VALIDATION_FILES = ("validation.json", "validation.png")


def _validate(args: argparse.Namespace) -> int:
    from bracekit.report.output import atomic_directory, prepare_output, to_json
    from bracekit.simulation.scenario import load_scenario

    _needs("mujoco", "validate", "bracekit validate")
    _needs("matplotlib", "viz", "bracekit validate")
    from bracekit.report.validation_figures import figure_validation
    from bracekit.validate import run_validation
    from bracekit.validate.runner import DEFAULT_DIRECTIONS

    if args.configs < 1:
        raise InputError(f"--configs must be at least 1, got {args.configs}")
    if args.tracking_points < 0:
        raise InputError(f"--tracking-points must be 0 (skip) or more, got {args.tracking_points}")
    scenario = load_scenario(args.scenario)
    if len(scenario.braced.braces) > 1:
        return _validate_braces(args, scenario)
    from bracekit.validate.runner import path_samples

    if args.configs > path_samples(scenario):
        raise InputError(
            f"--configs {args.configs} is more than the {path_samples(scenario)} samples of the path of scenario "
            f"'{scenario.name}'; give at most {path_samples(scenario)}"
        )
    with ExitStack() as stack:
        stack.enter_context(_sigterm_as_interrupt())
        plan = None
        if args.out is not None:
            command = f"bracekit validate {args.scenario}"
            plan = stack.enter_context(
                prepare_output(args.out, overwrite=args.overwrite, files=VALIDATION_FILES, command=command)
            )
        bar = None
        if not args.json:
            from tqdm import tqdm

            total = args.configs * len(DEFAULT_DIRECTIONS)
            bar = tqdm(total=total, desc=f"{scenario.name}: validating", unit="case", file=sys.stderr)
        try:
            report = run_validation(scenario, configs=args.configs, progress=None if bar is None else bar.update)
        finally:
            if bar is not None:
                bar.close()
        data = report.to_json()
        from bracekit.validate.runner import (
            run_capacity_validation,
            run_holding_validation,
            run_preloaded_validation,
        )

        extra: list[Any] = []  # the further checks: preloaded model, holding statics, capacity ramps
        configs = report.configurations
        pre = run_preloaded_validation(scenario, configs=configs)
        data["preloaded"] = pre.to_json()
        extra.append(pre)
        holding = None
        if scenario.holding.active:
            holding = run_holding_validation(scenario, configs=configs)
            data["holding"] = holding.to_json()
            extra.append(holding)
        tracking = None
        if args.tracking_points > 0:
            from bracekit.validate.tracking import run_tracking_validation

            tracking = run_tracking_validation(scenario, points=args.tracking_points)
            data["tracking"] = tracking.to_json()
            extra.append(tracking)
        capacity = None
        if scenario.holding.preload > 0.0 and scenario.holding.wrenches is not None:
            capacity = run_capacity_validation(scenario, configs=configs)
            data["capacity"] = capacity.to_json()
            extra.append(capacity)
        if plan is not None:
            with atomic_directory(plan) as tmp:
                (tmp / "validation.json").write_text(to_json(data) + "\n", encoding="utf-8")
                figure_validation(report, tmp / "validation.png")
    print(to_json(data) if args.json else report.table_text())
    if not args.json:
        for part in extra:
            print(part.table_text())
    counts = report.counts()
    failed = counts.get("failed", 0) + pre.counts()["failed"]
    if holding is not None:
        s = holding.summary()
        failed += s["counts"]["failed"] + len(s["margin_disagreements"])
    if capacity is not None:
        failed += capacity.counts()["failed"] + capacity.counts()["disagrees"]
    if tracking is not None:
        failed += len(tracking.disagreements())
    if failed > 0 or report.model_stats("constrained")["n_cases"] == 0:
        print(f"bracekit: error: {failed} validation case(s) failed", file=sys.stderr)
        return 1
    return 0


def _validate_braces(args: argparse.Namespace, scenario: Any) -> int:
    """``validate`` for a scenario with several braces: the stacked constrained model against MuJoCo and statics."""
    from bracekit.report.output import atomic_directory, prepare_output, to_json
    from bracekit.validate.multi_brace import run_several_braces_validation, several_braces_text

    with ExitStack() as stack:
        stack.enter_context(_sigterm_as_interrupt())
        plan = None
        if args.out is not None:
            command = f"bracekit validate {args.scenario}"
            files = ("validation.json",)
            plan = stack.enter_context(prepare_output(args.out, overwrite=args.overwrite, files=files, command=command))
        data = run_several_braces_validation(scenario, configs=args.configs)
        if plan is not None:
            with atomic_directory(plan) as tmp:
                (tmp / "validation.json").write_text(to_json(data) + "\n", encoding="utf-8")
    print(to_json(data) if args.json else several_braces_text(data))
    s = data["summary"]
    median = s["constrained_vs_mujoco"]["median"]
    if s["n_failed"] or s["n_ok"] == 0 or median is None or median > 0.01:
        print(f"bracekit: error: {s['n_failed']} case(s) failed or the median error exceeds 1 %", file=sys.stderr)
        return 1
    return 0


# --- bench ---------------------------------------------------------------------------------------
def _bench(args: argparse.Namespace) -> int:
    module = _bench_module()
    results = module.run_benchmarks(quick=args.quick, parts=tuple(args.only) if args.only else module.PARTS)
    print(json.dumps(results, indent=2) if args.json else results.get("table", ""))
    return 0


def _is_bracekit_repository(root: Path) -> bool:
    """Whether `root` is the clone this bracekit was installed from (its pyproject names bracekit, its src holds us)."""
    import tomllib

    try:
        meta = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    here = Path(__file__).resolve().parents[1]
    return meta.get("project", {}).get("name") == "bracekit" and (root / "src" / "bracekit").resolve() == here


def _bench_module() -> Any:
    """benchmarks/bench.py of the repository bracekit was installed from (the timing code is not installed)."""
    import importlib.util

    here = Path(__file__).resolve()
    for root in here.parents:
        path = root / "benchmarks" / "bench.py"
        if path.is_file() and _is_bracekit_repository(root):
            spec = importlib.util.spec_from_file_location("bracekit_benchmarks", path)
            if spec is None or spec.loader is None:
                break
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            return module
    raise InputError(
        "bracekit bench runs the repository's benchmarks/ folder, which an installed package does not carry: "
        "install bracekit from a clone (pip install -e .) and run it there"
    )


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
