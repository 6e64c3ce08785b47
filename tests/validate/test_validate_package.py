"""The package's exported names (``bracekit.validate.__all__``), imported on first use (PEP 562).

Reference: each name's defining module, read directly; in a fresh process where every submodule was imported
first (as the checks' own imports do), so a submodule bound on the package never shadows an exported name.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

_CHECK = """
import importlib, json, pkgutil, types
import bracekit.validate as package
for info in pkgutil.iter_modules(package.__path__):
    importlib.import_module(f"bracekit.validate.{info.name}")
wrong = []
for name in package.__all__:
    got = getattr(package, name)
    want = getattr(importlib.import_module(package._EXPORTS[name]), name)
    if isinstance(got, types.ModuleType) or got is not want:
        wrong.append(name)
print(json.dumps(wrong))
"""


def test_every_exported_name_is_its_modules_object_after_every_submodule_is_imported() -> None:
    pytest.importorskip("mujoco")
    out = subprocess.run([sys.executable, "-c", _CHECK], capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []


def test_one_module_of_the_package_imports_no_other_check() -> None:
    pytest.importorskip("mujoco")
    code = "import sys, bracekit.validate.mujoco_check; print('bracekit.validate.runner' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "False"
