"""Rays started from hits (``start=hits``, issue 17): shadow rays, reflections and
transmissions from a cast's hit points, with no offset origin, for every query kind.

The rule (``Scene.cast``'s ``start``): a ray started from a hit on triangle ``T`` hits what its
line meets at one point (closed triangles, never one whose plane holds the line) at ``t`` in
``[tmin, tmax]`` *strictly beyond* the point where the line crosses ``T``'s plane (beyond
``t = 0`` when the line is parallel to that plane). Two judges that share nothing with the walk
decide it: a brute force in rational arithmetic over every triangle (here), and the exact
referee (``tetrace.referee``, ``leaving=``), which are first checked against each other. The
cases are the ones where an epsilon offset fails: hits exactly on vertices and edges, concave
creases where a reflected ray meets the neighbouring face at a tiny ``t``, grazing and exactly
tangent directions, transmissions through thin walls, and rays from inside a closed surface.
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np
import pytest
import trimesh

import tetrace
from tetrace.hits import HIT, MISS
from tetrace.referee import Referee, judge, judge_lists

# --------------------------------------------------------------------------- brute force


def _q(v):
    return [Fraction(float(x)) for x in v]


def _sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _candidates(o, d, tris):
    """Triangles the ray may meet: a float64 Moller-Trumbore test with a margin of 1e-6 on
    the barycentrics (rounding here is ~1e-15 on these small, well-shaped scenes), so no
    triangle the exact test would keep is dropped; the exact test decides the rest."""
    e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    with np.errstate(all="ignore"):
        s = o - tris[:, 0]
        u = np.einsum("ij,ij->i", s, p) / det
        q = np.cross(s, e1)
        v = (q @ d) / det
        t = np.einsum("ij,ij->i", e2, q) / det
        m = 1e-6
        near = (u >= -m) & (v >= -m) & (u + v <= 1 + m) & (t >= -m * (1 + np.abs(t)))
    return np.flatnonzero(near | ~np.isfinite(u) | ~np.isfinite(v))


def exact_meets(o, d, tris, tmin=0.0, tmax=np.inf, leave=None):
    """``{t: [triangle ids]}`` of one ray by the rule above, in rationals (``leave``: the
    corners of the triangle the ray leaves, or None for an ordinary ray)."""
    ks = _candidates(np.asarray(o, np.float64), np.asarray(d, np.float64), tris)
    o, d = _q(o), _q(d)
    tmin = Fraction(float(tmin))
    after = None
    if leave is not None:
        a, b, c = (_q(p) for p in leave)
        n = _cross(_sub(b, a), _sub(c, a))
        nd = _dot(n, d)
        after = Fraction(0) if nd == 0 else _dot(n, _sub(a, o)) / nd
    out: dict[Fraction, list[int]] = {}
    for k in ks:
        a, b, c = (_q(p) for p in tris[k])
        e1, e2 = _sub(b, a), _sub(c, a)
        p = _cross(d, e2)
        det = _dot(e1, p)
        if det == 0:  # the line is parallel to the plane or in it: never a hit
            continue
        s = _sub(o, a)
        u = _dot(s, p) / det
        q = _cross(s, e1)
        v = _dot(d, q) / det
        t = _dot(e2, q) / det
        if u < 0 or v < 0 or u + v > 1 or t < tmin or (tmax != np.inf and t > float(tmax)):
            continue
        if after is not None and not t > after:
            continue
        out.setdefault(t, []).append(int(k))
    return out


def brute_force(tris, origins, directions, tmin, tmax, leaving):
    """Per ray: the sorted exact points ``[(t, ids)]`` of :func:`exact_meets`."""
    tmax = np.broadcast_to(tmax, (len(origins),))
    res = []
    for i in range(len(origins)):
        if tmax[i] < 0:
            res.append([])
            continue
        leave = tris[leaving[i]] if leaving[i] >= 0 else None
        res.append(
            sorted(exact_meets(origins[i], directions[i], tris, 0.0, tmax[i], leave).items())
        )
    return res


# --------------------------------------------------------------------------- scenes and rays


def _cube():
    m = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)


def _groove():
    """Two open quads meeting at a 60-degree crease along the x axis (concave from above),
    and a thin slab floating above (a wall for transmissions)."""
    h = np.tan(np.radians(60.0))  # walls rise at 60 degrees: opening 60 degrees
    v = [
        [-1, 0, 0], [1, 0, 0], [1, -1, h], [-1, -1, h],  # left wall
        [1, 1, h], [-1, 1, h],  # right wall shares the crease (0, 1)
        [-0.5, -0.3, 2.5], [0.5, -0.3, 2.5], [0.5, 0.3, 2.5], [-0.5, 0.3, 2.5],  # slab bottom
        [-0.5, -0.3, 2.52], [0.5, -0.3, 2.52], [0.5, 0.3, 2.52], [-0.5, 0.3, 2.52],  # slab top
    ]  # fmt: skip
    f = [
        [0, 1, 2], [0, 2, 3], [1, 0, 5], [1, 5, 4],
        [6, 8, 7], [6, 9, 8], [10, 11, 12], [10, 12, 13],
        [6, 7, 11], [6, 11, 10], [7, 8, 12], [7, 12, 11],
        [8, 9, 13], [8, 13, 12], [9, 6, 10], [9, 10, 13],
    ]  # fmt: skip
    return np.asarray(v, np.float64), np.asarray(f, np.int64)


def _sphere():
    m = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)


def _targets(v, f, rng, n_random):
    """Points on the surface: every vertex, every edge midpoint, every centroid and random
    points in triangles (rays aimed there hit exactly on vertices and edges)."""
    tris = v[f]
    mids = np.concatenate([(tris[:, 0] + tris[:, 1]) / 2, (tris[:, 1] + tris[:, 2]) / 2])
    w = rng.dirichlet([1, 1, 1], size=n_random)
    k = rng.integers(0, len(f), n_random)
    rand = np.einsum("ij,ijk->ik", w, tris[k])
    return np.concatenate([v, mids, tris.mean(1), rand])


def _primary(v, f, eyes, rng, n_random=40):
    targets = _targets(v, f, rng, n_random)
    o = np.repeat(np.asarray(eyes, np.float64), len(targets), axis=0)
    d = np.tile(targets, (len(eyes), 1)) - o
    return o, d


def _unit(x):
    """Unit vectors; a zero vector (a miss's) becomes +z, which no test reads."""
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    return np.where(n > 0, x / np.where(n > 0, n, 1.0), [0.0, 0.0, 1.0])


def _secondary_directions(hits, d, rng):
    """Directions of every kind from each hit: mirror reflection, transmission (straight on),
    to a point light, random over the sphere, grazing (tangent plus a tiny normal part, both
    signs) and exactly tangent (along an edge of the hit triangle)."""
    n = np.nan_to_num(hits.normal.astype(np.float64))
    d = _unit(d)
    reflect = d - 2 * np.sum(d * n, axis=1, keepdims=True) * n
    light = np.array([0.3, 0.2, 4.0]) - np.nan_to_num(hits.point)
    rand = _unit(rng.normal(size=d.shape))
    tangent = _unit(np.cross(n, rng.normal(size=d.shape)))
    graze_in = tangent - 1e-9 * n
    graze_out = tangent + 1e-12 * n
    return {
        "reflect": reflect,
        "transmit": d,
        "light": light,
        "random": rand,
        "graze_in": graze_in,
        "graze_out": graze_out,
    }


CASES = {
    "cube": (_cube, [[2.5, 1.7, 3.1], [-2.2, -0.4, 0.9], [0.1, 0.05, 0.0]]),
    "groove": (_groove, [[0.3, 0.05, 3.5], [-0.6, -0.4, 1.5], [0.0, 0.0, 0.8]]),
    "sphere": (_sphere, [[0.0, 0.0, 0.0], [0.1, -0.2, 0.3], [3.0, 1.0, 2.0]]),
}


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    make, eyes = CASES[request.param]
    v, f = make()
    scene = tetrace.Scene.from_mesh((v, f))
    rng = np.random.default_rng(17)
    o, d = _primary(v, f, eyes, rng)
    hits = scene.cast(o, d)
    assert (hits.status == HIT).sum() > len(o) // 3, "too few primary hits to test anything"
    dirs = _secondary_directions(hits, d, rng)
    # Exactly tangent: along the hit triangle's first edge (the line lies in its plane).
    tris = v[f]
    k = np.maximum(hits.scene_triangle, 0)
    dirs["tangent"] = tris[k, 1] - tris[k, 0]
    return request.param, v, f, scene, hits, dirs


def _leaving_ids(hits):
    return np.where(hits.status == HIT, hits.scene_triangle, -1)


def _flat_rays(hits, d):
    hit = hits.status == HIT
    o = np.where(hit[:, None], hits.point, 0.0)
    return o, np.where(hit[:, None], d, 1.0), hit


# --------------------------------------------------------------------------- the judges agree


def test_brute_force_and_referee_agree_on_rays_from_hits(case):
    """The two judges, written apart, give the same first hits (exact t, tie sets) and the
    same crossings for every kind of ray from a hit."""
    name, v, f, scene, hits, dirs = case
    tris = v[f]
    ref = Referee(v, f)
    leaving = _leaving_ids(hits)
    for kind, d in dirs.items():
        o, dd, hit = _flat_rays(hits, d)
        tmax = np.where(hit, np.inf, -np.inf)
        bf = brute_force(tris, o, dd, 0.0, tmax, leaving)
        verdict = ref.first_hits(o, dd, 0.0, tmax, leaving=leaving)
        crossings = ref.crossings(o, dd, 0.0, tmax, leaving=leaving)
        for i, pts in enumerate(bf):
            assert verdict.hit[i] == bool(pts), (name, kind, i)
            assert crossings.ray_ptr[i + 1] - crossings.ray_ptr[i] == len(pts), (name, kind, i)
            if pts:
                t0, ids = pts[0]
                assert verdict.t[i] == float(t0), (name, kind, i)
                assert sorted(verdict.tie_set(i)) == sorted(ids), (name, kind, i)


def test_the_rule_matters_on_these_rays(case):
    """The cases have teeth: for some rays the plain ray from the rounded hit point (what an
    epsilon-free cast from ``hits.point`` answers) differs from the ray started from the hit —
    it hits the triangle it leaves, or a neighbour short of its plane."""
    name, v, f, scene, hits, dirs = case
    tris = v[f]
    leaving = _leaving_ids(hits)
    differ = 0
    for kind in ("reflect", "transmit", "graze_in", "tangent"):
        o, dd, hit = _flat_rays(hits, dirs[kind])
        for i in np.flatnonzero(hit):
            leave = tris[leaving[i]]
            plain = exact_meets(o[i], dd[i], tris)
            started = exact_meets(o[i], dd[i], tris, leave=leave)
            differ += min(plain, default=None) != min(started, default=None)
    assert differ > 0, f"{name}: no ray where the rule decides anything"


# --------------------------------------------------------------------------- every query kind


def _cast_judged(scene, v, f, hits, d, **kw):
    """Cast from the hits with ``d`` and judge against the referee: no ray may be anything but
    right."""
    o, dd, hit = _flat_rays(hits, d)
    tmax = np.where(hit, np.inf, -np.inf)
    got = scene.cast(start=hits, directions=d, **kw)
    verdict = Referee(v, f).first_hits(o, dd, 0.0, tmax, leaving=_leaving_ids(hits))
    masks = judge(got, verdict)
    bad = np.flatnonzero(~masks["right"] & ~masks["invalid"])
    assert not len(bad), {k: int(m.sum()) for k, m in masks.items()}
    assert (got.status[~hit] == MISS).all()
    return got


@pytest.mark.parametrize("accel", [None, "reshetov_bvh", "portalez_octree"])
def test_closest_hit_from_hits_is_exact(case, accel):
    name, v, f, scene, hits, dirs = case
    for d in dirs.values():
        _cast_judged(scene, v, f, hits, d, accel=accel)


def test_occluded_from_hits_is_exact(case):
    name, v, f, scene, hits, dirs = case
    tris = v[f]
    leaving = _leaving_ids(hits)
    for kind, d in dirs.items():
        for tmax in (np.inf, 1.0):
            o, dd, hit = _flat_rays(hits, d)
            got = scene.occluded(start=hits, directions=d, tmax=tmax)
            tm = np.where(hit, tmax, -np.inf)
            want = np.array([bool(p) for p in brute_force(tris, o, dd, 0.0, tm, leaving)])
            np.testing.assert_array_equal(got, want, err_msg=f"{name} {kind} tmax={tmax}")


def test_intersections_and_counts_from_hits_are_exact(case):
    name, v, f, scene, hits, dirs = case
    ref = Referee(v, f)
    leaving = _leaving_ids(hits)
    for kind, d in dirs.items():
        o, dd, hit = _flat_rays(hits, d)
        tmax = np.where(hit, np.inf, -np.inf)
        crossings = ref.crossings(o, dd, 0.0, tmax, leaving=leaving)
        got = scene.intersections(start=hits, directions=d)
        verdict = judge_lists(got.offsets, got.t, got.scene_triangle, crossings)
        assert verdict["right"].all(), (name, kind, {k: int(m.sum()) for k, m in verdict.items()})
        counts = scene.count_intersections(start=hits, directions=d)
        np.testing.assert_array_equal(counts, np.diff(crossings.ray_ptr))


def test_light_at_the_end_of_a_shadow_ray(case):
    """``directions = light - point`` with ``tmax = 1``: occluded exactly when something lies
    between the hit (beyond its own triangle) and the light, the light's own position
    included."""
    name, v, f, scene, hits, dirs = case
    d = dirs["light"]
    occluded = scene.occluded(start=hits, directions=d, tmax=1.0)
    first = scene.cast(start=hits, directions=d)
    hit = hits.status == HIT
    # Consistent with the closest hit of the same rays: occluded iff it lies at t <= 1 (the
    # exact t of a hit at 1 rounds to 1; first hits are exact to the referee, tested above).
    assert not occluded[~hit].any()
    np.testing.assert_array_equal(occluded[hit], (first.status[hit] == HIT) & (first.t[hit] <= 1))


# --------------------------------------------------------------------------- what it rests on


def test_connectivity_changes_no_answer(case):
    """The tet a hit names only saves point location: the same rays with no tet (-1), or with
    a wrong tet anywhere in the mesh, give the same answers bit for bit."""
    name, v, f, scene, hits, dirs = case
    rng = np.random.default_rng(3)
    for d in dirs.values():
        base = scene.cast(start=hits, directions=d)
        for tet in (np.full_like(hits.tet, -1), rng.integers(0, scene.n_tets, hits.tet.shape)):
            other = dataclasses.replace(hits, tet=tet.astype(np.int32))
            again = scene.cast(start=other, directions=d)
            for field in ("status", "triangle", "t", "u", "v"):
                np.testing.assert_array_equal(getattr(again, field), getattr(base, field))


def test_threads_packets_and_float32_change_no_answer(case):
    name, v, f, scene, hits, dirs = case
    d = dirs["reflect"]
    base = scene.cast(start=hits, directions=d)
    for kw in ({"threads": 1}, {"threads": 2}, {"packet": False}):
        again = scene.cast(start=hits, directions=d, **kw)
        np.testing.assert_array_equal(again.t, base.t)
        np.testing.assert_array_equal(again.triangle, base.triangle)
    # float32 rays: the hit points are float32, and the rays from them are judged as given.
    o32, d32 = _primary(v, f, CASES[name][1], np.random.default_rng(17))
    hits32 = scene.cast(o32.astype(np.float32), d32.astype(np.float32))
    assert hits32.point.dtype == np.float32
    refl = _secondary_directions(hits32, d32, np.random.default_rng(5))["reflect"]
    _cast_judged(scene, v, f, hits32, refl.astype(np.float32))


def test_gpu_casts_from_hits_are_the_cpu_exact_casts(case):
    """``start=hits`` on the GPU (exact kernel): each ray begins where the CPU exact walk
    begins it, next to its hit's tet, the GPU takes the plain steps, the CPU the rest. Every
    column equals the CPU exact walk's float32 cast from the same hits, bit for bit (the CPU
    default's hits and t, u, v, point too), and the referee finds every ray right."""
    from conftest import gpu_device

    gpu_device()
    name, v, f, scene, hits, dirs = case
    o32, d32 = _primary(v, f, CASES[name][1], np.random.default_rng(17))
    hits32 = scene.cast(o32.astype(np.float32), d32.astype(np.float32))
    walked = 0
    for kind, d in _secondary_directions(hits32, d32, np.random.default_rng(5)).items():
        d = d.astype(np.float32)
        got = _cast_judged(scene, v, f, hits32, d, device="gpu")
        # The CPU exact walk from the same hits (the CPU default's hits name no tet: both
        # walks begin next to the hit's triangle), and the CPU default (the exact BVH).
        cpu = scene.cast(start=hits32, directions=d, accel="tetwalk")
        bvh = scene.cast(start=hits32, directions=d)
        for tmax in (np.inf, 1.0):
            np.testing.assert_array_equal(
                scene.occluded(start=hits32, directions=d, tmax=tmax, device="gpu"),
                scene.occluded(start=hits32, directions=d, tmax=tmax),
                f"{kind} occluded, tmax {tmax}",
            )
        for field in ("status", "triangle", "t", "u", "v", "point", "tet", "steps", "normal"):
            np.testing.assert_array_equal(
                getattr(got, field), getattr(cpu, field), f"{kind} {field}"
            )
        for field in ("status", "triangle", "t", "u", "v", "point", "normal"):
            np.testing.assert_array_equal(
                getattr(got, field), getattr(bvh, field), f"{kind} {field}, exact BVH"
            )
        # Not one origin: the resumed kernel, which the CPU hands each begun walk.
        assert got.timings is not None and not got.timings["shared_origin"], kind
        walked += got.timings["walked"]
    if name == "cube":
        # An axis-aligned face: every float32 hit point lies in its triangle's plane exactly,
        # so the CPU decides each ray's start and walks it whole (`origin_on_a_plane`).
        assert walked == 0
    else:
        assert walked > 0, "no ray from a hit was walked on the GPU"


def test_directions_broadcast_over_the_hits(case):
    """``(S, *hits.shape, 3)`` directions cast S rays from every hit (area-light samples)."""
    name, v, f, scene, hits, dirs = case
    d = np.stack([dirs["light"], dirs["random"]])
    two = scene.occluded(start=hits, directions=d)
    assert two.shape == (2,) + hits.t.shape
    np.testing.assert_array_equal(two[0], scene.occluded(start=hits, directions=dirs["light"]))
    np.testing.assert_array_equal(two[1], scene.occluded(start=hits, directions=dirs["random"]))


def test_bad_starts_are_refused(case):
    name, v, f, scene, hits, dirs = case
    d = dirs["reflect"]
    with pytest.raises(TypeError, match="start"):
        scene.cast(start=np.zeros((3, 3)), directions=d)
    with pytest.raises(TypeError, match="not both"):
        scene.cast(hits.point, d, start=hits)
    with pytest.raises(TypeError, match="directions"):
        scene.cast(start=hits)
    with pytest.raises(ValueError, match="broadcast"):
        scene.cast(start=hits, directions=np.ones((len(d) + 1, 3)))
    with pytest.raises(ValueError, match="exact method"):
        scene.cast(start=hits, directions=d, method="aman2022")
    with pytest.raises(ValueError, match="exact kernel"):
        scene.cast(start=hits, directions=d, device="gpu", method="aman2022")
    far = dataclasses.replace(hits, scene_triangle=np.full_like(hits.scene_triangle, len(f) + 5))
    with pytest.raises(ValueError, match="triangles"):
        scene.cast(start=far, directions=d)
    # The scene still answers.
    _cast_judged(scene, v, f, hits, d)


# --------------------------------------------------------------------------- a real scene


@pytest.mark.parametrize("which", ["default", "bunny.obj"])
def test_shadow_and_bounce_rays_on_a_real_scene(which, scene_path):
    """A camera's hits on the bundled scene and the bunny, then shadow rays to a light and
    mirror bounces from every hit: every ray right against the referee."""
    from tetrace.dev.camera import pinhole

    path = tetrace.default_scene_path() if which == "default" else scene_path(which)
    mesh = trimesh.load(path, force="mesh", process=False)
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    scene = tetrace.Scene.from_mesh((v, f))
    lo, hi = v.min(0), v.max(0)
    c, r = (lo + hi) / 2, np.linalg.norm(hi - lo)
    o, d = pinhole(c + [0.3 * r, 0.4 * r, 1.2 * r], c, width=48, height=40, dtype=np.float64)
    hits = scene.cast(o, d)
    assert (hits.status == HIT).sum() > 200
    light = c + [r, 2 * r, 0.5 * r]
    _cast_judged(scene, v, f, hits, light - np.nan_to_num(hits.point), tmax=1.0)
    dd = _unit(d)
    n = np.nan_to_num(hits.normal.astype(np.float64))
    _cast_judged(scene, v, f, hits, dd - 2 * np.sum(dd * n, axis=-1, keepdims=True) * n)


def test_secondary_bench_rows_are_right():
    """``python -m tetrace.bench secondary`` on the bundled scene: both ``start=hits`` rows are
    right on every ray, and locating every origin walks the very same tets (same steps)."""
    from tetrace.bench.secondary import run_secondary

    rows = run_secondary([None], res=24, repeat=1)
    assert {r["kind"] for r in rows} == {"shadow", "bounce"}
    for kind in ("shadow", "bounce"):
        mine = [r for r in rows if r["kind"] == kind and r["caster"].startswith("tetrace start")]
        assert len(mine) == 2 and mine[0]["rays"] > 50
        assert all(r["wrong"] == 0 for r in mine)
        assert mine[0]["steps_per_ray"] == mine[1]["steps_per_ray"]
