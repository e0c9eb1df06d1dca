"""Bad rays and options (issue 18, item 1): each case gives a typed error whose message names
the argument, or the answer exact arithmetic gives; either way the scene still casts right.

The cases whose answer is an answer rather than an error (extreme but finite directions,
origins far outside, an empty [tmin, tmax]) are judged against the exact referee."""

from __future__ import annotations

import numpy as np
import pytest

import tetrace
from tetrace.referee import Referee


@pytest.fixture(scope="module")
def spot():
    return tetrace.default_scene()


def _rays(scene, n=4):
    """n rays from above the scene's box straight down through its middle (they hit)."""
    lo, hi = scene.domain
    c = (lo + hi) / 2
    o = np.tile([c[0], c[1], hi[2] + 1.0], (n, 1))
    o[:, 0] += np.linspace(-0.05, 0.05, n)
    d = np.tile([0.0, 0.0, -1.0], (n, 1))
    return o, d


def _one_bad(a, value):
    """a copy of a with its first row set to value."""
    a = a.copy()
    a[0] = value
    return a


# (id, call(scene, o, d), exception type, a word the message must contain)
ERRORS = [
    ("dtype-object", lambda s, o, d: s.cast(o.astype(object), d), TypeError, "origins"),
    ("dtype-complex", lambda s, o, d: s.cast(o, d.astype(complex)), TypeError, "directions"),
    ("dtype-bool", lambda s, o, d: s.cast(o.astype(bool), d), TypeError, "origins"),
    ("dtype-str", lambda s, o, d: s.cast(o.astype(str), d), TypeError, "origins"),
    ("shape-2-columns", lambda s, o, d: s.cast(o[:, :2], d), ValueError, "origins"),
    ("shape-4-columns", lambda s, o, d: s.cast(o, np.ones((4, 4))), ValueError, "directions"),
    ("shape-scalar", lambda s, o, d: s.cast(o, 1.0), ValueError, "directions"),
    ("shape-lengths", lambda s, o, d: s.cast(o[:3], d), ValueError, "origins"),
    ("rays-6-columns", lambda s, o, d: tetrace.cast(o, s), ValueError, "(N, 6)"),
    ("nan-origin", lambda s, o, d: s.cast(_one_bad(o, np.nan), d), ValueError, "origins"),
    ("inf-direction", lambda s, o, d: s.cast(o, _one_bad(d, np.inf)), ValueError, "directions"),
    (
        "nan-direction-f32",
        lambda s, o, d: s.cast(o, _one_bad(d, np.nan), precision="f32"),
        ValueError,
        "directions",
    ),
    ("zero-direction", lambda s, o, d: s.cast(o, _one_bad(d, 0.0)), ValueError, "directions"),
    ("denormal-direction", lambda s, o, d: s.cast(o, d * 5e-324), ValueError, "overflows"),
    ("denormal-direction-1e-310", lambda s, o, d: s.cast(o, d * 1e-310), ValueError, "overflows"),
    (
        "f32-t-overflows",
        lambda s, o, d: s.cast(o.astype(np.float32), (d * 1e-39).astype(np.float32)),
        ValueError,
        "overflows float32",
    ),
    (
        "intersections-t-overflows",
        lambda s, o, d: s.intersections(o, d * 1e-310),
        ValueError,
        "overflows",
    ),
    (
        "count-t-overflows",
        lambda s, o, d: s.count_intersections(o, d * 5e-324),
        ValueError,
        "overflows",
    ),
    (
        "direction-spans-exponent-range",
        lambda s, o, d: s.cast(o, np.tile([0.1, -0.2, -1.7976931348623157e308], (len(o), 1))),
        ValueError,
        "exponent range",
    ),
    ("nan-occluded", lambda s, o, d: s.occluded(_one_bad(o, np.nan), d), ValueError, "origins"),
    (
        "nan-intersections",
        lambda s, o, d: s.intersections(o, _one_bad(d, np.nan)),
        ValueError,
        "directions",
    ),
    ("tmin-negative", lambda s, o, d: s.cast(o, d, tmin=-1.0), ValueError, "tmin"),
    ("tmax-nan", lambda s, o, d: s.cast(o, d, tmax=np.nan), ValueError, "tmax"),
    ("tmax-shape", lambda s, o, d: s.cast(o, d, tmax=np.ones(3)), ValueError, "tmax"),
    ("tmin-dtype", lambda s, o, d: s.cast(o, d, tmin="0"), TypeError, "tmin"),
    ("invalid-name", lambda s, o, d: s.cast(o, d, invalid="ignore"), ValueError, "invalid"),
    ("method-unknown", lambda s, o, d: s.cast(o, d, method="nope"), ValueError, "method"),
    ("method-type", lambda s, o, d: s.cast(o, d, method=3), TypeError, "method"),
    ("layout-unknown", lambda s, o, d: s.cast(o, d, layout="nope"), ValueError, "layout"),
    ("accel-unknown", lambda s, o, d: s.cast(o, d, accel="nope"), ValueError, "accel"),
    ("precision-unknown", lambda s, o, d: s.cast(o, d, precision="f16"), ValueError, "precision"),
    ("device-unknown", lambda s, o, d: s.cast(o, d, device="tpu"), ValueError, "device"),
    ("packet-type", lambda s, o, d: s.cast(o, d, packet="yes"), TypeError, "packet"),
    ("option-unknown", lambda s, o, d: s.cast(o, d, thread=2), TypeError, "thread"),
    ("threads-0", lambda s, o, d: s.cast(o, d, threads=0), ValueError, "threads"),
    ("threads-negative", lambda s, o, d: s.cast(o, d, threads=-1), ValueError, "threads"),
    ("threads-absurd", lambda s, o, d: s.cast(o, d, threads=10**9), ValueError, "threads"),
    (
        "threads-above-cap",
        lambda s, o, d: s.cast(o, d, threads=tetrace.scene.MAX_THREADS + 1),
        ValueError,
        "threads",
    ),
    ("threads-float", lambda s, o, d: s.cast(o, d, threads=1.5), TypeError, "threads"),
    ("threads-str", lambda s, o, d: s.cast(o, d, threads="2"), TypeError, "threads"),
    ("threads-bool", lambda s, o, d: s.cast(o, d, threads=True), TypeError, "threads"),
    ("threads-occluded", lambda s, o, d: s.occluded(o, d, threads=10**9), ValueError, "threads"),
    ("threads-contains", lambda s, o, d: s.contains(o, threads="2"), TypeError, "threads"),
    ("threads-closest", lambda s, o, d: s.closest_points(o, threads=0), ValueError, "threads"),
    # Beyond the mesh's coordinate limit, squared distances overflow (answered -1 and inf).
    ("closest-huge", lambda s, o, d: s.closest_points([[0, 0, 2e100]]), ValueError, "beyond"),
    ("distance-huge", lambda s, o, d: s.distance([[0, 0, -1e200]]), ValueError, "beyond"),
    ("signed-huge", lambda s, o, d: s.signed_distance([[1e300, 0, 0]]), ValueError, "beyond"),
    (
        "threads-native",
        lambda s, o, d: tetrace._native.RayRequest(
            np.asarray(o, np.float64).reshape(-1, 3),
            np.asarray(d, np.float64).reshape(-1, 3),
            np.zeros(1),
            np.full(1, np.inf),
            precision="f64",
            threads=10**9,
        ),
        ValueError,
        "threads",
    ),
    ("max-steps-0", lambda s, o, d: s.cast(o, d, max_steps=0), ValueError, "max_steps"),
    ("max-steps-huge", lambda s, o, d: s.cast(o, d, max_steps=2**40), ValueError, "max_steps"),
    ("max-steps-float", lambda s, o, d: s.cast(o, d, max_steps=1.5), TypeError, "max_steps"),
    ("max-steps-str", lambda s, o, d: s.cast(o, d, max_steps="9"), TypeError, "max_steps"),
]


def _still_right(scene):
    o, d = _rays(scene)
    h = scene.cast(o, d)
    verdict = Referee(scene.vertices, scene.faces).first_hits(o, d, hint=h.triangle)
    assert np.all(h.status == tetrace.HIT)
    np.testing.assert_array_equal(h.triangle, verdict.triangle)
    np.testing.assert_allclose(h.t, verdict.t, rtol=1e-12)


@pytest.mark.parametrize("call, kind, word", [c[1:] for c in ERRORS], ids=[c[0] for c in ERRORS])
def test_bad_input_raises_a_typed_error_naming_the_argument(spot, call, kind, word):
    o, d = _rays(spot)
    with pytest.raises(kind) as info:
        call(spot, o, d)
    assert type(info.value) is kind or isinstance(info.value, kind)
    assert word in str(info.value), str(info.value)
    _still_right(spot)


def test_invalid_mark_gives_status_invalid(spot):
    o, d = _rays(spot)
    bad_o = _one_bad(o, np.nan)
    tiny = d.copy()
    tiny[1] *= 5e-324
    h = spot.cast(bad_o, tiny, invalid="mark")
    assert h.status.tolist() == [tetrace.INVALID, tetrace.INVALID, tetrace.HIT, tetrace.HIT]
    assert h.triangle[1] == -1 and np.isinf(h.t[1])


def test_invalid_mark_for_every_hit_whose_t_overflows(spot):
    """As closest hits: a ray whose hits' t overflow float64 is INVALID in the all-hits
    queries (no points listed, count -1), not a list of hits at t = inf; the others are
    listed as without it."""
    o, d = _rays(spot)
    tiny = d.copy()
    tiny[1] *= 1e-310
    listed = spot.intersections(o, tiny, invalid="mark")
    alone = spot.intersections(o[[0, 2, 3]], d[[0, 2, 3]])
    assert listed.status.tolist() == [tetrace.HIT, tetrace.INVALID, tetrace.HIT, tetrace.HIT]
    assert listed.offsets[2] == listed.offsets[1] and np.all(np.isfinite(listed.t))
    np.testing.assert_array_equal(listed.t, alone.t)
    count, status = spot.count_intersections(o, tiny, invalid="mark", return_status=True)
    assert count.tolist()[1] == -1 and status[1] == tetrace.INVALID
    np.testing.assert_array_equal(np.delete(count, 1), np.diff(alone.offsets))
    _still_right(spot)


# Arrays the API takes as given (layout, dtype) and extreme but finite rays: the exact answer.
def _scaled(k):
    return lambda o, d: (o, d * k)


ANSWERS = [
    ("int-arrays", lambda o, d: (np.round(o * 4).astype(np.int64), d.astype(np.int32))),
    ("float16", lambda o, d: (o.astype(np.float16), d.astype(np.float16))),
    ("fortran-order", lambda o, d: (np.asfortranarray(o), np.asfortranarray(d))),
    ("strided", lambda o, d: (np.repeat(o, 2, 0)[::2], np.repeat(d, 2, 0)[::2])),
    ("read-only", lambda o, d: (_read_only(o), _read_only(d))),
    ("broadcast-origin", lambda o, d: (np.broadcast_to(o[0], o.shape), d)),
    ("direction-1e-200", _scaled(1e-200)),
    ("direction-1e-300", _scaled(1e-300)),
    ("direction-1e-307", _scaled(1e-307)),
    ("direction-1e+200", _scaled(1e200)),
    ("direction-1e+300", _scaled(1e300)),
    ("direction-1.5e+308", _scaled(1.5e308)),
    ("origin-far-1e12", lambda o, d: (o + [0.0, 0.0, 1e12], d)),
    ("origin-far-1e300", lambda o, d: (o + [0.0, 0.0, 1e300], d)),
    ("origin-far-side", lambda o, d: (o + [1e9, 0.0, 0.0], d + [-1e9 / (o[0, 2] + 2), 0, 0])),
]


def _read_only(a):
    a = a.copy()
    a.setflags(write=False)
    return a


@pytest.mark.parametrize("make", [c[1] for c in ANSWERS], ids=[c[0] for c in ANSWERS])
def test_odd_but_valid_rays_get_the_exact_answer(spot, make):
    o, d = make(*_rays(spot))
    h = spot.cast(o, d)
    o64, d64 = np.asarray(o, np.float64), np.asarray(d, np.float64)
    if h.t.dtype == np.float32:  # float32 rays (float16 in): judged as the float32 numbers
        o64, d64 = o64.astype(np.float32).astype(np.float64), d64.astype(np.float32)
        d64 = d64.astype(np.float64)
    verdict = Referee(spot.vertices, spot.faces).first_hits(o64, d64, hint=h.triangle)
    np.testing.assert_array_equal(h.status == tetrace.HIT, verdict.hit)
    hit = verdict.hit
    np.testing.assert_array_equal(h.triangle[hit], verdict.triangle[hit])
    np.testing.assert_allclose(
        h.t[hit], verdict.t[hit], rtol=1e-6 if h.t.dtype == np.float32 else 1e-12
    )
    assert np.all(np.isfinite(h.t[hit]))
    _still_right(spot)


def test_empty_interval_misses(spot):
    # tmin > tmax is an empty interval, not an error: every ray misses (as in Embree).
    o, d = _rays(spot)
    h = spot.cast(o, d, tmin=2.0, tmax=1.0)
    assert np.all(h.status == tetrace.MISS)
    assert np.all(spot.occluded(o, d, tmin=2.0, tmax=1.0) == 0)
    _still_right(spot)


def test_a_scene_serves_many_python_threads_at_once(spot):
    from concurrent.futures import ThreadPoolExecutor

    o, d = _rays(spot, 64)
    want = spot.cast(o, d)

    def one(k):
        h = spot.cast(o, d, threads=1 + k % 2)
        return np.array_equal(h.triangle, want.triangle) and np.array_equal(h.t, want.t)

    with ThreadPoolExecutor(8) as ex:
        assert all(ex.map(one, range(32)))
