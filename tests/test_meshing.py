"""The mesher: loading, cleaning, the domain box, TetGen presets and self-intersection repair.

Nothing here needs the compiled extension (numpy, trimesh, tetgen and libigl only).
Every tetrahedralization is checked by :func:`check_ct`: indices in range, the tets
fill the domain box, every constrained face is a tet face lying inside the caller's
triangle it names, and no box face is reported as constrained.
"""

from __future__ import annotations

import os
import time
from importlib import resources

import numpy as np
import pytest

from tetrace.dev import synthetic
from tetrace.mesh import (
    PRESETS,
    CleanMesh,
    MeshFileNotFoundError,
    MeshingError,
    Tetrahedralization,
    clean,
    count_intersecting_pairs,
    domain_box,
    load_triangles,
    tetgen_options,
    tetrahedralize,
)
from tetrace.mesh.isolate import _call_forked, _TetGenCrashed, _TetGenFailed, _TetGenTimeout

SPOT = resources.files("tetrace").joinpath("data", "spot.obj")
# The two presets of the foundation, run on every synthetic and real scene here; the
# other presets are tested in test_meshers.py.
BASE_PRESETS = ("constrained", "quality")


# --------------------------------------------------------------------------- checks


def tet_volumes(points, tets):
    p = points[tets.astype(np.int64)]
    return (
        np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))
        / 6.0
    )


def face_keys(tri, n):
    """Encode unordered index triples as int64 (n < 2**21)."""
    s = np.sort(tri.astype(np.int64), axis=1)
    return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]


def check_ct(tz: Tetrahedralization, vertices, faces, *, tiles=True):
    """Assert the invariants every tetrahedralization must satisfy.

    ``tiles``: the constrained pieces of each caller triangle cover exactly its area
    (false after a repair, where a piece shared by two overlapping triangles goes to one).
    """
    P, T, C, ft = tz.points, tz.tets, tz.faces, tz.face_triangle
    # dtypes and layout the Rust core relies on
    assert P.dtype == np.float64 and P.ndim == 2 and P.shape[1] == 3 and P.flags.c_contiguous
    assert T.dtype == np.uint32 and T.ndim == 2 and T.shape[1] == 4 and T.flags.c_contiguous
    assert C.dtype == np.uint32 and C.ndim == 2 and C.shape[1] == 3 and C.flags.c_contiguous
    assert ft.dtype == np.uint32 and ft.shape == (len(C),) and ft.flags.c_contiguous
    assert tz.domain.shape == (2, 3)
    assert tz.n_input_triangles == len(faces)
    assert set(tz.timings) >= {"clean", "repair", "tetgen", "total"}
    assert all(v >= 0 for v in tz.timings.values())
    assert len(T) > 0 and len(C) > 0
    assert T.max() < len(P) and C.max() < len(P)
    assert ft.max() < len(faces)
    assert len(np.unique(np.sort(T, axis=1), axis=0)) == len(T), "repeated tets"

    lo, hi = tz.domain
    diag = float(np.linalg.norm(hi - lo))
    # The domain contains the scene, strictly, and every point lies in the domain.
    assert np.all(vertices.min(axis=0) > lo) and np.all(vertices.max(axis=0) < hi)
    assert np.all(P >= lo - 1e-12 * diag) and np.all(P <= hi + 1e-12 * diag)

    # The tets tile the box: no inverted or missing tets.
    vol = tet_volumes(P, T)
    assert np.all(vol > 0) or np.all(vol < 0), "tets are not consistently oriented"
    np.testing.assert_allclose(np.abs(vol).sum(), np.prod(hi - lo), rtol=1e-9)

    # Every constrained face is a face of some tet.
    tet_faces = np.concatenate([T[:, [1, 2, 3]], T[:, [0, 2, 3]], T[:, [0, 1, 3]], T[:, [0, 1, 2]]])
    assert np.isin(face_keys(C, len(P)), face_keys(tet_faces, len(P))).all()

    # No box face: a box face has its three points on one side of the box.
    q = P[C.astype(np.int64)]
    for axis in range(3):
        for side in (lo, hi):
            assert not np.any(np.all(q[:, :, axis] == side[axis], axis=1)), (
                "a box face is constrained"
            )

    # Each piece lies on the plane of its caller triangle and inside it; after snap
    # rounding, within the distance the snapping moved the vertices.
    tol = 1e-9 * diag + tz.snap * np.sqrt(3)
    tri = vertices[faces[ft.astype(np.int64)]]
    a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    normal = np.cross(e1, e2)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    d = q - a[:, None, :]
    dist = np.abs(np.einsum("cij,cj->ci", d, normal))
    assert dist.max() <= tol, f"piece off its triangle's plane by {dist.max():.3g}"
    tmin, tmax = tri.min(axis=1), tri.max(axis=1)
    assert np.all(q >= tmin[:, None, :] - tol) and np.all(q <= tmax[:, None, :] + tol)
    d00, d01, d11 = (np.einsum("ij,ij->i", x, y) for x, y in ((e1, e1), (e1, e2), (e2, e2)))
    d20 = np.einsum("cij,cj->ci", d, e1)
    d21 = np.einsum("cij,cj->ci", d, e2)
    den = (d00 * d11 - d01 * d01)[:, None]
    v = (d11[:, None] * d20 - d01[:, None] * d21) / den
    w = (d00[:, None] * d21 - d01[:, None] * d20) / den
    if tz.snap == 0:
        assert min(v.min(), w.min(), (1 - v - w).min()) >= -1e-9, "piece outside its triangle"
    else:
        # barycentric times (twice the area / edge length): distance to that edge's line
        area2 = np.linalg.norm(np.cross(e1, e2), axis=1)[:, None]
        for bary, edge in ((1 - v - w, tri[:, 2] - tri[:, 1]), (v, e2), (w, e1)):
            out = bary * area2 / np.linalg.norm(edge, axis=1)[:, None]
            assert out.min() >= -tol, f"piece outside its triangle by {-out.min():.3g}"

    if tiles:
        # The pieces of each triangle add up to its area (no gaps, overlaps or strays).
        piece = 0.5 * np.linalg.norm(np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]), axis=1)
        total = np.bincount(ft, weights=piece, minlength=len(faces))
        ids = tz.clean.triangle_ids
        area = 0.5 * np.linalg.norm(
            np.cross(*(vertices[faces[ids]][:, k] - vertices[faces[ids]][:, 0] for k in (1, 2))),
            axis=1,
        )
        np.testing.assert_allclose(total[ids], area, rtol=1e-9, atol=1e-12 * diag**2)

    # Every triangle TetGen was given shows up, under the caller's id.
    assert set(np.unique(ft).tolist()) <= set(tz.clean.triangle_ids.tolist())
    if tiles:
        assert set(np.unique(ft).tolist()) == set(tz.clean.triangle_ids.tolist())


# --------------------------------------------------------------------------- spot (bundled)


@pytest.fixture(scope="module")
def spot():
    return load_triangles(str(SPOT))


@pytest.fixture(scope="module", params=BASE_PRESETS)
def spot_ct(request, spot):
    return tetrahedralize(spot, request.param)


def test_spot_ct_is_valid(spot_ct, spot):
    vertices, faces = spot
    check_ct(spot_ct, vertices, faces)
    assert not spot_ct.repaired
    # spot has no degenerate triangles: every caller triangle is constrained.
    assert np.array_equal(np.unique(spot_ct.face_triangle), np.arange(len(faces)))
    # the scene's vertices are points of the tetrahedralization, bit for bit
    assert set(map(tuple, vertices.tolist())) <= set(map(tuple, spot_ct.points.tolist()))


def test_spot_presets_differ(spot):
    constrained = tetrahedralize(spot, "constrained")
    quality = tetrahedralize(spot, "quality")
    assert constrained.preset == "constrained" and quality.preset == "quality"
    # no refinement: the constrained faces are exactly the cleaned triangles
    assert len(constrained.faces) == len(constrained.clean.faces)
    assert len(constrained.points) == len(constrained.clean.vertices) + 8
    # refinement adds Steiner points, off the surface only (TetGen -Y keeps triangles whole)
    assert len(quality.points) > len(constrained.points)
    assert len(quality.faces) == len(constrained.faces) == len(quality.clean.faces)
    assert len(quality.tets) != len(constrained.tets)


def test_spot_from_path_and_trimesh(spot):
    import trimesh

    from_path = tetrahedralize(SPOT, "constrained")
    from_mesh = tetrahedralize(trimesh.load(str(SPOT), force="mesh"), "constrained")
    from_arrays = tetrahedralize(spot, "constrained")
    assert len(from_path.tets) == len(from_mesh.tets) == len(from_arrays.tets)
    assert np.array_equal(from_path.face_triangle, from_arrays.face_triangle)


# --------------------------------------------------------------------------- loading


def test_load_triangles_as_given():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0]], dtype=np.float32)
    f = np.array([[0, 1, 2], [0, 3, 2], [0, 1, 1]], dtype=np.uint16)
    vertices, faces = load_triangles((v, f))
    assert vertices.dtype == np.float64 and vertices.flags.c_contiguous and vertices.shape == (4, 3)
    assert faces.dtype == np.int64 and np.array_equal(faces, f)  # nothing merged or dropped
    vertices, faces = load_triangles([v.tolist(), f.tolist()])
    assert faces.shape == (3, 3)


@pytest.mark.parametrize(
    "vertices, faces, exc, match",
    [
        (np.zeros((3, 3)), np.zeros((0, 3), np.int64), MeshingError, "no faces"),
        (
            [[0, 0, 0], [1, 0, 0], [0, np.nan, 0], [np.inf, 0, 0]],
            [[0, 1, 2]],
            MeshingError,
            r"2 of 4 vertices have non-finite",
        ),
        (np.eye(3), [[0, 1, 3]], MeshingError, "out of range.*largest index 3.*3 vertices"),
        (np.eye(3), [[0, -1, 2]], MeshingError, "negative vertex indices"),
        (np.eye(3), [[0.0, 1.0, 2.0]], TypeError, "faces must be integers"),
        (np.eye(3), [[0, 1, 2, 0]], MeshingError, r"faces must have shape \(F, 3\)"),
        (np.ones((3, 2)), [[0, 1, 2]], MeshingError, r"vertices must have shape \(V, 3\)"),
        (np.array([["a", "b", "c"]] * 3), [[0, 1, 2]], TypeError, "vertices must be real numbers"),
    ],
    ids=["empty", "nan", "out-of-range", "negative", "float-faces", "quads", "2d-vertices", "str"],
)
def test_bad_input(vertices, faces, exc, match):
    with pytest.raises(exc, match=match):
        load_triangles((vertices, faces))
    # tetrahedralize validates the same way before doing anything
    with pytest.raises(exc, match=match):
        tetrahedralize((vertices, faces))


def test_bad_mesh_argument(tmp_path):
    with pytest.raises(TypeError, match="trimesh.Trimesh, a path, a"):
        load_triangles(42)
    missing = tmp_path / "nope.obj"
    with pytest.raises(MeshFileNotFoundError, match="not found"):
        load_triangles(missing)
    with pytest.raises(FileNotFoundError):  # also a FileNotFoundError
        tetrahedralize(str(missing))
    bad = tmp_path / "mesh.notaformat"
    bad.write_text("garbage")
    with pytest.raises(MeshingError, match="could not load mesh file"):
        load_triangles(bad)
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing\n")
    with pytest.raises(MeshingError, match="could not load|no faces"):
        load_triangles(empty)


def test_all_degenerate_scene():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], dtype=float)
    with pytest.raises(MeshingError, match="all 2 triangles are degenerate"):
        tetrahedralize((v, [[0, 1, 2], [1, 2, 3]]))


def test_bad_options():
    cube = synthetic.cube()
    with pytest.raises(ValueError, match="unknown preset"):
        tetrahedralize(cube, "fast")
    with pytest.raises(ValueError, match="margin must be a positive"):
        tetrahedralize(cube, margin=0)
    with pytest.raises(ValueError, match="minratio"):
        tetrahedralize(cube, minratio=1.0)
    with pytest.raises(ValueError, match="maxvolume"):
        tetrahedralize(cube, maxvolume=-1)
    with pytest.raises(ValueError, match="repair must be"):
        tetrahedralize(cube, repair="yes")


# --------------------------------------------------------------------------- cleaning


def test_clean_counts_and_ids():
    v = np.array(
        [
            [0, 0, 0],  # 0
            [1, 0, 0],  # 1
            [0, 1, 0],  # 2
            [0, 0, 1],  # 3
            [1, 0, 0],  # 4: duplicate of 1
            [2, 0, 0],  # 5: on the line through 0 and 1
            [-0.0, 1, 0],  # 6: duplicate of 2 (negative zero)
        ],
        dtype=float,
    )
    f = np.array(
        [
            [0, 1, 2],  # 0 kept
            [0, 4, 3],  # 1 kept (uses the duplicate vertex)
            [0, 1, 5],  # 2 zero area (collinear)
            [6, 1, 0],  # 3 duplicate of 0, reversed winding, through vertex 6
            [1, 4, 2],  # 4 repeats a vertex after merging
            [1, 2, 3],  # 5 kept
            [0, 3, 4],  # 6 duplicate of 1 (same vertices, other order)
        ]
    )
    cm = clean(v, f)
    assert isinstance(cm, CleanMesh)
    assert cm.dropped_degenerate == 2
    assert cm.dropped_duplicate == 2
    assert cm.triangle_ids.dtype == np.int64 and cm.triangle_ids.tolist() == [0, 1, 5]
    assert cm.faces.dtype == np.int64 and cm.faces.shape == (3, 3)
    assert len(cm.vertices) == 4  # merged, and vertex 5 (only in a dropped face) removed
    assert len(np.unique(cm.vertices, axis=0)) == 4
    # each kept face has the caller's triangle's coordinates, corner for corner
    assert np.array_equal(cm.vertices[cm.faces], v[f[cm.triangle_ids]] + 0.0)


def test_clean_area_threshold():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5], [6, 5, 5], [5.5, 5 + 1e-9, 5]])
    f = np.array([[0, 1, 2], [3, 4, 5]])  # the second is a sliver, area 5e-10 vs 0.5
    assert clean(v, f).triangle_ids.tolist() == [0, 1]
    cm = clean(v, f, area_eps=1e-6)
    assert cm.triangle_ids.tolist() == [0] and cm.dropped_degenerate == 1


# --------------------------------------------------------------------------- domain


def test_domain_box_contains_points():
    v, _ = synthetic.cube()
    box = domain_box(v, margin=0.1)
    pad = 0.1 * np.sqrt(3)
    np.testing.assert_allclose(box, [[-pad] * 3, [1 + pad] * 3])
    contain = np.array([[5.0, 0.5, 0.5], [0.5, -3.0, 0.5]])
    box = domain_box(v, margin=0.1, contain=contain)
    assert np.all(box[0] < contain.min(axis=0)) and np.all(box[1] > contain.max(axis=0))
    np.testing.assert_allclose(box, [[-pad, -3 - pad, -pad], [5 + pad, 1 + pad, 1 + pad]])
    # a single point and an empty array are accepted too
    assert np.all(domain_box(v, contain=[0.5, 9.0, 0.5])[1, 1] > 9.0)
    np.testing.assert_array_equal(domain_box(v, contain=np.zeros((0, 3))), domain_box(v))
    with pytest.raises(ValueError, match="finite"):
        domain_box(v, contain=[[np.nan, 0, 0]])


def test_domain_box_flat_scene():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)
    box = domain_box(v)
    assert np.all(box[1] - box[0] > 0)
    assert box[0, 2] < 0 < box[1, 2]
    tz = tetrahedralize((v, [[0, 1, 2]]), "constrained")
    check_ct(tz, v, np.array([[0, 1, 2]]))


def test_tetrahedralize_contain():
    v, f = synthetic.cube()
    eye = np.array([[4.0, 3.0, -2.0]])
    tz = tetrahedralize((v, f), "constrained", contain=eye)
    assert np.all(tz.domain[0] < eye[0]) and np.all(tz.domain[1] > eye[0])
    check_ct(tz, v, f)


# --------------------------------------------------------------------------- synthetic scenes


@pytest.mark.parametrize("preset", BASE_PRESETS)
@pytest.mark.parametrize("builder", ["cube", "thin_plate", "nested_spheres", "torus_knot"])
def test_synthetic_scene(builder, preset):
    vertices, faces = getattr(synthetic, builder)()
    assert count_intersecting_pairs(vertices, faces) == 0  # valid PLCs as built
    t0 = time.perf_counter()
    tz = tetrahedralize((vertices, faces), preset)
    assert time.perf_counter() - t0 < 20
    assert not tz.repaired
    check_ct(tz, vertices, faces)
    assert np.array_equal(np.unique(tz.face_triangle), np.arange(len(faces)))


def test_synthetic_shapes():
    for name in synthetic.__all__:
        v, f = getattr(synthetic, name)()
        assert (
            v.dtype == np.float64 and f.dtype == np.int64 and f.shape[1] == 3 and f.max() < len(v)
        )
    import trimesh

    knot = trimesh.Trimesh(*synthetic.torus_knot(), process=False)
    assert knot.is_watertight and knot.volume > 0
    v, _ = synthetic.thin_plate()
    size = v.max(axis=0) - v.min(axis=0)
    assert size[2] == pytest.approx(1e-3 * size[0])
    assert len(trimesh.Trimesh(*synthetic.nested_spheres(), process=False).split()) == 2


def test_touching_boxes_need_repair():
    vertices, faces = synthetic.touching_boxes()
    n = count_intersecting_pairs(vertices, faces)
    assert n > 0  # coplanar overlapping sides: not a PLC as given
    with pytest.raises(MeshingError, match=rf"{n} pairs of triangles intersect.*repair="):
        tetrahedralize((vertices, faces), repair=False)
    for preset in BASE_PRESETS:
        tz = tetrahedralize((vertices, faces), preset)  # repair="auto"
        assert tz.repaired
        assert count_intersecting_pairs(tz.clean.vertices, tz.clean.faces) == 0
        check_ct(tz, vertices, faces, tiles=False)
        # every caller triangle keeps at least a piece: none lies inside another
        assert np.array_equal(np.unique(tz.face_triangle), np.arange(len(faces)))
        # the overlap of the two x = 1 sides went to box A's triangles (lower ids)
        q = tz.points[tz.faces.astype(np.int64)]
        on_overlap = (
            np.all(q[:, :, 0] == 1.0, axis=1)
            & np.all(q[:, :, 1:] >= 0.25, axis=(1, 2))
            & np.all(q[:, :, 1:] <= 1.0, axis=(1, 2))
        )
        assert on_overlap.any() and set(tz.face_triangle[on_overlap].tolist()) <= {2, 3}


def test_repair_true_on_valid_scene():
    vertices, faces = synthetic.cube()
    tz = tetrahedralize((vertices, faces), "constrained", repair=True)
    assert tz.repaired
    check_ct(tz, vertices, faces)


def test_options():
    vertices, faces = synthetic.cube()
    plain = tetrahedralize((vertices, faces), "constrained")
    refined = tetrahedralize((vertices, faces), "constrained", minratio=1.2)
    # The bound reaches TetGen; a cube whose faces stay whole (-Y) has nothing to refine.
    assert refined.options["quality"] and refined.options["minratio"] == 1.2
    assert not plain.options["quality"]
    assert len(refined.tets) >= len(plain.tets)
    small = tetrahedralize((vertices, faces), "constrained", maxvolume=1e-3)
    check_ct(small, vertices, faces)
    vol = np.abs(tet_volumes(small.points, small.tets))
    # TetGen's mesh optimisation after refinement may exceed the bound a little
    assert len(small.tets) > 500 and vol.max() < 2e-3
    opts = tetgen_options("quality", n_vertices=10**6)
    assert opts["quality"] and opts["minratio"] == PRESETS["quality"]["minratio"]
    assert opts["steinerleft"] >= 10**6 and opts["brio_hilbert"]
    assert tetgen_options("constrained")["steinerleft"] == -1


# --------------------------------------------------------------------------- TetGen isolation


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_forked_call():
    assert _call_forked(np.add, 1, 2) == 3
    with pytest.raises(_TetGenCrashed, match="SIGABRT"):
        _call_forked(os.abort)

    def fail():
        raise _TetGenFailed("The input surface mesh contain self-intersections.")

    with pytest.raises(_TetGenFailed, match="self-intersections"):
        _call_forked(fail)
    with pytest.raises(_TetGenFailed, match="ZeroDivisionError"):
        _call_forked(lambda: 1 / 0)
    t0 = time.perf_counter()
    with pytest.raises(_TetGenTimeout, match="stopped after 0.5 s"):
        _call_forked(time.sleep, 30, timeout=0.5)
    assert time.perf_counter() - t0 < 10
    # large results come back whole
    big = _call_forked(np.arange, 5_000_000, timeout=60)
    assert len(big) == 5_000_000 and big[-1] == 4_999_999


# --------------------------------------------------------------------------- real scenes


def test_cornell_box_is_repaired(scene_path):
    path = scene_path("cornell_box.obj")
    vertices, faces = load_triangles(path)
    cm = clean(vertices, faces)
    assert count_intersecting_pairs(cm.vertices, cm.faces) > 0
    with pytest.raises(MeshingError, match="intersect"):
        tetrahedralize(path, repair=False)
    for preset in BASE_PRESETS:
        tz = tetrahedralize(path, preset)
        assert tz.repaired
        check_ct(tz, vertices, faces, tiles=False)
        assert np.all(tz.face_triangle < len(faces))
        # the block footprints lie on the floor; every other triangle keeps pieces
        assert len(np.unique(tz.face_triangle)) >= len(faces) - 4


@pytest.mark.parametrize(
    "name, preset",
    [("bunny.obj", "quality"), ("torus_knots_27.obj", "quality"), ("bunny.obj", "constrained")],
)
def test_real_scene_builds(scene_path, name, preset):
    path = scene_path(name)
    vertices, faces = load_triangles(path)
    t0 = time.perf_counter()
    tz = tetrahedralize((vertices, faces), preset)
    elapsed = time.perf_counter() - t0
    print(
        f"{name} {preset}: {len(tz.tets)} tets, {len(tz.points)} points, {elapsed:.2f} s, "
        f"{tz.timings}"
    )
    assert not tz.repaired
    assert elapsed < 120
    check_ct(tz, vertices, faces)
    assert len(np.unique(tz.face_triangle)) == len(faces)
