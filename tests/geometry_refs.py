"""The UFactory xArm7 of example-robot-data (a test extra) and independent references for its meshes.

References: the STL files read here (binary or ASCII, without coal or assimp), placed by Pinocchio's own
frame placements of the link frames, and the signed distance of points from the surface's solid written out
here (the disk of radius r_max on the plane and the body below it).
"""

from __future__ import annotations

import importlib.metadata
import struct
from pathlib import Path

import numpy as np
import pytest

from bracekit.model.robot import Robot


def xarm_share() -> Path:
    """The folder holding example-robot-data's package (skips the test if the extra is not installed)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data (the test extra) is not installed")
    return Path(str(dist.locate_file("cmeel.prefix/share")))


def xarm_planar(folder: Path, strategies: tuple[str, ...]) -> Path:
    """tests/data/xarm7-planar.toml with example-robot-data's xArm7 and `strategies` (skips without the extra)."""
    share = xarm_share()
    urdf = share / "example-robot-data/robots/xarm_description/urdf/xarm7.urdf"
    text = (Path(__file__).resolve().parent / "data" / "xarm7-planar.toml").read_text(encoding="utf-8")
    names = ", ".join(f'"{s}"' for s in strategies)
    path = folder / "xarm7-planar.toml"
    path.write_text(text.format(urdf=urdf, share=share, strategies=names), encoding="utf-8")
    return path


def xarm7() -> Robot:
    """The xArm7 with its STL collision meshes, tip link_eef."""
    share = xarm_share()
    urdf = share / "example-robot-data/robots/xarm_description/urdf/xarm7.urdf"
    return Robot.from_urdf(urdf, tip="link_eef", package_dirs=[share])


def read_stl(path: str | Path) -> np.ndarray:
    """The triangles' corners (t, 3, 3) of an STL file, m (binary or ASCII)."""
    raw = Path(path).read_bytes()
    if raw[:5] == b"solid" and b"facet" in raw[:512]:
        rows = [line.split()[1:4] for line in raw.decode().splitlines() if line.strip().startswith("vertex")]
        return np.array(rows, dtype=float).reshape(-1, 3, 3)
    count = struct.unpack("<I", raw[80:84])[0]
    record = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    return np.frombuffer(raw[84 : 84 + 50 * count], dtype=record)["v"].astype(float)


def solid_distance(points: np.ndarray, centre: np.ndarray, normal: np.ndarray, r_max: float) -> np.ndarray:
    """Signed distance of points (k, 3) from the disk of radius r_max about `centre` and the body below it."""
    rel = points - centre
    h = rel @ normal
    rho = np.linalg.norm(rel - np.outer(h, normal), axis=1)
    outside = np.hypot(np.maximum(rho - r_max, 0.0), np.maximum(h, 0.0))
    inside = (h <= 0.0) & (rho <= r_max)
    return np.where(inside, np.maximum(h, rho - r_max), outside)


def write_ascii_stl(path: Path, triangles: np.ndarray) -> None:
    """Write triangles (t, 3, 3) as an ASCII STL file."""
    lines = ["solid test"]
    for tri in triangles:
        n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
        n = n / np.linalg.norm(n)
        lines.append(f"facet normal {n[0]} {n[1]} {n[2]}")
        lines.append("outer loop")
        lines.extend(f"vertex {p[0]} {p[1]} {p[2]}" for p in tri)
        lines.append("endloop")
        lines.append("endfacet")
    lines.append("endsolid test")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def box_triangles(half: tuple[float, float, float]) -> np.ndarray:
    """A closed box of half edges `half` centred at the origin as 12 outward triangles (t, 3, 3)."""
    hx, hy, hz = half
    v = np.array([[x, y, z] for x in (-hx, hx) for y in (-hy, hy) for z in (-hz, hz)])
    faces = [
        (0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
        (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3),
    ]  # fmt: skip
    return v[np.array(faces)]


def surface_points(triangles: np.ndarray, step: float = 0.002) -> np.ndarray:
    """The corners of triangles (t, 3, 3) and, on those longer than `step` (m), a barycentric grid of that pitch."""
    out = [triangles.reshape(-1, 3)]
    edge = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)
    count = np.ceil(edge / step).astype(int)
    for n in np.unique(count[count > 1]):
        weights = np.array([(i, j, n - i - j) for i in range(n + 1) for j in range(n + 1 - i)]) / n
        out.append(np.einsum("wc,tci->twi", weights, triangles[count == n]).reshape(-1, 3))
    return np.concatenate(out)


def deepest_in_solid(
    vertices: np.ndarray, centre: np.ndarray, normal: np.ndarray, r_max: float, starts: int = 3, seed: int = 0
) -> float:
    """The least signed distance from the post's solid over the convex hull of `vertices` (k, 3), where ≤ 0.

    Minus the depth of the hull's deepest point: min over x = Σ λ_k v_k (λ on the simplex) of
    max(h, ρ − r_max), as SciPy's SLSQP solves its epigraph (min t: h ≤ t, ρ² ≤ (r_max + t)², t ≥ −r_max) from
    the deepest vertex and from random weights; the least of their points' and the vertices' signed distances.
    """
    from scipy.optimize import minimize

    v = np.asarray(vertices, dtype=float).reshape(-1, 3)
    k = len(v)
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    rel = v - centre
    heights = rel @ n
    flat = rel - np.outer(heights, n)

    def parts(lam: np.ndarray) -> tuple[float, np.ndarray]:
        return float(lam @ heights), lam @ flat

    corners = solid_distance(v, centre, n, r_max)
    best = float(corners.min())
    rng = np.random.default_rng(seed)
    firsts = [np.eye(k)[int(np.argmin(corners))], *(rng.dirichlet(np.ones(k)) for _ in range(starts - 1))]
    for lam0 in firsts:
        h0, p0 = parts(lam0)
        z0 = np.append(lam0, max(h0, float(np.linalg.norm(p0)) - r_max) + 1e-3)
        constraints = [
            {"type": "eq", "fun": lambda z: z[:k].sum() - 1.0},
            {"type": "ineq", "fun": lambda z: z[k] - parts(z[:k])[0]},
            {"type": "ineq", "fun": lambda z: (r_max + z[k]) ** 2 - float(np.sum(parts(z[:k])[1] ** 2))},
            {"type": "ineq", "fun": lambda z: r_max + z[k]},
        ]
        res = minimize(
            lambda z: z[k], z0, jac=lambda z: np.eye(k + 1)[k], constraints=constraints,
            bounds=[(0.0, 1.0)] * k + [(None, None)], method="SLSQP", options={"ftol": 1e-14, "maxiter": 500},
        )  # fmt: skip
        lam = np.clip(res.x[:k], 0.0, None)
        point = (lam / lam.sum()) @ v
        best = min(best, float(solid_distance(point[None], centre, n, r_max)[0]))
    return best
