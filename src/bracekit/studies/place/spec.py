"""What `bracekit place` places on: a sweep spec, or a scenario taken as a spec.

A spec gives the base scenario, the link axis, the surface and the feasibility rules; a scenario is taken as
the spec ``{base = SCENARIO, axes = {link = "all"}}`` with the sweep's default rules.
"""

from __future__ import annotations

import os
from pathlib import Path

from bracekit._io import read_toml
from bracekit.errors import InputError
from bracekit.simulation.scenario import shipped_scenarios
from bracekit.studies.place.surface import SurfaceKind
from bracekit.studies.sweep.spec import SweepSpec, load_spec, parse_spec, shipped_specs


def load_place_spec(source: str) -> SweepSpec:
    """The spec of `source`: a shipped spec or scenario name, or a TOML file (a spec has a ``base`` key).

    Raises:
        InputError (SpecError, ScenarioError): the source is missing, not TOML, or malformed.
    """
    if source in shipped_specs():
        return load_spec(source)
    if source in shipped_scenarios():
        return parse_spec({"name": f"place-{source}", "base": source, "axes": {"link": "all"}})
    path = Path(source)
    if not path.is_file():
        names = ", ".join(sorted({*shipped_specs(), *shipped_scenarios()}))
        raise InputError(f"no spec or scenario {source!r}: give a .toml file or one of: {names}")
    data = read_toml(path, "spec or scenario")
    if "base" in data:
        return load_spec(path)
    other = sorted({"admittance", "operator", "process", "control"} & set(data))
    if other:
        raise InputError(
            f"{source!r} is a `bracekit cobot` scenario (it has [{other[0]}]); `bracekit place` takes a place spec "
            "(a TOML with a 'base' key) or a run scenario"
        )
    base = os.fspath(path.resolve())
    return parse_spec({"name": f"place-{path.stem}", "base": base, "axes": {"link": "all"}}, base=path.parent)


def default_surface(spec: SweepSpec) -> SurfaceKind:
    """The surface `bracekit place` puts the pad on by default: the sweep's for the same spec.

    ``collision`` when the spec has an ``angle`` axis (the sweep then puts each candidate's pad on the link's
    collision surface at (fraction, angle), docs/geometry.md), else ``capsule`` (the sweep's candidate is then a
    point of the joint line, and the capsule about it is the surface nearest to it).
    """
    return "collision" if spec.axis("angle") is not None else "capsule"
