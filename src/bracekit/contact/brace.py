"""The brace: a frame {b} of the robot touching a surface through a contact type (eq:constraint)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import as_number, show
from bracekit.contact.base import ContactType, contact_type
from bracekit.contact.frictionless_point import FRICTIONLESS_POINT
from bracekit.contact.surface import Surface
from bracekit.errors import ContactError

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Brace:
    """A bracing contact: frame {b} of the robot touching `surface` through `contact`.

    Attributes:
        frame: name of the bracing frame {b} (a frame of the robot; add one at a link point with
            ``Robot.with_point_frame``).
        surface: the bracing plane.
        contact: contact type (default: the paper's frictionless point contact).
        region_radius: r_max of the circular bracing region centred at ``surface.point`` (m), or None.
        surface_radius: the surface as an obstacle for the links: a disk of this radius about ``surface.point``
            (m, ≥ region_radius), e.g. a table top; None: the bracing region's disk, or the whole plane when
            there is no region either.
        environment_stiffness: stiffness of the environment along each constraint direction (N/m, or
            N·m/rad for constraint moments); None means rigid (the paper's assumption).
        pad_axis: whether the z axis of {b} is a pad direction (the brace's contact normal on the robot's
            side), so that θ_z (eq:theta) is defined: True for a frame of the robot's description or a link
            point given a pad axis; False for a bare link point, whose z is only the link's.
        pad_radius: radius (m) of the pad's neighbourhood on the braced link that may touch the surface; the
            rest of the link must keep clear of it (used with collision meshes, :mod:`bracekit.geometry.distance`).
    """

    frame: str
    surface: Surface
    contact: ContactType | str = FRICTIONLESS_POINT
    region_radius: float | None = None
    environment_stiffness: float | None = None
    pad_axis: bool = True
    surface_radius: float | None = None
    pad_radius: float = 0.02

    def __post_init__(self) -> None:
        if not isinstance(self.frame, str) or not self.frame:
            raise ContactError(f"the brace frame must be a frame name (a non-empty string), got {show(self.frame)}")
        if not isinstance(self.surface, Surface):
            raise ContactError(f"the brace surface must be a bracekit Surface, got {type(self.surface).__name__}")
        object.__setattr__(self, "contact", contact_type(self.contact))
        if not isinstance(self.pad_axis, bool):
            raise ContactError(f"pad_axis must be True or False, got {show(self.pad_axis)}")
        if self.region_radius is not None:
            radius = as_number(self.region_radius, "region_radius", positive=True, unit="m", error=ContactError)
            if not radius < 1e150:  # r_max² must stay in float64
                raise ContactError(f"region_radius must be a length below 1e150 m, got {radius:g}")
        if self.surface_radius is not None:
            extent = as_number(self.surface_radius, "surface_radius", positive=True, unit="m", error=ContactError)
            if not extent < 1e150:
                raise ContactError(f"surface_radius must be a length below 1e150 m, got {extent:g}")
            if self.region_radius is not None and extent < self.region_radius:
                raise ContactError(
                    f"surface_radius {extent:g} m is smaller than the bracing region's radius "
                    f"{self.region_radius:g} m; the region lies on the surface: give a surface at least as large"
                )
        pad = as_number(self.pad_radius, "pad_radius", nonnegative=True, unit="m", error=ContactError)
        if not pad < 1e150:
            raise ContactError(f"pad_radius must be a length below 1e150 m, got {pad:g}")
        object.__setattr__(self, "pad_radius", pad)
        if self.environment_stiffness is not None:
            as_number(
                self.environment_stiffness,
                "environment_stiffness (omit it for a rigid surface)",
                positive=True,
                unit="N/m",
                error=ContactError,
            )

    @property
    def obstacle_radius(self) -> float | None:
        """Radius (m) of the disk of the plane the links must stay clear of; None: the whole plane."""
        return self.region_radius if self.surface_radius is None else self.surface_radius

    @property
    def kind(self) -> ContactType:
        """The contact type (``contact``, which the constructor turns from a name into a ContactType)."""
        return contact_type(self.contact)

    def H(self) -> Array:
        """H of eq:constraint for this brace (6×l)."""
        return self.kind.H(self.surface.frame)

    def X(self) -> Array:
        """Constraint wrench basis X (6×(6−l)), Hᵀ X = 0."""
        return self.kind.X(self.surface.frame)
