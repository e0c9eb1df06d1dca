"""How accurate a mesher's tetrahedralization is for casting: the fraction of random rays on
which it agrees with Embree on the caller's mesh (``mesher="auto"`` picks by it).

Needs embreex (imported when it measures). Takes the scene class as an argument, so it does
not import :mod:`tetrace.scene`.
"""

from __future__ import annotations

import numpy as np

from .hits import HIT

__all__ = ["measure_accuracy"]


def measure_accuracy(
    scene_class, tetrahedralization, vertices, faces, *, rays=20_000, seed=0, hit_distance=1e-3
):
    """Fraction of random rays on which a tetrahedralization agrees with Embree.

    Parameters
    ----------
    scene_class : type
        The scene to cast with, :class:`tetrace.Scene` (:meth:`tetrace.Scene.from_mesh`
        passes it): ``scene_class(tetrahedralization, vertices, faces)``.
    tetrahedralization : tetrace.mesh.Tetrahedralization
    vertices, faces : numpy.ndarray
        The caller's mesh, which ``tetrahedralization`` was built from.
    rays : int
        Random rays, origins uniform in the scene's box grown by a quarter of its size
        on each side, directions uniform on the sphere.
    seed : int
    hit_distance : float
        Hits on different triangles agree when the hit points are this close, as a
        fraction of the scene's diagonal (``tetrace.mesh.auto.HIT_DISTANCE``: fTetWild's
        surface lies within its envelope of the input).

    Returns
    -------
    float
        Rays with the same outcome as Embree (both miss, or both hit the same triangle
        or points within ``hit_distance``), over all rays.

    Raises
    ------
    ImportError
        embreex is not installed.
    """
    from .baselines.embree import embree_scene
    from .dev.camera import random_rays

    v = np.asarray(vertices, np.float64)
    o, d = random_rays(np.array([v.min(0), v.max(0)]), int(rays), seed)
    # The walk through this tetrahedralization is what is measured (the CPU default, the
    # exact BVH, would read the caller's triangles and never the mesher's faces).
    scene = scene_class(tetrahedralization, v, faces)
    hits = scene.cast(o, d, precision="f64", accel="tetwalk")
    ref = embree_scene((v, faces)).cast(o, d)
    diagonal = float(np.linalg.norm(v.max(0) - v.min(0)))
    near = np.linalg.norm(hits.point - ref.point, axis=1) <= hit_distance * diagonal
    same = (hits.status == ref.status) & (
        (hits.status != HIT) | (hits.triangle == ref.triangle) | near
    )
    return float(same.mean())
