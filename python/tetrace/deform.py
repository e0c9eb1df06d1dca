"""Moving a scene's vertices (:meth:`tetrace.Scene.update_vertices`): the move in place when
the tetrahedralization stays valid, else a rebuild, and the :class:`Deformation` report.

The functions take the scene as an argument (this module does not import
:mod:`tetrace.scene`); ``docs/deformation.md`` describes the rule.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

__all__ = ["Deformation", "update_vertices"]


@dataclasses.dataclass(frozen=True)
class Deformation:
    """What :meth:`Scene.update_vertices` did.

    Attributes
    ----------
    action : {"moved", "rebuilt"}
        ``"moved"``: the tetrahedralization kept its topology and took the new positions
        (every tet stayed positively oriented, exactly), or, on a scene whose
        tetrahedralization is not built yet, the triangles took them (nothing meshed).
        ``"rebuilt"``: the scene was meshed again from the new vertices, with the options
        it was built with.
    inverted : int
        Tets whose orientation with the proposed positions was not positive (inverted or
        flat), counted exactly; 0 when the move was not tried (see ``reason``).
    outside : int
        Proposed points that left the domain box (or box points that moved).
    reason : str
        Why the scene was rebuilt (``""`` when moved).
    seconds : dict
        Seconds per stage: ``map`` (how the points follow the vertices: once after each
        build), ``points`` (the proposed positions), ``update`` (the exact check and the
        swap in the core), ``rebuild`` (meshing again; 0 when moved), ``total``.
    frames : int
        Updates since the scene was last built or rebuilt, this one included (0 when this
        one rebuilt it).
    """

    action: str
    inverted: int
    outside: int
    reason: str
    seconds: dict
    frames: int


def update_vertices(scene, vertices):
    """The body of :meth:`tetrace.Scene.update_vertices` (which documents it)."""
    t_start = time.perf_counter()
    V = check_new_vertices(scene, vertices)
    seconds = dict(map=0.0, points=0.0, update=0.0, rebuild=0.0, total=0.0)
    if scene._tet is None:
        # No tetrahedralization yet: nothing to keep valid and nothing to mesh. The core of
        # the triangles alone is made again for the new positions; the BVHs follow the rule
        # of a move (built again now with other than the default parameters, else on their
        # next use). A later build_ct meshes the moved triangles.
        from . import construct

        t = time.perf_counter()
        fresh = construct.surface_scene(V, scene.faces, scene._build_options)
        fresh.adopt_structures(scene._native)
        scene._native = fresh
        set_vertices(scene, V)
        scene._frames += 1
        seconds["update"] = time.perf_counter() - t
        seconds["total"] = time.perf_counter() - t_start
        return report(scene, "moved", 0, 0, "", seconds)
    if scene._point_map is None:
        from .mesh.deform import PointMap

        t = time.perf_counter()
        rest = scene._rest or (scene.tetrahedralization, scene.vertices)
        scene._point_map = PointMap.build(*rest, scene.faces)
        seconds["map"] = time.perf_counter() - t
    pm = scene._point_map
    inverted = outside = 0
    reason = pm.reason or pm.check(V)
    if not reason:
        t = time.perf_counter()
        points = pm.points(V)
        tri = np.ascontiguousarray(V[np.asarray(scene.faces)], dtype=np.float64)
        seconds["points"] = time.perf_counter() - t
        t = time.perf_counter()
        applied, inverted, outside = scene._native.update_points(points, tri)
        seconds["update"] = time.perf_counter() - t
        if applied:
            tz = scene.tetrahedralization
            if scene._rest is None:
                scene._rest = (tz, scene.vertices)
            cm = tz.clean
            scene.tetrahedralization = dataclasses.replace(
                tz,
                points=points,
                clean=dataclasses.replace(cm, vertices=V[pm.input_src]),
                _weight=None,
            )
            set_vertices(scene, V)
            scene._frames += 1
            seconds["total"] = time.perf_counter() - t_start
            return report(scene, "moved", inverted, outside, "", seconds)
        reason = (
            f"{inverted} tets would invert or flatten"
            if inverted
            else f"{outside} points would leave the domain box"
        )
    t = time.perf_counter()
    rebuild(scene, V)
    seconds["rebuild"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t_start
    return report(scene, "rebuilt", inverted, outside, reason, seconds)


def check_new_vertices(scene, vertices):
    """New vertices as a float64 copy of the scene's shape, or a clear error."""
    v = np.asarray(vertices)
    if v.dtype.kind not in "iuf":
        raise TypeError(f"vertices must be real numbers, got dtype {v.dtype}")
    shape = np.shape(scene.vertices)
    if v.shape != shape:
        raise ValueError(f"vertices must have the shape of scene.vertices {shape}, got {v.shape}")
    v = np.array(v, dtype=np.float64, order="C", copy=True)
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(
            f"{int(bad.sum())} of {len(v)} vertices have a NaN/inf coordinate "
            f"(first: vertex {k}, {v[k].tolist()})"
        )
    return v


def set_vertices(scene, V):
    """Take ``V`` (float64, read-only after) as the scene's vertices; drop what they made."""
    V.setflags(write=False)
    scene.vertices = V
    scene._normals = None
    scene._surface = None  # moved vertices can merge, or make a triangle zero-area


def report(scene, action, inverted, outside, reason, seconds):
    """Keep and return the :class:`Deformation` of an update."""
    scene.last_deformation = Deformation(
        action=action,
        inverted=int(inverted),
        outside=int(outside),
        reason=reason,
        seconds=seconds,
        frames=scene._frames,
    )
    return scene.last_deformation


def rebuild(scene, V):
    """Mesh the scene again from vertices ``V`` with the options it was built with;
    the BVH and octree are built again with the parameters they had."""
    fresh = type(scene).from_mesh(
        (V, np.asarray(scene.faces)), hilbert=scene.hilbert, lazy=False, **scene._build_options
    )
    # The core's rule of a move (a structure built with other than the default parameters
    # is built again now, a default one on its next use), applied to the new scene before
    # anything else can see it.
    fresh._native.adopt_structures(scene._native)
    scene.tetrahedralization = fresh.tetrahedralization
    scene._native = fresh._native
    scene.build_times = fresh.build_times
    set_vertices(scene, V)
    scene._point_map = None
    scene._rest = None
    scene._frames = 0
