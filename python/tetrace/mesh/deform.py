"""Where the points of a constrained tetrahedralization go when the caller's vertices move
(Lagae & Dutré 2008: keep the topology, move every vertex, Steiner points included).

The rule (``docs/deformation.md``):

* a point that is one of the caller's vertices (after cleaning: exact duplicates merged)
  goes where that vertex goes;
* a point on the domain box's sides stays;
* a Steiner point on a constrained face follows the caller's triangle it lies on,
  barycentrically; one on an edge that several triangles share follows the edge (the same
  position whichever triangle is asked), so constrained faces stay on the moved triangles up
  to rounding;
* a Steiner point in the volume takes the displacement of the nearest fixed point (in CT
  edges), smoothed by :data:`SMOOTHING_ITERATIONS` Jacobi steps that average its
  neighbours' displacements over CT edges, the other points fixed.

Positions depend only on the rest state (the tetrahedralization as built) and the new
vertices, not on earlier frames. Whether the result is a valid CT is the core's exact check
(:meth:`tetrace._native.NativeScene.update_points`); this module only proposes positions and
says when the CT cannot follow the triangles at all (:attr:`PointMap.reason`).

Only numpy is imported.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .clean import DEGENERATE_WIDTH, _double_areas, _widths

__all__ = ["PointMap", "SMOOTHING_ITERATIONS"]

#: Jacobi steps smoothing the volume Steiner points' displacement.
SMOOTHING_ITERATIONS = 10


def _match_rows(a, b):
    """For each row of ``a``, the index of an equal row of ``b`` (the first), else -1."""
    a = np.ascontiguousarray(a, np.float64) + 0.0
    b = np.ascontiguousarray(b, np.float64) + 0.0
    if len(a) == 0:
        return np.zeros(0, np.int64)
    if len(b) == 0:
        return np.full(len(a), -1, np.int64)
    _, inverse = np.unique(np.concatenate([b, a]), axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    first = np.full(int(inverse.max()) + 1, -1, np.int64)
    first[inverse[: len(b)][::-1]] = np.arange(len(b) - 1, -1, -1)
    return first[inverse[len(b) :]]


def _box_points(points):
    """Points on the sides of the points' bounding box, within the core's snapping tolerance
    (``mesh::build::snap_to_box``)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    tol = 1e-10 * float((hi - lo).max())
    return np.any((np.abs(points - lo) <= tol) | (np.abs(hi - points) <= tol), axis=1)


def _edges(tets, n_points):
    """The CT's edges as CSR adjacency (offsets, neighbours), each edge both ways."""
    t = np.asarray(tets, np.int64)
    pairs = np.concatenate([t[:, [i, j]] for i in range(4) for j in range(i + 1, 4)])
    pairs.sort(axis=1)
    key = np.unique(pairs[:, 0] * n_points + pairs[:, 1])
    a, b = key // n_points, key % n_points
    src = np.concatenate([a, b])
    dst = np.concatenate([b, a])
    order = np.argsort(src, kind="stable")
    offsets = np.zeros(n_points + 1, np.int64)
    np.cumsum(np.bincount(src, minlength=n_points), out=offsets[1:])
    return offsets, dst[order]


def _nearest_fixed(offsets, neighbours, fixed):
    """For each point, a fixed point fewest CT edges away (multi-source breadth-first)."""
    n = len(offsets) - 1
    source = np.full(n, -1, np.int64)
    source[fixed] = np.flatnonzero(fixed)
    frontier = np.flatnonzero(fixed)
    while len(frontier):
        counts = offsets[frontier + 1] - offsets[frontier]
        starts = np.repeat(offsets[frontier], counts)
        within = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
        nbr = neighbours[starts + within]
        src = np.repeat(source[frontier], counts)
        new = source[nbr] < 0
        nbr, src = nbr[new], src[new]
        nbr, first = np.unique(nbr, return_index=True)
        source[nbr] = src[first]
        frontier = nbr
    return source


@dataclasses.dataclass
class PointMap:
    """How the points of one tetrahedralization follow its caller's vertices.

    Build with :meth:`build`; :meth:`points` gives the CT's points for new vertices.

    Attributes
    ----------
    reason : str
        Why the CT cannot follow the triangles in place (every update must re-mesh), or
        ``""`` when it can.
    counts : dict
        Points of each kind: ``input`` (the caller's vertices), ``box``, ``surface``
        (Steiner points on constrained faces), ``volume`` (other Steiner points).
    """

    reason: str
    counts: dict
    rest_points: np.ndarray | None = None
    rest_vertices: np.ndarray | None = None
    input_ct: np.ndarray | None = None
    input_src: np.ndarray | None = None
    used_caller: np.ndarray | None = None
    used_rep: np.ndarray | None = None
    surf_ct: np.ndarray | None = None
    surf_corners: np.ndarray | None = None
    surf_weights: np.ndarray | None = None
    free_ct: np.ndarray | None = None
    free_source: np.ndarray | None = None
    free_rows: tuple | None = None
    dropped: np.ndarray | None = None
    faces: np.ndarray | None = None

    @classmethod
    def build(cls, tet, vertices, faces) -> PointMap:
        """The map of ``tet`` (a :class:`tetrace.mesh.Tetrahedralization`) built from the
        caller's ``vertices`` and ``faces``."""
        counts = dict(input=0, box=0, surface=0, volume=0)
        if getattr(tet, "mesher", "tetgen") != "tetgen":
            return cls(
                f"the surface was remeshed by {tet.mesher}: its points are not the caller's",
                counts,
            )
        if tet.repaired:
            return cls(
                "the scene was repaired (self-intersections cut): the cut points lie on two "
                "triangles that move apart",
                counts,
            )
        if tet.snap:
            return cls("the scene was snap-rounded: its points are not the caller's", counts)
        V = np.ascontiguousarray(vertices, np.float64)
        F = np.asarray(faces, np.int64).reshape(-1, 3)
        P = np.ascontiguousarray(tet.points, np.float64)
        cm = tet.clean
        n = len(P)
        nv = len(cm.vertices)
        # TetGen numbers its input points first, in order; check, else match coordinates.
        if nv <= n and np.array_equal(P[:nv], cm.vertices):
            input_ct = np.arange(nv)
        else:
            input_ct = _match_rows(cm.vertices, P)
            if (input_ct < 0).any():
                return cls(
                    f"{int((input_ct < 0).sum())} cleaned vertices are not points of the "
                    "tetrahedralization",
                    counts,
                )
        # Each used caller vertex names its cleaned vertex (exact duplicates merged).
        used = np.unique(F[cm.triangle_ids].ravel())
        clean_of_used = _match_rows(V[used], cm.vertices)
        if (clean_of_used < 0).any():
            return cls("some caller vertices are not among the cleaned ones", counts)
        clean_of = np.full(len(V), -1, np.int64)
        clean_of[used] = clean_of_used
        input_src = np.full(nv, -1, np.int64)
        input_src[clean_of_used[::-1]] = used[::-1]
        kind = np.full(n, 3, np.int8)  # 0 input, 1 box, 2 surface, 3 volume
        kind[input_ct] = 0
        box = _box_points(P)
        if (box & (kind == 0)).any():
            return cls("a caller vertex lies on the domain box", counts)
        kind[box] = 1
        # Constrained faces: each corner that is an input vertex must be a corner of the
        # caller's triangle the face names (a vertex on another triangle's edge, a
        # T-junction, would move off it).
        cf = np.asarray(tet.faces, np.int64).reshape(-1, 3)
        ft = np.asarray(tet.face_triangle, np.int64)
        corners = clean_of[F[ft]]  # (C, 3) cleaned ids of each face's triangle
        ct_clean = np.full(n, -1, np.int64)
        ct_clean[input_ct] = np.arange(nv)
        for k in range(3):
            c = ct_clean[cf[:, k]]
            bad = (c >= 0) & ~(corners == c[:, None]).any(axis=1)
            if bad.any():
                return cls(
                    f"{int(bad.sum())} constrained faces have a caller vertex that is not a "
                    "corner of their triangle (T-junctions)",
                    counts,
                )
        # Steiner points on constrained faces: their triangles (hosts).
        on_face = cf.ravel()
        host = np.repeat(ft, 3)
        steiner = kind[on_face] == 3
        on_face, host = on_face[steiner], host[steiner]
        key = np.unique(on_face * (len(F) + 1) + host)
        pt, tri = key // (len(F) + 1), key % (len(F) + 1)
        surf_ct, first, n_hosts = np.unique(pt, return_index=True, return_counts=True)
        kind[surf_ct] = 2
        surf_corners = F[tri[first]].copy()  # caller vertex ids
        a, b, c = (V[surf_corners[:, k]] for k in range(3))
        p = P[surf_ct]
        # Least-squares barycentrics on the host triangle (the point may be an ulp off it).
        e1, e2, r = b - a, c - a, p - a
        d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
        r1, r2 = (r * e1).sum(1), (r * e2).sum(1)
        det = d11 * d22 - d12 * d12
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (d22 * r1 - d12 * r2) / det
            v = (d11 * r2 - d12 * r1) / det
        weights = np.stack([1 - u - v, u, v], axis=1)
        # Shared by several triangles: on the edge they share, follow that edge.
        for j in np.flatnonzero(n_hosts > 1):
            hosts = tri[first[j] : first[j] + n_hosts[j]]
            common = set(clean_of[F[hosts[0]]].tolist())
            for h in hosts[1:]:
                common &= set(clean_of[F[h]].tolist())
            if len(common) == 3:
                continue  # the same three corners (duplicates): any one will do
            if len(common) != 2:
                return cls(
                    f"a Steiner point lies on {len(hosts)} triangles that share no edge",
                    counts,
                )
            ea, eb = sorted(common)
            va, vb = input_src[ea], input_src[eb]
            d = V[vb] - V[va]
            s = float(np.dot(P[surf_ct[j]] - V[va], d) / np.dot(d, d))
            surf_corners[j] = [va, vb, va]
            weights[j] = [1 - s, s, 0.0]
        if not np.isfinite(weights).all():
            return cls("a Steiner point lies on a degenerate triangle", counts)
        # Volume Steiner points: the nearest fixed point's displacement, smoothed.
        free = kind == 3
        offsets, neighbours = _edges(tet.tets, n)
        free_ct = np.flatnonzero(free)
        free_source = _nearest_fixed(offsets, neighbours, ~free)[free_ct]
        counts_f = offsets[free_ct + 1] - offsets[free_ct]
        starts = np.repeat(offsets[free_ct], counts_f)
        within = np.arange(int(counts_f.sum())) - np.repeat(
            np.cumsum(counts_f) - counts_f, counts_f
        )
        rows = (np.repeat(np.arange(len(free_ct)), counts_f), neighbours[starts + within], counts_f)
        # Caller triangles the cleaning dropped as degenerate (not as duplicates): a rebuild
        # would keep one that the move makes non-degenerate.
        kept = np.zeros(len(F), bool)
        kept[cm.triangle_ids] = True
        key_kept = {tuple(sorted(t)) for t in clean_of[F[kept]].tolist()}
        dropped = np.array(
            [
                i
                for i in np.flatnonzero(~kept).tolist()
                if (clean_of[F[i]] < 0).any() or tuple(sorted(clean_of[F[i]])) not in key_kept
            ],
            np.int64,
        )
        counts = dict(
            input=int((kind == 0).sum()),
            box=int((kind == 1).sum()),
            surface=int((kind == 2).sum()),
            volume=int((kind == 3).sum()),
        )
        return cls(
            "",
            counts,
            rest_points=P,
            rest_vertices=V.copy(),
            input_ct=input_ct,
            input_src=input_src,
            used_caller=used,
            used_rep=input_src[clean_of_used],
            surf_ct=surf_ct,
            surf_corners=surf_corners,
            surf_weights=weights,
            free_ct=free_ct,
            free_source=free_source,
            free_rows=rows,
            dropped=dropped,
            faces=F,
        )

    def check(self, vertices) -> str:
        """Why ``vertices`` cannot move the CT in place (``""``: they can): caller vertices
        the cleaning merged that move apart, or a dropped degenerate triangle that becomes a
        triangle a rebuild would keep."""
        V = vertices
        apart = (V[self.used_caller] != V[self.used_rep]).any(axis=1)
        if apart.any():
            return f"{int(apart.sum())} caller vertices that were one point (merged) move apart"
        if len(self.dropped):
            F = self.faces
            kept = np.ones(len(F), bool)
            kept[self.dropped] = False
            area = _double_areas(V, F[self.dropped])
            width = _widths(V, F[self.dropped])[0]
            largest = float(_double_areas(V, F[kept]).max()) if kept.any() else 0.0
            # clean()'s test, with its default area_eps.
            grows = (width > DEGENERATE_WIDTH) & (area > 1e-14 * largest) & (area > 0)
            if grows.any():
                return (
                    f"{int(grows.sum())} degenerate triangles (dropped at build) are not "
                    "degenerate any more"
                )
        return ""

    def points(self, vertices, iterations=SMOOTHING_ITERATIONS):
        """The CT's points, in the tetrahedralization's order, for caller ``vertices``."""
        V = vertices
        P = self.rest_points.copy()
        P[self.input_ct] = V[self.input_src]
        w, c = self.surf_weights, self.surf_corners
        P[self.surf_ct] = w[:, 0:1] * V[c[:, 0]] + w[:, 1:2] * V[c[:, 1]] + w[:, 2:3] * V[c[:, 2]]
        if len(self.free_ct):
            D = P - self.rest_points
            D[self.free_ct] = D[self.free_source]
            row, nbr, count = self.free_rows
            nf = len(self.free_ct)
            for _ in range(iterations):
                s = np.stack(
                    [np.bincount(row, weights=D[nbr, a], minlength=nf) for a in range(3)],
                    axis=1,
                )
                D[self.free_ct] = s / count[:, None]
            P[self.free_ct] = self.rest_points[self.free_ct] + D[self.free_ct]
        return P
