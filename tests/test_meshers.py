"""The meshers beyond the foundation's two presets: TetGen's named presets and sizing,
time limits, the snap-rounding ladder, fTetWild (``pytetwild``) and the fallback route.

fTetWild tests need ``pytetwild`` (in the ``test`` extra): they skip without it locally
and fail under CI. A fTetWild mesh is checked like a TetGen one except that its
constrained faces lie within the envelope of the input instead of on it, and its box is
fTetWild's own; rays cast through it are compared with Embree.
"""

from __future__ import annotations

import os
import time
from importlib import resources

import numpy as np
import pytest

import tetrace
from tetrace import meshing, synthetic
from tetrace.camera import orbit_views, pinhole, random_rays
from tetrace.compare import compare, same_plane
from tetrace.meshing import (
    PRESETS,
    MeshingError,
    _call_forked,
    _last_phase,
    _snap,
    _TetGenCrashed,
    clean,
    count_intersecting_pairs,
    default_timeout,
    ftetwild_available,
    load_triangles,
    preset_options,
    tetgen_options,
    tetrahedralize,
)
from tetrace.reference import embree_scene

from conftest import skip_or_fail
from test_meshing import check_ct, face_keys

SPOT = str(resources.files("tetrace").joinpath("data", "spot.obj"))


@pytest.fixture(scope="session")
def ftetwild():
    if not ftetwild_available():
        skip_or_fail("pytetwild is not installed (pip install 'pytetwild>=0.2.3,<0.3')")
    return True


# --------------------------------------------------------------------------- presets


def test_preset_names():
    assert preset_options("quality")["minratio"] == 5.0
    assert preset_options("constrained")["minratio"] is None
    assert preset_options("quality1.5")["minratio"] == 1.5
    assert preset_options("quality1.25")["minratio"] == 1.25  # any quality<r>
    assert preset_options("graded")["sizing"] is not None
    for bad in ("quality1", "quality0.5", "qualityx", "fast", "Quality2"):
        with pytest.raises(ValueError, match="preset"):
            preset_options(bad)
    with pytest.raises(ValueError, match="radius-edge bound must be > 1"):
        tetrahedralize(synthetic.cube(), "quality0.9")
    with pytest.raises(ValueError, match="unknown preset"):
        tetrahedralize(synthetic.cube(), "fast")
    assert tetgen_options("quality2")["minratio"] == 2.0
    assert tetgen_options("constrained")["quality"] is False


def test_quality_bounds_order_the_tet_counts():
    """Tighter radius-edge bounds give more tets; every preset gives a valid CT."""
    vertices, faces = synthetic.torus_knot()
    counts = {}
    for preset in ["constrained", "quality", "quality3", "quality2", "quality1.5"]:
        tz = tetrahedralize((vertices, faces), preset)
        check_ct(tz, vertices, faces)
        assert tz.preset == preset and tz.mesher == "tetgen" and tz.snap == 0.0
        assert tz.surface_distance is None and tz.attempts == []
        counts[preset] = len(tz.tets)
    # ("constrained" is not the smallest here: refinement also removes slivers)
    assert counts["quality"] <= counts["quality3"] < counts["quality2"] < counts["quality1.5"], counts


def test_graded_preset_grows_tets_away_from_the_surface():
    """'graded' adds points away from the surface: more tets than 'quality', and the
    largest tets far from the scene are smaller, growing with the distance."""
    vertices, faces = load_triangles(SPOT)
    quality = tetrahedralize((vertices, faces), "quality")
    graded = tetrahedralize((vertices, faces), "graded")
    check_ct(graded, vertices, faces)
    assert graded.preset == "graded" and not graded.attempts
    assert len(graded.tets) > len(quality.tets)
    diag = np.linalg.norm(vertices.max(0) - vertices.min(0))
    h0, growth = PRESETS["graded"]["sizing"]

    def longest_edge(tz):
        p = tz.points[tz.tets.astype(np.int64)]
        e = [np.linalg.norm(p[:, i] - p[:, j], axis=1) for i in range(4) for j in range(i + 1, 4)]
        return np.max(e, axis=0), p.mean(axis=1)

    import igl

    ratios = {}
    for tz in (quality, graded):
        edge, centre = longest_edge(tz)
        d = np.sqrt(igl.point_mesh_squared_distance(centre, vertices, faces)[0])
        ratios[tz.preset] = edge / (h0 * diag + growth * d)
    # The sizing field brings the longest edges closer to the target length: an ordering
    # (the worst and the 99th percentile tet), not a number copied from a run. TetGen gives
    # no bound on edge length with isolated points, so none is asserted.
    assert ratios["graded"].max() < ratios["quality"].max()
    assert np.quantile(ratios["graded"], 0.99) < np.quantile(ratios["quality"], 0.99)
    # What can be derived: every point the field asks for (_sizing_points: octree leaves,
    # jittered within the middle half of their cell) is a vertex of the graded mesh.
    cm = clean(vertices, faces)
    wanted = meshing._sizing_points(graded.domain, cm.vertices, cm.faces, h0 * diag, growth)
    assert len(wanted) > 0
    have = {tuple(p) for p in graded.points}
    assert all(tuple(p) in have for p in wanted)
    with pytest.raises(ValueError, match="sizing"):
        tetrahedralize((vertices, faces), sizing=(0, 1))


# --------------------------------------------------------------------------- time limits


def test_default_timeout_grows_with_the_scene(monkeypatch):
    monkeypatch.delenv("TETRACE_TETGEN_TIMEOUT", raising=False)
    assert 0 < default_timeout(10) < default_timeout(100_000) < default_timeout(10**6)
    assert default_timeout(10**5, "ftetwild") > default_timeout(10**5, "tetgen")
    monkeypatch.setenv("TETRACE_TETGEN_TIMEOUT", "7")
    assert default_timeout(10**6) == 7.0
    monkeypatch.setenv("TETRACE_TETGEN_TIMEOUT", "none")
    assert default_timeout(10**6) is None


@pytest.mark.skipif(not meshing.ISOLATE_TETGEN, reason="time limits need the forked child")
def test_tetgen_timeout_names_the_stage():
    vertices, faces = synthetic.torus_knot()
    t0 = time.perf_counter()
    with pytest.raises(MeshingError) as info:
        tetrahedralize((vertices, faces), "quality1.5", timeout=0.02, repair=False)
    assert time.perf_counter() - t0 < 30
    msg = str(info.value)
    assert "TetGen on the scene as given timed out: stopped after 0.02 s" in msg, msg
    assert "TETRACE_TETGEN_TIMEOUT" in msg


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_crash_names_the_phase():
    # TetGen prints to the C stdout (file descriptor 1), as these do.
    def crash():
        os.write(1, b"Delaunizing vertices...\n  Sorting vertices.\nRecovering boundaries...\n")
        os.abort()

    with pytest.raises(_TetGenCrashed, match="SIGABRT") as info:
        _call_forked(crash)
    assert info.value.phase == "Recovering boundaries"
    assert meshing._stage_message("TetGen", info.value, None) == (
        "TetGen crashed (killed by SIGABRT) in TetGen's phase 'Recovering boundaries'")

    def slow():
        os.write(1, b"Refining mesh...\n")
        time.sleep(30)

    with pytest.raises(meshing._TetGenTimeout) as info:
        _call_forked(slow, timeout=1.0)
    assert info.value.phase == "Refining mesh"
    assert _last_phase("  indented...\nno dots\n") is None


# --------------------------------------------------------------------------- snap rounding


def test_snap_merges_nearby_vertices_and_keeps_ids():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1e-9, 1e-9, 0], [1, 1, 1e-12]], float)
    f = np.array([[0, 1, 2], [3, 1, 4]])
    cm = clean(v, f)
    snapped = _snap(cm, 2.0**-20)
    # vertex 3 merges with vertex 0 and 4 lands on z = 0: both faces survive, on the grid
    assert len(snapped.vertices) == 4
    assert np.all(snapped.vertices * 2**20 == np.round(snapped.vertices * 2**20))
    assert snapped.triangle_ids.tolist() == [0, 1]
    # a triangle smaller than the cell collapses and is dropped
    tiny = clean(np.array([[0, 0, 0], [1e-9, 0, 0], [0, 1e-9, 0]]), np.array([[0, 1, 2]]))
    assert len(_snap(tiny, 2.0**-20).faces) == 0


def test_needles_in_intersecting_pairs_are_dropped():
    """A needle (1e-9 wide) crossing a triangle: _drop_needles removes the needle, not the
    triangle, and counts it as degenerate; a wide crossing triangle is kept."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0],                 # floor triangle
                  [0.2, 0.2, -0.5], [0.2, 0.2, 0.5], [0.2 + 1e-9, 0.2, 0.0],  # needle
                  [0.5, 0.1, -0.5], [0.1, 0.5, -0.5], [0.3, 0.3, 0.5]])     # wide, crossing
    f = np.array([[0, 1, 2], [3, 4, 5], [6, 7, 8]])
    cm = clean(v, f)
    assert count_intersecting_pairs(cm.vertices, cm.faces) == 2
    out, dropped = meshing._drop_needles(cm, 1e-6 * np.sqrt(3))
    assert dropped == 1 and out.triangle_ids.tolist() == [0, 2]
    assert out.dropped_degenerate == cm.dropped_degenerate + 1
    assert count_intersecting_pairs(out.vertices, out.faces) == 1


def test_snap_ladder_after_a_tetgen_failure(monkeypatch):
    """When TetGen fails on the scene as given, the next rung snap-rounds, repairs and
    meshes with TetGen's optimisation off; the result is a valid CT on the snapped
    scene and the failure is recorded."""
    vertices, faces = synthetic.touching_boxes()
    real = meshing._run_tetgen
    calls = []

    def flaky(cm, box, options, *args, **kwargs):
        calls.append(dict(options))
        if len(calls) == 1:
            raise meshing._TetGenFailed("Internal TetGen error within `repair_tet`.")
        return real(cm, box, options, *args, **kwargs)

    monkeypatch.setattr(meshing, "_run_tetgen", flaky)
    tz = tetrahedralize((vertices, faces), "quality")
    assert len(calls) == 2 and calls[1]["opt_iterations"] == 0
    assert "opt_iterations" not in calls[0]
    assert tz.snap > 0 and tz.repaired and tz.preset == "quality"
    assert len(tz.attempts) == 1 and "repair_tet" in tz.attempts[0]
    assert count_intersecting_pairs(tz.clean.vertices, tz.clean.faces) == 0
    # every point of the snapped scene is on the grid
    assert np.all(np.round(tz.clean.vertices / tz.snap) * tz.snap == tz.clean.vertices)
    check_ct(tz, vertices, faces, tiles=False)


def test_fallback_constrained_rung(monkeypatch):
    """mesher='fallback': when every rung fails with the refining preset, the first
    snap-rounded scene is meshed with 'constrained' before fTetWild is tried."""
    vertices, faces = synthetic.cube()
    real = meshing._run_tetgen

    def refuse_quality(cm, box, options, *args, **kwargs):
        if options.get("quality"):
            raise meshing._TetGenFailed("refused")
        return real(cm, box, options, *args, **kwargs)

    monkeypatch.setattr(meshing, "_run_tetgen", refuse_quality)
    with pytest.raises(MeshingError, match="preset='constrained' may work"):
        tetrahedralize((vertices, faces), "quality")
    tz = tetrahedralize((vertices, faces), "quality", mesher="fallback")
    assert tz.mesher == "tetgen" and tz.preset == "constrained" and tz.snap > 0
    assert len(tz.attempts) == 1 + len(meshing.SNAP_LADDER)
    check_ct(tz, vertices, faces)


# --------------------------------------------------------------------------- fTetWild


def check_ftetwild(tz, vertices, faces, epsilon):
    """The invariants of a fTetWild CT: a box tiled by consistently oriented tets, whose
    boundary faces lie on the box; constrained faces are tet faces within the envelope
    of the triangle they name."""
    P, T, C, ft = tz.points, tz.tets, tz.faces, tz.face_triangle
    assert tz.mesher == "ftetwild" and tz.preset == "ftetwild"
    assert P.dtype == np.float64 and T.dtype == np.uint32 and C.dtype == np.uint32
    assert ft.dtype == np.uint32 and ft.shape == (len(C),)
    assert P.flags.c_contiguous and T.flags.c_contiguous and C.flags.c_contiguous
    assert len(C) > 0 and T.max() < len(P) and C.max() < len(P) and ft.max() < len(faces)
    lo, hi = tz.domain
    np.testing.assert_array_equal(tz.domain, [P.min(0), P.max(0)])
    assert np.all(vertices.min(0) > lo) and np.all(vertices.max(0) < hi)
    # Consistently oriented, and no tet flat (bound 0: the Rust side orients with exact
    # predicates and rejects a flat tet), judged exactly: a tet can be flat in floating
    # point and not exactly.
    signs, vol, err = exact_orientations(P, T)
    assert np.all(signs == signs[0]) and signs[0] != 0
    # The tets tile the box: the exact volumes sum to the box's. Derived bound on the
    # float64 sum: each |vol| is off by at most its orient3d error bound (err), the sum of
    # n terms by n ulps of it, and the box volume (3 differences, 2 products) by 5 ulps.
    box = np.prod(hi - lo)
    total = np.abs(vol).sum()
    bound = err.sum() + len(vol) * EPS * total + 5 * EPS * box
    assert abs(total - box) <= bound, (total, box, bound)
    # Boundary faces (on one tet only) all lie on a side of the box.
    tf = np.sort(np.concatenate([T[:, [1, 2, 3]], T[:, [0, 2, 3]], T[:, [0, 1, 3]],
                                 T[:, [0, 1, 2]]]).astype(np.int64), axis=1)
    keys, counts = np.unique(face_keys(tf, len(P)), return_counts=True)
    assert counts.max() <= 2
    bf = tf[np.isin(face_keys(tf, len(P)), keys[counts == 1])]
    q = P[bf]
    on_side = np.zeros(len(bf), bool)
    for axis in range(3):
        for side in (lo, hi):
            on_side |= np.all(q[:, :, axis] == side[axis], axis=1)
    assert on_side.all()
    assert np.isin(face_keys(C, len(P)), keys).all()
    # Within the envelope of their own triangle.
    import igl

    diag = tz.surface_distance["diagonal"]
    tol = epsilon * diag * 1.001
    cen = P[C.astype(np.int64)].mean(axis=1)
    for k in np.unique(ft)[:200]:
        sel = ft == k
        d2, _, _ = igl.point_mesh_squared_distance(cen[sel], vertices, faces[k:k + 1])
        assert np.sqrt(d2).max() <= tol
    sd = tz.surface_distance
    assert 0 <= sd["mean"] <= sd["max"] <= tol
    assert set(sd) == {"max", "mean", "input_max", "input_mean", "diagonal"}
    assert set(tz.timings) >= {"ftetwild", "recover", "mesher", "total"}


EPS = 2.0 ** -53  # float64's unit roundoff


def exact_orientations(P, T):
    """The exact orientation sign of each tet ``T`` over float64 points ``P``.

    float64 determinants of the rounded differences, certified with Shewchuk's bound for
    them (orient3d's ``errboundA = (7 + 56 eps) eps`` times the permanent); the uncertain
    ones are evaluated exactly with fractions. Returns ``(signs, volumes, errors)``: the
    signs (-1, 0, 1), the float64 volumes and their error bounds.
    """
    from fractions import Fraction

    p = P[T.astype(np.int64)]
    a, b, c = p[:, 0] - p[:, 3], p[:, 1] - p[:, 3], p[:, 2] - p[:, 3]
    m = [b[:, 1] * c[:, 2], b[:, 2] * c[:, 1], b[:, 2] * c[:, 0], b[:, 0] * c[:, 2],
         b[:, 0] * c[:, 1], b[:, 1] * c[:, 0]]
    det = a[:, 0] * (m[0] - m[1]) + a[:, 1] * (m[2] - m[3]) + a[:, 2] * (m[4] - m[5])
    perm = (np.abs(a[:, 0]) * (np.abs(m[0]) + np.abs(m[1]))
            + np.abs(a[:, 1]) * (np.abs(m[2]) + np.abs(m[3]))
            + np.abs(a[:, 2]) * (np.abs(m[4]) + np.abs(m[5])))
    err = (7.0 + 56.0 * EPS) * EPS * perm
    signs = np.sign(det).astype(np.int64)
    for i in np.flatnonzero(~(np.abs(det) > err)):
        q = [[Fraction(float(x)) for x in row] for row in p[i]]
        d = [[q[k][j] - q[3][j] for j in range(3)] for k in range(3)]
        exact = (d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1])
                 + d[0][1] * (d[1][2] * d[2][0] - d[1][0] * d[2][2])
                 + d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0]))
        signs[i] = (exact > 0) - (exact < 0)
    # /6 rounds once more: at most one ulp of each volume on top of err/6.
    vol = det / 6.0
    return signs, vol, err / 6.0 + EPS * np.abs(vol)


def test_exact_orientations_decide_what_float64_cannot():
    from fractions import Fraction

    # Tets of four points rounded onto the plane x + y + z = 1 (nearly flat: float64 cannot
    # tell most signs), a few clear ones, and exactly flat ones; against plain fractions.
    rng = np.random.default_rng(5)
    xy = rng.uniform(0, 1, (400, 2))
    P = np.vstack([np.column_stack([xy, 1.0 - xy.sum(1)]), [[0, 0, 0], [1, 0, 0], [0, 1, 0],
                                                             [1, 1, 0], [0, 0, 1]]])
    T = np.vstack([np.arange(400).reshape(100, 4), [[400, 401, 402, 404], [400, 402, 401, 404],
                                                    [400, 401, 402, 403]]])
    signs, vol, err = exact_orientations(P, T)

    def exact(t):
        q = [[Fraction(float(x)) for x in P[i]] for i in t]
        d = [[q[k][j] - q[3][j] for j in range(3)] for k in range(3)]
        e = (d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1])
             + d[0][1] * (d[1][2] * d[2][0] - d[1][0] * d[2][2])
             + d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0]))
        return (e > 0) - (e < 0), e / 6

    want = [exact(t) for t in T]
    assert signs.tolist() == [w[0] for w in want]
    assert signs[-3:].tolist() == [-1, 1, 0] and 0 in signs[:100]
    assert (~(np.abs(vol) > err)).sum() > 50  # most near-flat ones needed the fractions
    assert all(abs(Fraction(float(x)) - w[1]) <= Fraction(float(e)) for x, w, e in
               zip(vol, want, err))


def _agreement(scene, n_res=256):
    v, f = scene.vertices, scene.faces
    bounds = np.array([v.min(0), v.max(0)])
    ref = embree_scene((v, f))
    eye, target, up = orbit_views(bounds, n=1, distance=1.6)[0]
    sets = [pinhole(eye, target, up, fov_deg=40.0, width=n_res, height=n_res, dtype=np.float64),
            random_rays(bounds, 50_000, seed=7, grow=0.25)]
    out = []
    for o, d in sets:
        h = scene.cast(o, d)
        r = ref.cast(o.astype(np.float32), d.astype(np.float32))
        a = compare(h, r, v, f, origins=o, directions=d)
        hit_differ = int(((h.status == tetrace.HIT) != (r.status == tetrace.HIT)).sum())
        out.append((a, hit_differ, (a.agree + same_plane(h, r, v, f)) / a.rays))
    return out


def test_ftetwild_synthetic(ftetwild):
    vertices, faces = synthetic.nested_spheres()
    tz = tetrahedralize((vertices, faces), mesher="ftetwild", epsilon=1e-3)
    check_ftetwild(tz, vertices, faces, 1e-3)
    assert tz.options["epsilon_rel"] == 1e-3 and not tz.options["optimize"]
    # closed spheres: the input is covered by the recovered surface
    assert tz.surface_distance["input_max"] <= 2e-3 * tz.surface_distance["diagonal"]
    # both spheres' triangles are named
    assert len(np.unique(tz.face_triangle)) > 0.8 * len(faces)


def test_ftetwild_scene_agrees_with_embree(ftetwild, embree):
    """Spot through fTetWild: hits are where Embree's are (hit/miss and t) and name the
    same triangle. A face of fTetWild's surface names the input triangle nearest its
    centroid and can span several; the cast names the neighbour the ray crosses
    (``neighbour_triangles``).

    Measured (epsilon 1e-3, 256^2 camera + 5e4 random rays): 99.998% of camera rays and
    99.994% of random rays name Embree's triangle (97.6-98.3% and 99.1% when each face
    named only its nearest triangle); 1-2 rays differ in hit/miss (grazing the
    silhouette); p99 |dt| 2e-7 of the diagonal.
    """
    scene = tetrace.Scene.from_mesh(SPOT, mesher="ftetwild")
    tz = scene.tetrahedralization
    check_ftetwild(tz, scene.vertices, scene.faces, 1e-3)
    for a, hit_differ, plane in _agreement(scene):
        assert a.failed == 0, a
        assert hit_differ <= 1e-3 * a.rays, (hit_differ, a)
        assert a.fraction >= 0.999, a
        assert plane >= a.fraction
        assert a.p99_dt <= 1e-5, a
        # t is evaluated on the named triangle: wherever Embree's triangle is named
        # too, the two agree as for TetGen.
        assert a.dt_over_unexplained == 0, a


def test_ftetwild_contain(ftetwild):
    vertices, faces = synthetic.cube()
    far = np.array([[5.0, 0.5, 0.5], [0.5, -4.0, 2.0]])
    tz = tetrahedralize((vertices, faces), mesher="ftetwild", contain=far)
    assert tz.options["box_in_input"]
    assert np.all(tz.domain[0] < far.min(0)) and np.all(tz.domain[1] > far.max(0))
    check_ftetwild(tz, vertices, faces, 1e-3)
    # only cube faces are constrained, not the domain box given to fTetWild
    assert tz.face_triangle.max() < 12
    scene = tetrace.Scene(tz, vertices, faces)
    o = np.repeat(far[:1], 3, axis=0)
    d = np.array([[-1.0, 0, 0], [-1.0, 0.05, 0.02], [1.0, 0, 0]])
    h = scene.cast(o, d)
    assert h.status.tolist() == [tetrace.HIT, tetrace.HIT, tetrace.MISS]
    np.testing.assert_allclose(h.t[:1], [4.0], rtol=1e-9)


def test_ftetwild_timeout(ftetwild):
    if not meshing.ISOLATE_TETGEN:
        pytest.skip("time limits need the forked child")
    with pytest.raises(MeshingError, match="fTetWild timed out: stopped after 0.01 s"):
        tetrahedralize(synthetic.nested_spheres(), mesher="ftetwild", timeout=0.01)


def test_fallback_uses_ftetwild_when_tetgen_cannot(ftetwild):
    """A self-intersecting scene with repair=False cannot go through TetGen; the
    fallback meshes it with fTetWild and records why."""
    vertices, faces = synthetic.touching_boxes()
    with pytest.raises(MeshingError, match="not a valid PLC"):
        tetrahedralize((vertices, faces), repair=False)
    tz = tetrahedralize((vertices, faces), mesher="fallback", repair=False)
    assert tz.mesher == "ftetwild"
    assert len(tz.attempts) == 1 and "not a valid PLC" in tz.attempts[0]
    check_ftetwild(tz, vertices, faces, 1e-3)
    # a scene TetGen takes stays exact under the fallback
    tz = tetrahedralize(synthetic.cube(), mesher="fallback")
    assert tz.mesher == "tetgen" and tz.attempts == []


def test_mesher_argument():
    with pytest.raises(ValueError, match="mesher must be one of"):
        tetrahedralize(synthetic.cube(), mesher="gmsh")
    with pytest.raises(ValueError, match="epsilon"):
        tetrahedralize(synthetic.cube(), mesher="ftetwild", epsilon=0)


# --------------------------------------------------------------------------- real scenes


def test_teapot_through_ftetwild(scene_path, ftetwild, embree):
    """A small shared scene with 161 intersecting triangle pairs, through fTetWild.

    The teapot's quads are split in coplanar triangle pairs, which fTetWild's surface
    does not separate; the cast names the one the ray crosses. Measured: 99.973% of
    camera rays and 99.982% of random rays name Embree's triangle (87-89% and 95.5%
    when each face named only its nearest triangle); 8 of 36,864 camera rays differ in
    hit/miss.
    """
    path = scene_path("teapot.obj")
    scene = tetrace.Scene.from_mesh(path, mesher="ftetwild")
    check_ftetwild(scene.tetrahedralization, scene.vertices, scene.faces, 1e-3)
    for a, hit_differ, plane in _agreement(scene, 192):
        assert a.failed == 0, a
        assert hit_differ <= 2e-3 * a.rays, (hit_differ, a)
        assert a.fraction >= 0.998, a
        assert plane >= a.fraction, (plane, a)
        assert a.p99_dt <= 1e-5, a


def test_happy_buddha_builds_after_snap_rounding(scene_path, embree):
    """happy_buddha (100k triangles, 59 intersecting pairs): TetGen rejects the exactly
    repaired scene ("self-intersections": pieces closer than its tolerance); the first
    snap-rounding rung builds it, exactly up to the snap (2.4e-7, 1.2e-7 of the
    diagonal). Measured: 10 s, 975k tets."""
    path = scene_path("happy_buddha.obj")
    vertices, faces = load_triangles(path)
    tz = tetrahedralize((vertices, faces))
    assert tz.mesher == "tetgen" and tz.preset == "quality" and tz.repaired
    # The first rung's cell, exactly: the power of two nearest 1e-7 of the domain diagonal.
    assert tz.snap == meshing._snap_cell(tz.domain, meshing.SNAP_LADDER[0][0]) > 0
    assert len(tz.attempts) == 1 and "TetGen after exact repair of" in tz.attempts[0]
    check_ct(tz, vertices, faces, tiles=False)
    scene = tetrace.Scene(tz, vertices, faces)
    for a, hit_differ, _ in _agreement(scene, 256):
        assert a.failed == 0, a
        assert a.fraction >= 0.999, a
        assert a.far_from_edges <= 1e-4 * a.rays, a


def test_neighbour_triangles_share_a_vertex_across_merged_copies():
    """Neighbours are found on the cleaned mesh: two triangles whose corners coincide only
    by position (each with its own vertex copies, as OBJ files split at seams) are
    neighbours, and a caller triangle never lists itself."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0],
                  [5, 5, 5], [6, 5, 5], [5, 6, 5]], float)
    f = np.array([[0, 1, 2], [3, 5, 4], [6, 7, 8]])
    offsets, ids = meshing.neighbour_triangles(clean(v, f), len(f))
    assert offsets.dtype == ids.dtype == np.uint32
    assert [list(ids[offsets[k]:offsets[k + 1]]) for k in range(3)] == [[1], [0], []]
