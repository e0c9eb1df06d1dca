"""``python -m tetrace.bench gpu`` (issue 34, item 6): a scene saved with ``--save`` is benched
from its ``.tetrace`` file (a GPU machine has no mesher); each ray set gets one row whose phases,
rates and handed-back share come from the cast's own timings, judged by the exact referee.
Times are printed, never asserted (benchmarks, not timed tests)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tetrace
from tetrace.bench.__main__ import main
from tetrace.bench.casters import gpu_cast_timed
from tetrace.dev.camera import orbit_view, pinhole

from conftest import gpu_device


def test_saved_scene_is_benched_row_by_row(tmp_path, capsys):
    gpu_device()
    assert main(["gpu", "--save", str(tmp_path)]) == 0
    saved = tmp_path / "spot.tetrace"
    assert saved.exists()
    out_json = tmp_path / "rows.json"
    args = ["gpu", str(saved), "--width", "40", "--height", "30", "--random", "500"]
    args += ["--sample", "300", "--repeat", "1", "--json", str(out_json), "--check"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "host ns/ray" in printed and "camera 40×30" in printed and "random 500" in printed
    rows = json.loads(out_json.read_text())["rows"]
    assert [(r["rays"], r["n"]) for r in rows] == [("camera 40×30", 1200), ("random 500", 500)]
    for r in rows:
        # --check passed: the referee found every judged ray right
        assert r["judged"] == 300 and r["right"] == 300
        assert 0 <= r["handed_back"] <= r["walked"] / r["n"] <= 1
        phases = sum(r[k] for k in ("locate_ms", "upload_ms", "kernel_ms", "readback_ms"))
        assert phases <= r["wall_ms"]
        assert r["host_ns_per_ray"] > 0 and r["cpu_exact_mrays_per_s"] > 0


@pytest.fixture(scope="module")
def spot(tmp_path_factory):
    path = tmp_path_factory.mktemp("saved") / "spot.tetrace"
    tetrace.Scene.from_mesh(tetrace.scene.default_scene_path()).save(path)
    return tetrace.Scene.load(path)


def test_timed_cast_returns_the_gpu_cast_and_its_phases(spot):
    gpu_device()
    scene = spot
    v = scene.vertices
    o, d = pinhole(*orbit_view(np.array([v.min(0), v.max(0)])), width=24, height=16)
    best, host, hits, _ = gpu_cast_timed(scene, o, d, 2)
    want = scene.cast(o, d)  # the CPU exact default: the GPU's default answers bit for bit
    for field in ("status", "triangle", "t"):
        np.testing.assert_array_equal(getattr(hits, field), getattr(want, field))
    assert best["wall"] >= best["kernel"] >= best["kernel_min"] > 0
    assert host * len(o) <= best["wall"]
