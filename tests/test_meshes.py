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


# --- trimesh.Scene (issue 36): what trimesh.load returns for a file of several objects ----


def _boxes_scene():
    """A trimesh.Scene of one unit box placed three times (translated; rotated 90 degrees
    about y; mirrored in x, which makes trimesh reverse the faces) and a point cloud. Every
    placed coordinate is exact, so hits can be checked with no tolerance."""
    tf = trimesh.transformations
    box = trimesh.creation.box()
    ts = trimesh.Scene()
    ts.add_geometry(
        box, node_name="left", geom_name="box", transform=tf.translation_matrix((-2, 0, 0))
    )
    # a quarter turn about y, written out so that every placed coordinate is exact
    quarter = np.array([[0.0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]])
    turned = tf.translation_matrix((2, 0, 0)) @ quarter
    ts.add_geometry(box, node_name="right", geom_name="box", transform=turned)
    mirrored = tf.translation_matrix((0, 0, -3)) @ np.diag([-1.0, 1, 1, 1])
    ts.add_geometry(box, node_name="mirror", geom_name="box", transform=mirrored)
    ts.add_geometry(trimesh.PointCloud(np.ones((4, 3))), node_name="dots", geom_name="dots")
    return ts


def test_from_mesh_takes_a_trimesh_scene():
    ts = _boxes_scene()
    placed = [g for g in ts.dump() if isinstance(g, trimesh.Trimesh)]
    assert [g.metadata["node"] for g in placed] == ["left", "right", "mirror"]
    scene = tetrace.Scene.from_mesh(ts, progress=False)
    geo = scene.geometries
    # one geometry per placed mesh, named by its node; the point cloud has no triangles
    assert geo.names == ("left", "right", "mirror")
    assert geo.triangle_offsets.tolist() == [0, 12, 24, 36]
    # the scene's triangles are trimesh's own concatenation (to_mesh), transforms applied
    whole = ts.to_mesh()
    assert np.array_equal(scene.vertices[scene.faces], whole.vertices[whole.faces])
    # straight down onto each box's top (z = 0.5; the mirror box's is 3 lower), and one ray
    # between the boxes
    o = np.array([[-2.1, 0.2, 5.0], [2.2, -0.1, 5.0], [0.3, 0.1, 5.0], [0.0, 3.0, 5.0]])
    h = scene.cast(o, np.array([0.0, 0.0, -1.0]))
    assert h.geometry.tolist() == [0, 1, 2, -1]
    assert h.triangle[3] == -1 and h.scene_triangle[3] == -1
    # exact: the ray's z falls from 5 to the top at 0.5 (the mirror box: 0.5 - 3)
    assert h.t.tolist()[:3] == [4.5, 4.5, 7.5] and h.t[3] == np.inf
    for g in range(3):
        t = int(h.triangle[g])
        corners = placed[g].vertices[placed[g].faces[t]]
        # the triangle within mesh g lies in that box's top face, and is wound outwards
        top = 0.5 if g < 2 else -2.5
        assert (corners[:, 2] == top).all()
        assert h.normal[g][2] > 0
        assert h.scene_triangle[g] == geo.triangle_offsets[g] + t


def test_trimesh_scene_numbers_triangles_as_its_file(tmp_path):
    """A file of two objects with materials loads as a trimesh.Scene: its scene triangles
    are the path's triangles (trimesh.load(path, force="mesh")), its meshes named."""
    (tmp_path / "two.mtl").write_text("newmtl red\nKd 1 0 0\nnewmtl green\nKd 0 1 0\n")
    path = tmp_path / "two.obj"
    path.write_text(
        "mtllib two.mtl\no first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n"
        "o second\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\nusemtl green\nf 4 5 6\nf 5 7 6\n"
    )
    ts = trimesh.load(path)
    assert isinstance(ts, trimesh.Scene)
    from_path = tetrace.Scene.from_mesh(path, progress=False)
    from_scene = tetrace.Scene.from_mesh(ts, progress=False)
    assert np.array_equal(from_scene.vertices, from_path.vertices)
    assert np.array_equal(from_scene.faces, from_path.faces)
    assert from_path.geometries is None
    assert from_scene.geometries.names == tuple(ts.graph.nodes_geometry)
    # load_triangles (Embree, tetrahedralize) reads a trimesh.Scene the same way
    v, f = load_triangles(ts)
    assert np.array_equal(v[f], from_path.vertices[from_path.faces])


def test_trimesh_scene_names_survive_save_and_dict_meshes_are_named(tmp_path):
    scene = tetrace.Scene.from_meshes({"a": _box((0, 0, 0)), "b": _box((3, 0, 0))})
    assert scene.geometries.names == ("a", "b")
    path = tmp_path / "named.tetrace"
    scene.save(path)
    assert tetrace.Scene.load(path).geometries.names == ("a", "b")
    assert tetrace.Scene.from_meshes([_box((0, 0, 0))]).geometries.names is None
    with pytest.raises(MeshingError, match=r"mesh 1 \('b'\): "):
        concatenate({"a": _box((0, 0, 0)), "b": (np.zeros((3, 3)), np.array([[0, 1, 5]]))})


def test_trimesh_scene_without_triangles_is_refused():
    ts = trimesh.Scene()
    ts.add_geometry(trimesh.PointCloud(np.ones((4, 3))), node_name="dots")
    with pytest.raises(MeshingError, match=r"holds no triangles: only 'dots' \(PointCloud\)"):
        tetrace.Scene.from_mesh(ts)
    with pytest.raises(MeshingError, match="holds no triangles: it is empty"):
        load_triangles(trimesh.Scene())


def test_cornell_box_as_loaded_by_trimesh(scene_path):
    """The file of issue 36: trimesh.load gives a Scene, which from_mesh takes (meshed
    once, as the path is) with each object's id."""
    path = scene_path("cornell_box.obj")
    ts = trimesh.load(path)
    assert isinstance(ts, trimesh.Scene)
    scene = tetrace.Scene.from_mesh(ts, progress=False)
    v, f = load_triangles(path)
    assert np.array_equal(scene.vertices[scene.faces], v[f])
    assert len(scene.geometries) == len(ts.graph.nodes_geometry) > 1
