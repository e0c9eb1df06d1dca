"""Triangle scene -> constrained tetrahedralization (CT), the input of the ray caster.

The pipeline is pure Python around TetGen (the ``tetgen`` wrapper) and, for
self-intersecting scenes, libigl's exact CGAL remeshing:

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
5. TetGen runs in a forked child process on Linux (:data:`ISOLATE_TETGEN`), so
   that a crash on near-degenerate input becomes a :class:`MeshingError`.

Only numpy is imported at module level; trimesh, tetgen and igl are imported
when needed, so this module loads without the compiled extension.
"""

from __future__ import annotations

import dataclasses
import os
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
    "load_triangles",
    "clean",
    "domain_box",
    "tetrahedralize",
    "tetgen_options",
    "count_intersecting_pairs",
]


class MeshingError(ValueError):
    """A scene cannot be loaded or tetrahedralized; the message names the cause."""


class MeshFileNotFoundError(MeshingError, FileNotFoundError):
    """The mesh file does not exist (both a :class:`MeshingError` and a ``FileNotFoundError``)."""


# Options every preset shares. brio_hilbert: TetGen inserts points in a BRIO/Hilbert
# order, which is what keeps its Delaunay phase fast; quiet/nowarning: TetGen prints
# to the C stdout, which Python cannot capture.
_COMMON = dict(plc=True, brio_hilbert=True, quiet=True, nowarning=True, verbose=0)

#: TetGen keyword arguments of each preset (passed to ``tetgen.TetGen.tetrahedralize``).
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
#:
#: :func:`tetrahedralize` adds a Steiner-point budget (``steinerleft``, see
#: :func:`tetgen_options`).
PRESETS: dict[str, dict] = {
    "constrained": dict(_COMMON, quality=False),
    "quality": dict(_COMMON, quality=True, minratio=5.0, mindihedral=0.0),
}

#: The preset :func:`tetrahedralize` uses when none is given.
DEFAULT_PRESET = "quality"

# Steiner-point budget of a refinement (TetGen -S): max(MIN, PER_VERTEX * scene
# vertices). Radius-edge refinement grades the mesh down to the smallest feature,
# so a thin plate or a light 0.1 under a 550-unit ceiling would otherwise take
# hundreds of thousands of points; the real scenes measured need 0.4-1.3 per vertex.
_STEINER_MIN = 10_000
_STEINER_PER_VERTEX = 2
# Radius-edge bound used when only maxvolume asks for refinement: loose enough
# that no tet is split for its shape.
_LOOSE_RATIO = 1e6


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
        TetGen gives them.
    faces : numpy.ndarray
        ``(C, 3)`` uint32, C-contiguous: the constrained faces, pieces of scene
        triangles (box faces are not included).
    face_triangle : numpy.ndarray
        ``(C,)`` uint32: the caller's triangle id each constrained face lies on.
    domain : numpy.ndarray
        ``(2, 3)`` float64: lower and upper corner of the domain box.
    preset : str
        The preset used.
    n_input_triangles : int
        Number of triangles the caller gave.
    clean : CleanMesh
        The scene mesh TetGen was given (after a repair: the repaired pieces,
        cleaned, with ``triangle_ids`` still naming the caller's triangles and
        the drop counts of both cleaning passes).
    repaired : bool
        Whether self-intersections were resolved before meshing.
    timings : dict
        Seconds spent in ``clean``, ``repair`` (the self-intersection check and
        any cutting), ``tetgen`` and ``total`` (loading included).
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

    def __repr__(self):
        return (f"Tetrahedralization({len(self.tets)} tets, {len(self.points)} points, "
                f"{len(self.faces)} constrained faces, preset={self.preset!r}, "
                f"repaired={self.repaired})")


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

# Passes of exact remeshing: rounding the exact cut points to doubles can leave
# (rarely) new tiny intersections, which another pass cuts.
_REPAIR_PASSES = 3


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


def _remesh(cm: CleanMesh, area_eps: float) -> tuple[CleanMesh, int]:
    """One pass of exact remeshing along the self-intersections; returns the cleaned result
    (triangle ids still the caller's) and the number of intersecting pairs cut."""
    cgal = _igl_cgal()
    v = np.ascontiguousarray(cm.vertices, dtype=np.float64)
    f = np.ascontiguousarray(cm.faces, dtype=np.int64)
    vv, ff, pairs, birth, im = cgal.remesh_self_intersections(v, f)
    # IM maps every vertex to the representative of its exact position (cut points
    # are created once per triangle pair); J (birth) is the face each piece came from.
    ff = np.asarray(im, dtype=np.int64)[np.asarray(ff, dtype=np.int64)]
    ids = cm.triangle_ids[np.asarray(birth, dtype=np.int64)]
    # Pieces in caller order, so where triangles overlap the lowest caller id keeps the piece.
    order = np.argsort(ids, kind="stable")
    ff, ids = ff[order], ids[order]
    # Rounding exact cut points to doubles can merge points and flatten slivers;
    # coplanar overlaps leave the same piece from both triangles (the first is kept).
    again = clean(vv, ff, area_eps=area_eps)
    return CleanMesh(
        vertices=again.vertices,
        faces=again.faces,
        triangle_ids=ids[again.triangle_ids],
        dropped_degenerate=cm.dropped_degenerate + again.dropped_degenerate,
        dropped_duplicate=cm.dropped_duplicate + again.dropped_duplicate,
    ), int(len(pairs))


def _repair(cm: CleanMesh, name: str, area_eps: float) -> tuple[CleanMesh, int]:
    """Remesh until no intersection is left; return the mesh and the pairs cut in the first pass."""
    if _igl_cgal() is None:
        raise MeshingError(f"{name}: repairing self-intersections needs libigl with CGAL "
                           f"(pip install libigl)")
    first = None
    for _ in range(_REPAIR_PASSES):
        cm, n = _remesh(cm, area_eps)
        first = n if first is None else first
        if len(cm.faces) == 0:
            raise MeshingError(f"{name}: nothing left to mesh after repairing self-intersections")
        if count_intersecting_pairs(cm.vertices, cm.faces, first_only=True) == 0:
            return cm, first
    left = count_intersecting_pairs(cm.vertices, cm.faces)
    raise MeshingError(
        f"{name}: the scene still has {left} intersecting triangle pairs after "
        f"{_REPAIR_PASSES} passes of exact repair ({first} pairs cut in the first); rounding "
        f"the cut points to floating point keeps creating new ones, so TetGen cannot mesh it")


# --------------------------------------------------------------------------- TetGen


class _TetGenFailed(Exception):
    """TetGen gave no mesh; ``str`` is its reason."""


class _TetGenCrashed(Exception):
    """The process running TetGen died; ``str`` says how."""


class _TetGenTimeout(_TetGenCrashed):
    """TetGen ran past :data:`TETGEN_TIMEOUT` and was stopped."""


#: Run TetGen in a forked child process (Linux only). TetGen can segfault on
#: near-degenerate input, and its error path (a C++ exception thrown from deep
#: inside) can corrupt the heap of the process it runs in; in a child, either
#: becomes a :class:`MeshingError` and the caller's process is unharmed. It costs a
#: fork and a copy of the result (milliseconds). Set ``TETRACE_TETGEN_ISOLATE=0``
#: (or assign False here) to run TetGen in-process.
ISOLATE_TETGEN = (sys.platform.startswith("linux") and hasattr(os, "fork")
                  and os.environ.get("TETRACE_TETGEN_ISOLATE", "1").strip().lower()
                  not in ("0", "false", "no", "off"))

#: Seconds TetGen may run (in the forked child) before it is stopped and
#: :func:`tetrahedralize` raises; None (the default) waits for ever. Set from
#: ``TETRACE_TETGEN_TIMEOUT``. On near-degenerate input (a repaired scene whose cut
#: pieces have edges far below TetGen's tolerance) TetGen can stall in boundary
#: recovery for tens of minutes.
TETGEN_TIMEOUT = float(os.environ["TETRACE_TETGEN_TIMEOUT"]) if os.environ.get(
    "TETRACE_TETGEN_TIMEOUT", "").strip() else None


def _tetgen_arrays(points_in, faces_in, markers, options):
    """Run TetGen; return ``(points, tets, scene_faces, scene_markers)``."""
    import tetgen

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
    scene = marks > 0
    return (np.ascontiguousarray(nodes, dtype=np.float64),
            np.ascontiguousarray(elems, dtype=np.uint32),
            np.ascontiguousarray(np.asarray(tg.trifaces).reshape(-1, 3)[scene], dtype=np.uint32),
            marks[scene].astype(np.int64))


def _call_forked(fn, *args, timeout=None):
    """Return ``fn(*args)`` computed in a forked child.

    Re-raises the child's :class:`_TetGenFailed`; raises :class:`_TetGenCrashed`
    when the child dies without answering or runs past ``timeout`` seconds.
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
    with tempfile.TemporaryDirectory(prefix="tetrace-tetgen-") as workdir:
        read_fd, write_fd = os.pipe()
        with warnings.catch_warnings():
            # Python >= 3.12 warns on fork in a threaded process; the child only runs
            # TetGen and numpy and never touches locks other threads may hold.
            warnings.simplefilter("ignore", DeprecationWarning)
            pid = os.fork()
        if pid == 0:  # child: never return into the caller's code
            try:
                os.close(read_fd)
                _child_setup(parent, workdir)
                try:
                    result = ("ok", fn(*args))
                except _TetGenFailed as exc:
                    result = ("failed", str(exc))
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
                        raise _TetGenTimeout(f"stopped after {timeout:g} s, TETGEN_TIMEOUT")
                    if not select.select([read_fd], [], [], left)[0]:
                        continue
                chunk = os.read(read_fd, 1 << 22)
                if not chunk:
                    break
                chunks.append(chunk)
        except BaseException:  # timeout or KeyboardInterrupt: stop the child too
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            raise
        finally:
            os.close(read_fd)
        _, status = os.waitpid(pid, 0)
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
        raise _TetGenCrashed(how)
    kind, payload = pickle.loads(data)
    if kind == "failed":
        raise _TetGenFailed(payload)
    if kind == "error":
        raise _TetGenFailed(f"error in the TetGen process: {payload}")
    return payload


def _child_setup(parent, workdir):
    """Prepare a forked TetGen child: quiet on crashes, bound to its parent's life."""
    # A crash is reported by the parent; no traceback dump from the child.
    import faulthandler

    faulthandler.disable()
    os.chdir(workdir)
    # Die with the parent (PR_SET_PDEATHSIG = 1), so a killed caller leaves no
    # TetGen running on; if it already died, stop now.
    try:
        import ctypes
        import signal

        ctypes.CDLL(None).prctl(1, int(signal.SIGKILL))
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(1)


def _run_tetgen(cm: CleanMesh, box: np.ndarray, options: dict, isolate=None):
    """Tetrahedralize scene + box; return ``(points, tets, faces, face_triangle)``."""
    import tetgen  # noqa: F401  (imported here so a forked child finds it loaded)

    corners, box_faces = _box_mesh(box)
    nv = len(cm.vertices)
    points_in = np.vstack([cm.vertices, corners])
    faces_in = np.vstack([cm.faces, box_faces + nv])
    if len(points_in) >= 2**31 or len(faces_in) >= 2**31 - 1:
        raise MeshingError(f"scene too large for TetGen: {len(points_in)} points, "
                           f"{len(faces_in)} faces")
    # Marker id + 1 for scene face id (0 is TetGen's "no marker"), -1 for the box.
    markers = np.concatenate([np.arange(1, len(cm.faces) + 1), np.full(len(box_faces), -1)])
    args = (points_in, faces_in.astype(np.int32), markers.astype(np.int32), options)
    if ISOLATE_TETGEN if isolate is None else isolate:
        points, tets, faces, marks = _call_forked(_tetgen_arrays, *args, timeout=TETGEN_TIMEOUT)
    else:
        points, tets, faces, marks = _tetgen_arrays(*args)
    face_triangle = np.ascontiguousarray(cm.triangle_ids[marks - 1], dtype=np.uint32)
    return points, tets, faces, face_triangle


def tetgen_options(preset=DEFAULT_PRESET, *, minratio=None, maxvolume=None, n_vertices=0) -> dict:
    """Return the keyword arguments :func:`tetrahedralize` passes to TetGen.

    Parameters
    ----------
    preset : {"quality", "constrained"}
        A key of :data:`PRESETS`.
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
        the points boundary recovery cannot do without are added.
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose one of {sorted(PRESETS)}")
    options = dict(PRESETS[preset])
    if minratio is not None:
        minratio = float(minratio)
        if not (np.isfinite(minratio) and minratio > 1.0):
            raise ValueError(f"minratio (TetGen radius-edge bound) must be > 1.0, got {minratio!r}")
        options.update(quality=True, minratio=minratio)
    if maxvolume is not None:
        maxvolume = float(maxvolume)
        if not (np.isfinite(maxvolume) and maxvolume > 0):
            raise ValueError(f"maxvolume must be a positive number, got {maxvolume!r}")
        options.update(fixedvolume=True, maxvolume=maxvolume)
        if not options.get("quality"):
            # TetGen enforces -a only while refining; a bound this loose splits
            # tets for their volume alone.
            options.update(quality=True, minratio=_LOOSE_RATIO)
    if options.get("quality"):
        options["steinerleft"] = max(_STEINER_MIN, _STEINER_PER_VERTEX * int(n_vertices))
    else:
        # Only the Steiner points boundary recovery cannot do without: no budget.
        options["steinerleft"] = -1
    return options


def tetrahedralize(mesh, preset=DEFAULT_PRESET, *, margin=0.02, contain=None, minratio=None,
                   maxvolume=None, repair="auto") -> Tetrahedralization:
    """Build a constrained tetrahedralization of a triangle scene inside a box.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or os.PathLike or tuple
        Anything :func:`load_triangles` takes. Open, non-manifold and
        multi-component scenes are fine; self-intersecting ones are repaired
        (see ``repair``).
    preset : {"quality", "constrained"}
        A key of :data:`PRESETS`.
    margin : float
        Domain box margin, a fraction of the scene's bounding-box diagonal.
    contain : array_like, optional
        ``(N, 3)`` points the domain box must contain.
    minratio : float, optional
        TetGen radius-edge bound (``-q``), overriding the preset's; it turns on
        refinement for ``"constrained"`` too.
    maxvolume : float, optional
        Maximum tet volume (TetGen ``-a``), in scene units cubed; TetGen's mesh
        optimisation after refinement can exceed it slightly.
    repair : {"auto", True, False}
        ``"auto"``: check the cleaned scene for self-intersections (exactly,
        with libigl/CGAL) and cut them if there are any. ``True``: always run
        the cutting step. ``False``: never; a self-intersecting scene raises.
        The check runs before TetGen because TetGen's failure on such input
        can corrupt the process heap. Without libigl nothing is checked and a
        scene TetGen rejects raises.

    Returns
    -------
    Tetrahedralization

    Raises
    ------
    MeshingError
        The mesh is invalid or empty after cleaning, it self-intersects and
        ``repair`` is False, intersections remain after repair, or TetGen fails;
        the message names the cause.

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
    name = _mesh_name(mesh)
    vertices, faces = load_triangles(mesh)
    timings = dict(clean=0.0, repair=0.0, tetgen=0.0, total=0.0)

    t = time.perf_counter()
    cm = clean(vertices, faces)
    timings["clean"] = time.perf_counter() - t
    if len(cm.faces) == 0:
        raise MeshingError(f"{name}: all {len(faces)} triangles are degenerate (zero area); "
                           f"nothing to mesh")
    # Bounds of every vertex a caller triangle uses, degenerate ones included.
    box = domain_box(vertices[np.unique(faces)], margin=margin, contain=contain)
    options = tetgen_options(preset, minratio=minratio, maxvolume=maxvolume,
                             n_vertices=len(cm.vertices))

    t = time.perf_counter()
    repaired, n_cut = False, 0
    have_igl = _igl_cgal() is not None
    if repair is True or (repair == "auto" and have_igl
                          and count_intersecting_pairs(cm.vertices, cm.faces, first_only=True)):
        cm, n_cut = _repair(cm, name, 1e-14)
        repaired = True
    elif repair is False and have_igl:
        n = count_intersecting_pairs(cm.vertices, cm.faces)
        if n:
            raise MeshingError(f"{name} is not a valid PLC: {n} pairs of triangles intersect "
                               f"(cross, overlap or touch away from shared edges), which TetGen "
                               f"cannot mesh; pass repair='auto' or repair=True to cut them")
    timings["repair"] = time.perf_counter() - t

    t = time.perf_counter()
    try:
        points, tets, cfaces, face_triangle = _run_tetgen(cm, box, options)
    except (_TetGenFailed, _TetGenCrashed) as exc:
        what = ("failed" if isinstance(exc, _TetGenFailed)
                else "timed out" if isinstance(exc, _TetGenTimeout) else "crashed")
        if repaired:
            why = (f"after exact repair of {n_cut} intersecting triangle pairs; the cut pieces "
                   "likely have features below TetGen's tolerance (nearly overlapping edges, "
                   "vertices very close to edges)")
        elif have_igl:
            why = ("the scene has no self-intersections, so TetGen rejected something else "
                   "(e.g. features below its tolerance)")
        else:
            why = ("self-intersections were not checked: install libigl (pip install libigl) "
                   "to check and repair them")
        raise MeshingError(f"TetGen {what} ({exc}) on {name}: {why}") from None
    timings["tetgen"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t_start
    return Tetrahedralization(
        points=points, tets=tets, faces=cfaces, face_triangle=face_triangle,
        domain=box, preset=preset, n_input_triangles=len(faces), clean=cm,
        repaired=repaired, timings=timings,
    )
