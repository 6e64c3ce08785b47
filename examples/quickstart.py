"""Quick start: load the paper's robot, brace it on a table, and compare its tip compliance with free space.

Run: python examples/quickstart.py
"""

import numpy as np

import bracekit as bk

robot = bk.load_model("paper-robot")  # PUMA 560 + five HEBI X8-16, 170 N·m/rad per joint
q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])

# Put a horizontal table under the bracing pad at this configuration.
b = bk.BracedRobot(robot, bk.Brace("brace", bk.Surface([0, 0, 0], [0, 0, 1]))).state(q).split.b
braced = bk.BracedRobot(robot, bk.Brace("brace", bk.Surface(b, [0, 0, 1]), region_radius=0.15))
state = braced.state(q)

beta_z = [0, 0, 1, 0, 0, 0]  # vertical deflection at the tool
free = bk.compliance_index(bk.free_space_compliance(state), beta_z)
constrained = bk.compliance_index(bk.end_effector_compliance(state, "constrained"), beta_z)
projection = bk.compliance_index(bk.end_effector_compliance(state, "projection"), beta_z)
print(f"chain 1: {braced.split.n1} joints, chain 2: {braced.split.n2} joints; tool at {np.round(state.e, 3)} m")
print(f"vertical compliance index C_i: free {1e3 * free:.2f} mm/N")
print(f"  braced: {1e3 * constrained:.2f} mm/N (constrained, exact), {1e3 * projection:.2f} mm/N (paper's projection)")
print(f"k of J = {bk.frobenius_condition(state.J_e):.2f}, k of J̃ = {bk.frobenius_condition(state.split.J_braced):.2f}")
