"""`bracekit evaluate`: the braced model at one configuration (text or JSON)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from bracekit._version import __version__
from bracekit.cli.common import add_limits_flag, floats, joint_values, load_robot, one, pct
from bracekit.contact import REGISTRY
from bracekit.errors import InputError
from bracekit.report.output import to_json
from bracekit.report.stiffness_file import write_stiffness_json
from bracekit.simulation.holding import Holding
from bracekit.simulation.scenario import MAX_WRENCHES
from bracekit.studies.evaluate import evaluate


def add_parser(sub: Any) -> None:
    """Add the command to the subparsers of ``bracekit``."""
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
    add_limits_flag(ev)
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
    ev.add_argument(
        "--beta-w",
        help="a wrench direction FX,FY,FZ,MX,MY,MZ: also report β_xᵀ C β_w, the deflection along β_x per unit wrench",
    )
    ev.add_argument(
        "--stiffness-out",
        type=Path,
        help="write the tool's 6×6 stiffness (first order, and preloaded with --preload/--gravity) to this JSON file",
    )
    ev.add_argument(
        "--stiffness-frame",
        default="world",
        help="axes of the exported stiffness: world, tool, or a rotation R11,...,R33 (row-major; default world)",
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


def contact_registry() -> tuple[str, ...]:
    """The names of the registered contact types (the choices of --contact)."""
    return tuple(REGISTRY)


def run(args: argparse.Namespace) -> int:
    """`bracekit evaluate`: print the braced model at --q (text or --json); the exit code."""
    robot, own_brace = load_robot(args)
    robot, frames = _brace_frames(args, robot, own_brace)
    normals = args.normal or ["0,0,1"]
    if len(frames) > 1 and args.normal is not None and len(normals) != len(frames):
        raise InputError(
            f"give one --normal per brace, in the order of the braces: {len(frames)} braces, {len(normals)} --normal"
        )
    if len(frames) == 1 and len(normals) > 1:
        raise InputError(f"give one --normal for the one brace, got {len(normals)}")
    q = joint_values(args, robot)
    beta = None if args.beta_x is None else floats(args.beta_x, "--beta-x")
    beta_w = None if args.beta_w is None else floats(args.beta_w, "--beta-w")
    frame = _stiffness_frame(args)
    holding = _holding(args)
    vectors = [floats(n, "--normal") for n in normals]
    if any(v.size != 3 for v in vectors):
        raise InputError("--normal needs 3 numbers NX,NY,NZ (world)")
    report = evaluate(
        robot,
        frames,
        q,
        normal=np.array(vectors) if len(vectors) > 1 else vectors[0],
        contact=args.contact,
        beta_x=beta,
        holding=holding,
        beta_w=beta_w,
        stiffness_frame=frame,
    )
    if args.stiffness_out is not None:
        write_stiffness_json(args.stiffness_out, report.pop("tool_stiffness"), __version__)
    if args.json:
        print(to_json(report))
    else:
        print(_evaluate_text(report))
    return 0


def _stiffness_frame(args: argparse.Namespace) -> Any:
    """The axes of --stiffness-frame ("world", "tool" or a 3×3 rotation) when --stiffness-out is given, else None."""
    if args.stiffness_out is None:
        return None
    if args.stiffness_frame in ("world", "tool"):
        return args.stiffness_frame
    values = floats(args.stiffness_frame, "--stiffness-frame")
    if values.size != 9:
        raise InputError("--stiffness-frame takes world, tool or 9 numbers R11,...,R33 (a rotation, row-major)")
    return values.reshape(3, 3)


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
        return robot.with_point_frame(names[0], links[0], floats(offsets[0], "--brace-offset")), names
    frames = [(n, link, floats(o, "--brace-offset"), None) for n, link, o in zip(names, links, offsets, strict=True)]
    return robot.with_point_frames(frames), names


def _holding(args: argparse.Namespace) -> Holding | None:
    """The statics of --gravity, --preload, --friction and --wrench (None when none is given)."""
    preload = one(args.preload, "--preload")
    friction = None if args.friction is None else one(args.friction, "--friction")
    if args.wrench and len(args.wrench) > MAX_WRENCHES:
        raise InputError(f"{len(args.wrench)} --wrench given; give at most {MAX_WRENCHES}")
    wrenches = None if not args.wrench else np.array([floats(w, "--wrench") for w in args.wrench], dtype=object)
    if wrenches is not None:
        if any(np.size(w) != 6 for w in wrenches):
            raise InputError("--wrench needs 6 numbers FX,FY,FZ,MX,MY,MZ (N, N·m, world axes)")
        wrenches = np.array([np.asarray(w, dtype=float) for w in wrenches])
    holding = Holding(gravity=bool(args.gravity), preload=preload, friction=friction, wrenches=wrenches)
    return holding if holding.active else None


def _scale(x: float | None) -> str:
    return "∞" if x is None else f"{x:.3g}"


def _statics_text(r: dict[str, Any]) -> str:
    """The statics lines of evaluate's text output (one brace: its keys at the top; several: in ``braces``)."""
    braces = r.get("braces", [r])
    contacts = "; ".join(
        f"preload {b['preload_N']:g} N, " + ("frictionless" if b["friction"] is None else f"μ = {b['friction']:g}")
        for b in braces
    )
    lines = [
        f"statics: gravity {'on' if r['gravity'] else 'off'}, {contacts}; "
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


def _ellipsoid_lines(r: dict[str, Any], models: tuple[tuple[str, str], ...]) -> list[str]:
    """One line per model: the translational ellipsoid's semi-axes (mm/N) along their world unit axes."""
    lines = []
    for label, key in models:
        ell = r[key]["translational"]
        axes = ", ".join(
            f"{1e3 * s:.3f} along {np.round(a, 3).tolist()}"
            for s, a in zip(ell["semi_axes"], np.array(ell["axes"]).T, strict=True)
        )
        lines.append(f"  {label:<20} {axes}")
    return lines


def _directional_text(r: dict[str, Any]) -> list[str]:
    """The lines naming what each directional number measures: c_t (m/N) and β_xᵀCβ_w beside C_i."""

    def mm(key: str) -> str:
        return "–" if r.get(key) is None else f"{1e3 * r[key]:.4f} mm/N"

    models = [m for m in ("free", "constrained", "projection") if r.get(f"ct_{m}") is not None]
    lines = [
        "  (C_i = ‖β_xᵀC_e‖ adds the m/N force columns and the 1/N moment columns: mixed units, the paper's index)"
    ]
    if models:
        lines.append(
            "translational compliance along β_x, c_t = β_xᵀC_ttβ_x (displacement per newton along β_x): "
            + ", ".join(f"{m} {mm(f'ct_{m}')}" for m in models)
            + (f", preloaded {mm('ct_preloaded')}" if r.get("ct_preloaded") is not None else "")
        )
    if "beta_w" in r:
        lines.append(
            f"β_xᵀCβ_w, along β_x per unit wrench along β_w = {np.round(r['beta_w'], 3).tolist()}: "
            + ", ".join(
                f"{m} {mm(f'Cw_{m}')}" for m in ("free", "constrained", "projection") if r.get(f"Cw_{m}") is not None
            )
        )
    return lines


def _evaluate_text(r: dict[str, Any]) -> str:
    """The text output of evaluate: the chain split for one brace, the stacked constraint for several."""
    one = "braces" not in r
    lines = _split_text(r) if one else _stacked_text(r)
    lines += ["", "translational compliance ellipsoid (semi-axes in mm/N along world unit axes):"]
    models = (("free space", "ellipsoid_free"), ("braced, constrained", "ellipsoid_constrained"))
    lines += _ellipsoid_lines(r, models + ((("braced, projection", "ellipsoid_projection"),) if one else ()))
    projection = (
        f", braced projection {1e3 * r['Ci_projection']:.4f} mm/N ({pct(r['Ci_reduction_projection'])} less)"
        if one
        else f"; no projection model: {r['projection_reason']}"
    )
    lines += [
        "",
        f"compliance index C_i = ‖β_xᵀC_e‖ along β_x = {np.round(r['beta_x'], 3).tolist()}:",
        f"  free space {1e3 * r['Ci_free']:.4f} mm/N, braced constrained {1e3 * r['Ci_constrained']:.4f} mm/N "
        f"({pct(r['Ci_reduction_constrained'])} less){projection}",
        f"  largest translational compliance (top eigenvalue of C_tt, any direction): free "
        f"{1e3 * r['max_translational_free']:.4f} mm/N → braced {1e3 * r['max_translational_constrained']:.4f} mm/N "
        "(constrained)",
        *_directional_text(r),
    ]
    if "tau0" in r:
        lines += ["", _statics_text(r)]
    return "\n".join(lines)


def _split_text(r: dict[str, Any]) -> list[str]:
    """The head of one brace's text output: the chain split, b, e, θ_z, k and chain 1's braced motions."""
    return [
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
    ]


def _stacked_text(r: dict[str, Any]) -> list[str]:
    """The head of several braces' text output: each brace, the stacked constraint G, e and k."""
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
    ]
    return lines
