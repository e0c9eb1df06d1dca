"""The Embree reference, the Hits container and the ray generators.

Nothing here needs the compiled extension: only numpy, trimesh and embreex.
"""

from __future__ import annotations

import numpy as np
import pytest

from tetrace.baselines.embree import embree_cast, embree_scene, load_triangles
from tetrace.dev.camera import orbit_views, pinhole, random_rays
from tetrace.dev.image import depth_image, save_png, shade
from tetrace.hits import FAILED, HIT, MISS, Hits

# Unit cube [0, 1]^3. Vertex index = 4x + 2y + z.
CUBE_VERTICES = np.array(
    [[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=np.float64
)
CUBE_FACES = np.array(
    [
        [0, 1, 3],
        [0, 3, 2],  # 0, 1: x = 0 (0 where z > y, 1 where y > z)
        [4, 6, 7],
        [4, 7, 5],  # 2, 3: x = 1 (2 where y > z, 3 where z > y)
        [0, 4, 5],
        [0, 5, 1],  # 4, 5: y = 0
        [2, 3, 7],
        [2, 7, 6],  # 6, 7: y = 1 (6 where z > x, 7 where x > z)
        [0, 2, 6],
        [0, 6, 4],  # 8, 9: z = 0
        [1, 5, 7],
        [1, 7, 3],  # 10, 11: z = 1 (10 where x > y, 11 where y > x)
    ],
    dtype=np.int64,
)
CUBE = (CUBE_VERTICES, CUBE_FACES)

# origin, direction, expected (t, triangle, u, v) or None for a miss
CUBE_RAYS = [
    ((-1.0, 0.2, 0.7), (1.0, 0.0, 0.0), (1.0, 0, 0.5, 0.2)),
    ((0.7, 0.2, 0.5), (0.0, 0.0, 1.0), (0.5, 10, 0.5, 0.2)),  # from inside
    ((0.25, 3.0, 0.6), (0.0, -2.0, 0.0), (1.0, 6, 0.35, 0.25)),  # non-unit direction
    ((-1.0, 2.0, 0.5), (1.0, 0.0, 0.0), None),  # passes above
    ((-1.0, 0.5, 0.5), (-1.0, 0.0, 0.0), None),  # points away
]


def cube_rays(dtype=np.float64):
    origins = np.array([r[0] for r in CUBE_RAYS], dtype=dtype)
    directions = np.array([r[1] for r in CUBE_RAYS], dtype=dtype)
    return origins, directions


def barycentric_point(vertices, faces, hits):
    tri = vertices[faces[hits.triangle]]
    u, v = hits.u[:, None], hits.v[:, None]
    return (1 - u - v) * tri[:, 0] + u * tri[:, 1] + v * tri[:, 2]


# --- Embree reference ------------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_cube_known_hits(embree, dtype):
    origins, directions = cube_rays(dtype)
    hits = embree_cast(CUBE, origins, directions)
    assert len(hits) == len(CUBE_RAYS)
    for dt_name in ("t", "u", "v", "point"):
        assert getattr(hits, dt_name).dtype == dtype
    assert hits.triangle.dtype == np.int32 and hits.tet.dtype == np.int32
    assert hits.steps.dtype == np.uint32 and hits.status.dtype == np.uint8
    for i, (o, d, want) in enumerate(CUBE_RAYS):
        if want is None:
            assert hits.status[i] == MISS
            continue
        t, tri, u, v = want
        assert hits.status[i] == HIT
        assert hits.triangle[i] == tri
        np.testing.assert_allclose(hits.t[i], t, rtol=1e-6)
        np.testing.assert_allclose([hits.u[i], hits.v[i]], [u, v], atol=1e-6)
        np.testing.assert_allclose(hits.point[i], np.add(o, t * np.asarray(d)), atol=1e-6)
    np.testing.assert_array_equal(hits.tet, -1)
    np.testing.assert_array_equal(hits.steps, 0)


def test_misses_report_sentinels(embree):
    origins, directions = cube_rays()
    hits = embree_cast(CUBE, origins, directions)
    miss = ~hits.hit
    assert miss.sum() == 2
    assert np.all(np.isinf(hits.t[miss])) and np.all(hits.t[miss] > 0)
    np.testing.assert_array_equal(hits.triangle[miss], -1)
    assert np.all(np.isnan(hits.u[miss])) and np.all(np.isnan(hits.v[miss]))
    assert np.all(np.isnan(hits.point[miss]))
    summary = hits.summary()
    assert (summary["rays"], summary["hit"], summary["miss"], summary["failed"]) == (5, 3, 2, 0)
    assert summary["mean_steps"] == 0.0


def test_uv_convention_on_skewed_triangle(embree):
    """Embree's (u, v) weight p1 and p2: point = (1-u-v) p0 + u p1 + v p2."""
    rng = np.random.default_rng(7)
    tri = np.array([[0.1, -0.3, 0.2], [1.7, 0.4, -0.1], [0.3, 1.2, 0.9]])
    n = 500
    w = rng.dirichlet([1.0, 1.0, 1.0], size=n) * 0.98 + 0.02 / 3  # stay off the edges
    targets = w @ tri
    normal = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    normal /= np.linalg.norm(normal)
    # both sides, never grazing: at least ~60 degrees from the plane
    directions = np.sign(rng.standard_normal((n, 1))) * normal + 0.5 * rng.uniform(-1, 1, (n, 3))
    origins = targets - 3.0 * directions
    hits = embree_cast((tri, [[0, 1, 2]]), origins, directions)
    assert hits.hit.all()
    np.testing.assert_allclose(hits.t, 3.0, rtol=1e-4)
    np.testing.assert_allclose(hits.u, w[:, 1], atol=1e-4)
    np.testing.assert_allclose(hits.v, w[:, 2], atol=1e-4)
    np.testing.assert_allclose(hits.point, targets, atol=1e-4)


def test_uv_matches_point_on_cube(embree):
    origins, _ = random_rays(np.array([[0, 0, 0], [1, 1, 1.0]]), 2000, seed=3, grow=1.0)
    targets = np.random.default_rng(4).random((2000, 3))
    hits = embree_cast(CUBE, origins, targets - origins)  # every ray crosses the cube
    assert hits.hit.all()
    h = hits.hit
    sub = Hits(
        *(
            getattr(hits, f)[h]
            for f in ("t", "triangle", "u", "v", "point", "tet", "steps", "status")
        )
    )
    np.testing.assert_allclose(
        barycentric_point(CUBE_VERTICES, CUBE_FACES, sub), sub.point, atol=1e-5
    )


def test_tmax_and_tmin(embree):
    o, d = np.array([[-1.0, 0.2, 0.7]]), np.array([[1.0, 0.0, 0.0]])
    assert embree_cast(CUBE, o, d, tmax=0.9).status[0] == MISS
    assert embree_cast(CUBE, o, d, tmax=1.1).triangle[0] == 0
    far = embree_cast(CUBE, o, d, tmin=1.5)  # skips the near face, hits x = 1
    assert far.triangle[0] == 3
    np.testing.assert_allclose(far.t[0], 2.0, rtol=1e-6)
    np.testing.assert_allclose(far.point[0], [1.0, 0.2, 0.7], atol=1e-6)
    np.testing.assert_allclose([far.u[0], far.v[0]], [0.2, 0.5], atol=1e-6)
    assert embree_cast(CUBE, o, d, tmin=2.5).status[0] == MISS
    assert embree_cast(CUBE, o, d, tmin=1.0, tmax=0.5).status[0] == MISS
    # per-ray limits
    origins, directions = cube_rays()
    hits = embree_cast(CUBE, origins, directions, tmax=np.array([0.5, 1.0, 1.0, 9.0, 9.0]))
    np.testing.assert_array_equal(hits.status, [MISS, HIT, HIT, MISS, MISS])


def test_ray_forms_agree(embree, tmp_path):
    origins, directions = cube_rays()
    base = embree_cast(CUBE, origins, directions)
    six = embree_cast(CUBE, np.hstack([origins, directions]))
    for f in ("t", "triangle", "u", "v", "status"):
        np.testing.assert_array_equal(getattr(six, f), getattr(base, f))
    # one direction for every ray
    one = embree_cast(
        CUBE, origins[:1].repeat(3, axis=0) + [[0, 0, 0], [0, 0.1, 0], [0, 0.2, 0]], (1, 0, 0)
    )
    assert one.hit.all()
    # a trimesh.Trimesh and a file path give the caller's face ids too
    import trimesh  # a dependency of tetrace: no skip

    mesh = trimesh.Trimesh(CUBE_VERTICES, CUBE_FACES, process=False)
    np.testing.assert_array_equal(embree_cast(mesh, origins, directions).triangle, base.triangle)
    path = tmp_path / "cube.ply"
    mesh.export(path)
    np.testing.assert_array_equal(embree_cast(path, origins, directions).triangle, base.triangle)
    with pytest.raises(ValueError):
        embree_cast(CUBE, origins)  # (N, 3) without directions


def test_degenerate_triangles_keep_caller_ids(embree):
    faces = np.vstack([[[0, 0, 1], [1, 1, 1]], CUBE_FACES])  # two zero-area triangles first
    origins, directions = cube_rays()
    hits = embree_cast((CUBE_VERTICES, faces), origins, directions)
    base = embree_cast(CUBE, origins, directions)
    np.testing.assert_array_equal(hits.triangle[base.hit], base.triangle[base.hit] + 2)


def test_scene_reuse_and_threads(embree):
    scene = embree_scene(CUBE)
    assert scene.n_triangles == 12 and scene.build_seconds >= 0 and scene.robust
    origins, directions = random_rays(np.array([[0, 0, 0], [1, 1, 1.0]]), 70_000, seed=11, grow=0.0)
    one = scene.cast(origins, directions, threads=1)
    many = scene.cast(origins, directions, threads=3)
    for f in ("t", "triangle", "u", "v", "status"):
        np.testing.assert_array_equal(getattr(one, f), getattr(many, f))
    assert one.hit.all()  # every origin is inside the closed cube
    empty = scene.cast(np.zeros((0, 3)), np.zeros((0, 3)))
    assert len(empty) == 0


def test_load_triangles_rejects_bad_input():
    with pytest.raises(ValueError):
        load_triangles((CUBE_VERTICES, [[0, 1, 99]]))
    with pytest.raises(TypeError):
        load_triangles(42)
    with pytest.raises(FileNotFoundError):
        load_triangles("/nonexistent/mesh.obj")


# --- Hits -----------------------------------------------------------------------


def test_hits_container():
    h = Hits.misses(4)
    assert len(h) == 4 and not h.hit.any()
    status = np.array([HIT, MISS, FAILED, HIT], dtype=np.uint8)
    h2 = Hits(h.t, h.triangle, h.u, h.v, h.point, h.tet, np.array([3, 1, 9, 3], np.uint32), status)
    summary = h2.summary()
    assert (summary["rays"], summary["hit"], summary["miss"], summary["failed"]) == (4, 2, 1, 1)
    assert summary["mean_steps"] == 4.0
    assert repr(h2) == "Hits(N=4, hits=2, misses=1, failed=1)"
    np.testing.assert_array_equal(h2.hit, [True, False, False, True])
    with pytest.raises(ValueError):
        Hits(h.t, h.triangle[:3], h.u, h.v, h.point, h.tet, h.steps, h.status)
    assert Hits.misses(0).summary()["mean_steps"] == 0.0


# --- camera -----------------------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_pinhole_shapes_and_orientation(dtype):
    eye, target = np.array([0.0, 0.0, 5.0]), np.zeros(3)
    w, h = 7, 5
    origins, dirs = pinhole(eye, target, fov_deg=60.0, width=w, height=h, dtype=dtype)
    assert origins.shape == dirs.shape == (w * h, 3)
    assert origins.dtype == dirs.dtype == dtype
    np.testing.assert_allclose(origins, np.broadcast_to(eye, origins.shape))
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, atol=1e-6)
    grid = dirs.reshape(h, w, 3)
    np.testing.assert_allclose(
        grid[h // 2, w // 2], [0, 0, -1], atol=1e-6
    )  # centre looks at target
    assert np.all(grid[0, :, 1] > 0) and np.all(grid[-1, :, 1] < 0)  # row 0 is the top
    assert np.all(grid[:, 0, 0] < 0) and np.all(grid[:, -1, 0] > 0)  # column 0 is the left
    # top-centre pixel centre sits half a pixel inside the vertical field of view
    angle = np.degrees(np.arccos(-grid[0, w // 2, 2]))
    np.testing.assert_allclose(
        angle, np.degrees(np.arctan((1 - 1 / h) * np.tan(np.radians(30)))), atol=1e-4
    )
    with pytest.raises(ValueError):
        pinhole(eye, target, up=(0, 0, 1))


def test_orbit_views_and_render(embree, tmp_path):
    bounds = np.array([[0, 0, 0], [1, 1, 1.0]])
    views = orbit_views(bounds, n=4, distance=2.5)
    assert len(views) == 4
    radius = 0.5 * np.sqrt(3)
    dirs = []
    for eye, target, _up in views:
        np.testing.assert_allclose(target, 0.5)
        np.testing.assert_allclose(np.linalg.norm(eye - target), 2.5 * radius)
        dirs.append((eye - target) / np.linalg.norm(eye - target))
    dirs = np.array(dirs)
    assert np.all(np.abs(dirs @ dirs.T - np.eye(4)) < 0.99)  # pairwise distinct
    w, h = 33, 31
    origins, directions = pinhole(*views[0], width=w, height=h)
    hits = embree_cast(CUBE, origins, directions)
    depth = depth_image(hits, w, h)
    assert depth.shape == (h, w)
    assert np.isfinite(depth[h // 2, w // 2]) and np.isnan(depth[0, 0])
    grey = shade(hits, directions, w, h)
    assert grey[0, 0] == 0.0 and 0.2 <= grey[h // 2, w // 2] <= 1.0
    png = save_png(tmp_path / "out" / "depth.png", depth, cmap="inferno")
    from PIL import Image

    img = np.asarray(Image.open(png))
    assert img.shape == (h, w, 3)
    assert img[0, 0].sum() == 0 and img[h // 2, w // 2].sum() > 0
    save_png(tmp_path / "shade.png", grey, cmap="gray", vmin=0.0, vmax=1.0)


def test_random_rays():
    bounds = np.array([[-1.0, 0.0, 2.0], [1.0, 4.0, 3.0]])
    o1, d1 = random_rays(bounds, 1000, seed=5)
    o2, d2 = random_rays(bounds, 1000, seed=5)
    o3, _ = random_rays(bounds, 1000, seed=6)
    np.testing.assert_array_equal(o1, o2)
    np.testing.assert_array_equal(d1, d2)
    assert not np.array_equal(o1, o3)
    assert o1.shape == d1.shape == (1000, 3) and o1.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(d1, axis=1), 1.0, atol=1e-12)
    size = bounds[1] - bounds[0]
    assert np.all(o1 >= bounds[0] - 0.25 * size) and np.all(o1 <= bounds[1] + 0.25 * size)
    assert np.any(o1 < bounds[0]) and np.any(o1 > bounds[1])  # the box is grown
    inner, _ = random_rays(bounds, 1000, seed=5, grow=0.0, dtype=np.float32)
    assert inner.dtype == np.float32
    assert np.all(inner >= bounds[0]) and np.all(inner <= bounds[1])
    assert np.all(np.abs(d1.mean(axis=0)) < 0.1)  # roughly isotropic


def test_invalid_rays_are_marked(embree):
    from tetrace.hits import INVALID

    origins, directions = cube_rays(np.float32)
    origins[1, 0] = np.nan
    directions[2] = 0.0
    before = (origins.copy(), directions.copy())
    hits = embree_cast(CUBE, origins, directions)
    np.testing.assert_array_equal(hits.status, [HIT, INVALID, INVALID, MISS, MISS])
    np.testing.assert_array_equal(hits.triangle, [0, -1, -1, -1, -1])
    assert np.isinf(hits.t[1:3]).all() and np.isnan(hits.u[1:3]).all()
    np.testing.assert_array_equal(origins, before[0])  # the caller's arrays are untouched
    np.testing.assert_array_equal(directions, before[1])
