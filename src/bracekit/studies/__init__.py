"""Studies on top of the model: everything at one configuration, and where to brace along the robot."""

from bracekit.studies.brace_location import BraceCandidate, brace_location_study
from bracekit.studies.evaluate import evaluate

__all__ = ["BraceCandidate", "brace_location_study", "evaluate"]
