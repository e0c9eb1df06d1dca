"""Inside/outside of open surfaces: the edge census that decides whether a mesh is closed, and
the generalized winding number (Jacobson, Kavan & Sorkine-Hornung 2013) that
:meth:`tetrace.Scene.contains` uses when it is not.

Both work on the caller's mesh as the scene's cleaning leaves it
(:func:`tetrace.mesh.clean`): exactly coincident vertices merged, zero-area and duplicate
triangles dropped. That is the surface the tetrahedralization constrains, so the census
describes the surface whose crossings :meth:`~tetrace.Scene.contains` counts in parity mode.

How exact the winding number is (measured on the Stanford bunny, a scan with holes, 69,451
triangles): libigl's fast winding number (Barill et al. 2018: Barnes-Hut over a BVH, far
clusters replaced by a 2nd-order Taylor expansion; the Python binding's triangle overload takes
no accuracy parameter and uses libigl's default) was off from the exact sum by at most 0.0044
over 10^4 points in the bounding box and 8 x 10^4 points within 10^-6 to 10^-2 of the
diagonal from the surface. So each point gets the fast value first, and points whose fast value
lies within :data:`RECHECK` (0.05, eleven times that error) of 1/2 get the exact one: the
direct sum of every triangle's solid angle (:func:`solid_angle_sum`) for up to
:data:`DIRECT_MAX` points, else ``igl.winding_number``, Jacobson et al.'s hierarchical sum,
which replaces a far subtree by a cap of its boundary (the same value in exact arithmetic).
Either's only error is floating-point rounding (they agreed to 3e-16 on the bunny). The inside
test (winding number >= 1/2) then answers as the exact sum would unless the fast error exceeds
0.05 somewhere: no bound proves it cannot, but none was seen.

Why not the exact sum everywhere: on the bunny (2 cores), 20,000 points took 2.1 s exact
(``igl.winding_number``: ~0.6 s to build its hierarchy, then ~0.1 ms a point) against 0.28 s
fast (~0.15 s of tree building per call); with the recheck, 7 of them were near 1/2 and
``Scene.contains`` took 0.34 to 0.37 s (a machine shared with other jobs: +-30%).
``python -m tetrace.bench.occupancy`` measures these and trimesh's and Open3D's answers on the
same points (docs/queries.md).
"""

from __future__ import annotations

import dataclasses

import numpy as np

#: Points whose fast winding number is within this of 1/2 are evaluated exactly: 11x the
#: largest fast-method error measured on the bunny (0.0044).
RECHECK = 0.05
#: Up to this many such points are summed directly, triangle by triangle (about 20 ms a point
#: on the bunny); more pay for libigl's hierarchy instead (about 0.6 s to build there, as
#: much as 30 direct sums).
DIRECT_MAX = 16
#: Triangles per numpy pass of the direct sum (bounds its temporaries to a few MB).
_CHUNK = 1 << 15


@dataclasses.dataclass(frozen=True)
class Surface:
    """The caller's mesh as cleaned, with its edge census.

    Attributes
    ----------
    vertices, faces : numpy.ndarray
        ``(V, 3)`` float64 and ``(F, 3)`` int64: exactly coincident vertices merged,
        zero-area and duplicate triangles (the same three vertices, either orientation) dropped,
        as :func:`tetrace.mesh.clean` does before meshing.
    edges : int
        Distinct edges (unordered vertex pairs).
    odd : int
        Edges shared by an odd number of triangles: 1 (a boundary edge, e.g. of a hole) or
        3, 5, ... Parity of crossings is a convention, not the inside, where there is one.
    non_manifold : int
        Edges shared by more than two triangles.
    misoriented : int
        Edges shared by exactly two triangles that run along it the same way (their normals
        disagree about which side is out).
    kept : numpy.ndarray
        ``(F,)`` bool over the caller's triangles: the ones cleaning keeps (``faces``' rows),
        the triangles whose crossings the parity counts.
    """

    vertices: np.ndarray
    faces: np.ndarray
    edges: int
    odd: int
    non_manifold: int
    misoriented: int
    kept: np.ndarray

    @property
    def closed(self) -> bool:
        """Every edge shared by an even number of triangles: the surface bounds a region
        (mod 2), so the parity of crossings along any path is exact. Two triangles per edge
        on a manifold surface; 4, 6, ... where closed pieces touch along an edge. Orientation
        is not part of it: parity does not use it (the winding number does)."""
        return self.odd == 0

    def describe(self) -> str:
        """E.g. ``"6 of 104,176 edges are shared by an odd number of triangles ..."``."""
        return (
            f"{self.odd:,} of {self.edges:,} edges are shared by an odd number of triangles "
            f"(boundary edges: holes), {self.non_manifold:,} by more than two, "
            f"{self.misoriented:,} by two triangles of disagreeing orientation"
        )


def surface(vertices, faces) -> Surface:
    """Clean ``(vertices, faces)`` as the scene does and count its edges (see :class:`Surface`).

    Parameters
    ----------
    vertices : array_like
        ``(V, 3)`` coordinates.
    faces : array_like
        ``(F, 3)`` integer vertex indices.

    Returns
    -------
    Surface
    """
    from .mesh.clean import clean

    cm = clean(vertices, faces)
    kept = np.zeros(len(np.asarray(faces).reshape(-1, 3)), dtype=bool)
    kept[np.asarray(cm.triangle_ids, np.int64)] = True
    f = np.asarray(cm.faces, np.int64).reshape(-1, 3)
    n = max(len(cm.vertices), 1)
    a = f.ravel()
    b = f[:, [1, 2, 0]].ravel()
    # Each triangle's three edges as directed pairs; an edge's key is its unordered pair, and
    # the direction says which way this triangle runs along it.
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * n + hi
    forward = a < b
    order = np.argsort(key, kind="stable")
    key, forward = key[order], forward[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if len(key) else np.zeros(0, int)
    count = np.diff(np.r_[starts, len(key)])
    n_forward = np.add.reduceat(forward.astype(np.int64), starts) if len(key) else count
    return Surface(
        vertices=np.ascontiguousarray(cm.vertices, dtype=np.float64),
        faces=np.ascontiguousarray(f),
        edges=len(count),
        odd=int(np.count_nonzero(count % 2 == 1)),
        non_manifold=int(np.count_nonzero(count > 2)),
        misoriented=int(np.count_nonzero((count == 2) & (n_forward != 1))),
        kept=kept,
    )


def winding_numbers(vertices, faces, points) -> np.ndarray:
    """The generalized winding number of each point: fast, and exact near 1/2.

    Parameters
    ----------
    vertices : array_like
        ``(V, 3)`` float64 coordinates.
    faces : array_like
        ``(F, 3)`` integer indices, oriented (a closed outward surface gives 1 inside).
    points : array_like
        ``(N, 3)`` float64 query points.

    Returns
    -------
    numpy.ndarray
        ``(N,)`` float64: libigl's fast winding number, replaced by the exact hierarchical sum
        (``igl.winding_number``) where it lies within :data:`RECHECK` of 1/2 (see the module
        docstring for the error).
    """
    import igl

    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    q = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    if len(q) == 0 or len(f) == 0:
        return np.zeros(len(q))
    w = np.array(igl.fast_winding_number(v, f, q), dtype=np.float64)
    near = np.flatnonzero(~(np.abs(w - 0.5) >= RECHECK))  # NaN counts as near
    if 0 < len(near) <= DIRECT_MAX:
        w[near] = solid_angle_sum(v, f, q[near])
    elif len(near):
        w[near] = igl.winding_number(v, f, np.ascontiguousarray(q[near]))
    return w


def solid_angle_sum(vertices, faces, points) -> np.ndarray:
    """The winding number by the direct sum of solid angles over every triangle.

    Each triangle's signed solid angle is ``2 atan2(a . (b x c), |a||b||c| + (a . b)|c| +
    (b . c)|a| + (c . a)|b|)`` with ``a, b, c`` its corners relative to the point (Van
    Oosterom & Strackee 1983), the formula libigl's exact evaluation uses; the winding
    number is their sum over 4 pi. O(triangles) per point.

    Parameters
    ----------
    vertices : array_like
        ``(V, 3)`` float64.
    faces : array_like
        ``(F, 3)`` integer indices.
    points : array_like
        ``(N, 3)`` float64.

    Returns
    -------
    numpy.ndarray
        ``(N,)`` float64.
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    q = np.asarray(points, np.float64).reshape(-1, 3)
    total = np.zeros(len(q))
    for start in range(0, len(f), _CHUNK):
        corners = v[f[start : start + _CHUNK]]  # (k, 3, 3)
        for i, p in enumerate(q):
            a, b, c = (corners[:, j] - p for j in range(3))
            la, lb, lc = (np.sqrt(np.einsum("ij,ij->i", x, x)) for x in (a, b, c))
            det = np.einsum("ij,ij->i", a, np.cross(b, c))
            den = (
                la * lb * lc
                + np.einsum("ij,ij->i", a, b) * lc
                + np.einsum("ij,ij->i", b, c) * la
                + np.einsum("ij,ij->i", c, a) * lb
            )
            total[i] += 2.0 * np.arctan2(det, den).sum()
    return total / (4.0 * np.pi)
