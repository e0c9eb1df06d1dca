"""Scoring casts: against the exact referee (:func:`agreement`, what tests assert on), and
one cast against another (:func:`compare`, :func:`same_plane`: only where no exact answer is
expected, e.g. fTetWild's remeshed surface against the input mesh).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..hits import FAILED, HIT

__all__ = ["Agreement", "Score", "agreement", "compare", "edge_distance", "same_plane"]


@dataclasses.dataclass
class Score:
    """How a cast agrees with the exact referee (``docs/referee.md``).

    Attributes
    ----------
    rays : int
        Rays judged (the referee's invalid rays are left out).
    right, failed, leaked, late, wrong : int
        Rays in each judgement of :func:`tetrace.referee.judge` (exactly one per ray).
    phantom, early, other_triangle, t_off : int
        The parts of ``wrong``: a hit where the referee has none; a triangle outside the tie
        set before ``t*``; outside the tie set at ``t*``; the right triangle with ``t`` out of
        the bound.
    max_t_ulps : float
        Largest ``|t - t*|`` in ulps of the cast's ``t`` dtype over rays on a tied triangle.
    ties : int
        Rays whose first hit is tied between several triangles (through an edge or vertex).
    worst : list of int
        Up to ten ray indices that are not right, for debugging.
    """

    rays: int
    right: int
    failed: int
    leaked: int
    late: int
    wrong: int
    phantom: int
    early: int
    other_triangle: int
    t_off: int
    max_t_ulps: float
    ties: int
    worst: list

    @property
    def fraction(self):
        """float : Share of rays the cast answers right."""
        return self.right / self.rays if self.rays else 1.0

    @property
    def bad(self):
        """int : Rays not right."""
        return self.rays - self.right

    def __str__(self):
        return (
            f"{self.right:,}/{self.rays:,} right ({self.fraction * 100:.4f}%): "
            f"{self.failed} failed, {self.leaked} leaked, {self.late} late, {self.wrong} wrong "
            f"({self.phantom} phantom, {self.early} early, {self.other_triangle} other "
            f"triangle at t*, {self.t_off} t off); max |t - t*| {self.max_t_ulps:.3g} ulp; "
            f"{self.ties} rays tied"
        )


def agreement(hits, verdict, arithmetic="f64"):
    """Score a cast against the referee's verdict on the same rays.

    Parameters
    ----------
    hits : Hits
    verdict : tetrace.referee.Verdict
    arithmetic : {"f64", "f32"}
        The precision the caster evaluates ``t`` in (see :func:`tetrace.referee.judge`).

    Returns
    -------
    Score
    """
    from ..referee import judge, out_dtype, ulp

    j = judge(hits, verdict, arithmetic)
    valid = ~j["invalid"]
    on_tie = valid & verdict.in_ties(np.where(np.asarray(hits.status) == HIT, hits.triangle, -1))
    t = np.asarray(hits.t)
    with np.errstate(invalid="ignore", divide="ignore"):
        ulps = np.abs(t[on_tie].astype(np.float64) - verdict.t[on_tie]) / ulp(
            verdict.t[on_tie], out_dtype(hits, arithmetic)
        )
    return Score(
        rays=int(valid.sum()),
        **{
            k: int(j[k].sum())
            for k in (
                "right",
                "failed",
                "leaked",
                "late",
                "wrong",
                "phantom",
                "early",
                "other_triangle",
                "t_off",
            )
        },
        max_t_ulps=float(ulps.max()) if len(ulps) else 0.0,
        ties=int((verdict.ties > 1).sum()),
        worst=np.flatnonzero(valid & ~j["right"])[:10].tolist(),
    )


@dataclasses.dataclass
class Agreement:
    """How two casts of the same rays agree.

    Attributes
    ----------
    rays : int
    agree : int
        Rays with the same hit/miss outcome and the same triangle id.
    failed : int
        Rays the first cast reported FAILED.
    far_from_edges : int
        Disagreements whose nearer hit is farther than ``edge_tol`` from every edge of the
        triangle it hit: disagreements that rounding at shared edges cannot explain.
    coincident : int
        Disagreements where both hit at the same ``t`` and each hit point lies on the other's
        triangle: overlapping coplanar triangles (e.g. a box standing on a floor), where
        either id is right. Not counted in ``far_from_edges``.
    max_dt, p50_dt, p99_dt : float
        ``|t - t_ref|`` over rays that agree on a hit, relative to the scene diagonal.
    dt_over : int
        Rays agreeing on a hit with ``|t - t_ref|`` above ``t_tol`` x diagonal.
    dt_over_unexplained : int
        Of those, rays whose ``t`` is also off from the exact (float64) intersection of the
        ray with the triangle's plane by more than a tenth of that bound. The others are
        the reference's own error: float32 Embree loses digits on grazing rays.
    worst : list of int
        Up to ten ray indices of unexplained disagreements, for debugging.
    """

    rays: int
    agree: int  # same outcome and triangle id
    failed: int
    far_from_edges: int
    max_dt: float
    p50_dt: float
    p99_dt: float
    worst: list
    dt_over: int = 0
    dt_over_unexplained: int = 0
    coincident: int = 0

    @property
    def fraction(self):
        """float : Share of rays that agree, counting hits on coincident triangles as agreeing."""
        return (self.agree + self.coincident) / self.rays if self.rays else 1.0

    @property
    def strict_fraction(self):
        """float : Share of rays with the same outcome and triangle id."""
        return self.agree / self.rays if self.rays else 1.0

    def __str__(self):
        return (
            f"{self.fraction * 100:.4f}% agree ({self.rays - self.agree} differ in id, "
            f"{self.far_from_edges} away from edges, {self.coincident} on coincident triangles, "
            f"{self.failed} failed), "
            f"|dt|/diag max {self.max_dt:.2e} p99 {self.p99_dt:.2e} "
            f"({self.dt_over} over bound, {self.dt_over_unexplained} not the reference's error)"
        )


def edge_distance(vertices, faces, triangle, u, v):
    """Distance from the points with barycentrics (u, v) on the given triangles to their edges.

    Parameters
    ----------
    vertices, faces : numpy.ndarray
        The mesh the triangle ids index.
    triangle : numpy.ndarray
        ``(K,)`` triangle ids.
    u, v : numpy.ndarray
        ``(K,)`` barycentrics (point = (1-u-v) p0 + u p1 + v p2).

    Returns
    -------
    numpy.ndarray
        ``(K,)`` distances to the nearest of the three edges' lines, measured in the plane.
    """
    p = vertices[faces[triangle]].astype(np.float64)
    u = np.asarray(u, np.float64)
    v = np.asarray(v, np.float64)
    w = 1.0 - u - v
    area2 = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    out = np.full(len(triangle), np.inf)
    # The barycentric opposite an edge, times twice the area over that edge's length, is the
    # distance to the edge's line (negative barycentrics: outside, still a distance).
    for bary, (i, j) in ((w, (1, 2)), (u, (2, 0)), (v, (0, 1))):
        length = np.linalg.norm(p[:, j] - p[:, i], axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.abs(bary) * area2 / length
        out = np.minimum(out, np.where(length > 0, d, 0.0))
    return out


def _on_triangle(points, vertices, faces, triangle, tol):
    """Whether each point lies on its triangle, within distance tol."""
    p = vertices[faces[triangle]]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    q = np.asarray(points, np.float64) - p[:, 0]
    n = np.cross(e1, e2)
    nn = np.linalg.norm(n, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        height = np.abs(np.einsum("ij,ij->i", q, n)) / nn
        # barycentrics of the point's projection
        d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
        q1, q2 = (q * e1).sum(1), (q * e2).sum(1)
        den = d11 * d22 - d12 * d12
        u = (d22 * q1 - d12 * q2) / den
        v = (d11 * q2 - d12 * q1) / den
    inside = edge_distance(vertices, faces, triangle, u, v)
    bary_ok = (u >= 0) & (v >= 0) & (u + v <= 1)
    return (height <= tol) & (bary_ok | (inside <= tol))


def _exact_t(origins, directions, vertices, faces, triangle):
    """Float64 ray parameter where each ray meets its triangle's plane."""
    p = vertices[faces[triangle]]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    o = np.asarray(origins, np.float64)
    d = np.asarray(directions, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.einsum("ij,ij->i", p[:, 0] - o, n) / np.einsum("ij,ij->i", d, n)


def compare(
    hits,
    ref,
    vertices,
    faces,
    *,
    edge_tol=1e-5,
    t_tol=1e-5,
    diagonal=None,
    origins=None,
    directions=None,
):
    """Compare a cast against a reference cast of the same rays.

    Parameters
    ----------
    hits, ref : Hits
        The cast under test and the reference (e.g. ``tetrace.baselines.embree.embree_cast``).
    vertices, faces : numpy.ndarray
        The caller's mesh (triangle ids index ``faces``).
    edge_tol : float
        Distance to a triangle edge, as a fraction of the scene diagonal, within which a
        disagreement counts as explained by rounding at a shared edge.
    t_tol : float
        Bound on ``|t - t_ref|`` as a fraction of the diagonal (see ``dt_over``).
    origins, directions : numpy.ndarray, optional
        The rays; when given, ``t`` differences over the bound are checked against the
        exact float64 intersection (``dt_over_unexplained``).
    diagonal : float, optional
        Scene diagonal; defaults to that of ``vertices``' bounding box.

    Returns
    -------
    Agreement
    """
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces)
    if diagonal is None:
        diagonal = float(np.linalg.norm(vertices.max(0) - vertices.min(0)))
    a_hit = hits.status == HIT
    b_hit = ref.status == HIT
    same = (a_hit == b_hit) & (~a_hit | (hits.triangle == ref.triangle))
    differ = np.flatnonzero(~same)
    far = 0
    worst = []
    n_coincident = 0
    if len(differ):
        ta = np.where(a_hit[differ], hits.t[differ].astype(np.float64), np.inf)
        tb = np.where(b_hit[differ], ref.t[differ].astype(np.float64), np.inf)
        use_a = ta <= tb  # the nearer hit is the one whose existence is in question
        tri = np.where(use_a, hits.triangle[differ], ref.triangle[differ])
        u = np.where(use_a, hits.u[differ], ref.u[differ])
        v = np.where(use_a, hits.v[differ], ref.v[differ])
        dist = edge_distance(vertices, faces, tri, u, v) / diagonal
        both_hit = a_hit[differ] & b_hit[differ]
        same_t = both_hit & (np.abs(np.where(both_hit, ta - tb, np.inf)) <= t_tol * diagonal)
        coincident = np.zeros(len(differ), bool)
        if same_t.any():
            k = np.flatnonzero(same_t)
            tol = edge_tol * diagonal
            coincident[k] = _on_triangle(
                ref.point[differ[k]], vertices, faces, hits.triangle[differ[k]], tol
            ) & _on_triangle(hits.point[differ[k]], vertices, faces, ref.triangle[differ[k]], tol)
        # Near an edge explains a disagreement first; coincident triangles only the rest.
        coincident &= dist > edge_tol
        n_coincident = int(coincident.sum())
        bad = differ[(dist > edge_tol) & ~coincident]
        far = len(bad)
        worst = bad[:10].tolist()
    both = a_hit & b_hit & same
    dt = np.abs(hits.t[both].astype(np.float64) - ref.t[both].astype(np.float64)) / diagonal
    over = np.flatnonzero(both)[dt > t_tol]
    unexplained = len(over)
    if len(over) and origins is not None and directions is not None:
        exact = _exact_t(origins[over], directions[over], vertices, faces, hits.triangle[over])
        off = np.abs(hits.t[over].astype(np.float64) - exact) / diagonal
        unexplained = int((~(off <= 0.1 * t_tol)).sum())
    return Agreement(
        rays=len(hits.status),
        agree=int(same.sum()),
        failed=int((hits.status == FAILED).sum()),
        far_from_edges=far,
        max_dt=float(dt.max()) if len(dt) else 0.0,
        p50_dt=float(np.median(dt)) if len(dt) else 0.0,
        p99_dt=float(np.quantile(dt, 0.99)) if len(dt) else 0.0,
        worst=worst,
        dt_over=int(len(over)),
        dt_over_unexplained=unexplained,
        coincident=n_coincident,
    )


def same_plane(hits, ref, vertices, faces, *, plane_tol=1e-5, max_degrees=1.0, diagonal=None):
    """Of the rays where both hit different triangles, how many hit a triangle lying in the
    same plane as the reference's at the reference's hit point (within ``plane_tol`` x
    diagonal, normals within ``max_degrees``): the same place with the same normal."""
    v = np.asarray(vertices, np.float64)
    if diagonal is None:
        diagonal = float(np.linalg.norm(v.max(0) - v.min(0)))
    k = np.flatnonzero((hits.status == HIT) & (ref.status == HIT) & (hits.triangle != ref.triangle))
    if len(k) == 0:
        return 0

    def unit_normals(tri):
        p = v[faces[tri]]
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        return n / np.linalg.norm(n, axis=1, keepdims=True), p[:, 0]

    n_ours, p_ours = unit_normals(hits.triangle[k])
    n_ref, _ = unit_normals(ref.triangle[k])
    cos = np.abs(np.einsum("ij,ij->i", n_ours, n_ref))
    off = np.abs(np.einsum("ij,ij->i", ref.point[k].astype(np.float64) - p_ours, n_ours))
    return int(((off <= plane_tol * diagonal) & (cos >= np.cos(np.radians(max_degrees)))).sum())
