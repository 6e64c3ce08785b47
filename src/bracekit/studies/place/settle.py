"""Whether MuJoCo's static check settles on a place's scenario: the placement's last rule before it names a best.

`bracekit validate` (docs/validation.md) loads the braced chain's tip with small dead wrenches in MuJoCo (a
frictionless sphere on the surface's plane, preloaded) and needs the chain to settle, max|q̇|·τ below its tolerance,
in every case. A place whose whole-task run is feasible by the sweep's rules may still give a chain MuJoCo does not
settle (a contact MuJoCo does not regularise drops in and out on round-off; :mod:`bracekit.validate.mjcf` gives each
contact sphere a body of its own for that reason). A place whose scenario MuJoCo cannot check is not named the best:
:func:`settles` runs one load case of the check (the validation's preload, force magnitude, contact and first
timestep, at the solved start) on a smaller step budget, and the engine takes the best place that settles
(:mod:`bracekit.studies.place.engine`). The check is one-sided: a place it passes settles in the validation's case
too (the same simulation, more steps allowed there); the validation may settle, at a smaller timestep or after more
steps, where it gave up.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from bracekit.errors import BracekitError
from bracekit.simulation.scenario_model import Scenario

#: The load of the check (N, world axes): the validation's force magnitude, pressing the tip down.
FORCE = np.array([0.0, 0.0, -0.5, 0.0, 0.0, 0.0])

#: The contact preload (N) of the validation's compliance check, and the step budget: a settling case takes
#: about 10000 steps on these arms; the validation allows 100000 (the check is conservative).
PRELOAD = 1.0
MAX_STEPS = 30_000


class Settled(NamedTuple):
    """Whether MuJoCo settled under the check's load, and why not (None when it did)."""

    ok: bool
    message: str | None


def settles(scenario: Scenario) -> Settled:
    """MuJoCo's static check of `scenario` at its solved start under :data:`FORCE`; never raises a BracekitError."""
    from bracekit.validate.contacts import plane_contacts
    from bracekit.validate.inputs import MUJOCO_SETTINGS, validation_configurations
    from bracekit.validate.mujoco_check import mujoco_static_deflection

    try:
        q = validation_configurations(scenario, 1)[0]
        robot = scenario.braced.robot
        contacts = plane_contacts(scenario.braced, PRELOAD)
        mujoco_static_deflection(
            robot.model, q, robot.stiffness, robot.tip_id, contacts, FORCE, max_steps=MAX_STEPS,
            sphere_radius=MUJOCO_SETTINGS["sphere_radius_m"],
        )  # fmt: skip
    except (BracekitError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return Settled(False, f"MuJoCo's static check: {exc}")
    return Settled(True, None)
