"""The strategies compared on two arms bracekit does not ship: the xArm7 planar guess and the iiwa-like forearm brace.

``python benchmarks/bench_qp_cases.py`` prints the Markdown rows of docs/qp.md for tests/data/xarm7-planar.toml
(example-robot-data's xArm7, the test extra) and for the iiwa-like arm of tests/helpers.py braced at its forearm,
following a 4 cm circle in ``position`` and in ``position+axis`` (period 4 s, dt 0.05 s), with every strategy;
the columns of ``bench_qp.py --compare`` and the run's verdict ``valid``. Needs bracekit[qp] and the test extra.
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
STRATEGIES = ("free_space_min_norm", "braced_min_norm", "braced_gradient_projection", "braced_qp")
CIRCLE = (
    'type = "circle"\ncentre = [0.66, 0.0, 0.50]\nradius = 0.04\nnormal = [0.0, 0.0, 1.0]\n'
    'start_direction = [1.0, 0.0, 0.0]\nperiod = 4.0\nspace = "{space}"\n'
)


def _names() -> str:
    return ", ".join(f'"{s}"' for s in STRATEGIES)


def xarm_planar(folder: Path) -> Path:
    """tests/data/xarm7-planar.toml with example-robot-data's xArm7."""
    import importlib.metadata

    share = Path(str(importlib.metadata.distribution("example-robot-data").locate_file("cmeel.prefix/share")))
    urdf = share / "example-robot-data/robots/xarm_description/urdf/xarm7.urdf"
    text = (ROOT / "tests/data/xarm7-planar.toml").read_text(encoding="utf-8")
    path = folder / "xarm7-planar.toml"
    path.write_text(text.format(urdf=urdf, share=share, strategies=_names()), encoding="utf-8")
    return path


def iiwa_forearm(folder: Path, space: str) -> Path:
    """The iiwa-like arm of tests/helpers.py braced at its forearm, a 4 cm circle in `space`."""
    sys.path.insert(0, str(ROOT / "tests"))
    from helpers import iiwa_like_urdf, iiwa_scenario_text

    (folder / "iiwa.urdf").write_text(iiwa_like_urdf(), encoding="utf-8")
    text = iiwa_scenario_text(True)
    text = text[: text.index('type = "line"')] + CIRCLE.format(space=space) + text[text.index("[start]") :]
    text = text.replace("dt = 0.05\n", f"dt = 0.05\nstrategies = [{_names()}]\n")
    path = folder / f"iiwa-{space.replace('+', '-')}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def rows(label: str, path: Path) -> list[dict[str, Any]]:
    """One row per strategy of the scenario at `path` (one run of all of them: ms per step is the whole run's)."""
    import numpy as np

    from bracekit.simulation.run import run_scenario
    from bracekit.simulation.scenario import load_scenario

    sc = load_scenario(path)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = run_scenario(path, both_models=False)
    wall = time.perf_counter() - t0
    runs = next(iter(res.trajectories.values()))
    steps = sum(max(tr.steps, 1) for tr in runs.values())
    out = []
    for name, tr in runs.items():
        s = res.summary["strategies"][name]
        margin = float(np.min(np.minimum(tr.q - sc.robot.lower, sc.robot.upper - tr.q)))
        out.append(
            {
                "scenario": label,
                "strategy": name,
                "completed": bool(s["completed"]),
                "valid": bool(s["valid"]),
                "Ci_mean": s["Ci_mean"],
                "min_link_clearance_m": s["min_link_clearance_m"],
                "limit_margin_rad": margin,
                "max_contact_violation_m": s["max_contact_violation_m"],
                "ms_per_step": 1e3 * wall / steps,
            }
        )
    return out


def markdown(found: list[dict[str, Any]]) -> str:
    """The rows in the format of docs/qp.md's table, with the verdict."""
    lines = []
    for r in found:
        lines.append(
            f"| {r['scenario']} | {r['strategy']} | {'yes' if r['completed'] else 'no'} | "
            f"{'yes' if r['valid'] else 'no'} | {1e3 * r['Ci_mean']:.3f} | {r['min_link_clearance_m']:.4f} | "
            f"{r['limit_margin_rad']:.3f} | {r['max_contact_violation_m']:.1e} | {r['ms_per_step']:.1f} |"
        )
    return "\n".join(lines)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        found = rows("xArm7 planar (position)", xarm_planar(folder))
        for space in ("position", "position+axis"):
            found += rows(f"iiwa forearm ({space})", iiwa_forearm(folder, space))
    print(markdown(found))


if __name__ == "__main__":
    main()
