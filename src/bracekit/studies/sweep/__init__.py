"""Design sweeps: whole-task runs over brace locations, regions, tasks and stiffness, on Dask distributed.

A spec (TOML) is a base scenario plus axes; each candidate runs the whole task with feasibility checks, after a
batch screening; the rows go to results.parquet / results.csv, a ranked table, a heatmap and a Pareto plot.
"""

from bracekit.studies.sweep.candidates import Candidate, expand
from bracekit.studies.sweep.engine import SweepRun, dask_client, run_sweep
from bracekit.studies.sweep.evaluate import evaluate_candidate
from bracekit.studies.sweep.report import write_outputs
from bracekit.studies.sweep.spec import SpecError, SweepSpec, load_spec, parse_spec, shipped_specs

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
