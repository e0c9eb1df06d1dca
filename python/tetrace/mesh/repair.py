"""Repairing self-intersections: exact remeshing (libigl/CGAL), snap rounding, dropping needles."""

from __future__ import annotations

import math

import numpy as np

from ..errors import MeshingError
from .clean import _double_areas, clean
from .types import CleanMesh

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
        v, f, detect_only=True, first_only=bool(first_only)
    )
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
        np.ascontiguousarray(v[used]), np.ascontiguousarray(local.reshape(-1, 3), dtype=np.int64)
    )
    # IM maps every vertex to the representative of its exact position (cut points
    # are created once per triangle pair); J (birth) is the face each piece came from.
    ff = np.asarray(im, dtype=np.int64)[np.asarray(ff, dtype=np.int64)] + len(v)
    ids = np.concatenate(
        [cm.triangle_ids[~cut], cm.triangle_ids[cut][np.asarray(birth, dtype=np.int64)]]
    )
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
        np.ascontiguousarray(cm.vertices),
        np.ascontiguousarray(cm.faces, dtype=np.int64),
        detect_only=True,
    )
    involved = np.unique(np.asarray(pairs, dtype=np.int64))
    if len(involved) == 0:
        return cm, 0
    p = cm.vertices[cm.faces[involved]]
    longest = np.max(
        [np.linalg.norm(p[:, i] - p[:, (i + 1) % 3], axis=1) for i in range(3)], axis=0
    )
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
        raise MeshingError(
            f"{name}: repairing self-intersections needs libigl with CGAL (pip install libigl)"
        )
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
                f"{last} intersecting pairs, more than the {before} of the pass before"
            )
        if len(cm.faces) == 0:
            raise MeshingError(f"{name}: nothing left to mesh after repairing self-intersections")
    return cm, first or 0, count_intersecting_pairs(cm.vertices, cm.faces)


def _repair_left_message(name, snap, left, first):
    passes = _SNAP_REPAIR_PASSES if snap else _REPAIR_PASSES
    how = f"snap-rounded to a {snap:.3g} grid and " if snap else ""
    return (
        f"{name}: the scene still has {left} intersecting triangle pairs after {passes} "
        f"passes of {how}exact repair ({first} pairs cut in the first); rounding the cut "
        f"points to floating point keeps creating new ones, so TetGen cannot mesh it"
    )
