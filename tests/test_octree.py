"""Portalez & Duguet's octree (``accel="portalez_octree"``, issue 16): its statistics (Tables 1
and 4) are computed, the 2:1 balance adds leaves and bounds the links, parameters are checked,
and balanced or not it answers as the tet walk. The stress families and fandisk are judged in
``tests/test_bvh.py`` (which runs every accelerator that tests triangles); the Rust tests
(``src/accel/portalez_octree/tests.rs``) check the tables against the paper's and the build's
invariants.
"""

import numpy as np
import pytest

from tetrace.hits import HIT

from conftest import own_default_scene

OCTREE = "portalez_octree"


def _camera(scene, res=48):
    from tetrace.dev.camera import orbit_views, pinhole

    v = scene.vertices
    eye, target, up = orbit_views(np.array([v.min(0), v.max(0)]), n=1, distance=1.6)[0]
    return pinhole(eye, target, up, fov_deg=40.0, width=res, height=res)


def test_octree_statistics_and_balance():
    """Leaves, links per leaf, bytes per part: computed and consistent; the balanced tree has
    at least the unbalanced one's leaves and at most 4 links per face (24 per leaf); casts on
    both give the walk's answers."""
    scene = own_default_scene()
    o, d = _camera(scene)
    walk = scene.cast(o, d)
    assert (walk.status == HIT).sum() > 500
    infos = {}
    for balance in (True, False):
        info = scene.build_octree(max_depth=7, leaf_size=8, balance=balance)
        assert scene.octree_info() == info
        infos[balance] = info
        assert info["balance"] is balance and info["max_depth"] == 7 and info["leaf_size"] == 8
        assert 0 < info["depth"] <= 7
        assert info["leaves"] > info["empty_leaves"] >= 0
        assert 0 < info["neighbours_per_leaf"] <= 24
        assert info["triangles_per_leaf"] > 0
        parts = ("cube_map", "octree", "triangles", "boxes", "hierarchy")
        assert all(info[f"bytes_{p}"] > 0 for p in parts), info
        assert info["bytes"] == sum(info[f"bytes_{p}"] for p in parts)
        assert scene.memory()["octree"] == info["bytes"]
        # A leaf record is 16 bytes plus 4 per link (Portalez & Duguet's layout).
        assert info["bytes_octree"] == pytest.approx(
            info["leaves"] * (16 + 4 * info["neighbours_per_leaf"]), rel=1e-9
        )
        got = scene.cast(o, d, accel=OCTREE)
        for field in ("status", "triangle", "t"):
            np.testing.assert_array_equal(getattr(got, field), getattr(walk, field))
        assert got.steps[got.status == HIT].min() >= 1
    assert infos[True]["leaves"] >= infos[False]["leaves"]
    assert infos[True]["node_links"] == 0


def test_octree_refuses_bad_parameters_and_methods():
    scene = own_default_scene()
    for bad in (dict(max_depth=17), dict(leaf_size=0), dict(leaf_size=1 << 17)):
        with pytest.raises(ValueError, match=next(iter(bad))):
            scene.build_octree(**bad)
    o = np.zeros((2, 3))
    d = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    with pytest.raises(ValueError, match="exit method"):
        scene.cast(o, d, accel=OCTREE, method="maria2017")
    with pytest.raises(ValueError, match="CPU only"):
        scene.cast(o, d, accel=OCTREE, device="gpu")


def test_octree_bench_measures_both_balances(embree):
    """``python -m tetrace.bench octree`` builds balanced and unbalanced trees, casts them and
    has the referee judge them: every row right, the statistics computed."""
    from tetrace.bench.octree import run_octree_stats

    lines = []
    rows = run_octree_stats(None, res=24, depths=(6,), leaf_sizes=(8,), repeat=1, out=lines.append)
    assert [r["accel"] for r in rows] == ["tetwalk", OCTREE, OCTREE]
    assert [r.get("balance") for r in rows[1:]] == [True, False]
    for r in rows:
        assert r["right"] == 1.0 and r["leaves_per_ray"] > 0 and r["mrays_per_s"] > 0, r
    assert rows[1]["leaves"] >= rows[2]["leaves"] > 0
    assert any("Octree" in line for line in lines)
