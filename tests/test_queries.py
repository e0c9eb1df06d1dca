"""The query kinds beside ``cast`` (issue 14): ``occluded``, ``intersections``,
``count_intersections`` and ``contains``, against an exact brute force.

The brute force here shares nothing with the walk: for every ray and every triangle it solves
the ray-triangle system in rational arithmetic (``fractions.Fraction`` of the float inputs,
so exactly), with the contract's rules: the closed triangle (edges and vertices included),
never a triangle in the ray's plane, ``tmin <= t <= tmax``, and each point where the ray meets
the surface once (distinct exact ``t``). Its closest hits are checked against the exact
referee (``tetrace.referee``) first. Containment is checked on a cube and an icosphere, where
inside and outside are known analytically.

Where the compiled core lacks a query kind these tests fail (AttributeError from
``Scene._native``): they are the acceptance tests of the native side, not optional.
The Python plumbing (shapes, offsets, points, geometry) is also tested against a stand-in
core built on the brute force (``FakeNative``), so it is checked without the native side.
"""

from __future__ import annotations

import os
import platform
import sys
from fractions import Fraction

import numpy as np
import pytest
import trimesh

import tetrace
from tetrace import referee
from tetrace.hits import HIT, INVALID, MISS, Intersections

#: Every ray walks with the exact method: rays here pass through vertices and edges.
METHOD = tetrace._native.DEFAULT_METHOD  # the exact walk

# --------------------------------------------------------------------------- brute force


def _exact_hits(o, d, triangles, tmin, tmax):
    """``{t: [triangle ids]}`` of one ray, exact (Fractions), by the contract."""
    o = [Fraction(float(x)) for x in o]
    d = [Fraction(float(x)) for x in d]
    tmin, tmax = Fraction(float(tmin)), float(tmax)

    def sub(a, b):
        return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]

    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]

    def dot(a, b):
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]

    out: dict[Fraction, list[int]] = {}
    for k, tri in enumerate(triangles):
        a, b, c = ([Fraction(float(x)) for x in p] for p in tri)
        e1, e2 = sub(b, a), sub(c, a)
        p = cross(d, e2)
        det = dot(e1, p)
        if det == 0:  # parallel to the plane, or in it: never a hit
            continue
        s = sub(o, a)
        q = cross(s, e1)
        u, v, t = dot(s, p) / det, dot(d, q) / det, dot(e2, q) / det
        if u < 0 or v < 0 or u + v > 1 or t < tmin or (tmax != np.inf and t > Fraction(tmax)):
            continue
        out.setdefault(t, []).append(k)
    return out


def brute_force(vertices, faces, origins, directions, tmin=0.0, tmax=np.inf):
    """Per ray, the sorted exact ``t`` of its distinct hits and the triangles at each."""
    tri = np.asarray(vertices, np.float64)[np.asarray(faces)]
    n = len(origins)
    lo = np.broadcast_to(np.asarray(tmin, np.float64), (n,))
    hi = np.broadcast_to(np.asarray(tmax, np.float64), (n,))
    result = []
    for i in range(n):
        hits = _exact_hits(origins[i], directions[i], tri, lo[i], hi[i])
        result.append([(t, hits[t]) for t in sorted(hits)])
    return result


# --------------------------------------------------------------------------- scenes and rays


def _cube():
    """The unit cube [-0.5, 0.5]^3 as 12 outward triangles."""
    box = trimesh.creation.box()
    return np.asarray(box.vertices, np.float64), np.asarray(box.faces)


def _cube_rays():
    """Rays through the cube's vertices, edges and faces, along its faces' planes, from
    inside, from its surface, and random ones; all coordinates dyadic (exact)."""
    o, d = [], []
    grid = [-0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75]
    for x in grid:  # straight down: misses, faces, edges (0.5) and vertices
        for y in grid:
            o.append([x, y, 2.0])
            d.append([0.0, 0.0, -1.0])
    for s in (-1.0, 1.0):  # the diagonals, through two vertices
        o.append([-1.0, -1.0 * s, -1.0])
        d.append([1.0, s, 1.0])
    for y in (0.5, -0.5, 0.25):  # in the plane of a face (y = +-0.5), across it
        o.append([-2.0, y, 0.125])
        d.append([1.0, 0.0, 0.0])
    o.append([-2.0, 0.5, 0.5])  # along an edge
    d.append([1.0, 0.0, 0.0])
    o.append([0.0, 0.0, 0.0])  # from inside
    d.append([0.25, 0.5, 1.0])
    o.append([0.5, 0.125, 0.25])  # from the surface (t = 0 is a hit)
    d.append([1.0, 0.0, 0.0])
    o.append([0.5, 0.125, 0.25])  # from the surface, inwards
    d.append([-1.0, 0.0, 0.0])
    o.append([-1.0, -0.25, 0.5])  # through an edge's interior at an angle
    d.append([1.0, 0.5, 0.0])
    rng = np.random.default_rng(14)
    ro = np.round(rng.uniform(-1.5, 1.5, (40, 3)) * 64) / 64
    rd = np.round(rng.standard_normal((40, 3)) * 64) / 64
    rd[np.all(rd == 0, axis=1)] = 1.0
    return np.vstack([o, ro]), np.vstack([d, rd])


def _cube_eye_rays():
    """Rays from one eye outside the cube (a camera: they share their origin, so they walk
    as packets) through a 1/8 grid on the plane of the cube's far face, which holds its
    vertices and edges; all dyadic (exact)."""
    eye = np.array([-2.0, 0.125, 0.25])
    ys, zs = np.meshgrid(np.arange(-6, 7) / 8, np.arange(-6, 7) / 8)
    targets = np.stack([np.full(ys.size, 0.5), ys.ravel(), zs.ravel()], 1)
    return np.tile(eye, (len(targets), 1)), targets - eye


def _sphere():
    m = trimesh.creation.icosphere(1)
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces)


def _sphere_rays():
    v, _ = _sphere()
    o = [4 * v[i] for i in range(0, len(v), 3)]  # exactly through a vertex and the centre
    d = [-v[i] for i in range(0, len(v), 3)]
    rng = np.random.default_rng(7)
    o += list(rng.uniform(-2, 2, (30, 3)))
    d += list(rng.standard_normal((30, 3)))
    o += [np.zeros(3)] * 5  # from the centre
    d += list(rng.standard_normal((5, 3)))
    return np.array(o), np.array(d)


@pytest.fixture(scope="module")
def cube():
    v, f = _cube()
    return tetrace.Scene.from_mesh((v, f)), v, f


@pytest.fixture(scope="module")
def sphere():
    v, f = _sphere()
    return tetrace.Scene.from_mesh((v, f)), v, f


@pytest.fixture(scope="module", params=["cube", "sphere", "cube_eye"])
def case(request, cube, sphere):
    scene, v, f = sphere if request.param == "sphere" else cube
    rays = {"cube": _cube_rays, "sphere": _sphere_rays, "cube_eye": _cube_eye_rays}
    o, d = rays[request.param]()
    return scene, v, f, o, d


def test_brute_force_agrees_with_the_referee(case):
    """The test's brute force finds the referee's closest hit and tie set."""
    _, v, f, o, d = case
    bf = brute_force(v, f, o, d)
    verdict = referee.first_hits(v, f, o, d)
    assert verdict.hit.tolist() == [len(h) > 0 for h in bf]
    for i, hits in enumerate(bf):
        if hits:
            t, ties = hits[0]
            assert float(t) == pytest.approx(verdict.t[i], rel=1e-15, abs=1e-15)
            assert sorted(ties) == sorted(verdict.tie_set(i).tolist())


def test_brute_force_counts_points_once():
    """Hand-checked counts on the cube: a vertex, an edge and the face plane."""
    v, f = _cube()
    o = np.array([[0.5, 0.5, 2.0], [0.5, 0.0, 2.0], [-2.0, 0.5, 0.125], [0.0, 0.0, 0.0]])
    d = np.array([[0, 0, -1.0], [0, 0, -1.0], [1.0, 0, 0], [0, 0, 1.0]])
    bf = brute_force(v, f, o, d)
    # A ray down the vertical edge x = y = 0.5 lies in the planes of the faces x = 0.5
    # and y = 0.5 (never hits), and meets the top and bottom faces at their corners.
    assert [len(h) for h in bf] == [2, 2, 2, 1]
    assert [float(t) for t, _ in bf[0]] == [1.5, 2.5]


# ------------------------------------------------------------------------ the referee's crossings


def test_referee_crossings_are_the_brute_force_points(case):
    """``Referee.crossings`` (the bench's judge of all hits and counts) finds the brute
    force's points: the same exact ``t`` (rounded to nearest) and the same triangles there."""
    _, v, f, o, d = case
    ref = referee.Referee(v, f)
    for tmin, tmax in ((0.0, np.inf), (0.25, 1.25)):
        bf = brute_force(v, f, o, d, tmin, tmax)
        c = ref.crossings(o, d, tmin, tmax)
        assert c.count.tolist() == [len(h) for h in bf]
        for i, hits in enumerate(bf):
            for k, (t, tris) in enumerate(hits):
                p = c.ray_ptr[i] + k
                assert c.t[p] == float(t)  # float(Fraction) rounds to nearest
                assert sorted(c.triangles_at(p).tolist()) == sorted(tris)
    assert sum(len(h) > 1 for hits in brute_force(v, f, o, d) for _, h in hits) > 0


def test_judge_lists_finds_missing_extra_and_wrong_hits(cube):
    """``referee.judge_lists`` passes the exact lists and catches each kind of fault."""
    scene, v, f = cube
    o, d = _cube_rays()
    c = referee.Referee(v, f).crossings(o, d)
    r = scene.intersections(o, d, method=METHOD)
    ok = referee.judge_lists(r.offsets, r.t, r.triangle, c)
    assert ok["right"].all()
    i = int(np.flatnonzero(c.count == 2)[0])
    a, b = r.offsets[i], r.offsets[i + 1]
    counts = np.diff(r.offsets)

    def judged(t, tri, cnt):
        off = np.concatenate([[0], np.cumsum(cnt)])
        j = referee.judge_lists(off, t, tri, c)
        return {k for k in ("right", "missing", "extra", "wrong") if j[k][i]}

    cnt = counts.copy()
    cnt[i] -= 1
    assert judged(np.delete(r.t, a), np.delete(r.triangle, a), cnt) == {"missing"}
    cnt = counts.copy()
    cnt[i] += 1
    assert judged(np.insert(r.t, a, r.t[a]), np.insert(r.triangle, a, r.triangle[a]), cnt) == {
        "extra"
    }
    far = [k for k in range(len(f)) if k not in c.triangles_at(c.ray_ptr[i])]
    tri = r.triangle.copy()
    tri[a] = far[0]
    assert judged(r.t, tri, counts) == {"wrong"}
    t = r.t.copy()
    t[b - 1] = np.nextafter(np.nextafter(t[b - 1], np.inf), np.inf)  # two ulps: past one
    assert judged(t, r.triangle, counts) == {"wrong"}
    swapped_t, swapped_tri = r.t.copy(), r.triangle.copy()
    swapped_t[a:b], swapped_tri[a:b] = r.t[a:b][::-1], r.triangle[a:b][::-1]
    assert judged(swapped_t, swapped_tri, counts) == {"wrong"}  # distinct t: order matters


def test_reference_containment_is_the_cube(cube):
    """The bench's containment reference (crossing parity along generic random rays) is
    the cube's inside, away from its surface."""
    from tetrace.bench.queries import reference_contains

    _, v, f = cube
    rng = np.random.default_rng(9)
    p = rng.uniform(-1.0, 1.0, (2000, 3))
    p = p[np.abs(np.abs(p) - 0.5).min(axis=1) > 0]  # none on a face plane (a formality)
    inside, decided = reference_contains(referee.Referee(v, f), p)
    assert decided.all()
    assert inside.tolist() == np.all(np.abs(p) < 0.5, axis=1).tolist()
    assert 0 < inside.sum() < len(p)


# --------------------------------------------------------------------------- the native queries


def _check_intersections(result, bf, o, d, crossings):
    """``result`` lists the brute force's points; each ``t`` and point within one float64 ulp
    of the exact values (``|x - x*| <= ulp(x*)``, decided exactly)."""
    assert isinstance(result, Intersections)
    counts = [len(h) for h in bf]
    assert result.counts.reshape(-1).tolist() == counts
    assert len(result) == sum(counts)
    assert result.offsets.tolist() == np.concatenate([[0], np.cumsum(counts)]).tolist()
    assert result.ray.tolist() == np.repeat(np.arange(len(bf)), counts).tolist()
    expect_status = [HIT if c else MISS for c in counts]
    assert result.status.reshape(-1).tolist() == expect_status
    for i, hits in enumerate(bf):
        mine = result.for_ray(i)
        assert len(mine) == len(hits)
        assert np.all(np.diff(mine.t) > 0)  # sorted, each point once
        for k, (t, tris) in enumerate(hits):
            assert int(mine.triangle[k]) in tris, (i, k, mine.triangle[k], tris)
            p = crossings.ray_ptr[i] + k
            at = crossings.point_ptr[p] + crossings.triangles_at(p).tolist().index(
                int(mine.triangle[k])
            )
            assert at >= 0
            # t and each coordinate of the exact point o + t d within one float64 ulp.
            exact = [t] + [
                Fraction(float(o[i][j])) + t * Fraction(float(d[i][j])) for j in range(3)
            ]
            got = [mine.t[k], *mine.point[k]]
            ok = referee.within_ulp(
                got,
                [float(x) for x in exact],
                np.array([x.numerator for x in exact], dtype=object),
                np.array([x.denominator for x in exact], dtype=object),
                np.float64,
            )
            assert ok.all(), (i, k, got, [float(x) for x in exact])


def test_intersections_match_brute_force(case):
    scene, v, f, o, d = case
    result = scene.intersections(o, d, method=METHOD)
    _check_intersections(
        result, brute_force(v, f, o, d), o, d, referee.Referee(v, f).crossings(o, d)
    )
    # u, v place the point on the named triangle
    p = v[f[result.triangle]]
    on = (1 - result.u - result.v)[:, None] * p[:, 0] + result.u[:, None] * p[:, 1]
    on += result.v[:, None] * p[:, 2]
    np.testing.assert_allclose(on, result.point, rtol=0, atol=1e-12)
    assert (result.geometry == 0).all()
    assert np.array_equal(result.triangle, result.scene_triangle)


def test_intersections_respect_tmin_tmax(case):
    scene, v, f, o, d = case
    rng = np.random.default_rng(3)
    tmin = np.round(rng.uniform(0, 2, len(o)) * 8) / 8
    tmax = tmin + np.round(rng.uniform(0, 2, len(o)) * 8) / 8
    result = scene.intersections(o, d, tmin=tmin, tmax=tmax, method=METHOD)
    crossings = referee.Referee(v, f).crossings(o, d, tmin, tmax)
    _check_intersections(result, brute_force(v, f, o, d, tmin, tmax), o, d, crossings)


def test_count_intersections_match_brute_force(case):
    scene, v, f, o, d = case
    count = scene.count_intersections(o, d, method=METHOD)
    assert count.dtype == np.int32 and count.shape == (len(o),)
    assert count.tolist() == [len(h) for h in brute_force(v, f, o, d)]
    tmax = 1.25
    count, status = scene.count_intersections(o, d, tmax=tmax, method=METHOD, return_status=True)
    bf = brute_force(v, f, o, d, 0.0, tmax)
    assert count.tolist() == [len(h) for h in bf]
    assert status.tolist() == [HIT if h else MISS for h in bf]


def test_occluded_matches_brute_force(case):
    scene, v, f, o, d = case
    for tmax in (np.inf, 0.75):
        hit = scene.occluded(o, d, tmax=tmax, method=METHOD)
        assert hit.dtype == bool and hit.shape == (len(o),)
        assert hit.tolist() == [len(h) > 0 for h in brute_force(v, f, o, d, 0.0, tmax)]


def test_packets_change_no_answer(case):
    """``packet=False`` (every ray walks alone) gives the same answers, bit for bit."""
    scene, _, _, o, d = case
    with pytest.raises(TypeError, match="packet"):
        scene.cast(o, d, packet="no")
    pair = [scene.cast(o, d, packet=p) for p in (True, False)]
    for field in ("t", "u", "v", "triangle", "status", "point", "steps"):
        np.testing.assert_array_equal(getattr(pair[0], field), getattr(pair[1], field))
    pair = [scene.intersections(o, d, packet=p) for p in (True, False)]
    for field in ("offsets", "t", "u", "v", "triangle", "status"):
        np.testing.assert_array_equal(getattr(pair[0], field), getattr(pair[1], field))
    for query in (scene.occluded, scene.count_intersections):
        a, b = (query(o, d, packet=p, return_status=True) for p in (True, False))
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])


def test_simd_levels_change_no_answer(monkeypatch):
    """Every SIMD level this CPU runs gives the same answers, bit for bit, on a camera of the
    bundled scene (rays share the eye: packets, whose per-ray exits have an AVX2 kernel);
    ``TETRACE_SIMD`` caps the level, and a name that is no level is refused."""
    from tetrace.dev.camera import orbit_views, pinhole

    levels, current = tetrace.simd_levels()
    assert levels[0] == "scalar" and current in levels
    if platform.machine() in ("x86_64", "AMD64") and os.environ.get("CI") == "true":
        assert "avx2" in levels, "CI's machine runs AVX2: both levels must be compared"
    scene = tetrace.default_scene()
    bounds = np.array([scene.vertices.min(0), scene.vertices.max(0)])
    for view in orbit_views(bounds, n=2, distance=1.2):
        o, d = pinhole(*view, width=96, height=96)
        answers = []
        for level in levels:
            monkeypatch.setenv("TETRACE_SIMD", level)
            assert tetrace.simd_levels()[1] == level
            answers.append((scene.cast(o, d), scene.occluded(o, d, return_status=True)))
        assert np.count_nonzero(answers[0][0].status == HIT) > 1000
        for hits, occluded in answers[1:]:
            for field in ("t", "u", "v", "triangle", "status", "point", "steps"):
                np.testing.assert_array_equal(getattr(hits, field), getattr(answers[0][0], field))
            np.testing.assert_array_equal(occluded[0], answers[0][1][0])
            np.testing.assert_array_equal(occluded[1], answers[0][1][1])
    monkeypatch.setenv("TETRACE_SIMD", "avx9")
    with pytest.raises(ValueError, match="TETRACE_SIMD"):
        scene.cast(o, d)
    with pytest.raises(ValueError, match="TETRACE_SIMD"):
        tetrace.simd_levels()


def test_queries_keep_the_leading_shape(cube):
    scene, v, f = cube
    o, d = _cube_rays()
    n = 8 * 7
    o, d = o[:n].reshape(8, 7, 3), d[:n].reshape(8, 7, 3)
    bf = brute_force(v, f, o.reshape(-1, 3), d.reshape(-1, 3))
    counts = np.array([len(h) for h in bf]).reshape(8, 7)
    assert scene.count_intersections(o, d, method=METHOD).tolist() == counts.tolist()
    assert scene.occluded(o, d, method=METHOD).tolist() == (counts > 0).tolist()
    rays = np.concatenate([o, d], axis=-1)
    result = scene.intersections(rays, method=METHOD)
    assert result.shape == (8, 7) and result.counts.tolist() == counts.tolist()
    assert result.for_ray((2, 3)).t.tolist() == result.for_ray(2 * 7 + 3).t.tolist()
    ri = result.ray_index
    assert np.array_equal(np.ravel_multi_index(ri, (8, 7)), result.ray)


def test_queries_on_several_meshes():
    """Two cubes along x: a ray along the axis crosses 4 faces, 2 per mesh."""
    v, f = _cube()
    scene = tetrace.Scene.from_meshes([(v, f), (v + [2.0, 0, 0], f)])
    o = np.array([[-2.0, 0.125, 0.25]])
    d = np.array([[1.0, 0, 0]])
    result = scene.intersections(o, d, method=METHOD)
    assert result.geometry.tolist() == [0, 0, 1, 1]
    np.testing.assert_array_equal(result.t, [1.5, 2.5, 3.5, 4.5])  # dyadic: exact
    assert (result.triangle < 12).all() and (result.scene_triangle[2:] >= 12).all()
    assert np.array_equal(result.scene_triangle, result.triangle + 12 * result.geometry)
    assert scene.count_intersections(o, d, method=METHOD).tolist() == [4]


def test_invalid_rays_raise_or_are_marked(cube):
    scene = cube[0]
    o = np.array([[0.0, 0, 2], [np.nan, 0, 2], [0.0, 0, 2]])
    d = np.array([[0.0, 0, -1], [0, 0, -1], [0, 0, 0]])
    for query in (scene.occluded, scene.intersections, scene.count_intersections):
        with pytest.raises(ValueError, match="NaN/inf"):
            query(o, d, method=METHOD)
    hit, status = scene.occluded(o, d, invalid="mark", method=METHOD, return_status=True)
    assert hit.tolist() == [True, False, False]
    assert status.tolist() == [HIT, INVALID, INVALID]
    count = scene.count_intersections(o, d, invalid="mark", method=METHOD)
    assert count.tolist() == [2, -1, -1]
    result = scene.intersections(o, d, invalid="mark", method=METHOD)
    assert result.status.tolist() == [HIT, INVALID, INVALID] and result.counts.tolist() == [2, 0, 0]


# --------------------------------------------------------------------------- contains


def test_contains_cube_exact(cube):
    scene = cube[0]
    g = np.array([-0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75])
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1)  # (7, 7, 7, 3)
    inside = scene.contains(p)
    assert inside.shape == (7, 7, 7) and inside.dtype == bool
    # points on the surface (a coordinate at +-0.5, none beyond) count as inside
    expect = np.all(np.abs(p) <= 0.5, axis=-1)
    assert inside.tolist() == expect.tolist()
    # outside the domain box: outside
    assert scene.contains(np.array([[10.0, 0, 0], [0, -1e6, 0]])).tolist() == [False, False]
    assert scene.contains([0.0, 0.0, 0.0]).shape == ()


def test_contains_sphere(sphere):
    scene, v, f = sphere
    rng = np.random.default_rng(5)
    x = rng.standard_normal((400, 3))
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    # the icosphere's inradius is above 0.79 (faces of icosphere(1) are close to the sphere)
    r = rng.uniform(0, 0.75, 400)
    assert scene.contains(x * r[:, None]).all()
    r = rng.uniform(1.0 + 1e-9, 1.5, 400)
    assert not scene.contains(x * r[:, None]).any()
    # every vertex is on the surface: inside
    assert scene.contains(v).all()


def test_contains_open_surfaces():
    """Open inputs, parity mode: inside when the fewest crossings to the outside of the
    domain is odd. A cube without its top is entered for free (0 crossings): its inside is
    outside. (The default for open inputs is the winding number: test_contains_winding.py.)"""
    v, f = _cube()
    top = np.all(v[f][:, :, 2] == 0.5, axis=1)
    open_box = tetrace.Scene.from_mesh((v, f[~top]))
    with pytest.warns(UserWarning, match="not closed"):
        got = open_box.contains(np.array([[0.0, 0, 0], [0.25, -0.25, -0.25]]), mode="parity")
    assert not got.any()
    plane = tetrace.Scene.from_mesh((v, f[top]))
    with pytest.warns(UserWarning, match="not closed"):
        assert not plane.contains(np.array([[0.0, 0, 0], [0, 0, 0.75]]), mode="parity").any()
    on_it = plane.contains(np.array([[0.0, 0.0, 0.5]]), mode="parity")  # warned already
    assert on_it.tolist() == [True]


def test_contains_rejects_bad_points(cube):
    scene = cube[0]
    with pytest.raises(ValueError, match="NaN/inf"):
        scene.contains(np.array([[0.0, np.nan, 0]]))
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        scene.contains(np.zeros((4, 2)))


# --------------------------------------------------------------------------- Python plumbing


class FakeNative:
    """A stand-in for the compiled core's query kinds, on the brute force above: checks
    what the wrappers pass and answers in the native layout (flat arrays, scene triangle
    ids, float64 t/u/v)."""

    def __init__(self, real, vertices, faces):
        self._real, self.v, self.f = real, vertices, faces

    def __getattr__(self, name):
        return getattr(self._real, name)

    def _check(self, o, d, tmin, tmax, method, layout):
        assert o.flags.c_contiguous and d.flags.c_contiguous and o.dtype == d.dtype
        assert o.ndim == 2 and o.shape[1] == 3 and o.shape == d.shape
        assert tmin.dtype == np.float64 and tmax.dtype == np.float64
        assert isinstance(method, str) and isinstance(layout, str)
        n = len(o)
        lo, hi = np.broadcast_to(tmin, (n,)), np.broadcast_to(tmax, (n,))
        bad = ~(np.isfinite(o).all(1) & np.isfinite(d).all(1) & (np.abs(d).sum(1) > 0))
        good = np.flatnonzero(~bad)
        bf = [[] for _ in range(n)]
        for i, hits in zip(good, brute_force(self.v, self.f, o[good], d[good], lo[good], hi[good])):
            bf[i] = hits
        status = np.where(bad, INVALID, [HIT if h else MISS for h in bf]).astype(np.uint8)
        return bf, status

    def occluded(
        self,
        o,
        d,
        tmin,
        tmax,
        threads=None,
        max_steps=None,
        method=None,
        layout=None,
        packet=True,
        accel=None,
        start=None,
        progress=None,
    ):
        # Ordinary rays here: the wrappers pass no start arrays (nor, with progress off,
        # a callback) for them.
        assert isinstance(packet, bool) and accel is None and start is None and progress is None
        return self._check(o, d, tmin, tmax, method, layout)[1]

    def count_intersections(
        self,
        o,
        d,
        tmin,
        tmax,
        threads=None,
        max_steps=None,
        method=None,
        layout=None,
        packet=True,
        accel=None,
        start=None,
        progress=None,
    ):
        # Ordinary rays here: the wrappers pass no start arrays (nor, with progress off,
        # a callback) for them.
        assert isinstance(packet, bool) and accel is None and start is None and progress is None
        bf, status = self._check(o, d, tmin, tmax, method, layout)
        return {"count": np.array([len(h) for h in bf], np.int32), "status": status}

    def intersections(
        self,
        o,
        d,
        tmin,
        tmax,
        threads=None,
        max_steps=None,
        method=None,
        layout=None,
        packet=True,
        accel=None,
        start=None,
        progress=None,
    ):
        # Ordinary rays here: the wrappers pass no start arrays (nor, with progress off,
        # a callback) for them.
        assert isinstance(packet, bool) and accel is None and start is None and progress is None
        bf, status = self._check(o, d, tmin, tmax, method, layout)
        tri = self.v[self.f]
        t, ids, u, w, points = [], [], [], [], []
        for i, hits in enumerate(bf):
            for tt, tris in hits:
                t.append(float(tt))
                ids.append(tris[0])
                p = o[i] + float(tt) * d[i]
                points.append(p)
                a, b, c = tri[tris[0]]
                m = np.array([b - a, c - a]).T
                uv = np.linalg.lstsq(m, p - a, rcond=None)[0]
                u.append(uv[0])
                w.append(uv[1])
        offsets = np.concatenate([[0], np.cumsum([len(h) for h in bf])]).astype(np.int64)
        return {
            "offsets": offsets,
            "t": np.array(t, np.float64),
            "triangle": np.array(ids, np.int32),
            "u": np.array(u, np.float64),
            "v": np.array(w, np.float64),
            "point": np.array(points, np.float64).reshape(-1, 3),
            "status": status,
        }

    def contains(self, points, threads=None):
        assert points.dtype == np.float64 and points.flags.c_contiguous
        d = np.tile([0.3141, 0.2718, 1.0], (len(points), 1))  # no cube edge or vertex
        inf = np.full(1, np.inf)
        bf = brute_force(self.v, self.f, points, d, np.zeros(1), inf)
        return np.array([len(h) % 2 == 1 for h in bf])


@pytest.fixture
def fake_scenes(monkeypatch):
    """A two-mesh scene (the cube twice) whose query kinds answer from FakeNative."""
    v, f = _cube()
    # Tetrahedralized now: the stand-in wraps the core that answers, which a later build
    # of the tetrahedralization would replace.
    scene = tetrace.Scene.from_meshes([(v, f), (v + [2.0, 0, 0], f)], lazy=False)
    monkeypatch.setattr(scene, "_native", FakeNative(scene._native, scene.vertices, scene.faces))
    return scene


def test_wrappers_shape_and_split_the_native_answers(fake_scenes):
    scene = fake_scenes
    o = np.array([-2.0, 0.125, 0.25])
    d = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0.0, 0, 0]]).reshape(3, 1, 3)
    d = np.broadcast_to(d, (3, 2, 3)).copy()
    with pytest.raises(ValueError, match=r"first: ray \(2, 0\)"):
        scene.intersections(o, d)
    result = scene.intersections(o, d, invalid="mark", tmax=np.array([np.inf, 3.0]))
    assert result.shape == (3, 2)
    assert result.counts.tolist() == [[4, 2], [0, 0], [0, 0]]
    assert result.status.tolist() == [[HIT, HIT], [MISS, MISS], [INVALID, INVALID]]
    assert result.geometry.tolist() == [0, 0, 1, 1, 0, 0]
    assert result.triangle.max() < 12 and result.scene_triangle[2:4].min() >= 12
    np.testing.assert_allclose(result.point[:, 0], [-0.5, 0.5, 1.5, 2.5, -0.5, 0.5])
    assert result.point.dtype == np.float64 and result.ray.tolist() == [0, 0, 0, 0, 1, 1]
    one = result.for_ray((0, 1))
    assert len(one) == 2 and one.ray.tolist() == [1, 1] and one.status.tolist() == [HIT]
    count, status = scene.count_intersections(o, d, invalid="mark", return_status=True)
    assert count.tolist() == [[4, 4], [0, 0], [-1, -1]] and status.shape == (3, 2)
    hit = scene.occluded(o, d, invalid="mark", precision="f32")
    assert hit.tolist() == [[True, True], [False, False], [False, False]]
    p = np.array([[[0.0, 0, 0], [2.0, 0, 0]], [[1.0, 0, 0], [5.0, 5, 5]]])
    assert scene.contains(p).tolist() == [[True, True], [False, False]]
    assert scene.contains(np.float32([2.25, 0.25, -0.25])).tolist() is True
    with pytest.raises(ValueError, match="threads"):
        scene.contains(p, threads=0)
    with pytest.raises(ValueError, match="tmax"):
        scene.occluded(o, d, tmax=np.ones(4))


# --------------------------------------------------------------------------- the GIL

#: Run in a fresh interpreter: pytest-xdist's own threads can force GIL switches that would
#: let the counting thread run during a call that holds the GIL.
GIL_PROBE = r"""
import json, sys, threading, time
import numpy as np, trimesh, tetrace

def progress_during(fn):
    # Another thread counts in a loop that gives the GIL up at every step (sleep(0)); with
    # the switch interval far longer than the call, a call that holds the GIL lets it make
    # no step between the two reads of its counter, one that releases it lets it run.
    count, stop = [0], threading.Event()
    def spin():
        while not stop.is_set():
            count[0] += 1
            time.sleep(0)
    sys.setswitchinterval(30.0)
    spinner = threading.Thread(target=spin)
    spinner.start()
    while count[0] == 0:
        time.sleep(0.001)
    before = count[0]
    start = time.perf_counter()
    fn()
    seconds = time.perf_counter() - start
    after = count[0]
    stop.set()
    spinner.join()
    return [after - before, seconds]

m = trimesh.creation.icosphere(1)
scene = tetrace.Scene.from_mesh((m.vertices, m.faces))
rng = np.random.default_rng(2)
o = rng.uniform(-1.5, 1.5, (200_000, 3))
d = rng.standard_normal((200_000, 3))
held = np.array([str(x) for x in range(400_000)], dtype=object)  # as long as a query
calls = {
    "free (sleeps: releases the GIL)": lambda: time.sleep(0.3),
    "control (numpy sorts Python objects: holds the GIL)": lambda: np.sort(held),
    "cast": lambda: scene.cast(o, d, threads=1),
    "occluded": lambda: scene.occluded(o, d, threads=1),
    "intersections": lambda: scene.intersections(o, d, threads=1),
    "count_intersections": lambda: scene.count_intersections(o, d, threads=1),
    "contains": lambda: scene.contains(np.tile(o, (5, 1)), threads=1),
}
print(json.dumps({name: progress_during(fn) for name, fn in calls.items()}))
"""


def test_every_query_releases_the_gil():
    """Each query kind runs without the GIL (the bindings' promise): another Python thread
    makes progress during the call; a control that holds the GIL lets it make none."""
    import json
    import subprocess

    out = subprocess.run(
        [sys.executable, "-c", GIL_PROBE], capture_output=True, text=True, timeout=600
    )
    assert out.returncode == 0, out.stderr
    progress = json.loads(out.stdout.strip().splitlines()[-1])
    # Steps per second of the other thread: a call that releases the GIL lets it run at about
    # its free rate (measured while the main thread sleeps); one that holds it lets it step only
    # at the handoffs at the call's edges (a few steps in a call of ~0.2 s, against thousands
    # free). The bar sits at a tenth of the free rate: an order of magnitude from either.
    rate = {name: steps / seconds for name, (steps, seconds) in progress.items()}
    free = rate.pop(next(k for k in rate if k.startswith("free")))
    control = next(k for k in rate if k.startswith("control"))
    assert rate.pop(control) < free / 10, (free, progress)
    assert set(rate) == {"cast", "occluded", "intersections", "count_intersections", "contains"}
    for name, r in rate.items():
        assert r >= free / 10, f"{name} held the GIL: {progress[name]} against {free:.0f}/s free"
