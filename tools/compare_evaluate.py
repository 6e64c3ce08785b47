"""Compare ``bracekit evaluate --json`` of two source trees on the paper robot and the panda.

    python tools/compare_evaluate.py OLD/src NEW/src

OLD and NEW are source trees of two bracekit versions (e.g. ``git archive REV src | tar -x -C /tmp/old``); each
case runs in a fresh process with that tree first on PYTHONPATH. One-brace cases (3 configurations of each robot,
with and without statics, another contact, β_x and β_w): the same keys and every number equal to 1e-12
(relative, or absolute below 1). Several-brace cases: every key of OLD equal to 1e-12, the keys NEW adds listed.
Exit 0 when everything agrees, 1 otherwise.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

Q_PAPER = [
    "0,0.194,-2.598,0,-0.737,-2.498,-1.898,3.142,2.106,2.438,0.867",
    "0.1,0.3,-2.4,0.1,-0.6,-2.3,-1.7,3.0,2.0,2.3,0.8",
    "-0.2,0.25,-2.5,0.05,-0.8,-2.6,-1.9,3.1,2.2,2.5,0.9",
]
Q_PANDA = ["0,-0.4,0,-2.2,0,1.8,0.8", "0.3,-0.2,0.1,-2.0,0.2,1.9,0.6", "-0.4,0.1,-0.2,-1.7,-0.3,1.5,1.0"]
STATICS = [
    "--gravity",
    "--preload",
    "12",
    "--friction",
    "0.4",
    "--wrench",
    "0,0,-10,0,0,0",
    "--wrench",
    "3,1,0,0,0.2,0",
]
PANDA_PAD = ["--brace-link", "panda_link5", "--brace-offset", "0.001,0.116,-0.067"]
ONE = [
    ["--model", "paper-robot", "--q", Q_PAPER[0], *STATICS],
    ["--model", "paper-robot", "--q", Q_PAPER[1]],
    ["--model", "paper-robot", "--q", Q_PAPER[2], *STATICS, "--beta-w", "0,0,1,0,0,0"],
    ["--model", "paper-robot", "--q", Q_PAPER[0], "--contact", "soft_finger", *STATICS],
    ["--model", "panda", *PANDA_PAD, "--q", Q_PANDA[0]],
    ["--model", "panda", *PANDA_PAD, "--q", Q_PANDA[1], *STATICS],
    ["--model", "panda", *PANDA_PAD, "--q", Q_PANDA[2], *STATICS, "--beta-x", "0,0,1,0,0,0"],
]
PAPER_PADS = ["--brace", "pad_a", "--brace", "pad_b", "--brace-link", "link3", "--brace-link", "link9"]
PAPER_PADS += ["--brace-offset", "0.05,0.02,0.1", "--brace-offset", "0,0,0", "--normal", "0.3,-0.2,1"]
PAPER_PADS += ["--normal", "-1,0.4,0.2"]
PANDA_PADS = [*PANDA_PAD, "--brace-link", "panda_link3", "--brace-offset", "0,0,0.05"]
SEVERAL = [["--model", "paper-robot", *PAPER_PADS, "--q", q] for q in Q_PAPER]
SEVERAL.append(["--model", "panda", *PANDA_PADS, "--q", Q_PANDA[1], "--normal", "0,0,1", "--normal", "0,1,0"])
CALL = "import sys; from bracekit.cli.main import main; sys.exit(main(sys.argv[1:]))"


def run(src: str, args: list[str]) -> dict[str, Any]:
    """The JSON report of ``bracekit evaluate --json ARGS`` with the tree `src`, or {"error": …}."""
    env = dict(os.environ, PYTHONPATH=src)
    p = subprocess.run(
        [sys.executable, "-c", CALL, "evaluate", "--json", *args], env=env, capture_output=True, text=True
    )
    if p.returncode != 0:
        return {"error": f"exit {p.returncode}: {p.stderr.strip()[-300:]}"}
    return dict(json.loads(p.stdout))


def diff(a: Any, b: Any, path: str = "") -> list[str]:
    """Where b differs from a (keys of a only; numbers to 1e-12)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = [f"{path}/{k}: missing" for k in a if k not in b]
        return out + [d for k in a if k in b for d in diff(a[k], b[k], f"{path}/{k}")]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} vs {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in diff(x, y, f"{path}[{i}]")]
    numbers = isinstance(a, int | float) and isinstance(b, int | float) and not isinstance(a, bool)
    if numbers and (a == b or abs(a - b) <= 1e-12 * max(1.0, abs(a), abs(b))):
        return []
    return [] if a == b else [f"{path}: {a!r} vs {b!r}"]


def main() -> int:
    old, new = sys.argv[1], sys.argv[2]
    bad = 0
    for label, cases, same_keys in (("one brace", ONE, True), ("several braces", SEVERAL, False)):
        for args in cases:
            a, b = run(old, args), run(new, args)
            extra = sorted(set(b) - set(a))
            problems = diff(a, b) + ([f"new keys {extra}"] if same_keys and extra else [])
            problems += [f"{tree}: {r['error']}" for tree, r in (("old", a), ("new", b)) if "error" in r]
            bad += bool(problems)
            shown = " ".join(args[:2] + args[args.index("--q") : args.index("--q") + 2])
            verdict = "OK" if not problems else f"{len(problems)} differences, first {problems[:3]}"
            print(f"[{label}] {shown}: {verdict}" + (f" (new keys: {extra})" if extra and not same_keys else ""))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
