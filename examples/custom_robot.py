"""Any URDF robot: brace an 8-joint arm at a point of its fourth link and run a line task with each strategy.

Run: python examples/custom_robot.py
"""

import warnings

import numpy as np

import bracekit as bk
from bracekit.errors import RegionWarning

URDF = """
<robot name="arm8">
  <link name="base"/>
  <link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/>
  <link name="l5"/><link name="l6"/><link name="l7"/><link name="l8"/>
  <link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0 0 0.35"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j5" type="revolute"><parent link="l4"/><child link="l5"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j6" type="revolute"><parent link="l5"/><child link="l6"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j7" type="revolute"><parent link="l6"/><child link="l7"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j8" type="revolute"><parent link="l7"/><child link="l8"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="l8"/><child link="tool"/><origin xyz="0 0 0.1"/></joint>
</robot>
"""

# 8 joints, one contact constraint: 7 DoF for a 6-DoF task, so one redundant DoF.
# Stiffer shoulder, softer wrist (N·m/rad); {b} is a pad 5 cm out from link 4's axis.
robot = bk.Robot.from_urdf(URDF, tip="tool", stiffness=[400, 400, 300, 300, 150, 150, 150, 150])
robot = robot.with_point_frame("pad", "l4", offset=[0.05, 0.0, 0.15])
q0 = np.array([0.3, 0.9, 0.4, 1.2, -0.5, -0.6, 0.3, 0.4])

# A vertical wall through the pad, normal pointing back at the robot.
probe = bk.BracedRobot(robot, bk.Brace("pad", bk.Surface([0, 0, 0], [-1, 0, 0]))).state(q0)
braced = bk.BracedRobot(robot, bk.Brace("pad", bk.Surface(probe.split.b, [-1, 0, 0]), region_radius=0.2))
print(f"n1 = {braced.split.n1} (chain 1 is not 6 joints: the braced motions of b are the null space of Xᵀ J1)")

e0 = braced.state(q0).e
task = bk.Line(e0, e0 + np.array([0.0, 0.1, -0.05]), duration=2.0)
beta_x = lambda t: np.array([1.0, 0, 0, 0, 0, 0])  # noqa: E731 - compliance along the wall normal
objective = bk.Objective(
    [bk.ComplianceIndex(beta_x(0.0)), bk.ConditionNumber(), bk.RegionBarrier(0.2, probe.split.b)], [100.0, 0.5, 0.01]
)
for strategy in (bk.FreeSpaceMinNorm(), bk.BracedMinNorm(), bk.BracedGradientProjection(objective, alpha=-1.0)):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RegionWarning)
        tr = bk.simulate(braced, strategy, task, q0, 0.05, beta_x)
    s = tr.summary()
    print(
        f"{strategy.name:28s} completed={s['completed']}  mean C_i = {1e3 * s['Ci_mean']:.3f} mm/N "
        f"(braced model) / {1e3 * np.mean(tr.measures['Ci_free']):.3f} mm/N (free)  "
        f"contact violation {s['max_contact_violation_m']:.1e} m"
    )
    if tr.failure:
        print("   ", tr.failure)
