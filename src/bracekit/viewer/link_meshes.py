"""The robot's link meshes that a run folder carries: ``meshes.npz``, written with the run, read bounded.

A robot whose URDF gives collision meshes (:mod:`bracekit.geometry.collision`, read through Pinocchio + coal)
is drawn with them: every element of ``Robot.geometry`` (meshes, and boxes, cylinders, capsules and spheres
triangulated) with its vertices in its joint's frame, so that a pose of the joint places it. The triangles are
stored in the run folder itself (not the paths of the STL files), so that a moved or copied folder still opens.
Robots without meshes are drawn with their link capsules, and no ``meshes.npz`` is written.

The file holds six arrays: ``links`` (m,) names, ``joints`` (m,) Pinocchio joint indices (0: the base),
``vertex_counts`` and ``triangle_counts`` (m,), ``vertices`` (V×3, float32, m, each element's in its joint's
frame, one after the other) and ``triangles`` (T×3, uint32, indices into the element's own vertices).
"""

from __future__ import annotations

import os
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bracekit._io import npz_shapes
from bracekit.errors import InputError
from bracekit.model.urdf_numbers import MAX_LENGTH
from bracekit.viewer.meshes import box_mesh, capsule_mesh, cylinder_mesh

if TYPE_CHECKING:
    from bracekit.geometry.collision import CollisionElement
    from bracekit.model.robot import Robot

Array = NDArray[np.float64]

#: The file name of the link meshes in a run's output folder.
MESH_FILE = "meshes.npz"
#: At most this many elements and triangles in all: a robot over the caps is drawn with its capsule fits.
MAX_MESH_ELEMENTS = 1000
MAX_MESH_TRIANGLES = 600_000
RERUN = "re-run `bracekit run` to write it"
_KEYS = ("links", "joints", "vertex_counts", "triangle_counts", "vertices", "triangles")


@dataclass(frozen=True, eq=False)
class LinkMesh:
    """One drawn element of a link.

    Attributes:
        link: the URDF link it belongs to.
        joint: Pinocchio index of the joint that moves it (0: fixed to the base).
        vertices: (k, 3) float32, m, in the joint's frame.
        triangles: (t, 3) uint32 vertex indices.
    """

    link: str
    joint: int
    vertices: NDArray[np.float32]
    triangles: NDArray[np.uint32]


def _triangulated(e: CollisionElement) -> tuple[Array, NDArray[np.uint32]]:
    """An element's triangles in its own frame (a cylinder's and a capsule's axis is z)."""
    if e.kind == "mesh" and e.vertices is not None and e.triangles is not None:
        return np.asarray(e.vertices, dtype=float), np.asarray(e.triangles, dtype=np.uint32)
    if e.kind == "box":
        return box_mesh(np.asarray(e.size, dtype=float))
    if e.kind == "sphere":
        return capsule_mesh(np.zeros(3), np.zeros(3), e.size[0])
    radius, length = e.size
    a, b = np.array([0.0, 0.0, -0.5 * length]), np.array([0.0, 0.0, 0.5 * length])
    return capsule_mesh(a, b, radius) if e.kind == "capsule" else cylinder_mesh(a, b, radius)


def link_meshes(robot: Robot) -> tuple[LinkMesh, ...]:
    """The robot's drawn elements, each in its joint's frame; () without a mesh among them or over the caps.

    Over :data:`MAX_MESH_ELEMENTS` elements or :data:`MAX_MESH_TRIANGLES` triangles the viewer draws the capsule
    fits (docs/viewer.md says so), and the figures always do.
    """
    from bracekit.geometry.collision import has_meshes

    elements = robot.geometry
    if not has_meshes(elements) or len(elements) > MAX_MESH_ELEMENTS:
        return ()
    out = []
    for e in elements:
        vertices, triangles = _triangulated(e)
        placed = vertices @ e.placement[:3, :3].T + e.placement[:3, 3]
        out.append(LinkMesh(e.link, e.joint, placed.astype(np.float32), triangles.astype(np.uint32)))
    if sum(m.triangles.shape[0] for m in out) > MAX_MESH_TRIANGLES:
        return ()
    return tuple(out)


def save_link_meshes(meshes: tuple[LinkMesh, ...], path: Path) -> None:
    """Write `meshes` as ``meshes.npz`` (see the module docstring)."""
    with open(path, "wb") as fh:
        np.savez_compressed(
            fh,
            links=np.array([m.link for m in meshes], dtype=str),
            joints=np.array([m.joint for m in meshes], dtype=np.int64),
            vertex_counts=np.array([m.vertices.shape[0] for m in meshes], dtype=np.int64),
            triangle_counts=np.array([m.triangles.shape[0] for m in meshes], dtype=np.int64),
            vertices=np.concatenate([m.vertices for m in meshes]).astype(np.float32),
            triangles=np.concatenate([m.triangles for m in meshes]).astype(np.uint32),
        )


def _checked(arrays: dict[str, NDArray[Any]], where: str, joints: int) -> tuple[LinkMesh, ...]:
    """The meshes of the read arrays; InputError when their sizes, indices or numbers do not fit."""
    links, joint, nv, nt = (arrays[k] for k in _KEYS[:4])
    vertices, triangles = arrays["vertices"], arrays["triangles"]
    m = links.shape[0]
    if not (links.ndim == joint.ndim == nv.ndim == nt.ndim == 1 and joint.shape == nv.shape == nt.shape == (m,)):
        raise InputError(f"{where}: links, joints and counts are not {m} entries each; {RERUN}")
    if m > MAX_MESH_ELEMENTS or vertices.ndim != 2 or vertices.shape[1:] != (3,) or triangles.shape[1:] != (3,):
        raise InputError(f"{where}: the vertices or triangles are not k×3 (or more than {MAX_MESH_ELEMENTS}); {RERUN}")
    if triangles.shape[0] > MAX_MESH_TRIANGLES:
        raise InputError(f"{where} holds more than {MAX_MESH_TRIANGLES} triangles; {RERUN}")
    if np.any(nv < 1) or np.any(nt < 1) or int(nv.sum()) != vertices.shape[0] or int(nt.sum()) != triangles.shape[0]:
        raise InputError(f"{where}: the vertex and triangle counts do not add up; {RERUN}")
    if np.any(joint < 0) or np.any(joint > joints):
        raise InputError(f"{where}: a mesh's joint is outside 0…{joints}; {RERUN}")
    if not np.all(np.isfinite(vertices)) or float(np.max(np.abs(vertices))) > MAX_LENGTH:
        raise InputError(f"{where}: a vertex is not finite or farther than {MAX_LENGTH:g} m; {RERUN}")
    out = []
    v0 = t0 = 0
    for i in range(m):
        v1, t1 = v0 + int(nv[i]), t0 + int(nt[i])
        tris = np.asarray(triangles[t0:t1])
        if tris.size and (np.min(tris) < 0 or np.max(tris) >= nv[i]):
            raise InputError(f"{where}: a triangle of mesh {i} names a vertex it does not have; {RERUN}")
        mesh = LinkMesh(str(links[i])[:200], int(joint[i]), vertices[v0:v1].astype(np.float32), tris.astype(np.uint32))
        out.append(mesh)
        v0, t0 = v1, t1
    return tuple(out)


def load_link_meshes(path: str | os.PathLike[str], joints: int) -> tuple[LinkMesh, ...]:
    """The meshes of a run's ``meshes.npz`` for a robot of `joints` joints, read bounded.

    Raises:
        InputError: the file is damaged, too large, or its arrays do not fit together (one line).
    """
    where = os.fspath(path)
    try:
        shapes = npz_shapes(path, max_elements=12 * MAX_MESH_TRIANGLES + 4 * MAX_MESH_ELEMENTS, max_arrays=len(_KEYS))
    except InputError as exc:
        raise InputError(f"{exc}; {RERUN}") from None
    if sorted(shapes) != sorted(_KEYS):
        raise InputError(f"{where} does not hold the arrays {', '.join(_KEYS)}; {RERUN}")
    if shapes["links"][1].itemsize > 4 * 1000:  # link names of at most 1000 characters
        raise InputError(f"{where}: the link names are longer than 1000 characters; {RERUN}")
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {k: np.asarray(npz[k]) for k in _KEYS}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error, AttributeError) as exc:
        raise InputError(f"cannot read {where} ({str(exc) or type(exc).__name__}); {RERUN}") from None
    for key in _KEYS[1:]:
        if arrays[key].dtype.kind not in "iuf":
            raise InputError(f"{where}: {key} is not numbers; {RERUN}")
    if arrays["links"].dtype.kind != "U":
        raise InputError(f"{where}: links is not text; {RERUN}")
    return _checked(arrays, where, joints)
