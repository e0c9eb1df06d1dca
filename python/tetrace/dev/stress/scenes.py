"""The exact synthetic scenes (integer balls, boxes) and the kinds of rays aimed at them."""

import functools

import numpy as np

from .case import _split

# --------------------------------------------------------------------------- scenes


def _convex_ints(q, f):
    """Whether the integer mesh ``q[f]`` has no zero-area face and no vertex strictly outside
    any face's plane (outward faces): a convex polyhedron, decided exactly in int64."""
    a, b, c = q[f[:, 0]], q[f[:, 1]], q[f[:, 2]]
    n = np.cross(b - a, c - a)
    if (n == 0).all(axis=1).any():
        return False
    for s in range(0, len(f), 256):
        side = np.einsum("fvk,fk->fv", q[None] - a[s : s + 256, None], n[s : s + 256])
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

    g = 2.0**grid_exp
    for sub in range(max_sub, -1, -1):
        s = trimesh.creation.icosphere(subdivisions=sub)
        q = np.round(np.asarray(s.vertices) / g).astype(np.int64)
        f = np.asarray(s.faces, np.int64)
        if np.abs(q).max() < 2**20 and _convex_ints(q, f):
            q.setflags(write=False)
            f.setflags(write=False)
            return q, f
    raise ValueError(f"no convex icosphere on the grid 2^{grid_exp}")


#: The base sphere's grid: 2^-16 (its vertices have at most 17 significant bits).
BALL_GRID = -16


def _ball(grid_exp=BALL_GRID, max_sub=3):
    q, f = _ball_ints(grid_exp, max_sub)
    return q * 2.0**grid_exp, f.copy()


def _box():
    import trimesh

    b = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    return np.asarray(b.vertices, np.float64), np.asarray(b.faces, np.int64)


#: Edge vectors of the rotated box (``box_edges``): integer, mutually orthogonal, each of
#: length 3, none along an axis, so that no face plane is an axis plane.
ROTATED_BASIS = ((1, 2, 2), (2, 1, -2), (2, -2, 1))


@functools.cache
def _grid_box_ints(k, basis=((1, 0, 0), (0, 1, 0), (0, 0, 1))):
    """A closed box surface whose faces are ``k x k`` grids of squares, each split in two
    triangles (the diagonals alternate in a checkerboard): ``(lat, q, f)``, ``lat`` the
    integer lattice coordinates ``(a, b, c)`` in ``{0..k}^3`` of each vertex (on the box's
    surface: some coordinate 0 or ``k``), ``q = lat @ basis`` the integer points (``basis``
    rows: the box's edge vectors, orthogonal) and ``f`` the faces, oriented outwards
    (checked exactly). ``k = 1`` is the 12-triangle box."""
    basis = np.asarray(basis, np.int64)
    g = np.arange(k + 1)
    lat = np.array(
        [(a, b, c) for a in g for b in g for c in g if {a, b, c} & {0, k}], np.int64
    ).reshape(-1, 3)
    index = {tuple(x): i for i, x in enumerate(lat.tolist())}
    faces = []
    for axis in range(3):
        u, w = (axis + 1) % 3, (axis + 2) % 3
        for side in (0, k):
            for i in range(k):
                for j in range(k):
                    quad = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        x = [0, 0, 0]
                        x[axis], x[u], x[w] = side, i + di, j + dj
                        quad.append(index[tuple(x)])
                    a, b, c, d = quad
                    if (i + j) % 2:
                        faces += [(a, b, c), (a, c, d)]
                    else:
                        faces += [(a, b, d), (b, c, d)]
    f = np.array(faces, np.int64)
    q = lat @ basis
    # outwards: the normal points away from the centre (3 x centroid - 3 x centre, exact)
    centre2 = k * basis.sum(axis=0)  # twice the centre
    a, b, c = q[f[:, 0]], q[f[:, 1]], q[f[:, 2]]
    n = np.cross(b - a, c - a)
    out = np.einsum("ij,ij->i", n, 2 * (a + b + c) - 3 * centre2)
    if (out == 0).any() or (n == 0).all(axis=1).any():
        raise AssertionError("degenerate box face")
    f[out < 0] = f[out < 0][:, ::-1]
    for x in (lat, q, f):
        x.setflags(write=False)
    return lat, q, f


def _grid_box(k, basis=((1, 0, 0), (0, 1, 0), (0, 0, 1)), scale=1.0):
    """:func:`_grid_box_ints` as points ``scale * q``, centred on the origin (exact: the
    centre is ``scale * k / 2 * sum(basis)``, dyadic for the ``scale`` used):
    ``(lat, points, faces)``."""
    lat, q, f = _grid_box_ints(k, tuple(map(tuple, np.asarray(basis).tolist())))
    centre = np.asarray(basis, np.float64).sum(axis=0) * (k / 2.0)
    return lat, (q - centre) * scale, f.copy()


@functools.cache
def _scan_ints(grid_exp=BALL_GRID, sub=3, seed=14):
    """A closed scan-like surface on the grid ``2^grid_exp``: an icosphere (``sub``
    subdivisions) made an ellipsoid (1, 0.85, 0.7), with smooth bumps (it is not convex)
    and per-vertex noise of 1.5% of the radius, rounded to the grid: integer vertices ``q``,
    faces ``f`` and the **kernel** origins ``ker`` (integer points, multiples of ``2^-6``
    within 0.2 of the centre, strictly on the inner side of every face's plane: decided
    exactly in int64). From a kernel point the surface is seen from the inside, every face
    oriented the same way: every ray from it crosses the surface exactly once, so the first
    hit of a ray aimed at a vertex or an edge point is exactly there."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=sub)
    u = np.asarray(s.vertices, np.float64)
    rng = np.random.default_rng(seed)
    r = (
        1.0
        + 0.1 * np.sin(3 * u[:, 0] + 1.0) * np.cos(2 * u[:, 1])
        + 0.06 * np.cos(4 * u[:, 2])
        + rng.uniform(-0.015, 0.015, len(u))
    )
    p = u * r[:, None] * np.array([1.0, 0.85, 0.7])
    q = np.round(p / 2.0**grid_exp).astype(np.int64)
    f = np.asarray(s.faces, np.int64)
    a, b, c = q[f[:, 0]], q[f[:, 1]], q[f[:, 2]]
    n = np.cross(b - a, c - a)  # outward (icosphere faces are), |n| < 2^40
    if (n == 0).all(axis=1).any():
        raise AssertionError("zero-area face in the scan surface")
    step = 2 ** (-6 - grid_exp)
    k = int(0.2 * 2**6)
    g = np.arange(-k, k + 1) * step
    cand = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    inside = np.ones(len(cand), bool)
    for s0 in range(0, len(f), 128):  # (o - a) . n < 0 for every face, |.| < 2^60: exact
        side = np.einsum("ofk,fk->of", cand[:, None] - a[None, s0 : s0 + 128], n[s0 : s0 + 128])
        inside &= (side < 0).all(axis=1)
    ker = cand[inside]
    if len(ker) < 1000:
        raise AssertionError(f"scan surface: only {len(ker)} kernel origins")
    for x in (q, f, ker):
        x.setflags(write=False)
    return q, f, ker


def _scan(grid_exp=BALL_GRID):
    """:func:`_scan_ints` as points: ``(vertices, faces, kernel origins)``."""
    q, f, ker = _scan_ints(grid_exp)
    return q * 2.0**grid_exp, f.copy(), ker * 2.0**grid_exp


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
    d = rng.integers(-(2**bits), 2**bits + 1, (n, 3)).astype(np.float64)
    zero = ~d.any(axis=1)
    d[zero, 0] = 1.0
    return d * 2.0**-bits


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
        o = origins[start : start + m]
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
        rays.add(
            kind,
            offset + scale * o,
            scale * (p - o) * dscale,
            hit=1,
            t=t,
            through=offset + scale * p,
            through_t=t,
            **claims,
        )


INSIDE_KINDS = ("vertex", "edge", "face", "random")
