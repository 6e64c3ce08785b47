"""Test helpers: random serial chains as URDF text, Pinocchio references, the paper scenario's text."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np


def random_chain_urdf(n: int, seed: int, brace_link: int | None = None, brace_offset: float = 0.05) -> str:
    """URDF text of an n-joint revolute chain with random axes and link offsets.

    Links are `base`, `l1`..`ln`; the tip frame is `tip` (fixed, 0.1 m beyond `ln`). If `brace_link` is
    given, a fixed frame `brace` sits on link `l{brace_link}` at a random offset of about brace_offset m.
    """
    rng = np.random.default_rng(seed)
    parts = ['<robot name="chain">', '<link name="base"/>']
    parent = "base"
    for i in range(1, n + 1):
        xyz = rng.uniform(-0.05, 0.25, 3) if i > 1 else np.array([0.0, 0.0, 0.1])
        rpy = rng.uniform(-np.pi, np.pi, 3)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        parts.append(
            f'<link name="l{i}"><inertial><mass value="0.5"/>'
            '<inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )
        parts.append(
            f'<joint name="j{i}" type="revolute"><parent link="{parent}"/><child link="l{i}"/>'
            f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
            f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
            '<limit lower="-3.14" upper="3.14" effort="10" velocity="1"/></joint>'
        )
        parent = f"l{i}"
    parts.append('<link name="tip"/>')
    parts.append(
        f'<joint name="tip_joint" type="fixed"><parent link="l{n}"/><child link="tip"/>'
        '<origin xyz="0.1 0.02 0.03" rpy="0 0 0"/></joint>'
    )
    if brace_link is not None:
        off = rng.normal(size=3)
        off *= brace_offset / np.linalg.norm(off)
        parts.append('<link name="brace"/>')
        parts.append(
            f'<joint name="brace_joint" type="fixed"><parent link="l{brace_link}"/><child link="brace"/>'
            f'<origin xyz="{off[0]} {off[1]} {off[2]}" rpy="0.3 -0.2 0.1"/></joint>'
        )
    parts.append("</robot>")
    return "\n".join(parts)


def branched_chain_urdf(joint_type: str = "revolute") -> str:
    """URDF of a 4-joint revolute chain base→l1..l4→`tip` with a side branch on l2.

    The side branch is joint `a_side_joint` (of type `joint_type`, e.g. revolute, or `continuous`) from l2
    to link `side`, which carries a fixed frame `side_tool`. Pinocchio orders sibling joints by name, so
    it numbers the side joint between j2 and j3 (the reduced model must drop a joint inside the chain).
    """
    limit = '<limit lower="-3" upper="3" effort="10" velocity="1"/>'
    joints = [
        ("j1", "base", "l1", "0 0 0.1", "0 0 1"),
        ("j2", "l1", "l2", "0 0.1 0.2", "0 1 0"),
        ("a_side_joint", "l2", "side", "0.1 -0.2 0", "1 0 0"),
        ("j3", "l2", "l3", "0.3 0 0", "0 1 0"),
        ("j4", "l3", "l4", "0.25 0.05 0", "1 0 0"),
    ]
    parts = ['<robot name="branched">', '<link name="base"/>']
    for link in ("l1", "l2", "side", "l3", "l4", "tip", "side_tool"):
        parts.append(f'<link name="{link}"/>')
    for name, parent, child, xyz, axis in joints:
        kind = joint_type if name == "a_side_joint" else "revolute"
        lim = "" if kind == "continuous" else limit
        parts.append(
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="0.1 0.2 0.3"/><axis xyz="{axis}"/>{lim}</joint>'
        )
    parts.append(
        '<joint name="tip_joint" type="fixed"><parent link="l4"/><child link="tip"/>'
        '<origin xyz="0.1 0 0" rpy="0 0 0"/></joint>'
    )
    parts.append(
        '<joint name="side_tool_joint" type="fixed"><parent link="side"/><child link="side_tool"/>'
        '<origin xyz="0.05 0 0" rpy="0 0 0"/></joint>'
    )
    parts.append("</robot>")
    return "\n".join(parts)


def continuous_chain_urdf(n: int, seed: int, continuous: tuple[int, ...] = (1, 3)) -> tuple[str, str]:
    """(URDF with joints j{i}, i in `continuous`, of type continuous and no <limit>, its revolute original).

    The chain is :func:`random_chain_urdf` (n joints, links base, l1..ln, tip frame `tip`).
    """
    revolute = random_chain_urdf(n, seed)
    text = revolute
    limit = '<limit lower="-3.14" upper="3.14" effort="10" velocity="1"/>'
    for i in continuous:
        head = f'<joint name="j{i}" type="revolute">'
        start = text.index(head)
        end = text.index("</joint>", start)
        body = text[start:end].replace(head, f'<joint name="j{i}" type="continuous">').replace(limit, "")
        text = text[:start] + body + text[end:]
    return text, revolute


def mimic_gripper_urdf(mimic_on_chain: bool = False) -> str:
    """A 3-joint chain base→l1..l3→`tip` with a two-finger gripper on l3 (finger_2 mimics finger_1).

    With `mimic_on_chain`, joint j3 mimics j2 instead (a coupled joint on the chain to the tip).
    """
    limit = '<limit lower="-2" upper="2" effort="10" velocity="1"/>'
    joints = [
        ("j1", "revolute", "base", "l1", "0 0 0.1", "0 0 1", ""),
        ("j2", "revolute", "l1", "l2", "0 0 0.3", "0 1 0", ""),
        ("j3", "revolute", "l2", "l3", "0.3 0 0", "0 1 0", '<mimic joint="j2"/>' if mimic_on_chain else ""),
        ("finger_1", "prismatic", "l3", "f1", "0.1 0.02 0", "0 1 0", ""),
        ("finger_2", "prismatic", "l3", "f2", "0.1 -0.02 0", "0 -1 0", '<mimic joint="finger_1" multiplier="1"/>'),
    ]
    parts = ['<robot name="gripper">', '<link name="base"/>']
    parts += [f'<link name="{link}"/>' for link in ("l1", "l2", "l3", "f1", "f2", "tip")]
    for name, kind, parent, child, xyz, axis, extra in joints:
        parts.append(
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="0 0 0"/><axis xyz="{axis}"/>{limit}{extra}</joint>'
        )
    parts.append(
        '<joint name="tip_joint" type="fixed"><parent link="l3"/><child link="tip"/>'
        '<origin xyz="0.15 0 0" rpy="0 0 0"/></joint></robot>'
    )
    return "\n".join(parts)


def iiwa_like_urdf() -> str:
    """URDF of a 7-joint arm with the KUKA LBR iiwa 14's kinematics (approximately) and limits.

    Joint axes z, y, z, −y, z, y, z; shoulder, elbow, wrist and flange 0.36, 0.42, 0.40 and 0.126 m apart
    along the arm at q = 0. Links link_0 (base) .. link_7, tip frame `tool` on the flange.
    """
    heights = [0.1575, 0.2025, 0.2045, 0.2155, 0.1845, 0.2155, 0.081]
    axes = ["0 0 1", "0 1 0", "0 0 1", "0 -1 0", "0 0 1", "0 1 0", "0 0 1"]
    limits = [170, 120, 170, 120, 170, 120, 175]
    speeds = [1.48, 1.48, 1.75, 1.31, 2.27, 2.36, 2.36]
    parts = ['<robot name="iiwa_like">', '<link name="link_0"/>']
    for i in range(7):
        lim = np.radians(limits[i])
        parts.append(f'<link name="link_{i + 1}"/>')
        parts.append(
            f'<joint name="joint_{i + 1}" type="revolute"><parent link="link_{i}"/><child link="link_{i + 1}"/>'
            f'<origin xyz="0 0 {heights[i]}" rpy="0 0 0"/><axis xyz="{axes[i]}"/>'
            f'<limit lower="{-lim}" upper="{lim}" effort="100" velocity="{speeds[i]}"/></joint>'
        )
    parts.append(
        '<link name="tool"/><joint name="tool_joint" type="fixed"><parent link="link_7"/><child link="tool"/>'
        '<origin xyz="0 0 0.126" rpy="0 0 0"/></joint></robot>'
    )
    return "\n".join(parts)


def iiwa_scenario_text(pad_axis: bool) -> str:
    """A scenario for :func:`iiwa_like_urdf` (file ``iiwa.urdf`` next to it): the forearm braced on a table.

    {b} is a point under link_4 (the forearm, whose z runs along it); the tip moves along a 0.12 m line
    holding its orientation. With `pad_axis` the point's pad direction is link_4's −x (up at the guess) and
    θ_z is weighted; without, θ_z has weight 0.
    """
    pad = "pad_axis = [-1.0, 0.0, 0.0]\n" if pad_axis else ""
    theta = "theta_z = 0.6, " if pad_axis else ""
    return f"""name = "iiwa-forearm"
[robot]
urdf = "iiwa.urdf"
tip = "tool"
[brace]
frame = "pad"
link = "link_4"
offset = [0.06, 0.0, 0.1]
{pad}point = [0.34, 0.0, 0.647]
normal = [0.0, 0.0, 1.0]
region_radius = 0.15
[task]
type = "line"
start = [0.70, -0.06, 0.50]
end = [0.70, 0.06, 0.50]
duration = 4.0
[start]
guess = [0.0, 0.6, 0.0, -0.97, 0.0, 1.2, 0.0]
[compliance]
beta_x = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0]
[gradient_projection]
# link_3 starts 0.03 m inside the table's disk: the clearance barrier (on by default) would refuse the start
weights = {{ k = 0.5, Ci = 100.0, {theta}d = 0.01, clearance = 0.0 }}
[simulation]
dt = 0.05
"""


def pin_frame_jacobian(model, frame: str, q: np.ndarray) -> np.ndarray:
    """Reference: Pinocchio's LOCAL_WORLD_ALIGNED frame Jacobian (6×nv) from a fresh computeFrameJacobian."""
    import pinocchio as pin

    data = model.createData()
    fid = model.getFrameId(frame)
    return np.asarray(
        pin.computeFrameJacobian(model, data, np.asarray(q, dtype=float), fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    ).copy()


def pin_frame_placement(model, frame: str, q: np.ndarray):
    """Reference: the world placement (pin.SE3) of a frame from a fresh framesForwardKinematics."""
    import pinocchio as pin

    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
    return data.oMf[model.getFrameId(frame)].copy()


def random_unit(rng: np.random.Generator, size: int = 3) -> np.ndarray:
    """A random unit vector."""
    v = rng.normal(size=size)
    return v / np.linalg.norm(v)


PAPER_TOML = Path(__file__).resolve().parents[1] / "src" / "bracekit" / "simulation" / "scenarios" / "paper.toml"


def scenario_text(**task: float) -> str:
    """The paper scenario's TOML with the task's scalar keys replaced (e.g. period=2.0) and dt=0.1."""
    text = PAPER_TOML.read_text(encoding="utf-8")
    for key, value in task.items():
        text = re.sub(rf"(?m)^{key} = .*$", f"{key} = {value}", text, count=1)
    return text


def solve_planes(model, q0, stiffness, brace_ids, tip_id, surfaces, wrench, *, preload=0.0, constraint_wrenches=None):  # type: ignore[no-untyped-def]
    """The nonlinear static solve (bracekit.validate.statics.solve_statics) with bilateral rigid plane contacts.

    One (point, normal) per brace frame id, one preload (N) each or one for all, and optionally each contact's
    constraint wrenches X_i (6×c_i, world axes; default [n̂; 0]).
    """
    import numpy as np

    from bracekit.validate.plane_contact import PlaneContact
    from bracekit.validate.statics import solve_statics

    loads = np.broadcast_to(np.asarray(preload, dtype=float), (len(brace_ids),))
    xs = [None] * len(brace_ids) if constraint_wrenches is None else list(constraint_wrenches)
    contacts = [
        PlaneContact(int(f), np.asarray(pt, dtype=float), np.asarray(nh, dtype=float), float(p), x)
        for f, (pt, nh), p, x in zip(brace_ids, surfaces, loads, xs, strict=True)
    ]
    return solve_statics(model, q0, stiffness, tip_id, contacts, np.asarray(wrench, dtype=float))
