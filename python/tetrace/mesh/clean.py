"""Cleaning the caller's triangles (exact duplicates merged, zero-area dropped) and the box
domain around them."""

from __future__ import annotations

import numpy as np

from ..errors import MeshingError
from .types import CleanMesh

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


#: A triangle whose width (its height over its longest edge) is at most this fraction of
#: that edge has collinear vertices up to rounding: zero area, a degenerate triangle,
#: whatever the other triangles' sizes. (The cross product of two edges is exact to a few
#: ulps; no triangle of the shared scenes comes within 1e6 of this.)
DEGENERATE_WIDTH = 1e-12

#: A triangle narrower than this fraction of its longest edge is a *needle*: TetGen takes
#: one for a self-intersection ("The input surface mesh contain self-intersections"), as
#: measured on a lone needle of width 1e-6; failure messages name such triangles.
NEEDLE_WIDTH = 1e-5


def _widths(vertices, faces):
    """Return each triangle's width (twice its area over its longest edge squared) and
    its longest edge; a triangle whose longest edge is 0 has width 0."""
    p = vertices[faces]
    edges = [p[:, (i + 1) % 3] - p[:, i] for i in range(3)]
    longest = np.max([np.linalg.norm(e, axis=1) for e in edges], axis=0)
    double_area = np.linalg.norm(np.cross(edges[0], -edges[2]), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        width = np.where(longest > 0, double_area / longest**2, 0.0)
    return width, longest


def describe_degenerate(vertices, faces, ids=None, *, caller_ids=None, limit=3) -> str:
    """Name the degenerate triangles among ``faces`` and why each is degenerate.

    Parameters
    ----------
    vertices, faces : numpy.ndarray
        The caller's mesh (or a cleaned one, with ``ids`` the caller's triangle ids).
    ids : array_like, optional
        Which triangles to describe (rows of ``faces``); default all.
    caller_ids : array_like, optional
        The caller's triangle id of each row of ``faces`` (a :class:`CleanMesh`'s
        ``triangle_ids``), named instead of the row.
    limit : int
        Name at most this many; the rest are counted.

    Returns
    -------
    str
        E.g. ``"triangle 4 (its vertices 2 and 7 are the same point); triangle 9 (its
        three vertices are collinear: width 1.2e-17 of its length)"``.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces).reshape(-1, 3)
    ids = np.arange(len(f)) if ids is None else np.asarray(ids).reshape(-1)
    parts = []
    for i in ids[:limit]:
        a, b, c = (int(k) for k in f[i])
        label = int(i) if caller_ids is None else int(caller_ids[i])
        p = v[[a, b, c]] + 0.0
        same = [(x, y) for x, y in ((a, b), (b, c), (a, c)) if np.array_equal(v[x], v[y])]
        if same:
            x, y = same[0]
            what = "a vertex twice" if x == y else f"vertices {x} and {y} at the same point"
            parts.append(f"triangle {label} (it has {what})")
            continue
        width, _ = _widths(p, np.array([[0, 1, 2]]))
        parts.append(
            f"triangle {label} (a needle: its three distinct vertices are collinear or "
            f"nearly, width {float(width[0]):.2g} of its longest edge)"
        )
    if len(ids) > limit:
        parts.append(f"and {len(ids) - limit} more")
    return "; ".join(parts)


def needles(cm: CleanMesh) -> np.ndarray:
    """Rows of ``cm.faces`` narrower than :data:`NEEDLE_WIDTH` of their longest edge."""
    if len(cm.faces) == 0:
        return np.zeros(0, np.int64)
    return np.flatnonzero(_widths(cm.vertices, cm.faces)[0] < NEEDLE_WIDTH)


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
        zero-area and are dropped, and so do triangles whose three vertices are
        collinear up to rounding (width at most :data:`DEGENERATE_WIDTH` of the
        longest edge), however large the others are.

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

    # Degenerate: a repeated index, collinear vertices (up to rounding, in the triangle's
    # own scale), or an area negligible next to the largest triangle.
    distinct = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    area = _double_areas(merged, f) if n_faces else np.zeros(0)
    width = _widths(merged, f)[0] if n_faces else np.zeros(0)
    distinct &= width > DEGENERATE_WIDTH
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
    faces = np.array(
        [
            [1, 3, 0],
            [4, 1, 0],
            [0, 3, 2],
            [2, 4, 0],
            [1, 7, 3],
            [5, 1, 4],
            [5, 7, 1],
            [3, 7, 2],
            [6, 4, 2],
            [2, 7, 6],
            [6, 5, 4],
            [7, 5, 6],
        ],
        dtype=np.int64,
    )
    return corners, faces
