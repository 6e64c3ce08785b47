"""The package as installed: its version, its public API and its optional dependencies."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import bracekit

REPO = Path(__file__).resolve().parents[1]


def test_import_bracekit_pulls_no_optional_dependency() -> None:
    code = "import sys, bracekit; print(sorted(m for m in ('matplotlib', 'mujoco', 'numba') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_version_has_one_source_read_by_pyproject() -> None:
    meta = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    assert "version" in meta["project"]["dynamic"]
    assert meta["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "bracekit._version.__version__"}
    changelog = (REPO / "CHANGELOG.md").read_text(encoding="utf-8")
    assert f"## [{bracekit.__version__}]" in changelog


def test_the_package_is_typed() -> None:
    assert (Path(bracekit.__file__).parent / "py.typed").is_file()


def test_every_public_name_resolves() -> None:
    assert len(bracekit.__all__) == len(set(bracekit.__all__))
    for name in bracekit.__all__:
        assert getattr(bracekit, name) is not None


def test_no_file_cites_a_path_outside_the_repository() -> None:
    for path in [*REPO.glob("src/**/*.py"), *REPO.glob("docs/**/*.md"), REPO / "README.md"]:
        text = path.read_text(encoding="utf-8")
        for outside in ("MODEL.md", "../shared", "shared/design"):
            assert outside not in text, f"{path.relative_to(REPO)} cites {outside}"


def test_every_dotted_bracekit_name_in_code_and_docs_resolves() -> None:
    """Docstrings and docs name modules and objects that exist (no old module path survives a move)."""
    import importlib
    import re

    allowed = {"bracekit.objective.joint_limits"}  # the architecture doc's example of a new term
    files = [*REPO.glob("src/**/*.py"), *REPO.glob("docs/**/*.md"), REPO / "README.md", *REPO.glob("benchmarks/*.py")]
    bad = []
    for path in files:
        for name in set(re.findall(r"\bbracekit(?:\.[A-Za-z_][A-Za-z0-9_]*)+", path.read_text(encoding="utf-8"))):
            if name in allowed or name.startswith("bracekit.egg"):
                continue
            parts = name.split(".")
            for cut in range(len(parts), 0, -1):  # the longest importable module, then attributes
                try:
                    obj = importlib.import_module(".".join(parts[:cut]))
                except ImportError:
                    continue
                try:
                    for attr in parts[cut:]:
                        obj = getattr(obj, attr)
                except AttributeError:
                    bad.append(f"{path.relative_to(REPO)}: {name}")
                break
            else:
                bad.append(f"{path.relative_to(REPO)}: {name}")
    assert not bad, "names that do not resolve:\n" + "\n".join(sorted(bad))
