"""Without numba (an optional extra), the mesh clearance's broad phase runs its loops as Python and says so.

Reference: the compiled broad phase in this process (and through it coal's exact distance, tested in
test_geometry_screen.py): the Python loops must give the same clearances; `import bracekit` never loads numba.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_geometry_distance import Q0, _braced

from bracekit.kinematics.clearance import Clearance, geometry_of
from geometry_refs import xarm7

SCRIPT = """
import importlib.abc, importlib.util, json, sys
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "numba" or name.startswith("numba."):
            raise ImportError("numba blocked by the test")
sys.meta_path.insert(0, Block())
found = importlib.util.find_spec
importlib.util.find_spec = lambda name, *a: None if name == "numba" else found(name, *a)
sys.path[:0] = {paths!r}
import numpy as np
from bracekit.kinematics.clearance import Clearance, geometry_of
from test_geometry_distance import Q0, _braced
from geometry_refs import xarm7
braced = _braced(xarm7())
qs = [Q0 + 0.2 * np.sin(np.arange(7) + k) for k in range(4)]
values = [float(Clearance(braced).minimum(q)[0]) for q in qs]
print(json.dumps({{"values": values, "geometry": geometry_of(braced), "numba": "numba" in sys.modules}}))
"""


@pytest.mark.slow
def test_the_python_broad_phase_equals_the_compiled_one_and_is_said() -> None:
    tests = Path(__file__).resolve().parents[1]
    paths = [str(tests / "geometry"), str(tests)]
    env = dict(os.environ)
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT.format(paths=paths)], capture_output=True, text=True, env=env, timeout=600
    )
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["numba"] is False
    assert got["geometry"].endswith("coal; broad phase in Python (numba not installed))")
    braced = _braced(xarm7())
    qs = [Q0 + 0.2 * np.sin(np.arange(7) + k) for k in range(4)]
    compiled = [float(Clearance(braced).minimum(q)[0]) for q in qs]
    assert np.allclose(got["values"], compiled, rtol=0.0, atol=1e-12)
    assert geometry_of(braced) == "meshes and primitives from the URDF (7 elements, coal)"
