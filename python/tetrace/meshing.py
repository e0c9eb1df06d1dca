"""Triangle scene -> constrained tetrahedralization (CT), the input of the ray caster.

Two meshers, pure Python around their wrappers:

* **TetGen** (the ``tetgen`` wrapper), the exact route: every scene triangle is a
  union of tet faces, bit for bit. Presets name its settings (:data:`PRESETS`).
* **fTetWild** (the ``pytetwild`` wrapper), the approximate route for scenes
  TetGen cannot take: it remeshes the scene surface within an envelope of
  ``epsilon`` (relative to the scene's diagonal) and tetrahedralizes the box
  around it. The constrained faces are the tet faces lying on the remeshed
  surface, each mapped to the nearest caller triangle; how far that surface is
  from the input is measured and reported (:attr:`Tetrahedralization.surface_distance`).

``mesher="fallback"`` tries TetGen and uses fTetWild when it fails, recording why.

The TetGen route:

1. :func:`load_triangles` takes the caller's triangles as given (their face
   indices are the triangle ids that hits report).
2. :func:`clean` merges coincident vertices and drops zero-area and duplicate
   triangles, which TetGen rejects or mishandles, keeping a map back to the
   caller's ids.
3. The scene plus a box around it (:func:`domain_box`) form a piecewise linear
   complex (PLC); TetGen builds a CT of the box in which every scene triangle
   is a union of tet faces. Scene triangles carry marker ``id + 1`` and box
   faces ``-1``, so the constrained faces TetGen outputs (pieces of input
   triangles, split wherever it inserted Steiner points) name their triangle.
4. Before TetGen runs, the cleaned scene is checked for self-intersections
   (triangles crossing, touching or overlapping other triangles' interiors:
   not a PLC). With ``repair="auto"`` they are cut with
   ``igl.copyleft.cgal.remesh_self_intersections`` in exact arithmetic; each
   piece keeps its original triangle id, and the result is cleaned again.
   The check comes first because TetGen's own failure on such input can
   corrupt the heap of the process it runs in.
5. If TetGen fails on that, the scene is *snap-rounded*: vertices are rounded
   to a grid of cell 2^k close to 1e-7 (then 1e-6) of the diagonal, which
   merges the nearly coincident points that exact cutting leaves behind, the
   intersections this creates are cut again, and so on until none is left;
   TetGen then runs without its final mesh optimisation (the step that fails
   on such scenes). See :data:`SNAP_LADDER`.
6. TetGen, the repair and fTetWild run in forked child processes on Linux
   (:data:`ISOLATE_TETGEN`), so that a crash becomes a :class:`MeshingError`,
   under a time limit that grows with the scene (:func:`default_timeout`); a
   timeout or crash names the stage and, for TetGen, the phase it was in.

Only numpy is imported at module level; trimesh, tetgen, igl and pytetwild are
imported when needed, so this module loads without the compiled extension.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

__all__ = [
    "MeshingError",
    "MeshFileNotFoundError",
    "CleanMesh",
    "Tetrahedralization",
    "PRESETS",
    "DEFAULT_PRESET",
    "MESHERS",
    "SNAP_LADDER",
    "load_triangles",
    "clean",
    "domain_box",
    "tetrahedralize",
    "tetgen_options",
    "preset_options",
    "default_timeout",
    "count_intersecting_pairs",
    "ftetwild_available",
]


class MeshingError(ValueError):
    """A scene cannot be loaded or tetrahedralized; the message names the cause."""


class MeshFileNotFoundError(MeshingError, FileNotFoundError):
    """The mesh file does not exist (both a :class:`MeshingError` and a ``FileNotFoundError``)."""


# Options every TetGen run shares. brio_hilbert: TetGen inserts points in a BRIO/Hilbert
# order, which is what keeps its Delaunay phase fast; quiet/nowarning: TetGen prints
# to the C stdout, which Python cannot capture (in a forked child it prints its phases
# to a log file instead, see _tetgen_arrays).
_COMMON = dict(plc=True, brio_hilbert=True, quiet=True, nowarning=True, verbose=0)

#: The named TetGen presets: ``minratio`` is the radius-edge bound (TetGen ``-q``;
#: None: no refinement), ``sizing`` a target edge length that grows away from the
#: surface (see ``sizing`` in :func:`tetrahedralize`; None: none), ``tetgen`` (optional)
#: TetGen keyword arguments that override the defaults.
#:
#: ``"constrained"``
#:     Constrained Delaunay tetrahedralization of the PLC (TetGen ``-p``), no
#:     refinement: the fewest tets, but long slivers fan out from the scene's
#:     vertices, so rays cross 1.7-3.8x more tets than with ``"quality"``.
#: ``"quality"`` (the default)
#:     Delaunay refinement to radius-edge ratio 5 (TetGen ``-pq5``). Measured on
#:     spot, bunny, armadillo and torus_knots_27, bounds from 1.5 to 10 all cut
#:     the tets a ray visits to a half to a third of ``"constrained"``; 3-5 visit
#:     the fewest, and 5 builds the fewest tets the fastest of those (bunny:
#:     261k tets in 3.5 s, against 613k in 9.7 s at 1.5).
#: ``"quality3"``, ``"quality2"``, ``"quality1.5"``
#:     Tighter radius-edge bounds (more, better-shaped tets). Any ``"quality<r>"``
#:     with r > 1 is accepted, e.g. ``"quality1.2"``.
#: ``"graded"``
#:     ``"quality"`` plus a sizing field: target edge length 2% of the scene
#:     diagonal on the surface, growing by 0.5 per unit of distance from it, so
#:     tet volume grows away from the surface instead of a few huge tets and
#:     long slivers filling the space between objects (see ``sizing`` in
#:     :func:`tetrahedralize`; needs libigl).
#:
#: :func:`tetrahedralize` adds a Steiner-point budget (``steinerleft``, see
#: :func:`tetgen_options`).
PRESETS: dict[str, dict] = {
    "constrained": dict(minratio=None, sizing=None),
    "quality": dict(minratio=5.0, sizing=None),
    "quality3": dict(minratio=3.0, sizing=None),
    "quality2": dict(minratio=2.0, sizing=None),
    "quality1.5": dict(minratio=1.5, sizing=None),
    "graded": dict(minratio=5.0, sizing=(0.02, 0.5)),
}

#: The preset :func:`tetrahedralize` uses when none is given.
DEFAULT_PRESET = "quality"

#: Values of ``mesher``: ``"tetgen"`` (exact, the default), ``"ftetwild"``
#: (approximate, within ``epsilon``), ``"fallback"`` (TetGen, then fTetWild if it fails),
#: ``"auto"`` (the lowest-weight setting that meets ``accuracy``; :mod:`tetrace.auto_mesher`).
MESHERS = ("tetgen", "ftetwild", "fallback", "auto")

#: fTetWild defaults, relative to the scene's bounding-box diagonal: the envelope
#: (how far the remeshed surface may lie from the input) and the target edge length.
FTETWILD_EPSILON = 1e-3
FTETWILD_EDGE_LENGTH = 0.05

#: Attempts of the TetGen route after the scene as given (or exactly repaired) fails:
#: ``(snap, overrides)``, the snap-rounding cell relative to the domain diagonal
#: (rounded to a power of two) and TetGen options that change. ``opt_iterations=0``
#: turns off TetGen's final mesh optimisation (``-O``), which is what raises
#: "Internal error in repair_tet" on repaired scenes; the CT is valid without it.
SNAP_LADDER = ((1e-7, dict(opt_iterations=0)), (1e-6, dict(opt_iterations=0)))

# Steiner-point budget of a refinement (TetGen -S): max(MIN, PER_VERTEX * scene
# vertices). Radius-edge refinement grades the mesh down to the smallest feature,
# so a thin plate or a light 0.1 under a 550-unit ceiling would otherwise take
# hundreds of thousands of points; the real scenes measured need 0.4-1.3 per vertex.
_STEINER_MIN = 10_000
_STEINER_PER_VERTEX = 2
# Radius-edge bound used when only maxvolume or a sizing field asks for refinement:
# loose enough that no tet is split for its shape.
_LOOSE_RATIO = 1e6


def preset_options(preset) -> dict:
    """Return the options of a preset name: ``minratio`` (float or None), ``sizing``
    (tuple or None) and ``tetgen`` (dict of TetGen overrides).

    Parameters
    ----------
    preset : str
        A key of :data:`PRESETS`, or ``"quality<r>"`` for any radius-edge bound r > 1.

    Raises
    ------
    ValueError
        Unknown name, or a bound not above 1.
    """
    if not isinstance(preset, str):
        raise TypeError(f"preset must be a name (str), got {type(preset).__name__}")
    if preset in PRESETS:
        return dict(dict(tetgen={}), **PRESETS[preset])
    m = re.fullmatch(r"quality(\d+(?:\.\d*)?|\.\d+)", preset)
    if m:
        ratio = float(m.group(1))
        if not ratio > 1.0:
            raise ValueError(f"preset {preset!r}: the radius-edge bound must be > 1")
        return dict(minratio=ratio, sizing=None, tetgen={})
    raise ValueError(f"unknown preset {preset!r}; choose one of {sorted(PRESETS)} "
                     f"or 'quality<r>' with r > 1")


def default_timeout(n_faces, stage="tetgen") -> float:
    """Seconds one stage may run on a scene of ``n_faces`` triangles before it is stopped.

    ``"tetgen"`` and ``"repair"``: 180 s + 1 ms per triangle (bunny, 69k triangles:
    249 s, against 3.5 s for the default preset and 10 s for ``"quality1.5"``; but
    featuretype's 3.5k triangles, with their sharp angles, took 50 s to refine);
    ``"ftetwild"``: 300 s + 10 ms per triangle (fTetWild is far slower: spot's 5.8k
    triangles take 13 s on one core). ``TETRACE_TETGEN_TIMEOUT`` (seconds; 0 or
    "none": no limit) overrides every stage.
    """
    env = os.environ.get("TETRACE_TETGEN_TIMEOUT", "").strip().lower()
    if env:
        if env in ("0", "none", "inf"):
            return None
        return float(env)
    n = max(int(n_faces), 0)
    if stage == "ftetwild":
        return 300.0 + 10e-3 * n
    return 180.0 + 1e-3 * n


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
        ``setting`` and every ``candidate`` tried (see :mod:`tetrace.auto_mesher`).
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
        return (f"Tetrahedralization({len(self.tets)} tets, {len(self.points)} points, "
                f"{len(self.faces)} constrained faces, mesher={self.mesher!r}, "
                f"preset={self.preset!r}, repaired={self.repaired}{extra})")


# --------------------------------------------------------------------------- loading


def _mesh_name(mesh) -> str:
    """Name a mesh argument in messages."""
    if isinstance(mesh, (str, os.PathLike)):
        return Path(mesh).name
    return "the mesh"


def load_triangles(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Return the caller's triangles as ``(vertices, faces)`` arrays, validated.

    Nothing is merged or removed, so face indices are the caller's triangle ids.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or os.PathLike or tuple
        A ``trimesh.Trimesh`` (anything with ``vertices`` and ``faces``), a file
        loaded with ``trimesh.load(path, force="mesh")`` (trimesh's default
        processing, as :func:`tetrace.reference.load_triangles` does, so both
        number triangles alike), or a ``(vertices (V, 3), faces (F, 3))`` tuple.

    Returns
    -------
    vertices : numpy.ndarray
        ``(V, 3)`` float64, C-contiguous.
    faces : numpy.ndarray
        ``(F, 3)`` int64.

    Raises
    ------
    MeshFileNotFoundError
        The path does not exist (also a ``FileNotFoundError``).
    MeshingError
        The file cannot be loaded; the mesh has no faces; vertices have
        non-finite coordinates; face indices are negative or out of range;
        arrays have the wrong shape.
    TypeError
        ``mesh`` is of an unsupported type, faces are not integers, or vertices
        are not real numbers.
    """
    if isinstance(mesh, (str, os.PathLike)):
        path = Path(mesh)
        if not path.is_file():
            what = "is a directory, not a mesh file" if path.is_dir() else "not found"
            raise MeshFileNotFoundError(2, f"mesh file {what}: {path}", str(path))
        import trimesh

        try:
            mesh = trimesh.load(path, force="mesh")
        except Exception as exc:  # trimesh raises many types for bad files
            raise MeshingError(f"could not load mesh file {path}: "
                               f"{type(exc).__name__}: {exc}") from exc
        if not hasattr(mesh, "faces"):
            raise MeshingError(f"could not load mesh file {path}: trimesh returned "
                               f"{type(mesh).__name__}, not a triangle mesh")
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    elif isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        vertices, faces = mesh
    else:
        raise TypeError("mesh must be a trimesh.Trimesh, a path or a (vertices, faces) tuple, "
                        f"got {type(mesh).__name__}")

    vertices = np.asarray(vertices)
    faces = np.asarray(faces)
    if vertices.dtype.kind not in "biuf":
        raise TypeError(f"vertices must be real numbers, got dtype {vertices.dtype}")
    if faces.size == 0:
        raise MeshingError(f"empty mesh: it has no faces (faces shape {faces.shape})")
    if faces.dtype.kind not in "iu":
        raise TypeError(f"faces must be integers (vertex indices), got dtype {faces.dtype}")
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise MeshingError(f"vertices must have shape (V, 3), got {vertices.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise MeshingError(f"faces must have shape (F, 3) (triangles only), got {faces.shape}")
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise MeshingError(f"{int(bad.sum())} of {len(vertices)} vertices have non-finite "
                           f"coordinates (NaN or inf), first at vertex {int(np.argmax(bad))}")
    # Compare before converting: a huge uint64 would wrap to a negative int64.
    if faces.dtype.kind == "i" and faces.min() < 0:
        n = int((faces < 0).any(axis=1).sum())
        raise MeshingError(f"{n} faces have negative vertex indices (smallest {int(faces.min())})")
    if faces.max() >= len(vertices):
        n = int((faces >= len(vertices)).any(axis=1).sum())
        raise MeshingError(f"{n} faces have vertex indices out of range: largest index "
                           f"{int(faces.max())}, but there are {len(vertices)} vertices")
    return vertices, np.ascontiguousarray(faces, dtype=np.int64)


# --------------------------------------------------------------------------- cleaning


def _merge_coincident(vertices):
    """Return ``(unique_vertices, inverse)``, unique rows in first-occurrence order."""
    # + 0.0 turns -0.0 into 0.0 so the two merge.
    v = np.ascontiguousarray(vertices, dtype=np.float64) + 0.0
    if len(v) == 0:
        return v.reshape(0, 3), np.zeros(0, np.int64)
    _, first, inverse = np.unique(v, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return v[first[order]], rank[inverse]


def _double_areas(vertices, faces):
    """Return twice the area of each triangle."""
    p = vertices[faces]
    return np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def clean(vertices, faces, *, area_eps=1e-14) -> CleanMesh:
    """Make a triangle soup acceptable to TetGen, keeping the caller's triangle ids.

    Parameters
    ----------
    vertices : array_like
        ``(V, 3)`` vertex coordinates.
    faces : array_like
        ``(F, 3)`` integer vertex indices.
    area_eps : float
        Triangles with area ``<= area_eps * (largest triangle area)`` count as
        zero-area and are dropped.

    Returns
    -------
    CleanMesh
        Vertices with exactly equal coordinates merged (and unused ones
        dropped); triangles that are zero-area or use a vertex twice after the
        merge dropped; duplicate triangles (the same three vertices in any order
        or orientation) dropped, the first one kept. ``triangle_ids`` gives the
        row of ``faces`` each kept triangle came from.
    """
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(faces).reshape(-1, 3)
    if faces.dtype.kind not in "iu":
        raise TypeError(f"faces must be integers, got dtype {faces.dtype}")
    faces = faces.astype(np.int64, copy=False)
    n_faces = len(faces)

    merged, inverse = _merge_coincident(vertices)
    f = inverse[faces] if n_faces else faces
    ids = np.arange(n_faces, dtype=np.int64)

    # Degenerate: a repeated index, or an area negligible next to the largest triangle.
    distinct = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    area = _double_areas(merged, f) if n_faces else np.zeros(0)
    max_area = area[distinct].max() if distinct.any() else 0.0
    keep = distinct & (area > area_eps * max_area) & (area > 0)
    dropped_degenerate = int(n_faces - keep.sum())
    f, ids = f[keep], ids[keep]

    # Duplicates: the same vertex set; np.unique's return_index is the first occurrence.
    dropped_duplicate = 0
    if len(f):
        _, first = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
        first.sort()
        dropped_duplicate = int(len(f) - len(first))
        f, ids = f[first], ids[first]

    # Drop vertices no face uses: TetGen would insert them as isolated points.
    used = np.zeros(len(merged), bool)
    used[f.ravel()] = True
    renumber = np.cumsum(used) - 1
    return CleanMesh(
        vertices=np.ascontiguousarray(merged[used]),
        faces=np.ascontiguousarray(renumber[f], dtype=np.int64).reshape(-1, 3),
        triangle_ids=ids,
        dropped_degenerate=dropped_degenerate,
        dropped_duplicate=dropped_duplicate,
    )


# --------------------------------------------------------------------------- domain


def domain_box(vertices, *, margin=0.02, contain=None) -> np.ndarray:
    """Return the domain box: the scene's bounds grown by a margin.

    Parameters
    ----------
    vertices : array_like
        ``(V, 3)`` scene vertices.
    margin : float
        Added on every side, as a fraction of the scene's bounding-box diagonal.
        Must be positive: a box touching the scene would overlap its faces.
        A flat scene gets the margin across its flat axis too, so the box never
        has zero size.
    contain : array_like, optional
        ``(N, 3)`` points (ray origins, a camera) the box must also contain,
        with the same margin around them.

    Returns
    -------
    numpy.ndarray
        ``(2, 3)`` float64: lower corner, upper corner.
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if len(v) == 0:
        raise MeshingError("domain_box needs at least one vertex")
    if not np.isfinite(v).all():
        raise MeshingError("domain_box: vertices have non-finite coordinates")
    margin = float(margin)
    if not (np.isfinite(margin) and margin > 0):
        raise ValueError(f"margin must be a positive number, got {margin!r}")
    lo, hi = v.min(axis=0), v.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    # A single point has no diagonal: fall back to its magnitude (or 1).
    scale = diag if diag > 0 else max(float(np.abs(lo).max()), 1.0)
    pad = margin * scale
    if contain is not None:
        c = np.asarray(contain, dtype=np.float64)
        if c.size:
            if c.shape[-1] != 3:
                raise ValueError(f"contain must be (N, 3) points, got shape {c.shape}")
            c = c.reshape(-1, 3)
            if not np.isfinite(c).all():
                raise ValueError("contain points must be finite")
            lo = np.minimum(lo, c.min(axis=0))
            hi = np.maximum(hi, c.max(axis=0))
    box = np.array([lo - pad, hi + pad])
    # For far-away coordinates the pad can vanish in rounding; step to the next doubles.
    box[0] = np.where(box[0] < lo, box[0], np.nextafter(lo, -np.inf))
    box[1] = np.where(box[1] > hi, box[1], np.nextafter(hi, np.inf))
    return box


def _box_mesh(box):
    """The 12 outward triangles of an axis-aligned box ``(2, 3)``."""
    lo, hi = box
    # Vertex i has x from bit 2, y from bit 1, z from bit 0 (trimesh.creation.box order).
    bits = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=bool)
    corners = np.where(bits, hi, lo).astype(np.float64)
    faces = np.array([[1, 3, 0], [4, 1, 0], [0, 3, 2], [2, 4, 0], [1, 7, 3], [5, 1, 4],
                      [5, 7, 1], [3, 7, 2], [6, 4, 2], [2, 7, 6], [6, 5, 4], [7, 5, 6]],
                     dtype=np.int64)
    return corners, faces


# --------------------------------------------------------------------------- repair

# Passes of exact remeshing: rounding the exact cut points to doubles can leave new
# tiny intersections, which another pass cuts (two_cylinder_engine: 33599, 307, 30, 4
# pairs, then 1 or 2 for ever: a needle 2e-7 of the diagonal wide keeps crossing a
# neighbour after rounding). Snap-rounded repair (each pass cuts, then rounds to the
# grid) may need more.
_REPAIR_PASSES = 8
_SNAP_REPAIR_PASSES = 8
# When a pass cut few pairs (8 or fewer) or no fewer than the one before, needles among
# the triangles still intersecting are dropped: a triangle narrower than this (relative to the
# diagonal) leaves a hole no wider, which rays cross with a probability of that order.
_NEEDLE_WIDTH = 1e-6


def _igl_cgal():
    """Return ``igl.copyleft.cgal``, or None when libigl is not installed."""
    try:
        import igl.copyleft.cgal as cgal
    except ImportError:
        return None
    return cgal


def count_intersecting_pairs(vertices, faces, *, first_only=False) -> int:
    """Count pairs of triangles that intersect other than in shared vertices or edges.

    Exact (CGAL, through libigl). Crossing triangles, coplanar overlaps and a
    vertex or edge touching another triangle's interior all count.

    Parameters
    ----------
    vertices : array_like
        ``(V, 3)`` float64.
    faces : array_like
        ``(F, 3)`` integer; should be cleaned (see :func:`clean`), since
        duplicate triangles count as intersecting.
    first_only : bool
        Stop at the first pair (returns 0 or 1): a cheap yes/no test.

    Returns
    -------
    int

    Raises
    ------
    MeshingError
        libigl is not installed.
    """
    cgal = _igl_cgal()
    if cgal is None:
        raise MeshingError("counting self-intersections needs libigl (pip install libigl)")
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    if len(f) < 2:
        return 0
    _, _, pairs, _, _ = cgal.remesh_self_intersections(
        v, f, detect_only=True, first_only=bool(first_only))
    return int(len(pairs))


def _recleaned(cm: CleanMesh, vertices, faces, ids, area_eps=1e-14) -> CleanMesh:
    """Clean ``(vertices, faces)`` whose faces came from caller triangles ``ids``."""
    again = clean(vertices, faces, area_eps=area_eps)
    return CleanMesh(
        vertices=again.vertices,
        faces=again.faces,
        triangle_ids=np.asarray(ids, dtype=np.int64)[again.triangle_ids],
        dropped_degenerate=cm.dropped_degenerate + again.dropped_degenerate,
        dropped_duplicate=cm.dropped_duplicate + again.dropped_duplicate,
    )


def _remesh(cm: CleanMesh, area_eps: float) -> tuple[CleanMesh, int]:
    """One pass of exact remeshing along the self-intersections; returns the cleaned result
    (triangle ids still the caller's) and the number of intersecting pairs cut.

    Only the triangles of intersecting pairs are cut (the others would come out
    unchanged, and cutting all of them made every pass cost as much as the first: two
    snap-rounding passes on two_cylinder_engine ran past 170 s). A cut point on an edge
    shared with an uncut triangle is a new intersection, which the next pass cuts.
    """
    cgal = _igl_cgal()
    v = np.ascontiguousarray(cm.vertices, dtype=np.float64)
    f = np.ascontiguousarray(cm.faces, dtype=np.int64)
    _, _, pairs, _, _ = cgal.remesh_self_intersections(v, f, detect_only=True)
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if len(pairs) == 0:
        return cm, 0
    cut = np.zeros(len(f), bool)
    cut[pairs.ravel()] = True
    used, local = np.unique(f[cut], return_inverse=True)
    vv, ff, _, birth, im = cgal.remesh_self_intersections(
        np.ascontiguousarray(v[used]), np.ascontiguousarray(local.reshape(-1, 3), dtype=np.int64))
    # IM maps every vertex to the representative of its exact position (cut points
    # are created once per triangle pair); J (birth) is the face each piece came from.
    ff = np.asarray(im, dtype=np.int64)[np.asarray(ff, dtype=np.int64)] + len(v)
    ids = np.concatenate([cm.triangle_ids[~cut],
                          cm.triangle_ids[cut][np.asarray(birth, dtype=np.int64)]])
    faces = np.concatenate([f[~cut], ff])
    # Pieces in caller order, so where triangles overlap the lowest caller id keeps the piece.
    order = np.argsort(ids, kind="stable")
    faces, ids = faces[order], ids[order]
    # The cut triangles' vertices come back as copies: clean merges them with the
    # originals. Rounding exact cut points to doubles can merge points and flatten
    # slivers; coplanar overlaps leave the same piece from both triangles (the first
    # is kept).
    return _recleaned(cm, np.vstack([v, vv]), faces, ids, area_eps), int(len(pairs))


def _snap_cell(box, rel) -> float:
    """The power of two nearest to ``rel`` times the domain diagonal."""
    diag = float(np.linalg.norm(box[1] - box[0]))
    return float(2.0 ** round(math.log2(rel * diag)))


def _snap(cm: CleanMesh, cell: float) -> CleanMesh:
    """Round every vertex to the nearest multiple of ``cell`` (a power of two: exact),
    then clean: vertices in one cell merge, triangles they flatten are dropped."""
    return _recleaned(cm, np.round(cm.vertices / cell) * cell, cm.faces, cm.triangle_ids)


def _drop_needles(cm: CleanMesh, width: float) -> tuple[CleanMesh, int]:
    """Drop the triangles of intersecting pairs whose height (twice the area over the
    longest edge) is below ``width``; returns the mesh and how many were dropped."""
    cgal = _igl_cgal()
    _, _, pairs, _, _ = cgal.remesh_self_intersections(
        np.ascontiguousarray(cm.vertices), np.ascontiguousarray(cm.faces, dtype=np.int64),
        detect_only=True)
    involved = np.unique(np.asarray(pairs, dtype=np.int64))
    if len(involved) == 0:
        return cm, 0
    p = cm.vertices[cm.faces[involved]]
    longest = np.max([np.linalg.norm(p[:, i] - p[:, (i + 1) % 3], axis=1) for i in range(3)],
                     axis=0)
    height = _double_areas(cm.vertices, cm.faces[involved]) / longest
    drop = involved[height < width]
    if len(drop) == 0:
        return cm, 0
    keep = np.ones(len(cm.faces), bool)
    keep[drop] = False
    out = _recleaned(cm, cm.vertices, cm.faces[keep], cm.triangle_ids[keep])
    out.dropped_degenerate += len(drop)
    return out, int(len(drop))


def _repair(cm: CleanMesh, name: str, area_eps: float, snap: float = 0.0):
    """Cut self-intersections until none is left (or the passes run out).

    With ``snap`` (a grid cell), round to the grid first and after every cut (snap
    rounding): the cut points that rounding to doubles leaves a hair apart merge.
    When a pass cut few pairs (8 or fewer) or no fewer than the one before, needles
    (see :data:`_NEEDLE_WIDTH`) among the triangles still intersecting are dropped.
    Returns ``(mesh, pairs cut in the first pass, pairs left)``.
    """
    if _igl_cgal() is None:
        raise MeshingError(f"{name}: repairing self-intersections needs libigl with CGAL "
                           f"(pip install libigl)")
    lo, hi = cm.vertices.min(axis=0), cm.vertices.max(axis=0)
    width = _NEEDLE_WIDTH * float(np.linalg.norm(hi - lo))
    if snap:
        cm = _snap(cm, snap)
    passes = _SNAP_REPAIR_PASSES if snap else _REPAIR_PASSES
    first = last = before = None
    for _ in range(passes):
        if first is not None or snap:
            # First pass without snap: the caller checked that something intersects.
            if count_intersecting_pairs(cm.vertices, cm.faces, first_only=True) == 0:
                return cm, first or 0, 0
        if last is not None and (last <= 8 or (before is not None and last >= before)):
            cm, dropped = _drop_needles(cm, width)
            if dropped and count_intersecting_pairs(cm.vertices, cm.faces, first_only=True) == 0:
                return cm, first or 0, 0
        cm, n = _remesh(cm, area_eps)
        if snap:
            cm = _snap(cm, snap)
        first = n if first is None else first
        before, last = last, n
        if snap and before is not None and last > before:
            # Rounding a heavily cut scene to the grid can fold slivers over their
            # neighbours faster than cutting removes them (two_cylinder_engine: 62944,
            # 38375, then 425635 pairs): stop rather than run into the time limit.
            raise MeshingError(
                f"{name}: snap rounding to a {snap:.3g} grid does not converge: a pass cut "
                f"{last} intersecting pairs, more than the {before} of the pass before")
        if len(cm.faces) == 0:
            raise MeshingError(f"{name}: nothing left to mesh after repairing self-intersections")
    return cm, first or 0, count_intersecting_pairs(cm.vertices, cm.faces)


def _repair_left_message(name, snap, left, first):
    passes = _SNAP_REPAIR_PASSES if snap else _REPAIR_PASSES
    how = f"snap-rounded to a {snap:.3g} grid and " if snap else ""
    return (f"{name}: the scene still has {left} intersecting triangle pairs after {passes} "
            f"passes of {how}exact repair ({first} pairs cut in the first); rounding the cut "
            f"points to floating point keeps creating new ones, so TetGen cannot mesh it")


# --------------------------------------------------------------------------- child processes


class _TetGenFailed(Exception):
    """A mesher (TetGen, fTetWild) gave no mesh; ``str`` is its reason."""

    phase = None


class _TetGenCrashed(Exception):
    """The child process running a stage died; ``str`` says how, ``phase`` where (if known)."""

    phase = None


class _TetGenTimeout(_TetGenCrashed):
    """A stage ran past its time limit and its child was stopped."""


#: Run TetGen, the repair and fTetWild in forked child processes (Linux only). TetGen
#: can segfault on near-degenerate input, and its error path (a C++ exception thrown
#: from deep inside) can corrupt the heap of the process it runs in; in a child,
#: either becomes a :class:`MeshingError` and the caller's process is unharmed, and a
#: stage that runs too long can be stopped. It costs a fork and a copy of the result
#: (milliseconds). Set ``TETRACE_TETGEN_ISOLATE=0`` (or assign False here) to run
#: in-process, without time limits.
ISOLATE_TETGEN = (sys.platform.startswith("linux") and hasattr(os, "fork")
                  and os.environ.get("TETRACE_TETGEN_ISOLATE", "1").strip().lower()
                  not in ("0", "false", "no", "off"))

# The file in the child's working folder its stdout and stderr go to.
_CHILD_LOG = "stage.log"


def _last_phase(text):
    """The last phase header in a TetGen log ("Recovering boundaries..."), or None."""
    phase = None
    for line in text.splitlines():
        s = line.rstrip()
        if s and not s[0].isspace() and s.endswith("..."):
            phase = s.rstrip(". ")
    return phase


def _call_forked(fn, *args, timeout=None):
    """Return ``fn(*args)`` computed in a forked child.

    The child's stdout and stderr go to a log file in its own working folder, which
    ``fn`` may write to; the last TetGen phase header found there is attached as
    ``.phase`` to the exceptions below. Re-raises the child's :class:`_TetGenFailed`
    and :class:`MeshingError`; raises :class:`_TetGenCrashed` when the child dies
    without answering and :class:`_TetGenTimeout` when it runs past ``timeout`` seconds.
    """
    import ctypes  # noqa: F401  (loaded before the fork; the child uses it)
    import pickle
    import select
    import signal
    import tempfile
    import warnings

    parent = os.getpid()
    # TetGen writes _skipped.node/.face into the working directory when it fails:
    # the child works in a folder of its own, removed afterwards.
    with tempfile.TemporaryDirectory(prefix="tetrace-mesher-") as workdir:
        log_path = os.path.join(workdir, _CHILD_LOG)
        read_fd, write_fd = os.pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        with warnings.catch_warnings():
            # Python >= 3.12 warns on fork in a threaded process; the child only runs
            # the mesher and numpy and never touches locks other threads may hold.
            warnings.simplefilter("ignore", DeprecationWarning)
            pid = os.fork()
        if pid == 0:  # child: never return into the caller's code
            try:
                os.close(read_fd)
                _child_setup(parent, workdir, log_path)
                try:
                    result = ("ok", fn(*args))
                except _TetGenFailed as exc:
                    result = ("failed", str(exc))
                except MeshingError as exc:
                    result = ("meshing", str(exc))
                except BaseException as exc:  # noqa: BLE001  (reported to the parent)
                    result = ("error", f"{type(exc).__name__}: {exc}")
                with os.fdopen(write_fd, "wb") as out:
                    out.write(pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))
            finally:
                os._exit(0)
        os.close(write_fd)
        deadline = None if timeout is None else time.monotonic() + timeout
        chunks = []
        try:
            while True:
                if deadline is not None:
                    left = deadline - time.monotonic()
                    if left <= 0:
                        raise _TetGenTimeout(f"stopped after {timeout:g} s")
                    if not select.select([read_fd], [], [], left)[0]:
                        continue
                chunk = os.read(read_fd, 1 << 22)
                if not chunk:
                    break
                chunks.append(chunk)
        except BaseException as exc:  # timeout or KeyboardInterrupt: stop the child too
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            if isinstance(exc, _TetGenCrashed):
                exc.phase = _read_phase(log_path)
            raise
        finally:
            os.close(read_fd)
        _, status = os.waitpid(pid, 0)
        phase = _read_phase(log_path)
    data = b"".join(chunks)
    if not data:
        if os.WIFSIGNALED(status):
            sig = os.WTERMSIG(status)
            try:
                how = f"killed by {signal.Signals(sig).name}"
            except ValueError:
                how = f"killed by signal {sig}"
        else:
            how = f"exit status {os.WEXITSTATUS(status)}"
        exc = _TetGenCrashed(how)
        exc.phase = phase
        raise exc
    kind, payload = pickle.loads(data)
    if kind == "meshing":
        raise MeshingError(payload)
    if kind in ("failed", "error"):
        exc = _TetGenFailed(payload if kind == "failed" else f"error in the child process: {payload}")
        exc.phase = phase
        raise exc
    return payload


def _read_phase(path):
    try:
        with open(path, errors="replace") as fh:
            return _last_phase(fh.read())
    except OSError:
        return None


def _child_setup(parent, workdir, log_path):
    """Prepare a forked child: quiet on crashes, output to a log, bound to its parent's life."""
    # A crash is reported by the parent; no traceback dump from the child.
    import faulthandler

    faulthandler.disable()
    os.chdir(workdir)
    # C code (TetGen) prints to fd 1: send it to the log, line-buffered so the last
    # phase header is there even if the child is killed mid-phase.
    fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)
    try:
        import ctypes
        import signal

        libc = ctypes.CDLL(None)
        try:
            stdout = ctypes.c_void_p.in_dll(libc, "stdout")
            libc.setvbuf(stdout, None, 1, 0)  # _IOLBF
        except (ValueError, AttributeError):
            pass
        # Die with the parent (PR_SET_PDEATHSIG = 1), so a killed caller leaves no
        # mesher running on; if it already died, stop now.
        libc.prctl(1, int(signal.SIGKILL))
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(1)


def _run_stage(fn, *args, timeout=None, isolate=None):
    """Run ``fn(*args)`` in a forked child under ``timeout`` (or in-process when not isolating)."""
    if ISOLATE_TETGEN if isolate is None else isolate:
        return _call_forked(fn, *args, timeout=timeout)
    return fn(*args)


def _stage_message(stage, exc, timeout) -> str:
    """One line naming the stage, what happened and (TetGen) the phase it was in."""
    where = f" in TetGen's phase '{exc.phase}'" if getattr(exc, "phase", None) else ""
    if isinstance(exc, _TetGenTimeout):
        return (f"{stage} timed out: stopped after {timeout:g} s{where} (time limit: "
                f"timeout=, or TETRACE_TETGEN_TIMEOUT)")
    if isinstance(exc, _TetGenCrashed):
        return f"{stage} crashed ({exc}){where}"
    return f"{stage} failed ({exc}){where}"


# --------------------------------------------------------------------------- TetGen


def _tetgen_arrays(points_in, faces_in, markers, options, log=False):
    """Run TetGen; return ``(points, tets, scene_faces, scene_markers)``.

    ``log``: stdout is a log file (a forked child): let TetGen print its phase headers
    there (verbose=0: headers only), so that a timeout or crash can name the phase.
    """
    import tetgen

    options = dict(options)
    if log:
        options.update(quiet=False)
    tg = tetgen.TetGen(points_in, faces_in, markers)
    try:
        nodes, elems, _, _ = tg.tetrahedralize(**options)
    except (RuntimeError, ValueError, MemoryError) as exc:
        raise _TetGenFailed(str(exc).strip() or type(exc).__name__) from exc
    if len(elems) == 0:
        raise _TetGenFailed("TetGen produced no tetrahedra")
    # Without facesout TetGen outputs only boundary faces: the box pieces (-1) and the
    # constrained scene pieces (their marker), never the unmarked interior faces.
    marks = np.asarray(tg.triface_markers).reshape(-1)
    keep = marks > 0
    return (np.ascontiguousarray(nodes, dtype=np.float64),
            np.ascontiguousarray(elems, dtype=np.uint32),
            np.ascontiguousarray(np.asarray(tg.trifaces).reshape(-1, 3)[keep], dtype=np.uint32),
            marks[keep].astype(np.int64))


#: Most points a sizing field may add (see :func:`_sizing_points`).
SIZING_MAX_POINTS = 2_000_000


def _sizing_points(box, vertices, faces, h0, growth):
    """Points that make TetGen's tets grow away from the surface: ``(N, 3)``.

    An octree over the domain box: a cell of side s is split while the target edge
    length ``h0 + growth * d`` at its centre (d: distance to the surface) is below s;
    each leaf contributes its centre unless the cell may touch the surface (d < s) or
    sticks out of the box. TetGen inserts them as isolated vertices, and its quality
    refinement fills in around them, so tets near a point at distance d have edges of
    about ``h0 + growth * d``. (TetGen's own sizing, ``-m`` with a background mesh,
    crashed on a torus knot, whichever background mesh it was given.)
    """
    import igl

    lo, hi = np.asarray(box[0], np.float64), np.asarray(box[1], np.float64)
    ext = hi - lo
    s = float(ext.min())
    counts = np.maximum(np.ceil(ext / s).astype(int), 1)
    grid = np.stack(np.meshgrid(*(np.arange(n) for n in counts), indexing="ij"), -1).reshape(-1, 3)
    centres = lo + (grid + 0.5) * s
    offsets = np.array([[(i >> 2 & 1), (i >> 1 & 1), i & 1] for i in range(8)], float) - 0.5
    v = np.ascontiguousarray(vertices, np.float64)
    f = np.ascontiguousarray(faces, np.int64)
    out = []
    total = 0
    while len(centres):
        d2, _, _ = igl.point_mesh_squared_distance(centres, v, f)
        d = np.sqrt(d2)
        leaf = h0 + growth * d >= s
        keep = leaf & (d >= s) & np.all(centres - s / 2 >= lo, axis=1) & np.all(
            centres + s / 2 <= hi, axis=1)
        out.append((centres[keep], s))
        total += int(keep.sum())
        if total > SIZING_MAX_POINTS:
            raise MeshingError(f"the sizing field (h0={h0:.3g}, growth={growth:.3g}) asks for "
                               f"more than {SIZING_MAX_POINTS:,} points; raise h0 or growth")
        # Split the rest, unless they are already finer than h0 (the surface's layer).
        split = centres[~leaf & (s / 2 >= h0 / 2)]
        centres = (split[:, None, :] + offsets[None] * (s / 2)).reshape(-1, 3)
        s /= 2
    if not total:
        return np.zeros((0, 3))
    # A jitter (seeded: the same scene gives the same mesh) breaks the grid's
    # degeneracies (cospherical and coplanar points), on which TetGen's boundary
    # recovery stalled for a thin plate. Each point stays in the middle half of its cell.
    rng = np.random.default_rng(0)
    return np.concatenate([c + rng.uniform(-size / 4, size / 4, c.shape) for c, size in out])


def _run_tetgen(cm: CleanMesh, box: np.ndarray, options: dict, isolate=None, *, extra=None,
                timeout=None):
    """Tetrahedralize scene + box (+ ``extra`` isolated points); return
    ``(points, tets, faces, face_triangle)``."""
    import tetgen  # noqa: F401  (imported here so a forked child finds it loaded)

    corners, box_faces = _box_mesh(box)
    nv = len(cm.vertices)
    parts = [cm.vertices, corners] + ([extra] if extra is not None and len(extra) else [])
    points_in = np.vstack(parts)
    faces_in = np.vstack([cm.faces, box_faces + nv])
    if len(points_in) >= 2**31 or len(faces_in) >= 2**31 - 1:
        raise MeshingError(f"scene too large for TetGen: {len(points_in)} points, "
                           f"{len(faces_in)} faces")
    # Marker id + 1 for scene face id (0 is TetGen's "no marker"), -1 for the box.
    markers = np.concatenate([np.arange(1, len(cm.faces) + 1), np.full(len(box_faces), -1)])
    isolate = ISOLATE_TETGEN if isolate is None else isolate
    args = (points_in, faces_in.astype(np.int32), markers.astype(np.int32), options, isolate)
    points, tets, faces, marks = _run_stage(_tetgen_arrays, *args, timeout=timeout, isolate=isolate)
    face_triangle = np.ascontiguousarray(cm.triangle_ids[marks - 1], dtype=np.uint32)
    return points, tets, faces, face_triangle


def tetgen_options(preset=DEFAULT_PRESET, *, minratio=None, maxvolume=None, n_vertices=0) -> dict:
    """Return the keyword arguments :func:`tetrahedralize` passes to TetGen.

    Parameters
    ----------
    preset : str
        A key of :data:`PRESETS` or ``"quality<r>"`` (see :func:`preset_options`).
    minratio : float, optional
        Radius-edge bound (TetGen ``-q``), > 1; turns refinement on.
    maxvolume : float, optional
        Maximum tet volume (TetGen ``-a``), > 0; turns refinement on.
    n_vertices : int
        Scene vertices, which size the Steiner-point budget of a refinement.

    Returns
    -------
    dict
        Keyword arguments of ``tetgen.TetGen.tetrahedralize``: the preset's,
        the overrides, and ``steinerleft``, the Steiner-point budget. A
        refinement gets ``max(10000, 2 * n_vertices)`` (radius-edge refinement
        grades down to the smallest feature, so a thin plate would otherwise
        take hundreds of thousands of points; the real scenes measured need
        0.4-1.3 per vertex). Without refinement it is unlimited (``-1``): only
        the points boundary recovery cannot do without are added. A preset's
        sizing field is not a TetGen option (see :func:`tetrahedralize`), but it
        turns refinement on.
    """
    p = preset_options(preset)
    options = dict(_COMMON, **p["tetgen"])
    if p["minratio"] is not None:
        options.update(quality=True, minratio=float(p["minratio"]), mindihedral=0.0)
    else:
        options.update(quality=False)
    if minratio is not None:
        minratio = float(minratio)
        if not (np.isfinite(minratio) and minratio > 1.0):
            raise ValueError(f"minratio (TetGen radius-edge bound) must be > 1.0, got {minratio!r}")
        options.update(quality=True, minratio=minratio, mindihedral=0.0)
    if maxvolume is not None:
        maxvolume = float(maxvolume)
        if not (np.isfinite(maxvolume) and maxvolume > 0):
            raise ValueError(f"maxvolume must be a positive number, got {maxvolume!r}")
        options.update(fixedvolume=True, maxvolume=maxvolume)
    if (maxvolume is not None or p["sizing"] is not None) and not options.get("quality"):
        # TetGen enforces -a and -m only while refining; a bound this loose splits
        # tets for their volume or size alone.
        options.update(quality=True, minratio=_LOOSE_RATIO, mindihedral=0.0)
    if options.get("quality"):
        options["steinerleft"] = max(_STEINER_MIN, _STEINER_PER_VERTEX * int(n_vertices))
    else:
        # Only the Steiner points boundary recovery cannot do without: no budget.
        options["steinerleft"] = -1
    return options


def _check_sizing(sizing):
    if sizing is None:
        return None
    try:
        h0, growth = (float(x) for x in sizing)
    except (TypeError, ValueError):
        raise ValueError(f"sizing must be (h0, growth), two numbers, got {sizing!r}") from None
    if not (np.isfinite(h0) and h0 > 0 and np.isfinite(growth) and growth >= 0):
        raise ValueError(f"sizing: h0 must be > 0 and growth >= 0, got {sizing!r}")
    return h0, growth


def _tetgen_route(name, cm, box, options, *, repair, sizing, timeout, timings, attempts,
                  diagonal, constrained_last=False, isolate=None):
    """The exact route: as given (repaired if it self-intersects), then the snap ladder,
    then (``constrained_last``, when the preset refines) the constrained CT of the first
    snap-rounded scene.

    Returns ``(points, tets, faces, face_triangle, cm, repaired, snap, options, preset)``;
    ``preset`` is None, or ``"constrained"`` when the last rung built it.
    """
    have_igl = _igl_cgal() is not None
    t = time.perf_counter()
    intersects = have_igl and repair is not False and count_intersecting_pairs(
        cm.vertices, cm.faces, first_only=True) > 0
    if repair is False and have_igl:
        n = count_intersecting_pairs(cm.vertices, cm.faces)
        if n:
            raise MeshingError(f"{name} is not a valid PLC: {n} pairs of triangles intersect "
                               f"(cross, overlap or touch away from shared edges), which TetGen "
                               f"cannot mesh; pass repair='auto' or repair=True to cut them")
    timings["repair"] += time.perf_counter() - t
    # Rungs: (snap cell, TetGen overrides, preset override).
    ladder = [(0.0, {}, None)]
    if repair is not False and have_igl:
        ladder += [(_snap_cell(box, rel), overrides, None) for rel, overrides in SNAP_LADDER]
        if constrained_last and options.get("quality") and SNAP_LADDER:
            rel, overrides = SNAP_LADDER[0]
            ladder.append((_snap_cell(box, rel), overrides, "constrained"))
    sizing_points = None
    if sizing is not None:
        try:
            import igl  # noqa: F401
        except ImportError:
            raise MeshingError("a sizing field (preset 'graded', sizing=) needs libigl "
                               "(pip install libigl)") from None
        t = time.perf_counter()
        sizing_points = _sizing_points(box, cm.vertices, cm.faces, sizing[0] * diagonal, sizing[1])
        timings["tetgen"] += time.perf_counter() - t
    repaired_meshes = {}  # snap cell -> (mesh, repaired, label) or an error message
    # Snap rounding starts from the exact repair's result when there is one, even if
    # a few intersections were left: that is most of the cutting done.
    start = cm
    for snap, overrides, preset in ladder:
        t = time.perf_counter()
        if snap not in repaired_meshes:
            try:
                if snap:
                    work, n_cut, left = _run_stage(_repair, start, name, 1e-14, snap,
                                                   timeout=timeout, isolate=isolate)
                    label = (f"TetGen on the scene snap-rounded to {snap:.3g} "
                             f"({snap / diagonal:.1g} of the diagonal) and repaired")
                elif repair is True or intersects:
                    work, n_cut, left = _run_stage(_repair, cm, name, 1e-14, timeout=timeout,
                                                   isolate=isolate)
                    start = work
                    label = f"TetGen after exact repair of {n_cut} intersecting triangle pairs"
                else:
                    work, n_cut, left = cm, None, 0
                    label = "TetGen on the scene as given"
                if left:
                    raise MeshingError(_repair_left_message(name, snap, left, n_cut))
                repaired_meshes[snap] = (work, n_cut is not None, label)
            except (_TetGenFailed, _TetGenCrashed) as exc:
                repaired_meshes[snap] = _stage_message(
                    f"repair{' (snap rounding)' if snap else ''}", exc, timeout)
                attempts.append(repaired_meshes[snap])
            except MeshingError as exc:
                repaired_meshes[snap] = str(exc)
                attempts.append(str(exc))
            timings["repair"] += time.perf_counter() - t
        if isinstance(repaired_meshes[snap], str):
            continue
        work, repaired, label = repaired_meshes[snap]
        if preset is None:
            opts = dict(options, **overrides)
            points = sizing_points
        else:
            opts = dict(tetgen_options(preset, n_vertices=len(work.vertices)), **overrides)
            label += f", preset {preset!r}"
            points = None
        if overrides.get("opt_iterations") == 0:
            label += ", mesh optimisation off"
        t = time.perf_counter()
        try:
            result = _run_tetgen(work, box, opts, isolate, extra=points, timeout=timeout)
        except (_TetGenFailed, _TetGenCrashed) as exc:
            timings["tetgen"] += time.perf_counter() - t
            attempts.append(_stage_message(label, exc, timeout))
            continue
        timings["tetgen"] += time.perf_counter() - t
        return (*result, work, repaired, snap, opts, preset)
    if not have_igl:
        hint = ("self-intersections were not checked: install libigl (pip install libigl) "
                "to check and repair them")
    elif repair is False:
        hint = "repair=False: no snap rounding was tried"
    else:
        hint = "mesher='ftetwild' or 'fallback' meshes it approximately"
        if options.get("quality") and not constrained_last:
            hint = "preset='constrained' may work; " + hint
    raise MeshingError(f"TetGen could not mesh {name}: " + "; ".join(attempts) + f". {hint}")


# --------------------------------------------------------------------------- fTetWild


def ftetwild_available() -> bool:
    """Whether the fTetWild route can run (``pytetwild`` imports)."""
    try:
        _pytetwild()
    except MeshingError:
        return False
    return True


def _pytetwild():
    try:
        import pytetwild
    except ImportError as exc:
        why = ("pytetwild >= 0.3 imports pyvista, which is not installed; "
               "pip install 'pytetwild>=0.2.3,<0.3' (or pyvista)"
               if "pyvista" in str(exc) else "pip install 'pytetwild>=0.2.3,<0.3'")
        raise MeshingError(f"the fTetWild mesher needs pytetwild: {why} ({exc})") from None
    return pytetwild


def _ftetwild_arrays(vertices, faces, epsilon_rel, edge_abs, threads, stop_energy, optimize):
    """Run fTetWild on a triangle soup, keeping its whole background box (no filtering).

    Its input simplification is off: it merges input triangles into larger surface
    faces, each of which can name only one triangle (on spot, 78% of camera rays then
    named Embree's triangle, against 98% without it and without optimisation).
    """
    pytetwild = _pytetwild()
    try:
        points, tets = pytetwild.tetrahedralize(
            np.ascontiguousarray(vertices, dtype=np.float64),
            np.ascontiguousarray(faces, dtype=np.int32),
            edge_length_abs=float(edge_abs), epsilon=float(epsilon_rel),
            stop_energy=float(stop_energy), num_threads=int(threads),
            disable_filtering=True, quiet=True, loglevel=6, simplify=False,
            optimize=bool(optimize))
    except (RuntimeError, ValueError, MemoryError) as exc:
        raise _TetGenFailed(str(exc).strip() or type(exc).__name__) from exc
    if len(tets) == 0:
        raise _TetGenFailed("fTetWild produced no tetrahedra")
    return (np.ascontiguousarray(points, dtype=np.float64),
            np.ascontiguousarray(tets, dtype=np.uint32))


#: Vertices of higher valence add no neighbours in :func:`neighbour_triangles` (a fan of
#: thousands of triangles would add millions of pairs; its triangles keep their edge
#: neighbours through their other vertices).
_MAX_VALENCE = 64


def neighbour_triangles(cm: CleanMesh, n_triangles: int):
    """The caller's triangles that share a vertex with each caller triangle.

    A fTetWild face names the input triangle nearest its centre; a ray crossing the face
    may cross a neighbour of that triangle instead, and the cast then names the neighbour
    it crosses (``alternatives`` of the native scene). Neighbours are found on the
    cleaned mesh (coincident vertices merged), whose faces map to the caller's triangles.

    Returns
    -------
    offsets, ids : numpy.ndarray
        uint32 CSR: the neighbours of caller triangle k are ``ids[offsets[k]:offsets[k+1]]``.
    """
    faces = np.asarray(cm.faces, np.int64)
    caller = np.asarray(cm.triangle_ids, np.int64)
    vert = faces.ravel()
    face = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(vert, kind="stable")
    vert, face = vert[order], face[order]
    starts = np.flatnonzero(np.r_[True, vert[1:] != vert[:-1]]) if len(vert) else vert
    counts = np.diff(np.r_[starts, len(vert)])
    keep = counts <= _MAX_VALENCE
    starts, counts = starts[keep], counts[keep]
    # Every ordered pair of faces around each kept vertex.
    group = np.repeat(np.arange(len(starts)), counts)
    members = np.repeat(starts, counts) + (np.arange(counts.sum()) - np.repeat(
        np.cumsum(counts) - counts, counts))
    size = counts[group]
    a = np.repeat(members, size)
    first = np.repeat(starts[group], size)
    b = first + (np.arange(size.sum()) - np.repeat(np.cumsum(size) - size, size))
    pairs = np.stack([caller[face[a]], caller[face[b]]], axis=1)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    if len(pairs):
        pairs = np.unique(pairs, axis=0)
    offsets = np.zeros(n_triangles + 1, np.int64)
    np.cumsum(np.bincount(pairs[:, 0], minlength=n_triangles), out=offsets[1:])
    return offsets.astype(np.uint32), np.ascontiguousarray(pairs[:, 1], dtype=np.uint32)


def _tet_faces(tets):
    """The ``(4T, 3)`` faces of the tets (with repeats)."""
    return np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]],
                           tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]])


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


def _point_triangle_distance(p, a, b, c):
    """Distance from points ``p (N, 3)`` to triangles ``(a, b, c)`` (each ``(N, 3)``),
    vectorized (Ericson, Real-Time Collision Detection, 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(invalid="ignore", divide="ignore"):
        # interior by default, then the regions in the reverse order of the book's tests
        den = va + vb + vc
        v, w = vb / den, vc / den
        closest = a + ab * v[:, None] + ac * w[:, None]
        cases = [
            ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),  # edge bc
             b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[:, None]),
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * (d2 / (d2 - d6))[:, None]),  # edge ac
            ((d6 >= 0) & (d5 <= d6), c),  # vertex c
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * (d1 / (d1 - d3))[:, None]),  # edge ab
            ((d3 >= 0) & (d4 <= d3), b),  # vertex b
            ((d1 <= 0) & (d2 <= 0), a),  # vertex a
        ]
    for mask, point in cases:
        closest = np.where(mask[:, None], point, closest)
    return np.linalg.norm(p - closest, axis=1)


def _face_samples(q):
    """Six points on each triangle of ``q (N, 3, 3)`` besides its centroid: the edge
    midpoints and three points halfway between the centroid and a corner; ``(N, 6, 3)``."""
    a, b, c = q[:, 0], q[:, 1], q[:, 2]
    return np.stack([(a + b) / 2, (b + c) / 2, (a + c) / 2,
                     (4 * a + b + c) / 6, (a + 4 * b + c) / 6, (a + b + 4 * c) / 6], axis=1)


#: A tet face near the scene counts as surface only if its normal is within about 8
#: degrees of its nearest triangle's (|cos| >= this). Without fTetWild's optimisation
#: its mesh is fine near the surface, and many faces lie in the envelope without being
#: on the remeshed surface (faces across the layer; on sponza 4.1M of them passed the
#: distance test, 1.1M this one, and the input was covered as well by either set).
SURFACE_MIN_COS = 0.99


# Rows processed at a time in the surface recovery: fTetWild without optimisation
# gives two_cylinder_engine 17M tets, and whole-array temporaries ran out of memory.
_CHUNK = 1 << 21


def _recover_chunk(points, faces, dv, scene_v, scene_f, n_scene, tol):
    """The surface test of :func:`_recover_surface` on candidate faces ``(N, 3)``."""
    import igl

    q = points[faces]
    c2, ci, _ = igl.point_mesh_squared_distance(q.mean(axis=1), scene_v, scene_f)
    dc = np.sqrt(c2)
    nearest = np.asarray(ci, dtype=np.int64)
    nf = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
    t = scene_v[scene_f[nearest]]
    nt = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.abs(np.einsum("ij,ij->i", nf, nt)) / (
            np.linalg.norm(nf, axis=1) * np.linalg.norm(nt, axis=1))
    keep = (dc <= tol) & (nearest < n_scene) & (cos >= SURFACE_MIN_COS)
    faces, q, dc, nearest = faces[keep], q[keep], dc[keep], nearest[keep]
    # Distances to the centroid's triangle bound those to the surface from above, and
    # settle most faces (fTetWild without optimisation keeps pieces of one triangle);
    # only samples farther than tol from it are looked up in the whole scene.
    samples = _face_samples(q).reshape(-1, 3)
    t = np.repeat(scene_v[scene_f[nearest]], 6, axis=0)
    ds = _point_triangle_distance(samples, t[:, 0], t[:, 1], t[:, 2])
    far = np.flatnonzero(~(ds <= tol))
    if len(far):
        s2, _, _ = igl.point_mesh_squared_distance(samples[far], scene_v, scene_f)
        ds[far] = np.sqrt(s2)
    ds = ds.reshape(len(faces), 6)
    on = ds.max(axis=1) <= tol
    dist = np.concatenate([dv[faces], dc[:, None], ds], axis=1)
    return faces[on], nearest[on], dist[on]


def _recover_surface(points, tets, scene_v, scene_f, n_scene, tol):
    """Find the tet faces lying on the remeshed scene surface.

    A face counts when its corners, its centroid and six more points on it (edge
    midpoints, ...) all lie within ``tol`` of the input surface ``(scene_v, scene_f)``,
    and it is nearly parallel to the input triangle nearest to its centroid
    (:data:`SURFACE_MIN_COS`), which is the triangle it names. Faces nearest to an
    input triangle at index ``>= n_scene`` (the domain box added to fTetWild's input)
    are not scene faces. Returns ``(faces (C, 3), nearest (C,), distances (C, 10))``:
    the distances of the three corners, the centroid and the six other points.
    """
    import igl

    d2, _, _ = igl.point_mesh_squared_distance(points, scene_v, scene_f)
    dv = np.sqrt(d2)
    near = dv <= tol
    index = np.int32 if len(points) < 2**31 else np.int64
    candidates = []
    for start in range(0, len(tets), _CHUNK):
        f = _tet_faces(np.asarray(tets[start:start + _CHUNK], dtype=index))
        f = f[near[f].all(axis=1)]
        candidates.append(np.sort(f, axis=1))
    faces = _unique_rows(np.concatenate(candidates)) if candidates else np.zeros((0, 3), index)
    del candidates
    parts = [_recover_chunk(points, faces[i:i + _CHUNK].astype(np.int64), dv, scene_v, scene_f,
                            n_scene, tol) for i in range(0, len(faces), _CHUNK)]
    if not parts:
        return np.zeros((0, 3), np.uint32), np.zeros(0, np.int64), np.zeros((0, 10))
    return (np.ascontiguousarray(np.concatenate([p[0] for p in parts]), dtype=np.uint32),
            np.concatenate([p[1] for p in parts]), np.concatenate([p[2] for p in parts]))


def _surface_distance(points, faces, dist, scene_v, scene_f, diagonal, n_samples=200_000,
                      seed=0):
    """How far the recovered faces and the input surface are from each other (see
    :attr:`Tetrahedralization.surface_distance`)."""
    import igl

    out = dict(diagonal=float(diagonal))
    out["max"] = float(dist.max()) if len(dist) else float("inf")
    out["mean"] = float(dist[:, 3].mean()) if len(dist) else float("inf")
    # Input -> faces: the input's vertices, centroids and area-weighted random points.
    p = scene_v[scene_f]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(p), size=n_samples, p=area / area.sum())
    r = rng.random((n_samples, 2))
    flip = r.sum(axis=1) > 1
    r[flip] = 1 - r[flip]
    tri = p[pick]
    rand = tri[:, 0] + r[:, :1] * (tri[:, 1] - tri[:, 0]) + r[:, 1:] * (tri[:, 2] - tri[:, 0])
    queries = np.concatenate([scene_v, p.mean(axis=1), rand])
    if len(faces):
        d2, _, _ = igl.point_mesh_squared_distance(queries, points, faces.astype(np.int64))
        d = np.sqrt(d2)
        out["input_max"] = float(d.max())
        out["input_mean"] = float(d[-n_samples:].mean())
    else:
        out["input_max"] = out["input_mean"] = float("inf")
    return out


def _ftetwild_route(name, cm, box, *, contain, epsilon, edge_length, threads, stop_energy,
                    optimize, timeout, timings, isolate=None):
    """The approximate route; returns ``(points, tets, faces, face_triangle, distance, options)``."""
    _pytetwild()
    try:
        import igl  # noqa: F401
    except ImportError:
        raise MeshingError("the fTetWild route finds the remeshed surface with libigl "
                           "(pip install libigl)") from None
    lo, hi = cm.vertices.min(axis=0), cm.vertices.max(axis=0)
    diagonal = float(np.linalg.norm(hi - lo)) or 1.0
    eps_abs, edge_abs = epsilon * diagonal, edge_length * diagonal
    v, f = cm.vertices, cm.faces
    n_scene = len(f)
    if contain is not None:
        # fTetWild meshes the bounding box of its input (grown by about one edge length):
        # add the domain box as surface so the domain contains the points; its faces are
        # not mapped to triangles.
        corners, box_faces = _box_mesh(box)
        v = np.vstack([v, corners])
        f = np.vstack([f, box_faces + len(cm.vertices)])
    input_diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) or 1.0
    options = dict(epsilon=eps_abs, edge_length=edge_abs, epsilon_rel=epsilon,
                   edge_length_rel=edge_length, stop_energy=stop_energy, threads=threads,
                   optimize=bool(optimize), simplify=False, box_in_input=contain is not None)
    t = time.perf_counter()
    try:
        points, tets = _run_stage(_ftetwild_arrays, v, f, eps_abs / input_diag, edge_abs,
                                  threads, stop_energy, optimize, timeout=timeout,
                                  isolate=isolate)
    except (_TetGenFailed, _TetGenCrashed) as exc:
        timings["ftetwild"] += time.perf_counter() - t
        raise MeshingError(f"{name}: " + _stage_message("fTetWild", exc, timeout)) from None
    timings["ftetwild"] += time.perf_counter() - t
    t = time.perf_counter()
    # fTetWild keeps its surface within the envelope; 0.1% slack for rounding.
    tol = eps_abs * 1.001
    faces, nearest, dist = _recover_surface(points, tets, v,
                                            f.astype(np.int64), n_scene, tol)
    if len(faces) == 0:
        timings["recover"] += time.perf_counter() - t
        raise MeshingError(f"{name}: fTetWild's mesh has no faces within {tol:.3g} of the scene")
    face_triangle = np.ascontiguousarray(cm.triangle_ids[nearest], dtype=np.uint32)
    distance = _surface_distance(points, faces, dist, cm.vertices, cm.faces, diagonal)
    timings["recover"] += time.perf_counter() - t
    return points, tets, faces, face_triangle, distance, options


# --------------------------------------------------------------------------- entry point


def tetrahedralize(mesh, preset=DEFAULT_PRESET, *, mesher="tetgen", margin=0.02, contain=None,
                   minratio=None, maxvolume=None, sizing=None, repair="auto",
                   epsilon=FTETWILD_EPSILON, edge_length=FTETWILD_EDGE_LENGTH,
                   ftetwild_optimize=False, timeout=None, threads=0,
                   stop_energy=10.0, accuracy=None) -> Tetrahedralization:
    """Build a constrained tetrahedralization of a triangle scene inside a box.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or os.PathLike or tuple
        Anything :func:`load_triangles` takes. Open, non-manifold and
        multi-component scenes are fine; self-intersecting ones are repaired
        (see ``repair``).
    preset : str
        TetGen settings: a key of :data:`PRESETS` (``"constrained"``,
        ``"quality"``, ``"quality3"``, ``"quality2"``, ``"quality1.5"``,
        ``"graded"``) or ``"quality<r>"`` for a radius-edge bound r > 1.
    mesher : {"tetgen", "ftetwild", "fallback", "auto"}
        ``"tetgen"``: exact; the constrained faces are pieces of the caller's
        triangles. ``"ftetwild"``: fTetWild remeshes the surface within
        ``epsilon`` and keeps the whole box around it; the constrained faces
        lie within ``epsilon`` of the input and name the nearest triangle.
        ``"fallback"``: TetGen, then, if every rung of the snap ladder fails,
        TetGen's ``"constrained"`` preset on the first snap-rounded scene (when
        the preset refines), then fTetWild; the reasons go to ``attempts`` and
        ``preset`` says which preset built it. ``"auto"``: build candidate settings
        and keep the one with the fewest tets among those that meet ``accuracy``
        with a weight (:meth:`Tetrahedralization.weight`) near the lowest; ``preset``
        and the TetGen/fTetWild settings are then chosen, not given
        (:func:`tetrace.auto_mesher.auto_tetrahedralize`).
    margin : float
        Domain box margin, a fraction of the scene's bounding-box diagonal
        (TetGen; fTetWild's box is the scene's grown by about one edge length).
    contain : array_like, optional
        ``(N, 3)`` points the domain box must contain.
    minratio : float, optional
        TetGen radius-edge bound (``-q``), overriding the preset's; it turns on
        refinement for ``"constrained"`` too.
    maxvolume : float, optional
        Maximum tet volume (TetGen ``-a``), in scene units cubed; TetGen's mesh
        optimisation after refinement can exceed it slightly.
    sizing : (float, float), optional
        ``(h0, growth)``: TetGen refines until edges near a point at distance d
        from the surface are no longer than about ``h0 * diagonal + growth * d``
        (the preset's, e.g. ``"graded"``, when None). Needs libigl.
    repair : {"auto", True, False}
        ``"auto"``: check the cleaned scene for self-intersections (exactly,
        with libigl/CGAL) and cut them if there are any; if TetGen still fails,
        snap-round and repair again (:data:`SNAP_LADDER`). ``True``: always run
        the cutting step. ``False``: never; a self-intersecting scene raises.
        The check runs before TetGen because TetGen's failure on such input
        can corrupt the process heap. Without libigl nothing is checked and a
        scene TetGen rejects raises.
    epsilon, edge_length : float
        fTetWild's envelope and target edge length, fractions of the scene's
        diagonal.
    timeout : float, optional
        Seconds each stage (a repair, a TetGen attempt, fTetWild) may run; by
        default :func:`default_timeout` of the scene's size. A stage that runs
        longer is stopped and counts as failed.
    ftetwild_optimize : bool
        Run fTetWild's mesh optimisation (edge collapses, swaps, smoothing towards
        better-shaped tets). Off by default: on spot it took 11 s instead of 0.3 s
        and merged surface pieces of different triangles, so that 78% of camera
        rays named Embree's triangle instead of 98%.
    threads : int
        fTetWild threads (0: all cores).
    stop_energy : float
        fTetWild stops optimising when the worst tet's AMIPS energy is below this.
    accuracy : float, optional
        ``mesher="auto"`` only: the fraction of random rays that must agree with
        Embree on the caller's mesh (default 0.999).

    Returns
    -------
    Tetrahedralization

    Raises
    ------
    MeshingError
        The mesh is invalid or empty after cleaning, it self-intersects and
        ``repair`` is False, intersections remain after repair, or the mesher
        fails, crashes or times out; the message names the stage and the cause.

    Notes
    -----
    Refinement stops after a budget of Steiner points (see
    :func:`tetgen_options`), so thin or tiny features cannot blow the mesh up;
    the result is then a valid CT, refined only in part. ``timings["repair"]``
    includes the self-intersection check, which runs even when nothing is cut.
    """
    t_start = time.perf_counter()
    if isinstance(repair, (bool, np.bool_)):
        repair = bool(repair)
    elif repair != "auto":
        raise ValueError(f"repair must be 'auto', True or False, got {repair!r}")
    if mesher not in MESHERS:
        raise ValueError(f"mesher must be one of {MESHERS}, got {mesher!r}")
    if mesher == "auto":
        from .auto_mesher import DEFAULT_ACCURACY, auto_tetrahedralize

        return auto_tetrahedralize(mesh, accuracy=DEFAULT_ACCURACY if accuracy is None else accuracy,
                                   margin=margin, contain=contain, timeout=timeout)
    if accuracy is not None:
        raise ValueError("accuracy is a target for mesher='auto'; the other meshers take settings")
    p = preset_options(preset)
    sizing = _check_sizing(sizing if sizing is not None else p["sizing"])
    for what, value in (("epsilon", epsilon), ("edge_length", edge_length),
                        ("stop_energy", stop_energy)):
        if not (np.isfinite(float(value)) and float(value) > 0):
            raise ValueError(f"{what} must be a positive number, got {value!r}")
    if timeout is not None and not (float(timeout) > 0):
        raise ValueError(f"timeout must be a positive number of seconds, got {timeout!r}")
    name = _mesh_name(mesh)
    vertices, faces = load_triangles(mesh)
    timings = dict(clean=0.0, repair=0.0, tetgen=0.0, ftetwild=0.0, recover=0.0, mesher=0.0,
                   total=0.0)

    t = time.perf_counter()
    cm = clean(vertices, faces)
    timings["clean"] = time.perf_counter() - t
    if len(cm.faces) == 0:
        raise MeshingError(f"{name}: all {len(faces)} triangles are degenerate (zero area); "
                           f"nothing to mesh")
    # Bounds of every vertex a caller triangle uses, degenerate ones included.
    used = vertices[np.unique(faces)]
    box = domain_box(used, margin=margin, contain=contain)
    diagonal = float(np.linalg.norm(used.max(axis=0) - used.min(axis=0))) or 1.0
    options = tetgen_options(preset, minratio=minratio, maxvolume=maxvolume,
                             n_vertices=len(cm.vertices))
    attempts: list[str] = []

    def done(**kw):
        timings["mesher"] = timings["tetgen"] + timings["ftetwild"] + timings["recover"]
        timings["total"] = time.perf_counter() - t_start
        return Tetrahedralization(n_input_triangles=len(faces), timings=timings,
                                  attempts=attempts, **kw)

    if mesher in ("tetgen", "fallback"):
        stage_timeout = timeout if timeout is not None else default_timeout(len(cm.faces), "tetgen")
        try:
            points, tets, cfaces, face_triangle, work, repaired, snap, opts, used = _tetgen_route(
                name, cm, box, options, repair=repair, sizing=sizing, timeout=stage_timeout,
                timings=timings, attempts=attempts, diagonal=diagonal,
                constrained_last=mesher == "fallback")
        except MeshingError as exc:
            if mesher == "tetgen":
                raise
            if str(exc) not in attempts:
                attempts.append(str(exc))
        else:
            return done(points=points, tets=tets, faces=cfaces, face_triangle=face_triangle,
                        domain=box, preset=used or preset, clean=work, repaired=repaired,
                        mesher="tetgen", snap=snap, options=opts)

    stage_timeout = timeout if timeout is not None else default_timeout(len(cm.faces), "ftetwild")
    try:
        points, tets, cfaces, face_triangle, distance, opts = _ftetwild_route(
            name, cm, box, contain=contain, epsilon=float(epsilon),
            edge_length=float(edge_length), threads=int(threads),
            stop_energy=float(stop_energy), optimize=ftetwild_optimize, timeout=stage_timeout,
            timings=timings)
    except MeshingError as exc:
        if mesher == "fallback":
            raise MeshingError(f"no mesher could mesh {name}: TetGen: {'; '.join(attempts)}; "
                               f"then {exc}") from None
        raise
    domain = np.array([points.min(axis=0), points.max(axis=0)])
    return done(points=points, tets=tets, faces=cfaces, face_triangle=face_triangle,
                domain=domain, preset="ftetwild", clean=cm, repaired=False, mesher="ftetwild",
                options=opts, surface_distance=distance)
