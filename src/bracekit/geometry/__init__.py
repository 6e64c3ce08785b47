"""The robot's collision geometry and the environment's solids (Pinocchio + coal): clearance and pad placement.

collision.py reads the URDF's collision elements; pieces.py makes them convex pieces for coal (the braced
link's surface without the pad's neighbourhood); obstacles.py holds the environment's solids; distance.py the
link clearance and its gradient; pad.py places a brace on a link's surface.
"""

from bracekit.geometry.collision import CollisionElement, geometry_description, has_meshes, read_collision_geometry
from bracekit.geometry.obstacles import Obstacle, box_obstacle, cylinder_obstacle, mesh_obstacle, surface_obstacle

__all__ = [
    "CollisionElement",
    "Obstacle",
    "box_obstacle",
    "cylinder_obstacle",
    "geometry_description",
    "has_meshes",
    "mesh_obstacle",
    "read_collision_geometry",
    "surface_obstacle",
]
