"""Rays of any leading shape (issue 14): ``(..., 6)`` rays and broadcast ``(..., 3)``
origins and directions give hits of that shape; ``hits.normal``."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh

import tetrace
from tetrace.hits import Hits
from tetrace.rays import prepare_bounds, prepare_ray_batch


@pytest.fixture(scope="module")
def sphere():
    return tetrace.Scene.from_mesh(trimesh.creation.icosphere(2))


def _directions(shape, seed=0):
    return np.random.default_rng(seed).standard_normal(shape + (3,))


def test_prepare_ray_batch_shapes():
    b = prepare_ray_batch(np.zeros(3), np.ones((4, 5, 3)))
    assert b.shape == (4, 5) and b.origins.shape == (20, 3) and b.directions.shape == (20, 3)
    assert b.origins.flags.c_contiguous and b.directions.flags.c_contiguous
    assert prepare_ray_batch(np.zeros(6)).shape == (1,)
    assert prepare_ray_batch(np.zeros(3), np.ones(3)).shape == (1,)
    assert prepare_ray_batch(np.zeros((7, 3)), np.ones((7, 3))).shape == (7,)
    b = prepare_ray_batch(np.zeros((2, 3, 6), np.float32))
    assert b.shape == (2, 3) and b.origins.dtype == np.float32
    b = prepare_ray_batch(np.zeros((4, 1, 3)), np.ones((1, 5, 3)))
    assert b.shape == (4, 5) and b.unravel(7) == (1, 2)
    with pytest.raises(ValueError, match="same length"):
        prepare_ray_batch(np.zeros((4, 3)), np.ones((5, 3)))
    with pytest.raises(ValueError, match=r"\(N, 6\)"):
        prepare_ray_batch(np.zeros((4, 5, 3)))


def test_prepare_bounds_broadcast():
    assert prepare_bounds(2.0, 20, "tmax", (4, 5)).tolist() == [2.0]
    col = prepare_bounds(np.arange(4.0)[:, None], 20, "tmax", (4, 5))
    assert col.tolist() == np.repeat(np.arange(4.0), 5).tolist()
    row = prepare_bounds(np.arange(5.0), 20, "tmax", (4, 5))
    assert row.tolist() == np.tile(np.arange(5.0), 4).tolist()
    with pytest.raises(ValueError, match="broadcast"):
        prepare_bounds(np.ones(3), 20, "tmax", (4, 5))
    with pytest.raises(ValueError, match=r"shape \(8,\)"):
        prepare_bounds(np.ones(3), 8, "tmax")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_image_shaped_rays_match_flat_rays(sphere, dtype):
    d = _directions((6, 7)).astype(dtype)
    o = np.array([0.1, -0.2, 0.05], dtype)
    flat = sphere.cast(np.broadcast_to(o, (42, 3)), d.reshape(-1, 3))
    image = sphere.cast(o, d)
    six = sphere.cast(np.concatenate([np.broadcast_to(o, d.shape), d], axis=-1))
    for h in (image, six):
        assert h.shape == (6, 7) and h.point.shape == (6, 7, 3) and h.normal.shape == (6, 7, 3)
        for name in ("t", "triangle", "u", "v", "point", "status", "normal", "geometry"):
            a, b = getattr(h, name), getattr(flat, name)
            np.testing.assert_array_equal(a.reshape(b.shape), b, err_msg=name)
    assert image.t.dtype == dtype and image.normal.dtype == dtype
    assert image.summary()["rays"] == 42 and len(image) == 6


def test_three_dimensional_batch_and_bounds(sphere):
    d = _directions((2, 3, 4), seed=1)
    tmax = np.array([0.5, np.inf])[:, None, None]  # the sphere has radius 1
    h = sphere.cast(
        np.zeros((2, 3, 4, 3)), d / np.linalg.norm(d, axis=-1, keepdims=True), tmax=tmax
    )
    assert h.shape == (2, 3, 4)
    assert (h.status[0] == tetrace.MISS).all() and (h.status[1] == tetrace.HIT).all()
    h = sphere.cast(np.zeros(3), d, tmin=np.zeros((3, 1)))
    assert h.shape == (2, 3, 4) and h.hit.all()


def test_single_ray_keeps_shape_one(sphere):
    h = sphere.cast([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    assert h.shape == (1,)
    h = sphere.cast([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    assert h.shape == (1,)


def test_invalid_rays_named_by_their_index(sphere):
    d = _directions((3, 4))
    d[2, 1] = 0.0
    with pytest.raises(ValueError, match=r"first: ray \(2, 1\)"):
        sphere.cast(np.zeros(3), d)
    h = sphere.cast(np.zeros(3), d, invalid="mark")
    assert h.status[2, 1] == tetrace.INVALID and h.shape == (3, 4)


def test_normal_is_the_unit_normal_of_the_callers_winding(sphere):
    """On the outward-wound icosphere, rays from the centre hit triangles whose normal
    points away from the centre; flipping the winding flips the normal."""
    m = trimesh.creation.icosphere(2)
    d = _directions((50,), seed=2)
    h = sphere.cast(np.zeros(3), d)
    v, f = m.vertices, m.faces
    p = v[f[h.triangle]]
    expect = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    expect /= np.linalg.norm(expect, axis=1, keepdims=True)
    np.testing.assert_allclose(h.normal, expect, rtol=0, atol=1e-15)
    assert (np.einsum("ij,ij->i", h.normal, d) > 0).all()
    flipped = tetrace.Scene.from_mesh((v, f[:, ::-1]))
    hf = flipped.cast(np.zeros(3), d)
    np.testing.assert_allclose(hf.normal, -h.normal, atol=1e-15)
    miss = sphere.cast(np.array([5.0, 5.0, 5.0]), np.array([1.0, 0.0, 0.0]))
    assert np.isnan(miss.normal).all() and miss.geometry.tolist() == [-1]


def _unit_normals(v, f):
    """The documented normal: np.cross of the triangle's edges over np.linalg.norm (nan
    where the area is zero)."""
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    with np.errstate(invalid="ignore", divide="ignore"):
        return n / np.linalg.norm(n, axis=1)[:, None]


@pytest.mark.parametrize("precision", ["f32", "f64"])
def test_normals_are_the_hit_triangles_rows_and_follow_moved_vertices(precision):
    """Every cast's ``normal`` is its hit triangle's unit normal as numpy computes it, bit for
    bit (rounded to float32 for float32 rays), and nan for a miss: on every CPU accelerator,
    in one cast of many chunks, and after ``update_vertices`` moves the triangles, in place or
    by meshing again. A zero-area triangle (three vertices on a line) is in the scene.

    The normals are gathered when first read: hits cast before a move, and a selection and a
    reshape of them made before it, read after it, are the normals of the triangles as they
    were at the cast."""
    m = trimesh.creation.icosphere(2)
    v = np.vstack([m.vertices, [[0.1, 0.1, 0.1], [0.2, 0.2, 0.2], [0.3, 0.3, 0.3]]])
    f = np.vstack([m.faces, [[len(m.vertices), len(m.vertices) + 1, len(m.vertices) + 2]]])
    scene = tetrace.Scene.from_mesh((v, f))
    rng = np.random.default_rng(5)
    n = 9000
    o = rng.uniform(-0.2, 0.2, (n, 3))
    d = rng.standard_normal((n, 3))
    d[: n // 3] *= -1.0
    o[: n // 3] += 3.0 * d[: n // 3] / np.linalg.norm(d[: n // 3], axis=1)[:, None]  # many miss
    dt = np.float32 if precision == "f32" else np.float64
    o, d = o.astype(dt), d.astype(dt)
    # The first pass's "tetwalk" cast meshes; the first move then keeps the
    # tetrahedralization (its points move in place), the second inverts tets and meshes again.
    bits = np.uint32 if dt == np.float32 else np.uint64
    pending = None
    for move, action in ((None, None), ([1.05, 0.97, 1.0], "moved"), ([1.5, 0.75, 1.0], "rebuilt")):
        if move is not None:
            assert scene.update_vertices(v * np.array(move)).action == action
        moved = move is not None
        want = _unit_normals(scene.vertices, f).astype(dt)
        for accel in ("exact_bvh", "reshetov_bvh", "tetwalk"):
            h = scene.cast(o, d, accel=accel, precision=precision)
            hit = h.status == tetrace.HIT
            assert 1000 < hit.sum() < n - 1000, accel
            assert h.normal.dtype == dt
            np.testing.assert_array_equal(
                h.normal[hit].view(bits),
                want[h.triangle[hit]].view(bits),
                err_msg=f"{accel}, moved {moved}",
            )
            assert np.isnan(h.normal[~hit]).all(), accel
        if pending is not None:
            # Cast before the move, read after it (and after casts that read the moved
            # triangles' normals).
            h, every_other, grid, before = pending
            hit = h.status == tetrace.HIT
            for got, rows in ((h.normal, slice(None)), (every_other.normal, slice(None, None, 2))):
                np.testing.assert_array_equal(
                    got[hit[rows]].view(bits), before[h.triangle[rows][hit[rows]]].view(bits)
                )
            np.testing.assert_array_equal(
                grid.normal.reshape(-1, 3).view(bits), h.normal.view(bits)
            )
        h = scene.cast(o, d, precision=precision)
        assert vars(h)["normal"] is None, "the normals wait to be read"
        pending = (h, h[::2], h.reshape((90, -1)), want)


def test_a_one_mesh_casts_geometry_is_made_when_read_and_is_zero_on_hits_only():
    """In a scene of one mesh a cast's ``geometry`` waits until read (``vars`` shows None),
    then is 0 where the status is HIT and -1 elsewhere, an int32 array of the rays' shape:
    on the cast, a selection, a reshape, one ray (0-d) and a pickle, each made before the
    cast's own was read; the triangle ids are the mesh's and ``scene_triangle``'s."""
    import pickle

    m = trimesh.creation.icosphere(2)
    scene = tetrace.Scene.from_mesh((m.vertices, m.faces))
    rng = np.random.default_rng(7)
    o = rng.uniform(-1.4, 1.4, (4000, 3))
    d = rng.standard_normal((4000, 3))
    for precision in ("f32", "f64"):
        h = scene.cast(o, d, precision=precision)
        assert vars(h)["geometry"] is None, "the geometry waits to be read"
        hit = h.status == tetrace.HIT
        assert 500 < hit.sum() < 3500
        want = np.where(hit, 0, -1)
        made = (
            h[::3],
            h.reshape((40, 100)),
            h[17],
            h[h.status != tetrace.HIT],
            pickle.loads(pickle.dumps(h)),
        )
        for got, rows in zip(
            made, (want[::3], want.reshape(40, 100), want[17], want[want < 0], want)
        ):
            assert isinstance(got.geometry, np.ndarray) and got.geometry.dtype == np.int32
            np.testing.assert_array_equal(got.geometry, rows)
        np.testing.assert_array_equal(h.geometry, want)
        np.testing.assert_array_equal(h.triangle, h.scene_triangle)
        assert ((h.triangle >= 0) == hit).all()


def test_normals_are_gathered_as_numpy_takes_them():
    """The core's parallel gather of the hits' normals (``_native.take_rows``) is
    ``np.take`` with -1 taking the last (NaN) row, in both precisions and past one piece;
    an index outside [-1, F) is a ValueError naming it, not a read past the table."""
    from tetrace import _native

    rng = np.random.default_rng(5)
    for dt in (np.float32, np.float64):
        rows = np.vstack([rng.normal(size=(40, 3)), np.full((1, 3), np.nan)]).astype(dt)
        index = rng.integers(-1, 40, size=70_001).astype(np.int32)
        got = _native.take_rows(rows, index, 2)
        assert got.dtype == dt and got.shape == (70_001, 3)
        np.testing.assert_array_equal(got, np.take(rows, index, axis=0))
        for bad in (40, -2):
            index[123] = bad
            with pytest.raises(ValueError, match=f"index {bad} is outside"):
                _native.take_rows(rows, index)
            index[123] = 0


def test_triangle_normals_are_numpys_bit_for_bit():
    """The core's normal table (``_native.triangle_normals``, what ``Scene.normals`` reads) is
    ``np.cross`` normalized by ``np.linalg.norm``, bit for bit, past one parallel piece, with
    NaN rows for zero-area triangles and a NaN row last; a face naming no vertex is a
    ValueError naming it."""
    from tetrace import _native

    rng = np.random.default_rng(7)
    v = rng.normal(size=(5_000, 3)) * 10.0 ** rng.integers(-8, 8, size=(5_000, 1))
    f = rng.integers(0, len(v), size=(40_000, 3))
    f[:100, 1] = f[:100, 0]  # zero area
    got = _native.triangle_normals(v, f, 2)
    p = v[f]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        want = np.where(length > 0, n / length, np.nan)
    assert got.shape == (len(f) + 1, 3) and np.isnan(got[-1]).all()
    assert np.isnan(got[:100]).all()
    np.testing.assert_array_equal(got[:-1], want)
    for bad in (len(v), -1):
        f[123, 2] = bad
        with pytest.raises(ValueError, match=f"vertex {bad}, outside"):
            _native.triangle_normals(v, f)


def test_hits_reshape_and_validation():
    h = Hits.misses(6).reshape((2, 3))
    assert h.shape == (2, 3) and h.point.shape == (2, 3, 3) and h.normal is None
    with pytest.raises(ValueError, match="normal has shape"):
        Hits(**{**h.__dict__, "normal": np.zeros((6, 3))})
    # A GPU cast's timings: the whole cast's, kept by reshape, dropped by selecting rays.
    assert h.timings is None
    timed = Hits(**{**h.__dict__, "timings": {"kernel": 1.0}})
    assert timed.reshape((6,)).timings == {"kernel": 1.0} and timed[0].timings is None
    with pytest.raises(TypeError, match="timings"):
        Hits(**{**h.__dict__, "timings": 1.0})


# --- indexing (issue 36): len(hits), hits[mask], hits[:10], hits[idx] ----------------


def _distinct_hits(n):
    """Hits of n rays, every field set (the optional ones too) and each ray's values
    different from every other's, so an index that mixes up rays between fields shows."""
    k = np.arange(n)
    return Hits(
        t=k + 0.5,
        triangle=k.astype(np.int32),
        u=k + 0.25,
        v=k + 0.125,
        point=np.arange(3 * n, dtype=np.float64).reshape(n, 3),
        tet=(k + 100).astype(np.int32),
        steps=(k + 7).astype(np.uint32),
        status=(k % 4).astype(np.uint8),
        normal=-np.arange(3 * n, dtype=np.float64).reshape(n, 3),
        geometry=(k % 3).astype(np.int32),
        scene_triangle=(k + 1000).astype(np.int32),
    )


def _assert_indexed(h, key, expect_shape):
    """Every field of h[key] is that field of h indexed by key along the rays' axes."""
    sub = h[key]
    assert sub.shape == expect_shape
    for field in dataclasses.fields(Hits):
        if field.name == "timings":  # not per ray: a GPU cast's; indexing drops it
            assert sub.timings is None
            continue
        whole = getattr(h, field.name)
        assert whole is not None, field.name  # the test covers every field
        got = getattr(sub, field.name)
        assert isinstance(got, np.ndarray) and got.dtype == whole.dtype, field.name
        vector = field.name in ("point", "normal")
        assert got.shape == expect_shape + ((3,) if vector else ()), field.name
        # numpy's own answer: the key on the leading axes, the vector axis whole
        rays = np.moveaxis(whole, -1, 0) if vector else whole[None]
        want = np.stack([r[key] for r in rays], axis=-1 if vector else 0)
        want = want if vector else want[0]
        assert np.array_equal(got, want), field.name


def test_hits_index_every_field_alike():
    h = _distinct_hits(12)
    assert len(h) == 12
    _assert_indexed(h, h.status == 1, (3,))  # a mask
    _assert_indexed(h, slice(None, 10), (10,))
    _assert_indexed(h, slice(None, None, -3), (4,))
    _assert_indexed(h, np.array([5, 0, 5, -1]), (4,))  # repeats and negatives, as numpy
    _assert_indexed(h, [2, 3], (2,))
    _assert_indexed(h, np.array([], dtype=np.intp), (0,))
    _assert_indexed(h, None, (1, 12))
    _assert_indexed(h, 7, ())  # one ray: a 0-d Hits
    one = h[7]
    assert float(one.t) == 7.5 and one.point.tolist() == [21.0, 22.0, 23.0]
    assert int(one.scene_triangle) == 1007 and one.summary()["rays"] == 1
    assert len(h[:10]) == 10 and len(h[h.status == 1]) == 3
    # an image of rays: numpy's multi-axis keys, Ellipsis, masks of the leading shape
    img = h.reshape((3, 4))
    _assert_indexed(img, (1, slice(1, 3)), (2,))
    _assert_indexed(img, (slice(None), 0), (3,))
    _assert_indexed(img, (Ellipsis, 2), (3,))
    _assert_indexed(img, (2, Ellipsis), (4,))
    _assert_indexed(img, img.t > 4, (8,))
    _assert_indexed(img, 1, (4,))
    _assert_indexed(img, (2, 3), ())
    assert len(img) == 3 and len(img[1]) == 4


def test_hits_index_views_and_errors():
    h = _distinct_hits(5)
    # basic indexing gives views (as numpy), masks and index arrays copies
    assert np.shares_memory(h[1:3].t, h.t) and np.shares_memory(h[1:3].point, h.point)
    assert not np.shares_memory(h[h.t > 1].t, h.t)
    assert [float(r.t) for r in h] == h.t.tolist()  # iteration yields each ray
    with pytest.raises(IndexError):
        h[5]
    with pytest.raises(IndexError):
        h[np.ones(4, bool)]  # a mask of the wrong length
    with pytest.raises(IndexError):
        h[0, 0]  # more indices than the rays have axes
    with pytest.raises(TypeError, match="use hits.t"):
        h["t"]
    with pytest.raises(TypeError, match="len"):
        len(h[0])


def test_hits_mask_of_a_cast_is_the_cast_of_those_rays(sphere):
    """hits[mask] of a real cast (normal, geometry, scene_triangle set) holds exactly what
    casting only those rays gives."""
    o = np.array([0.2, -0.1, 3.0])
    d = _directions((64,), seed=5) + [0.0, 0.0, -1.5]
    h = sphere.cast(o, d)
    mask = h.hit & (h.triangle % 2 == 0)
    assert 0 < mask.sum() < h.hit.sum()
    sub, alone = h[mask], sphere.cast(o, d[mask])
    for field in dataclasses.fields(Hits):
        assert np.array_equal(getattr(sub, field.name), getattr(alone, field.name)), field.name
