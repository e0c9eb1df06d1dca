"""Structures built when needed (issue 35): ``Scene.from_mesh`` loads the triangles and meshes
nothing; the CPU default (the exact BVH) answers every triangle query without a
tetrahedralization, exactly (judged by the referee, and equal to the exact walk's answers);
whatever walks tets builds it, once, with the options from_mesh was given, keeping the BVHs
built before; a scene TetGen cannot mesh still answers; and the core refuses to walk the
placeholder box it holds until then."""

import numpy as np
import pytest

import tetrace
from tetrace import construct
from tetrace.dev import synthetic
from tetrace.dev.camera import orbit_view, pinhole, random_rays
from tetrace.dev.compare import agreement
from tetrace.errors import MeshingError
from tetrace.referee import Referee
from tetrace.scene import default_scene_path

SPOT = str(default_scene_path())


def _lazy(**options):
    scene = tetrace.Scene.from_mesh(SPOT, **options)
    assert not scene.has_ct
    return scene


@pytest.fixture(scope="module")
def eager():
    scene = tetrace.Scene.from_mesh(SPOT, lazy=False)
    assert scene.has_ct
    return scene


def _rays(scene):
    v = scene.vertices
    bounds = np.array([v.min(0), v.max(0)])
    o, d = pinhole(*orbit_view(bounds), width=48, height=40, dtype=np.float32)
    o2, d2 = random_rays(bounds, 3000, seed=4, dtype=np.float32)
    return np.vstack([o.reshape(-1, 3), o2]), np.vstack([d.reshape(-1, 3), d2])


def test_cpu_queries_need_no_tetrahedralization(eager):
    lazy = _lazy()
    assert "not built" in repr(lazy)
    o, d = _rays(lazy)
    h = lazy.cast(o, d)
    walk = eager.cast(o, d, accel="tetwalk")
    for f in ("status", "triangle", "t", "u", "v", "point", "normal"):
        np.testing.assert_array_equal(getattr(h, f), getattr(walk, f), err_msg=f)
    assert (h.tet == -1).all() and (h.status == tetrace.HIT).sum() > 500
    score = agreement(h, Referee(lazy.vertices, lazy.faces).first_hits(o, d))
    assert score.right == score.rays == len(o), score
    np.testing.assert_array_equal(lazy.occluded(o, d), eager.occluded(o, d, accel="tetwalk"))
    np.testing.assert_array_equal(
        lazy.count_intersections(o, d), eager.count_intersections(o, d, accel="tetwalk")
    )
    a, b = lazy.intersections(o, d), eager.intersections(o, d, accel="tetwalk")
    for f in ("offsets", "t", "triangle"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)
    p = o[:500].astype(np.float64)
    np.testing.assert_array_equal(lazy.distance(p), eager.distance(p))
    np.testing.assert_array_equal(
        lazy.contains(p, mode="winding"), eager.contains(p, mode="winding")
    )
    assert not lazy.has_ct, "a triangle query built the tetrahedralization"
    assert lazy.memory()["exact_bvh"] > 0


TRIGGERS = {
    "accel=tetwalk": lambda s, o, d: s.cast(o, d, accel="tetwalk"),
    "a paper's method": lambda s, o, d: s.cast(o, d, method="aman2022"),
    "a layout": lambda s, o, d: s.occluded(o, d, layout="tet32"),
    "n_tets": lambda s, o, d: s.n_tets,
    "tets()": lambda s, o, d: s.tets(),
    "domain": lambda s, o, d: s.domain,
    "tetrahedralization": lambda s, o, d: s.tetrahedralization,
    "build_ct": lambda s, o, d: s.build_ct(),
}


@pytest.mark.parametrize("what", list(TRIGGERS))
def test_what_walks_tets_builds_the_tetrahedralization_once(what, eager, monkeypatch):
    built = []
    mesh = construct._tetrahedralize
    monkeypatch.setattr(construct, "_tetrahedralize", lambda *a: built.append(1) or mesh(*a))
    lazy = _lazy()
    o, d = _rays(lazy)
    h = lazy.cast(o, d)  # the exact BVH: nothing meshed
    assert built == [] and not lazy.has_ct
    TRIGGERS[what](lazy, o, d)
    assert built == [1] and lazy.has_ct and lazy.build_times["tetgen"] > 0
    assert lazy.n_tets == eager.n_tets  # the same meshing as from_mesh(lazy=False)
    again = lazy.cast(o, d, accel="tetwalk")
    assert built == [1] and lazy.build_ct() is lazy and built == [1]
    np.testing.assert_array_equal(again.tet, eager.cast(o, d, accel="tetwalk").tet)
    np.testing.assert_array_equal(lazy.cast(o, d).t, h.t)


def test_the_bvh_built_before_is_kept(eager):
    lazy = _lazy()
    lazy.build_exact_bvh(leaf_size=2)
    info = lazy.exact_bvh_info()
    lazy.build_ct()
    assert lazy.exact_bvh_info() == info  # not rebuilt with the defaults
    # Shared as it was: its bytes are what the scene without the tetrahedralization counted.
    assert lazy.memory()["exact_bvh"] > 0 and lazy.memory()["points_f64"] > 0


def test_options_reach_the_deferred_meshing(eager):
    lazy = _lazy(preset="constrained", margin=0.1)
    now = tetrace.Scene.from_mesh(SPOT, preset="constrained", margin=0.1, lazy=False)
    assert lazy.tetrahedralization.preset == "constrained"
    np.testing.assert_array_equal(lazy.domain, now.domain)
    assert lazy.n_tets == now.n_tets != eager.n_tets
    assert (lazy.domain[1] - lazy.domain[0] > eager.domain[1] - eager.domain[0]).all()


def test_a_scene_tetgen_cannot_mesh_still_answers():
    v, f = synthetic.touching_boxes()
    scene = tetrace.Scene.from_mesh((v, f), repair=False, mesher="tetgen")
    c = v[f].mean(axis=1)
    o = c + np.array([0.31, 0.77, 1.9])
    d = c - o
    before = scene.cast(o, d)
    score = agreement(before, Referee(v, f).first_hits(o, d))
    assert score.right == score.rays == len(o), score
    with pytest.raises(MeshingError, match="not a valid PLC"):
        scene.build_ct()
    assert not scene.has_ct
    np.testing.assert_array_equal(scene.cast(o, d).t, before.t)


def test_the_core_refuses_to_walk_the_placeholder():
    lazy = _lazy()
    o, d = _rays(lazy)
    q = tetrace.rays.RayRequest(o, d, accel="tetwalk")
    with pytest.raises(ValueError, match="build_ct"):
        lazy._native.query("closest", q.native)
    with pytest.raises(ValueError, match="build_ct"):
        lazy._native.contains(o[:3].astype(np.float64))
    assert not lazy._native.has_ct and not lazy.has_ct


def test_lazy_is_a_bool():
    with pytest.raises(TypeError, match="lazy"):
        tetrace.Scene.from_mesh(SPOT, lazy="yes")


@pytest.mark.parametrize(
    "mesh, words",
    [
        ((np.array([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]]), np.array([[0, 1, 2]])), "non-finite"),
        ((np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 9]])), "out of range"),
        ((np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.zeros((0, 3), int)), "no faces"),
    ],
    ids=["nan-vertex", "index-out-of-range", "no-faces"],
)
def test_bad_input_is_refused_before_anything_is_meshed(mesh, words):
    """What is wrong with the input itself is said at from_mesh, as when it meshed at once."""
    with pytest.raises(MeshingError, match=words):
        tetrace.Scene.from_mesh(mesh)


def test_a_scene_without_its_tetrahedralization_moves_its_triangles_alone(monkeypatch):
    """update_vertices before the CT is built meshes nothing; every query answers on the
    moved triangles (as a scene meshed from them does, and right by the referee); a BVH
    built with other than the default parameters is built again with them; a later
    build_ct meshes the moved triangles."""
    built = []
    mesh = construct._tetrahedralize
    monkeypatch.setattr(construct, "_tetrahedralize", lambda *a: built.append(1) or mesh(*a))
    lazy = _lazy()
    lazy.build_exact_bvh(leaf_size=2)
    info = lazy.exact_bvh_info()
    v = lazy.vertices
    moved = v + 0.05 * np.sin(v[:, [1, 2, 0]] * 7.0) * (v.max(0) - v.min(0))
    report = lazy.update_vertices(moved)
    assert report.action == "moved" and report.frames == 1 and built == []
    assert not lazy.has_ct and np.array_equal(lazy.vertices, moved)
    params = ("cost_ratio", "max_leaf", "bins", "leaf_size")
    assert {k: lazy.exact_bvh_info()[k] for k in params} == {k: info[k] for k in params}
    o, d = _rays(lazy)
    h = lazy.cast(o, d)
    score = agreement(h, Referee(moved, lazy.faces).first_hits(o, d))
    assert score.right == score.rays == len(o), score
    meshed = tetrace.Scene.from_mesh((moved, lazy.faces), lazy=False)
    assert built == [1]
    walk = meshed.cast(o, d, accel="tetwalk")
    for f in ("status", "triangle", "t", "u", "v", "point", "normal"):
        np.testing.assert_array_equal(getattr(h, f), getattr(walk, f), err_msg=f)
    lazy.build_ct()
    assert built == [1, 1] and lazy.n_tets == meshed.n_tets
    np.testing.assert_array_equal(lazy.cast(o, d, accel="tetwalk").t, walk.t)
    with pytest.raises(ValueError, match="shape"):
        _lazy().update_vertices(moved[:-1])
