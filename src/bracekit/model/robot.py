"""Robot: a serial chain from URDF (Pinocchio model), its tip frame {e} and its joint stiffnesses.

The model is what does not change during a run; everything computed at a configuration lives in
:mod:`bracekit.kinematics`.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit.errors import FrameNotFoundError, InputError, ModelError

Array = NDArray[np.float64]

#: Accepted joint stiffnesses, N·m/rad (N/m for prismatic joints).
STIFFNESS_RANGE = (1e-6, 1e12)


@contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence the C++ parser's own stderr lines (bracekit reports one line of its own)."""
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):  # no real file descriptor (e.g. captured)
        yield
        return
    sys.stderr.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


def _load_urdf(source: str | Path) -> pin.Model:
    text = str(source)
    is_xml = isinstance(source, str) and text.lstrip().startswith("<")
    if is_xml:
        try:
            with _quiet_stderr():
                return pin.buildModelFromXML(text)
        except Exception as exc:  # pinocchio raises ValueError/RuntimeError with multi-line text
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ModelError(f"cannot parse the URDF string: {first}; check that it is valid URDF XML") from exc
    path = Path(source)
    if not path.is_file():
        raise ModelError(f"URDF file not found: {path}; give the path of an existing .urdf file")
    try:
        head = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise ModelError(f"cannot read the URDF file {path}: {exc.strerror}") from exc
    if "<robot" not in head:
        raise ModelError(f"{path} is not a URDF file (no <robot> element); give a valid URDF file")
    try:
        with _quiet_stderr():
            return pin.buildModelFromUrdf(str(path))
    except Exception as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ModelError(f"cannot parse the URDF file {path}: {first}") from exc


def _as_stiffness(stiffness: float | Sequence[float] | ArrayLike, names: Sequence[str]) -> Array:
    n = len(names)
    try:
        k = np.asarray(stiffness, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"joint stiffness must be numbers in N·m/rad, got {stiffness!r}") from None
    if k.ndim == 0:
        k = np.full(n, float(k))
    k = k.reshape(-1)
    if k.size != n:
        raise InputError(f"got {k.size} joint stiffnesses for {n} joints ({', '.join(names)}); give one value or {n}")
    for name, value in zip(names, k, strict=True):
        if not np.isfinite(value) or value <= 0.0:
            raise InputError(f"joint stiffness of '{name}' must be a positive number in N·m/rad, got {value}")
        if not STIFFNESS_RANGE[0] <= value <= STIFFNESS_RANGE[1]:
            raise InputError(
                f"joint stiffness of '{name}' is {value:g}; give a value between {STIFFNESS_RANGE[0]:g} and "
                f"{STIFFNESS_RANGE[1]:g} N·m/rad (outside it the compliance under- or overflows)"
            )
    return k


@dataclass(frozen=True, eq=False)
class Robot:
    """A serial robot: Pinocchio model of the chain from the base to the tip frame {e}.

    Joints not on the path to the tip are locked at their neutral value when the model is loaded.
    Joint values are given in chain order, base to tip (n values, rad or m).

    Attributes:
        model: Pinocchio model; every joint is 1-DoF (revolute or prismatic), nq == nv == n.
        tip: name of the end-effector frame {e}.
        stiffness: joint stiffnesses K (n,), N·m/rad (N/m for prismatic joints).
    """

    model: pin.Model
    tip: str
    stiffness: Array
    off_chain: frozenset[str] = frozenset()
    _tip_id: int = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.model.nq != self.model.nv:
            raise ModelError("every joint must be 1-DoF revolute or prismatic (nq == nv)")
        object.__setattr__(self, "_tip_id", self.frame_id(self.tip))
        object.__setattr__(self, "stiffness", _as_stiffness(self.stiffness, self.joint_names))

    @classmethod
    def from_urdf(
        cls,
        source: str | Path,
        tip: str,
        stiffness: float | Sequence[float] | ArrayLike = 170.0,
    ) -> Robot:
        """Load a robot from a URDF file path or an XML string.

        Args:
            source: path of a .urdf file, or the URDF text itself (a string starting with '<').
            tip: name of the end-effector frame {e} (a link or a fixed joint of the URDF).
            stiffness: one joint stiffness for all joints or one per joint of the chain, N·m/rad.
        """
        full = _load_urdf(source)
        if not full.existFrame(tip):
            raise FrameNotFoundError(f"unknown tip frame '{tip}'; known frames: {', '.join(_frame_names(full))}")
        tip_joint = full.frames[full.getFrameId(tip)].parentJoint
        keep = set(full.supports[tip_joint])
        lock = [j for j in range(1, full.njoints) if j not in keep]
        model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        off_chain = frozenset(f.name for f in full.frames if f.parentJoint not in keep)
        if model.nv == 0:
            raise ModelError(f"no joint moves the tip frame '{tip}'; choose a frame on a moving link")
        for j in range(1, model.njoints):
            joint = model.joints[j]
            if joint.nq != 1 or joint.nv != 1:
                raise ModelError(
                    f"joint '{model.names[j]}' is {joint.shortname()} (nq={joint.nq}, nv={joint.nv}); "
                    "bracekit needs revolute or prismatic joints: give it type='revolute' with <limit>"
                )
        return cls(model=model, tip=tip, stiffness=stiffness, off_chain=off_chain)  # type: ignore[arg-type]

    # --- names and sizes -------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of joints of the chain."""
        return int(self.model.nv)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joint names in chain order, base to tip."""
        return tuple(self.model.names[1:])

    @property
    def lower(self) -> Array:
        """Lower joint limits (n,)."""
        return np.asarray(self.model.lowerPositionLimit, dtype=float).copy()

    @property
    def upper(self) -> Array:
        """Upper joint limits (n,)."""
        return np.asarray(self.model.upperPositionLimit, dtype=float).copy()

    @property
    def tip_id(self) -> int:
        """Pinocchio frame id of {e}."""
        return self._tip_id

    def frame_id(self, name: str) -> int:
        """Pinocchio frame id of a frame or link name; raises FrameNotFoundError."""
        if not self.model.existFrame(name):
            raise FrameNotFoundError(f"unknown frame '{name}'; known frames: {', '.join(_frame_names(self.model))}")
        return int(self.model.getFrameId(name))

    def frame_joint(self, name: str) -> int:
        """Index (0-based, in chain order) of the last joint that moves frame `name`; −1 if none."""
        return int(self.model.frames[self.frame_id(name)].parentJoint) - 1

    # --- configurations --------------------------------------------------------------------------
    def check_q(self, q: ArrayLike) -> Array:
        """Q as a float array (n,); raises InputError on a wrong length or a non-finite value."""
        try:
            a = np.asarray(q, dtype=float).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise InputError(f"joint values must be numbers: {exc}") from exc
        if a.size != self.n:
            raise InputError(
                f"got {a.size} joint values for {self.n} joints ({', '.join(self.joint_names)}); "
                f"give {self.n} values in chain order"
            )
        if not np.all(np.isfinite(a)):
            raise InputError(f"joint values must be finite numbers, got {a.tolist()}")
        return a

    def neutral(self) -> Array:
        """The neutral configuration (zeros for revolute and prismatic joints)."""
        return np.asarray(pin.neutral(self.model), dtype=float)

    # --- derived robots --------------------------------------------------------------------------
    def with_point_frame(
        self,
        name: str,
        link: str,
        offset: ArrayLike = (0.0, 0.0, 0.0),
        rotation: ArrayLike | None = None,
    ) -> Robot:
        """A copy of this robot with a new frame `name` fixed to `link` at `offset` (m, link axes).

        `rotation` (3×3, link axes) orients the new frame; identity by default. Use it to place a
        bracing frame {b} at a point of a link's body.
        """
        if self.model.existFrame(name):
            raise InputError(f"frame '{name}' already exists; choose another name for the brace point")
        fid = self.frame_id(link)
        if link in self.off_chain:
            raise InputError(f"link '{link}' is not on the chain to the tip '{self.tip}'")
        off = np.asarray(offset, dtype=float).reshape(-1)
        if off.size != 3 or not np.all(np.isfinite(off)):
            raise InputError(f"the offset of frame '{name}' must be 3 finite numbers (m), got {off.tolist()}")
        rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float).reshape(3, 3)
        if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-9) or np.linalg.det(rot) < 0:
            raise InputError(f"the rotation of frame '{name}' must be a proper rotation matrix")
        model = pin.Model(self.model)
        parent = model.frames[fid]
        placement = parent.placement * pin.SE3(rot, off)
        model.addFrame(pin.Frame(name, parent.parentJoint, fid, placement, pin.FrameType.OP_FRAME))
        return Robot(model=model, tip=self.tip, stiffness=self.stiffness, off_chain=self.off_chain)

    def with_stiffness(self, stiffness: float | Sequence[float] | ArrayLike) -> Robot:
        """A copy of this robot with other joint stiffnesses (N·m/rad)."""
        return Robot(model=self.model, tip=self.tip, stiffness=stiffness, off_chain=self.off_chain)  # type: ignore[arg-type]


def _frame_names(model: pin.Model) -> list[str]:
    body = [f.name for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
    return body or [f.name for f in model.frames]
