"""Property tests of the Python API (issue 18, item 5), with hypothesis: any ray gets a valid
status, occluded/count/intersections agree with the cast, scaling directions by a power of two
scales t exactly, and translating scene and rays together by a power of two changes nothing.

Scenes are built once per module; ``derandomize=True`` makes every run draw the same examples
(reproducible, bounded for CI)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tetrace

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True)
STATUSES = {tetrace.MISS, tetrace.HIT, tetrace.FAILED, tetrace.INVALID}
OFFSET = np.array([8.0, -4.0, 16.0])  # powers of two: cube + OFFSET is exact in float64


def _cubes():
    """Two nested cubes (dyadic corners): rays cross surfaces from outside and inside."""
    corners = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    v = np.vstack([corners, 0.25 + 0.5 * corners])
    f = np.vstack([faces, faces + 8])
    return v, f


@pytest.fixture(scope="module")
def scenes():
    v, f = _cubes()
    return tetrace.Scene.from_mesh((v, f)), tetrace.Scene.from_mesh((v + OFFSET, f))


# Dyadic coordinates (multiples of 2^-6) so that translating by OFFSET is exact.
dyadic = st.integers(-96, 160).map(lambda k: k / 64.0)
odd = st.sampled_from([np.nan, np.inf, -np.inf, 0.0, -0.0, 5e-324, 1e-300, 1e300, -1e300])
component = st.one_of(dyadic, dyadic, dyadic, odd)
vec = st.tuples(component, component, component)
dvec = st.tuples(dyadic, dyadic, dyadic).filter(lambda d: any(d))
bound = st.one_of(st.just(0.0), st.just(np.inf), st.floats(-2, 4), odd)


def _arrays(rays):
    o = np.array([r[0] for r in rays], float).reshape(-1, 3)
    d = np.array([r[1] for r in rays], float).reshape(-1, 3)
    return o, d


@SETTINGS
@given(rays=st.lists(st.tuples(vec, vec), min_size=1, max_size=8), tmin=bound, tmax=bound)
def test_any_ray_gets_a_valid_status(scenes, rays, tmin, tmax):
    scene = scenes[0]
    o, d = _arrays(rays)
    if np.isnan(tmin) or np.isnan(tmax) or tmin < 0:
        # Bounds are checked before any ray: a typed error, never a status.
        with pytest.raises(ValueError, match="tmin|tmax"):
            scene.cast(o, d, tmin=tmin, tmax=tmax, invalid="mark")
        return
    hits = scene.cast(o, d, tmin=tmin, tmax=tmax, invalid="mark")
    assert set(hits.status.tolist()) <= STATUSES
    hit = hits.status == tetrace.HIT
    assert np.all(np.isfinite(hits.t[hit]))
    assert np.all((tmin <= hits.t[hit]) & (hits.t[hit] <= tmax))
    assert np.all(hits.triangle[hit] >= 0)
    valid = hits.status != tetrace.INVALID
    if valid.any():
        ov, dv = o[valid], d[valid]
        occ = scene.occluded(ov, dv, tmin=tmin, tmax=tmax)
        assert np.array_equal(occ, hits.status[valid] == tetrace.HIT)
        count = scene.count_intersections(ov, dv, tmin=tmin, tmax=tmax)
        every = scene.intersections(ov, dv, tmin=tmin, tmax=tmax)
        assert np.array_equal(np.diff(every.offsets), count)
        first = every.t[every.offsets[:-1][count > 0]]
        assert np.array_equal(first, hits.t[valid][count > 0])


@SETTINGS
@given(
    rays=st.lists(st.tuples(st.tuples(dyadic, dyadic, dyadic), dvec), min_size=1, max_size=8),
    k=st.integers(-60, 60),
)
def test_scaling_directions_scales_t_exactly(scenes, rays, k):
    scene = scenes[0]
    o, d = _arrays(rays)
    a = scene.cast(o, d)
    b = scene.cast(o, d * 2.0**k)
    assert np.array_equal(a.status, b.status)
    hit = a.status == tetrace.HIT
    assert np.array_equal(a.triangle, b.triangle)
    assert np.array_equal(a.t[hit], b.t[hit] * 2.0**k)


@SETTINGS
@given(rays=st.lists(st.tuples(st.tuples(dyadic, dyadic, dyadic), dvec), min_size=1, max_size=8))
def test_translating_scene_and_rays_changes_nothing(scenes, rays):
    scene, moved = scenes
    o, d = _arrays(rays)
    a = scene.cast(o, d)
    b = moved.cast(o + OFFSET, d)
    assert np.array_equal(a.status, b.status)
    hit = a.status == tetrace.HIT
    # t is evaluated in float64 on the caller's triangle: equal up to rounding.
    np.testing.assert_allclose(a.t[hit], b.t[hit], rtol=1e-12, atol=1e-12)
    # The triangle is the same unless the point lies on an edge or vertex (ties).
    inner = hit & (np.minimum(np.minimum(a.u, a.v), 1 - a.u - a.v) > 1e-9)
    assert np.array_equal(a.triangle[inner], b.triangle[inner])
