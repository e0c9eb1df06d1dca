"""Construction: a scene's compiled core from a tetrahedralization, and the body of
:meth:`tetrace.Scene.from_mesh`. Receives the scene class; does not import
:mod:`tetrace.scene`."""

from __future__ import annotations

from functools import partial

import numpy as np

from . import _native
from .accuracy import measure_accuracy

__all__ = ["MESH_OPTIONS", "native_scene", "from_mesh", "triangle_normals"]

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


def from_mesh(cls, mesh, options, hilbert, progress):
    """The body of :meth:`tetrace.Scene.from_mesh` (which documents it): a ``cls`` meshed
    from ``mesh`` with ``options`` (:data:`MESH_OPTIONS`)."""
    from .io import _mesh_name, is_trimesh_scene
    from .mesh import FTETWILD_EDGE_LENGTH, FTETWILD_EPSILON, load_triangles, tetrahedralize
    from .progress import reporting, stage

    if is_trimesh_scene(mesh):
        # Meshed as one, like its path, but with the per-mesh ids from_meshes records.
        return cls.from_meshes(mesh, hilbert=hilbert, progress=progress, **options)
    with reporting(progress):
        vertices, faces = load_triangles(mesh)
        epsilon, edge_length = options["epsilon"], options["edge_length"]
        tet = tetrahedralize(
            (vertices, faces),
            **dict(
                options,
                epsilon=FTETWILD_EPSILON if epsilon is None else epsilon,
                edge_length=FTETWILD_EDGE_LENGTH if edge_length is None else edge_length,
            ),
            measure=partial(measure_accuracy, cls),
            name=_mesh_name(mesh),
        )
        with stage(f"build the scene ({len(tet.tets)} tets)"):
            scene = cls(tet, vertices, faces, hilbert=hilbert)
    scene._build_options = options
    return scene


def triangle_normals(vertices, faces):
    """:meth:`tetrace.Scene.normals` (which documents them), read-only."""
    p = np.asarray(vertices, np.float64)[np.asarray(faces)]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        n = np.where(length > 0, n / length, np.nan)
    n.setflags(write=False)
    return n
