"""Rays of any leading shape (issue 14): ``(..., 6)`` rays and broadcast ``(..., 3)``
origins and directions give hits of that shape; ``hits.normal``."""

from __future__ import annotations

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


def test_hits_reshape_and_validation():
    h = Hits.misses(6).reshape((2, 3))
    assert h.shape == (2, 3) and h.point.shape == (2, 3, 3) and h.normal is None
    with pytest.raises(ValueError, match="normal has shape"):
        Hits(**{**h.__dict__, "normal": np.zeros((6, 3))})
