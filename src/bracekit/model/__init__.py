"""The robot model: a serial chain from URDF (Pinocchio), its tip frame and joint stiffnesses; shipped robots."""

from bracekit.model.robot import Robot
from bracekit.model.shipped import MODELS, default_brace_frame, load_model, model_path

__all__ = ["MODELS", "Robot", "default_brace_frame", "load_model", "model_path"]
