"""What meshing produces: the cleaned input and the tetrahedralization."""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass
class CleanMesh:
    """A triangle mesh TetGen can take, with the map back to the caller's triangles.

    Attributes
    ----------
    vertices : numpy.ndarray
        ``(V, 3)`` float64. Coincident vertices merged; vertices no kept face
        uses dropped. First-occurrence order of the input.
    faces : numpy.ndarray
        ``(F, 3)`` int64 indices into ``vertices``; no zero-area and no
        duplicate triangles.
    triangle_ids : numpy.ndarray
        ``(F,)`` int64: for each face, the index of the caller's triangle it
        came from (a piece of it, after a repair).
    dropped_degenerate : int
        Triangles dropped as zero-area (including those whose vertices merged).
    dropped_duplicate : int
        Triangles dropped as duplicates of an earlier one.
    """

    vertices: np.ndarray
    faces: np.ndarray
    triangle_ids: np.ndarray
    dropped_degenerate: int
    dropped_duplicate: int


@dataclasses.dataclass
class Tetrahedralization:
    """A constrained tetrahedralization of a triangle scene inside a box.

    Attributes
    ----------
    points : numpy.ndarray
        ``(P, 3)`` float64, C-contiguous: scene vertices, box corners and
        Steiner points.
    tets : numpy.ndarray
        ``(T, 4)`` uint32, C-contiguous indices into ``points``, oriented as
        the mesher gives them (all the same way).
    faces : numpy.ndarray
        ``(C, 3)`` uint32, C-contiguous: the constrained faces, pieces of scene
        triangles (box faces are not included).
    face_triangle : numpy.ndarray
        ``(C,)`` uint32: the caller's triangle id each constrained face lies on
        (fTetWild: the caller's triangle nearest to the face's centroid).
    domain : numpy.ndarray
        ``(2, 3)`` float64: lower and upper corner of the domain box.
    preset : str
        The TetGen preset used, or ``"ftetwild"``.
    n_input_triangles : int
        Number of triangles the caller gave.
    clean : CleanMesh
        The scene mesh the mesher was given (after a repair: the repaired
        pieces, cleaned, with ``triangle_ids`` still naming the caller's
        triangles and the drop counts of all cleaning passes).
    repaired : bool
        Whether self-intersections were resolved before meshing.
    timings : dict
        Seconds spent in ``clean``, ``repair`` (the self-intersection check and
        any cutting and snapping), ``tetgen``, ``ftetwild``, ``recover``
        (finding fTetWild's surface faces), ``mesher`` (the three before) and
        ``total`` (loading and failed attempts included).
    mesher : str
        ``"tetgen"`` or ``"ftetwild"``: the mesher that produced this.
    snap : float
        Cell of the snap-rounding grid the scene was rounded to (0.0: none), in
        scene units; vertices moved by at most ``snap * sqrt(3) / 2``.
    options : dict
        The mesher's settings: TetGen keyword arguments, or fTetWild's
        ``epsilon`` and ``edge_length`` (absolute) and the rest.
    attempts : list of str
        What was tried before and failed, and why (the TetGen attempts before a
        snap-rounded one succeeded, or before the fallback to fTetWild).
    auto : dict or None
        ``mesher="auto"`` only: the accuracy target, the weight tolerance, the chosen
        ``setting`` and every ``candidate`` tried (see :mod:`tetrace.mesh.auto`).
    surface_distance : dict or None
        fTetWild only: how far the constrained faces are from the caller's
        triangles, in scene units: ``max`` and ``mean`` (from points sampled on
        the constrained faces to the input), ``input_max`` and ``input_mean``
        (from points sampled on the input to the constrained faces: holes and
        dropped features show here), and ``diagonal`` (the scene's). None for
        TetGen, whose faces lie on the input exactly (up to ``snap``).
    """

    points: np.ndarray
    tets: np.ndarray
    faces: np.ndarray
    face_triangle: np.ndarray
    domain: np.ndarray
    preset: str
    n_input_triangles: int
    clean: CleanMesh
    repaired: bool
    timings: dict
    mesher: str = "tetgen"
    snap: float = 0.0
    options: dict = dataclasses.field(default_factory=dict)
    attempts: list = dataclasses.field(default_factory=list)
    surface_distance: dict | None = None
    auto: dict | None = None
    _weight: float | None = dataclasses.field(default=None, repr=False, compare=False)

    def weight(self) -> float:
        """Sum of the areas of all faces of the tetrahedralization (each shared face once).

        Lagae & Dutre (2008) found render time roughly proportional to it: by
        Crofton's formula, the number of faces a random line crosses is, on
        average, proportional to their total area. :func:`tetrahedralize` with
        ``mesher="auto"`` ranks its candidate settings by it.
        """
        if self._weight is None:
            faces = _unique_rows(np.sort(_tet_faces(self.tets), axis=1))
            p = self.points
            a, b, c = p[faces[:, 0]], p[faces[:, 1]], p[faces[:, 2]]
            self._weight = float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())
        return self._weight

    def __repr__(self):
        extra = ""
        if self.snap:
            extra += f", snap={self.snap:.3g}"
        if self.surface_distance:
            extra += f", max distance {self.surface_distance['max']:.3g}"
        return (
            f"Tetrahedralization({len(self.tets)} tets, {len(self.points)} points, "
            f"{len(self.faces)} constrained faces, mesher={self.mesher!r}, "
            f"preset={self.preset!r}, repaired={self.repaired}{extra})"
        )


def _tet_faces(tets):
    """The ``(4T, 3)`` faces of the tets (with repeats)."""
    return np.concatenate(
        [tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]]
    )


def _unique_rows(a):
    """Unique rows of an ``(N, 3)`` integer array whose rows are sorted."""
    if len(a) == 0:
        return a.reshape(0, 3)
    a = np.ascontiguousarray(a)
    order = np.lexsort((a[:, 2], a[:, 1], a[:, 0]))
    a = a[order]
    keep = np.ones(len(a), bool)
    keep[1:] = np.any(a[1:] != a[:-1], axis=1)
    return a[keep]
