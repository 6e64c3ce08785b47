"""Reporting: Table I, Figures 2–4, the animation, and whole-or-nothing output directories.

No physics here: everything is read from a :class:`bracekit.simulation.RunResult`.
"""

from bracekit.report.output import write_run
from bracekit.report.table import PAPER_TABLE_I, table_rows

__all__ = ["PAPER_TABLE_I", "table_rows", "write_run"]
