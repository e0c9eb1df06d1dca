"""``python -m tetrace.bench queries``: every query kind, timed against embreex and Open3D (and
closest hits against warp-lang and mitsuba) on the same rays and judged ray by ray by the exact
referee.

Query kinds and their peers (same float32 rays, same thread count, an untimed warm-up, the
best of ``repeat``):

* closest: ``Scene.cast``; embreex ``run`` (``rtcIntersect1``); Open3D ``cast_rays``;
  warp-lang ``wp.mesh_query_ray`` (CPU) and mitsuba ``ray_intersect_preliminary``
  (``scalar_rgb`` and ``llvm_ad_rgb``), the casters of :mod:`tetrace.bench.casters`, on the
  closest-hit ray sets (their ``tmax`` is infinite, which those casters take as given);
* any: ``Scene.occluded``; embreex ``run(query="OCCLUDED")``; Open3D ``test_occlusions``;
* all: ``Scene.intersections``; Open3D ``list_intersections`` (embreex has none);
* count: ``Scene.count_intersections``; Open3D ``count_intersections``;
* contains: ``Scene.contains``; Open3D ``compute_occupancy``.

The judge is :mod:`tetrace.referee`, which shares no code with the walk: ``first_hits`` for
closest and any hit, ``crossings`` (every distinct exact point where the ray meets a closed
triangle, not one whose plane holds the ray) for all hits and counts, and for containment the
parity of the crossings along a ray from the point in a random direction that meets the
surface only inside triangles (re-drawn until it does); points exactly on the surface (the
mesh's vertices) are inside by tetrace's contract. Containment is judged here on closed
surfaces only (every edge shared by an even number of triangles: exact parity); open ones take
the winding number, benchmarked against a closed copy by ``python -m tetrace.bench.occupancy``.

The rays: a pinhole camera (``res``^2, from outside), random rays in and around the scene,
shadow rays from a point light to the camera's hits (``tmax`` short of the hit, so the rays
do not touch the surface they aim at), and the degenerate rays of the stress families
(:mod:`tetrace.dev.stress`: through vertices and edges, along edges, in face planes, from the
surface), where the peers list or count a crossing at a shared edge once per triangle. Points
for containment: uniform in the grown bounding box (timed), and the mesh's vertices (judged).
"""

from __future__ import annotations

import time

import numpy as np

from ..baselines.embree import cpu_count, embree_scene
from ..dev.camera import orbit_views, pinhole, random_rays
from ..referee import Referee, judge, judge_lists
from ..scene import Scene, default_scene_path, simd_levels
from .casters import PEER_TITLES, PEERS, _peer_hits, open3d_module
from .scene_bench import _table

QUERIES = ("closest", "any", "all", "count", "contains")
#: The peers that answer closest hits only, through their bench casters.
CLOSEST_PEERS = ("warp", "mitsuba", "mitsuba_llvm")
#: Every peer, as the tables show them.
PEER_NAMES = ("embreex", "open3d", *CLOSEST_PEERS)
#: Shadow rays stop this fraction of the way to the hit they aim at.
SHADOW_TMAX = 1.0 - 2.0**-10


def _best(fn, repeat):
    """A first call (timed apart: it builds what a query builds lazily), then the best wall
    time of ``repeat`` calls; ``(best, first, result)``."""
    t0 = time.perf_counter()
    out = fn()
    first = time.perf_counter() - t0
    best = np.inf
    for _ in range(max(int(repeat), 1)):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, first, out


def is_closed(vertices, faces):
    """Every edge shared by an even number of triangles (tetrace's 'closed'), with vertices
    at one position taken as one (a textured file repeats them along its UV seams)."""
    _, weld = np.unique(np.asarray(vertices), axis=0, return_inverse=True)
    f = weld.ravel()[np.asarray(faces, np.int64)]
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return bool((counts % 2 == 0).all())


def reference_contains(referee, points, seed=0, tries=8):
    """Exact inside/outside of points for a closed surface (see the module docstring).

    Returns
    -------
    inside : numpy.ndarray
        bool.
    decided : numpy.ndarray
        bool: a generic direction was found within ``tries`` (otherwise not judged).
    """
    rng = np.random.default_rng(seed)
    p = np.asarray(points, np.float64)
    inside = np.zeros(len(p), bool)
    decided = np.zeros(len(p), bool)
    todo = np.arange(len(p))
    for _ in range(tries):
        if not len(todo):
            break
        d = rng.standard_normal((len(todo), 3))
        c = referee.crossings(p[todo], d)
        pair_ray = np.repeat(np.arange(len(todo)), c.count)
        # Generic: one triangle at each point, strictly inside it, and not at the start.
        ties = np.diff(c.point_ptr)
        first = c.point_ptr[:-1]
        bad_point = (ties != 1) | (c.zero_signs[first] != 0) | (c.t == 0)
        bad = np.bincount(pair_ray[bad_point], minlength=len(todo)) > 0
        ok = todo[~bad]
        inside[ok] = c.count[~bad] % 2 == 1
        decided[ok] = True
        todo = todo[bad]
    return inside, decided


def _open3d_scene(o3d, v, f):
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.ascontiguousarray(v, np.float32)),
        o3d.core.Tensor(np.ascontiguousarray(f, np.uint32)),
    )
    return scene


def _rays6(o3d, o, d):
    return o3d.core.Tensor(np.ascontiguousarray(np.hstack([o, d]), dtype=np.float32))


class _Peers:
    """The peers' calls for each query kind, on float32 rays (None where a peer has none)."""

    def __init__(self, v, f):
        self.embree = embree_scene((v, f))
        self.o3d, self.o3d_reason = open3d_module()
        self.o3d_scene = _open3d_scene(self.o3d, v, f) if self.o3d else None
        self.closest_casters, self.skipped = {}, {}
        for name in CLOSEST_PEERS:
            module, make = PEERS[name]
            m, why = module()
            if m is None:
                self.skipped[name] = why
            else:
                self.closest_casters[name] = make(m, v, f)

    def closest_peer(self, name, query, o, d, tmax, k):
        """A closest-only peer's cast (None for other queries and for a finite ``tmax``)."""
        caster = self.closest_casters.get(name)
        if caster is None or query != "closest" or np.isfinite(tmax):
            return None
        return lambda: caster.cast(o, d, k)

    def embreex(self, query, o, d, tmax, k):
        if query == "closest":
            tfar = np.full(len(o), tmax, np.float32)
            return lambda: self.embree.intersect(o, d, tfar.copy(), threads=k)
        if query == "any":
            tfar = np.full(len(o), tmax, np.float32)
            return lambda: self.embree.occluded(o, d, tfar, threads=k)
        return None

    def open3d(self, query, o, d, tmax, k):
        if self.o3d is None:
            return None
        s, o3d = self.o3d_scene, self.o3d
        if query == "contains":
            pts = o3d.core.Tensor(np.ascontiguousarray(o, np.float32))
            return lambda: s.compute_occupancy(pts, nthreads=k)
        rays = _rays6(o3d, o, d)
        return {
            "closest": lambda: s.cast_rays(rays, nthreads=k),
            "any": lambda: s.test_occlusions(rays, tfar=float(tmax), nthreads=k),
            "all": lambda: s.list_intersections(rays, nthreads=k),
            "count": lambda: s.count_intersections(rays, nthreads=k),
        }[query]


#: tetrace's casters: the tet walk (the default), Reshetov's BVH (``accel=``), one ray at a
#: time and in 4×4 packets with frustum vertex culling, and Portalez & Duguet's octree.
TETRACE_CASTERS = {
    "tetrace": None,
    "tetrace_bvh": "reshetov_bvh",
    "tetrace_bvh_packets": "reshetov_bvh_packets",
    "tetrace_octree": "portalez_octree",
}


def _tetrace(scene, query, o, d, tmax, k, accel=None):
    kw = dict(tmax=tmax, threads=k, accel=accel)
    if query == "closest":
        return lambda: scene.cast(o, d, **kw)
    if query == "any":
        return lambda: scene.occluded(o, d, **kw)
    if query == "all":
        return lambda: scene.intersections(o, d, **kw)
    if query == "count":
        return lambda: scene.count_intersections(o, d, **kw)
    if accel is not None:
        return None  # containment is the tet walk's (exact location and parity)
    return lambda: scene.contains(o, threads=k)


# --------------------------------------------------------------------------- judging


def _lists_of(caster, out, n):
    """``(offsets, t, triangle, arithmetic)`` of an all-hits answer."""
    if caster in TETRACE_CASTERS:
        return out.offsets, out.t, out.triangle, "f64"
    # Open3D does not promise its lists sorted by t: judged as sets, sorted here.
    splits = out["ray_splits"].numpy().astype(np.int64)
    t, tri = out["t_hit"].numpy(), out["primitive_ids"].numpy().astype(np.int64)
    order = np.lexsort((t, np.repeat(np.arange(n), np.diff(splits))))
    return splits, t[order], tri[order], "f32"


def judge_answer(query, caster, out, ref, origins=None, directions=None, peer=None):
    """``(right, judged)`` of one caster's answer to ``query`` against the referee's ``ref``.

    ``ref`` is a :class:`~tetrace.referee.Verdict` (closest, any), a
    :class:`~tetrace.referee.Crossings` (all, count) or ``(inside, decided)`` (contains);
    ``origins``, ``directions`` (the rays cast) are needed for a peer's closest hits;
    ``peer`` is the bench caster of a closest-only peer (:data:`CLOSEST_PEERS`).
    """
    if query == "contains":
        inside, decided = ref
        got = np.asarray(out.numpy() if hasattr(out, "numpy") else out).astype(bool)
        got = got.ravel()
        return int((decided & (got == inside)).sum()), int(decided.sum())
    if query == "closest":
        if caster == "embreex":
            hits, arith = _peer_hits(origins, directions, *out), "f32"
        elif peer is not None:
            hits, arith = peer.hits(out, origins, directions), peer.arithmetic
        elif caster == "open3d":
            t = out["t_hit"].numpy()
            prim = np.where(np.isfinite(t), out["primitive_ids"].numpy().astype(np.int64), -1)
            uv = out["primitive_uvs"].numpy()
            hits, arith = _peer_hits(origins, directions, prim, t, uv[:, 0], uv[:, 1]), "f32"
        else:
            hits, arith = out, "f64"
        j = judge(hits, ref, arith)
        return int(j["right"].sum()), int((~j["invalid"]).sum())
    if query == "any":
        got = np.asarray(out.numpy() if hasattr(out, "numpy") else out).astype(bool).ravel()
        valid = ~ref.invalid
        return int((valid & (got == ref.hit)).sum()), int(valid.sum())
    if query == "count":
        got = np.asarray(out.numpy() if hasattr(out, "numpy") else out).astype(np.int64).ravel()
        valid = ~ref.invalid
        return int((valid & (got == ref.count)).sum()), int(valid.sum())
    offsets, t, tri, arith = _lists_of(caster, out, len(ref))
    j = judge_lists(offsets, t, tri, ref, arith)
    return int(j["right"].sum()), int((~j["invalid"]).sum())


def _reference(referee, query, o, d, tmin, tmax, hint=None):
    if query in ("closest", "any"):
        return referee.first_hits(o, d, tmin, tmax, hint=hint)
    return referee.crossings(o, d, tmin, tmax)


# --------------------------------------------------------------------------- the runs


def _ray_sets(v, res, n_random, scene):
    bounds = np.array([v.min(0), v.max(0)])
    eye, target, up = orbit_views(bounds, n=1, distance=1.6)[0]
    co, cd = pinhole(eye, target, up, fov_deg=40.0, width=res, height=res, dtype=np.float32)
    ro, rd = random_rays(bounds, n_random, seed=7, grow=0.25, dtype=np.float32)
    # Shadow rays: from a light above and beside the camera to the camera's hits.
    h = scene.cast(co, cd)
    hit = h.status == 1
    light = (eye + 0.5 * np.linalg.norm(bounds[1] - bounds[0]) * np.asarray(up)).astype(np.float32)
    so = np.broadcast_to(light, (int(hit.sum()), 3)).astype(np.float32)
    sd = (h.point[hit] - so).astype(np.float32)
    rng = np.random.default_rng(11)
    lo, hi = bounds[0] - 0.25 * (bounds[1] - bounds[0]), bounds[1] + 0.25 * (bounds[1] - bounds[0])
    pts = (lo + rng.random((n_random, 3)) * (hi - lo)).astype(np.float32)
    return {
        "camera": (co, cd, np.inf),
        "random": (ro, rd, np.inf),
        "shadow": (so, sd, SHADOW_TMAX),
        "points": (pts, None, None),
    }


def judge_surface_points(scene, referee, peers, vertices):
    """Containment of points on the surface (the mesh's vertices): inside by tetrace's
    contract. tetrace gets them as they are (float64); Open3D takes float32 points, so it is
    judged on the vertices rounded to float32 (inside where rounding kept them on the
    surface, else the exact parity)."""
    p64 = np.unique(np.asarray(vertices, np.float64), axis=0)
    rows = []
    got = scene.contains(p64)
    rows.append(
        dict(
            query="contains",
            rays="vertices",
            caster="tetrace",
            right=int(got.sum()),
            judged=len(p64),
        )
    )
    if peers.o3d is not None:
        p32 = p64.astype(np.float32)
        on = np.all(p32 == p64, axis=1)
        inside, decided = np.ones(len(p32), bool), np.ones(len(p32), bool)
        inside[~on], decided[~on] = reference_contains(referee, p32[~on])
        occ = peers.open3d("contains", p32, None, None, 0)()
        right, n = judge_answer("contains", "open3d", occ, (inside, decided))
        rows.append(dict(query="contains", rays="vertices", caster="open3d", right=right, judged=n))
    return rows


def run_queries(path=None, *, res=256, n_random=20_000, repeat=3, stress=300, out=print):
    """Time and judge every query kind on one scene; judge them on the stress families.

    Returns
    -------
    dict
        ``timing`` rows (query, ray set, caster, threads, Mq/s) and ``judged`` rows (query,
        ray set, caster, right, judged).
    """
    from .. import _native

    path = str(path) if path else str(default_scene_path())
    scene = Scene.from_mesh(path)
    v, f = scene.vertices, scene.faces
    referee = Referee(v, f)
    peers = _Peers(v, f)
    sets = _ray_sets(v, res, n_random, scene)
    closed = is_closed(v, f)
    threads = sorted({1, cpu_count()})
    out(
        f"scene {path}: {len(f)} triangles, closed: {closed}; tetrace method "
        f"{_native.DEFAULT_METHOD} (the default), SIMD level {simd_levels()[1]}; "
        f"threads {threads}"
    )
    if peers.o3d is None:
        out(f"Open3D: {peers.o3d_reason}")
    for name, why in peers.skipped.items():
        out(f"{PEER_TITLES[name]} ({name}): {why}")
    plan = [
        ("closest", "camera"),
        ("closest", "random"),
        ("any", "shadow"),
        ("any", "random"),
        ("all", "camera"),
        ("all", "random"),
        ("count", "camera"),
        ("count", "random"),
    ]
    if closed:
        plan.append(("contains", "points"))
    timing, judged = [], []
    for query, set_name in plan:
        o, d, extra = sets[set_name]
        tmax = extra if query != "contains" else None
        if query == "contains":
            ref = reference_contains(referee, o)
        else:
            ref = None
        for caster in (*TETRACE_CASTERS, *PEER_NAMES):
            calls = {
                k: (
                    _tetrace(scene, query, o, d, tmax, k, TETRACE_CASTERS[caster])
                    if caster in TETRACE_CASTERS
                    else peers.closest_peer(caster, query, o, d, tmax, k)
                    if caster in CLOSEST_PEERS
                    else getattr(peers, caster)(query, o, d, tmax, k)
                )
                for k in threads
            }
            if calls[1] is None:
                continue
            for k, fn in calls.items():
                secs, first, answer = _best(fn, repeat)
                timing.append(
                    dict(
                        query=query,
                        rays=set_name,
                        caster=caster,
                        threads=k,
                        n=len(o),
                        mqs=len(o) / secs / 1e6,
                        first_s=first,
                    )
                )
            if ref is None:
                hint = None
                if query == "closest":
                    hint = scene.cast(o, d, tmax=tmax).triangle
                ref = _reference(referee, query, o, d, 0.0, tmax, hint)
            right, n = judge_answer(
                query, caster, answer, ref, o, d, peers.closest_casters.get(caster)
            )
            judged.append(dict(query=query, rays=set_name, caster=caster, right=right, judged=n))
    if closed:
        judged += judge_surface_points(scene, referee, peers, v)
    _print_timing(timing, out)
    if stress:
        judged += judge_stress(stress, peers_too=peers.o3d is not None, out=out)
    _print_judged(judged, out)
    return dict(timing=timing, judged=judged)


def judge_stress(n, *, peers_too=True, out=print):
    """Judge any, all and count on ``n`` rays of each exact stress family, float32 rays.

    tetrace gets each ray's ``tmin``/``tmax``; the peers (whose list and count calls take no
    bounds) are judged on the rays with ``tmin = 0`` and ``tmax = inf`` only.
    """
    from ..dev.stress import EXACT_FAMILIES, build_scene, cases

    rows = []
    o3d, _ = open3d_module() if peers_too else (None, None)
    for case in cases(n, families=EXACT_FAMILIES):
        o, d = case.rays("f32")
        o64, d64 = o.astype(np.float64), d.astype(np.float64)
        scene = build_scene(case)
        referee = Referee(case.vertices, case.faces)
        plain = (case.tmin == 0) & np.isinf(case.tmax)
        verdict = referee.first_hits(o64, d64, case.tmin, case.tmax)
        cross = referee.crossings(o64, d64, case.tmin, case.tmax)
        for caster, accel in TETRACE_CASTERS.items():
            kw = dict(tmin=case.tmin, tmax=case.tmax, accel=accel)
            answers = {
                "any": scene.occluded(o, d, **kw),
                "all": scene.intersections(o, d, **kw),
                "count": scene.count_intersections(o, d, **kw),
            }
            for query, ans in answers.items():
                ref = verdict if query == "any" else cross
                right, k = judge_answer(query, caster, ans, ref)
                rows.append(dict(query=query, rays="stress", caster=caster, right=right, judged=k))
        if o3d is None or not plain.any():
            continue
        s = _open3d_scene(o3d, case.vertices, case.faces)
        rays = _rays6(o3d, o[plain], d[plain])
        sub_v = referee.first_hits(o64[plain], d64[plain])
        sub_c = referee.crossings(o64[plain], d64[plain])
        for query, ans, ref in (
            ("any", s.test_occlusions(rays), sub_v),
            ("all", s.list_intersections(rays), sub_c),
            ("count", s.count_intersections(rays), sub_c),
        ):
            right, k = judge_answer(query, "open3d", ans, ref)
            rows.append(dict(query=query, rays="stress", caster="open3d", right=right, judged=k))
    return rows


def _print_timing(rows, out):
    out("\nThroughput (million queries/s; float32 rays; best of the repeats):")
    keys = list(dict.fromkeys((r["query"], r["rays"]) for r in rows))  # as run
    table = []
    for q, rs in keys:
        sel = [r for r in rows if r["query"] == q and r["rays"] == rs]
        for k in sorted({r["threads"] for r in sel}):
            cell = {r["caster"]: r["mqs"] for r in sel if r["threads"] == k}
            t = cell.get("tetrace")
            b = cell.get("tetrace_bvh")
            pk = cell.get("tetrace_bvh_packets")
            oc = cell.get("tetrace_octree")
            row = [q, rs, sel[0]["n"], k, f"{t:.2f}"]
            row += ["--" if not x else f"{x:.2f}" for x in (b, pk, oc)]
            for peer in PEER_NAMES:
                p = cell.get(peer)
                row.append(
                    "--" if not p else f"{p:.2f} ({t / p:.2f}x" + (f", {b / p:.2f}x)" if b else ")")
                )
            table.append(row)
    out(
        _table(
            table,
            [
                "query",
                "rays",
                "n",
                "threads",
                "tetrace",
                "tetrace bvh",
                "bvh packets",
                "octree",
                *(f"{peer} (tetrace/it, bvh/it)" for peer in PEER_NAMES),
            ],
        )
    )
    for r in rows:
        if r["caster"] == "tetrace" and r["query"] == "contains":
            out(
                f"tetrace contains, first call on {r['threads']} thread(s): {r['first_s']:.3f} s "
                "(the first call builds the regions' parity)"
            )
            break


def _print_judged(rows, out):
    out("\nRight by the exact referee (right / judged; wrong in brackets):")
    agg = {}
    for r in rows:
        key = (r["query"], r["rays"], r["caster"])
        a = agg.setdefault(key, [0, 0])
        a[0] += r["right"]
        a[1] += r["judged"]
    table = []
    pairs = list(dict.fromkeys((k[0], k[1]) for k in agg))
    for q, rs in sorted(pairs, key=lambda x: QUERIES.index(x[0])):  # stable: as run within
        row = [q, rs]
        for c in (*TETRACE_CASTERS, *PEER_NAMES):
            a = agg.get((q, rs, c))
            row.append("--" if a is None else f"{a[0]:,}/{a[1]:,} ({a[1] - a[0]:,})")
        table.append(row)
    out(_table(table, ["query", "rays", "tetrace", "tetrace bvh", *PEER_NAMES]))
