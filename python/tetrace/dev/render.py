"""Small numpy helpers for the rendering notebook (``notebooks/rendering.ipynb``).

Sampling (stratified squares, an area light, cosine-weighted hemispheres), Lambert shading,
the ground quad the notebook puts under a mesh, Embree's epsilon offset for secondary rays,
and the tets a ray's segment crosses, computed from the geometry alone. Imports only numpy;
every random draw comes from a ``numpy.random.Generator`` the caller seeds.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ground_quad",
    "facing",
    "stratified",
    "area_light_points",
    "cosine_hemisphere",
    "lambert",
    "offset_origins",
    "segment_tets",
]


def ground_quad(vertices, *, extent=1.5, gap=0.01):
    """A square ground plane under a mesh, wound so its normal points up (+y).

    Parameters
    ----------
    vertices : array_like
        ``(V, 3)`` vertices of the mesh to stand on the ground.
    extent : float, optional
        Half the side of the square, in units of the mesh's largest bounding-box side.
    gap : float, optional
        How far below the mesh's lowest point the plane lies, in units of its height.

    Returns
    -------
    vertices : numpy.ndarray
        ``(4, 3)`` float64 corners.
    faces : numpy.ndarray
        ``(2, 3)`` int64 triangles, counter-clockwise seen from above.
    """
    v = np.asarray(vertices, dtype=np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    size = hi - lo
    cx, cz = (lo[0] + hi[0]) / 2.0, (lo[2] + hi[2]) / 2.0
    y = lo[1] - gap * size[1]
    r = extent * size.max()
    corners = np.array(
        [[cx - r, y, cz - r], [cx + r, y, cz - r], [cx + r, y, cz + r], [cx - r, y, cz + r]]
    )
    return corners, np.array([[0, 2, 1], [0, 3, 2]])


def facing(normals, directions):
    """Flip normals to face against the rays that hit them (two-sided shading).

    Parameters
    ----------
    normals, directions : array_like
        ``(..., 3)`` unit normals of the hit triangles and the directions of the rays that
        hit them (``nan`` normals, from misses, stay ``nan``).

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` float64 normals ``n`` with ``dot(n, direction) <= 0``.
    """
    n = np.asarray(normals, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    s = np.where(np.einsum("...i,...i->...", n, d) > 0.0, -1.0, 1.0)
    return n * s[..., None]


def stratified(k, n, rng):
    """Jittered samples of the unit square: ``k x k`` strata, one sample in each, per pixel.

    Parameters
    ----------
    k : int
        Strata per side: ``k * k`` samples per pixel.
    n : int
        Pixels.
    rng : numpy.random.Generator
        Source of the jitter (seed it for repeatable images).

    Returns
    -------
    numpy.ndarray
        ``(k * k, n, 2)`` float64 points in ``[0, 1)^2``; sample ``s`` of every pixel lies
        in stratum ``(s // k, s % k)``, with its own jitter per pixel.
    """
    i, j = np.divmod(np.arange(k * k), k)
    cell = np.stack([i, j], axis=1).astype(np.float64)[:, None, :]
    return (cell + rng.random((k * k, n, 2))) / k


def area_light_points(corner, edge_u, edge_v, uv):
    """Points on a parallelogram light, ``corner + u * edge_u + v * edge_v``.

    Parameters
    ----------
    corner, edge_u, edge_v : array_like
        ``(3,)`` one corner of the light and its two edges.
    uv : array_like
        ``(..., 2)`` coordinates in ``[0, 1)^2`` (e.g. from :func:`stratified`).

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` float64 points.
    """
    uv = np.asarray(uv, dtype=np.float64)
    corner, edge_u, edge_v = (np.asarray(a, dtype=np.float64) for a in (corner, edge_u, edge_v))
    return corner + uv[..., :1] * edge_u + uv[..., 1:] * edge_v


def _basis(n):
    """Two unit tangents completing each unit normal to an orthonormal frame (Duff et al.
    2017, "Building an orthonormal basis, revisited")."""
    sign = np.where(n[..., 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + n[..., 2])
    b = n[..., 0] * n[..., 1] * a
    t1 = np.stack([1.0 + sign * n[..., 0] ** 2 * a, sign * b, -sign * n[..., 0]], axis=-1)
    t2 = np.stack([b, sign + n[..., 1] ** 2 * a, -n[..., 1]], axis=-1)
    return t1, t2


def cosine_hemisphere(normals, uv):
    """Cosine-weighted directions on the hemisphere about each normal (Malley's method).

    Parameters
    ----------
    normals : array_like
        ``(N, 3)`` unit normals (rows with ``nan`` give ``nan`` directions).
    uv : array_like
        ``(S, N, 2)`` points in ``[0, 1)^2``, e.g. from :func:`stratified`: sample ``s`` of
        pixel ``i`` maps ``uv[s, i]`` to the unit disk (polar map) and lifts it to the
        hemisphere about ``normals[i]``.

    Returns
    -------
    numpy.ndarray
        ``(S, N, 3)`` float64 unit directions, with density ``cos(theta) / pi`` about the
        normal.
    """
    n = np.asarray(normals, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    r = np.sqrt(uv[..., 0])
    phi = 2.0 * np.pi * uv[..., 1]
    x, y = r * np.cos(phi), r * np.sin(phi)
    z = np.sqrt(np.maximum(0.0, 1.0 - uv[..., 0]))
    t1, t2 = _basis(n)
    return x[..., None] * t1 + y[..., None] * t2 + z[..., None] * n


def lambert(normals, points, light, lit, *, albedo=0.8, ambient=0.15, background=1.0):
    """Lambert shading from one point light, with a visibility factor.

    Parameters
    ----------
    normals : array_like
        ``(N, 3)`` unit normals facing the viewer (:func:`facing`); ``nan`` for misses.
    points : array_like
        ``(N, 3)`` shaded points.
    light : array_like
        ``(3,)`` light position.
    lit : array_like
        ``(N,)`` fraction of the light each point sees: ``1`` lit, ``0`` in shadow, in
        between for soft shadows.
    albedo, ambient : float, optional
        Surface reflectance and the light every point receives regardless.
    background : float, optional
        The value where ``normals`` is ``nan`` (rays that missed).

    Returns
    -------
    numpy.ndarray
        ``(N,)`` float64 radiance in ``[0, 1]``, ``background`` where ``normals`` is ``nan``.
    """
    n = np.asarray(normals, dtype=np.float64)
    to_light = np.asarray(light, dtype=np.float64) - np.asarray(points, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        to_light /= np.linalg.norm(to_light, axis=-1, keepdims=True)
        cos = np.clip(np.einsum("...i,...i->...", n, to_light), 0.0, 1.0)
    value = albedo * (ambient + (1.0 - ambient) * cos * np.asarray(lit, dtype=np.float64))
    return np.where(np.isnan(n).any(axis=-1), background, value)


def offset_origins(points, normals, directions, eps):
    """Embree's secondary-ray origins: the hit point pushed ``eps`` along the normal.

    The push goes to the side of the surface the new ray leaves by, so the ray does not
    hit the triangle it starts on again ("shadow acne"). tetrace needs no such offset
    (``start=hits``); this is for the Embree comparison.

    Parameters
    ----------
    points, normals : array_like
        ``(..., 3)`` hit points and their triangles' unit normals.
    directions : array_like
        ``(..., 3)`` directions of the secondary rays.
    eps : float
        Offset, in the scene's units.

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` float64 origins.
    """
    p = np.asarray(points, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    side = np.sign(np.einsum("...i,...i->...", n, np.asarray(directions, dtype=np.float64)))
    return p + eps * side[..., None] * n


def segment_tets(points, tets, origin, direction, tmax=np.inf):
    """The tets a ray's segment passes through, from the geometry alone, in order along it.

    For each tet the segment ``origin + t * direction``, ``0 <= t <= tmax``, is clipped by
    the tet's four face planes (float64); tets where what is left has positive length are
    kept, sorted by where the ray enters them. A ray that slides exactly along a face or
    edge may list either side's tets.

    Parameters
    ----------
    points : array_like
        ``(P, 3)`` points of the tetrahedralization (``Scene.points()``).
    tets : array_like
        ``(T, 4)`` point indices per tet (``Scene.tets()``).
    origin, direction : array_like
        ``(3,)`` the ray.
    tmax : float, optional
        End of the segment (``inf``: the whole ray).

    Returns
    -------
    ids : numpy.ndarray
        ``(K,)`` int64 indices of the tets crossed, in order along the ray.
    t_in, t_out : numpy.ndarray
        ``(K,)`` float64 where the ray enters and leaves each of them.
    """
    p = np.asarray(points, dtype=np.float64)
    tt = np.asarray(tets, dtype=np.int64)
    o = np.asarray(origin, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    lo = np.zeros(len(tt))
    hi = np.full(len(tt), float(tmax))
    for k in range(4):
        # Face opposite vertex k; its normal, oriented towards vertex k, points inside.
        a, b, c = (p[tt[:, (k + m) % 4]] for m in (1, 2, 3))
        n = np.cross(b - a, c - a)
        n *= np.sign(np.einsum("ij,ij->i", n, p[tt[:, k]] - a))[:, None]
        # Inside: n . (o + t d - a) >= 0, i.e. num + t * den >= 0.
        num = np.einsum("ij,ij->i", n, o - a)
        den = n @ d
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -num / den
        enter, leave = den > 0.0, den < 0.0
        lo = np.where(enter, np.maximum(lo, t), lo)
        hi = np.where(leave, np.minimum(hi, t), hi)
        outside = (den == 0.0) & (num < 0.0)
        hi = np.where(outside, -np.inf, hi)
    keep = np.flatnonzero(hi > lo)
    order = np.argsort(lo[keep], kind="stable")
    ids = keep[order]
    return ids, lo[ids], hi[ids]
