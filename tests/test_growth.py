"""The local-complexity bench (issue 5) on a tiny configuration: Spot alone, with one far
copy and in the stadium bowl, a 64x64 camera, one timing pass.

It needs embreex (the ``embree`` fixture skips without it locally, fails under CI).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import tetrace
from tetrace import _native

from tetrace.bench.growth import _parse_world, copy_offsets, make_world, run_growth, stadium_mesh
from tetrace.camera import orbit_views
from tetrace.meshing import load_triangles
from tetrace.scene import default_scene_path

SPOT_TRIANGLES = 5856


@pytest.fixture(scope="module")
def rows(embree, tmp_path_factory):
    out = tmp_path_factory.mktemp("growth")
    lines = []
    rows = run_growth(None, ["alone", "+1", "stadium"], res=64, repeat=1,
                      json_path=out / "growth.json", png_path=out / "growth.png", out=lines.append)
    return {r["world"]: r for r in rows}, lines, out


def test_world_names():
    assert _parse_world("alone") == (0, False)
    assert _parse_world("+100") == (100, False)
    assert _parse_world("stadium") == (0, True)
    assert _parse_world("stadium+7") == (7, True)
    for bad in ("", "alone+1", "+", "arena", "+1x"):
        with pytest.raises(ValueError, match="unknown world"):
            _parse_world(bad)


def test_copies_are_far_and_out_of_view():
    v, f = load_triangles(str(default_scene_path()))
    eye, centre, _ = orbit_views(np.array([v.min(0), v.max(0)]), n=1, distance=1.6)[0]
    diag = np.linalg.norm(v.max(0) - v.min(0))
    off = copy_offsets(100, centre, eye, 30 * diag)
    assert off.shape == (100, 3)
    np.testing.assert_allclose(np.linalg.norm(off, axis=1), 30 * diag)
    # No two copies closer than a few diagonals: they must not touch.
    gaps = np.linalg.norm(off[:, None] - off[None], axis=-1) + np.eye(100) * 1e9
    assert gaps.min() > 3 * diag
    forward = (centre - eye) / np.linalg.norm(centre - eye)
    to = centre + off - eye
    assert (to @ forward / np.linalg.norm(to, axis=1)).max() < np.cos(np.radians(35)) + 1e-12
    wv, wf, n_stadium = make_world(v, f, "stadium+3", eye=eye)
    sv, sf = stadium_mesh(centre, 50 * diag)
    assert n_stadium == len(sf) == 360 and len(wf) == 4 * len(f) + 360
    np.testing.assert_array_equal(wf[:len(f)], f)  # the original's triangle ids come first
    np.testing.assert_allclose(np.linalg.norm(sv - centre, axis=1), 50 * diag)


def test_rows(rows):
    rows, lines, _ = rows
    assert list(rows) == ["alone", "+1", "stadium"]
    assert rows["alone"]["triangles"] == SPOT_TRIANGLES
    assert rows["+1"]["triangles"] == 2 * SPOT_TRIANGLES
    assert rows["stadium"]["triangles"] == SPOT_TRIANGLES + rows["stadium"]["stadium_triangles"]
    assert rows["stadium"]["stadium_triangles"] == 360
    assert rows["+1"]["tets"] > rows["alone"]["tets"]
    for r in rows.values():
        assert r["rays"] == 64 * 64
        assert r["agreement"] >= 0.999 and r["failed"] == 0
        assert 0.2 < r["object_fraction"] < 0.9  # the object fills the middle, not the frame
        assert math.isfinite(r["tets_per_object_ray"]) and r["tets_per_object_ray"] > 0
        assert r["tets_per_miss_ray"] > 0
        for key in ("tetrace_mrays_1", "embreex_mrays_1", "tetrace_object_mrays_1",
                    "embreex_object_mrays_1"):
            assert math.isfinite(r[key]) and r[key] > 0, key
    # The camera sees the same object in every world, and the bowl catches every other ray.
    assert abs(rows["+1"]["object_fraction"] - rows["alone"]["object_fraction"]) < 1e-3
    assert rows["alone"]["nothing_fraction"] > 0.1
    assert rows["stadium"]["nothing_fraction"] == 0.0
    # The header line, what each caster is and how it was scheduled, the table (its header,
    # rule and three rows), the verdict, the chart.
    assert len(lines) == 6 and len(lines[3].splitlines()) == 5
    ncpu = rows["alone"]["threads_all"]
    assert lines[1] == (f"tetrace = tetrace {tetrace.__version__}: Scene.cast(method="
                        f"{_native.DEFAULT_METHOD}, layout={_native.DEFAULT_LAYOUT}, precision=f32, "
                        f"device=cpu); {ncpu} thread{'s' * (ncpu != 1)}: rayon work stealing over "
                        f"4096-ray chunks (at {ncpu})")
    assert lines[2].startswith("embreex = embreex ") and lines[2].endswith(
        f"EmbreeScene.run, rtcIntersect1 one ray per call, RTC_SCENE_FLAG_ROBUST; {ncpu} "
        f"thread{'s' * (ncpu != 1)}: 4096-ray chunks taken from one shared queue (at {ncpu})")
    assert lines[4].startswith("verdict: from alone") and lines[5].startswith("chart:")


def test_outputs(rows):
    rows, lines, out = rows
    saved = json.loads((out / "growth.json").read_text())
    assert [r["world"] for r in saved] == list(rows)
    assert (out / "growth.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
