"""Braced kinematics (Section III): the model :class:`BracedRobot` and the state :class:`BracedState` at q."""

from bracekit.kinematics.braced import BracedRobot, BracedState, ContactState, FramePlacements, skeleton
from bracekit.kinematics.constraint import StackedConstraint, contact_null_space, stacked_constraint
from bracekit.kinematics.hessian import LWA, check_hessian_layout, frame_hessian, frame_hessian_rows
from bracekit.kinematics.split import BraceSplit, ChainSplit

__all__ = [
    "LWA",
    "BraceSplit",
    "BracedRobot",
    "BracedState",
    "ChainSplit",
    "ContactState",
    "FramePlacements",
    "StackedConstraint",
    "check_hessian_layout",
    "contact_null_space",
    "frame_hessian",
    "frame_hessian_rows",
    "skeleton",
    "stacked_constraint",
]
