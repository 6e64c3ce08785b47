"""`bracekit cobot SCENARIO --out DIR`: a worker guides the braced robot in MuJoCo; the numbers per strategy."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from bracekit.cli.common import OUT_HELP, OVERWRITE_HELP, needs, sigterm_as_interrupt

COBOT_FILES = ("summary.json", "table.md", "cobot.png", "series.npz", "trajectories.npz", "scene.json")


def add_parser(sub: Any) -> None:
    """Add the command to the subparsers of ``bracekit``."""
    p = sub.add_parser(
        "cobot", help="a worker guides the braced robot through admittance control in MuJoCo while the work loads it"
    )
    p.add_argument("scenario", nargs="?", default="panda-cobot", help="cobot scenario file or shipped name")
    p.add_argument("--out", type=Path, required=True, help=f"output folder; {OUT_HELP}")
    p.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    p.add_argument("--no-figures", action="store_true", help="skip cobot.png (no matplotlib needed)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def run(args: argparse.Namespace) -> int:
    """Run the scenario, write the outputs whole into --out, print the table; 1 when a brace was not held."""
    import numpy as np

    from bracekit.report.output import atomic_directory, prepare_output, to_json

    needs("mujoco", "validate", "bracekit cobot")
    if not args.no_figures:
        needs("matplotlib", "viz", "bracekit cobot with figures (or pass --no-figures)")
    from bracekit.cobot.config import load_cobot
    from bracekit.cobot.report import figure_cobot, table_markdown
    from bracekit.cobot.run import run_cobot
    from bracekit.cobot.scene import cobot_scene, cobot_trajectories
    from bracekit.viewer.link_meshes import MESH_FILE, link_meshes, save_link_meshes

    sc = load_cobot(args.scenario)
    meshes = link_meshes(sc.base.robot)  # the robot's meshes travel with the replay (scene.json names them)
    files = COBOT_FILES if not args.no_figures else tuple(f for f in COBOT_FILES if f != "cobot.png")
    files += (MESH_FILE,) if meshes else ()
    with (
        sigterm_as_interrupt(),
        prepare_output(
            args.out, overwrite=args.overwrite, files=files, command=f"bracekit cobot {args.scenario}"
        ) as plan,
    ):
        progress = None if args.quiet else (lambda name: print(f"{sc.name}: {name} in MuJoCo", file=sys.stderr))
        result = run_cobot(sc, progress=progress)
        table = table_markdown(sc, result.summaries)
        with atomic_directory(plan) as tmp:
            (tmp / "summary.json").write_text(to_json(result.to_json()) + "\n", encoding="utf-8")
            (tmp / "table.md").write_text(table, encoding="utf-8")
            series = {}
            for r in result.runs:
                for key in ("t", "force", "e", "e_cmd", "process", "normal", "tangential", "torque", "dwell", "qpos"):
                    series[f"{r.strategy}/{key}"] = getattr(r, key)
            np.savez_compressed(tmp / "series.npz", **series)
            np.savez_compressed(tmp / "trajectories.npz", **cobot_trajectories(result))  # the replay of `bracekit view`
            (tmp / "scene.json").write_text(to_json(cobot_scene(result, bool(meshes))) + "\n", encoding="utf-8")
            if meshes:
                save_link_meshes(meshes, tmp / MESH_FILE)
            if not args.no_figures:
                figure_cobot(sc, result.runs, tmp / "cobot.png")
    print(table, end="")
    print(f"wrote {len(files)} files to {args.out}/: " + ", ".join(files))
    held = all(s.get("brace_held", True) for s in result.summaries)
    if not held:
        print("bracekit: warning: a braced strategy did not hold its brace throughout (table.md)", file=sys.stderr)
    return 0 if held else 1
