"""Typed exceptions and warnings of bracekit: every exception the library raises derives from BracekitError.

Every error a user can cause derives from :class:`InputError` (also a ValueError); the command line maps it
to exit code 2. Numerical trouble (singularities, non-convergence, barriers at their limit, failed physics
checks) derives from :class:`NumericalError` (exit code 1), so callers can tell a bad input from a hard
configuration.
"""

from __future__ import annotations


class BracekitError(Exception):
    """Base class of every bracekit error."""


class InputError(BracekitError, ValueError):
    """Bad user input: a file, a name, a value or a scenario key. The message says how to fix it."""


class ModelError(InputError):
    """A robot model that bracekit cannot use (missing URDF, unsupported joint, unknown frame)."""


class FrameNotFoundError(ModelError, KeyError):
    """A frame or link name that the robot does not have."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class ContactError(InputError):
    """A contact, surface or brace that is ill-defined (zero normal, brace not on the chain to the tip)."""


class ScenarioError(InputError):
    """A scenario file with a missing, unknown or malformed key."""


class NumericalError(BracekitError, ArithmeticError):
    """A computation that cannot give a finite, trustworthy result."""


class SingularityError(NumericalError):
    """A Jacobian (or J1 of the braced chain) is singular or too ill-conditioned to invert."""


class UnstableEquilibriumError(NumericalError):
    """The loaded static equilibrium is unstable: the tangent stiffness is not positive on the allowed motions."""


class BarrierError(NumericalError):
    """A barrier term is at or beyond its limit (e.g. the bracing point left the bracing region)."""


class JointLimitError(NumericalError):
    """A step would take a joint beyond its URDF limits and the strategy cannot keep it inside."""


class ConvergenceError(NumericalError):
    """An iterative solve (pose correction, static equilibrium, start configuration) did not converge."""


class StaticSolveError(ConvergenceError):
    """The nonlinear static equilibrium cannot be computed (no convergence, singular KKT system, unloaded contact)."""


class MujocoValidationError(NumericalError):
    """A MuJoCo check could not produce a trustworthy result (instability, no settling, a rejected model)."""


class MissingDependencyError(InputError):
    """An optional dependency is not installed; the message names the extra to install."""


class BracekitWarning(UserWarning):
    """Base class of bracekit's warnings."""


class UnloadedContactWarning(BracekitWarning):
    """The contact carries no load from chain 1 along some constraint direction (Xᵀ C1 X is singular)."""


class RedundantContactWarning(BracekitWarning):
    """Several braces constrain the same motion (dependent rows of the stacked constraint G): one is dropped."""


class NoRedundancyWarning(BracekitWarning):
    """Gradient projection was asked for where the task leaves no null space: it equals minimum norm."""


class RegionWarning(BracekitWarning):
    """The bracing point left the bracing region during a run whose strategy does not guard it."""


class JointLimitWarning(BracekitWarning):
    """A run started with a joint beyond its URDF limits (the steps of a run never take one beyond them)."""


class OutputError(InputError):
    """An output folder bracekit may not or cannot write: not a folder, in use, or holding files it did not write."""


class ChainSingularWarning(BracekitWarning):
    """Chain 1 is singular (J1 loses rank): it realises fewer braced motions of {b} than the contact allows."""


class PadAxisWarning(BracekitWarning):
    """The pad axis of {b} points away from the surface at the start (θ_z > π/2): likely given with the wrong sign."""


class HoldingWarning(BracekitWarning):
    """The brace would lift off or slip, or an actuator saturate, under the listed loads or unloaded."""


class ClearanceWarning(BracekitWarning):
    """A link of the robot entered the surface as a solid obstacle (negative clearance)."""


class PadPlacementWarning(BracekitWarning):
    """A brace point given inside its link's collision geometry (the warning gives the depth), or off its surface."""
