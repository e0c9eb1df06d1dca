"""The synthetic stress families: rays through vertices, along edges, in planes, grazing, on the
surface, at tmin, from the domain, axis-parallel, tiny/huge/far/flat, terrain, long, scaled.

Over 500 lines on purpose: one function per synthetic family, each beside the claims it
makes; splitting them would scatter families that share the ray kinds of scenes.py. The
families on closed meshes added for the exact default (scan, boxes, icosphere, parallel) are in
closed.py.
"""

import numpy as np

from .case import _Rays, _split
from .scenes import (
    BALL_GRID,
    INSIDE_KINDS,
    _aimed,
    _ball,
    _box,
    _edge_neighbours,
    _edge_points,
    _face_points,
    _interior,
    _vertex_face,
)

# --------------------------------------------------------------------------- families


def fam_vertices(rng, n):
    """From inside a convex sphere (a grid icosphere), exactly through its vertices: the first
    hit is the vertex, at t = 1, on every triangle around it."""
    v, f = _ball()
    r = _Rays()
    _aimed(r, rng, n, v, f, _interior(rng, n, 2.0**-6), ["vertex"])
    return r.case("vertices", v, f, "through a vertex at t=1 (zero_signs 2), first hit")


def fam_edges(rng, n):
    """From inside a convex sphere, exactly through points of its edges (midpoints and
    multiples of 1/8): first hit on the edge, at t = 1, on both triangles."""
    v, f = _ball()
    r = _Rays()
    _aimed(r, rng, n, v, f, _interior(rng, n, 2.0**-6), ["edge"])
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
            r.add(
                kind, o, b - a, hit=1, t=s, zs=2, not_tie=not_tie, through=a, through_t=s, plane=fi
            )
        else:
            lam = rng.integers(1, 8, m) / 8.0
            o = a + lam[:, None] * (b - a)
            back = rng.random(m) < 0.5  # towards a: the end ahead is a, at t = lam
            d = np.where(back[:, None], a - b, b - a)
            t = np.where(back, lam, 1 - lam)
            ahead = np.where(back[:, None], a, b)
            r.add(
                kind, o, d, hit=1, t=t, zs=2, not_tie=not_tie, through=ahead, through_t=t, plane=fi
            )
    return r.case(
        "along_edges",
        v,
        f,
        "line contains an edge; first hit at its end vertex "
        "(zero_signs 2), never on the edge's own triangles",
    )


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
    r.add(
        "in_plane",
        o,
        d,
        hit=1,
        zs_lo=1,
        zs_hi=2,
        not_tie=np.column_stack([fi, fi]),
        through=p,
        through_t=4.0,
        plane=fi,
    )
    return r.case(
        "planes",
        v,
        f,
        "line in a face's plane: that face never hit; first hit on "
        "the face's border (zero_signs >= 1)",
    )


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
    r.add(
        "in_box_plane",
        o,
        d,
        hit=1,
        zs_lo=1,
        zs_hi=2,
        not_tie=own,
        through=p,
        through_t=4.0,
        plane=own[:, 0],
    )
    return r.case(
        "grazing",
        v,
        f,
        "line in a box face's plane: its triangles never hit; "
        "first hit on the face's border (zero_signs >= 1)",
    )


def _surface_points(rng, v, f, n):
    """Points exactly on a convex mesh: a third vertices, a third edge points, a third face
    points; returns ``(kind, points, zero_signs, a face holding each)``."""
    vf = _vertex_face(f, len(v))
    m = _split(rng, n, 3)
    vi = rng.integers(0, len(v), m[0])
    pe, fe, *_ = _edge_points(rng, v, f, m[1])
    pf, ff = _face_points(rng, v, f, m[2])
    kind = np.repeat(["vertex", "edge", "face"], m)
    return (
        kind,
        np.concatenate([v[vi], pe, pf]),
        np.repeat([2, 1, 0], m),
        np.concatenate([vf[vi], fe, ff]),
    )


def fam_on_surface(rng, n):
    """Origins exactly on a convex sphere's vertices, edges and faces, tmin = 0, inwards and
    outwards: the first hit is the origin itself, at t = 0 exactly."""
    v, f = _ball()
    kind, o, zs, fi = _surface_points(rng, v, f, n)
    q = _interior(rng, n, 2.0**-6)
    inward = rng.random(n) < 0.5
    d = np.where(inward[:, None], q - o, o - q)
    r = _Rays()
    for k in ("vertex", "edge", "face"):
        s = kind == k
        r.add(
            "on_" + k,
            o[s],
            d[s],
            hit=1,
            t=0.0,
            zs=zs[s][0] if s.any() else 0,
            in_tie=fi[s],
            through=o[s],
            through_t=0.0,
        )
    return r.case(
        "on_surface",
        v,
        f,
        "origin exactly on a vertex / edge / face, tmin=0: first hit at t=0 (zero_signs 2 / 1 / 0)",
    )


def fam_on_surface_tmin(rng, n):
    """Origins exactly on a convex sphere's vertices, edges and faces with tmin > 0 (2^-6,
    2^-20 or 2^-40): inwards the first hit is on the far side (after tmin, not the start's
    triangles); outwards nothing is hit."""
    v, f = _ball()
    kind, o, _, fi = _surface_points(rng, v, f, n)
    q = _interior(rng, n, 2.0**-6)
    inward = rng.random(n) < 0.5
    d = np.where(inward[:, None], q - o, o - q)
    tmin = rng.choice([2.0**-6, 2.0**-20, 2.0**-40], n)
    r = _Rays()
    for k in ("vertex", "edge", "face"):
        for into in (True, False):
            s = (kind == k) & (inward == into)
            r.add(
                ("into_" if into else "out_") + k,
                o[s],
                d[s],
                tmin=tmin[s],
                hit=int(into),
                not_tie=np.column_stack([fi[s], fi[s]]) if into else -1,
                through=o[s],
                through_t=0.0,
            )
    return r.case(
        "on_surface_tmin",
        v,
        f,
        "origin exactly on a vertex / edge / face, tmin>0: "
        "inwards a hit past the start's triangles, outwards a miss",
    )


def fam_tmin(rng, n):
    """tmin and tmax against an exact crossing at t = 1 (through a vertex, edge or face point
    of a convex sphere from inside): the crossing counts at tmax = 1 and at tmin = 1 (closed
    interval), not at tmax = 1 - 2^-30 or tmin = 1 + 2^-30, and with 0 < tmin < 1 < tmax; and
    from outside, through the sphere to a far vertex with tmin = 3/4, past the near crossing."""
    v, f = _ball()
    vf = _vertex_face(f, len(v))
    r = _Rays()
    m_in, m_out = _split(rng, n, 2) if n > 1 else (n, 0)
    o = _interior(rng, m_in, 2.0**-6)
    _, p, zs, fi = _surface_points(rng, v, f, m_in)
    case = rng.integers(0, 5, m_in)
    tmin = np.zeros(m_in)
    tmax = np.full(m_in, np.inf)
    tmax[case == 0] = 1.0
    tmin[case == 1] = 1.0
    tmax[case == 2] = 1.0 - 2.0**-30
    tmin[case == 3] = 1.0 + 2.0**-30
    tmin[case == 4] = rng.integers(1, 2**10, (case == 4).sum()) * 2.0**-10
    tmax[case == 4] = 1.0 + rng.integers(1, 2**10, (case == 4).sum()) * 2.0**-8
    names = ["tmax_at", "tmin_at", "tmax_before", "tmin_after", "bracket"]
    for c in range(5):
        s = case == c
        if c in (2, 3):
            r.add(
                names[c],
                o[s],
                p[s] - o[s],
                tmin=tmin[s],
                tmax=tmax[s],
                hit=0,
                through=p[s],
                through_t=1.0,
            )
        else:
            r.add(
                names[c],
                o[s],
                p[s] - o[s],
                tmin=tmin[s],
                tmax=tmax[s],
                hit=1,
                t=1.0,
                zs_lo=zs[s],
                zs_hi=zs[s],
                in_tie=fi[s],
                through=p[s],
                through_t=1.0,
            )
    # From 4 radii away, through the sphere to a vertex on the far side: the near crossing
    # is before t = 0.65 (the chord to a vertex within 30 degrees of the far pole is longer
    # than 1.7), so tmin = 3/4 skips it and the far vertex, at t = 1, is the first hit.
    u = rng.standard_normal((m_out, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    o = np.round(u * 4 * 64) / 64
    far = (v / np.linalg.norm(v, axis=1, keepdims=True)) @ (-u.T)  # (V, m)
    cand = far > np.cos(np.radians(30))
    vi = np.argmax(cand * rng.random(cand.shape), axis=0)
    r.add(
        "past_near_side",
        o,
        v[vi] - o,
        tmin=0.75,
        hit=1,
        t=1.0,
        zs=2,
        in_tie=vf[vi],
        through=v[vi],
        through_t=1.0,
    )
    return r.case(
        "tmin",
        v,
        f,
        "tmin/tmax exactly at, just before, just after an exact "
        "crossing at t=1; tmin past a near side",
    )


def _dyadic_margin(vertices, pad):
    """A margin for which ``domain_box`` pads the scene's bounds by exactly ``pad``."""
    from ...mesh import domain_box

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
    margin, box = _dyadic_margin(v, 2.0**-4)
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
    r.add("along_edge", c0 - s[:, None] * (c1 - c0), c1 - c0, hit=0, through=c0, through_t=s)
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
    return r.case(
        "domain",
        v,
        f,
        "from outside, exactly through the domain box's corners and "
        "edge points: inwards a hit, along/touching the box a miss",
        contain=False,
        margin=margin,
        domain=box,
    )


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
    return r.case(
        "axis",
        v,
        f,
        "grid origins inside a box, directions in {-1,0,1}^3: exact "
        "crossings of its edges and corners; every ray hits",
    )


def _scaled(name, rng, n, scale, what, kinds=INSIDE_KINDS):
    v, f = _ball()
    r = _Rays()
    _aimed(r, rng, n, v, f, _interior(rng, n, 2.0**-6), kinds, scale=scale)
    return r.case(name, v * np.asarray(scale), f, what)


def fam_tiny(rng, n):
    """The convex sphere scaled by 2^-13 (about 1e-4): from inside through vertices, edges,
    faces and in random directions."""
    return _scaled(
        "tiny",
        rng,
        n,
        2.0**-13,
        "sphere x 2^-13: through vertices/edges/faces at t=1, random directions; every ray hits",
    )


def fam_huge(rng, n):
    """The convex sphere scaled by 2^20 (about 1e6)."""
    return _scaled(
        "huge",
        rng,
        n,
        2.0**20,
        "sphere x 2^20: through vertices/edges/faces at t=1, random directions; every ray hits",
    )


def fam_flat(rng, n):
    """The convex sphere flattened to 2^-13 of its width (TetGen fills it with flat tets and
    slivers): from inside through vertices, edges, faces and in random directions."""
    return _scaled(
        "flat",
        rng,
        n,
        np.array([1.0, 1.0, 2.0**-13]),
        "sphere with z x 2^-13: "
        "through vertices/edges/faces at t=1, random directions; every ray hits",
    )


def fam_far(rng, n, offset, name):
    """The unit sphere moved to ``offset`` (on every axis), on the float32 grid there: its
    vertices are multiples of float32's spacing at the offset (2^-14 at 1e3, 2^-10 at 1e4,
    2^-7 at 1e5, 1 at 1e7, where the sphere is a cuboctahedron), origins too; from inside
    through vertices, edges and faces (directions are small dyadic numbers, exact) and in
    random directions."""
    c = float(offset)
    grid = max(float(np.spacing(np.float32(c + 2.0))), 2.0**BALL_GRID)
    e = int(np.log2(grid))
    v, f = _ball(e)
    r = _Rays()
    _aimed(
        r,
        rng,
        n,
        v,
        f,
        _interior(rng, n, max(grid, 2.0**-6)),
        INSIDE_KINDS,
        offset=np.array([c, c, c]),
    )
    return r.case(
        name,
        v + c,
        f,
        f"unit sphere at offset {name[3:]} on float32's grid there (2^{e}): through "
        "vertices/edges/faces at t=1, random directions; every ray hits",
    )


def fam_terrain(rng, n, k=33):
    """A nearly flat open height field (x, y on a 1/32 grid, bumps of a few 2^-20) hit from
    above exactly at its vertices, on its edges and inside its triangles, away from the
    border: the first hit is the aimed-at point, at t = 1."""
    x, y = np.meshgrid(np.arange(k) / (k - 1), np.arange(k) / (k - 1), indexing="ij")
    z = rng.integers(-4, 5, x.shape) * 2.0**-20
    v = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    i = np.arange(k * k).reshape(k, k)
    a, b, c, d_ = i[:-1, :-1].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel(), i[:-1, 1:].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d_])])
    inner = np.all((v[f][:, :, :2] > 0) & (v[f][:, :, :2] < 1), axis=(1, 2))
    fin = f[inner]
    ids = np.flatnonzero(inner)
    r = _Rays()
    sizes = _split(rng, n, 3)
    o = np.column_stack([rng.integers(0, 2**10 + 1, (n, 2)) * 2.0**-10, np.full(n, 0.25)])
    vf = _vertex_face(fin, len(v))
    inner_v = np.unique(fin)
    inner_v = inner_v[np.all((v[inner_v, :2] > 0) & (v[inner_v, :2] < 1), axis=1)]
    s0, s1 = sizes[0], sizes[0] + sizes[1]
    vi = inner_v[rng.integers(0, len(inner_v), sizes[0])]
    r.add(
        "vertex",
        o[:s0],
        v[vi] - o[:s0],
        hit=1,
        t=1.0,
        zs=2,
        in_tie=ids[vf[vi]],
        through=v[vi],
        through_t=1.0,
    )
    pe, fe, *_ = _edge_points(rng, v, fin, sizes[1])
    r.add(
        "edge",
        o[s0:s1],
        pe - o[s0:s1],
        hit=1,
        t=1.0,
        zs=1,
        in_tie=ids[fe],
        through=pe,
        through_t=1.0,
    )
    pf, ff = _face_points(rng, v, fin, sizes[2])
    r.add(
        "face", o[s1:], pf - o[s1:], hit=1, t=1.0, zs=0, in_tie=ids[ff], through=pf, through_t=1.0
    )
    return r.case(
        "terrain",
        v,
        f,
        "height field (bumps 2^-20) from above, exactly at vertices"
        "/edges/faces at t=1: first hit there",
    )


def _facing_aims(rng, v, f, n):
    """``n`` unit directions ``u`` from the sphere's centre, for each a face ``fi`` that faces
    it (nothing of the convex sphere hides it from far along ``u``) and integer weights ``w``
    (sixteenths, each >= 2: well inside the face)."""
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
    return u, fi, w


def fam_long(rng, n, distance=2**13):
    """Rays from ``distance`` (about 1e4) sphere radii away, outside the domain, aimed at points
    well inside faces that face them (weights >= 2/16): they enter through the domain box after
    a very long way and hit the aimed-at face. The float64 rays are exact; the float32 rays are
    them rounded (24 bits cannot hold both the origin and the target): rounding moves the line
    by about 2^-24 x 8192 = 5e-4 at the sphere, far less than the 1/8 of a face (about 0.02)
    between the target and the face's border, so both claim the hit on the aimed-at face."""
    v, f = _ball()
    u, fi, w = _facing_aims(rng, v, f, n)
    p = np.einsum("ij,ijk->ik", w / 16.0, v[f[fi]])
    o = np.round(u * distance)
    r = _Rays()
    r.add("long", o, p - o, hit=1, in_tie=fi)
    return r.case(
        "long",
        v,
        f,
        "from 2^13 radii away, outside the domain, at a face's "
        "interior: hit on that face (float32: the rays rounded)",
        contain=False,
        exact32=False,
    )


def fam_distance(rng, n, distance, name):
    """Rays from ``distance`` (1e2 to 1e8) away from the unit sphere, outside the domain, aimed
    at points of faces that face them: interiors (weights >= 2/16), edge points and vertices,
    a third each
    (issue 32: the float64 formula ``det(a - o, b - o, c - o) / den`` lost up to twelve digits
    of ``t`` at 1e6). The aimed-at point is rounded into the direction, so edge and vertex rays
    are judged by the referee alone. Up to 1e4 the interior rays claim a hit on the aimed face:
    rounding to float32 moves their line by about ``distance x 2^-23`` (1e-3 at 1e4), well
    inside the face; farther, float32 rounding moves it by more than a face (an origin 1e8
    away moves by up to 4), so no ray claims anything and the referee judges them all."""
    v, f = _ball()
    u, fi, w = _facing_aims(rng, v, f, n)
    o = u * distance
    tri = v[f[fi]]
    r = _Rays()
    for kind, sel in zip(("face", "edge", "vertex"), np.array_split(np.arange(n), 3)):
        ww = w[sel] / 16.0
        if kind == "edge":
            ww = np.column_stack([ww[:, 0], 1 - ww[:, 0], np.zeros(len(sel))])
        elif kind == "vertex":
            ww = np.tile([1.0, 0.0, 0.0], (len(sel), 1))
        p = np.einsum("ij,ijk->ik", ww, tri[sel])
        claims = dict(hit=1, in_tie=fi[sel]) if kind == "face" and distance <= 1e4 else {}
        r.add(kind, o[sel], p - o[sel], **claims)
    return r.case(
        name,
        v,
        f,
        f"from {name[6:]} away, outside the domain, at face interiors (up to 1e4: hit on "
        "that face), edges and vertices (judged only); float32: the rays rounded",
        contain=False,
        exact32=False,
    )


def fam_dirscale(rng, n):
    """From inside the convex sphere through vertices, edges, faces and in random directions,
    directions scaled by 2^-100, 2^-33, 2^33 or 2^100 (exact): t scales inversely."""
    v, f = _ball()
    r = _Rays()
    origins = _interior(rng, n, 2.0**-6)
    sizes = _split(rng, n, 4)
    start = 0
    for e, m in zip((-100, -33, 33, 100), sizes):
        sub = _Rays()
        _aimed(sub, rng, m, v, f, origins[start : start + m], INSIDE_KINDS, dscale=2.0**e)
        start += m
        for part in sub.parts:
            part["kind"] = np.char.add(part["kind"], f"_2^{e}")
        r.parts += sub.parts
    return r.case(
        "dirscale",
        v,
        f,
        "directions x 2^-100..2^100 through vertices/edges/faces: "
        "first hit there at t = 2^-e exactly",
    )
