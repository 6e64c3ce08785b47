"""The package's public names, imported on first use: a worker's task imports only what it runs."""

from __future__ import annotations

import os
import subprocess
import sys
from importlib import import_module
from pathlib import Path

import pytest

import bracekit
import bracekit.studies.sweep as sweep


@pytest.mark.parametrize("name", sweep.__all__)
def test_every_public_name_is_its_module_s_own(name: str) -> None:
    home = import_module(f"bracekit.studies.sweep.{sweep._HOME[name]}")
    assert getattr(sweep, name) is getattr(home, name)


def test_an_unknown_name_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no_such_name"):
        sweep.no_such_name  # noqa: B018


def test_a_worker_s_modules_do_not_import_the_client_s() -> None:
    """Unpickling a candidate's task (evaluate, context, spec) imports neither the engine nor the tables' writers."""
    code = (
        "import sys\n"
        "import bracekit.studies.sweep.evaluate, bracekit.studies.sweep.context, bracekit.studies.sweep.spec\n"
        "client = ('engine', 'report', 'store', 'refine', 'screen')\n"
        "print(' '.join(m for m in client if f'bracekit.studies.sweep.{m}' in sys.modules))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(bracekit.__file__).parents[1])}  # this source tree's bracekit
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    assert done.stdout.strip() == ""


def test_the_parquet_writer_is_imported_while_the_candidates_run() -> None:
    """In a new process: the writers' thread imports pyarrow.parquet, which the tables then write with."""
    code = (
        "import sys\n"
        "from bracekit.studies.sweep.store import import_writers\n"
        "assert 'pyarrow.parquet' not in sys.modules\n"
        "import_writers().join(60)\n"
        "print('pyarrow.parquet' in sys.modules)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(bracekit.__file__).parents[1])}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    assert done.stdout.strip() == "True"
