"""Adversarial rays and scenes for measuring where traversal methods fail.

Each family is reproducible from a seed and yields ``StressCase`` objects: a scene, rays, and
what is known about them (e.g. that every ray starts inside a closed surface, so a miss is a
leak). ``classify`` sorts the results of a cast into the failure taxonomy, using the robust
method in float64 as the reference walk.

This is the first part of the stability work: the families below and the classification by
outcome. Deciding per step whether a method chose a wrong exit face is not done here yet.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .hits import FAILED, HIT

__all__ = ["StressCase", "FAMILIES", "cases", "classify", "OUTCOMES"]


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
        Every ray starts strictly inside a closed, watertight surface of the scene: a miss is
        a leak.
    """

    family: str
    vertices: np.ndarray
    faces: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    closed: bool


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


#: Family name -> generator ``(rng, n) -> StressCase``.
FAMILIES = {
    "vertices": fam_vertices,
    "edges": fam_edges,
    "axis": fam_axis,
    "grazing": fam_grazing,
    "far1e3": lambda rng, n: fam_far(rng, n, 1e3),
    "far1e6": lambda rng, n: fam_far(rng, n, 1e6),
    "tiny": fam_tiny,
}


def cases(n_per_family, seed=0, families=None):
    """Yield one :class:`StressCase` per family, each from its own stream of ``seed``."""
    names = list(FAMILIES) if families is None else list(families)
    for i, name in enumerate(names):
        rng = np.random.default_rng([seed, i])
        case = FAMILIES[name](rng, n_per_family)
        case.family = name
        yield case


#: Outcome names, in the order ``classify`` counts them.
OUTCOMES = ("correct", "wrong", "leak", "failed")


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


def classify(hits, origins, directions, vertices, faces, closed, band=1e-6, t_tol=1e-6):
    """Sort a cast's rays into outcomes, decided against every triangle of the scene.

    Parameters
    ----------
    hits : Hits
        The cast under test.
    origins, directions : numpy.ndarray
        The rays as cast (after rounding to the walk's precision).
    vertices, faces : numpy.ndarray
        The scene.
    closed : bool
        Rays start inside a closed surface: a ray without a hit is a leak.
    band : float
        Relative barycentric margin separating "touches" from "pierces" (see
        :func:`brute_bounds`); rounding of the walk's precision belongs inside it.
    t_tol : float
        Tolerance on t relative to the scene diagonal.

    Returns
    -------
    dict
        Counts of :data:`OUTCOMES`: ``failed`` (step guard), ``leak`` (closed family, no hit),
        ``wrong`` (a hit before anything the ray touches, or after a triangle it surely
        pierces, or a miss despite a sure hit), ``correct``.
    """
    diag = float(np.linalg.norm(np.ptp(np.asarray(vertices, np.float64), axis=0)))
    touch, sure = brute_bounds(origins, directions, vertices, faces, band)
    tol = t_tol * diag / np.maximum(np.linalg.norm(np.asarray(directions, np.float64), axis=1), 1e-300)
    failed = hits.status == FAILED
    hit = hits.status == HIT
    leak = ~failed & ~hit & closed
    t = hits.t.astype(np.float64)
    wrong = ~failed & ~leak & np.where(hit, (t < touch - tol) | (t > sure + tol), np.isfinite(sure))
    correct = ~(failed | leak | wrong)
    return {"correct": int(correct.sum()), "wrong": int(wrong.sum()),
            "leak": int(leak.sum()), "failed": int(failed.sum())}
