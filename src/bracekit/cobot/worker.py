"""The worker and the work: a hand pulling the handle through a human-arm impedance, and the process wrench.

The hand follows a minimum-jerk path to each target in ``travel`` s (Flash and Hogan's model of a point-to-point
reach), holds there for ``approach`` s, and lets go of the handle for the ``dwell`` (the work), gripping again
where the handle then is. Its force on the handle is the arm's impedance,

    F_h = γ(t) [K_h (h − e) + D_h (ḣ − ė)] + tremor,

K_h, D_h the arm's stiffness and damping (N/m, N·s/m; a relaxed human arm: K_h ≈ 200–800 N/m, D_h ≈ 10–30 N·s/m,
Tsuji et al. 1995, Burdet et al. 2001), γ ∈ [0, 1] the grip (ramped over the process ramp when gripping or
letting go), the tremor a seeded Gaussian force low-passed at 10 Hz (N rms). The process wrench is on during a
dwell from ``start``, ramped in and out over ``ramp`` with a smoothstep, held ``hold`` s.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from bracekit.cobot.config import CobotScenario

Array = NDArray[np.float64]

__all__ = ["Phase", "Worker", "smoothstep"]

_TREMOR_HZ = 10.0


def smoothstep(x: float) -> float:
    """3x² − 2x³ on [0, 1], 0 before, 1 after."""
    x = min(1.0, max(0.0, x))
    return x * x * (3.0 - 2.0 * x)


class Phase(NamedTuple):
    """Where a time falls: the target index, the phase ("travel", "approach", "dwell") and the time into it (s)."""

    target: int
    name: str
    since: float


class Worker:
    """The hand, its grip and force, and the process wrench of a cobot scenario (module docstring)."""

    def __init__(self, sc: CobotScenario, start: Array) -> None:
        self.sc = sc
        self.op = sc.operator
        self.rng = np.random.default_rng(sc.seed)
        self.tremor = np.zeros(3)
        self.origin = np.asarray(start, dtype=float).copy()
        self.period = self.op.travel + self.op.approach + self.op.dwell

    def phase(self, t: float) -> Phase:
        """The phase at time t (s)."""
        i = min(int(t // self.period), len(self.op.targets) - 1)
        s = t - i * self.period
        if s < self.op.travel:
            return Phase(i, "travel", s)
        if s < self.op.travel + self.op.approach:
            return Phase(i, "approach", s - self.op.travel)
        return Phase(i, "dwell", s - self.op.travel - self.op.approach)

    def regrip(self, e: Array) -> None:
        """The hand takes the handle where it is (the start of the next reach)."""
        self.origin = np.asarray(e, dtype=float).copy()

    def hand(self, ph: Phase) -> tuple[Array, Array]:
        """Hand position (3,) m and velocity (3,) m/s: minimum jerk from the grip point to the target."""
        goal = self.op.targets[ph.target]
        if ph.name != "travel":
            return goal.copy(), np.zeros(3)
        s = ph.since / self.op.travel
        shape = 10 * s**3 - 15 * s**4 + 6 * s**5
        rate = (30 * s**2 - 60 * s**3 + 30 * s**4) / self.op.travel
        return self.origin + shape * (goal - self.origin), rate * (goal - self.origin)

    def grip(self, ph: Phase) -> float:
        """γ ∈ [0, 1]: 1 while guiding, ramped out at a dwell's start and in at a reach's start."""
        ramp = self.sc.process.ramp
        if ph.name == "dwell":
            return 1.0 - smoothstep(ph.since / ramp)
        if ph.name == "travel" and ph.target > 0:
            return smoothstep(ph.since / ramp)
        return 1.0

    def step_tremor(self, dt: float) -> Array:
        """The next tremor force (3,), N: white noise through a first-order low-pass at 10 Hz, seeded."""
        if self.op.tremor == 0.0:
            return self.tremor
        a = np.exp(-2.0 * np.pi * _TREMOR_HZ * dt)
        gain = self.op.tremor * np.sqrt(1.0 - a * a)  # stationary rms = tremor
        self.tremor = a * self.tremor + gain * self.rng.standard_normal(3)
        return self.tremor

    def force(self, ph: Phase, e: Array, edot: Array, dt: float) -> Array:
        """The hand's force on the handle (3,), N, world: γ [K_h (h − e) + D_h (ḣ − ė)] + γ tremor."""
        h, hdot = self.hand(ph)
        tremor = self.step_tremor(dt)
        return self.grip(ph) * (self.op.stiffness * (h - e) + self.op.damping * (hdot - edot) + tremor)

    def process(self, ph: Phase) -> float:
        """The process wrench's scale a ∈ [0, 1] at a phase (0 outside a dwell's work)."""
        if ph.name != "dwell":
            return 0.0
        p = self.sc.process
        x = ph.since - p.start
        return smoothstep(x / p.ramp) - smoothstep((x - p.ramp - p.hold) / p.ramp)
