"""The record of one load case of the deflection checks (compliance and preloaded): predictions vs references.

A case's first-order predictions Δx_pred = C w (one per model) against the static solve's and MuJoCo's
deflections [Δp; Δθ] (m, rad, world axes) under the same tip wrench w, with errors in ‖·‖_L
(:func:`~bracekit.validate.table._rel_err`, L in m). JSON-able dicts, one layout for both checks.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bracekit.validate.inputs import Array
from bracekit.validate.table import _rel_err

__all__ = ["case_record", "failed_record"]


def case_record(
    head: dict[str, Any],
    w: Array,
    pred: dict[str, Array],
    refs: dict[str, Any],
    messages: list[str],
    length: float,
    opened_note: str,
) -> dict[str, Any]:
    """One compared case: ``head`` (its config, label, …) then status, deflections, errors and contact forces.

    ``refs``: the static and MuJoCo results (None where they failed, the failures in ``messages``) and the
    MuJoCo timestep; ``pred``: each model's Δx = C w; ``length``: L (m). The status is ``failed`` with a
    message, ``contact_opened`` (``opened_note`` added: kept out of the statistics) or ``ok``.
    """
    st, mj = refs["static"], refs["mujoco"]
    ref = {
        "static": None if st is None else np.asarray(st.deflection, dtype=float),
        "mujoco": None if mj is None else np.asarray(mj.deflection, dtype=float),
    }
    opened = bool((st is not None and st.contact_opened) or (mj is not None and mj.contact_opened))
    status = "failed" if messages else ("contact_opened" if opened else "ok")
    if status == "contact_opened":
        messages.append(opened_note)
    return {
        **head,
        "wrench": w.tolist(),
        "status": status,
        "message": "; ".join(messages) if messages else None,
        "length_scale_m": length,
        "deflection": {
            **{k: (None if v is None else v.tolist()) for k, v in ref.items()},
            **{m: c.tolist() for m, c in pred.items()},
        },
        "rel_err": {m: {k: _rel_err(c, ref[k], length) for k in ("mujoco", "static")} for m, c in pred.items()},
        "rel_err_mujoco_vs_static": (
            _rel_err(ref["mujoco"], ref["static"], length) if ref["mujoco"] is not None else None
        ),
        "contact_force_static": None if st is None else float(st.contact_force),
        "contact_force_mujoco": None if mj is None else float(mj.contact_force),
        "opened": opened,
        "opened_static": None if st is None else bool(st.contact_opened),
        "opened_mujoco": None if mj is None else bool(mj.contact_opened),
        "mujoco_steps": None if mj is None else int(mj.steps),
        "contact_forces_static": None if st is None else st.contact_forces.tolist(),
        "contact_forces_mujoco": None if mj is None else mj.contact_forces.tolist(),
        "mujoco_timestep_s": refs["timestep"],
    }


def failed_record(
    head: dict[str, Any], w: Array, models: tuple[str, ...], length: float | None, message: str
) -> dict[str, Any]:
    """A case that could not be compared (``message`` says why): the layout of :func:`case_record`, all None."""
    return {
        **head,
        "wrench": w.tolist(),
        "status": "failed",
        "message": message,
        "length_scale_m": length,
        "deflection": {k: None for k in ("mujoco", "static", *models)},
        "rel_err": {m: {"mujoco": None, "static": None} for m in models},
        "rel_err_mujoco_vs_static": None,
        "contact_force_static": None,
        "contact_force_mujoco": None,
        "opened": False,
        "opened_static": None,
        "opened_mujoco": None,
        "mujoco_steps": None,
        "contact_forces_static": None,
        "contact_forces_mujoco": None,
        "mujoco_timestep_s": None,
    }
