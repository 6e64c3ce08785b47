"""The robot's collision geometry as Pinocchio reads it: every link's meshes and primitives from the URDF.

Pinocchio's ``buildGeomFromUrdf`` (with coal, shipped in the ``pin`` wheel) reads each ``<collision>`` element:
a mesh (STL, DAE, OBJ, … through coal's assimp loader, scaled by its ``scale``), a box, a cylinder, a capsule or
a sphere. Mesh paths are resolved as Pinocchio resolves them: ``package://name/…`` through the search paths
given (``package_dirs``) and then ``ROS_PACKAGE_PATH``, absolute paths and ``file://`` as they are. A mesh that
cannot be found or read is a :class:`~bracekit.errors.ModelError` naming the file, never skipped.

Each element is kept as a :class:`CollisionElement`: plain arrays (its placement in its joint's frame, the mesh
vertices and triangles), so that a robot carrying its geometry pickles (sweeps ship robots to workers) and coal's
objects are built where they are used (:mod:`bracekit.geometry.distance`).
"""

from __future__ import annotations

import importlib.util
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import InputError, ModelError

if TYPE_CHECKING:
    from bracekit.kinematics.braced import BracedRobot

Array = NDArray[np.float64]

#: The kinds of collision element (URDF geometry tags).
KINDS = ("mesh", "box", "cylinder", "capsule", "sphere")


@dataclass(frozen=True, eq=False)
class CollisionElement:
    """One ``<collision>`` element of a link, fixed to a joint of the chain.

    Attributes:
        link: the URDF link it belongs to.
        joint: Pinocchio index of the joint that moves it (0: fixed to the base).
        placement: 4×4 pose of the element's frame in its joint's frame (m).
        kind: one of :data:`KINDS`.
        size: box: its three edge lengths; cylinder and capsule: (radius, length); sphere: (radius,); mesh: ()
            (m; a cylinder's and a capsule's axis is the element frame's z).
        vertices: a mesh's vertices (k, 3), m, in the element's frame (scaled); None for a primitive.
        triangles: a mesh's triangles (t, 3) as vertex indices; None for a primitive.
        source: the mesh file that was read ("" for a primitive).
    """

    link: str
    joint: int
    placement: Array
    kind: str
    size: tuple[float, ...] = ()
    vertices: Array | None = None
    triangles: NDArray[np.int64] | None = None
    source: str = ""


def _element(obj: pin.GeometryObject, model: pin.Model) -> CollisionElement:
    """The element of one Pinocchio geometry object."""
    geom = obj.geometry
    link = str(model.frames[obj.parentFrame].name)
    place = np.array(obj.placement.homogeneous, dtype=float)
    joint = int(obj.parentJoint)
    name = type(geom).__name__
    if name.startswith("BVHModel"):
        verts = np.array(geom.vertices(), dtype=float).reshape(-1, 3)
        tris = np.array([list(geom.tri_indices(i)[k] for k in range(3)) for i in range(geom.num_tris)], dtype=np.int64)
        if verts.shape[0] == 0 or tris.shape[0] == 0:
            raise ModelError(f"link {link!r}: the mesh {obj.meshPath!r} has no triangles; give a mesh with faces")
        return CollisionElement(link, joint, place, "mesh", (), verts, tris.reshape(-1, 3), str(obj.meshPath))
    if name == "Box":
        return CollisionElement(link, joint, place, "box", tuple(float(2.0 * h) for h in geom.halfSide))
    if name in ("Cylinder", "Capsule"):
        kind = name.lower()
        return CollisionElement(link, joint, place, kind, (float(geom.radius), float(2.0 * geom.halfLength)))
    if name == "Sphere":
        return CollisionElement(link, joint, place, "sphere", (float(geom.radius),))
    raise ModelError(
        f"link {link!r} has a collision element of coal type {name}; bracekit reads meshes, boxes, cylinders, "
        "capsules and spheres"
    )


_MISSING = re.compile(r"Mesh (\S+) could not be found")
_UNREADABLE = re.compile(r"Could not load resource (\S+)")


def _mesh_error(exc: BaseException) -> ModelError:
    """One line naming the mesh file Pinocchio or coal could not find or read."""
    text = str(exc)
    missing = _MISSING.search(text)
    if missing:
        return ModelError(
            f"collision mesh {missing.group(1)} not found; give the folder holding its package in the search paths "
            "(package_dirs, --package-dir, or ROS_PACKAGE_PATH)"
        )
    unreadable = _UNREADABLE.search(text)
    if unreadable and not os.path.exists(unreadable.group(1)):
        return ModelError(
            f"collision mesh {unreadable.group(1)} not found; give the URDF a mesh path that exists (absolute, "
            "relative to the URDF's folder, or package:// through package_dirs or ROS_PACKAGE_PATH)"
        )
    if unreadable:
        return ModelError(f"cannot read the collision mesh {unreadable.group(1)}; give a valid STL, DAE or OBJ file")
    first = text.strip().splitlines()[0] if text.strip() else type(exc).__name__
    return ModelError(f"cannot read the URDF's collision geometry: {first}")


def read_collision_geometry(
    model: pin.Model, urdf_text: str, package_dirs: Sequence[str | os.PathLike[str]] = ()
) -> tuple[CollisionElement, ...]:
    """Every collision element of the links of `model` (Pinocchio + coal), in the model's joint frames.

    Args:
        model: the chain's Pinocchio model (a reduced model is fine: locked links are its fixed frames).
        urdf_text: the URDF text.
        package_dirs: folders searched for ``package://`` meshes before ``ROS_PACKAGE_PATH``.

    Returns:
        The elements, () for a URDF without ``<collision>`` elements (or text that is not a URDF).

    Raises:
        ModelError: a mesh cannot be found or read, or an element is of a kind bracekit does not read.
    """
    if "<collision" not in urdf_text:
        return ()
    if isinstance(package_dirs, str | bytes | os.PathLike):
        raise InputError(f"package_dirs must be a list of folders, got {package_dirs!r}")
    dirs = [os.fspath(d) for d in package_dirs]
    try:
        geom = pin.buildGeomFromUrdfString(model, urdf_text, pin.GeometryType.COLLISION, package_dirs=dirs)
    except (ValueError, RuntimeError) as exc:
        raise _mesh_error(exc) from exc
    return tuple(_element(obj, model) for obj in geom.geometryObjects)


def has_meshes(elements: Sequence[CollisionElement]) -> bool:
    """Whether any element of the moving links is a mesh (then coal computes the clearance)."""
    return any(e.kind == "mesh" and e.joint > 0 for e in elements)


def geometry_description(elements: Sequence[CollisionElement], capsules: int) -> str:
    """What the clearance is computed from, for a run's summary.

    Args:
        elements: the robot's collision elements.
        capsules: how many capsules were fitted to URDF collision primitives (0: none).
    """
    moving = [e for e in elements if e.joint > 0]
    if has_meshes(elements):
        phase = "" if broad_phase() == "compiled" else f"; broad phase in {broad_phase()}"
        return f"meshes and primitives from the URDF ({len(moving)} elements, coal{phase})"
    if capsules:
        return f"capsules fitted to the URDF's collision primitives ({capsules})"
    return "capsules (no collision geometry in the URDF)"


def broad_phase() -> str:
    """How the mesh clearance's broad phase runs: "compiled" (numba, the ``[fast]`` extra) or as plain Python."""
    return "compiled" if importlib.util.find_spec("numba") is not None else "Python (numba not installed)"


#: Coal's shape classes as a scenario's ``[[obstacle]]`` tables name them.
_KINDS = {"Box": "box", "Cylinder": "cylinder", "Sphere": "sphere", "Convex": "mesh"}


def solids_of(braced: BracedRobot) -> str:
    """What the link clearance of `braced` is measured against, in words for a run's notes.

    Each brace's surface solid (the half-space below its plane, or the disk of its ``obstacle_radius`` and the
    body below it) and the further obstacles by kind and name, e.g. "the body under the bracing disk (radius
    0.15 m) or an obstacle (box 'fixture')".
    """
    radii = [b.obstacle_radius for b in braced.braces]
    disks = sorted({r for r in radii if r is not None})
    planes = len(radii) - sum(r is not None for r in radii)
    surfaces = []
    if disks:
        sizes = ", ".join(f"{r:.3g}" for r in disks)
        one = len(radii) - planes == 1
        surfaces.append(
            f"the body under the bracing disk (radius {sizes} m)"
            if one
            else f"the bodies under the bracing disks (radii {sizes} m)"
        )
    if planes:
        surfaces.append(
            "the half-space below the bracing plane" if planes == 1 else "the half-spaces below the bracing planes"
        )
    out = " or ".join(surfaces)
    if braced.obstacles:
        named = ", ".join(f"{_KINDS.get(type(o.shape).__name__, 'solid')} '{o.name}'" for o in braced.obstacles)
        out += f" or an obstacle ({named})"
    return out
