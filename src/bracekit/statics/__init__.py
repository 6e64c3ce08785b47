"""Quasi-static force analysis of the braced robot: preloaded equilibrium, load capacity, actuator relief.

``equilibrium``: spring set points for a preload at q and the first-order contact-wrench and torque response to
a tool wrench. ``capacity``: the scale of each tool wrench at which the brace lifts off, slips or an actuator
saturates. ``relief``: the peak actuator load in free space against braced with the best constant preload (LP).
"""

from bracekit.statics.capacity import (
    Capacity,
    CapacityAlong,
    capacity_along,
    capacity_of,
    effort_limits,
    liftoff_scale,
    load_capacity,
    peak_ratio,
    saturation_scale,
    slip_scale,
)
from bracekit.statics.equilibrium import ContactResponse, gravity_torque, load_contact_wrenches
from bracekit.statics.relief import Relief, actuator_relief, actuator_torques, relief_of
from bracekit.statics.stacked import ContactResponses, contact_response, contact_responses

__all__ = [
    "Capacity",
    "CapacityAlong",
    "ContactResponse",
    "ContactResponses",
    "Relief",
    "actuator_relief",
    "actuator_torques",
    "capacity_along",
    "capacity_of",
    "contact_response",
    "contact_responses",
    "effort_limits",
    "gravity_torque",
    "liftoff_scale",
    "load_capacity",
    "load_contact_wrenches",
    "peak_ratio",
    "relief_of",
    "saturation_scale",
    "slip_scale",
]
