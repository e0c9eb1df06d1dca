"""Parity containment without a tetrahedralization (issue 35: every query kind on the exact
BVH, nothing meshed): on a closed surface ``contains`` counts one exact ray's crossings of the
cleaned triangles (``src/accel/exact_bvh/ray_parity.rs``), which is the tetrahedralization's
rule there.

Judged by analytic geometry (boxes alone, nested and overlapping, at grid points on their
faces, edges and corners) and by the tetrahedralization's exact parity (a different algorithm:
point location and region parity) on closed meshes at random points, every vertex, every
triangle's centroid and every edge's midpoint. Nothing is meshed, except for the points no ray
decides (forced here) and for open surfaces, whose parity rule is not one ray's count.
"""

import numpy as np
import pytest

import tetrace
from tetrace import construct, point_queries
from tetrace.scene import default_scene_path


def box(lo, hi):
    """The 12 triangles of the box [lo, hi] as (vertices, faces), outward."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[(hi if i >> a & 1 else lo)[a] for a in range(3)] for i in range(8)])
    quads = [[0, 2, 6, 4], [1, 5, 7, 3], [0, 4, 5, 1], [2, 3, 7, 6], [0, 1, 3, 2], [4, 6, 7, 5]]
    f = np.array([t for q in quads for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])])
    return v, f


def boxes(*spans):
    vs, fs, n = [], [], 0
    for lo, hi in spans:
        v, f = box(lo, hi)
        vs.append(v)
        fs.append(f + n)
        n += len(v)
    return np.vstack(vs), np.vstack(fs)


@pytest.fixture
def meshed(monkeypatch):
    """The meshings run in the test (from here on)."""
    calls = []
    mesh = construct._tetrahedralize
    monkeypatch.setattr(construct, "_tetrahedralize", lambda *a: calls.append(1) or mesh(*a))
    return calls


def on_surface_points(v, f):
    """Every vertex, centroid and edge midpoint (as float64 rounds them: on or near)."""
    tri = v[f]
    mids = [(tri[:, 0] + tri[:, 1]) / 2, (tri[:, 1] + tri[:, 2]) / 2]
    return np.vstack([v, tri.mean(axis=1), *mids])


@pytest.mark.parametrize(
    "spans",
    [
        [([0, 0, 0], [1, 1, 1])],
        [([0, 0, 0], [3, 3, 3]), ([1, 1, 1], [2, 2, 2])],
        [([0, 0, 0], [2, 2, 2]), ([1, 0.5, 1], [3, 2.5, 3])],
    ],
    ids=["one box", "nested", "overlapping"],
)
def test_boxes_answer_as_geometry_says_and_nothing_is_meshed(spans, meshed):
    v, f = boxes(*spans)
    scene = tetrace.Scene.from_mesh((v, f))
    assert scene.is_closed and not scene.has_ct
    g = np.arange(-2, 15) * 0.25  # faces, edges and corners of every box at 1/4 steps
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    p = np.vstack([p, np.random.default_rng(3).uniform(-0.5, 3.5, (4000, 3))])
    lo = np.array([s[0] for s in spans], float)[:, None]
    hi = np.array([s[1] for s in spans], float)[:, None]
    closed = ((lo <= p) & (p <= hi)).all(axis=-1)
    open_ = ((lo < p) & (p < hi)).all(axis=-1)
    want = (closed & ~open_).any(axis=0) | (open_.sum(axis=0) % 2 == 1)
    got = scene.contains(p)
    assert np.array_equal(got, want), np.flatnonzero(got != want)[:10]
    assert got.sum() > 100 and (~got).sum() > 100
    assert meshed == [] and not scene.has_ct
    # signed_distance takes its sign from the same rule, still without meshing.
    sd = scene.signed_distance(p)
    assert np.array_equal(sd <= 0, want) and meshed == []


def closed_meshes():
    yield "spot", str(default_scene_path())
    v, f = boxes(([0, 0, 0], [2, 2, 2]), ([1, 0.5, 1], [3, 2.5, 3]))
    yield "overlapping boxes", (v, f)


@pytest.mark.parametrize("name, mesh", list(closed_meshes()), ids=lambda x: str(x)[:20])
def test_without_a_tetrahedralization_the_answers_are_the_tetrahedralizations(name, mesh, meshed):
    lazy = tetrace.Scene.from_mesh(mesh)
    v, f = np.asarray(lazy.vertices), np.asarray(lazy.faces)
    lo, hi = v.min(0), v.max(0)
    rng = np.random.default_rng(7)
    p = np.vstack([lo + (hi - lo) * rng.uniform(-0.1, 1.1, (20000, 3)), on_surface_points(v, f)])
    got = lazy.contains(p)
    assert meshed == [] and not lazy.has_ct
    eager = tetrace.Scene.from_mesh(mesh, lazy=False)
    want = eager.contains(p)
    assert np.array_equal(got, want), f"{name}: {np.count_nonzero(got != want)} disagree"
    assert got[20000 : 20000 + len(v)].all(), "every vertex is on the surface"
    # Float32 points convert exactly: the same answers.
    p32 = p.astype(np.float32)
    assert np.array_equal(lazy.contains(p32), eager.contains(p32.astype(np.float64)))


def test_shared_scene_answers_are_the_tetrahedralizations(scene_path, meshed):
    path = scene_path("torus_knot.obj")
    lazy = tetrace.Scene.from_mesh(path)
    assert lazy.is_closed
    v, f = np.asarray(lazy.vertices), np.asarray(lazy.faces)
    lo, hi = v.min(0), v.max(0)
    p = np.vstack(
        [
            lo + (hi - lo) * np.random.default_rng(8).uniform(-0.1, 1.1, (30000, 3)),
            on_surface_points(v, f),
        ]
    )
    got = lazy.contains(p)
    assert meshed == []
    want = tetrace.Scene.from_mesh(path, lazy=False).contains(p)
    assert np.array_equal(got, want), np.count_nonzero(got != want)


def test_points_no_ray_decides_are_decided_on_the_tetrahedralization(meshed, monkeypatch):
    # The core leaves a point undecided only when all its directions meet an edge, a corner
    # or a triangle's plane (src/accel/exact_bvh/ray_parity/tests.rs builds one); forced here.
    v, f = boxes(([0, 0, 0], [3, 3, 3]), ([1, 1, 1], [2, 2, 2]))
    scene = tetrace.Scene.from_mesh((v, f))
    sides = point_queries.ray_sides

    def every_third_undecided(*args):
        side = sides(*args)
        side[::3] = point_queries.RAY_UNDECIDED
        return side

    monkeypatch.setattr(point_queries, "ray_sides", every_third_undecided)
    g = np.arange(-1, 14) * 0.25
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    got = scene.contains(p)
    assert meshed == [1] and scene.has_ct
    want = tetrace.Scene.from_mesh((v, f), lazy=False).contains(p)
    assert np.array_equal(got, want)
    inner = ((1 < p) & (p < 2)).all(axis=1)
    assert not got[inner].any() and got[((0 < p) & (p < 3)).all(axis=1) & ~inner].all()


def test_an_open_surface_still_takes_the_tetrahedralizations_rule(meshed):
    # A box without its top: entered for free, so its inside is outside by the fewest
    # crossings; one ray's count would depend on the ray. Meshed for it.
    v, f = box([-0.5] * 3, [0.5] * 3)
    top = np.all(v[f][:, :, 2] == 0.5, axis=1)
    scene = tetrace.Scene.from_mesh((v, f[~top]))
    with pytest.warns(UserWarning, match="not closed"):
        got = scene.contains(np.array([[0.0, 0, 0], [0.25, -0.25, -0.25]]), mode="parity")
    assert not got.any() and meshed == [1]


def test_duplicate_and_zero_area_triangles_do_not_count(meshed):
    # The caller's duplicates and zero-area triangles are dropped by cleaning (the surface
    # the tetrahedralization is built from and is_closed counts): a duplicated face would
    # otherwise flip every ray through it.
    v, f = box([0, 0, 0], [1, 1, 1])
    extra = np.array([f[0], f[0][::-1], [0, 0, 1], [0, 1, 1]])
    scene = tetrace.Scene.from_mesh((v, np.vstack([f, extra])))
    assert scene.is_closed
    assert scene._surface_info().kept.tolist() == [True] * 12 + [False] * 4
    g = np.arange(-1, 6) * 0.25
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    want = ((0 <= p) & (p <= 1)).all(axis=1)
    assert np.array_equal(scene.contains(p), want) and meshed == []
