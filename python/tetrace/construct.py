"""Construction: a scene's compiled core from a tetrahedralization, and the body of
:meth:`tetrace.Scene.from_mesh`. Receives the scene class; does not import
:mod:`tetrace.scene`."""

from __future__ import annotations

from functools import partial

import numpy as np

from . import _native
from .accuracy import measure_accuracy

__all__ = [
    "MESH_OPTIONS",
    "native_scene",
    "surface_scene",
    "from_mesh",
    "build_ct",
    "triangle_normals",
]

#: The options of :meth:`tetrace.Scene.from_mesh` that reach the mesher, kept on the scene
#: (``_build_options``): a rebuild (``update_vertices``) meshes again with them.
MESH_OPTIONS = (
    "preset",
    "mesher",
    "margin",
    "contain",
    "minratio",
    "maxvolume",
    "sizing",
    "repair",
    "epsilon",
    "edge_length",
    "timeout",
    "accuracy",
)


def native_scene(tet, vertices, faces, hilbert):
    """The compiled core (``_native.NativeScene``) of tetrahedralization ``tet`` of the
    caller's mesh ``(vertices, faces)``."""
    triangles = np.ascontiguousarray(vertices[faces], dtype=np.float64)
    # fTetWild's faces lie near the input, not on it: let hits name the neighbour of a
    # face's triangle that the ray crosses (see tetrace.mesh.neighbour_triangles).
    alternatives = None
    if getattr(tet, "mesher", "tetgen") == "ftetwild":
        from .mesh.ftetwild import neighbour_triangles

        alternatives = neighbour_triangles(tet.clean, len(faces))
    return _native.NativeScene(
        np.ascontiguousarray(tet.points, dtype=np.float64),
        np.ascontiguousarray(tet.tets, dtype=np.uint32),
        np.ascontiguousarray(tet.faces, dtype=np.uint32).reshape(-1, 3),
        np.ascontiguousarray(tet.face_triangle, dtype=np.uint32),
        triangles,
        hilbert=bool(hilbert),
        alternatives=alternatives,
    )


def surface_scene(vertices, faces, options):
    """The compiled core of the caller's triangles alone (``NativeScene.surface_only``), in
    the domain box :meth:`~tetrace.Scene.from_mesh`'s ``options`` (``margin``, ``contain``)
    would have the mesher wrap them in: what the BVHs, the octree and closest points read
    before (or without) a tetrahedralization."""
    from .mesh.clean import domain_box

    lo, hi = domain_box(vertices, margin=options["margin"], contain=options["contain"])
    triangles = np.ascontiguousarray(np.asarray(vertices, np.float64)[faces])
    return _native.NativeScene.surface_only(triangles, tuple(lo), tuple(hi))


def _tetrahedralize(cls, vertices, faces, options, name):
    """The tetrahedralization of ``(vertices, faces)`` with :meth:`~tetrace.Scene.from_mesh`'s
    ``options``."""
    from .mesh import FTETWILD_EDGE_LENGTH, FTETWILD_EPSILON, tetrahedralize

    epsilon, edge_length = options["epsilon"], options["edge_length"]
    return tetrahedralize(
        (vertices, faces),
        **dict(
            options,
            epsilon=FTETWILD_EPSILON if epsilon is None else epsilon,
            edge_length=FTETWILD_EDGE_LENGTH if edge_length is None else edge_length,
        ),
        measure=partial(measure_accuracy, cls),
        name=name,
    )


def from_mesh(cls, mesh, options, hilbert, progress, lazy=True):
    """The body of :meth:`tetrace.Scene.from_mesh` (which documents it): a ``cls`` of
    ``mesh`` with ``options`` (:data:`MESH_OPTIONS`), meshed now unless ``lazy``."""
    from .io import _mesh_name, is_trimesh_scene
    from .mesh import load_triangles
    from .progress import reporting, stage

    if not isinstance(lazy, bool):
        raise TypeError(f"lazy must be True or False, got {lazy!r}")
    if is_trimesh_scene(mesh):
        # Meshed as one, like its path, but with the per-mesh ids from_meshes record.
        return cls.from_meshes(mesh, hilbert=hilbert, progress=progress, lazy=lazy, **options)
    with reporting(progress):
        vertices, faces = load_triangles(mesh)
        name = _mesh_name(mesh)
        if lazy:
            return cls._without_ct(vertices, faces, options, hilbert, name)
        tet = _tetrahedralize(cls, vertices, faces, options, name)
        with stage(f"build the scene ({len(tet.tets)} tets)"):
            scene = cls(tet, vertices, faces, hilbert=hilbert)
    scene._build_options = options
    scene._mesh_name = name
    return scene


def build_ct(scene, progress):
    """The body of :meth:`tetrace.Scene.build_ct`: mesh ``scene``'s triangles with the options
    it was made with and install the tetrahedralization (its BVHs are kept)."""
    from .progress import reporting, stage

    with reporting(progress):
        tet = _tetrahedralize(
            type(scene), scene.vertices, scene.faces, scene._build_options, scene._mesh_name
        )
        with stage(f"build the scene ({len(tet.tets)} tets)"):
            loaded = scene.build_times.get("total", 0.0)
            scene._install_ct(tet)
            scene.build_times["surface"] = loaded


def triangle_normals(vertices, faces):
    """:meth:`tetrace.Scene.normals` (which documents them) with a row of ``nan`` appended
    (a miss's, for the hits' gather), ``(F + 1, 3)``, read-only: computed by the core on
    every core, the same bits as ``np.cross`` and ``np.linalg.norm`` give."""
    rows = _native.triangle_normals(
        np.ascontiguousarray(vertices, np.float64), np.ascontiguousarray(faces, np.int64)
    )
    rows.setflags(write=False)
    return rows
