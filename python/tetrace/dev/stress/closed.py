"""Stress families on closed meshes, for the exact default's contract: rays from inside a
scan-like surface at its vertices and edge midpoints, axis-parallel rays through a box's
vertices, rays through an icosphere's vertices from its centre and from outside, rays along a
rotated box's edges, and rays parallel to faces just off their planes.

Every mesh is on a dyadic grid and every ray is built from its points by differences and
power-of-two scalings, so the float32 rays are the same numbers as the float64 ones and each
claim holds by construction (and is certified by the referee, as every family's is).
"""

import numpy as np

from .case import _Rays, _split
from .families import _in_plane
from .scenes import BALL_GRID, ROTATED_BASIS, _ball, _grid_box, _scan, _vertex_face


def fam_scan(rng, n):
    """From inside a closed, non-convex scan-like surface (:func:`scenes._scan_ints`: a noisy,
    bumpy ellipsoid of 1280 triangles on a 2^-16 grid), from origins in its kernel (checked
    exactly), exactly at its vertices and at its edges' midpoints (a vertex has at most 17
    significant bits, a midpoint 18): every ray crosses the surface once, so the first hit is
    the aimed-at point at t = 1, on every triangle around the vertex / both triangles of the
    edge."""
    v, f, ker = _scan()
    vf = _vertex_face(f, len(v))
    r = _Rays()
    m_v, m_e = _split(rng, n, 2)
    o = ker[rng.integers(0, len(ker), n)]
    scale = 2.0 ** rng.integers(-2, 3, n)  # |d| from 1/4 to 4 times |p - o|: t = 1 / scale
    vi = rng.integers(0, len(v), m_v)
    t = 1.0 / scale[:m_v]
    r.add(
        "vertex",
        o[:m_v],
        (v[vi] - o[:m_v]) * scale[:m_v, None],
        hit=1,
        t=t,
        zs=2,
        in_tie=vf[vi],
        through=v[vi],
        through_t=t,
    )
    fi = rng.integers(0, len(f), m_e)
    k = rng.integers(0, 3, m_e)
    p = (v[f[fi, k]] + v[f[fi, (k + 1) % 3]]) / 2
    t = 1.0 / scale[m_v:]
    r.add(
        "edge_midpoint",
        o[m_v:],
        (p - o[m_v:]) * scale[m_v:, None],
        hit=1,
        t=t,
        zs=1,
        in_tie=fi,
        through=p,
        through_t=t,
    )
    return r.case(
        "scan",
        v,
        f,
        "from the kernel of a closed non-convex scan-like surface, at its vertices and edge "
        "midpoints: first hit there at t = 1/scale (zero_signs 2 / 1)",
    )


# --------------------------------------------------------------------------- boxes


def _box_index(lat):
    return {tuple(x): i for i, x in enumerate(np.asarray(lat).tolist())}


def _faces_with(f, *vids):
    """Faces holding every vertex of ``vids``."""
    ok = np.ones(len(f), bool)
    for x in vids:
        ok &= (f == x).any(axis=1)
    return np.flatnonzero(ok)


def _edge_runs(rng, m, lat, pts, f, k, step, kinds):
    """Rays along the lines of a box's edges (``step[j]``: the vector from one lattice vertex
    to the next along the box's axis ``j``), kinds among:

    * ``corner_out``: from outside beyond a corner, along an edge towards the box: the first
      hit is the corner, on the triangles of the face across the edge (zero_signs 2);
    * ``corner_away``: the same line, the ray pointing away from the box: a miss;
    * ``on_edge``: from a point of the edge (a multiple of 1/8 of it; mesh vertices on it
      included), tmin = 0, towards one end: the first hit is that end corner (the start lies
      on the triangles along the edge, whose planes hold the line: never hit).

    The triangles along the edge at the corner (their planes hold the line) are claimed not
    in the tie set, one as ``plane``. Yields ``(kind, o, d, claims)``."""
    index = _box_index(lat)
    corners = np.flatnonzero(np.isin(lat, (0, k)).all(axis=1))
    sizes = _split(rng, m, len(kinds))
    for kind, mm in zip(kinds, sizes):
        ci = corners[rng.integers(0, len(corners), mm)]
        ax = rng.integers(0, 3, mm)
        o = np.empty((mm, 3))
        d = np.empty((mm, 3))
        t = np.empty(mm)
        not_tie = np.empty((mm, 2), np.int64)
        in_tie = np.empty(mm, np.int64)
        for i in range(mm):
            c = lat[ci[i]]
            j = ax[i]
            sgn = 1 if c[j] == 0 else -1  # into the box along axis j
            inward = sgn * np.asarray(step[j], np.float64)
            nxt = c.copy()
            nxt[j] += sgn
            along = _faces_with(f, ci[i], index[tuple(nxt)])
            across = [
                x for x in _faces_with(f, ci[i]) if (lat[f[x], j] == c[j]).all() and x not in along
            ]
            not_tie[i], in_tie[i] = along, across[0]
            e = rng.integers(-2, 3)
            if kind == "corner_out":
                s = rng.choice([0.25, 0.5, 1.0, 2.0])
                o[i], d[i], t[i] = pts[ci[i]] - s * inward, inward * 2.0**e, s * 2.0**-e
            elif kind == "corner_away":
                s = rng.choice([0.25, 0.5, 1.0, 2.0])
                o[i], d[i], t[i] = pts[ci[i]] - s * inward, -inward * 2.0**e, -s * 2.0**-e
            else:  # on_edge: from lam of the edge's length, back to the corner
                lam = rng.integers(1, 8) / 8.0
                o[i] = pts[ci[i]] + (lam * k) * inward
                d[i], t[i] = -inward * 2.0**e, lam * k * 2.0**-e
        p = pts[ci]
        if kind == "corner_away":
            claims = dict(hit=0, through=p, through_t=t, plane=not_tie[:, 0])
        else:
            claims = dict(
                hit=1,
                t=t,
                zs=2,
                in_tie=in_tie,
                not_tie=not_tie,
                through=p,
                through_t=t,
                plane=not_tie[:, 0],
            )
        yield kind, o, d, claims


def fam_box_axis(rng, n):
    """A closed box of 12 triangles ([-1/2, 1/2]^3), axis-parallel rays through its corners:
    such a line runs along an edge. From outside towards the box the first hit is the corner
    on the face across the edge; pointing away, a miss; from a point of the edge (the closed
    box's boundary, tmin = 0), the corner ahead. The two faces along the edge hold the line:
    never hit."""
    lat, v, f = _grid_box(1)
    r = _Rays()
    step = np.eye(3)
    for kind, o, d, claims in _edge_runs(
        rng, n, lat, v, f, 1, step, ("corner_out", "corner_away", "on_edge")
    ):
        r.add(kind, o, d, **claims)
    return r.case(
        "box_axis",
        v,
        f,
        "12-triangle box, axis-parallel through its corners (along its edges), from outside "
        "and from its edges: first hit the corner (zero_signs 2), never the faces along",
    )


def fam_box_grid_axis(rng, n, k=4):
    """A closed box ([-1/2, 1/2]^3) whose faces are 4 x 4 grids of squares (192 triangles),
    axis-parallel rays through its vertices, powers of two apart:

    * ``face_in`` / ``face_out``: through a vertex inside a face, perpendicular to it, from
      inside / outside the box: first hit that vertex, on every triangle around it;
    * ``edge_out``: through a vertex of a box edge, perpendicular to one of its two faces,
      from outside: the line lies in the other face's plane (never hit); first hit the vertex;
    * ``edge_in``: the same line from inside that other face (an origin on the surface,
      tmin = 0, on triangles whose plane holds the line): first hit the edge vertex;
    * ``corner_out`` / ``on_edge``: along the box's edges through their vertices to a corner
      (see ``box_axis``)."""
    lat, v, f = _grid_box(k, scale=1.0 / k)
    vf = _vertex_face(f, len(v))
    ext = np.isin(lat, (0, k))
    n_ext = ext.sum(axis=1)
    face_v = np.flatnonzero(n_ext == 1)
    edge_v = np.flatnonzero(n_ext == 2)
    r = _Rays()
    m = _split(rng, n, 4)
    for kind, mm in (("face_in", m[0]), ("face_out", m[1])):
        vi = face_v[rng.integers(0, len(face_v), mm)]
        ax = np.argmax(ext[vi], axis=1)
        sgn = np.where(lat[vi, ax] == k, 1.0, -1.0)  # outward
        nrm = np.zeros((mm, 3))
        nrm[np.arange(mm), ax] = sgn
        s = rng.integers(1, 8, mm) / 8.0 * (1 if kind == "face_in" else 4)
        e = rng.integers(-3, 4, mm)
        if kind == "face_in":
            o, d = v[vi] - s[:, None] * nrm, nrm * 2.0 ** e[:, None]
        else:
            o, d = v[vi] + s[:, None] * nrm, -nrm * 2.0 ** e[:, None]
        t = s * 2.0**-e
        r.add(kind, o, d, hit=1, t=t, zs=2, in_tie=vf[vi], through=v[vi], through_t=t)
    for kind, mm in (("edge_out", m[2] - m[2] // 2), ("edge_in", m[2] // 2)):
        vi = edge_v[rng.integers(0, len(edge_v), mm)]
        o = np.empty((mm, 3))
        d = np.empty((mm, 3))
        t = np.empty(mm)
        in_tie = np.empty(mm, np.int64)
        plane = np.empty(mm, np.int64)
        for i in range(mm):
            c = lat[vi[i]]
            a, b = rng.permutation(np.flatnonzero(ext[vi[i]]))  # travel along a, in face b
            nrm = np.zeros(3)
            nrm[a] = 1.0 if c[a] == k else -1.0
            e = rng.integers(-3, 4)
            s = rng.integers(1, 8) / 8.0
            if kind == "edge_out":
                s *= 4
                o[i], d[i] = v[vi[i]] + s * nrm, -nrm * 2.0**e
            else:
                o[i], d[i] = v[vi[i]] - s * nrm, nrm * 2.0**e
            t[i] = s * 2.0**-e
            around = _faces_with(f, vi[i])
            in_tie[i] = [x for x in around if (lat[f[x], a] == c[a]).all()][0]
            plane[i] = [x for x in around if (lat[f[x], b] == c[b]).all()][0]
        r.add(
            kind,
            o,
            d,
            hit=1,
            t=t,
            zs=2,
            in_tie=in_tie,
            not_tie=plane,
            through=v[vi],
            through_t=t,
            plane=plane,
        )
    for kind, o, d, claims in _edge_runs(
        rng, m[3], lat, v, f, k, np.eye(3) / k, ("corner_out", "on_edge")
    ):
        r.add(kind, o, d, **claims)
    return r.case(
        "box_grid_axis",
        v,
        f,
        "box of 4x4-grid faces, axis-parallel through its face / edge / corner vertices, from "
        "inside, outside and its faces: first hit the vertex (zero_signs 2), never an "
        "in-plane face",
    )


def fam_box_edges(rng, n, k=2):
    """A rotated closed box (edges along (1, 2, 2), (2, 1, -2), (2, -2, 1), so no face plane is
    an axis plane; each face a 2 x 2 grid of squares: 48 triangles; vertices multiples of 1/8),
    rays exactly along its edges: from outside beyond a corner (first hit the corner, on the
    face across the edge), pointing away (a miss), and from points of the edge, its middle
    vertex included (tmin = 0: first hit the corner ahead). They lie in the planes of the two
    faces along the edge, which they never hit."""
    lat, v, f = _grid_box(k, ROTATED_BASIS, 2.0**-3)
    step = np.asarray(ROTATED_BASIS, np.float64) * 2.0**-3
    r = _Rays()
    for kind, o, d, claims in _edge_runs(
        rng, n, lat, v, f, k, step, ("corner_out", "corner_away", "on_edge")
    ):
        r.add(kind, o, d, **claims)
    return r.case(
        "box_edges",
        v,
        f,
        "rotated box (faces off the axis planes), along its edges from outside and from the "
        "edge: first hit the corner across (zero_signs 2), never the faces along",
    )


# --------------------------------------------------------------------------- icosphere


def fam_icosphere(rng, n):
    """Through the vertices of a closed icosphere (2 subdivisions: 162 vertices, 320
    triangles, on the 2^-16 grid, convex: checked exactly): from its centre (the origin
    exactly, d = 2^e v), from outside on the line through the centre (o = (1 + s) v) and from
    outside on the line through an interior grid point c (o = v + s (v - c), d = c - v):
    the line crosses the surface at the vertex, the first hit, on every triangle around it."""
    v, f = _ball(BALL_GRID, max_sub=2)
    vf = _vertex_face(f, len(v))
    r = _Rays()
    m = _split(rng, n, 3)
    vi = rng.integers(0, len(v), m[0])
    e = rng.integers(-3, 4, m[0])
    t = 2.0**-e
    r.add(
        "centre",
        np.zeros((m[0], 3)),
        v[vi] * 2.0 ** e[:, None],
        hit=1,
        t=t,
        zs=2,
        in_tie=vf[vi],
        through=v[vi],
        through_t=t,
    )
    vi = rng.integers(0, len(v), m[1])
    s = rng.choice([0.25, 0.5, 1.0, 3.0], m[1])
    e = rng.integers(-3, 4, m[1])
    t = s * 2.0**-e
    r.add(
        "radial_out",
        v[vi] * (1 + s[:, None]),
        -v[vi] * 2.0 ** e[:, None],
        hit=1,
        t=t,
        zs=2,
        in_tie=vf[vi],
        through=v[vi],
        through_t=t,
    )
    vi = rng.integers(0, len(v), m[2])
    c = rng.integers(-19, 20, (m[2], 3)) * 2.0**-6  # within 0.3 of the centre: inside
    s = rng.choice([0.25, 0.5, 1.0, 2.0], m[2])
    r.add(
        "chord_out",
        v[vi] + s[:, None] * (v[vi] - c),
        c - v[vi],
        hit=1,
        t=s,
        zs=2,
        in_tie=vf[vi],
        through=v[vi],
        through_t=s,
    )
    return r.case(
        "icosphere",
        v,
        f,
        "icosphere (320 triangles), through its vertices from the centre and from outside: "
        "first hit the vertex (zero_signs 2) on all triangles around it",
    )


# --------------------------------------------------------------------------- parallel


def fam_parallel(rng, n):
    """A box ([-1/2, 1/2]^3, faces 2 x 2 grids of squares) and lines parallel to a face at
    2^-8, 2^-16 or 2^-24 off its plane (float32 numbers: 1/2 - 2^-24 is one), directions
    powers of two: inside the box (``box_in``) the first hit is on a side face at an exact
    dyadic t, never on the face alongside; outside (``box_out``) a miss (the box lies on the
    plane's other side)."""
    lat, v, f = _grid_box(2, scale=0.5)
    r = _Rays()
    for kind, mm in zip(("box_in", "box_out"), _split(rng, n, 2)):
        ax = rng.integers(0, 3, mm)
        side = rng.choice([-1.0, 1.0], mm)
        delta = 2.0 ** -rng.choice([8, 16, 24], mm)
        o = rng.integers(-7, 8, (mm, 3)) / 16.0
        rows = np.arange(mm)
        o[rows, ax] = side * (0.5 - delta if kind == "box_in" else 0.5 + delta)
        d = rng.choice([-1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0], (mm, 3))
        d[rows, ax] = 0.0
        zero = ~d.any(axis=1)
        d[zero, (ax[zero] + 1) % 3] = 0.5
        # two triangles of the face alongside (all three vertices on its plane)
        lat_side = np.where(side > 0, 2, 0)
        own = np.array(
            [np.flatnonzero((lat[f][:, :, a] == s).all(axis=1))[:2] for a, s in zip(ax, lat_side)],
            np.int64,
        ).reshape(mm, 2)
        if kind == "box_in":
            dd = np.where(d != 0, d, 1.0)
            ts = np.where(d != 0, (np.sign(d) * 0.5 - o) / dd, np.inf)
            t = ts.min(axis=1)  # exact: a dyadic number over a power of two
            r.add(kind, o, d, hit=1, t=t, not_tie=own, parallel=own[:, 0])
        else:
            r.add(kind, o, d, hit=0, not_tie=own, parallel=own[:, 0])
    return r.case(
        "parallel",
        v,
        f,
        "box, lines parallel to a face 2^-24..2^-8 off its plane: never that face; inside a "
        "hit at an exact t on a side face, outside a miss",
    )


def fam_parallel_ball(rng, n):
    """The convex sphere's faces and lines parallel to one: a direction in the face's plane
    (as ``planes``) and the origin moved off the plane by 2^-6, 2^-12 or 2^-20 along the axis
    its normal is largest on (exact: the normal is exact in float64 for the sphere's grid).
    Outwards (``ball_out``: the plane supports the convex sphere) a miss; inwards
    (``ball_in``) never a hit on that face."""
    v, f = _ball()
    r = _Rays()
    for kind, mm in zip(("ball_in", "ball_out"), _split(rng, n, 2)):
        fi = rng.integers(0, len(f), mm)
        o, d, _ = _in_plane(rng, v, f, fi)
        tri = v[f[fi]]
        nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        ax = np.argmax(np.abs(nrm), axis=1)
        out = np.sign(nrm[np.arange(mm), ax])  # along +out e_ax: away from the sphere
        sgn = out if kind == "ball_out" else -out
        o[np.arange(mm), ax] += sgn * 2.0 ** -rng.choice([6, 12, 20], mm)
        claims = dict(not_tie=np.column_stack([fi, fi]), parallel=fi)
        if kind == "ball_out":
            claims["hit"] = 0
        r.add(kind, o, d, **claims)
    return r.case(
        "parallel_ball",
        v,
        f,
        "convex sphere, lines parallel to a face 2^-20..2^-6 off its plane: never that face; "
        "outside its plane a miss",
    )
