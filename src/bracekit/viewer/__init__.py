"""An interactive 3D view of a run in the browser (viser): ``bracekit view OUT_DIR``.

``scene``: what a run's output folder holds for drawing (scene.json) and :func:`load_scene`. ``frames``: per-sample
poses and compliance ellipsoids. ``meshes``: the shapes as triangle meshes. ``server``: :func:`serve` (needs
``bracekit[view]``).
"""

from bracekit.viewer.scene import Scene, load_scene, scene_data

__all__ = ["Scene", "load_scene", "scene_data"]
