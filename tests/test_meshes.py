"""Scenes of several meshes and triangle soups (issue 14): ``Scene.from_meshes`` and
``hits.geometry``, ``hits.triangle`` within the mesh, ``hits.scene_triangle``."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import tetrace
from tetrace.errors import MeshingError
from tetrace.io import load_triangles, weld
from tetrace.meshes import Geometries, concatenate


def _box(centre, size=1.0):
    b = trimesh.creation.box(extents=(size, size, size))
    return b.vertices + centre, b.faces


def test_weld_is_exact_and_keeps_winding():
    soup = np.array(
        [
            [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
            [[1, 0, 0], [0, 1, 0], [-0.0, 0, 1]],  # -0.0 welds with 0.0
            [[1, 1e-300, 0], [0, 1, 0], [0, 0, 1]],  # 1e-300 away: not welded
        ]
    )
    v, f = weld(soup)
    assert f.tolist() == [[0, 1, 2], [1, 2, 3], [4, 2, 3]]
    assert np.array_equal(v[f], soup + 0.0)


def test_from_mesh_takes_a_soup():
    box = trimesh.creation.box()
    scene = tetrace.Scene.from_mesh(box.triangles)
    assert scene.n_triangles == 12 and len(scene.vertices) == 8
    h = scene.cast(np.array([[0.1, 0.2, 5.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert h.hit.all() and np.allclose(h.point, [[0.1, 0.2, 0.5]])
    # triangle i of the soup is triangle i of the scene
    assert np.array_equal(scene.vertices[scene.faces], box.triangles)
    # lists of triangles too (but a pair is (vertices, faces))
    v, f = load_triangles(box.triangles.tolist())
    assert len(f) == 12


def test_concatenate_and_locate():
    a, b = _box((0, 0, 0)), _box((3, 0, 0))
    c = trimesh.creation.icosphere(0).triangles + [0, 3, 0]
    v, f, geo = concatenate([a, b, c])
    assert len(geo) == 3 and geo.triangle_offsets.tolist() == [0, 12, 24, 44]
    assert len(v) == 8 + 8 + 12 and len(f) == 44
    assert np.array_equal(v[f[12:24]], b[0][b[1]])
    g, t = geo.locate(np.array([-1, 0, 11, 12, 30, 43]))
    assert g.tolist() == [-1, 0, 0, 1, 2, 2] and t.tolist() == [-1, 0, 11, 0, 6, 19]
    assert g.dtype == np.int32 and t.dtype == np.int32
    assert geo.scene_triangle(g[1:], t[1:]).tolist() == [0, 11, 12, 30, 43]
    single = Geometries.single(5)
    assert single.locate(np.array([4, -1]))[0].tolist() == [0, -1]
    with pytest.raises(ValueError, match="at least one mesh"):
        concatenate([])
    with pytest.raises(MeshingError, match="mesh 1: "):
        concatenate([a, (np.zeros((3, 3)), np.array([[0, 1, 5]]))])


def test_from_meshes_reports_geometry_and_triangle_within_it(tmp_path):
    path = tmp_path / "ball.obj"
    ball = trimesh.creation.icosphere(1)
    ball.apply_translation((0, 4, 0))
    ball.export(path)
    meshes = [
        _box((0, 0, 0)),  # (vertices, faces)
        trimesh.creation.box().apply_translation((4, 0, 0)),  # Trimesh
        path,  # a file
        trimesh.creation.box().triangles + [4, 4, 0],  # a soup
    ]
    scene = tetrace.Scene.from_meshes(meshes)
    sizes = [12, 12, len(ball.faces), 12]
    assert scene.geometries.triangle_offsets.tolist() == np.cumsum([0] + sizes).tolist()
    centres = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0], [4, 4, 0], [9, 9, 0]], float)
    o = centres + [0.01, 0.02, 5.0]
    h = scene.cast(o, np.array([0.0, 0.0, -1.0]), method="robust")
    assert h.geometry.tolist() == [0, 1, 2, 3, -1]
    assert h.triangle[-1] == -1 and h.scene_triangle[-1] == -1
    for g in range(4):
        t, st = int(h.triangle[g]), int(h.scene_triangle[g])
        assert 0 <= t < sizes[g]
        assert st == scene.geometries.triangle_offsets[g] + t
        # the triangle within mesh g has the hit point on it
        v, f = load_triangles(meshes[g])
        p = v[f[t]]
        np.testing.assert_allclose(
            (1 - h.u[g] - h.v[g]) * p[0] + h.u[g] * p[1] + h.v[g] * p[2], h.point[g], atol=1e-12
        )
        n = np.cross(p[1] - p[0], p[2] - p[0])
        np.testing.assert_allclose(h.normal[g], n / np.linalg.norm(n), atol=1e-15)
        assert h.normal[g][2] > 0  # every mesh is wound outwards


def test_one_mesh_scene_geometry_is_zero():
    scene = tetrace.Scene.from_mesh(_box((0, 0, 0)))
    assert scene.geometries is None
    h = scene.cast(np.array([[0.1, 0.2, 5.0], [5, 5, 5]]), np.array([0.0, 0.0, -1.0]))
    assert h.geometry.tolist() == [0, -1]
    assert np.array_equal(h.triangle, h.scene_triangle)
