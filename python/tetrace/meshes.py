"""Scenes of several meshes: one triangle array for the core, and the way back to each mesh.

:meth:`tetrace.Scene.from_meshes` concatenates the meshes (vertices and faces, in the
order given) into one scene; the core numbers triangles in that concatenation (the *scene
triangle*). :class:`Geometries` maps a scene triangle back to ``(geometry, triangle)``: the
mesh it came from and its index in that mesh's faces. Imports only numpy and
:mod:`tetrace.io`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from .errors import MeshingError
from .io import is_trimesh_scene, load_triangles, trimesh_scene_meshes

__all__ = ["Geometries", "concatenate"]


@dataclasses.dataclass(frozen=True, eq=False)
class Geometries:
    """Where each mesh's triangles and vertices sit in a concatenated scene.

    Attributes
    ----------
    triangle_offsets : numpy.ndarray
        ``(G + 1,)`` int64: mesh ``g`` has the scene triangles
        ``triangle_offsets[g]:triangle_offsets[g + 1]``, in its own face order.
    vertex_offsets : numpy.ndarray
        ``(G + 1,)`` int64: the same for vertices.
    names : tuple of str or None
        Mesh ``g``'s name: the keys of a dict of meshes, the node names of a
        ``trimesh.Scene`` (:func:`tetrace.io.trimesh_scene_meshes`); None for a list.
    """

    triangle_offsets: np.ndarray
    vertex_offsets: np.ndarray
    names: tuple | None = None

    @classmethod
    def single(cls, n_triangles, n_vertices=0) -> Geometries:
        """One mesh: scene triangles are the mesh's triangles."""
        return cls(
            np.array([0, int(n_triangles)], np.int64), np.array([0, int(n_vertices)], np.int64)
        )

    def __len__(self) -> int:
        """Number of meshes ``G``."""
        return len(self.triangle_offsets) - 1

    def locate(self, scene_triangle):
        """Split scene triangle ids into ``(geometry, triangle)``.

        Parameters
        ----------
        scene_triangle : array_like
            Integer ids into the concatenated triangles; negative ids (misses) stay
            ``-1`` in both outputs.

        Returns
        -------
        geometry, triangle : numpy.ndarray
            int32, the shape of ``scene_triangle``: the mesh, and the index in its faces.
        """
        s = np.asarray(scene_triangle)
        hit = s >= 0
        g = np.searchsorted(self.triangle_offsets, s, side="right") - 1
        geometry = np.where(hit, g, -1).astype(np.int32)
        local = np.where(hit, s - self.triangle_offsets[np.clip(g, 0, len(self))], -1)
        return geometry, local.astype(np.int32)

    def scene_triangle(self, geometry, triangle):
        """Return the scene triangle id of ``triangle`` of mesh ``geometry`` (the inverse
        of :meth:`locate`)."""
        return np.asarray(self.triangle_offsets)[np.asarray(geometry)] + np.asarray(triangle)


def concatenate(meshes):
    """Concatenate meshes into one ``(vertices, faces)`` scene.

    Parameters
    ----------
    meshes : iterable or dict or trimesh.Scene
        Each a ``(vertices, faces)`` pair, a ``trimesh.Trimesh``, a path or an
        ``(F, 3, 3)`` triangle soup (anything :func:`tetrace.io.load_triangles` takes);
        a dict names them (its keys, in order, become :attr:`Geometries.names`); a
        ``trimesh.Scene`` is the dict of its placed meshes by node name
        (:func:`tetrace.io.trimesh_scene_meshes`).

    Returns
    -------
    vertices : numpy.ndarray
        ``(V, 3)`` float64, each mesh's vertices in order.
    faces : numpy.ndarray
        ``(F, 3)`` int64, each mesh's faces in order, renumbered into ``vertices``.
    geometries : Geometries

    Raises
    ------
    ValueError
        No meshes were given.
    tetrace.MeshingError, TypeError
        A mesh cannot be read; the message names its index.
    """
    if is_trimesh_scene(meshes):
        meshes = trimesh_scene_meshes(meshes)
    if isinstance(meshes, (str, bytes)) or not hasattr(meshes, "__iter__"):
        raise TypeError(
            f"meshes must be a list of meshes, got {type(meshes).__name__} "
            f"(use Scene.from_mesh for one mesh)"
        )
    names = None
    if isinstance(meshes, Mapping):
        names = tuple(str(k) for k in meshes)
        meshes = list(meshes.values())
    vertices, faces = [], []
    for g, mesh in enumerate(meshes):
        try:
            v, f = load_triangles(mesh)
        except (MeshingError, TypeError) as exc:
            which = f"mesh {g}" if names is None else f"mesh {g} ({names[g]!r})"
            raise type(exc)(f"{which}: {exc}") from exc
        vertices.append(v)
        faces.append(f)
    if not vertices:
        raise ValueError("meshes is empty: a scene needs at least one mesh")
    vertex_offsets = np.concatenate([[0], np.cumsum([len(v) for v in vertices])]).astype(np.int64)
    triangle_offsets = np.concatenate([[0], np.cumsum([len(f) for f in faces])]).astype(np.int64)
    all_faces = np.concatenate([f + o for f, o in zip(faces, vertex_offsets[:-1])])
    return (
        np.ascontiguousarray(np.concatenate(vertices)),
        np.ascontiguousarray(all_faces, dtype=np.int64),
        Geometries(triangle_offsets, vertex_offsets, names),
    )
