"""The point queries' work (:meth:`tetrace.Scene.contains`, :meth:`~tetrace.Scene.closest_points`
and the methods built on them): the inside rule a ``mode`` resolves to, containment by exact
parity or the winding number, and the closest points' answer.

The functions take the scene as an argument (this module does not import
:mod:`tetrace.scene`); :mod:`tetrace.winding` is loaded when the winding number is first asked.
"""

from __future__ import annotations

import warnings

import numpy as np

from .hits import ClosestPoints, locate

__all__ = ["contains_mode", "inside", "closest_points", "surface_info"]

#: ``_native.Scene.ray_parity``'s answer for a point no direction decided.
RAY_UNDECIDED = 2


def contains_mode(scene, mode):
    """``mode`` checked and resolved (None: by ``scene.is_closed``), warning once per scene
    when parity is asked of a mesh that is not closed. Called by the public methods
    directly, so that the warning names their caller's line."""
    if mode is None:
        return "parity" if scene.is_closed else "winding"
    if not isinstance(mode, str) or mode not in ("parity", "winding"):
        raise ValueError(f"mode must be None, 'parity' or 'winding', got {mode!r}")
    if mode == "parity" and not scene._parity_warned and not scene.is_closed:
        scene._parity_warned = True
        warnings.warn(
            "contains/signed_distance with mode='parity' on a mesh that is not closed ("
            f"{scene._surface_info().describe()}): a point counts as inside only when the "
            "fewest crossings to outside the domain is odd, so points reachable through a "
            "hole are outside; mode='winding' (the default for this scene) uses the "
            "generalized winding number instead",
            UserWarning,
            stacklevel=3,
        )
    return mode


def surface_info(scene):
    """The caller's mesh as cleaned, with its edge census: built once, kept on the scene
    until its vertices move (``scene._surface``)."""
    if scene._surface is None:
        from .winding import surface

        scene._surface = surface(scene.vertices, scene.faces)
    return scene._surface


def inside(scene, flat, mode, threads):
    """Containment of the ``(N, 3)`` float64 points by the resolved ``mode``."""
    if mode == "parity":
        if scene.has_ct or not scene.is_closed:
            # The parity of the tetrahedralization's regions (the fewest crossings to
            # outside): built now if it is not yet. On an open surface that rule is not one
            # ray's count, so it needs the tetrahedralization.
            return np.asarray(scene.build_ct()._native.contains(flat, threads), dtype=bool)
        # A closed surface with no tetrahedralization: one exact ray's crossings of the
        # cleaned triangles on the exact BVH give the same answer, with no meshing
        # (src/accel/exact_bvh/ray_parity.rs). A point every direction fails for (on lines
        # and planes through mesh features in all of them) is decided on the
        # tetrahedralization.
        side = ray_sides(scene, flat, threads)
        undecided = np.flatnonzero(side == RAY_UNDECIDED)
        if len(undecided):
            side[undecided] = scene.build_ct()._native.contains(flat[undecided], threads)
        return side == 1
    from .winding import winding_numbers

    s = scene._surface_info()
    return winding_numbers(s.vertices, s.faces, flat) >= 0.5


def ray_sides(scene, flat, threads):
    """Each point's side by one ray's crossings of the cleaned triangles on the exact BVH:
    0 outside, 1 inside, :data:`RAY_UNDECIDED` (``_native.Scene.ray_parity``)."""
    return scene._native.ray_parity(flat, scene._surface_info().kept, threads)


def closest_points(scene, flat, shape, threads):
    """:meth:`tetrace.Scene.closest_points` of the checked ``(N, 3)`` float64 points, given
    back in their leading ``shape``."""
    r = scene._native.closest_points(flat, threads)
    scene_triangle = np.asarray(r["triangle"])
    geometry, triangle = locate(scene.geometries, scene_triangle)
    return ClosestPoints(
        point=np.asarray(r["point"]).reshape(shape + (3,)),
        triangle=triangle.reshape(shape),
        u=np.asarray(r["u"]).reshape(shape),
        v=np.asarray(r["v"]).reshape(shape),
        distance=np.asarray(r["distance"]).reshape(shape),
        geometry=geometry.reshape(shape),
        scene_triangle=scene_triangle.reshape(shape),
    )
