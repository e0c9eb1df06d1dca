"""Module conveniences: the bundled default scene and a one-call cast (``tetrace.cast``)."""

from __future__ import annotations

from functools import lru_cache

from .scene import Scene, default_scene_path

__all__ = ["default_scene", "cast"]


@lru_cache(maxsize=1)
def default_scene():
    """Return the bundled default scene, built once per process with the default preset.

    Every call returns the same object: building its structures with other parameters
    (``build_exact_bvh``, ``build_bvh``, ``build_octree``) or moving its vertices changes it
    for every caller. ``Scene.from_mesh(default_scene_path())`` gives a scene of your own.
    """
    return Scene.from_mesh(str(default_scene_path()))


def cast(rays, scene=None, **kwargs):
    """Cast rays through a scene.

    Parameters
    ----------
    rays : array_like or tuple
        ``(N, 6)`` rays ``[ox, oy, oz, dx, dy, dz]`` or an ``(origins, directions)`` tuple.
    scene : Scene or mesh or path, optional
        A built :class:`Scene`, or anything :meth:`Scene.from_mesh` takes; None casts into
        the bundled default scene.
    **kwargs
        Passed to :meth:`Scene.cast` (``tmin``, ``tmax``, ``threads``, ...).

    Returns
    -------
    Hits
    """
    if scene is None:
        scene = default_scene()
    elif not isinstance(scene, Scene):
        scene = Scene.from_mesh(scene)
    if isinstance(rays, tuple):
        if len(rays) != 2:
            raise ValueError("rays given as a tuple must be (origins, directions)")
        return scene.cast(rays[0], rays[1], **kwargs)
    return scene.cast(rays, **kwargs)
