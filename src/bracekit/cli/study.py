"""`bracekit study`: where to brace — tip compliance for bracing points along the robot."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from bracekit.cli.common import add_limits_flag, floats, joint_values, load_robot, pct
from bracekit.errors import InputError
from bracekit.report.output import to_json
from bracekit.studies.brace_location import BraceCandidate, brace_location_study


def add_parser(sub: Any) -> None:
    """Add the command to the subparsers of ``bracekit``."""
    st = sub.add_parser("study", help="where to brace: tip compliance for bracing points along the robot")
    src2 = st.add_mutually_exclusive_group(required=True)
    src2.add_argument("--urdf", type=Path, help="URDF file of the robot")
    src2.add_argument("--model", help="a shipped robot: paper-robot, puma560 or panda")
    st.add_argument("--tip", help="end-effector frame {e} (default: the model's own)")
    st.add_argument("--q", required=True, help="joint values in chain order: Q1,...,Qn (rad)")
    add_limits_flag(st)
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


def run(args: argparse.Namespace) -> int:
    """`bracekit study`: rank bracing points (or second points with --first-brace); the exit code."""
    pair = args.first_brace is not None
    if pair and args.normal is not None:
        raise InputError(
            "--normal is for the one-brace study; with --first-brace give --first-normal and --second-normal"
        )
    for flag, value in (("--first-normal", args.first_normal), ("--second-normal", args.second_normal)):
        if not pair and value is not None:
            raise InputError(f"{flag} needs --first-brace FRAME (the brace the second points are added to)")
    robot, _ = load_robot(args)
    first = floats("0,0,1" if args.first_normal is None else args.first_normal, "--first-normal")
    normal = floats("0,0,1" if args.normal is None else args.normal, "--normal")
    second = first if args.second_normal is None else floats(args.second_normal, "--second-normal")
    cands = brace_location_study(
        robot,
        joint_values(args, robot),
        normal=second if pair else normal,
        fixed=[(args.first_brace, first)] if pair else [],
        beta_x=None if args.beta_x is None else floats(args.beta_x, "--beta-x"),
        points_per_link=args.points_per_link,
    )
    if pair:
        return _print_pairs(args, cands, first, second)
    if args.json:
        print(to_json({"candidates": [_candidate_json(c, ONE_BRACE_KEYS) for c in cands]}))
        return 0
    print("bracing candidates, best first (C_i in mm/N; k of J̃; fraction along the link to the next joint)")
    head = f"{'link':>10} {'n1':>3} {'frac':>5}  {'point [m]':<26} {'free':>8} {'constr.':>8} {'proj.':>8}"
    print(head + f" {'less':>7} {'k(J̃)':>8}")
    for c in cands:
        k = "singular" if c.k_braced is None else f"{c.k_braced:8.2f}"
        note = "  (no load: chain 1 cannot push b)" if c.unloaded else ""
        print(
            f"{c.link:>10} {c.joint:>3} {c.fraction:5.2f}  {np.round(c.point, 3).tolist()!s:<26} "
            f"{1e3 * c.Ci_before:8.3f} {1e3 * c.Ci_constrained:8.3f} {1e3 * (c.Ci_projection or 0.0):8.3f} "
            f"{pct(c.reduction):>7} {k:>8}{note}"
        )
    return 0


#: The JSON keys of a one-brace candidate and the candidate's field of each (n1: the joints that move the point;
#: Ci_free: C_i unbraced; reduction: what the brace removes).
ONE_BRACE_KEYS = (
    ("link", "link"),
    ("n1", "joint"),
    ("fraction", "fraction"),
    ("point", "point"),
    ("Ci_free", "Ci_before"),
    ("Ci_constrained", "Ci_constrained"),
    ("Ci_projection", "Ci_projection"),
    ("k_braced", "k_braced"),
    ("unloaded", "unloaded"),
    ("reduction", "reduction"),
)
#: The JSON keys of a second-brace candidate (Ci_first: the first brace alone; gain: what the second adds).
PAIR_KEYS = (
    ("link", "link"),
    ("joint", "joint"),
    ("fraction", "fraction"),
    ("point", "point"),
    ("Ci_first", "Ci_before"),
    ("Ci_pair", "Ci_constrained"),
    ("k_pair", "k_braced"),
    ("redundant", "redundant"),
    ("unloaded", "unloaded"),
    ("gain", "reduction"),
)


def _candidate_json(c: BraceCandidate, keys: tuple[tuple[str, str], ...]) -> dict[str, Any]:
    """A candidate under the JSON keys of its study (``ONE_BRACE_KEYS`` or ``PAIR_KEYS``)."""
    return {key: getattr(c, field) for key, field in keys}


def _print_pairs(args: argparse.Namespace, cands: list[BraceCandidate], first: Any, second: Any) -> int:
    """`bracekit study --first-brace FRAME`: second bracing points ranked with the first brace fixed."""
    ci_first = cands[0].Ci_before if cands else None
    if args.json:
        print(
            to_json(
                {
                    "first_brace": {"frame": args.first_brace, "normal": first, "Ci": ci_first},
                    "second_normal": second,
                    "candidates": [_candidate_json(c, PAIR_KEYS) for c in cands],
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
        k = "singular" if c.k_braced is None else f"{c.k_braced:9.2f}"
        note = "  (redundant: adds no constraint to the first brace)" if c.redundant else ""
        note += "  (no load: no joint can push the point along the normal)" if c.unloaded else ""
        print(
            f"{c.link:>10} {c.joint:>5} {c.fraction:5.2f}  {np.round(c.point, 3).tolist()!s:<26} "
            f"{1e3 * c.Ci_constrained:8.3f} {pct(c.reduction):>7} {k:>9}{note}"
        )
    return 0
