"""A plain ``pip install tetrace`` meshes common scenes and says why it cannot mesh others.

Issue 14: the README's ``tetrace.cast(rays)`` needs Pillow (trimesh loads the bundled
textured spot.obj with it), the Cornell box needs the self-intersection repair (libigl),
and a needle triangle must be named as degenerate, not blamed on self-intersections.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

import tetrace
from tetrace.errors import MeshingError
from tetrace.mesh import clean, repair

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def _dependencies():
    try:
        import tomllib
    except ImportError:  # Python 3.10
        tomllib = pytest.importorskip("tomli")
    with open(PYPROJECT, "rb") as f:
        deps = tomllib.load(f)["project"]["dependencies"]
    return {re.split(r"[<>=!~;\[ ]", d, maxsplit=1)[0].lower() for d in deps}


def test_plain_install_needs_pillow_libigl_and_pytetwild():
    """Pillow loads the bundled scene, libigl repairs self-intersections, pytetwild builds
    the scenes no exact TetGen route can (conference, the two-cylinder engine)."""
    deps = _dependencies()
    assert {"numpy", "trimesh", "tetgen", "libigl", "pillow", "pytetwild"} <= deps
    import igl.copyleft.cgal  # noqa: F401
    import PIL  # noqa: F401
    import pytetwild  # noqa: F401


def test_cast_into_the_bundled_scene():
    """The README's first call: rays into the bundled (textured) spot.obj."""
    o = np.array([[0.0, 0.0, 5.0], [0.0, 0.0, 5.0]])
    d = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    hits = tetrace.cast((o, d))
    assert hits.status.tolist() == [tetrace.HIT, tetrace.MISS]


def _check_cast(scene, vertices, faces):
    """Rays from outside at the centroids of 20 triangles hit a triangle (the same or one
    at the same distance)."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces)
    centre = v.mean(axis=0)
    ids = np.linspace(0, len(f) - 1, 20).astype(int)
    targets = v[f[ids]].mean(axis=1)
    o = np.broadcast_to(centre + 3 * (v.max(0) - v.min(0)), targets.shape)
    hits = scene.cast(o, targets - o)
    assert (hits.status == tetrace.HIT).all()
    assert (hits.t <= 1 + 1e-9).all()


def test_cornell_box_meshes(scene_path):
    """cornell_box.obj has touching triangles: TetGen rejects it unless libigl repairs it."""
    path = scene_path("cornell_box.obj")
    scene = tetrace.Scene.from_mesh(path)
    assert scene.tetrahedralization.repaired
    assert scene.n_triangles == 36
    _check_cast(scene, scene.vertices, scene.faces)


def test_uv_sphere_meshes():
    sphere = trimesh.creation.uv_sphere()
    scene = tetrace.Scene.from_mesh(sphere)
    assert scene.n_triangles == len(sphere.faces)
    _check_cast(scene, sphere.vertices, sphere.faces)


# --------------------------------------------------------------------------- needles

#: Three distinct vertices, collinear up to rounding (0.1 * 3 != 0.3 in doubles): zero area.
ROUNDED_NEEDLE = [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [0.1, 0.2, 0.3]]
#: Exactly collinear, distinct vertices.
EXACT_NEEDLE = [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [0.5, 1.0, 1.5]]


def _with_sphere(needle):
    s = trimesh.creation.icosphere(2)
    v = np.vstack([s.vertices, needle])
    n = len(s.vertices)
    f = np.vstack([s.faces, [[n, n + 1, n + 2]]])
    return v, f, len(s.faces)


@pytest.mark.parametrize("needle", [ROUNDED_NEEDLE, EXACT_NEEDLE], ids=["rounded", "exact"])
def test_zero_area_needle_is_degenerate(needle):
    """A lone zero-area needle is degenerate (its own scale, not the largest triangle's)."""
    v, f = np.array(needle), np.array([[0, 1, 2]])
    cm = clean(v, f)
    assert len(cm.faces) == 0 and cm.dropped_degenerate == 1
    with pytest.raises(MeshingError) as info:
        tetrace.Scene.from_mesh((v, f), lazy=False)
    message = str(info.value)
    assert "degenerate" in message and "triangle 0" in message
    assert "collinear" in message
    assert "self-intersect" not in message


@pytest.mark.parametrize("needle", [ROUNDED_NEEDLE, EXACT_NEEDLE], ids=["rounded", "exact"])
def test_zero_area_needle_among_triangles_is_dropped(needle):
    v, f, k = _with_sphere(needle)
    scene = tetrace.Scene.from_mesh((v, f), lazy=False)
    cm = scene.tetrahedralization.clean
    assert cm.dropped_degenerate == 1 and k not in cm.triangle_ids
    assert not scene.tetrahedralization.repaired


@pytest.mark.parametrize("have_igl", [True, False], ids=["libigl", "no-libigl"])
def test_thin_needle_is_named_not_blamed_on_self_intersection(have_igl, monkeypatch):
    """A needle 1e-9 wide has an area TetGen rejects as a 'self-intersection'; the message
    names the triangle as a degenerate needle, with or without libigl."""
    if not have_igl:
        monkeypatch.setattr(repair, "_igl_cgal", lambda: None)
        from tetrace.mesh import tetgen as tetgen_module

        monkeypatch.setattr(tetgen_module, "_igl_cgal", lambda: None)
    s = trimesh.creation.box()
    v = np.vstack([s.vertices, [[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [2.5, 1e-9, 0.0]]])
    f = np.vstack([s.faces, [[8, 9, 10]]])
    # Alone, nothing can be meshed: the error names triangle 12 as a needle.
    with pytest.raises(MeshingError) as info:
        tetrace.Scene.from_mesh((v[8:], f[12:] - 8), lazy=False)
    message = str(info.value)
    assert "degenerate needle" in message and "triangle 0" in message
    assert "install libigl" not in message
    if have_igl:
        # Beside other triangles, snap rounding flattens it and the box meshes.
        scene = tetrace.Scene.from_mesh((v, f), lazy=False)
        assert 12 not in scene.tetrahedralization.clean.triangle_ids
    else:
        with pytest.raises(MeshingError, match=r"degenerate needle.*triangle 12"):
            tetrace.Scene.from_mesh((v, f), lazy=False)


def test_errors_name_the_file(tmp_path):
    """A mesh given by path is named by its file in the error (not 'the mesh')."""
    path = tmp_path / "needle_only.obj"
    path.write_text("v 0 0 0\nv 1 2 3\nv 0.5 1 1.5\nf 1 2 3\n")
    with pytest.raises(MeshingError, match=r"^needle_only\.obj: .*degenerate"):
        tetrace.Scene.from_mesh(path, lazy=False)
