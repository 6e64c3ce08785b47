"""Design sweeps: whole-task runs over brace locations, regions, tasks and stiffness, on Dask distributed.

A spec (TOML) is a base scenario plus axes; each candidate runs the whole task with feasibility checks, after a
batch screening; the rows go to results.parquet / results.csv, a ranked table, a heatmap and a Pareto plot.

The names below are imported on first use: a Dask worker that unpickles a candidate's task imports the modules
that task needs (spec, context, evaluate), not the client's engine, tables and figures.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from bracekit.studies.sweep.candidates import Candidate, expand
    from bracekit.studies.sweep.engine import SweepRun, dask_client, run_sweep
    from bracekit.studies.sweep.evaluate import evaluate_candidate
    from bracekit.studies.sweep.report import write_outputs
    from bracekit.studies.sweep.spec import SpecError, SweepSpec, load_spec, parse_spec, shipped_specs

#: Public name → the module of the package that defines it.
_HOME = {
    "Candidate": "candidates",
    "expand": "candidates",
    "SweepRun": "engine",
    "dask_client": "engine",
    "run_sweep": "engine",
    "evaluate_candidate": "evaluate",
    "write_outputs": "report",
    "SpecError": "spec",
    "SweepSpec": "spec",
    "load_spec": "spec",
    "parse_spec": "spec",
    "shipped_specs": "spec",
}

__all__ = [
    "Candidate",
    "SpecError",
    "SweepRun",
    "SweepSpec",
    "dask_client",
    "evaluate_candidate",
    "expand",
    "load_spec",
    "parse_spec",
    "run_sweep",
    "shipped_specs",
    "write_outputs",
]


def __getattr__(name: str) -> Any:
    """The public name `name`, imported from its module on first use (PEP 562)."""
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{home}"), name)
    globals()[name] = value
    return value
