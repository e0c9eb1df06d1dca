"""The demo (issue 36): ``python -m tetrace.demo`` runs, writes its image where it says, and
the image shows the bundled cow whole and from the front (it showed it from behind, its
legs cut off by the frame)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

import tetrace
from tetrace.bench.scene_bench import FOV_DEG
from tetrace.dev import demo
from tetrace.dev.camera import orbit_view, pinhole
from tetrace.scene import default_scene_path

REPO = Path(__file__).resolve().parents[1]


def test_demo_camera_sees_spot_whole_and_from_the_front():
    scene = tetrace.Scene.from_mesh(default_scene_path(), progress=False)
    v = scene.vertices
    view = orbit_view(np.array([v.min(0), v.max(0)]), demo.AZIMUTH, demo.ELEVATION, demo.DISTANCE)
    n = 128
    o, d = pinhole(*view, fov_deg=FOV_DEG, width=n, height=n, dtype=np.float64)
    hits = scene.cast(o, d).reshape((n, n))
    # whole: no ray along the frame's edges meets the cow; and it fills a fair share
    edges = np.concatenate([hits.hit[0], hits.hit[-1], hits.hit[:, 0], hits.hit[:, -1]])
    assert not edges.any()
    assert hits.hit.mean() > 0.15
    # from the front: Spot faces -z (its snout reaches z = -0.67, its rump z = 1.05), so the
    # camera sees more of the snout's end than of the rump's (from behind: 4 rays to 1682)
    z = hits[hits.hit].point[:, 2]
    assert v[:, 2].min() < -0.6 and v[:, 2].max() > 1.0
    assert (z < -0.5).sum() > 10 * max(1, (z > 0.8).sum())


def test_python_m_tetrace_demo_writes_its_image_where_it_says(tmp_path):
    """The module the demo's help names exists and runs (a small image, one timed cast per
    caster); the image goes to the working directory, which the repository ignores."""
    from PIL import Image

    run = subprocess.run(
        [sys.executable, "-m", "tetrace.demo", "--size", "64", "--repeat", "1"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    assert f"image: {demo.DEFAULT_OUT}" in run.stdout
    assert [p.name for p in tmp_path.iterdir()] == [demo.DEFAULT_OUT]
    image = np.asarray(Image.open(tmp_path / demo.DEFAULT_OUT).convert("L"))
    assert image.shape == (64, 64)
    assert image.any() and not image[[0, -1]].any() and not image[:, [0, -1]].any()
    usage = subprocess.run(
        [sys.executable, "-m", "tetrace.demo", "--help"], capture_output=True, text=True
    ).stdout
    assert usage.startswith("usage: python -m tetrace.demo ")
    if (REPO / ".git").exists() and shutil.which("git"):
        ignored = subprocess.run(
            ["git", "-C", str(REPO), "check-ignore", "-q", demo.DEFAULT_OUT], check=False
        )
        assert ignored.returncode == 0, f"{demo.DEFAULT_OUT} is not in .gitignore"
