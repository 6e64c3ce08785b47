"""Shared fixtures: random serial chains as URDF text, and the shipped models."""

from __future__ import annotations

import numpy as np
import pytest


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


@pytest.fixture
def chain_urdf() -> str:
    """A 9-joint random chain braced on link 5 (n1 = 5 is not 6 on purpose)."""
    return random_chain_urdf(9, seed=3, brace_link=5)
