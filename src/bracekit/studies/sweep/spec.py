"""Sweep specs (TOML): a base scenario and the axes of a design study of where to brace, validated at construction.

Every mistake raises :class:`~bracekit.errors.InputError` in one line naming the key. Shipped specs live in
``bracekit/studies/sweep/specs/`` and are addressed by name (``paper-links``). docs/sweep.md lists every key.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import math
import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from bracekit._linalg import show
from bracekit._version import __version__
from bracekit.contact import REGISTRY
from bracekit.errors import InputError
from bracekit.simulation.scenario import parse_scenario, shipped_scenarios
from bracekit.simulation.scenario_model import Scenario
from bracekit.simulation.toml_table import read_source
from bracekit.statics.equilibrium import MAX_FRICTION, MAX_PRELOAD

#: Axes a spec may sweep: name → kind ("link": link names, "scalar", "vector": [x, y, z]).
AXES: dict[str, str] = {
    "link": "link",
    "fraction": "scalar",
    "angle": "scalar",
    "offset": "vector",
    "region_offset": "vector",
    "task_centre": "vector",
    "task_radius": "scalar",
    "stiffness": "scalar",
    "preload": "scalar",
    "friction": "scalar",
}
#: The axes that place the brace on the robot; the others change the task context (the free-space run).
BRACE_AXES = ("link", "fraction", "angle", "offset", "region_offset")
#: Most candidates a spec may expand to.
MAX_CANDIDATES = 100_000
#: The braced strategies a candidate runs (free space runs once per task context).
BRACED_STRATEGIES = ("braced_min_norm", "braced_gradient_projection")
#: The frame name of a candidate's bracing point (a new frame on its link).
POINT_FRAME = "sweep_point"


class SpecError(InputError):
    """A sweep spec with a missing, unknown or malformed key."""


@dataclass(frozen=True)
class Axis:
    """One swept input: explicit ``values``, or a ``range`` [low, high] with a grid ``count``.

    Scalars in SI units (m, N·m/rad, N); vectors are [x, y, z] lists; links are names.
    """

    name: str
    kind: str
    values: tuple[Any, ...] | None = None
    low: Any = None
    high: Any = None
    count: int = 0

    def grid(self) -> list[Any]:
        """The axis's grid values, in order: the listed values, or `count` evenly spaced from low to high."""
        if self.values is not None:
            return list(self.values)
        if self.count == 1:
            return [_mix(self.low, self.high, 0.5)]
        return [_mix(self.low, self.high, i / (self.count - 1)) for i in range(self.count)]


def _mix(low: Any, high: Any, t: float) -> Any:
    if isinstance(low, list):
        return [float(a + t * (b - a)) for a, b in zip(low, high, strict=True)]
    return float(low + t * (high - low))


@dataclass(frozen=True)
class Screening:
    """Batch screening along the free-space path (see :mod:`bracekit.studies.sweep.screen`).

    ``k_max``: largest braced k along the path that passes; ``keep_fraction``: share of a task context's
    candidates, best screened C_i first, that pass; a candidate whose screened C_i is below the free-space
    C_i also passes.
    """

    enabled: bool = True
    k_max: float = 100.0
    keep_fraction: float = 0.3


@dataclass(frozen=True)
class Feasibility:
    """What a candidate's gradient-projection run must meet to be feasible.

    Mean k of J̃ ≤ ``k_max``, link clearance ≥ ``min_clearance`` (m), joint-limit violation ≤
    ``joint_limit_tolerance`` (rad), holding margins ≥ ``min_margin`` when the base has statics (a margin is a
    scale on the listed load: 1 = it holds under the listed wrenches; above 1, a reserve), the run's ``holds``
    not false and no unstable sample.
    """

    k_max: float = 50.0
    min_clearance: float = 0.0
    joint_limit_tolerance: float = 1e-9
    min_margin: float = 1.0


@dataclass(frozen=True)
class Refinement:
    """Bounded scalar optimisation of the fraction along the link for the ``top`` best feasible candidates."""

    top: int = 3
    max_evaluations: int = 12
    xatol: float = 0.01


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep spec. ``base_data`` is the base scenario's TOML data (one brace)."""

    name: str
    description: str
    base_name: str
    base_data: dict[str, Any]
    base_dir: Path
    axes: tuple[Axis, ...]
    mode: str = "grid"
    samples: int = 0
    seed: int = 0
    normal: tuple[float, float, float] | None = None
    region_radius: float | None = None
    surface_radius: float | None = None
    contact: str | None = None
    dt: float | None = None
    screening: Screening = field(default_factory=Screening)
    feasibility: Feasibility = field(default_factory=Feasibility)
    refinement: Refinement = field(default_factory=Refinement)
    source: Path | None = None
    base_path: Path | None = None

    def axis(self, name: str) -> Axis | None:
        """The axis called `name`, or None."""
        return next((a for a in self.axes if a.name == name), None)

    @property
    def axis_names(self) -> tuple[str, ...]:
        """The swept inputs, in spec order."""
        return tuple(a.name for a in self.axes)

    def base_scenario(self) -> Scenario:
        """The base scenario as given (validated)."""
        return parse_scenario(self.base_data, base=self.base_dir, name=self.base_name)

    def base_files(self) -> list[Path]:
        """The files the base scenario is read from: its TOML and, if it names one, its URDF file."""
        files = [] if self.base_path is None else [self.base_path]
        urdf = self.base_data.get("robot", {}).get("urdf")
        if isinstance(urdf, str) and urdf:
            files.append(Path(urdf) if Path(urdf).is_absolute() else self.base_dir / urdf)
        return files

    def fingerprint_parts(self) -> dict[str, str]:
        """What a candidate's row depends on, in three hashes: the spec's inputs, bracekit's version, the files.

        Not the screening, refinement or feasibility bounds: a row's feasibility is judged again on every run.
        """
        data = {
            "base": self.base_data,
            "axes": [a.__dict__ for a in self.axes],
            "sampling": [self.mode, self.samples, self.seed],
            "brace": [self.normal, self.region_radius, self.surface_radius, self.contact, self.dt],
        }
        text = json.dumps(data, sort_keys=True, default=str)
        files = hashlib.sha256()
        for path in self.base_files():
            files.update(path.name.encode() + b"\0")
            try:
                files.update(path.read_bytes())
            except OSError:
                files.update(b"(unreadable)")
        return {
            "spec": hashlib.sha256(text.encode()).hexdigest()[:16],
            "bracekit": __version__,
            "files": files.hexdigest()[:16],
        }

    def fingerprint(self) -> str:
        """A hash of :meth:`fingerprint_parts`: the spec's inputs, bracekit's version and the base's files."""
        text = json.dumps(self.fingerprint_parts(), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def shipped_specs() -> dict[str, Path]:
    """Name → path of the sweep specs shipped with bracekit."""
    root = resources.files("bracekit.studies.sweep").joinpath("specs")
    return {p.name[:-5]: Path(str(p)) for p in root.iterdir() if p.name.endswith(".toml")}


def load_spec(source: str | os.PathLike[str]) -> SweepSpec:
    """Read and validate a sweep spec: a TOML path or a shipped spec's name ('paper-links').

    Raises:
        SpecError: the file is missing or not TOML, or a key is missing, unknown or malformed (named).
    """
    path, data = read_source(source, shipped_specs(), "sweep spec", SpecError)
    return parse_spec(data, base=path.parent, name=path.stem, source=path)


def _table(data: Any, path: str, allowed: tuple[str, ...]) -> dict[str, Any]:
    if not isinstance(data, dict):
        raise SpecError(f"'{path or 'spec'}' must be a table of keys, got {show(data)}")
    unknown = sorted(set(data) - set(allowed))
    if unknown:
        where = f"[{path}]" if path else "the top level"
        raise SpecError(f"unknown key '{_join(path, unknown[0])}'; allowed keys in {where}: {', '.join(allowed)}")
    return data


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _number(v: Any, key: str, *, positive: bool = False, low: float | None = None, high: float | None = None) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(float(v)):
        raise SpecError(f"'{key}' must be a finite number, got {show(v)}")
    x = float(v)
    if positive and x <= 0:
        raise SpecError(f"'{key}' must be positive, got {show(v)}")
    if (low is not None and x < low) or (high is not None and x > high):
        raise SpecError(f"'{key}' must be in [{low:g}, {high:g}], got {show(v)}")
    return x


def _int(v: Any, key: str, low: int, high: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
        raise SpecError(f"'{key}' must be a whole number in [{low}, {high}], got {show(v)}")
    return int(v)


def _vector(v: Any, key: str) -> list[float]:
    if not isinstance(v, list) or len(v) != 3:
        raise SpecError(f"'{key}' must be 3 numbers [x, y, z], got {show(v)}")
    return [_number(x, key) for x in v]


def _base(value: Any, base: Path) -> tuple[Path, dict[str, Any], Path]:
    """The base scenario's TOML path, data and folder (relative paths are from the spec's folder)."""
    if not isinstance(value, str) or not value:
        raise SpecError(f"'base' must be a scenario: a shipped name or a .toml path, got {show(value)}")
    try:
        path, data = read_source(value, shipped_scenarios(), "base scenario", SpecError, folder=base)
    except SpecError as exc:
        raise SpecError(f"'base' = {show(value)}: {exc}") from None
    return path, data, path.parent


def _axis(name: str, raw: Any, links: tuple[str, ...]) -> Axis:
    key = f"axes.{name}"
    kind = AXES[name]
    if kind == "link":
        if isinstance(raw, str) and raw == "all":
            return Axis(name, kind, values=links)
        if not isinstance(raw, list) or not raw or not all(isinstance(x, str) for x in raw):
            raise SpecError(f"'{key}' must be \"all\" or a list of link names, got {show(raw)}")
        bad = [x for x in raw if x not in links]
        if bad:
            raise SpecError(
                f"'{key}': {show(bad[0])} is not a link that can carry a brace; choose from {', '.join(links)}"
            )
        if len(set(raw)) != len(raw):
            raise SpecError(f"'{key}' lists a link twice")
        return Axis(name, kind, values=tuple(raw))
    check = (lambda v, k: _vector(v, k)) if kind == "vector" else (lambda v, k: _number(v, k))
    if isinstance(raw, list):
        if not raw:
            raise SpecError(f"'{key}' must list at least one value")
        values = [check(v, key) for v in raw]
        if len({json.dumps(v) for v in values}) != len(values):
            raise SpecError(f"'{key}' lists a value twice")
        axis = Axis(name, kind, values=tuple(values))
    elif isinstance(raw, dict):
        _table(raw, key, ("range", "count"))
        rng = raw.get("range")
        if not isinstance(rng, list) or len(rng) != 2:
            raise SpecError(f"'{key}.range' must be [low, high], got {show(rng)}")
        low, high = check(rng[0], f"{key}.range"), check(rng[1], f"{key}.range")
        if low == high:
            raise SpecError(f"'{key}.range' must have low ≠ high, got {show(rng)}")
        count = _int(raw.get("count", 5), f"{key}.count", 1, 10_000)
        axis = Axis(name, kind, low=low, high=high, count=count)
    else:
        raise SpecError(
            f"'{key}' must be a list of values or a table {{ range = [low, high], count = N }}, got {show(raw)}"
        )
    _check_axis_values(axis, key)
    return axis


def _check_axis_values(axis: Axis, key: str) -> None:
    """Physical bounds of an axis's values (all of its range)."""
    ends = list(axis.values) if axis.values is not None else [axis.low, axis.high]
    for v in ends:
        if axis.name == "fraction" and not 0.0 <= v <= 1.0:
            raise SpecError(f"'{key}' must lie in [0, 1] (0: at the link's joint, 1: at the next joint), got {v:g}")
        if axis.name in ("stiffness", "task_radius") and v <= 0:
            raise SpecError(f"'{key}' must be positive, got {v:g}")
        if axis.name == "preload" and not 0.0 <= v <= MAX_PRELOAD:
            raise SpecError(f"'{key}' must be a force in [0, {MAX_PRELOAD:g}] N, got {v:g}")
        if axis.name == "friction" and not 0.0 <= v <= MAX_FRICTION:
            raise SpecError(f"'{key}' must be a coefficient μ in [0, {MAX_FRICTION:g}], got {v:g}")


def _toml_values(data: Any) -> None:
    """SpecError for a value no TOML file can hold (an array, bytes, an object), at any depth (iteratively)."""
    stack: list[tuple[str, Any]] = [("", data)]
    while stack:
        where, value = stack.pop()
        if isinstance(value, dict):
            stack.extend((_join(where, str(k)), v) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((f"{where}[{i}]", v) for i, v in enumerate(value))
        elif not isinstance(value, str | int | float | bool | datetime.date | datetime.time):
            raise SpecError(f"'{where or 'spec'}' is a {type(value).__name__}, which no TOML file holds")


def parse_spec(
    data: dict[str, Any], base: Path = Path("."), name: str = "sweep", source: Path | None = None
) -> SweepSpec:
    """Validate the TOML data of a sweep spec (see ``specs/paper-links.toml`` and docs/sweep.md)."""
    _toml_values(data)
    top = _table(
        data,
        "",
        ("name", "description", "base", "brace", "sampling", "axes", "screen", "feasibility", "refine", "simulation"),
    )
    if "base" not in top:
        raise SpecError("missing key 'base' (the base scenario: a shipped name such as \"paper\" or a .toml path)")
    base_path, base_data, base_dir = _base(top["base"], base)
    base_name = base_path.stem
    try:
        scenario = parse_scenario(base_data, base=base_dir, name=base_name)
    except InputError as exc:
        raise SpecError(f"'base' = {show(top['base'])}: {exc}") from exc
    if len(scenario.braced.braces) != 1:
        raise SpecError(
            f"'base' = {show(top['base'])} has several braces; a sweep places one brace: give a "
            "scenario with one [brace]"
        )
    from bracekit.studies.sweep.candidates import brace_links

    links = brace_links(scenario.robot)
    brace = _table(top.get("brace", {}), "brace", ("normal", "region_radius", "surface_radius", "contact"))
    normal = _vector(brace["normal"], "brace.normal") if "normal" in brace else None
    if normal is not None and not any(normal):
        raise SpecError("'brace.normal' must be a non-zero vector (the surface normal, toward the robot)")
    region = _number(brace["region_radius"], "brace.region_radius", positive=True) if "region_radius" in brace else None
    surface = (
        _number(brace["surface_radius"], "brace.surface_radius", positive=True) if "surface_radius" in brace else None
    )
    contact = brace.get("contact")
    if contact is not None and contact not in REGISTRY:
        raise SpecError(f"'brace.contact' = {show(contact)} is not one of: {', '.join(REGISTRY)}")
    sampling = _table(top.get("sampling", {}), "sampling", ("mode", "samples", "seed"))
    mode = sampling.get("mode", "grid")
    if mode not in ("grid", "random"):
        raise SpecError(f"'sampling.mode' = {show(mode)} is not one of: grid, random")
    samples = _int(sampling.get("samples", 100), "sampling.samples", 1, MAX_CANDIDATES) if mode == "random" else 0
    if mode == "grid" and "samples" in sampling:
        raise SpecError("'sampling.samples' is for mode = \"random\"; a grid takes every combination of the axes")
    seed = _int(sampling.get("seed", 0), "sampling.seed", 0, 2**63 - 1)
    axes_t = _table(top.get("axes"), "axes", tuple(AXES)) if "axes" in top else None
    if not axes_t or "link" not in axes_t:
        raise SpecError("missing key 'axes.link' (the links to brace: \"all\" or a list of link names)")
    if "fraction" in axes_t and "offset" in axes_t:
        raise SpecError("'axes.fraction' and 'axes.offset' both place the point on the link; give one")
    if "angle" in axes_t and "offset" in axes_t:
        raise SpecError("'axes.angle' places the pad on the link's surface with 'axes.fraction', not 'axes.offset'")
    axes = tuple(_axis(k, axes_t[k], links) for k in AXES if k in axes_t)
    if ("task_centre" in axes_t or "task_radius" in axes_t) and base_data.get("task", {}).get("type") != "circle":
        raise SpecError("'axes.task_centre' and 'axes.task_radius' need a base scenario with a circle task")
    if mode == "grid":
        total = math.prod(len(a.grid()) for a in axes)
        if total > MAX_CANDIDATES:
            raise SpecError(f"the axes give {total} candidates (more than {MAX_CANDIDATES}); use fewer values")
    screen_t = _table(top.get("screen", {}), "screen", ("enabled", "k_max", "keep_fraction"))
    enabled = screen_t.get("enabled", True)
    if not isinstance(enabled, bool):
        raise SpecError(f"'screen.enabled' must be true or false, got {show(enabled)}")
    screening = Screening(
        enabled=enabled,
        k_max=_number(screen_t.get("k_max", 100.0), "screen.k_max", positive=True),
        keep_fraction=_number(screen_t.get("keep_fraction", 0.3), "screen.keep_fraction", low=0.0, high=1.0),
    )
    feas_t = _table(
        top.get("feasibility", {}), "feasibility", ("k_max", "min_clearance", "joint_limit_tolerance", "min_margin")
    )
    feasibility = Feasibility(
        k_max=_number(feas_t.get("k_max", 50.0), "feasibility.k_max", positive=True),
        min_clearance=_number(feas_t.get("min_clearance", 0.0), "feasibility.min_clearance"),
        joint_limit_tolerance=_number(
            feas_t.get("joint_limit_tolerance", 1e-9), "feasibility.joint_limit_tolerance", low=0.0, high=1.0
        ),
        min_margin=_number(feas_t.get("min_margin", 1.0), "feasibility.min_margin"),
    )
    ref_t = _table(top.get("refine", {}), "refine", ("top", "max_evaluations", "xatol"))
    refinement = Refinement(
        top=_int(ref_t.get("top", 3), "refine.top", 0, 100),
        max_evaluations=_int(ref_t.get("max_evaluations", 12), "refine.max_evaluations", 3, 1000),
        xatol=_number(ref_t.get("xatol", 0.01), "refine.xatol", low=1e-6, high=0.5),
    )
    sim_t = _table(top.get("simulation", {}), "simulation", ("dt",))
    dt = _number(sim_t["dt"], "simulation.dt", positive=True) if "dt" in sim_t else None
    spec_name = top.get("name", name)
    if not isinstance(spec_name, str) or not spec_name:
        raise SpecError(f"'name' must be a non-empty string, got {show(spec_name)}")
    description = top.get("description", "")
    if not isinstance(description, str):
        raise SpecError(f"'description' must be a string, got {show(description)}")
    spec = SweepSpec(
        name=spec_name,
        description=description,
        base_name=base_name,
        base_data=base_data,
        base_dir=base_dir,
        axes=axes,
        mode=mode,
        samples=samples,
        seed=seed,
        normal=None if normal is None else (normal[0], normal[1], normal[2]),
        region_radius=region,
        surface_radius=surface,
        contact=contact,
        dt=dt,
        screening=screening,
        feasibility=feasibility,
        refinement=refinement,
        source=source,
        base_path=base_path,
    )
    _check_candidate_scenario(spec)
    return spec


def _check_candidate_scenario(spec: SweepSpec) -> None:
    """Build the first candidate's scenario (at the base's guess) so that a spec that cannot run fails now."""
    from bracekit.studies.sweep.candidates import expand
    from bracekit.studies.sweep.scenario import candidate_data

    first = expand(spec, limit=1)[0]
    guess = spec.base_scenario().guess
    data = candidate_data(spec, first, guess, [0.0, 0.0, 0.0])
    try:
        parse_scenario(data, base=spec.base_dir, name=spec.name)
    except InputError as exc:
        raise SpecError(f"the candidate scenarios of this spec are invalid: {exc}") from exc
