"""The distance queries (issue 16): ``Scene.closest_points``, ``distance`` and
``signed_distance``, after Open3D's ``compute_closest_points``, ``compute_distance`` and
``compute_signed_distance``.

Judged against analytic geometry on a cube (the nearest point of a box is the point clamped
into it) and against an exact brute force on an icosphere (every point-triangle distance in
rational arithmetic, ``fractions.Fraction``), which shares nothing with the BVH.

The tolerance is the float64 evaluation's error bound, derived: the nearest point is
``a + u (b - a) + v (c - a)`` with ``u``, ``v`` ratios of sums of products of coordinate
differences, at most 12 roundings from the inputs to each coordinate, so each coordinate is
off by at most ``16 u (|a_k| + |b_k - a_k| + |c_k - a_k|)`` (``u = 2^-53``, 16 > 12 / (1 - 12
u) with room for the sums); a distance, by at most ``sqrt(3)`` times that plus two roundings
of the norm.
"""

from fractions import Fraction

import numpy as np
import pytest
import trimesh

import tetrace

U = 2.0**-53


def _bound(tri, d):
    """The derived bound on the error of a computed distance ``d`` to triangle ``tri``."""
    a, b, c = tri
    q = 16 * U * np.max(np.abs(a) + np.abs(b - a) + np.abs(c - a))
    return np.sqrt(3) * q + 4 * U * d


@pytest.fixture(scope="module")
def cube():
    box = trimesh.creation.box()
    v, f = np.asarray(box.vertices, np.float64), np.asarray(box.faces)
    return tetrace.Scene.from_mesh((v, f)), v, f


def test_cube_outside_points_are_clamped_into_it(cube):
    """Outside the cube [-0.5, 0.5]^3 the nearest point is the clamped point (nearest a face,
    an edge or a corner, by the point's position), and the distance its distance."""
    scene, v, f = cube
    g = np.arange(-6, 7) / 4.0  # -1.5 .. 1.5 in quarters: faces, edges, corners
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    p = p[np.abs(p).max(axis=1) > 0.5]
    r = scene.closest_points(p)
    want = np.clip(p, -0.5, 0.5)
    tol = 16 * U * 2.5  # |a_k| <= 0.5, edges <= 1 per coordinate
    np.testing.assert_allclose(r.point, want, rtol=0, atol=tol)
    exact = np.linalg.norm(p - want, axis=1)
    np.testing.assert_allclose(r.distance, exact, rtol=4 * U, atol=np.sqrt(3) * tol)
    # The triangle named holds the point: its barycentrics rebuild it.
    tri = v[f[r.triangle]]
    rebuilt = (1 - r.u - r.v)[:, None] * tri[:, 0] + r.u[:, None] * tri[:, 1]
    rebuilt += r.v[:, None] * tri[:, 2]
    np.testing.assert_allclose(rebuilt, r.point, rtol=0, atol=2 * tol)
    assert (r.u >= 0).all() and (r.v >= 0).all() and (r.u + r.v <= 1 + 4 * U).all()
    np.testing.assert_array_equal(scene.distance(p), r.distance)
    np.testing.assert_array_equal(scene.signed_distance(p), r.distance)


def test_cube_inside_points_are_negative(cube):
    """Inside, the nearest point is on the nearest face and the signed distance is minus
    the gap to it (points with one nearest face only)."""
    scene, _, _ = cube
    g = np.arange(-7, 8) / 16.0
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    gap = 0.5 - np.abs(p)
    one = (gap == gap.min(axis=1, keepdims=True)).sum(axis=1) == 1
    p, gap = p[one], gap[one]
    want = 0.5 - np.abs(p).max(axis=1)
    s = scene.signed_distance(p)
    tol = np.sqrt(3) * 16 * U * 2.5
    np.testing.assert_allclose(s, -want, rtol=4 * U, atol=tol)
    assert (s < 0).all()
    r = scene.closest_points(p)
    k = np.argmin(gap, axis=1)
    onto = p.copy()
    onto[np.arange(len(p)), k] = 0.5 * np.sign(p[np.arange(len(p)), k])
    np.testing.assert_allclose(r.point, onto, rtol=0, atol=16 * U * 2.5)


def _exact_dist2(p, tri):
    """The exact squared distance from ``p`` to the closed triangle (Fractions)."""
    p = [Fraction(float(x)) for x in p]
    a, b, c = ([Fraction(float(x)) for x in q] for q in tri)

    def sub(x, y):
        return [x[0] - y[0], x[1] - y[1], x[2] - y[2]]

    def dot(x, y):
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]

    def cross(x, y):
        return [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]]

    n = cross(sub(b, a), sub(c, a))
    nn = dot(n, n)
    if nn:
        # The projection lies in the triangle: the plane's distance.
        inside = all(dot(n, cross(sub(y, x), sub(p, x))) >= 0 for x, y in ((a, b), (b, c), (c, a)))
        if inside:
            return dot(n, sub(p, a)) ** 2 / nn
    best = None
    for x, y in ((a, b), (b, c), (c, a)):
        e = sub(y, x)
        ee = dot(e, e)
        t = min(max(dot(sub(p, x), e) / ee, Fraction(0)), Fraction(1)) if ee else Fraction(0)
        w = sub(p, [x[k] + t * e[k] for k in range(3)])
        best = dot(w, w) if best is None else min(best, dot(w, w))
    return best


def _check_against_brute_force(r, p, tris):
    """Each distance is the exact minimum over ``tris`` within the derived bound, and the
    triangle named is one whose exact distance is that minimum within the bound."""
    for i, q in enumerate(p):
        exact = [_exact_dist2(q, t) for t in tris]
        d_min = np.sqrt(float(min(exact)))
        bound = max(_bound(t, d_min) for t in tris)
        assert abs(r.distance[i] - d_min) <= bound, (i, r.distance[i], d_min, bound)
        named = np.sqrt(float(exact[r.triangle[i]]))
        assert named - d_min <= 2 * bound, (i, r.triangle[i], named, d_min)


def test_icosphere_matches_the_exact_brute_force():
    """Points inside, near and far from an icosphere: the distance is the exact minimum
    over all triangles within the derived bound; the triangle named is one whose exact
    distance is that minimum within the bound; the sign is containment's."""
    m = trimesh.creation.icosphere(1)
    v, f = np.asarray(m.vertices, np.float64), np.asarray(m.faces)
    scene = tetrace.Scene.from_mesh((v, f))
    rng = np.random.default_rng(16)
    p = np.round(rng.uniform(-1.6, 1.6, (150, 3)) * 256) / 256
    p = np.vstack([p, v[:10], v[f[:10]].mean(axis=1)])  # on vertices and on faces
    r = scene.closest_points(p)
    _check_against_brute_force(r, p, v[f])
    inside = scene.contains(p)
    s = scene.signed_distance(p)
    np.testing.assert_array_equal(np.abs(s), r.distance)
    assert (np.signbit(s) == inside).all()
    # Analytic: inside the inscribed sphere is inside, outside the unit sphere is outside.
    radius = np.linalg.norm(p, axis=1)
    inscribed = np.abs(
        np.einsum("fk,fk->f", trimesh.creation.icosphere(1).face_normals, v[f][:, 0])
    ).min()
    assert inside[radius < inscribed].all() and not inside[radius > 1].any()
    assert (radius < inscribed).sum() > 10 and (radius > 1).sum() > 10


@pytest.mark.parametrize("power", [-300, -200, 200, 300])
def test_distances_hold_at_every_scale_a_mesh_may_have(power):
    """The icosphere and its points scaled by 2^power (exactly: the brute force is the same
    up to that factor), as large as 2e90 and as small as 5e-91, inside the coordinates a mesh
    may have (``io.MAX_COORDINATE``). Ericson's region tests multiply four coordinate
    differences: from about 1e77 on they overflowed, and a point over a face was given the
    nearest point of an edge (1.03 times the distance at 1e80); below about 1e-77 they
    underflowed."""
    m = trimesh.creation.icosphere(1)
    s = 2.0**power
    v, f = np.asarray(m.vertices, np.float64) * s, np.asarray(m.faces)
    scene = tetrace.Scene.from_mesh((v, f))
    rng = np.random.default_rng(18)
    p = np.round(rng.uniform(-1.6, 1.6, (60, 3)) * 256) / 256 * s
    p = np.vstack([p, v[f[:10]].mean(axis=1) * 1.25])  # over faces, where it failed
    r = scene.closest_points(p)
    _check_against_brute_force(r, p, v[f])
    assert np.isfinite(r.distance).all() and (r.triangle >= 0).all()


def test_triangles_without_area_are_as_near_as_their_segments():
    """Zero-area triangles beside an icosphere (two corners at one point, in each of the three
    places; three on a line; three at one point), points around them: the brute force
    measures each as its segment (or point). With two corners at one point the distance
    query skipped the triangle (Ericson's edge region divided 0 by 0) and named a farther
    one, the icosphere's."""
    m = trimesh.creation.icosphere(1)
    v, f = np.asarray(m.vertices, np.float64), np.asarray(m.faces)
    flat = np.array(
        [
            [[2, 0, 0], [2, 0, 0], [3, 0.5, 0]],
            [[0, 2, 0], [0, 3, 0.5], [0, 2, 0]],
            [[0.5, 0, 3], [0, 0, 2], [0, 0, 2]],
            [[-2, 0, 0], [-2.5, 0.25, 0], [-3, 0.5, 0]],
            [[0, -2.5, 0]] * 3,
        ],
        np.float64,
    )
    vertices = np.vstack([v, flat.reshape(-1, 3)])
    faces = np.vstack([f, len(v) + np.arange(len(flat) * 3).reshape(-1, 3)])
    scene = tetrace.Scene.from_mesh((vertices, faces))
    rng = np.random.default_rng(17)
    # Points around each flat triangle, a few beyond its ends.
    p = np.vstack([t.mean(axis=0) + rng.uniform(-1.0, 1.0, (30, 3)) for t in flat])
    p = np.round(p * 256) / 256
    r = scene.closest_points(p)
    _check_against_brute_force(r, p, vertices[faces])
    near_flat = (r.triangle >= len(f)).sum()
    assert near_flat > 100, near_flat


def test_shapes_meshes_and_refusals():
    """The leading shape is kept; a scene of several meshes names the mesh and its
    triangle; bad points raise."""
    a = trimesh.creation.box()
    b = trimesh.creation.box()
    b.apply_translation([3.0, 0.0, 0.0])
    scene = tetrace.Scene.from_meshes([a, b])
    p = np.array([[[-1.0, 0.0, 0.0], [4.0, 0.25, 0.0]], [[3.0, 2.0, 0.0], [0.0, 0.0, 2.0]]])
    r = scene.closest_points(p)
    assert r.point.shape == (2, 2, 3) and r.distance.shape == (2, 2)
    assert r.geometry.tolist() == [[0, 1], [1, 0]]
    np.testing.assert_array_equal(r.scene_triangle, np.where(r.geometry == 1, 12, 0) + r.triangle)
    # Corners up to 3.5, edges 1: the derived bound with |a_k| + |b_k - a_k| + |c_k - a_k| <= 5.5.
    tol = np.sqrt(3) * 16 * U * 5.5 + 4 * U * 1.5
    np.testing.assert_allclose(r.distance, [[0.5, 0.5], [1.5, 1.5]], rtol=0, atol=tol)
    for bad, err in (
        ([np.nan, 0, 0], ValueError),
        (np.zeros((3, 2)), ValueError),
        (["x"] * 3, TypeError),
    ):
        with pytest.raises(err):
            scene.closest_points(bad)
    with pytest.raises(ValueError, match="threads"):
        scene.distance(p, threads=0)
