"""Reshetov's BVH (``accel="reshetov_bvh"``, issue 16), one ray at a time and in packets with
frustum vertex culling (``"reshetov_bvh_packets"``, ``"reshetov_bvh_packets8"``), and Portalez
& Duguet's octree (``"portalez_octree"``) keep tetrace's contract.

Its answers are judged by the exact referee on every local stress family (rays through
vertices, along edges, in face planes, from the surface, at tmin, with directions from
1e-30 to 1e30, far from the origin in float32 ...) and on one shared scene, in both
precisions, and compared ray for ray with the tet walk's (the exact default): closest hits,
any hits, all hits and counts. The Rust tests (``src/accel/reshetov_bvh/tests.rs``) add
triangles outside float32's range and the tree's invariants.
"""

import numpy as np
import pytest

import tetrace
from tetrace.dev.compare import agreement
from tetrace.dev.stress import FAMILIES, SHARED_SCENES, build_scene, cases, make_case, subset
from tetrace.hits import HIT
from tetrace.referee import Referee, judge, judge_lists

from conftest import own_default_scene

#: Rays per family (the certified candidates of each family).
N = 600
PRECISIONS = ("f32", "f64")
LOCAL = [f for f in FAMILIES if f not in SHARED_SCENES]
BVH = "reshetov_bvh"
PACKETS = ("reshetov_bvh_packets", "reshetov_bvh_packets8")
OCTREE = "portalez_octree"
#: The ways of walking the BVH (the sweep's rows).
WALKS = (BVH, *PACKETS)
#: Every accelerator that tests triangles.
ACCELS = (*WALKS, OCTREE)


@pytest.fixture(scope="module")
def local():
    return {c.family: (c, build_scene(c)) for c in cases(N, seed=4, families=LOCAL)}


def _check_case(case, scene, accel=BVH):
    """Closest hits right by the referee and equal to the walk's; any hits equal to the
    closest hits' status; all hits right by the referee's crossings, counts the walk's."""
    tie_decided = 0
    for p in PRECISIONS:
        o, d = case.rays(p)
        kw = dict(tmin=case.tmin, tmax=case.tmax, precision=p, invalid="mark")
        bvh = scene.cast(o, d, accel=accel, **kw)
        walk = scene.cast(o, d, **kw)
        verdict = case.verdicts[p]
        masks = judge(bvh, verdict)
        bad = {k: int(m.sum()) for k, m in masks.items() if k not in ("right", "invalid")}
        assert masks["right"].sum() == (~masks["invalid"]).sum(), (case.family, p, bad)
        np.testing.assert_array_equal(bvh.status, walk.status)
        same = bvh.triangle == walk.triangle
        # Another triangle than the walk's only where several tie at the first hit.
        assert (verdict.ties[~same] > 1).all(), (case.family, p)
        tie_decided += int((~same).sum())
        hit = same & (bvh.status == HIT)
        np.testing.assert_array_equal(bvh.t[hit], walk.t[hit])
        occluded, status = scene.occluded(o, d, accel=accel, return_status=True, **kw)
        np.testing.assert_array_equal(status, bvh.status)
        if p == "f64":
            lists = scene.intersections(o, d, accel=accel, **kw)
            crossings = Referee(case.vertices, case.faces).crossings(o, d, case.tmin, case.tmax)
            j = judge_lists(lists.offsets, lists.t, lists.triangle, crossings, status=lists.status)
            valid = ~j["invalid"]
            assert j["right"][valid].all(), (
                case.family,
                {k: int(m.sum()) for k, m in j.items() if k != "right"},
            )
            counts = scene.count_intersections(o, d, accel=accel, **kw)
            np.testing.assert_array_equal(counts, scene.count_intersections(o, d, **kw))
            np.testing.assert_array_equal(counts, lists.counts.reshape(counts.shape))
    return tie_decided


@pytest.mark.parametrize("accel", ACCELS)
@pytest.mark.parametrize("family", LOCAL)
def test_bvh_is_right_and_answers_as_the_walk(local, family, accel):
    case, scene = local[family]
    assert len(case) > 0
    _check_case(case, scene, accel)


def test_bvh_is_right_on_a_shared_scene(scene_path):
    case = make_case("fandisk", N, seed=4, path=scene_path(SHARED_SCENES["fandisk"]))
    case = subset(case, N)
    scene = build_scene(case)
    for accel in ACCELS:
        _check_case(case, scene, accel)


@pytest.mark.parametrize("accel", PACKETS)
def test_packets_cull_and_answer_as_one_ray(accel):
    """Packets on a camera's rays: the frustum culls (the share of ray-triangle tests culled
    is computed: above 0, below 1, as rays hit) and every answer is the one-ray tree's."""
    from tetrace.dev.camera import orbit_views, pinhole

    scene = own_default_scene()
    v = scene.vertices
    eye, target, up = orbit_views(np.array([v.min(0), v.max(0)]), n=1, distance=1.6)[0]
    o, d = pinhole(eye, target, up, fov_deg=40.0, width=64, height=64)
    scene.build_bvh()
    before = scene.bvh_info()
    assert before["packet_tests"] == before["packet_culled"] == 0
    packets = scene.cast(o, d, accel=accel)
    info = scene.bvh_info()
    tests, culled = info["packet_tests"], info["packet_culled"]
    assert 0 < culled < tests, info
    assert info["packet_leaves_frustum"] > 0, info
    one = scene.cast(o, d, accel=BVH)
    assert (one.status == HIT).sum() > 1000
    for field in ("status", "t", "triangle", "u", "v"):
        np.testing.assert_array_equal(getattr(packets, field), getattr(one, field))
    # One ray at a time adds nothing to the packets' counts.
    assert scene.bvh_info()["packet_tests"] == tests


def test_bvh_options_and_shape():
    """The accel names, the BVH's parameters (checked), its shape and memory, and the
    refusals: an unknown accel, a float method, the GPU."""
    assert tetrace.accels() == [
        "tetwalk",
        BVH,
        *PACKETS,
        OCTREE,
        "exact_bvh",
        "exact_bvh_packets",
    ]
    scene = own_default_scene()
    n_triangles = len(scene.faces)
    built = scene.build_bvh(cost_ratio=4.0, max_leaf=32, bins=8)
    assert built["leaves"] * 32 >= n_triangles and built["nodes"] == 2 * built["leaves"] - 1
    assert (built["cost_ratio"], built["max_leaf"], built["bins"]) == (4.0, 32, 8)
    assert scene.bvh_info() == built
    assert scene.memory()["bvh"] == built["bytes"] > 72 * n_triangles
    fine = scene.build_bvh(cost_ratio=0.0, max_leaf=1)
    assert fine["leaves"] >= built["leaves"]


def test_exact_bvh_options_shape_and_refusals():
    """The 8-wide BVH's parameters (checked, kept by save and load), its shape and memory,
    and its answers: the exact walk's on the bundled scene's camera and random rays."""
    scene = own_default_scene()
    n = len(scene.faces)
    lo, hi = (np.asarray(x) for x in scene.domain)
    rng = np.random.default_rng(9)
    o = lo + rng.random((3000, 3)) * (hi - lo)
    d = rng.normal(size=(3000, 3))
    built = scene.build_exact_bvh(cost_ratio=2.0, max_leaf=4, bins=8, leaf_size=2)
    assert (built["cost_ratio"], built["max_leaf"], built["bins"], built["leaf_size"]) == (
        2.0,
        4,
        8,
        2,
    )
    assert scene.exact_bvh_info() == built
    assert scene.memory()["exact_bvh"] == built["bytes"] > 76 * n
    # Eight children at most per node; a leaf holds at most max(max_leaf, leaf_size) = 4.
    assert 1 <= built["children_per_node"] <= 8 and built["leaves"] * 4 >= n
    for bad in (dict(max_leaf=17), dict(leaf_size=0), dict(bins=1), dict(cost_ratio=-1.0)):
        with pytest.raises(ValueError, match=next(iter(bad))):
            scene.build_exact_bvh(**bad)
    with pytest.raises(ValueError, match="exit method"):
        scene.cast(o, d, accel="exact_bvh", method="aman2022")
    # The same answers as Reshetov's tree (the same tie rule), bit for bit, in both
    # precisions; and the same any-hit statuses.
    for dtype in (np.float32, np.float64):
        o_, d_ = o.astype(dtype), d.astype(dtype)
        a = scene.cast(o_, d_, accel="exact_bvh")
        b = scene.cast(o_, d_, accel=BVH)
        assert (a.status == HIT).sum() > 500
        np.testing.assert_array_equal(a.status, b.status)
        np.testing.assert_array_equal(a.triangle, b.triangle)
        np.testing.assert_array_equal(a.t.view(np.uint8), b.t.view(np.uint8))
        np.testing.assert_array_equal(
            scene.occluded(o_, d_, accel="exact_bvh"), scene.occluded(o_, d_, accel=BVH)
        )
    for bad in (
        dict(cost_ratio=-1.0),
        dict(cost_ratio=float("nan")),
        dict(max_leaf=0),
        dict(bins=1),
    ):
        with pytest.raises(ValueError, match=next(iter(bad))):
            scene.build_bvh(**bad)
    o = np.zeros((4, 3))
    d = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [1.0, 1.0, 1.0]])
    with pytest.raises(ValueError, match="unknown accel"):
        scene.cast(o, d, accel="kdtree")
    with pytest.raises(ValueError, match="exit method"):
        scene.cast(o, d, accel=BVH, method="aman2022")
    with pytest.raises(ValueError, match="CPU only"):
        scene.cast(o, d, accel=BVH, device="gpu")
    # Parameters change the tree, never an answer.
    a = scene.cast(o, d, accel=BVH)
    scene.build_bvh()
    b = scene.cast(o, d, accel=BVH)
    for field in ("status", "t", "triangle"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_bvh_sweep_measures_every_tree(embree):
    """``python -m tetrace.bench bvh`` (the SAH-ratio sweep) builds each tree, casts it, and
    has the referee judge it: every row right, the shapes computed, and the larger ratio's
    tree no larger."""
    from tetrace.bench.bvh import run_bvh_sweep

    lines = []
    rows = run_bvh_sweep(None, res=24, ratios=(0.0, 100.0), leaves=(8,), repeat=1, out=lines.append)
    assert [r["accel"] for r in rows] == ["tetwalk", *WALKS, *WALKS]
    for r in rows:
        assert r["right"] == 1.0 and r["nodes_per_ray"] > 0 and r["mrays_per_s"] > 0, r
        # Packets report the share culled (computed: rays hit, so not every test is culled).
        assert ("culled" in r) == (r["accel"] in PACKETS), r
        assert 0 <= r.get("culled", 0) < 1, r
    fine, coarse = rows[1], rows[1 + len(WALKS)]
    assert coarse["leaves"] < fine["leaves"] and coarse["bytes"] < fine["bytes"]
    assert any("BVH sweep" in line for line in lines)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_exact_bvh_packets_answer_as_one_ray(precision):
    """The exact BVH walked by packets (consecutive camera rays share the eye) answers every
    column as the one-ray walk, bit for bit, and rightly by the referee; a chunk of rays with
    their own origins walks them alone, with the same answers."""
    from tetrace.dev.camera import orbit_views, pinhole

    scene = tetrace.default_scene()
    v, f = scene.vertices, scene.faces
    eye, target, up = orbit_views(np.array([v.min(0), v.max(0)]), n=1, distance=1.6)[0]
    dtype = np.float32 if precision == "f32" else np.float64
    o, d = pinhole(eye, target, up, fov_deg=40.0, width=64, height=48, dtype=dtype)
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    # The same rays again, each from its own point on its line (no packets form).
    step = np.random.default_rng(2).uniform(0.0, 0.5, (len(o), 1))
    o2 = (o + step * d).astype(dtype)
    for origins in (o, o2):
        packets = scene.cast(origins, d, accel="exact_bvh_packets")
        one = scene.cast(origins, d, accel="exact_bvh", packet=False)
        default = scene.cast(origins, d)  # the CPU default
        assert (one.status == HIT).sum() > 500
        for field in ("status", "t", "triangle", "u", "v", "point", "normal"):
            np.testing.assert_array_equal(getattr(packets, field), getattr(one, field), field)
            np.testing.assert_array_equal(getattr(default, field), getattr(one, field), field)
    r = Referee(v, f).first_hits(o, d)
    score = agreement(scene.cast(o, d, accel="exact_bvh_packets"), r)
    assert score.right == score.rays == len(o), score


@pytest.mark.parametrize("precision", PRECISIONS)
def test_rays_from_one_origin_answer_as_one_ray(precision):
    """Rays from one origin take the fan by default (``src/accel/exact_bvh/fan.rs``: a grid
    over their directions, built per cast): a camera, and a sensor's sweep over the whole
    sphere (every side of the fan's cube), from eyes around the model and one just off its
    surface. Closest hits (every column), any hits and all hits equal the one-ray walk's
    (``packet=False``) bit for bit, and the referee finds every closest hit and every list
    right."""
    from tetrace.dev.camera import orbit_views, pinhole

    scene = tetrace.default_scene()
    v, f = scene.vertices, scene.faces
    box = np.array([v.min(0), v.max(0)])
    dtype = np.float32 if precision == "f32" else np.float64
    referee = Referee(v, f)
    # Enough rays that the default takes the fan (at least 1024, and half the triangles).
    sphere = np.random.default_rng(11).normal(size=(4 * len(f), 3))
    normal = np.cross(v[f[0, 1]] - v[f[0, 0]], v[f[0, 2]] - v[f[0, 0]])
    near = v[f[0]].mean(0) + 1e-3 * normal / np.linalg.norm(normal)
    sets = []
    for eye, target, up in orbit_views(box, n=3, distance=1.6):
        o, d = pinhole(eye, target, up, fov_deg=40.0, width=96, height=64, dtype=dtype)
        sets.append((o.reshape(-1, 3), d.reshape(-1, 3)))
    for eye in (box[1] + (box[1] - box[0]), near):
        sets.append((np.tile(eye, (len(sphere), 1)).astype(dtype), sphere.astype(dtype)))
    hits = 0
    for o, d in sets:
        fan, one = scene.cast(o, d), scene.cast(o, d, packet=False)
        for field in ("status", "t", "triangle", "u", "v", "point", "normal"):
            np.testing.assert_array_equal(getattr(fan, field), getattr(one, field), field)
        np.testing.assert_array_equal(scene.occluded(o, d), scene.occluded(o, d, packet=False))
        lists, lists1 = scene.intersections(o, d), scene.intersections(o, d, packet=False)
        for field in ("offsets", "t", "triangle", "point", "status"):
            np.testing.assert_array_equal(getattr(lists, field), getattr(lists1, field), field)
        score = agreement(fan, referee.first_hits(o, d))
        assert score.right == score.rays == len(o), score
        masks = judge_lists(
            lists.offsets, lists.t, lists.triangle, referee.crossings(o, d), status=lists.status
        )
        assert masks["right"].all(), {k: int(m.sum()) for k, m in masks.items()}
        hits += int((fan.status == HIT).sum())
    assert hits > 5000, hits
