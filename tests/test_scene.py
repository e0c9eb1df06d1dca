"""The Scene/cast API on the bundled and synthetic scenes: fields, options, bad input."""

import numpy as np
import pytest

import tetrace
from tetrace.dev.camera import pinhole, random_rays
from tetrace.dev.compare import agreement
from tetrace.referee import Referee


@pytest.fixture(scope="module")
def spot():
    return tetrace.default_scene()


def _camera(scene, res=128, dtype=np.float32, distance=1.5):
    lo, hi = scene.vertices.min(0), scene.vertices.max(0)
    c = (lo + hi) / 2
    eye = c + np.array([0.3, 0.2, 1.0]) * distance * np.linalg.norm(hi - lo)
    return pinhole(eye, c, width=res, height=res, dtype=dtype)


def test_hits_fields(spot):
    o, d = _camera(spot)
    for dtype in (np.float32, np.float64):
        h = spot.cast(o.astype(dtype), d.astype(dtype))
        n = len(o)
        assert len(h) == n
        for f in ("t", "u", "v"):
            assert getattr(h, f).dtype == dtype and getattr(h, f).shape == (n,)
        assert h.point.shape == (n, 3) and h.point.dtype == dtype
        assert h.triangle.dtype == np.int32 and h.tet.dtype == np.int32
        assert h.steps.dtype == np.uint32 and h.status.dtype == np.uint8
        hit = h.status == tetrace.HIT
        assert 0 < hit.sum() < n
        assert np.all(np.isinf(h.t[~hit])) and np.all(h.triangle[~hit] == -1)
        assert np.all(np.isnan(h.point[~hit]))
        assert np.all((h.triangle[hit] >= 0) & (h.triangle[hit] < len(spot.faces)))
        # point, t and barycentrics describe the same place on the caller's triangle
        np.testing.assert_allclose(h.point[hit], o[hit] + h.t[hit, None] * d[hit], atol=1e-5)
        p = spot.vertices[spot.faces[h.triangle[hit]]]
        u, v = h.u[hit, None], h.v[hit, None]
        np.testing.assert_allclose(
            (1 - u - v) * p[:, 0] + u * p[:, 1] + v * p[:, 2], h.point[hit], atol=1e-5
        )
        # The CPU default (the exact BVH) walks no tets and counts the boxes a ray entered;
        # the tet walk names the tet each hit's walk ended in.
        assert np.all(h.tet == -1) and np.all(h.steps[hit] >= 1)
        w = spot.cast(o.astype(dtype), d.astype(dtype), accel="tetwalk")
        for f in ("status", "triangle", "t", "u", "v", "point"):
            np.testing.assert_array_equal(getattr(w, f), getattr(h, f), err_msg=f)
        assert np.all((w.tet[hit] >= 0) & (w.tet[hit] < spot.n_tets))
        assert np.all(w.steps[hit] >= 1)


def test_ray_forms_are_equivalent(spot):
    o, d = _camera(spot, 32, np.float64)
    a = spot.cast(o, d)
    b = tetrace.cast(np.hstack([o, d]), spot)
    c = tetrace.cast((o, d), spot)
    e = spot.cast(o[0], d)  # one shared origin
    f = spot.cast(np.asfortranarray(o), np.asfortranarray(d))  # not C-contiguous
    g = spot.cast(np.repeat(o, 2, 0)[::2], np.repeat(d, 2, 0)[::2])  # strided
    for h in (b, c, e, f, g):
        np.testing.assert_array_equal(a.triangle, h.triangle)
        np.testing.assert_array_equal(a.t, h.t)
    dflt = tetrace.cast((o, d))  # the bundled scene by default
    np.testing.assert_array_equal(dflt.triangle, a.triangle)


def test_threads_do_not_change_results(spot):
    o, d = random_rays(spot.domain, 20_000, seed=3)
    a = spot.cast(o, d, threads=1)
    b = spot.cast(o, d, threads=None)
    c = spot.cast(o, d, threads=2)
    for h in (b, c):
        np.testing.assert_array_equal(a.triangle, h.triangle)
        np.testing.assert_array_equal(a.steps, h.steps)


def test_tmin_tmax(spot):
    o, d = _camera(spot, 64, np.float64)
    full = spot.cast(o, d)
    hit = full.status == tetrace.HIT
    # tmax just short of the hit: a miss
    short = spot.cast(o, d, tmax=np.where(hit, full.t * 0.999, np.inf))
    assert np.all(short.status[hit] == tetrace.MISS)
    # tmin past the first hit: the next surface (spot is closed, so the back side)
    past = spot.cast(o, d, tmin=np.where(hit, full.t * 1.0001, 0.0))
    assert np.all(past.status[hit] == tetrace.HIT)
    assert np.all(past.t[hit] > full.t[hit])
    verdict = Referee(spot.vertices, spot.faces).first_hits(
        o, d, tmin=np.where(hit, full.t * 1.0001, 0.0), hint=past.triangle
    )
    score = agreement(past, verdict)
    assert score.right == score.rays == len(o), str(score)  # a float64 walk: every ray right
    # tmax below tmin: nothing
    none = spot.cast(o, d, tmin=2.0, tmax=1.0)
    assert np.all(none.status == tetrace.MISS)


def test_rays_from_inside_a_closed_surface_always_hit(spot):
    # Spot is watertight: rays from its centre must hit (a miss would be a leak).
    c = spot.vertices.mean(0)
    rng = np.random.default_rng(0)
    d = rng.standard_normal((20_000, 3))
    for dtype in (np.float32, np.float64):
        h = spot.cast(c.astype(dtype), d.astype(dtype))
        assert np.all(h.status == tetrace.HIT)


def test_bad_rays_raise_clear_errors(spot):
    o, d = _camera(spot, 8, np.float64)
    bad = o.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="NaN/inf"):
        spot.cast(bad, d)
    zero = d.copy()
    zero[5] = 0
    with pytest.raises(ValueError, match="zero-length"):
        spot.cast(o, zero)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        spot.cast(o[:, :2], d[:, :2])
    with pytest.raises(ValueError, match="same length"):
        spot.cast(o[:5], d[:6])
    with pytest.raises(ValueError, match=r"\(N, 6\)"):
        spot.cast(o)
    with pytest.raises(TypeError, match="float"):
        spot.cast(o.astype(complex), d)
    with pytest.raises(TypeError, match="float"):
        spot.cast(np.array([["a", "b", "c"]]), d[:1])
    with pytest.raises(ValueError, match="tmin must be >= 0"):
        spot.cast(o, d, tmin=-1.0)
    with pytest.raises(ValueError, match="tmax"):
        spot.cast(o, d, tmax=np.ones(3))
    with pytest.raises(ValueError, match="NaN"):
        spot.cast(o, d, tmax=np.nan)
    with pytest.raises(ValueError, match="threads"):
        spot.cast(o, d, threads=0)
    with pytest.raises(ValueError, match="invalid"):
        spot.cast(o, d, invalid="ignore")


def test_invalid_rays_can_be_marked(spot):
    o, d = _camera(spot, 8, np.float32)
    o[1] = np.inf
    d[2] = 0
    h = spot.cast(o, d, invalid="mark")
    assert h.status[1] == tetrace.INVALID and h.status[2] == tetrace.INVALID
    good = np.ones(len(o), bool)
    good[[1, 2]] = False
    assert np.all(h.status[good] != tetrace.INVALID)
    assert h.summary()["invalid"] == 2


def test_integer_and_empty_rays(spot):
    h = spot.cast(np.zeros((0, 3)), np.zeros((0, 3)))
    assert len(h) == 0 and h.t.dtype == np.float64
    c = np.round(spot.vertices.mean(0) * 0).astype(int)
    h = spot.cast(np.array([[5, 0, 0]]), np.array([[-1, 0, 0]]))  # ints become float64
    assert h.t.dtype == np.float64 and h.status[0] == tetrace.HIT
    assert c.dtype.kind == "i"


def test_memory_and_sizes(spot):
    lazy = tetrace.Scene.from_mesh(tetrace.scene.default_scene_path())
    m = lazy.memory()
    assert not lazy.has_ct and "not built" in repr(lazy)
    assert m["points_f64"] == m["locator"] == m[f"tets_{tetrace._native.DEFAULT_LAYOUT}"] == 0
    lazy.cast(np.zeros(3), np.ones(3))
    assert lazy.memory()["exact_bvh"] > 0 and not lazy.has_ct
    m = spot.build_ct().memory()
    default = tetrace._native.DEFAULT_LAYOUT
    assert {"points_f64", "points_f32", "constrained", "locator", f"tets_{default}"} <= set(m)
    assert m[f"tets_{default}"] == spot.n_tets * spot.bytes_per_tet
    assert spot.bytes_per_tet == tetrace.LAYOUT_BYTES[default]
    assert spot.tets().shape == (spot.n_tets, 4) and spot.points().shape == (spot.n_points, 3)
    assert spot.build_times["rust"] > 0 and spot.build_times["tetgen"] > 0
    assert "tets" in repr(spot)


def test_hilbert_order_is_a_renumbering(spot):
    # Without reordering the same rays hit the same triangles, through renumbered tets.
    plain = tetrace.Scene(spot.tetrahedralization, spot.vertices, spot.faces, hilbert=False)
    assert spot.hilbert and not plain.hilbert
    o, d = random_rays(spot.domain, 5000, seed=9)
    a = spot.cast(o, d)
    b = plain.cast(o, d)
    np.testing.assert_array_equal(a.triangle, b.triangle)
    np.testing.assert_allclose(a.t, b.t)
    np.testing.assert_array_equal(a.steps, b.steps)

    # The ordered scene's tets are the same tets in another order.
    def tets_as_point_sets(sc):
        corners = np.sort(sc.points()[sc.tets()].reshape(-1, 4, 3).view("f8,f8,f8"), axis=1)
        return sorted(map(bytes, corners))

    assert tets_as_point_sets(spot) == tets_as_point_sets(plain)


SYNTHETIC = ["cube", "nested_spheres", "thin_plate", "torus_knot", "touching_boxes"]


@pytest.mark.parametrize("name", SYNTHETIC)
@pytest.mark.parametrize("preset", ["quality", "constrained"])
def test_synthetic_scenes_agree_with_referee(name, preset):
    from tetrace.dev import synthetic

    v, f = getattr(synthetic, name)()
    scene = tetrace.Scene.from_mesh((v, f), preset)
    bounds = np.array([v.min(0), v.max(0)])
    o, d = random_rays(bounds, 20_000, seed=5, grow=0.3)
    referee = Referee(v, f)
    for dtype in (np.float32, np.float64):
        o2, d2 = o.astype(dtype), d.astype(dtype)
        h = scene.cast(o2, d2)
        a = agreement(h, referee.first_hits(o2, d2, hint=h.triangle))
        print(f"{name} {preset} {np.dtype(dtype).name}: {a}")
        assert a.failed == 0, f"{name}: {a}"
        assert a.bad == 0, f"{name} {preset}: {a} {a.worst}"


def test_closed_synthetic_scenes_do_not_leak():
    from tetrace.dev import synthetic

    v, f = synthetic.nested_spheres()
    scene = tetrace.Scene.from_mesh((v, f))
    rng = np.random.default_rng(1)
    d = rng.standard_normal((10_000, 3))
    c = v.mean(0)
    h = scene.cast(c, d)
    assert np.all(h.status == tetrace.HIT)


def test_methods_layouts_and_precisions_are_selectable(spot):
    assert "aman2022" in tetrace.methods()
    assert tetrace.layouts() == ["plain", "tet80", "tet32", "tet20", "tet16"]
    assert tetrace.LAYOUT_BYTES == {"plain": 32, "tet80": 80, "tet32": 32, "tet20": 20, "tet16": 16}
    o, d = random_rays(spot.domain, 5000, seed=11)
    base = spot.cast(o, d)
    for layout in tetrace.layouts():
        for precision in ("f32", "f64"):
            if layout == "tet80" and precision == "f64":
                with pytest.raises(ValueError, match="tet80.*f32"):
                    spot.cast(o, d, layout=layout, precision=precision)
                continue
            h = spot.cast(o, d, layout=layout, precision=precision)
            assert h.t.dtype == (np.float32 if precision == "f32" else np.float64)
            assert np.mean(h.triangle == base.triangle) > 0.999, (layout, precision)
        assert spot.memory()[f"tets_{layout}"] == spot.n_tets * tetrace.LAYOUT_BYTES[layout]
    with pytest.raises(ValueError, match="unknown layout.*known: plain"):
        spot.cast(o, d, layout="tet64")
    with pytest.raises(ValueError, match="unknown method.*known: "):
        spot.cast(o, d, method="fastest")
    with pytest.raises(ValueError, match="precision"):
        spot.cast(o, d, precision="f16")
    with pytest.raises(TypeError, match="method must be a name"):
        spot.cast(o, d, method=3)
