"""numba's cache directory: a user cache directory (XDG), the user's own NUMBA_CACHE_DIR kept, never src/."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bracekit import _numba_cache

SRC = Path(_numba_cache.__file__).resolve().parents[1]  # the tree bracekit is imported from (src/)


def test_default_is_the_xdg_cache_home(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert _numba_cache.default_cache_dir() == tmp_path / "bracekit" / "numba"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert _numba_cache.default_cache_dir() == Path.home() / ".cache" / "bracekit" / "numba"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/dir")  # the XDG spec: a relative path is ignored
    assert _numba_cache.default_cache_dir() == Path.home() / ".cache" / "bracekit" / "numba"


def test_configure_keeps_the_users_choice_and_updates_an_imported_numba(monkeypatch, tmp_path: Path) -> None:
    numba_config = pytest.importorskip("numba.core.config")
    monkeypatch.setattr(numba_config, "CACHE_DIR", numba_config.CACHE_DIR)  # restored after the test
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert _numba_cache.configure() == str(tmp_path / "mine")
    assert numba_config.CACHE_DIR == str(tmp_path / "mine")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    chosen = _numba_cache.configure()
    assert chosen == str(tmp_path / "xdg" / "bracekit" / "numba") == os.environ["NUMBA_CACHE_DIR"]
    assert numba_config.CACHE_DIR == chosen


_PROBE = """
import json, sys
import numpy as np
import bracekit
from bracekit import load_scenario
from bracekit.resolution import GradientProjectionStep
import numba
from numba.core.dispatcher import Dispatcher
sc = load_scenario("paper")
step = GradientProjectionStep(sc.braced, sc.strategy("braced_gradient_projection"), backend="numba")
step(np.asarray(sc.guess, dtype=float), np.concatenate([sc.task.velocity(0.0), np.zeros(3)]))
paths = set()
for name, module in list(sys.modules.items()):
    if name.startswith("bracekit"):
        for value in vars(module).values():
            if isinstance(value, Dispatcher) and value._cache is not None and value.signatures:
                paths.add(value._cache._cache_path)
print(json.dumps({"config": numba.config.CACHE_DIR, "paths": sorted(paths)}))
"""


def _compiled_under(folder: Path) -> set[Path]:
    return {p for pattern in ("*.nbi", "*.nbc") for p in folder.rglob(pattern)}


@pytest.mark.slow  # a new process (or a Dask cluster): seconds, in the slow group
def test_a_new_process_caches_the_kernels_in_the_user_cache_not_in_src(tmp_path: Path) -> None:
    pytest.importorskip("numba")
    before = _compiled_under(SRC)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}  # as a user starts it
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")])
    expected = _numba_cache.default_cache_dir() if "XDG_CACHE_HOME" not in os.environ else None
    proc = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, env=env, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    cache = Path(out["config"])
    assert expected is None or cache == expected
    assert cache.parts[-2:] == ("bracekit", "numba") and SRC not in cache.parents
    assert out["paths"], "no cached numba kernel was loaded"
    for path in map(Path, out["paths"]):
        assert cache in path.parents, path  # every kernel of bracekit is cached under the user cache directory
        assert list(path.glob("*.nbi")), path  # and was written there
    assert _compiled_under(SRC) == before  # nothing new under src/
