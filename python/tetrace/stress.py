"""Adversarial rays and scenes that are what they say, judged by the exact referee.

Each family is reproducible from a seed and yields a :class:`StressCase`: a scene, rays (with
per-ray ``tmin`` and ``tmax``) and **claims** about each ray: that its first hit is exactly at
a mesh vertex (``zero_signs == 2``), on an edge (1) or inside a face (0), at an exact ``t``;
that it hits or misses; that a named triangle is, or is not, in its tie set; that its line
passes exactly through a given point, or lies exactly in a triangle's plane.

Exactness is built in. Every synthetic scene lies on a grid of small integers scaled by a
power of two (a sphere's vertices rounded to the grid and checked convex in integers, a box,
a height field), placed with an exact offset or power-of-two scaling; rays are built from grid
points by differences and dyadic combinations whose every bit fits float32's 24: the float32
rays are the same numbers as the float64 ones. Real meshes (Spot; fandisk and the bunny from
``$TETRACE_SCENES``) have their vertices rounded to a dyadic grid of 2^-19 of their largest
coordinate for the same reason (rays built from them that still miss a float32 bit do not
certify). The one family whose rays cannot be float32 numbers (``long``: an origin 10^4 sizes
away and a target on the surface) claims only what survives rounding (a hit, on the aimed-at
triangle) and is judged on the float32 rays as passed.

The verdicts are computed once per family and precision when the rays are certified, before
any cast (the referee's hint only speeds its search up; the verdict does not depend on it):
every method, layout and precision is judged against the same verdict. :func:`cast_case`
computes one with the cast's triangles as the hint for a case that has none.

Then every ray is **certified**: the exact referee (:mod:`tetrace.referee`) computes its verdict
in each precision, exact integer arithmetic checks the geometric claims, and only rays whose
claims all hold are kept (:func:`cases`); each case records how many candidates it had and the
certified fraction per precision. Families built exact certify 100% of their candidates
(``tests/test_stability.py`` asserts it); the real meshes keep the rays whose aimed-at point is
the first thing they meet (others are occluded) and report the fraction.

Each ray is judged twice. Per ray, against the referee's verdict (:func:`judge_cast`, after
``docs/referee.md``): ``failed`` (the walk gave up, e.g. its step guard fired on a cycle),
``leaked`` (a miss where the referee hits), ``late`` (a triangle past the first hit), ``wrong``
(anything else: a phantom or early hit, a triangle not in the tie set, ``t`` off its bound). Per
step, by the walk's exact audit (:func:`audited_cast`): every exit face the method took is
checked with exact orientation predicates against the line the robust walk in the same precision
follows (``wrong_exit``), and methods with a fallback report the steps where their own tests
found no exit face (``no_exit``).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import zlib
from fractions import Fraction
from pathlib import Path

import numpy as np

__all__ = ["StressCase", "FAMILIES", "EXACT_FAMILIES", "REAL_FAMILIES", "SHARED_SCENES",
           "CLAIMS", "cases", "make_case", "certify", "check_claims", "exact_through",
           "exact_in_plane", "family_unavailable", "OUTCOMES", "audited_cast", "build_scene",
           "cast_case", "judge_cast", "count", "examples"]

#: The claims a case can make about each ray (arrays of length N; the "unclaimed" value in
#: brackets): ``hit`` int8 (1 hits, 0 misses; [-1]); ``t`` float64 (the exact first-hit
#: parameter; [nan]); ``zs_lo``, ``zs_hi`` int8 (range of the first tie's exact zero side
#: products: 2 at a vertex, 1 on an edge, 0 inside a face; [-1]); ``in_tie`` int64 (a triangle
#: in the tie set; [-1]); ``not_tie`` (N, 2) int64 (triangles not in the tie set, e.g. those
#: whose plane holds the line; [-1]); ``through`` (N, 3) float64 and ``through_t`` float64 (the
#: line passes exactly through this point at this parameter; [nan]); ``plane`` int64 (a
#: triangle whose plane holds the line exactly; [-1]).
CLAIMS = ("hit", "t", "zs_lo", "zs_hi", "in_tie", "not_tie", "through", "through_t", "plane")


@dataclasses.dataclass
class StressCase:
    """A scene, rays to cast into it, and what is claimed of each ray.

    Attributes
    ----------
    family : str
        Family name (see :data:`FAMILIES`).
    vertices, faces : numpy.ndarray
        The scene (float64 vertices; every family's are float32 numbers too).
    origins, directions : numpy.ndarray
        ``(N, 3)`` float64 rays.
    tmin, tmax : numpy.ndarray
        ``(N,)`` float64 bounds of the hit parameter.
    claims : dict
        Per-ray claims (:data:`CLAIMS`).
    kind : numpy.ndarray
        ``(N,)`` str: what each ray is (``vertex``, ``edge``, ``face``, ``random``, ...).
    what : str
        What is exact about the family, in words.
    exact32 : bool
        The rays are float32 numbers: the float32 rays are the same numbers.
    built_exact : bool
        The construction makes every claim true (so 100% of the candidates certify); False
        for real meshes, whose aimed-at points may be hidden.
    contain : bool
        Grow the domain to hold the origins (False: rays enter through the domain box).
    margin : float
        Domain box margin (``Scene.from_mesh``'s, a fraction of the diagonal).
    domain : numpy.ndarray or None
        ``(2, 3)`` the domain box the rays were aimed at (families that aim at it).
    candidates : int
        Rays generated before certification.
    certified : dict
        ``{"f64": fraction, "f32": fraction}`` of the candidates whose claims all hold in each
        precision (set by :func:`certify`).
    verdicts : dict
        ``{"f64": Verdict, "f32": Verdict}`` of the kept rays (set by :func:`certify`).
    """

    family: str
    vertices: np.ndarray
    faces: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    tmin: np.ndarray
    tmax: np.ndarray
    claims: dict
    kind: np.ndarray
    what: str = ""
    exact32: bool = True
    built_exact: bool = True
    contain: bool = True
    margin: float = 0.02
    domain: np.ndarray | None = None
    candidates: int = 0
    certified: dict = dataclasses.field(default_factory=dict)
    verdicts: dict = dataclasses.field(default_factory=dict)

    def __len__(self):
        return len(self.origins)

    def rays(self, precision):
        """``(origins, directions)`` in ``precision`` (``"f32"``: the float64 rays rounded)."""
        dt = np.float32 if precision == "f32" else np.float64
        return self.origins.astype(dt), self.directions.astype(dt)


# --------------------------------------------------------------------------- ray builder

class _Rays:
    """Accumulates rays and their claims, kind by kind."""

    def __init__(self):
        self.parts = []

    def add(self, kind, o, d, *, tmin=0.0, tmax=np.inf, **claims):
        n = len(o)
        c = dict(hit=np.full(n, -1, np.int8), t=np.full(n, np.nan), zs_lo=np.full(n, -1, np.int8),
                 zs_hi=np.full(n, -1, np.int8), in_tie=np.full(n, -1, np.int64),
                 not_tie=np.full((n, 2), -1, np.int64), through=np.full((n, 3), np.nan),
                 through_t=np.full(n, np.nan), plane=np.full(n, -1, np.int64))
        for k, v in claims.items():
            if k == "zs":
                c["zs_lo"][:] = v
                c["zs_hi"][:] = v
                continue
            if k not in c:
                raise KeyError(k)
            v = np.asarray(v)
            if k == "not_tie" and v.ndim == 1:
                v = np.column_stack([v, np.full(n, -1)])
            c[k][:] = v
        self.parts.append(dict(kind=np.full(n, kind), o=np.asarray(o, np.float64),
                               d=np.asarray(d, np.float64),
                               tmin=np.broadcast_to(np.asarray(tmin, np.float64), (n,)),
                               tmax=np.broadcast_to(np.asarray(tmax, np.float64), (n,)), c=c))

    def case(self, family, v, f, what, **kw):
        p = self.parts
        claims = {k: np.concatenate([x["c"][k] for x in p]) for k in CLAIMS}
        o = np.concatenate([x["o"] for x in p])
        return StressCase(family, np.asarray(v, np.float64), np.asarray(f, np.int64), o,
                          np.concatenate([x["d"] for x in p]),
                          np.concatenate([x["tmin"] for x in p]).copy(),
                          np.concatenate([x["tmax"] for x in p]).copy(), claims,
                          np.concatenate([x["kind"] for x in p]), what=what, candidates=len(o),
                          **kw)


def _split(rng, n, k):
    """``n`` split into ``k`` nearly equal random-order parts."""
    sizes = np.full(k, n // k)
    sizes[rng.permutation(k)[:n % k]] += 1
    return sizes


# --------------------------------------------------------------------------- scenes

def _convex_ints(q, f):
    """Whether the integer mesh ``q[f]`` has no zero-area face and no vertex strictly outside
    any face's plane (outward faces): a convex polyhedron, decided exactly in int64."""
    a, b, c = q[f[:, 0]], q[f[:, 1]], q[f[:, 2]]
    n = np.cross(b - a, c - a)
    if (n == 0).all(axis=1).any():
        return False
    for s in range(0, len(f), 256):
        side = np.einsum("fvk,fk->fv", q[None] - a[s:s + 256, None], n[s:s + 256])
        if (side > 0).any():
            return False
    return True


@functools.cache
def _ball_ints(grid_exp, max_sub=3):
    """The unit icosphere on the grid ``2^grid_exp``: integer vertices ``q`` (``q * 2^grid_exp``
    are the points) and faces, of the finest subdivision (at most ``max_sub``) whose rounded
    mesh is still convex with no zero-area face (:func:`_convex_ints`). On the coarsest grids
    this is an icosahedron rounded to (0, +-1, +-1): a cuboctahedron whose square faces are
    pairs of coplanar triangles."""
    import trimesh

    g = 2.0 ** grid_exp
    for sub in range(max_sub, -1, -1):
        s = trimesh.creation.icosphere(subdivisions=sub)
        q = np.round(np.asarray(s.vertices) / g).astype(np.int64)
        f = np.asarray(s.faces, np.int64)
        if np.abs(q).max() < 2 ** 20 and _convex_ints(q, f):
            q.setflags(write=False)
            f.setflags(write=False)
            return q, f
    raise ValueError(f"no convex icosphere on the grid 2^{grid_exp}")


#: The base sphere's grid: 2^-16 (its vertices have at most 17 significant bits).
BALL_GRID = -16


def _ball(grid_exp=BALL_GRID):
    q, f = _ball_ints(grid_exp)
    return q * 2.0 ** grid_exp, f.copy()


def _box():
    import trimesh

    b = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    return np.asarray(b.vertices, np.float64), np.asarray(b.faces, np.int64)


def _edge_neighbours(f):
    """``(F, 3)``: the face across edge ``k`` (from ``f[:, k]`` to ``f[:, k+1]``), -1 if none."""
    nf = len(f)
    a = f.ravel()
    b = np.roll(f, -1, axis=1).ravel()
    key = np.minimum(a, b) * (a.max() + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    out = np.full(3 * nf, -1, np.int64)
    same = np.flatnonzero(ks[1:] == ks[:-1])
    for i in same:  # an edge shared by two faces (more on non-manifold meshes: first pair)
        x, y = order[i], order[i + 1]
        out[x], out[y] = y // 3, x // 3
    return out.reshape(nf, 3)


def _vertex_face(f, nv):
    """For each vertex, one face that holds it."""
    out = np.full(nv, -1, np.int64)
    out[f.ravel()[::-1]] = np.repeat(np.arange(len(f)), 3)[::-1]
    return out


# --------------------------------------------------------------------------- ray kinds

def _interior(rng, n, grid):
    """Origins near the centre of the unit sphere: multiples of ``grid`` within 0.3 of it in
    every axis (strictly inside any convex icosphere on a grid, whose inradius exceeds 0.79)."""
    k = int(np.floor(0.3 / grid))
    return rng.integers(-k, k + 1, (n, 3)) * grid


def _dyadic_dirs(rng, n, bits=10):
    """Nonzero directions with integer components below ``2^bits``, scaled by ``2^-bits``."""
    d = rng.integers(-2 ** bits, 2 ** bits + 1, (n, 3)).astype(np.float64)
    zero = ~d.any(axis=1)
    d[zero, 0] = 1.0
    return d * 2.0 ** -bits


def _edge_points(rng, v, f, n, half=0.5):
    """Points exactly on edges: ``(point, face, edge k, a index, b index, lambda)``, lambda a
    multiple of 1/8 in (0, 1), 1/2 for a fraction ``half`` of them."""
    fi = rng.integers(0, len(f), n)
    k = rng.integers(0, 3, n)
    ia, ib = f[fi, k], f[fi, (k + 1) % 3]
    lam = np.where(rng.random(n) < half, 0.5, rng.integers(1, 8, n) / 8.0)
    a, b = v[ia], v[ib]
    return a + lam[:, None] * (b - a), fi, k, ia, ib, lam


def _face_points(rng, v, f, n, low=1):
    """Points strictly inside faces: barycentric weights ``(i, j, k) / 16``, each >= low."""
    fi = rng.integers(0, len(f), n)
    w = np.empty((n, 3))
    for r in range(n):
        while True:
            i, j = rng.integers(low, 16 - 2 * low + 1, 2)
            if 16 - i - j >= low:
                w[r] = (i, j, 16 - i - j)
                break
    w /= 16.0
    return np.einsum("ij,ijk->ik", w, v[f[fi]]), fi


def _aimed(rays, rng, n, v, f, origins, kinds, *, scale=1.0, offset=0.0, dscale=1.0):
    """From ``origins`` (inside a convex closed mesh) through its vertices, edge points, face
    points, or in random directions: the first hit is exactly the aimed-at point, at t = 1
    (times ``1/dscale``). Points are mapped by ``offset + scale * x`` (exact: scale is a power
    of two per axis and the grid fits the offset) and directions by ``scale * dscale``."""
    vf = _vertex_face(f, len(v))
    sizes = _split(rng, n, len(kinds))
    start = 0
    scale = np.asarray(scale, np.float64)
    for kind, m in zip(kinds, sizes):
        o = origins[start:start + m]
        start += m
        if kind == "vertex":
            vi = rng.integers(0, len(v), m)
            p, claims = v[vi], dict(zs=2, in_tie=vf[vi])
        elif kind == "edge":
            p, fi, *_ = _edge_points(rng, v, f, m)
            claims = dict(zs=1, in_tie=fi)
        elif kind == "face":
            p, fi = _face_points(rng, v, f, m)
            claims = dict(zs=0, in_tie=fi)
        elif kind == "random":
            d = _dyadic_dirs(rng, m)
            rays.add(kind, offset + scale * o, scale * d * dscale, hit=1)
            continue
        else:
            raise ValueError(kind)
        t = 1.0 / dscale
        rays.add(kind, offset + scale * o, scale * (p - o) * dscale, hit=1, t=t,
                 through=offset + scale * p, through_t=t, **claims)


INSIDE_KINDS = ("vertex", "edge", "face", "random")


# --------------------------------------------------------------------------- families

def fam_vertices(rng, n):
    """From inside a convex sphere (a grid icosphere), exactly through its vertices: the first
    hit is the vertex, at t = 1, on every triangle around it."""
    v, f = _ball()
    r = _Rays()
    _aimed(r, rng, n, v, f, _interior(rng, n, 2.0 ** -6), ["vertex"])
    return r.case("vertices", v, f, "through a vertex at t=1 (zero_signs 2), first hit")


def fam_edges(rng, n):
    """From inside a convex sphere, exactly through points of its edges (midpoints and
    multiples of 1/8): first hit on the edge, at t = 1, on both triangles."""
    v, f = _ball()
    r = _Rays()
    _aimed(r, rng, n, v, f, _interior(rng, n, 2.0 ** -6), ["edge"])
    return r.case("edges", v, f, "through an edge point at t=1 (zero_signs 1), first hit")


def fam_along_edges(rng, n):
    """Lines that contain an edge of a convex sphere: from outside beyond one end, the first
    hit is that end vertex (on the triangles around it that do not hold the edge: the edge's
    two triangles hold the line in their planes and are never hit); from a point on the edge,
    the first hit is the end ahead (tmin = 0: the start is on the edge's triangles only, which
    hold the line)."""
    v, f = _ball()
    nb = _edge_neighbours(f)
    r = _Rays()
    m_out, m_on = _split(rng, n, 2)
    for kind, m in (("outside", m_out), ("on_edge", m_on)):
        fi = rng.integers(0, len(f), m)
        k = rng.integers(0, 3, m)
        ia, ib = f[fi, k], f[fi, (k + 1) % 3]
        a, b = v[ia], v[ib]
        not_tie = np.column_stack([fi, nb[fi, k]])
        if kind == "outside":
            s = rng.choice([0.25, 0.5, 1.0, 2.0], m)
            o = a - s[:, None] * (b - a)
            r.add(kind, o, b - a, hit=1, t=s, zs=2, not_tie=not_tie, through=a, through_t=s,
                  plane=fi)
        else:
            lam = rng.integers(1, 8, m) / 8.0
            o = a + lam[:, None] * (b - a)
            back = rng.random(m) < 0.5  # towards a: the end ahead is a, at t = lam
            d = np.where(back[:, None], a - b, b - a)
            t = np.where(back, lam, 1 - lam)
            ahead = np.where(back[:, None], a, b)
            r.add(kind, o, d, hit=1, t=t, zs=2, not_tie=not_tie, through=ahead, through_t=t,
                  plane=fi)
    return r.case("along_edges", v, f, "line contains an edge; first hit at its end vertex "
                  "(zero_signs 2), never on the edge's own triangles")


def _in_plane(rng, v, f, fi, tri_w_low=1):
    """For faces ``fi``: a point ``p`` strictly inside, an in-plane direction ``d`` (integer
    combination of the edge vectors / 4) and ``o = p - 4 d``, outside the triangle."""
    m = len(fi)
    tri = v[f[fi]]
    w = np.empty((m, 3))
    for i in range(m):
        while True:
            x, y = rng.integers(tri_w_low, 16, 2)
            if 16 - x - y >= tri_w_low:
                w[i] = (x, y, 16 - x - y)
                break
    p = np.einsum("ij,ijk->ik", w / 16.0, tri)
    mu = rng.integers(-4, 5, (m, 2))
    zero = ~mu.any(axis=1)
    mu[zero, 0] = 1
    d = (mu[:, :1] * (tri[:, 1] - tri[:, 0]) + mu[:, 1:] * (tri[:, 2] - tri[:, 0])) / 4.0
    return p - 4 * d, d, p


def fam_planes(rng, n):
    """Rays lying exactly in the plane of a face of a convex sphere, from outside the face
    across its interior: never a hit on that face (in-plane); the first hit is where the line
    enters the face, on a neighbour's edge or at a vertex (zero_signs >= 1)."""
    v, f = _ball()
    fi = rng.integers(0, len(f), n)
    o, d, p = _in_plane(rng, v, f, fi)
    r = _Rays()
    r.add("in_plane", o, d, hit=1, zs_lo=1, zs_hi=2, not_tie=np.column_stack([fi, fi]),
          through=p, through_t=4.0, plane=fi)
    return r.case("planes", v, f, "line in a face's plane: that face never hit; first hit on "
                  "the face's border (zero_signs >= 1)")


def fam_grazing(rng, n):
    """Rays lying exactly in the planes of a unit box's faces, from outside across a face:
    never a hit on its two triangles; the first hit is on the border of the face, on a side
    face's edge or corner (zero_signs >= 1)."""
    v, f = _box()
    r = _Rays()
    axis = rng.integers(0, 3, n)
    side = rng.choice([-0.5, 0.5], n)
    p = rng.integers(-7, 8, (n, 3)) / 16.0
    p[np.arange(n), axis] = side
    d = rng.integers(-4, 5, (n, 3)) / 4.0
    d[np.arange(n), axis] = 0.0
    zero = ~d.any(axis=1)
    d[zero, (axis[zero] + 1) % 3] = 0.25
    o = p - 4 * d
    # the two triangles of each face: all three vertices on the face's plane
    tri = v[f]
    face_of = np.full((3, 2, 2), -1, np.int64)
    for a in range(3):
        for si, s in enumerate((-0.5, 0.5)):
            ids = np.flatnonzero((tri[:, :, a] == s).all(axis=1))
            face_of[a, si] = ids
    own = face_of[axis, (side > 0).astype(int)]
    r.add("in_box_plane", o, d, hit=1, zs_lo=1, zs_hi=2, not_tie=own, through=p,
          through_t=4.0, plane=own[:, 0])
    return r.case("grazing", v, f, "line in a box face's plane: its triangles never hit; "
                  "first hit on the face's border (zero_signs >= 1)")


def _surface_points(rng, v, f, n):
    """Points exactly on a convex mesh: a third vertices, a third edge points, a third face
    points; returns ``(kind, points, zero_signs, a face holding each)``."""
    vf = _vertex_face(f, len(v))
    m = _split(rng, n, 3)
    vi = rng.integers(0, len(v), m[0])
    pe, fe, *_ = _edge_points(rng, v, f, m[1])
    pf, ff = _face_points(rng, v, f, m[2])
    kind = np.repeat(["vertex", "edge", "face"], m)
    return (kind, np.concatenate([v[vi], pe, pf]), np.repeat([2, 1, 0], m),
            np.concatenate([vf[vi], fe, ff]))


def fam_on_surface(rng, n):
    """Origins exactly on a convex sphere's vertices, edges and faces, tmin = 0, inwards and
    outwards: the first hit is the origin itself, at t = 0 exactly."""
    v, f = _ball()
    kind, o, zs, fi = _surface_points(rng, v, f, n)
    q = _interior(rng, n, 2.0 ** -6)
    inward = rng.random(n) < 0.5
    d = np.where(inward[:, None], q - o, o - q)
    r = _Rays()
    for k in ("vertex", "edge", "face"):
        s = kind == k
        r.add("on_" + k, o[s], d[s], hit=1, t=0.0, zs=zs[s][0] if s.any() else 0, in_tie=fi[s],
              through=o[s], through_t=0.0)
    return r.case("on_surface", v, f, "origin exactly on a vertex / edge / face, tmin=0: first "
                  "hit at t=0 (zero_signs 2 / 1 / 0)")


def fam_on_surface_tmin(rng, n):
    """Origins exactly on a convex sphere's vertices, edges and faces with tmin > 0 (2^-6,
    2^-20 or 2^-40): inwards the first hit is on the far side (after tmin, not the start's
    triangles); outwards nothing is hit."""
    v, f = _ball()
    kind, o, _, fi = _surface_points(rng, v, f, n)
    q = _interior(rng, n, 2.0 ** -6)
    inward = rng.random(n) < 0.5
    d = np.where(inward[:, None], q - o, o - q)
    tmin = rng.choice([2.0 ** -6, 2.0 ** -20, 2.0 ** -40], n)
    r = _Rays()
    for k in ("vertex", "edge", "face"):
        for into in (True, False):
            s = (kind == k) & (inward == into)
            r.add(("into_" if into else "out_") + k, o[s], d[s], tmin=tmin[s], hit=int(into),
                  not_tie=np.column_stack([fi[s], fi[s]]) if into else -1,
                  through=o[s], through_t=0.0)
    return r.case("on_surface_tmin", v, f, "origin exactly on a vertex / edge / face, tmin>0: "
                  "inwards a hit past the start's triangles, outwards a miss")


def fam_tmin(rng, n):
    """tmin and tmax against an exact crossing at t = 1 (through a vertex, edge or face point
    of a convex sphere from inside): the crossing counts at tmax = 1 and at tmin = 1 (closed
    interval), not at tmax = 1 - 2^-30 or tmin = 1 + 2^-30, and with 0 < tmin < 1 < tmax; and
    from outside, through the sphere to a far vertex with tmin = 3/4, past the near crossing."""
    v, f = _ball()
    vf = _vertex_face(f, len(v))
    r = _Rays()
    m_in, m_out = _split(rng, n, 2) if n > 1 else (n, 0)
    o = _interior(rng, m_in, 2.0 ** -6)
    _, p, zs, fi = _surface_points(rng, v, f, m_in)
    case = rng.integers(0, 5, m_in)
    tmin = np.zeros(m_in)
    tmax = np.full(m_in, np.inf)
    tmax[case == 0] = 1.0
    tmin[case == 1] = 1.0
    tmax[case == 2] = 1.0 - 2.0 ** -30
    tmin[case == 3] = 1.0 + 2.0 ** -30
    tmin[case == 4] = rng.integers(1, 2 ** 10, (case == 4).sum()) * 2.0 ** -10
    tmax[case == 4] = 1.0 + rng.integers(1, 2 ** 10, (case == 4).sum()) * 2.0 ** -8
    names = ["tmax_at", "tmin_at", "tmax_before", "tmin_after", "bracket"]
    for c in range(5):
        s = case == c
        if c in (2, 3):
            r.add(names[c], o[s], p[s] - o[s], tmin=tmin[s], tmax=tmax[s], hit=0,
                  through=p[s], through_t=1.0)
        else:
            r.add(names[c], o[s], p[s] - o[s], tmin=tmin[s], tmax=tmax[s], hit=1, t=1.0,
                  zs_lo=zs[s], zs_hi=zs[s], in_tie=fi[s], through=p[s], through_t=1.0)
    # From 4 radii away, through the sphere to a vertex on the far side: the near crossing
    # is before t = 0.65 (the chord to a vertex within 30 degrees of the far pole is longer
    # than 1.7), so tmin = 3/4 skips it and the far vertex, at t = 1, is the first hit.
    u = rng.standard_normal((m_out, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    o = np.round(u * 4 * 64) / 64
    far = (v / np.linalg.norm(v, axis=1, keepdims=True)) @ (-u.T)  # (V, m)
    cand = far > np.cos(np.radians(30))
    vi = np.argmax(cand * rng.random(cand.shape), axis=0)
    r.add("past_near_side", o, v[vi] - o, tmin=0.75, hit=1, t=1.0, zs=2, in_tie=vf[vi],
          through=v[vi], through_t=1.0)
    return r.case("tmin", v, f, "tmin/tmax exactly at, just before, just after an exact "
                  "crossing at t=1; tmin past a near side")


def _dyadic_margin(vertices, pad):
    """A margin for which ``domain_box`` pads the scene's bounds by exactly ``pad``."""
    from .meshing import domain_box

    v = np.asarray(vertices, np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    m = pad / diag
    for _ in range(64):
        for cand in (m, np.nextafter(m, 0), np.nextafter(m, 1)):
            box = domain_box(v, margin=float(cand))
            if np.array_equal(box, np.array([lo - pad, hi + pad])):
                return float(cand), box
        m = np.nextafter(m, 1)
    raise ValueError("no margin gives that pad exactly")


def fam_domain(rng, n):
    """Rays from outside the domain box (the sphere's bounds plus the margin ``Scene.from_mesh``
    adds; the margin is chosen so that the box is dyadic) through exactly its corners and
    points of its edges: inwards towards the sphere (a hit), along an edge's line, in a
    face's plane, or touching the box only at the corner or edge point (a miss: the scene is
    strictly inside the box)."""
    v, f = _ball()
    margin, box = _dyadic_margin(v, 2.0 ** -4)
    lo, hi = box
    centre = (lo + hi) / 2
    bits = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], bool)
    corners = np.where(bits, hi, lo)
    r = _Rays()
    m = _split(rng, n, 6)

    def inward(p, m_):  # integer direction from p to near the centre, max component 16
        w = centre - p
        w = np.round(16 * w / np.abs(w).max(axis=1, keepdims=True))
        return (w + rng.integers(-2, 3, w.shape)) / 16.0

    # through a corner, inwards (every component points into the box)
    c = corners[rng.integers(0, 8, m[0])]
    d = inward(c, m[0])
    sgn = np.sign(centre - c)
    d = sgn * np.maximum(np.abs(d), 1 / 16.0)
    r.add("corner_in", c - 2 * d, d, hit=1, through=c, through_t=2.0)
    # through a point of an edge, inwards across it
    ci = rng.integers(0, 8, m[1])
    ax = rng.integers(0, 3, m[1])
    c0 = corners[ci]
    c1 = corners[ci ^ (4 >> ax)]
    lam = rng.integers(1, 16, m[1]) / 16.0
    q = c0 + lam[:, None] * (c1 - c0)
    d = inward(q, m[1])
    sgn = np.sign(centre - q)
    keep_axis = np.arange(3)[None] == ax[:, None]
    d = np.where(keep_axis, d, sgn * np.maximum(np.abs(d), 1 / 16.0))
    r.add("edge_in", q - 2 * d, d, hit=1, through=q, through_t=2.0)
    # along the line of an edge, from beyond its end
    ci = rng.integers(0, 8, m[2])
    ax = rng.integers(0, 3, m[2])
    c0, c1 = corners[ci], corners[ci ^ (4 >> ax)]
    s = rng.choice([0.25, 0.5, 1.0], m[2])
    r.add("along_edge", c0 - s[:, None] * (c1 - c0), c1 - c0, hit=0, through=c0,
          through_t=s)
    # in a face's plane, from outside across the face
    ax = rng.integers(0, 3, m[3])
    side = rng.integers(0, 2, m[3])
    p = lo + rng.integers(1, 16, (m[3], 3)) / 16.0 * (hi - lo)
    p[np.arange(m[3]), ax] = np.where(side == 1, hi[ax], lo[ax])
    d = rng.integers(-4, 5, (m[3], 3)) / 4.0
    d[np.arange(m[3]), ax] = 0
    zero = ~d.any(axis=1)
    d[zero, (ax[zero] + 1) % 3] = 0.25
    r.add("face_plane", p - 16 * d, d, hit=0, through=p, through_t=16.0)
    # touching the box at a corner only: inwards along two axes, outwards along the third
    c = corners[rng.integers(0, 8, m[4])]
    d = np.sign(centre - c) * rng.integers(1, 5, (m[4], 3)) / 4.0
    out = rng.integers(0, 3, m[4])
    d[np.arange(m[4]), out] *= -1
    r.add("corner_touch", c - d, d, hit=0, through=c, through_t=1.0)
    # touching the box at a point of an edge only: inwards across one face, outwards the other
    ci = rng.integers(0, 8, m[5])
    ax = rng.integers(0, 3, m[5])
    c0, c1 = corners[ci], corners[ci ^ (4 >> ax)]
    lam = rng.integers(1, 16, m[5]) / 16.0
    q = c0 + lam[:, None] * (c1 - c0)
    d = np.sign(centre - q) * rng.integers(1, 5, (m[5], 3)) / 4.0
    d[np.arange(m[5]), ax] = rng.integers(-4, 5, m[5]) / 4.0
    other = (ax + rng.integers(1, 3, m[5])) % 3
    d[np.arange(m[5]), other] *= -1
    r.add("edge_touch", q - d, d, hit=0, through=q, through_t=1.0)
    return r.case("domain", v, f, "from outside, exactly through the domain box's corners and "
                  "edge points: inwards a hit, along/touching the box a miss", contain=False,
                  margin=margin, domain=box)


def fam_axis(rng, n):
    """Axis-aligned directions and directions with zero components, from points of a 1/16 grid
    inside a unit box whose faces are axis planes: rays run parallel to faces, through the
    box's edges, corners and face diagonals exactly."""
    v, f = _box()
    o = rng.integers(-7, 8, (n, 3)) / 16.0
    d = rng.integers(-1, 2, (n, 3)).astype(np.float64)
    zero = ~d.any(axis=1)
    d[zero, 0] = 1.0
    r = _Rays()
    r.add("axis", o, d, hit=1)
    return r.case("axis", v, f, "grid origins inside a box, directions in {-1,0,1}^3: exact "
                  "crossings of its edges and corners; every ray hits")


def _scaled(name, rng, n, scale, what, kinds=INSIDE_KINDS):
    v, f = _ball()
    r = _Rays()
    _aimed(r, rng, n, v, f, _interior(rng, n, 2.0 ** -6), kinds, scale=scale)
    return r.case(name, v * np.asarray(scale), f, what)


def fam_tiny(rng, n):
    """The convex sphere scaled by 2^-13 (about 1e-4): from inside through vertices, edges,
    faces and in random directions."""
    return _scaled("tiny", rng, n, 2.0 ** -13, "sphere x 2^-13: through vertices/edges/faces "
                   "at t=1, random directions; every ray hits")


def fam_huge(rng, n):
    """The convex sphere scaled by 2^20 (about 1e6)."""
    return _scaled("huge", rng, n, 2.0 ** 20, "sphere x 2^20: through vertices/edges/faces at "
                   "t=1, random directions; every ray hits")


def fam_flat(rng, n):
    """The convex sphere flattened to 2^-13 of its width (TetGen fills it with flat tets and
    slivers): from inside through vertices, edges, faces and in random directions."""
    return _scaled("flat", rng, n, np.array([1.0, 1.0, 2.0 ** -13]), "sphere with z x 2^-13: "
                   "through vertices/edges/faces at t=1, random directions; every ray hits")


def fam_far(rng, n, offset, name):
    """The unit sphere moved to ``offset`` (on every axis), on the float32 grid there: its
    vertices are multiples of float32's spacing at the offset (2^-14 at 1e3, 2^-10 at 1e4,
    2^-7 at 1e5, 1 at 1e7, where the sphere is a cuboctahedron), origins too; from inside
    through vertices, edges and faces (directions are small dyadic numbers, exact) and in
    random directions."""
    c = float(offset)
    grid = max(float(np.spacing(np.float32(c + 2.0))), 2.0 ** BALL_GRID)
    e = int(np.log2(grid))
    v, f = _ball(e)
    r = _Rays()
    _aimed(r, rng, n, v, f, _interior(rng, n, max(grid, 2.0 ** -6)), INSIDE_KINDS,
           offset=np.array([c, c, c]))
    return r.case(name, v + c, f,
                  f"unit sphere at offset {name[3:]} on float32's grid there (2^{e}): through "
                  "vertices/edges/faces at t=1, random directions; every ray hits")


def fam_terrain(rng, n, k=33):
    """A nearly flat open height field (x, y on a 1/32 grid, bumps of a few 2^-20) hit from
    above exactly at its vertices, on its edges and inside its triangles, away from the
    border: the first hit is the aimed-at point, at t = 1."""
    x, y = np.meshgrid(np.arange(k) / (k - 1), np.arange(k) / (k - 1), indexing="ij")
    z = rng.integers(-4, 5, x.shape) * 2.0 ** -20
    v = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    i = np.arange(k * k).reshape(k, k)
    a, b, c, d_ = i[:-1, :-1].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel(), i[:-1, 1:].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d_])])
    inner = np.all((v[f][:, :, :2] > 0) & (v[f][:, :, :2] < 1), axis=(1, 2))
    fin = f[inner]
    ids = np.flatnonzero(inner)
    r = _Rays()
    sizes = _split(rng, n, 3)
    o = np.column_stack([rng.integers(0, 2 ** 10 + 1, (n, 2)) * 2.0 ** -10, np.full(n, 0.25)])
    vf = _vertex_face(fin, len(v))
    inner_v = np.unique(fin)
    inner_v = inner_v[np.all((v[inner_v, :2] > 0) & (v[inner_v, :2] < 1), axis=1)]
    s0, s1 = sizes[0], sizes[0] + sizes[1]
    vi = inner_v[rng.integers(0, len(inner_v), sizes[0])]
    r.add("vertex", o[:s0], v[vi] - o[:s0], hit=1, t=1.0, zs=2, in_tie=ids[vf[vi]],
          through=v[vi], through_t=1.0)
    pe, fe, *_ = _edge_points(rng, v, fin, sizes[1])
    r.add("edge", o[s0:s1], pe - o[s0:s1], hit=1, t=1.0, zs=1, in_tie=ids[fe], through=pe,
          through_t=1.0)
    pf, ff = _face_points(rng, v, fin, sizes[2])
    r.add("face", o[s1:], pf - o[s1:], hit=1, t=1.0, zs=0, in_tie=ids[ff], through=pf,
          through_t=1.0)
    return r.case("terrain", v, f, "height field (bumps 2^-20) from above, exactly at vertices"
                  "/edges/faces at t=1: first hit there")


def fam_long(rng, n, distance=2 ** 13):
    """Rays from ``distance`` (about 1e4) sphere radii away, outside the domain, aimed at points
    well inside faces that face them (weights >= 2/16): they enter through the domain box after
    a very long way and hit the aimed-at face. The float64 rays are exact; the float32 rays are
    them rounded (24 bits cannot hold both the origin and the target): rounding moves the line
    by about 2^-24 x 8192 = 5e-4 at the sphere, far less than the 1/8 of a face (about 0.02)
    between the target and the face's border, so both claim the hit on the aimed-at face."""
    v, f = _ball()
    c = v[f].mean(1)
    u = rng.standard_normal((n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    facing = (c / np.linalg.norm(c, axis=1, keepdims=True)) @ u.T > 0.5
    fi = np.argmax(facing * rng.random(facing.shape), axis=0)
    w = np.empty((n, 3))
    for i in range(n):
        while True:
            a, b = rng.integers(2, 13, 2)
            if 16 - a - b >= 2:
                w[i] = (a, b, 16 - a - b)
                break
    p = np.einsum("ij,ijk->ik", w / 16.0, v[f[fi]])
    o = np.round(u * distance)
    r = _Rays()
    r.add("long", o, p - o, hit=1, in_tie=fi)
    return r.case("long", v, f, "from 2^13 radii away, outside the domain, at a face's "
                  "interior: hit on that face (float32: the rays rounded)", contain=False,
                  exact32=False)


def fam_dirscale(rng, n):
    """From inside the convex sphere through vertices, edges, faces and in random directions,
    directions scaled by 2^-100, 2^-33, 2^33 or 2^100 (exact): t scales inversely."""
    v, f = _ball()
    r = _Rays()
    origins = _interior(rng, n, 2.0 ** -6)
    sizes = _split(rng, n, 4)
    start = 0
    for e, m in zip((-100, -33, 33, 100), sizes):
        sub = _Rays()
        _aimed(sub, rng, m, v, f, origins[start:start + m], INSIDE_KINDS, dscale=2.0 ** e)
        start += m
        for part in sub.parts:
            part["kind"] = np.char.add(part["kind"], f"_2^{e}")
        r.parts += sub.parts
    return r.case("dirscale", v, f, "directions x 2^-100..2^100 through vertices/edges/faces: "
                  "first hit there at t = 2^-e exactly")


# --------------------------------------------------------------------------- real meshes

#: Shared scenes (``$TETRACE_SCENES``) with a family each: fandisk (a CAD part: flat regions
#: of coplanar triangles) and the Stanford bunny.
SHARED_SCENES = {"fandisk": "fandisk.obj", "bunny": "bunny.obj"}

#: Bits kept of a real mesh's coordinates (relative to the largest), so that every ray built
#: from it below is a float32 number: points on edges and faces add 2-3 bits, origins up to
#: twice the mesh's size one more, which leaves a bit of float32's 24 to spare.
REAL_BITS = 19


def _real_mesh(path):
    from .meshing import load_triangles

    v, f = load_triangles(str(path))
    v = np.asarray(v, np.float64)
    e = int(np.ceil(np.log2(np.abs(v).max()))) - REAL_BITS
    return np.round(v / 2.0 ** e) * 2.0 ** e, np.asarray(f, np.int64), e


def _quantized_normals(n):
    q = np.round(8 * n / np.maximum(np.abs(n).max(axis=1, keepdims=True), 1e-300))
    zero = ~q.any(axis=1)
    q[zero, 2] = 1
    return q


def fam_real(rng, n, path, name):
    """A real mesh, its vertices rounded to a dyadic grid (2^-19 of its largest coordinate):
    rays exactly through vertices, edge points and face points from just outside along the
    normal (first hit there at t = 1, where nothing hides it), origins exactly on vertices,
    edges and faces with tmin = 0 (first hit at t = 0) and tmin > 0 going inwards (a hit past
    the start's triangles), and rays in faces' planes (never a hit on that face). Every ray is
    certified by the referee; the kept fraction is reported."""
    import trimesh

    v, f, e = _real_mesh(path)
    mesh = trimesh.Trimesh(v, f, process=False)
    fn = np.nan_to_num(np.asarray(mesh.face_normals))
    area = np.asarray(mesh.area_faces)
    good = np.flatnonzero(area > 0)
    vn = np.zeros_like(v)
    np.add.at(vn, f.ravel(), np.repeat(fn * area[:, None], 3, axis=0))
    used = np.unique(f[good])
    vf = _vertex_face(f[good], len(v))
    diag = float(np.linalg.norm(np.ptp(v, axis=0)))
    h = 2.0 ** np.round(np.log2(diag / 256))  # |offset| = h |n| <= 8 sqrt(3) h ~ diag / 18
    r = _Rays()
    m = _split(rng, n, 7)
    # through a vertex, from outside along its normal
    vi = used[rng.integers(0, len(used), m[0])]
    nv = _quantized_normals(vn[vi]) * h
    r.add("vertex", v[vi] + nv, -nv, hit=1, t=1.0, zs=2, in_tie=good[vf[vi]], through=v[vi],
          through_t=1.0)
    # through an edge point (lambda 1/4, 1/2, 3/4), from outside along the face normal
    fi = good[rng.integers(0, len(good), m[1])]
    k = rng.integers(0, 3, m[1])
    a, b = v[f[fi, k]], v[f[fi, (k + 1) % 3]]
    lam = rng.integers(1, 4, m[1]) / 4.0
    p = a + lam[:, None] * (b - a)
    nf = _quantized_normals(fn[fi]) * h
    r.add("edge", p + nf, -nf, hit=1, t=1.0, zs=1, in_tie=fi, through=p, through_t=1.0)
    # through a face point (weights / 8, each >= 1/8)
    fi = good[rng.integers(0, len(good), m[2])]
    w = np.array([(i, j, 8 - i - j) for i in range(1, 7) for j in range(1, 8 - i)], float) / 8
    w = w[rng.integers(0, len(w), m[2])]
    p = np.einsum("ij,ijk->ik", w, v[f[fi]])
    nf = _quantized_normals(fn[fi]) * h
    r.add("face", p + nf, -nf, hit=1, t=1.0, zs=0, in_tie=fi, through=p, through_t=1.0)
    # origins on the surface, tmin = 0 and tmin > 0, inwards
    for kind, mm, tmin in (("on_surface", m[3], 0.0), ("on_surface_tmin", m[4], 2.0 ** -8)):
        sizes = _split(rng, mm, 3)
        vi = used[rng.integers(0, len(used), sizes[0])]
        fe = good[rng.integers(0, len(good), sizes[1])]
        ke = rng.integers(0, 3, sizes[1])
        ae, be = v[f[fe, ke]], v[f[fe, (ke + 1) % 3]]
        pe = ae + rng.integers(1, 4, sizes[1])[:, None] / 4.0 * (be - ae)
        ff = good[rng.integers(0, len(good), sizes[2])]
        pf = np.einsum("ij,ijk->ik", w[rng.integers(0, len(w), sizes[2])], v[f[ff]])
        for sub, p, nrm, fid, zs in (("vertex", v[vi], vn[vi], good[vf[vi]], 2),
                                     ("edge", pe, fn[fe], fe, 1), ("face", pf, fn[ff], ff, 0)):
            d = -_quantized_normals(nrm) * h
            if tmin == 0:
                r.add(f"{kind}_{sub}", p, d, hit=1, t=0.0, zs=zs, in_tie=fid, through=p,
                      through_t=0.0)
            else:
                r.add(f"{kind}_{sub}", p, d, tmin=tmin, hit=1,
                      not_tie=np.column_stack([fid, fid]), through=p, through_t=0.0)
    # in a face's plane, from outside it across it
    fi = good[rng.integers(0, len(good), m[5] + m[6])]
    o, d, p = _in_plane(rng, v, f, fi)
    r.add("in_plane", o, d, not_tie=np.column_stack([fi, fi]), through=p, through_t=4.0,
          plane=fi)
    return r.case(name, v, f, f"{Path(path).name} on a 2^{e} grid: through vertices/edges/"
                  "faces at t=1, origins on them (tmin 0 and >0), in face planes; certified",
                  built_exact=False)


def fam_spot(rng, n):
    """The bundled scene (Spot): see :func:`fam_real`."""
    from .scene import default_scene_path

    return fam_real(rng, n, default_scene_path(), "spot")


def _shared_path(name):
    env = os.environ.get("TETRACE_SCENES")
    if not env:
        return None, "TETRACE_SCENES is not set"
    path = Path(env).expanduser() / SHARED_SCENES[name]
    if not path.is_file():
        return None, f"{path} not found"
    return path, None


def _fam_shared(name):
    def fam(rng, n, path=None):
        if path is None:
            path, why = _shared_path(name)
            if path is None:
                raise FileNotFoundError(why)
        return fam_real(rng, n, path, name)

    fam.__doc__ = f"The shared scene {SHARED_SCENES[name]} (``$TETRACE_SCENES``): see fam_real."
    return fam


#: Family name -> generator ``(rng, n) -> StressCase`` (uncertified candidates).
FAMILIES = {
    "vertices": fam_vertices,
    "edges": fam_edges,
    "along_edges": fam_along_edges,
    "planes": fam_planes,
    "grazing": fam_grazing,
    "on_surface": fam_on_surface,
    "on_surface_tmin": fam_on_surface_tmin,
    "tmin": fam_tmin,
    "domain": fam_domain,
    "axis": fam_axis,
    "tiny": fam_tiny,
    "huge": fam_huge,
    "flat": fam_flat,
    "terrain": fam_terrain,
    "long": fam_long,
    "dirscale": fam_dirscale,
    "far1e3": lambda rng, n: fam_far(rng, n, 1e3, "far1e3"),
    "far1e4": lambda rng, n: fam_far(rng, n, 1e4, "far1e4"),
    "far1e5": lambda rng, n: fam_far(rng, n, 1e5, "far1e5"),
    "far1e7": lambda rng, n: fam_far(rng, n, 1e7, "far1e7"),
    "spot": fam_spot,
    "fandisk": _fam_shared("fandisk"),
    "bunny": _fam_shared("bunny"),
}

#: Families on real meshes (rays certified and kept; the rest are built exact).
REAL_FAMILIES = ("spot", "fandisk", "bunny")
#: Families whose construction makes every claim true: all candidates certify.
EXACT_FAMILIES = tuple(k for k in FAMILIES if k not in REAL_FAMILIES)


def family_unavailable(name):
    """Why a family cannot be built here (a shared scene not found), or None."""
    if name in SHARED_SCENES:
        return _shared_path(name)[1]
    return None


def _stream(seed, name):
    return np.random.default_rng([seed, zlib.crc32(name.encode())])


def make_case(name, n, seed=0, *, certify_rays=True, **kw):
    """Build family ``name`` with ``n`` candidate rays from its own stream of ``seed`` (the same
    rays whatever other families are built), certified (:func:`certify`) unless asked not to."""
    case = FAMILIES[name](_stream(seed, name), n, **kw)
    case.family = name
    return certify(case) if certify_rays else case


def cases(n_per_family, seed=0, families=None, *, skipped=None):
    """Yield one certified :class:`StressCase` per family (default: every family available).

    Families that cannot be built here (a shared scene not found) are left out; their names
    and the reasons are appended to ``skipped`` when given.
    """
    names = list(FAMILIES) if families is None else list(families)
    for name in names:
        why = family_unavailable(name)
        if why is not None:
            if skipped is not None:
                skipped.append((name, why))
            continue
        yield make_case(name, n_per_family, seed)


# --------------------------------------------------------------------------- certification

def _ints(*arrays):
    """Float64 arrays (same leading length) -> object arrays of Python ints, all scaled by one
    power of two per row (so equalities and signs of homogeneous expressions are exact)."""
    cols = np.concatenate([np.asarray(a, np.float64).reshape(len(a), -1) for a in arrays], 1)
    mant, ex = np.frexp(cols)
    m = (mant * 2.0 ** 53).astype(np.int64)
    ex = ex.astype(np.int64) - 53
    ex = np.where(m == 0, np.iinfo(np.int64).max, ex)
    low = ex.min(axis=1, keepdims=True)
    low = np.where(low == np.iinfo(np.int64).max, 0, low)
    shift = np.where(m == 0, 0, ex - low)
    out = m.astype(object) * (np.ones_like(shift, dtype=object) << shift.astype(object))
    parts, s = [], 0
    for a in arrays:
        w = int(np.prod(np.shape(a)[1:], dtype=np.int64))
        parts.append(out[:, s:s + w])
        s += w
    return parts


def exact_through(o, d, p, t):
    """Whether ``o + t d == p`` exactly, per ray (all float64 numbers, taken exactly)."""
    o, d, p = (np.asarray(x, np.float64) for x in (o, d, p))
    ok = np.zeros(len(o), bool)
    for i in range(len(o)):
        ti = Fraction(float(t[i]))
        ok[i] = all(Fraction(float(o[i, k])) + ti * Fraction(float(d[i, k]))
                    == Fraction(float(p[i, k])) for k in range(3))
    return ok


def exact_in_plane(o, d, tri):
    """Whether the line ``o + t d`` lies exactly in the plane of each triangle ``(N, 3, 3)``:
    ``det(b - a, c - a, o - a) == 0`` and ``det(b - a, c - a, d) == 0`` in exact integers."""
    O, D, A, B, C = _ints(o, d, tri[:, 0], tri[:, 1], tri[:, 2])

    def det(x, y, z):
        return (x[:, 0] * (y[:, 1] * z[:, 2] - y[:, 2] * z[:, 1])
                - x[:, 1] * (y[:, 0] * z[:, 2] - y[:, 2] * z[:, 0])
                + x[:, 2] * (y[:, 0] * z[:, 1] - y[:, 1] * z[:, 0]))

    e1, e2 = B - A, C - A
    return np.array([x == 0 for x in det(e1, e2, O - A)], bool) & \
        np.array([x == 0 for x in det(e1, e2, D)], bool)


def check_claims(case, verdict, precision):
    """Per ray, whether every claim of ``case`` holds for its rays in ``precision`` and their
    exact ``verdict``; returns ``(ok, failures)``, ``failures`` a dict claim -> mask."""
    c = case.claims
    o, d = case.rays(precision)
    o, d = o.astype(np.float64), d.astype(np.float64)
    fail = {}
    h = c["hit"]
    fail["hit"] = (h >= 0) & (verdict.hit != (h == 1))
    tc = ~np.isnan(c["t"])
    with np.errstate(invalid="ignore"):
        fail["t"] = tc & ~(verdict.hit & (verdict.t == c["t"]))
    zc = c["zs_lo"] >= 0
    zs = verdict.zero_signs.astype(np.int16)
    fail["zero_signs"] = zc & ~(verdict.hit & (zs >= c["zs_lo"]) & (zs <= c["zs_hi"]))
    it = c["in_tie"] >= 0
    fail["in_tie"] = it & ~verdict.in_ties(np.where(it, c["in_tie"], -1))
    nt = np.zeros(len(o), bool)
    for col in range(c["not_tie"].shape[1]):
        x = c["not_tie"][:, col]
        nt |= (x >= 0) & verdict.in_ties(np.where(x >= 0, x, -1))
    fail["not_tie"] = nt
    th = ~np.isnan(c["through_t"])
    bad = np.zeros(len(o), bool)
    if th.any():
        idx = np.flatnonzero(th)
        bad[idx] = ~exact_through(o[idx], d[idx], c["through"][idx], c["through_t"][idx])
    fail["through"] = bad
    pl = c["plane"] >= 0
    bad = np.zeros(len(o), bool)
    if pl.any():
        idx = np.flatnonzero(pl)
        tri = case.vertices[case.faces[c["plane"][idx]]]
        bad[idx] = ~exact_in_plane(o[idx], d[idx], tri)
    fail["plane"] = bad
    fail["invalid"] = verdict.invalid
    ok = np.ones(len(o), bool)
    for m in fail.values():
        ok &= ~m
    return ok, fail


def _subset_verdict(ver, keep):
    from .referee import Verdict

    idx = np.flatnonzero(keep)
    counts = np.diff(ver.tie_ptr)[idx]
    ptr = np.zeros(len(idx) + 1, np.int64)
    np.cumsum(counts, out=ptr[1:])
    ids = (np.concatenate([ver.tie_ids[ver.tie_ptr[i]:ver.tie_ptr[i + 1]] for i in idx])
           if len(idx) else np.zeros(0, np.int64))
    return Verdict(hit=ver.hit[idx], t=ver.t[idx], triangle=ver.triangle[idx], tie_ptr=ptr,
                   tie_ids=ids.astype(np.int64), zero_signs=ver.zero_signs[idx],
                   t_bound=ver.t_bound[idx], invalid=ver.invalid[idx],
                   exact_pairs=ver.exact_pairs)


def _take(case, keep):
    case.origins, case.directions = case.origins[keep], case.directions[keep]
    case.tmin, case.tmax, case.kind = case.tmin[keep], case.tmax[keep], case.kind[keep]
    case.claims = {k: v[keep] for k, v in case.claims.items()}


def certify(case, keep_uncertified=False):
    """Compute the referee's verdicts of the case's rays in both precisions, check every claim
    (:func:`check_claims`), record the certified fraction per precision in
    ``case.certified``, keep only the rays certified in both (unless ``keep_uncertified``) and
    store their verdicts in ``case.verdicts``. Returns the case."""
    from .referee import Referee

    def is32(x):
        return x.astype(np.float32).astype(np.float64) == x

    if not is32(case.vertices).all():
        raise AssertionError(f"{case.family}: the vertices are not float32 numbers")
    # Rays of an exact32 family must be float32 numbers: a construction error where the
    # family is built exact; on a real mesh, a ray that does not certify.
    f32ok = np.ones(len(case), bool)
    if case.exact32:
        f32ok = is32(case.origins).all(1) & is32(case.directions).all(1)
        if case.built_exact and not f32ok.all():
            raise AssertionError(f"{case.family}: {int((~f32ok).sum())} rays are not float32 "
                                 "numbers")
    ref = Referee(case.vertices, case.faces)
    verdicts, oks = {}, {}
    n = len(case)
    for p in ("f64", "f32"):
        if p == "f32" and case.exact32:
            verdicts[p] = verdicts["f64"]  # the same numbers: the same verdict
        else:
            o, d = case.rays(p)
            verdicts[p] = ref.first_hits(o, d, case.tmin, case.tmax)
        oks[p] = check_claims(case, verdicts[p], p)[0] & f32ok
    case.candidates = n
    case.certified = {p: float(oks[p].mean()) if n else 1.0 for p in oks}
    keep = oks["f64"] & oks["f32"]
    case.uncertified = int((~keep).sum())
    if keep_uncertified or keep.all():
        case.verdicts = verdicts
        return case
    _take(case, keep)
    case.verdicts = {p: _subset_verdict(v, keep) for p, v in verdicts.items()}
    return case


# --------------------------------------------------------------------------- casting, judging

#: What is counted per family x method x layout x precision (a ray counts in each that holds):
#: ``late``, ``leaked``, ``failed``, ``wrong`` (the referee's judgement: exactly one or none
#: per ray) and the audit's ``wrong_exit`` and ``no_exit``.
OUTCOMES = ("late", "leaked", "failed", "wrong", "wrong_exit", "no_exit")


def build_scene(case, **kw):
    """The :class:`tetrace.Scene` of a stress case (domain grown to its origins if asked)."""
    from .scene import Scene

    contain = np.vstack([case.origins, case.origins + 1e-9]) if case.contain else None
    scene = Scene.from_mesh((case.vertices, case.faces), contain=contain, margin=case.margin,
                            **kw)
    if case.domain is not None and not np.array_equal(scene.domain, case.domain):
        raise AssertionError(f"{case.family}: the scene's domain {scene.domain.tolist()} is not "
                             f"the box the rays aim at {case.domain.tolist()}")
    return scene


def audited_cast(scene, origins, directions, *, tmin=0.0, tmax=np.inf, method=None,
                 layout=None, precision="f64", threads=None, max_steps=None):
    """Cast with the exact per-step audit.

    Returns
    -------
    hits : Hits
    audit : numpy.ndarray
        ``(N, 2)`` uint32 per ray: exit faces taken that the line does not leave by (decided
        with exact orientation predicates on the points the walk read), and steps where the
        method's own tests found no exit face.
    """
    from . import _native
    from .hits import Hits
    from .rays import prepare_bounds

    dt = np.float32 if precision == "f32" else np.float64
    o = np.ascontiguousarray(origins, dtype=dt)
    d = np.ascontiguousarray(directions, dtype=dt)
    n = len(o)
    r = scene._native.cast(o, d, prepare_bounds(tmin, n, "tmin"), prepare_bounds(tmax, n, "tmax"),
                           threads, max_steps, method or _native.DEFAULT_METHOD,
                           layout or _native.DEFAULT_LAYOUT, True)
    audit = r.pop("audit")
    return Hits(**r), audit


def judge_cast(hits, audit, verdict):
    """Masks of :data:`OUTCOMES` (plus ``right`` and the parts of ``wrong``) for a cast,
    against the referee's verdict of the same rays (``tetrace.referee.judge``: tetrace
    evaluates ``t`` in float64 on the caller's triangle in both precisions)."""
    from .referee import judge

    j = judge(hits, verdict)
    j["wrong_exit"] = audit[:, 0] > 0
    j["no_exit"] = audit[:, 1] > 0
    return j


def cast_case(case, scene, method, layout, precision, *, verdict=None, threads=None):
    """Cast a case's rays with the audit and judge them: ``(hits, audit, masks)``.

    The verdict defaults to the one :func:`certify` computed; without one the referee computes
    it with the cast's triangles as the hint (it only speeds the search up)."""
    o, d = case.rays(precision)
    h, audit = audited_cast(scene, o, d, tmin=case.tmin, tmax=case.tmax, method=method,
                            layout=layout, precision=precision, threads=threads)
    if verdict is None:
        verdict = case.verdicts.get(precision)
    if verdict is None:
        from .referee import Referee

        verdict = Referee(case.vertices, case.faces).first_hits(
            o, d, case.tmin, case.tmax, hint=h.triangle)
    return h, audit, judge_cast(h, audit, verdict)


def count(masks):
    """Counts of :data:`OUTCOMES` (and ``rays``, ``right``) from :func:`judge_cast`'s masks."""
    out = {"rays": len(masks["right"]), "right": int(masks["right"].sum())}
    out.update({k: int(masks[k].sum()) for k in OUTCOMES})
    return out


def examples(case, hits, masks, verdict, outcome, k=3):
    """Up to ``k`` rays in ``outcome``, as dicts (kind, origin, direction, tmin, tmax, the cast's
    status/triangle/t and the referee's hit/t/tie set) for reports."""
    out = []
    for i in np.flatnonzero(masks[outcome])[:k]:
        out.append(dict(i=int(i), kind=str(case.kind[i]), o=case.origins[i].tolist(),
                        d=case.directions[i].tolist(), tmin=float(case.tmin[i]),
                        tmax=float(case.tmax[i]), status=int(hits.status[i]),
                        triangle=int(hits.triangle[i]), t=float(hits.t[i]),
                        ref_hit=bool(verdict.hit[i]), ref_t=float(verdict.t[i]),
                        ties=verdict.tie_set(i).tolist()))
    return out
