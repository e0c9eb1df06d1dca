"""Inside/outside of open meshes (issue 36, item 1): ``Scene.contains`` and
``Scene.signed_distance`` take the generalized winding number where the mesh is not closed,
exact parity where it is; ``scene.is_closed`` reports the choice, ``mode=`` overrides it,
and parity asked of an open mesh warns once per scene.

Synthetic meshes whose inside is known analytically run everywhere. A cube without its top:
its winding number is 1 minus the missing face's, and a flat face subtends less than half the
sphere from any point off its plane, so off that plane the inside is the cube's, exactly
(points near the opening, where the value is near 1/2, take the exact evaluation). The
Stanford bunny (a scan with five holes in its base) needs the shared scenes: its answers are
checked against the exact parity of a copy with the holes closed, outside the band where a
copy may rightly differ (derived in :mod:`tetrace.bench.occupancy`).
"""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest
import trimesh

import tetrace
from tetrace import winding


def _cube(offset=(0.0, 0.0, 0.0)):
    """The cube [-0.5, 0.5]^3 (shifted by ``offset``) as 12 outward triangles."""
    box = trimesh.creation.box()
    return np.asarray(box.vertices, np.float64) + offset, np.asarray(box.faces, np.int64)


def _top(v, f):
    """The two triangles of the cube's top face (z = 0.5 + its offset)."""
    z = v[f][:, :, 2]
    return np.all(z == z.max(), axis=1)


@pytest.fixture(scope="module")
def closed_cube():
    return tetrace.Scene.from_mesh(_cube())


@pytest.fixture(scope="module")
def open_cube():
    """The cube without its top face: open (4 boundary edges)."""
    v, f = _cube()
    return tetrace.Scene.from_mesh((v, f[~_top(v, f)]))


def _no_warning(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return fn(*args, **kwargs)


# --------------------------------------------------------------------------- is_closed


def test_is_closed_of_closed_open_and_non_manifold_meshes(closed_cube, open_cube):
    v, f = _cube()
    assert closed_cube.is_closed and not open_cube.is_closed
    census = open_cube._surface_info()
    assert (census.odd, census.non_manifold, census.misoriented) == (4, 0, 0)
    # A fin on one of the cube's edges: three triangles there, odd: not closed.
    fin_v = np.vstack([v, [[1.5, 0.0, 0.0]]])
    a, b = (int(i) for i in np.flatnonzero((v[:, 0] == 0.5) & (v[:, 2] == -0.5)))
    fin = tetrace.Scene.from_mesh((fin_v, np.vstack([f, [[a, b, len(v)]]])))
    assert not fin.is_closed
    census = fin._surface_info()  # the shared edge (3 triangles) and the fin's free edges
    assert (census.odd, census.non_manifold) == (3, 1)


def test_is_closed_rule_on_the_cleaned_mesh():
    """The census (``tetrace.winding.surface``) reads the mesh as the scene's cleaning leaves
    it; even edge counts are closed whatever the orientation."""
    v, f = _cube()
    assert winding.surface(v, f).closed
    # Every triangle with its own three vertices (a UV-seamed file): merged, still closed.
    soup = v[f].reshape(-1, 3)
    assert winding.surface(soup, np.arange(len(soup)).reshape(-1, 3)).closed
    # A zero-area triangle and a reversed duplicate: dropped as the scene drops them.
    extra = np.array([[0, 0, 1], f[0][::-1]])
    assert winding.surface(v, np.vstack([f, extra])).closed
    # One triangle flipped: still closed (parity is exact), its three edges misoriented.
    flipped = f.copy()
    flipped[0] = flipped[0][::-1]
    s = winding.surface(v, flipped)
    assert s.closed and s.misoriented == 3
    # Two cubes sharing an edge: four triangles there, even: closed, non-manifold.
    v2, f2 = _cube((1.0, 1.0, 0.0))
    both = winding.surface(np.vstack([v, v2]), np.vstack([f, f2 + len(v)]))
    assert both.closed and both.non_manifold == 1
    assert not winding.surface(v, f[1:]).closed  # one triangle missing


# --------------------------------------------------------------------------- closed: parity


def test_closed_cube_keeps_exact_parity(closed_cube):
    g = np.array([-0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75])
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    expect = np.all(np.abs(p) <= 0.5, axis=1)  # on the surface counts as inside
    auto = _no_warning(closed_cube.contains, p)
    assert auto.tolist() == expect.tolist()
    assert _no_warning(closed_cube.contains, p, mode="parity").tolist() == expect.tolist()
    s = _no_warning(closed_cube.signed_distance, p)
    assert (np.signbit(s) == expect).all()
    # The winding mode agrees off the surface.
    off = np.abs(np.abs(p) - 0.5).min(axis=1) > 0
    assert closed_cube.contains(p[off], mode="winding").tolist() == expect[off].tolist()


# --------------------------------------------------------------------------- open: winding


def test_open_cube_inside_is_the_cube(open_cube):
    rng = np.random.default_rng(36)
    p = rng.uniform(-0.9, 0.9, (4000, 3))
    # Near the opening too, where the winding number is near 1/2 (the exact evaluation).
    q = rng.uniform(-0.45, 0.45, (200, 3))
    q[:, 2] = 0.5 + rng.choice([-1, 1], 200) * rng.uniform(1e-4, 0.05, 200)
    p = np.vstack([p, q])
    p = p[np.abs(np.abs(p) - 0.5).min(axis=1) > 1e-6]  # none on a face plane
    expect = np.all(np.abs(p) < 0.5, axis=1)
    got = _no_warning(open_cube.contains, p)
    assert got.tolist() == expect.tolist()
    assert expect.sum() > 500 and (~expect).sum() > 500
    s = _no_warning(open_cube.signed_distance, p)
    assert (np.signbit(s) == expect).all()
    np.testing.assert_array_equal(np.abs(s), open_cube.distance(p))  # the exact magnitude
    # The centre's winding number is 1 - 1/6 (the missing face subtends a sixth of the sphere).
    centre = [[0.0, 0.0, 0.0]]
    assert abs(winding.solid_angle_sum(*_cube_without_top(), centre)[0] - 5 / 6) < 1e-15
    assert abs(winding.winding_numbers(*_cube_without_top(), centre)[0] - 5 / 6) < 1e-3  # fast
    assert open_cube.contains([0.0, 0.0, 0.0]).shape == ()


def _cube_without_top():
    v, f = _cube()
    return v, f[~_top(v, f)]


def test_the_fast_value_is_replaced_near_one_half(monkeypatch):
    """Points whose fast winding number is within RECHECK of 1/2 get the exact sum."""
    import igl

    v, f = _cube_without_top()
    p = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.49], [0.0, 0.0, 2.0]])
    exact = np.asarray(igl.winding_number(v, f, p))
    fake = np.array([0.5 + winding.RECHECK / 2, 0.5 - winding.RECHECK / 2, 0.5 + winding.RECHECK])
    monkeypatch.setattr(igl, "fast_winding_number", lambda *a: fake.copy())
    for direct_max in (winding.DIRECT_MAX, 0):  # summed directly, or by libigl's hierarchy
        monkeypatch.setattr(winding, "DIRECT_MAX", direct_max)
        w = winding.winding_numbers(v, f, p)
        np.testing.assert_allclose(w[:2], exact[:2], rtol=0, atol=1e-14)
        assert w[2] == fake[2]  # not near 1/2: the fast value stands
    # The direct sum is the exact one on a mesh of many triangles too.
    s = trimesh.creation.icosphere(3)
    q = np.random.default_rng(1).uniform(-1.2, 1.2, (20, 3))
    np.testing.assert_allclose(
        winding.solid_angle_sum(s.vertices, s.faces, q),
        igl.winding_number(np.asarray(s.vertices), np.asarray(s.faces, np.int64), q),
        rtol=0,
        atol=1e-13,
    )


# --------------------------------------------------------------------------- mode and warning


def test_mode_overrides_and_bad_modes_are_refused(closed_cube, open_cube):
    p = np.array([[0.0, 0.0, 0.0], [0.25, 0.25, -0.25], [2.0, 0.0, 0.0]])
    assert open_cube.contains(p, mode="winding").tolist() == [True, True, False]
    assert closed_cube.contains(p, mode="winding").tolist() == [True, True, False]
    for bad in ("Parity", "even-odd", 1, True):
        for method in (closed_cube.contains, closed_cube.signed_distance):
            with pytest.raises(ValueError, match="mode must be None, 'parity' or 'winding'"):
                method(p, mode=bad)


def test_parity_on_an_open_mesh_warns_once_per_scene():
    v, f = _cube_without_top()
    scene = tetrace.Scene.from_mesh((v, f))
    centre = np.zeros((1, 3))
    with pytest.warns(UserWarning, match=r"mode='parity' on a mesh that is not closed \(4 of") as w:
        assert scene.contains(centre, mode="parity").tolist() == [False]  # escapes: the top
    assert w[0].filename == __file__  # names the caller's line
    assert _no_warning(scene.contains, centre, mode="parity").tolist() == [False]
    assert _no_warning(scene.signed_distance, centre, mode="parity")[0] == 0.5
    # Another scene object (here a pickled copy) warns again; signed_distance warns too.
    copy = pickle.loads(pickle.dumps(scene))
    with pytest.warns(UserWarning, match="not closed") as w:
        assert copy.signed_distance(centre, mode="parity")[0] == 0.5
    assert w[0].filename == __file__
    assert _no_warning(copy.signed_distance, centre)[0] == -0.5  # winding: inside


# --------------------------------------------------------------------------- scenes of meshes


def test_multi_mesh_scenes_and_saved_scenes(tmp_path):
    cube, shifted = _cube(), _cube((2.0, 0.0, 0.0))
    v, f = shifted
    p = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.75]])
    both_closed = tetrace.Scene.from_meshes([cube, shifted])
    assert both_closed.is_closed
    assert _no_warning(both_closed.contains, p).tolist() == [True, True, False, False]
    mixed = tetrace.Scene.from_meshes([cube, (v, f[~_top(v, f)])])
    assert not mixed.is_closed  # judged as one mesh: winding for both
    assert _no_warning(mixed.contains, p).tolist() == [True, True, False, False]
    # Saving and loading keeps the answers (the census is rebuilt, not saved).
    mixed.save(tmp_path / "mixed.tetrace")
    loaded = tetrace.Scene.load(tmp_path / "mixed.tetrace")
    assert not loaded.is_closed
    np.testing.assert_array_equal(loaded.signed_distance(p), mixed.signed_distance(p))


def test_moved_vertices_are_judged_anew():
    """update_vertices drops the cleaned mesh the winding number reads: it follows the move."""
    v, f = _cube_without_top()
    scene = tetrace.Scene.from_mesh((v, f))
    p = np.array([[0.55, 0.0, 0.0]])
    assert not scene.contains(p)[0] and not scene.is_closed
    scene.update_vertices(v + [0.1, 0.0, 0.0])
    assert scene.contains(p)[0] and not scene.is_closed


# --------------------------------------------------------------------------- the bunny


@pytest.fixture(scope="module")
def bunny(scene_path):
    mesh = trimesh.load(scene_path("bunny.obj"), force="mesh")
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    return tetrace.Scene.from_mesh((v, f), progress=False), v, f


def test_bunny_centre_and_interior_are_inside(bunny):
    scene, v, f = bunny
    assert not scene.is_closed  # five holes in its base
    centre = (v.min(axis=0) + v.max(axis=0)) / 2
    assert _no_warning(scene.contains, centre)
    assert _no_warning(scene.signed_distance, centre) < 0
    # A grid of points inside the closed copy (exact parity), at least 1% of the diagonal
    # from the scan: all inside, all negative.
    from tetrace.bench.occupancy import closed_reference

    g = [np.linspace(a, b, 16) for a, b in zip(v.min(axis=0), v.max(axis=0))]
    p = np.stack(np.meshgrid(*g, indexing="ij"), axis=-1).reshape(-1, 3)
    diagonal = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    deep = closed_reference(v, f, p)["inside"] & (scene.distance(p) > 0.01 * diagonal)
    assert deep.sum() > 200
    assert scene.contains(p[deep]).all()
    assert (scene.signed_distance(p[deep]) < 0).all()
    # What parity answered before: every point escapes through a hole.
    with pytest.warns(UserWarning, match="not closed"):
        assert not scene.contains(p[deep], mode="parity").any()


def test_bunny_agrees_with_a_closed_copy(bunny):
    """On a 24^3 grid over the bounding box: the same answers as the exact parity of the copy
    with its holes closed, except in the band where the hole patches alone have a winding
    number of magnitude 1/2 or more (``w_scan = w_copy - w_patch``: see
    tetrace.bench.occupancy), which is a few points within a small distance of a patch."""
    from tetrace.bench.occupancy import closed_reference

    scene, v, f = bunny
    g = [np.linspace(a, b, 24) for a, b in zip(v.min(axis=0), v.max(axis=0))]
    p = np.stack(np.meshgrid(*g, indexing="ij"), axis=-1).reshape(-1, 3)
    ref = closed_reference(v, f, p)
    assert ref["holes"] == 5
    got = _no_warning(scene.contains, p)
    keep = ~ref["band"]
    assert ref["band"].sum() <= 0.001 * len(p), ref["band"].sum()
    diagonal = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    assert ref["band_distance"] < 0.01 * diagonal
    wrong = np.flatnonzero(got[keep] != ref["inside"][keep])
    assert len(wrong) == 0, p[keep][wrong[:10]]
    assert 0.2 < ref["inside"].mean() < 0.35


def test_the_occupancy_bench_runs_on_an_open_cube(tmp_path):
    """``python -m tetrace.bench.occupancy`` end to end on a small file: the hole is closed
    by a flat fan (an empty band), and the winding mode agrees with the closed copy where
    parity calls every point outside."""
    from tetrace.bench.occupancy import close_holes, run_occupancy

    v, f = _cube_without_top()
    cv, cf, n_patch = close_holes(v, f)
    assert n_patch == 4 and winding.surface(cv, cf).closed
    assert winding.surface(cv, cf).misoriented == 0
    path = tmp_path / "open_cube.obj"
    trimesh.Trimesh(v, f, process=False).export(path)
    lines = []
    rows = {r["caster"]: r for r in run_occupancy(path, n=300, repeat=1, out=lines.append)}
    assert rows["tetrace contains (auto: winding)"]["agree"] == 1.0
    assert rows["tetrace contains (mode='parity')"]["agree"] == 0.0  # all inside the cube
    assert rows["trimesh contains"]["points"] == 300 and "agrees with closed copy" in lines[-1]
