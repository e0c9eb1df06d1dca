"""fTetWild: one run, the surface recovery that names each face's triangle, and its
neighbours."""

from __future__ import annotations

import time

import numpy as np

from ..errors import MeshingError
from ..progress import stage
from .clean import _box_mesh
from .isolate import _run_stage, _stage_message, _TetGenCrashed, _TetGenFailed
from .types import CleanMesh, _tet_faces, _unique_rows

# --------------------------------------------------------------------------- fTetWild


def ftetwild_available() -> bool:
    """Whether the fTetWild route can run (``pytetwild`` imports)."""
    try:
        _pytetwild()
    except MeshingError:
        return False
    return True


def _pytetwild():
    try:
        import pytetwild
    except ImportError as exc:
        why = (
            "pytetwild >= 0.3 imports pyvista, which is not installed; "
            "pip install 'pytetwild>=0.2.3,<0.3' (or pyvista)"
            if "pyvista" in str(exc)
            else "pip install 'pytetwild>=0.2.3,<0.3'"
        )
        raise MeshingError(f"the fTetWild mesher needs pytetwild: {why} ({exc})") from None
    return pytetwild


def _ftetwild_arrays(vertices, faces, epsilon_rel, edge_abs, threads, stop_energy, optimize):
    """Run fTetWild on a triangle soup, keeping its whole background box (no filtering).

    Its input simplification is off: it merges input triangles into larger surface
    faces, each of which can name only one triangle (on spot, 78% of camera rays then
    named Embree's triangle, against 98% without it and without optimisation).
    """
    pytetwild = _pytetwild()
    try:
        points, tets = pytetwild.tetrahedralize(
            np.ascontiguousarray(vertices, dtype=np.float64),
            np.ascontiguousarray(faces, dtype=np.int32),
            edge_length_abs=float(edge_abs),
            epsilon=float(epsilon_rel),
            stop_energy=float(stop_energy),
            num_threads=int(threads),
            disable_filtering=True,
            quiet=True,
            loglevel=6,
            simplify=False,
            optimize=bool(optimize),
        )
    except (RuntimeError, ValueError, MemoryError) as exc:
        raise _TetGenFailed(str(exc).strip() or type(exc).__name__) from exc
    if len(tets) == 0:
        raise _TetGenFailed("fTetWild produced no tetrahedra")
    return (
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(tets, dtype=np.uint32),
    )


#: Vertices of higher valence add no neighbours in :func:`neighbour_triangles` (a fan of
#: thousands of triangles would add millions of pairs; its triangles keep their edge
#: neighbours through their other vertices).
_MAX_VALENCE = 64


def neighbour_triangles(cm: CleanMesh, n_triangles: int):
    """The caller's triangles that share a vertex with each caller triangle.

    A fTetWild face names the input triangle nearest its centre; a ray crossing the face
    may cross a neighbour of that triangle instead, and the cast then names the neighbour
    it crosses (``alternatives`` of the native scene). Neighbours are found on the
    cleaned mesh (coincident vertices merged), whose faces map to the caller's triangles.

    Returns
    -------
    offsets, ids : numpy.ndarray
        uint32 CSR: the neighbours of caller triangle k are ``ids[offsets[k]:offsets[k+1]]``.
    """
    faces = np.asarray(cm.faces, np.int64)
    caller = np.asarray(cm.triangle_ids, np.int64)
    vert = faces.ravel()
    face = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(vert, kind="stable")
    vert, face = vert[order], face[order]
    starts = np.flatnonzero(np.r_[True, vert[1:] != vert[:-1]]) if len(vert) else vert
    counts = np.diff(np.r_[starts, len(vert)])
    keep = counts <= _MAX_VALENCE
    starts, counts = starts[keep], counts[keep]
    # Every ordered pair of faces around each kept vertex.
    group = np.repeat(np.arange(len(starts)), counts)
    members = np.repeat(starts, counts) + (
        np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    )
    size = counts[group]
    a = np.repeat(members, size)
    first = np.repeat(starts[group], size)
    b = first + (np.arange(size.sum()) - np.repeat(np.cumsum(size) - size, size))
    pairs = np.stack([caller[face[a]], caller[face[b]]], axis=1)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    if len(pairs):
        pairs = np.unique(pairs, axis=0)
    offsets = np.zeros(n_triangles + 1, np.int64)
    np.cumsum(np.bincount(pairs[:, 0], minlength=n_triangles), out=offsets[1:])
    return offsets.astype(np.uint32), np.ascontiguousarray(pairs[:, 1], dtype=np.uint32)


def _point_triangle_distance(p, a, b, c):
    """Distance from points ``p (N, 3)`` to triangles ``(a, b, c)`` (each ``(N, 3)``),
    vectorized (Ericson, Real-Time Collision Detection, 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(invalid="ignore", divide="ignore"):
        # interior by default, then the regions in the reverse order of the book's tests
        den = va + vb + vc
        v, w = vb / den, vc / den
        closest = a + ab * v[:, None] + ac * w[:, None]
        cases = [
            (
                (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),  # edge bc
                b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[:, None],
            ),
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * (d2 / (d2 - d6))[:, None]),  # edge ac
            ((d6 >= 0) & (d5 <= d6), c),  # vertex c
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * (d1 / (d1 - d3))[:, None]),  # edge ab
            ((d3 >= 0) & (d4 <= d3), b),  # vertex b
            ((d1 <= 0) & (d2 <= 0), a),  # vertex a
        ]
    for mask, point in cases:
        closest = np.where(mask[:, None], point, closest)
    return np.linalg.norm(p - closest, axis=1)


def _face_samples(q):
    """Six points on each triangle of ``q (N, 3, 3)`` besides its centroid: the edge
    midpoints and three points halfway between the centroid and a corner; ``(N, 6, 3)``."""
    a, b, c = q[:, 0], q[:, 1], q[:, 2]
    return np.stack(
        [
            (a + b) / 2,
            (b + c) / 2,
            (a + c) / 2,
            (4 * a + b + c) / 6,
            (a + 4 * b + c) / 6,
            (a + b + 4 * c) / 6,
        ],
        axis=1,
    )


#: A tet face near the scene counts as surface only if its normal is within about 8
#: degrees of its nearest triangle's (|cos| >= this). Without fTetWild's optimisation
#: its mesh is fine near the surface, and many faces lie in the envelope without being
#: on the remeshed surface (faces across the layer; on sponza 4.1M of them passed the
#: distance test, 1.1M this one, and the input was covered as well by either set).
SURFACE_MIN_COS = 0.99


# Rows processed at a time in the surface recovery: fTetWild without optimisation
# gives two_cylinder_engine 17M tets, and whole-array temporaries ran out of memory.
_CHUNK = 1 << 21


def _recover_chunk(points, faces, dv, scene_v, scene_f, n_scene, tol):
    """The surface test of :func:`_recover_surface` on candidate faces ``(N, 3)``."""
    import igl

    q = points[faces]
    c2, ci, _ = igl.point_mesh_squared_distance(q.mean(axis=1), scene_v, scene_f)
    dc = np.sqrt(c2)
    nearest = np.asarray(ci, dtype=np.int64)
    nf = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
    t = scene_v[scene_f[nearest]]
    nt = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.abs(np.einsum("ij,ij->i", nf, nt)) / (
            np.linalg.norm(nf, axis=1) * np.linalg.norm(nt, axis=1)
        )
    keep = (dc <= tol) & (nearest < n_scene) & (cos >= SURFACE_MIN_COS)
    faces, q, dc, nearest = faces[keep], q[keep], dc[keep], nearest[keep]
    # Distances to the centroid's triangle bound those to the surface from above, and
    # settle most faces (fTetWild without optimisation keeps pieces of one triangle);
    # only samples farther than tol from it are looked up in the whole scene.
    samples = _face_samples(q).reshape(-1, 3)
    t = np.repeat(scene_v[scene_f[nearest]], 6, axis=0)
    ds = _point_triangle_distance(samples, t[:, 0], t[:, 1], t[:, 2])
    far = np.flatnonzero(~(ds <= tol))
    if len(far):
        s2, _, _ = igl.point_mesh_squared_distance(samples[far], scene_v, scene_f)
        ds[far] = np.sqrt(s2)
    ds = ds.reshape(len(faces), 6)
    on = ds.max(axis=1) <= tol
    dist = np.concatenate([dv[faces], dc[:, None], ds], axis=1)
    return faces[on], nearest[on], dist[on]


def _recover_surface(points, tets, scene_v, scene_f, n_scene, tol):
    """Find the tet faces lying on the remeshed scene surface.

    A face counts when its corners, its centroid and six more points on it (edge
    midpoints, ...) all lie within ``tol`` of the input surface ``(scene_v, scene_f)``,
    and it is nearly parallel to the input triangle nearest to its centroid
    (:data:`SURFACE_MIN_COS`), which is the triangle it names. Faces nearest to an
    input triangle at index ``>= n_scene`` (the domain box added to fTetWild's input)
    are not scene faces. Returns ``(faces (C, 3), nearest (C,), distances (C, 10))``:
    the distances of the three corners, the centroid and the six other points.
    """
    import igl

    d2, _, _ = igl.point_mesh_squared_distance(points, scene_v, scene_f)
    dv = np.sqrt(d2)
    near = dv <= tol
    index = np.int32 if len(points) < 2**31 else np.int64
    candidates = []
    for start in range(0, len(tets), _CHUNK):
        f = _tet_faces(np.asarray(tets[start : start + _CHUNK], dtype=index))
        f = f[near[f].all(axis=1)]
        candidates.append(np.sort(f, axis=1))
    faces = _unique_rows(np.concatenate(candidates)) if candidates else np.zeros((0, 3), index)
    del candidates
    parts = [
        _recover_chunk(
            points, faces[i : i + _CHUNK].astype(np.int64), dv, scene_v, scene_f, n_scene, tol
        )
        for i in range(0, len(faces), _CHUNK)
    ]
    if not parts:
        return np.zeros((0, 3), np.uint32), np.zeros(0, np.int64), np.zeros((0, 10))
    return (
        np.ascontiguousarray(np.concatenate([p[0] for p in parts]), dtype=np.uint32),
        np.concatenate([p[1] for p in parts]),
        np.concatenate([p[2] for p in parts]),
    )


def _surface_distance(points, faces, dist, scene_v, scene_f, diagonal, n_samples=200_000, seed=0):
    """How far the recovered faces and the input surface are from each other (see
    :attr:`Tetrahedralization.surface_distance`)."""
    import igl

    out = dict(diagonal=float(diagonal))
    out["max"] = float(dist.max()) if len(dist) else float("inf")
    out["mean"] = float(dist[:, 3].mean()) if len(dist) else float("inf")
    # Input -> faces: the input's vertices, centroids and area-weighted random points.
    p = scene_v[scene_f]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(p), size=n_samples, p=area / area.sum())
    r = rng.random((n_samples, 2))
    flip = r.sum(axis=1) > 1
    r[flip] = 1 - r[flip]
    tri = p[pick]
    rand = tri[:, 0] + r[:, :1] * (tri[:, 1] - tri[:, 0]) + r[:, 1:] * (tri[:, 2] - tri[:, 0])
    queries = np.concatenate([scene_v, p.mean(axis=1), rand])
    if len(faces):
        d2, _, _ = igl.point_mesh_squared_distance(queries, points, faces.astype(np.int64))
        d = np.sqrt(d2)
        out["input_max"] = float(d.max())
        out["input_mean"] = float(d[-n_samples:].mean())
    else:
        out["input_max"] = out["input_mean"] = float("inf")
    return out


def _ftetwild_route(
    name,
    cm,
    box,
    *,
    contain,
    epsilon,
    edge_length,
    threads,
    stop_energy,
    optimize,
    timeout,
    timings,
    isolate=None,
):
    """The approximate route.

    Returns ``(points, tets, faces, face_triangle, distance, options)``.
    """
    _pytetwild()
    try:
        import igl  # noqa: F401
    except ImportError:
        raise MeshingError(
            "the fTetWild route finds the remeshed surface with libigl (pip install libigl)"
        ) from None
    lo, hi = cm.vertices.min(axis=0), cm.vertices.max(axis=0)
    diagonal = float(np.linalg.norm(hi - lo)) or 1.0
    eps_abs, edge_abs = epsilon * diagonal, edge_length * diagonal
    v, f = cm.vertices, cm.faces
    n_scene = len(f)
    if contain is not None:
        # fTetWild meshes the bounding box of its input (grown by about one edge length):
        # add the domain box as surface so the domain contains the points; its faces are
        # not mapped to triangles.
        corners, box_faces = _box_mesh(box)
        v = np.vstack([v, corners])
        f = np.vstack([f, box_faces + len(cm.vertices)])
    input_diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) or 1.0
    options = dict(
        epsilon=eps_abs,
        edge_length=edge_abs,
        epsilon_rel=epsilon,
        edge_length_rel=edge_length,
        stop_energy=stop_energy,
        threads=threads,
        optimize=bool(optimize),
        simplify=False,
        box_in_input=contain is not None,
    )
    t = time.perf_counter()
    try:
        with stage(f"fTetWild (epsilon {epsilon:g}, edge length {edge_length:g})"):
            points, tets = _run_stage(
                _ftetwild_arrays,
                v,
                f,
                eps_abs / input_diag,
                edge_abs,
                threads,
                stop_energy,
                optimize,
                timeout=timeout,
                isolate=isolate,
            )
    except (_TetGenFailed, _TetGenCrashed) as exc:
        timings["ftetwild"] += time.perf_counter() - t
        raise MeshingError(f"{name}: " + _stage_message("fTetWild", exc, timeout)) from None
    timings["ftetwild"] += time.perf_counter() - t
    t = time.perf_counter()
    # fTetWild keeps its surface within the envelope; 0.1% slack for rounding.
    tol = eps_abs * 1.001
    faces, nearest, dist = _recover_surface(points, tets, v, f.astype(np.int64), n_scene, tol)
    if len(faces) == 0:
        timings["recover"] += time.perf_counter() - t
        raise MeshingError(f"{name}: fTetWild's mesh has no faces within {tol:.3g} of the scene")
    face_triangle = np.ascontiguousarray(cm.triangle_ids[nearest], dtype=np.uint32)
    distance = _surface_distance(points, faces, dist, cm.vertices, cm.faces, diagonal)
    timings["recover"] += time.perf_counter() - t
    return points, tets, faces, face_triangle, distance, options
