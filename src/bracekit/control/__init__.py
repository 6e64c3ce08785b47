"""Control of a braced robot at a control rate: one tick of the resolution that keeps every brace, and admittance.

``step``: :class:`ControlStep`, q̇ and the servo set point for (q, ẋ), any strategy, any number of braces.
``admittance``: :class:`Admittance`, the virtual mass–damper a worker's wrench drives.
"""

from bracekit.control.admittance import Admittance, AdmittanceState
from bracekit.control.step import ControlResult, ControlStep

__all__ = ["Admittance", "AdmittanceState", "ControlResult", "ControlStep"]
