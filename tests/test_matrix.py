"""Speed against accuracy: the weight, ``mesher="auto"`` and the benchmark matrix.

The matrix runs here on the bundled scene at a tiny resolution: the tests check that
every row, file and chart is produced and that the numbers in them are right (agreement
of exact settings, Pareto rows not dominated), never how fast anything is.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import tetrace
from conftest import skip_or_fail
from tetrace import auto_mesher, synthetic
from tetrace.bench import matrix
from tetrace.camera import random_rays
from tetrace.meshing import MeshingError, Tetrahedralization, tetrahedralize
from tetrace.scene import default_scene_path

PNG = b"\x89PNG\r\n\x1a\n"


def _tz(points, tets):
    points = np.asarray(points, np.float64)
    return Tetrahedralization(points=points, tets=np.asarray(tets, np.uint32),
                              faces=np.zeros((0, 3), np.uint32), face_triangle=np.zeros(0, np.uint32),
                              domain=np.array([points.min(0), points.max(0)]), preset="quality",
                              n_input_triangles=0, clean=None, repaired=False, timings={})


def test_weight_counts_each_shared_face_once():
    # Two tets on the unit right triangle in z=0, apexes at z=+1 and z=-1: 7 faces.
    p = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, -1)]
    tz = _tz(p, [(0, 1, 2, 3), (0, 2, 1, 4)])
    base = 0.5
    legs = 2 * 0.5  # the faces in x=0 and y=0, per apex
    slant = 0.5 * np.sqrt(3.0)  # the face through (1,0,0), (0,1,0) and the apex
    assert tz.weight() == pytest.approx(base + 2 * (legs + slant), rel=1e-12)


def test_weight_of_a_real_mesh_matches_a_direct_sum():
    tz = tetrahedralize(synthetic.cube(), "quality")
    seen = {}
    for t in tz.tets:
        for face in ((t[1], t[2], t[3]), (t[0], t[2], t[3]), (t[0], t[1], t[3]), (t[0], t[1], t[2])):
            a, b, c = tz.points[list(face)]
            seen[tuple(sorted(face))] = 0.5 * np.linalg.norm(np.cross(b - a, c - a))
    assert tz.weight() == pytest.approx(sum(seen.values()), rel=1e-9)


def test_auto_picks_the_fewest_tets_among_the_lightest(embree):
    tz = tetrahedralize(str(default_scene_path()), mesher="auto")
    auto = tz.auto
    rows = [r for r in auto["candidates"] if "tets" in r]
    assert {"quality", "quality7", "quality3"} <= {r["setting"] for r in rows}
    ok = [r for r in rows if r["accuracy"] >= auto["accuracy"]]
    w_min = min(r["weight"] for r in ok)
    near = [r for r in ok if r["weight"] <= (1 + auto["tolerance"]) * w_min]
    chosen = next(r for r in rows if r["setting"] == auto["setting"])
    assert chosen["tets"] == min(r["tets"] for r in near) == len(tz.tets)
    assert chosen["accuracy"] >= auto["accuracy"]
    quality = next(r for r in rows if r["setting"] == "quality")
    assert chosen["tets"] <= quality["tets"]
    assert tz.weight() == pytest.approx(chosen["weight"])


def test_auto_measures_a_repaired_scene(embree):
    # Two overlapping boxes intersect: the exact route repairs them, so the result is no
    # longer exact by construction and its accuracy is measured against Embree.
    v, f = synthetic.touching_boxes(offset=0.25)
    scene = tetrace.Scene.from_mesh((v, f), mesher="auto", accuracy=0.99)
    first = scene.tetrahedralization.auto["candidates"][0]
    assert first["repaired"] and 0.99 <= first["accuracy"] < 1.0 + 1e-12
    o, d = random_rays(np.array([v.min(0), v.max(0)]), 2000, seed=3)
    hits = scene.cast(o, d, precision="f64")
    assert (hits.status != tetrace.FAILED).all()


def test_auto_raises_when_no_setting_meets_the_target(monkeypatch, embree):
    monkeypatch.setattr(auto_mesher, "_exact", lambda tz: False)
    monkeypatch.setattr(auto_mesher, "measure_accuracy", lambda *a, **k: 0.5)
    monkeypatch.setattr(auto_mesher, "AUTO_RATIOS", (5.0, 7.0))
    monkeypatch.setattr(auto_mesher, "AUTO_EPSILONS", (3e-3,))
    with pytest.raises(MeshingError, match=r"no setting reached accuracy 0.999 \(best 0.500000\)"):
        tetrahedralize(synthetic.cube(), mesher="auto")


def test_auto_rejects_bad_targets():
    with pytest.raises(ValueError, match="accuracy must be in"):
        tetrahedralize(synthetic.cube(), mesher="auto", accuracy=1.5)
    with pytest.raises(ValueError, match="accuracy is a target for mesher='auto'"):
        tetrahedralize(synthetic.cube(), mesher="tetgen", accuracy=0.9)


def test_pareto_keeps_only_undominated_rows():
    rows = [dict(scene="a", ratio=r, plane_agreement=a, rays=10)
            for r, a in [(1.0, 0.9), (0.5, 1.0), (0.4, 0.95), (0.8, 0.99), (0.8, 0.98)]]
    rows.append(dict(scene="b", ratio=0.1, plane_agreement=0.5, rays=10))
    best = matrix.pareto(rows)
    assert [(r["scene"], r["ratio"], r["plane_agreement"]) for r in best] == [
        ("a", 1.0, 0.9), ("a", 0.8, 0.99), ("a", 0.5, 1.0), ("b", 0.1, 0.5)]


def test_matrix_writes_rows_files_and_charts(tmp_path, embree):
    lines = []
    res = matrix.run_matrix([str(default_scene_path())],
                            settings=["constrained", "quality", "quality3"],
                            methods=["aman2022", "robust"], layouts=["tet32", "tet20"],
                            precisions=["f32", "f64"], threads=["1"], res=16, repeat=1,
                            out_dir=tmp_path, out=lines.append)
    rows = res["rows"]
    ours = [r for r in rows if r["caster"] == "tetrace"]
    assert len(ours) == 3 * 2 * 2 * 2
    assert [r["caster"] for r in rows if r["caster"] != "tetrace"][0] == "embreex"
    o3d, why = matrix.open3d_peer()
    assert any(r["caster"] == "open3d" for r in rows) == (o3d is not None)
    for r in ours:
        # Exact TetGen settings name Embree's triangle on all but rays through edges.
        assert r["plane_agreement"] >= 0.999 and r["failed"] == 0
        assert r["tets"] > 0 and r["weight"] > 0 and r["mem_mb"] > 0 and r["tets_per_ray"] > 0
        assert r["ratio"] == pytest.approx(r["mrays"] / rows[0]["mrays"])
    tets = {r["setting"]: r["tets"] for r in ours}
    assert tets["constrained"] < tets["quality"] < tets["quality3"]
    for name in ("speed_accuracy", "build", "weight_time"):
        assert res["charts"][name].read_bytes()[:8] == PNG
    assert len(json.loads((tmp_path / "matrix.json").read_text())) == len(rows)
    csv_lines = (tmp_path / "matrix.csv").read_text().strip().splitlines()
    assert len(csv_lines) == len(rows) + 1 and csv_lines[0].startswith("scene,")
    for r in res["pareto"]:
        assert not any(o["ratio"] > r["ratio"] and o["plane_agreement"] > r["plane_agreement"]
                       for o in ours)
    assert np.isfinite(res["weight_time_r"]) and res["weight_steps_r"] > 0.5
    assert any("Pareto-best" in line for line in lines)
    again = matrix.report(json.loads((tmp_path / "matrix.json").read_text()), tmp_path / "re",
                          out=lambda line: None)
    assert [r["setting"] for r in again["pareto"]] == [r["setting"] for r in res["pareto"]]


def test_matrix_skips_a_missing_peer_and_names_why(tmp_path, monkeypatch, embree):
    monkeypatch.setattr(matrix, "open3d_peer", lambda: (None, "open3d not available (test)"))
    lines = []
    rows = matrix.run_matrix([str(default_scene_path())], settings=["quality"],
                             methods=["aman2022"], layouts=["tet32"], precisions=["f32"],
                             threads=["1"], res=8, repeat=1, out_dir=tmp_path,
                             out=lines.append)["rows"]
    assert {r["caster"] for r in rows} == {"embreex", "tetrace"}
    assert any("Open3D peer skipped: open3d not available (test)" in line for line in lines)


def test_matrix_command_line(tmp_path, embree):
    code = matrix.matrix_main(["--quick", "--res", "8", "--repeat", "1", "--settings", "quality",
                               "--methods", "aman2022", "--precisions", "f32",
                               "--out", str(tmp_path)])
    assert code == 0
    rows = json.loads((tmp_path / "matrix.json").read_text())
    assert {r["setting"] for r in rows if r["caster"] == "tetrace"} == {"quality"}
    with pytest.raises(ValueError, match="unknown settings"):
        matrix.run_matrix([], settings=["nope"], methods=[], layouts=[], precisions=[],
                          threads=[], res=8, repeat=1, out_dir=tmp_path)


def test_matrix_gpu_rows(tmp_path, embree):
    from tetrace import gpu

    try:
        gpu.device()
    except tetrace.GpuError as e:
        skip_or_fail(f"no GPU adapter: {e}")
    rows = matrix.run_matrix([str(default_scene_path())], settings=["quality"],
                             methods=["aman2022"], layouts=["tet32"], precisions=["f32"],
                             threads=["1"], res=16, repeat=1, out_dir=tmp_path, gpu=True,
                             out=lambda line: None)["rows"]
    rows = [r for r in rows if r.get("device") == "gpu"]
    assert {(r["method"], r["layout"]) for r in rows} == set(gpu.kernels())
    for r in rows:
        assert r["plane_agreement"] >= 0.999 and r["failed"] == 0 and r["kernel_mrays"] > 0


def test_accuracy_counts_nearby_hits_on_neighbouring_triangles(embree):
    # A mesher whose faces name a neighbour of the triangle they lie on (as fTetWild's did
    # before the cast learnt to pick the neighbour the ray crosses): the hits are in the
    # right place on the wrong triangle. Within HIT_DISTANCE of Embree's point they agree.
    import dataclasses

    v, f = tetrace.meshing.load_triangles(str(default_scene_path()))
    tz = tetrahedralize((v, f))
    offsets, ids = tetrace.meshing.neighbour_triangles(tz.clean, len(f))
    shifted = ids[offsets[tz.face_triangle]]  # the first neighbour of each named triangle
    tz = dataclasses.replace(tz, face_triangle=shifted.astype(np.uint32))
    strict = auto_mesher.measure_accuracy(tz, v, f, rays=4000, hit_distance=0.0)
    loose = auto_mesher.measure_accuracy(tz, v, f, rays=4000, hit_distance=1e-3)
    anywhere = auto_mesher.measure_accuracy(tz, v, f, rays=4000, hit_distance=1.0)
    # Measured: 0.80, 0.87 (Spot's triangles are coarse: a neighbour's plane can pass
    # farther than 1e-3 of the diagonal from the hit), 1.0.
    assert strict < 0.9 and loose > strict + 0.05 and anywhere >= 0.999
