"""A braced cobot: a worker guides a braced robot through admittance control in MuJoCo while the work loads its tool.

``config`` (the cobot scenario TOML), ``worker`` (the hand's impedance and the process wrench), ``loop`` (the
closed loop of one strategy in MuJoCo), ``report`` (the numbers per strategy, the table and the figure). Needs
MuJoCo (extra ``[validate]``).
"""

from bracekit.cobot.config import CobotScenario, load_cobot, shipped_cobots

__all__ = ["CobotScenario", "load_cobot", "shipped_cobots"]
