"""Braced kinematics (Section III): the model :class:`BracedRobot` and the state :class:`BracedState` at q."""

from bracekit.kinematics.braced import BracedRobot, BracedState, contact_null_space, skeleton
from bracekit.kinematics.hessian import LWA, check_hessian_layout, frame_hessian, frame_hessian_rows

__all__ = [
    "LWA",
    "BracedRobot",
    "BracedState",
    "check_hessian_layout",
    "contact_null_space",
    "frame_hessian",
    "frame_hessian_rows",
    "skeleton",
]
