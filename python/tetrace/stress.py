"""Adversarial rays and scenes for measuring where traversal methods fail.

Each family is reproducible from a seed and yields ``StressCase`` objects: a scene, rays, and
what is known about them (e.g. that every ray starts inside a closed surface, so a miss is a
leak). ``classify`` sorts the results of a cast into the failure taxonomy, using the robust
method in float64 as the reference walk.

Each ray is judged twice. Per step, by the walk's exact audit (``audited_cast``): every exit
face the method took is checked with exact orientation predicates against the line the robust
walk in the same precision follows (a face the line does not leave by is a *wrong exit*), and
methods with a fallback report the steps where their own tests found *no exit face*. Per ray,
against every triangle of the scene (``brute_bounds``): a hit before anything the ray touches
or past a triangle it surely pierces is a *wrong hit*; no hit where one was certain is a *leak*;
the step guard firing is a *cycle*.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .hits import FAILED, HIT

__all__ = ["StressCase", "FAMILIES", "cases", "classify", "OUTCOMES", "audited_cast",
           "build_scene"]


@dataclasses.dataclass
class StressCase:
    """A scene and rays to cast into it.

    Attributes
    ----------
    family : str
        Family name (see :data:`FAMILIES`).
    vertices, faces : numpy.ndarray
        The scene.
    origins, directions : numpy.ndarray
        ``(N, 3)`` float64 rays.
    closed : bool
        Every ray must hit (it starts strictly inside a closed, watertight surface, or is
        aimed at a point of the scene from outside): a miss is a leak.
    contain : bool
        Grow the domain to hold the origins (False: rays enter through the domain box).
    """

    family: str
    vertices: np.ndarray
    faces: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    closed: bool
    contain: bool = True


def _sphere(subdivisions=3):
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.asarray(s.vertices, np.float64), np.asarray(s.faces, np.int64)


def _box():
    import trimesh

    b = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    return np.asarray(b.vertices, np.float64), np.asarray(b.faces, np.int64)


def _unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _inside_at(v, f, rng, n, targets):
    """Rays from points near the centre towards given target points (on the surface)."""
    o = v.mean(0) + (rng.random((n, 3)) - 0.5) * 0.2 * (v.max(0) - v.min(0))
    return o, targets - o


def fam_vertices(rng, n):
    """From inside a sphere, aimed exactly at its vertices (a ray meets several triangles there)."""
    v, f = _sphere()
    t = v[rng.integers(0, len(v), n)]
    o, d = _inside_at(v, f, rng, n, t)
    return StressCase("vertices", v, f, o, d, True)


def fam_edges(rng, n):
    """From inside a sphere, aimed at points on its edges (midpoints and random points)."""
    v, f = _sphere()
    e = f[rng.integers(0, len(f), n)]
    k = rng.integers(0, 3, n)
    a, b = v[e[np.arange(n), k]], v[e[np.arange(n), (k + 1) % 3]]
    w = np.where(rng.random(n) < 0.5, 0.5, rng.random(n))[:, None]
    o, d = _inside_at(v, f, rng, n, a + w * (b - a))
    return StressCase("edges", v, f, o, d, True)


def fam_axis(rng, n):
    """Axis-aligned directions and directions with zero components, from inside a box whose
    faces are axis planes: rays run parallel to faces and through edges of the mesh."""
    v, f = _box()
    o = (rng.integers(-8, 9, (n, 3)) / 20.0).astype(np.float64)
    d = rng.integers(-1, 2, (n, 3)).astype(np.float64)
    zero = ~d.any(axis=1)
    d[zero, 0] = 1.0
    return StressCase("axis", v, f, o, d, True)


def fam_grazing(rng, n):
    """Rays lying in the planes of the scene's triangles (from outside a box, along its faces)."""
    v, f = _box()
    tri = v[f[rng.integers(0, len(f), n)]]
    # a point in the triangle's plane, outside the box, moving within that plane
    n_ = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    inplane = _unit(np.cross(n_, rng.standard_normal((n, 3))))
    c = tri.mean(1)
    o = c - 2.0 * inplane
    return StressCase("grazing", v, f, o, inplane, False)


def fam_far(rng, n, offset=1e5):
    """A sphere translated far from the world origin (offset x its size); rays from inside."""
    v, f = _sphere()
    v = v + offset
    t = v[f[rng.integers(0, len(f), n)]].mean(1)
    o, d = _inside_at(v, f, rng, n, t)
    return StressCase(f"far{offset:g}", v, f, o, d, True)


def fam_tiny(rng, n, scale=1e-4):
    """A sphere scaled very small; rays from inside to random directions."""
    v, f = _sphere()
    v = v * scale
    o = (rng.random((n, 3)) - 0.5) * 0.5 * scale
    d = rng.standard_normal((n, 3))
    return StressCase(f"tiny{scale:g}", v, f, o, d, True)


def fam_huge(rng, n, scale=1e6):
    """A sphere scaled very large; rays from inside to random directions."""
    case = fam_tiny(rng, n, scale)
    case.family = f"huge{scale:g}"
    return case


def fam_flat(rng, n, flatness=1e-4):
    """A sphere flattened to ``flatness`` of its width: nearly coplanar points, so TetGen
    fills it with flat tets and slivers; rays from inside in random directions graze them."""
    v, f = _sphere()
    v = v * np.array([1.0, 1.0, flatness])
    o = (rng.random((n, 3)) - 0.5) * np.array([0.8, 0.8, 0.8 * flatness])
    d = rng.standard_normal((n, 3))
    return StressCase("flat", v, f, o, d, True)


def fam_terrain(rng, n, k=24, bump=1e-6):
    """A nearly flat open height field (bumps of ``bump`` x its size) hit from above at its
    vertices, on its edges and inside its triangles: every ray must hit."""
    x, y = np.meshgrid(np.linspace(0, 1, k), np.linspace(0, 1, k), indexing="ij")
    z = bump * rng.standard_normal(x.shape)
    v = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    i = np.arange(k * k).reshape(k, k)
    a, b, c, d_ = i[:-1, :-1].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel(), i[:-1, 1:].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d_])])
    # Aim only at triangles away from the border: a vertex or edge on the border of an open
    # surface may rightly be missed; interior ones are surrounded by triangles.
    inner = np.nonzero(np.all((v[f][:, :, :2] > 0.01) & (v[f][:, :, :2] < 0.99), axis=(1, 2)))[0]
    tri = v[f[inner[rng.integers(0, len(inner), n)]]]
    w = rng.random((n, 3)) + 1e-3
    kind = rng.random(n)
    k = rng.integers(0, 3, n)
    w[kind < 0.3] = np.eye(3)[k[kind < 0.3]]  # a third exactly at vertices
    on_edge = (kind >= 0.3) & (kind < 0.6)
    w[on_edge, k[on_edge]] = 0.0  # a third on edges
    w /= w.sum(1, keepdims=True)
    target = np.einsum("ij,ijk->ik", w, tri)
    o = np.column_stack([rng.random((n, 2)), np.full(n, 0.5)])
    return StressCase("terrain", v, f, o, target - o, True)


def fam_long(rng, n, distance=1e4):
    """Rays from ``distance`` x the sphere's size away, outside the domain, aimed at points of
    the sphere facing them (away from its silhouette, so rounding cannot make them miss):
    they enter through the domain box after a very long way."""
    v, f = _sphere()
    c = v[f].mean(1)
    o = _unit(rng.standard_normal((n, 3)))
    facing = (_unit(c) @ o.T) > 0.5
    t = c[np.argmax(facing * rng.random(facing.shape), axis=0)]
    o = o * distance
    return StressCase("long", v, f, o, t - o, True, contain=False)


def fam_dirscale(rng, n):
    """From inside a sphere, directions of length 1e-30 to 1e30 (t scales with them)."""
    v, f = _sphere()
    o = (rng.random((n, 3)) - 0.5) * 0.5
    d = _unit(rng.standard_normal((n, 3))) * (10.0 ** rng.choice([-30, -10, 10, 30], n))[:, None]
    return StressCase("dirscale", v, f, o, d, True)


#: Family name -> generator ``(rng, n) -> StressCase``.
FAMILIES = {
    "vertices": fam_vertices,
    "edges": fam_edges,
    "axis": fam_axis,
    "grazing": fam_grazing,
    "far1e3": lambda rng, n: fam_far(rng, n, 1e3),
    "far1e6": lambda rng, n: fam_far(rng, n, 1e6),
    "tiny": fam_tiny,
    "huge": fam_huge,
    "flat": fam_flat,
    "terrain": fam_terrain,
    "long": fam_long,
    "dirscale": fam_dirscale,
}


def cases(n_per_family, seed=0, families=None):
    """Yield one :class:`StressCase` per family, each from its own stream of ``seed``."""
    names = list(FAMILIES) if families is None else list(families)
    for i, name in enumerate(names):
        rng = np.random.default_rng([seed, i])
        case = FAMILIES[name](rng, n_per_family)
        case.family = name
        yield case


#: Outcome names, in the order ``classify`` counts them. A ray counts once in each that holds
#: of it; ``correct`` rays have none of the others.
OUTCOMES = ("correct", "wrong_exit", "no_exit", "cycle", "leak", "wrong_hit")


def build_scene(case):
    """The :class:`tetrace.Scene` of a stress case (domain grown to its origins if asked)."""
    from .scene import Scene

    contain = np.vstack([case.origins, case.origins + 1e-9]) if case.contain else None
    return Scene.from_mesh((case.vertices, case.faces), contain=contain)


def audited_cast(scene, origins, directions, *, method=None, layout=None, precision="f64",
                 threads=None):
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
    r = scene._native.cast(o, d, prepare_bounds(0.0, n, "tmin"), prepare_bounds(np.inf, n, "tmax"),
                           threads, None, method or _native.DEFAULT_METHOD,
                           layout or _native.DEFAULT_LAYOUT, True)
    audit = r.pop("audit")
    return Hits(**r), audit


def brute_bounds(origins, directions, vertices, faces, band, chunk=512):
    """Exact-enough bounds on each ray's right answer, by testing every triangle.

    Returns ``(t_touch, t_sure)``: the nearest parameter where the ray meets a triangle
    grown by ``band`` (relative barycentric margin; coplanar triangles count at their nearest
    vertex), and the nearest where it pierces one shrunk by ``band``. Where the ray only grazes
    edges or faces, any answer between the two is right; ``inf`` when there is none.
    """
    o = np.asarray(origins, np.float64)
    d = np.asarray(directions, np.float64)
    p = np.asarray(vertices, np.float64)[np.asarray(faces)]
    p0, e1, e2 = p[:, 0], p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    nrm = np.cross(e1, e2)
    touch = np.full(len(o), np.inf)
    sure = np.full(len(o), np.inf)
    for s in range(0, len(o), chunk):
        oo, dd = o[s:s + chunk, None, :], d[s:s + chunk, None, :]
        pv = np.cross(dd, e2[None])
        det = np.einsum("ijk,jk->ij", pv, e1)
        tv = oo - p0[None]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.einsum("ijk,ijk->ij", tv, pv) / det
            qv = np.cross(tv, e1[None])
            v = np.einsum("ijk,ijk->ij", dd, qv) / det
            t = np.einsum("ijk,jk->ij", qv, e2) / det
        scale = np.linalg.norm(nrm, axis=1)[None] * np.linalg.norm(dd, axis=2)
        parallel = np.abs(det) <= 1e-12 * scale
        ok_t = np.isfinite(t) & (t >= 0) & ~parallel
        with np.errstate(invalid="ignore"):
            w = 1 - u - v
        with np.errstate(invalid="ignore"):
            grown = ok_t & (u >= -band) & (v >= -band) & (w >= -band)
            inner = ok_t & (u > band) & (v > band) & (w > band)
        touch[s:s + chunk] = np.where(grown, t, np.inf).min(1)
        sure[s:s + chunk] = np.where(inner, t, np.inf).min(1)
        # A triangle in a plane holding the ray is touched, not pierced: nearest vertex's t.
        coplanar = parallel & (np.abs(np.einsum("ijk,jk->ij", tv, nrm))
                               <= 1e-9 * np.linalg.norm(nrm, axis=1)[None] * (1 + np.linalg.norm(tv, axis=2)))
        if coplanar.any():
            tvert = np.einsum("ijlk,ik->ijl", p[None] - oo[:, :, None, :], dd[:, 0, :]) / (dd[:, 0, :] ** 2).sum(1)[:, None, None]
            tc = np.where(coplanar, np.maximum(tvert.min(2), 0.0), np.inf).min(1)
            touch[s:s + chunk] = np.minimum(touch[s:s + chunk], tc)
    return touch, sure


def classify(hits, audit, bounds, directions, diag, closed, t_tol=1e-6):
    """Sort a cast's rays into the taxonomy of :data:`OUTCOMES`.

    Parameters
    ----------
    hits : Hits
        The cast under test.
    audit : numpy.ndarray
        Its per-step audit (:func:`audited_cast`).
    bounds : tuple of numpy.ndarray
        ``(t_touch, t_sure)`` of :func:`brute_bounds` for these rays.
    directions : numpy.ndarray
        The rays' directions as cast.
    diag : float
        Scene diagonal (``t_tol`` is relative to it).
    closed : bool
        Every ray must hit: a ray without a hit is a leak.

    Returns
    -------
    dict
        Rays in each outcome: ``wrong_exit`` (took an exit face the line does not leave by),
        ``no_exit`` (the method's tests found no exit face at some step), ``cycle`` (the step
        guard fired: FAILED), ``leak`` (a must-hit ray reported no hit), ``wrong_hit`` (a hit
        before anything the ray touches or after a triangle it surely pierces, or a miss
        despite a sure hit), and ``correct`` (none of these).
    """
    touch, sure = bounds
    tol = t_tol * diag / np.maximum(np.linalg.norm(np.asarray(directions, np.float64), axis=1), 1e-300)
    # t is reported in the walk's precision: its own rounding is no error of the walk.
    tol = np.maximum(tol, 4 * np.finfo(hits.t.dtype).eps * np.where(np.isfinite(touch), touch, 0))
    cycle = hits.status == FAILED
    hit = hits.status == HIT
    leak = ~cycle & ~hit & closed
    t = hits.t.astype(np.float64)
    with np.errstate(invalid="ignore"):
        wrong_hit = ~cycle & ~leak & np.where(hit, (t < touch - tol) | (t > sure + tol),
                                              np.isfinite(sure))
    wrong_exit = audit[:, 0] > 0
    no_exit = audit[:, 1] > 0
    flags = dict(wrong_exit=wrong_exit, no_exit=no_exit, cycle=cycle, leak=leak,
                 wrong_hit=wrong_hit)
    bad = np.zeros(len(t), bool)
    for f in flags.values():
        bad |= f
    return {"correct": int((~bad).sum()), **{k: int(v.sum()) for k, v in flags.items()}}
