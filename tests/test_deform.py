"""Deformation without rebuild (Lagae & Dutré 2008; docs/deformation.md).

``Scene.update_vertices`` keeps the tetrahedralization's topology and moves its points when
every tet stays positively oriented (checked exactly), and meshes again otherwise. Either
way, every answer afterwards must be the exact answer on the moved mesh: each frame is
judged ray by ray by the exact referee built on the moved vertices, with Embree (a float
caster, built on the moved mesh too) as a second opinion whose disagreements the referee
decides.

The smooth frames use a bend and a twist of amplitude 0.5% of the scene's diagonal, at
which no tet of the ``quality`` meshes of Spot and of the bunny (margin 0.1, see
BUNNY_MARGIN) inverts with the rule of docs/deformation.md, so every frame must be a move.
At 1% some thin tets between the surface and the box corners invert even when every point
follows the exact displacement field (docs/deformation.md) and the scene is rebuilt: that
path is tested by the inverting frames below.
"""

import numpy as np
import pytest

import tetrace
from tetrace.baselines.embree import embree_cast
from tetrace.bench.agreement import ray_sets
from tetrace.dev.compare import agreement
from tetrace.referee import Referee, judge

from conftest import gpu_device

FRAMES = 20
#: Amplitude of the smooth frames, as a fraction of the scene's diagonal (see above).
AMPLITUDE = 0.005
#: The bunny's domain margin: with the default (0.02), a tet joining a box corner to three
#: nearly coplanar vertices of the bunny's flat base (volume 4e-7 of its longest edge cubed)
#: inverts under any frame that tilts the base, however small: a rebuild, rightly.
BUNNY_MARGIN = 0.1


def smooth_frame(rest, k, frames=FRAMES, amplitude=AMPLITUDE):
    """Frame k of a periodic bend plus twist about the scene's vertical axis: displacement
    at most ``amplitude`` x diagonal (the bend) plus a rotation of the same arc length."""
    lo, hi = rest.min(0), rest.max(0)
    c = (lo + hi) / 2
    size = float(np.linalg.norm(hi - lo))
    phase = 2 * np.pi * k / frames
    a = amplitude * size
    y = (rest[:, 1] - c[1]) / (hi[1] - lo[1])
    out = rest.copy()
    out[:, 0] += a * np.sin(phase) * np.sin(np.pi * y)
    out[:, 2] += 0.5 * a * np.cos(phase) * np.cos(np.pi * y)
    angle = a * np.sin(phase + 1.0) * np.sin(np.pi * y) / (size / 2)
    x, z = out[:, 0] - c[0], out[:, 2] - c[2]
    out[:, 0] = c[0] + np.cos(angle) * x - np.sin(angle) * z
    out[:, 2] = c[2] + np.sin(angle) * x + np.cos(angle) * z
    return out


def rays_for(vertices, res, n_random):
    """One orbit camera of res x res rays and ``n_random`` random rays around the scene."""
    bounds = np.array([vertices.min(0), vertices.max(0)])
    sets = ray_sets(bounds, res, n_random)
    (_, oc, dc), (_, orand, drand) = sets[0], sets[-1]
    return (
        np.concatenate([oc.reshape(-1, 3), orand]),
        np.concatenate([dc.reshape(-1, 3), drand]),
    )


def judge_frame(scene, o, d, what):
    """Every ray of the default exact cast is right against the referee on the scene's
    (moved) vertices; where Embree on the same mesh names another triangle, the referee
    finds Embree wrong or both on the exact tie set. Returns the hits."""
    V, F = np.asarray(scene.vertices), np.asarray(scene.faces)
    hits = scene.cast(o, d)
    verdict = Referee(V, F).first_hits(o, d, hint=hits.triangle)
    score = agreement(hits, verdict)
    assert score.failed == 0 and score.right == score.rays == len(o), f"{what}: {score}"
    emb = embree_cast((V, F), o, d)
    same = (emb.status == hits.status) & (
        (hits.status != tetrace.HIT) | (emb.triangle == hits.triangle)
    )
    emb_right = judge(emb, verdict, "f32")["right"]
    tetrace_tri = np.where(hits.status == tetrace.HIT, hits.triangle, -1)
    emb_tri = np.where(emb.status == tetrace.HIT, emb.triangle, -1)
    tie = verdict.in_ties(tetrace_tri) & verdict.in_ties(emb_tri) & (emb_tri >= 0)
    unexplained = np.flatnonzero(~same & emb_right & ~tie)
    assert len(unexplained) == 0, f"{what}: Embree disagrees and is right: {unexplained[:10]}"
    print(f"{what}: {score}; Embree agrees on {int(same.sum())}/{len(o)}")
    return hits


def run_frames(scene, what, *, res=48, n_random=2000):
    rest = np.array(scene.vertices, dtype=np.float64)
    o, d = rays_for(rest, res, n_random)
    before = scene.cast(o, d)
    changed = 0
    for k in range(1, FRAMES + 1):
        V = smooth_frame(rest, k)
        report = scene.update_vertices(V)
        assert report is scene.last_deformation
        assert report.action == "moved", f"{what} frame {k}: {report}"
        assert report.inverted == 0 and report.outside == 0 and report.reason == ""
        assert report.frames == k
        assert set(report.seconds) == {"map", "points", "update", "rebuild", "total"}
        np.testing.assert_array_equal(scene.vertices, V)
        hits = judge_frame(scene, o, d, f"{what} frame {k}")
        changed += int(((hits.triangle != before.triangle) | (hits.t != before.t)).sum())
    # The frames moved the answers (a scene that ignored the update would fail here, and
    # the referee on the moved vertices above).
    assert changed > 0
    return o, d


def test_bundled_scene_follows_smooth_frames(embree):
    scene = tetrace.Scene.from_mesh(tetrace.default_scene_path(), lazy=False)
    run_frames(scene, "spot")


def test_bunny_follows_smooth_frames_and_every_query(scene_path, embree):
    scene = tetrace.Scene.from_mesh(scene_path("bunny.obj"), margin=BUNNY_MARGIN, lazy=False)
    scene.build_bvh(max_leaf=4)  # non-default parameters: kept across the moves
    o, d = run_frames(scene, "bunny")
    assert scene.bvh_info()["max_leaf"] == 4
    # Every query kind answers on the moved mesh: against the referee, and against a scene
    # meshed from scratch on the same vertices (exact answers do not depend on the mesh).
    V, F = np.asarray(scene.vertices), np.asarray(scene.faces)
    fresh = tetrace.Scene.from_mesh((V, F), margin=BUNNY_MARGIN, lazy=False)
    referee = Referee(V, F)
    verdict = referee.first_hits(o, d)
    for accel in ("reshetov_bvh", "portalez_octree"):
        score = agreement(scene.cast(o, d, accel=accel), verdict)
        assert score.right == score.rays == len(o), f"{accel}: {score}"
    np.testing.assert_array_equal(scene.occluded(o, d), verdict.t < np.inf)
    crossings = referee.crossings(o, d)
    np.testing.assert_array_equal(scene.count_intersections(o, d), crossings.count)
    all_hits = scene.intersections(o, d)
    np.testing.assert_array_equal(np.diff(all_hits.offsets), crossings.count)
    lo, hi = V.min(0), V.max(0)
    pts = np.random.default_rng(3).uniform(lo, hi, (3000, 3))
    np.testing.assert_array_equal(scene.contains(pts), fresh.contains(pts))
    near, near_fresh = scene.closest_points(pts), fresh.closest_points(pts)
    np.testing.assert_array_equal(near.distance, near_fresh.distance)


def test_steiner_points_on_triangles_follow_them(embree):
    """A volume bound makes TetGen split the caller's triangles (Steiner points on
    constrained faces) and refine the box's sides: those follow their triangle, these stay,
    and every frame is still a move, answered right."""
    scene = tetrace.Scene.from_mesh(tetrace.default_scene_path(), maxvolume=1e-3, lazy=False)
    o, d = rays_for(np.asarray(scene.vertices), 32, 1000)
    rest = np.array(scene.vertices, dtype=np.float64)
    for k in (2, 5, 8):
        report = scene.update_vertices(smooth_frame(rest, k))
        assert report.action == "moved", report
        judge_frame(scene, o, d, f"spot maxvolume frame {k}")
    counts = scene._point_map.counts
    assert counts["surface"] > 0 and counts["box"] > 8 and counts["volume"] > 0, counts
    # The rebuild keeps the options: the volume bound again splits triangles.
    scene.update_vertices(smooth_frame(rest, 5, amplitude=0.1))
    assert scene.last_deformation.action == "rebuilt"
    assert scene.tetrahedralization.options["maxvolume"] == 1e-3
    judge_frame(scene, o, d, "spot maxvolume rebuilt")


@pytest.fixture
def device():
    return gpu_device()


def test_gpu_buffers_follow_the_move(device):
    """A GPU cast before the move uploads the scene; after it, the robust kernel still
    matches its CPU twin ray for ray (docs/gpu.md), on the moved points."""
    scene = tetrace.Scene.from_mesh(tetrace.default_scene_path(), lazy=False)
    o, d = rays_for(np.asarray(scene.vertices), 48, 2000)
    o, d = o.astype(np.float32), d.astype(np.float32)
    kw = dict(method="robust", layout="tet20")
    scene.cast(o, d, device="gpu", **kw)
    assert any(k.startswith("gpu_") for k in scene.memory())
    scene.update_vertices(smooth_frame(np.asarray(scene.vertices, np.float64), 3))
    assert scene.last_deformation.action == "moved"
    assert not any(k.startswith("gpu_") for k in scene.memory()), "GPU buffers dropped"
    gpu, cpu = scene.cast(o, d, device="gpu", **kw), scene.cast(o, d, **kw)
    for f in ("status", "triangle", "tet", "steps", "t"):
        np.testing.assert_array_equal(getattr(gpu, f), getattr(cpu, f), err_msg=f)


def test_inverting_frames_rebuild_and_stay_right(embree):
    scene = tetrace.Scene.from_mesh(tetrace.default_scene_path(), lazy=False)
    rest = np.array(scene.vertices, dtype=np.float64)
    o, d = rays_for(rest, 48, 2000)
    # A large bend (20x the smooth frames'): thin tets invert.
    report = scene.update_vertices(smooth_frame(rest, 5, amplitude=0.1))
    assert report.action == "rebuilt" and report.inverted > 0, report
    assert "invert" in report.reason and report.frames == 0
    assert report.seconds["rebuild"] > 0
    judge_frame(scene, o, d, "spot, large bend")
    # The rebuilt scene is the new rest state: a small move from it is a move again.
    V = np.array(scene.vertices)
    V2 = V + 1e-4 * float(np.linalg.norm(np.ptp(V, axis=0))) * np.sin(V[:, [1, 2, 0]])
    report = scene.update_vertices(V2)
    assert report.action == "moved" and report.frames == 1, report
    judge_frame(scene, o, d, "spot, after the rebuild")
    # Everything translated by a quarter of the diagonal: points leave the domain box.
    V4 = np.array(scene.vertices) + 0.25 * float(np.linalg.norm(np.ptp(V2, axis=0)))
    report = scene.update_vertices(V4)
    assert report.action == "rebuilt" and report.outside > 0, report
    judge_frame(scene, o + (V4[0] - V2[0]), d, "spot, translated")
    # One vertex pushed through the opposite side of the body: its tets invert (and the
    # scene now crosses itself: the rebuild repairs it).
    V3 = np.array(scene.vertices)
    k = int(np.argmax(V3[:, 0]))
    V3[k, 0] = V3[:, 0].min() + 0.3 * np.ptp(V3[:, 0])
    report = scene.update_vertices(V3)
    assert report.action == "rebuilt" and report.inverted > 0, report
    judge_frame(scene, o + (V4[0] - V2[0]), d, "spot, one vertex pushed through")


def test_bad_input_raises_and_leaves_the_scene(embree):
    scene = tetrace.Scene.from_mesh(tetrace.default_scene_path(), lazy=False)
    V = np.array(scene.vertices)
    o, d = rays_for(V, 16, 500)
    before = scene.cast(o, d)
    nan, inf = V.copy(), V.copy()
    nan[7, 1] = np.nan
    inf[3, 0] = np.inf
    cases = [
        (V[:-1], ValueError, "shape"),
        (V.T, ValueError, "shape"),
        (V[:, :2], ValueError, "shape"),
        (V.ravel(), ValueError, "shape"),
        (nan, ValueError, "vertex 7"),
        (inf, ValueError, "vertex 3"),
        (V.astype(complex), TypeError, "real numbers"),
        (V.astype(object), TypeError, "real numbers"),
        (V > 0, TypeError, "real numbers"),
        ("vertices", TypeError, "real numbers"),
    ]
    for bad, error, words in cases:
        with pytest.raises(error, match=words):
            scene.update_vertices(bad)
        assert scene.last_deformation is None
        np.testing.assert_array_equal(scene.vertices, V)
    after = scene.cast(o, d)
    for f in ("status", "triangle", "t", "tet", "steps"):
        np.testing.assert_array_equal(getattr(after, f), getattr(before, f), err_msg=f)
    # Still usable: float32 and integer vertices are accepted (as float64).
    report = scene.update_vertices(V.astype(np.float32))
    assert report.action in ("moved", "rebuilt")
    judge_frame(scene, o, d, "spot, float32 vertices")
    assert scene.vertices.dtype == np.float64


def test_scenes_that_cannot_follow_in_place_rebuild():
    """A repaired scene (two boxes that cross: cut by the repair) has points on two
    triangles at once; its updates rebuild, saying why, and answer right."""
    cube_v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    cube_f = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    )  # fmt: skip
    v = np.concatenate([cube_v, cube_v + 0.5])
    scene = tetrace.Scene.from_mesh((v, np.concatenate([cube_f, cube_f + 8])), lazy=False)
    assert scene.tetrahedralization.repaired
    V = np.array(scene.vertices) * 1.01
    report = scene.update_vertices(V)
    assert report.action == "rebuilt" and "repaired" in report.reason, report
    o, d = rays_for(V, 16, 500)
    verdict = Referee(V, np.asarray(scene.faces)).first_hits(o, d)
    score = agreement(scene.cast(o, d), verdict)
    assert score.right == score.rays == len(o), score


def test_deformation_is_exported():
    assert tetrace.Deformation is tetrace.scene.Deformation
    assert "Deformation" in tetrace.__all__
