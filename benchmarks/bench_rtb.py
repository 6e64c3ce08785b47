"""Robotics Toolbox for Python on the paper robot's URDF chain, beside Pinocchio, when it is installed."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from bracekit.kinematics import BracedRobot
from bracekit.model import model_path


def rtb_benchmarks(braced: BracedRobot, q: np.ndarray, calls: int, rounds: int) -> dict[str, Any]:
    """Robotics Toolbox for Python on the same URDF chain, if it is installed (never a dependency)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb
    except Exception as exc:  # ImportError, or a broken install
        return {"available": False, "reason": f"roboticstoolbox not importable ({type(exc).__name__})"}
    try:
        path = model_path("paper-robot")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:  # roboticstoolbox ≥ 1.2
                from roboticstoolbox.models.URDF.URDFRobot import URDF_read

                links, name, *_ = URDF_read(str(path))
                robot = rtb.Robot(links, name=name)
            except ImportError:  # older releases
                robot = rtb.Robot.URDF(str(path))
        tip = braced.robot.tip
        state = braced.state(q, hessians=True)
        j0 = np.asarray(robot.jacob0(q, end=tip))
        h0 = np.asarray(robot.hessian0(q, end=tip))  # (n, 6, n): [k, :, i] = ∂J[:, i]/∂q_k
        diff = max(float(np.max(np.abs(j0 - state.J_e))), float(np.max(np.abs(h0.transpose(1, 2, 0) - state.dJ_e))))
        from bench_core import _interleaved

        t = _interleaved(
            {
                "jacob0": (lambda: robot.jacob0(q, end=tip), calls),
                "hessian0": (lambda: robot.hessian0(q, end=tip), calls),
            },
            rounds,
        )
        return {
            "available": True,
            "version": getattr(rtb, "__version__", "?"),
            "jacob0_us": 1e6 * t["jacob0"],
            "hessian0_us": 1e6 * t["hessian0"],
            "max_abs_diff_vs_pinocchio": diff,
        }
    except Exception as exc:
        return {"available": False, "reason": f"roboticstoolbox failed on the URDF: {type(exc).__name__}: {exc}"}
