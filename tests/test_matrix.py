"""Speed against accuracy: the weight, ``mesher="auto"`` and the benchmark matrix.

The matrix runs here on the bundled scene at a tiny resolution: the tests check that
every row, file and chart is produced and that the numbers in them are right (agreement
of exact settings, Pareto rows not dominated), never how fast anything is.

Over 500 lines on purpose: the tests of the weight, mesher="auto" and the matrix bench share
the fixtures at the top.
"""

from __future__ import annotations

import json
import re
import threading
from pathlib import Path

import numpy as np
import pytest

import tetrace
from tetrace.baselines import embree as reference
from tetrace.bench import casters, matrix
from tetrace.dev import synthetic
from tetrace.dev.camera import random_rays
from tetrace.mesh import MeshingError, Tetrahedralization, tetrahedralize
from tetrace.mesh import auto as auto_mesher
from tetrace.referee import Referee, judge
from tetrace.scene import default_scene_path

from conftest import gpu_device

PNG = b"\x89PNG\r\n\x1a\n"


def _tz(points, tets):
    points = np.asarray(points, np.float64)
    return Tetrahedralization(
        points=points,
        tets=np.asarray(tets, np.uint32),
        faces=np.zeros((0, 3), np.uint32),
        face_triangle=np.zeros(0, np.uint32),
        domain=np.array([points.min(0), points.max(0)]),
        preset="quality",
        n_input_triangles=0,
        clean=None,
        repaired=False,
        timings={},
    )


def test_weight_counts_each_shared_face_once():
    # Two tets on the unit right triangle in z=0, apexes at z=+1 and z=-1: 7 faces.
    p = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, -1)]
    tz = _tz(p, [(0, 1, 2, 3), (0, 2, 1, 4)])
    base = 0.5
    legs = 2 * 0.5  # the faces in x=0 and y=0, per apex
    slant = 0.5 * np.sqrt(3.0)  # the face through (1,0,0), (0,1,0) and the apex
    assert tz.weight() == pytest.approx(base + 2 * (legs + slant), rel=1e-12)


def test_weight_of_a_real_mesh_matches_a_direct_sum():
    tz = tetrahedralize(synthetic.cube(), "quality")
    seen = {}
    for t in tz.tets:
        for face in (
            (t[1], t[2], t[3]),
            (t[0], t[2], t[3]),
            (t[0], t[1], t[3]),
            (t[0], t[1], t[2]),
        ):
            a, b, c = tz.points[list(face)]
            seen[tuple(sorted(face))] = 0.5 * np.linalg.norm(np.cross(b - a, c - a))
    assert tz.weight() == pytest.approx(sum(seen.values()), rel=1e-9)


def test_auto_picks_the_fewest_tets_among_the_lightest(embree):
    tz = tetrahedralize(str(default_scene_path()), mesher="auto")
    auto = tz.auto
    rows = [r for r in auto["candidates"] if "tets" in r]
    assert {"quality", "quality7", "quality3"} <= {r["setting"] for r in rows}
    ok = [r for r in rows if r["accuracy"] >= auto["accuracy"]]
    w_min = min(r["weight"] for r in ok)
    near = [r for r in ok if r["weight"] <= (1 + auto["tolerance"]) * w_min]
    chosen = next(r for r in rows if r["setting"] == auto["setting"])
    assert chosen["tets"] == min(r["tets"] for r in near) == len(tz.tets)
    assert chosen["accuracy"] >= auto["accuracy"]
    quality = next(r for r in rows if r["setting"] == "quality")
    assert chosen["tets"] <= quality["tets"]
    assert tz.weight() == pytest.approx(chosen["weight"])


def test_auto_measures_a_repaired_scene(embree):
    # Two overlapping boxes intersect: the exact route repairs them, so the result is no
    # longer exact by construction and its accuracy is measured against Embree.
    v, f = synthetic.touching_boxes(offset=0.25)
    scene = tetrace.Scene.from_mesh((v, f), mesher="auto", accuracy=0.99)
    first = scene.tetrahedralization.auto["candidates"][0]
    assert first["repaired"] and 0.99 <= first["accuracy"] < 1.0 + 1e-12
    o, d = random_rays(np.array([v.min(0), v.max(0)]), 2000, seed=3)
    hits = scene.cast(o, d, precision="f64")
    assert (hits.status != tetrace.FAILED).all()


def test_auto_raises_when_no_setting_meets_the_target(monkeypatch, embree):
    monkeypatch.setattr(auto_mesher, "_exact", lambda tz: False)
    monkeypatch.setattr(auto_mesher, "AUTO_RATIOS", (5.0, 7.0))
    monkeypatch.setattr(auto_mesher, "AUTO_EPSILONS", (3e-3,))
    with pytest.raises(MeshingError, match=r"no setting reached accuracy 0.999 \(best 0.500000\)"):
        tetrahedralize(synthetic.cube(), mesher="auto", measure=lambda *a, **k: 0.5)


def test_auto_rejects_bad_targets():
    with pytest.raises(ValueError, match="accuracy must be in"):
        tetrahedralize(synthetic.cube(), mesher="auto", accuracy=1.5)
    with pytest.raises(ValueError, match="accuracy is a target for mesher='auto'"):
        tetrahedralize(synthetic.cube(), mesher="tetgen", accuracy=0.9)


def test_pareto_keeps_only_undominated_rows():
    rows = [
        dict(scene="a", ratio=r, right=a, rays=10)
        for r, a in [(1.0, 0.9), (0.5, 1.0), (0.4, 0.95), (0.8, 0.99), (0.8, 0.98)]
    ]
    rows.append(dict(scene="b", ratio=0.1, right=0.5, rays=10))
    best = matrix.pareto(rows)
    assert [(r["scene"], r["ratio"], r["right"]) for r in best] == [
        ("a", 1.0, 0.9),
        ("a", 0.8, 0.99),
        ("a", 0.5, 1.0),
        ("b", 0.1, 0.5),
    ]


#: The "all" thread count of the instrumented run: more threads than this machine may have
#: cores, and than its 768 rays fill chunks (the old cap, rays // 16384, gave embreex 1).
ALL = 3
CONFIGS = dict(
    settings=["constrained", "quality", "quality3"],
    methods=["aman2022", "robust"],
    layouts=["tet32", "tet20"],
    precisions=["f32", "f64"],
    threads=["1", "all"],
)


@pytest.fixture(scope="module")
def run(tmp_path_factory, embree):
    """One matrix run on Spot (16^2 x 3 views = 768 rays), every caster instrumented: the
    rays and thread count each one received, recorded where the bench hands them over
    (Scene.cast, EmbreeReference.intersect and the chunk queue, Open3D's cast_rays, the warp
    and mitsuba casters' cast)."""
    out_dir = tmp_path_factory.mktemp("matrix")
    calls, queues, lines = [], [], []

    def record(caster, origins, directions, threads):
        calls.append(
            dict(
                caster=caster,
                origins=np.array(origins, copy=True),
                directions=np.array(directions, copy=True),
                threads=threads,
            )
        )

    real_cast = tetrace.Scene.cast
    real_intersect = reference.EmbreeReference.intersect
    real_run_chunks = reference.run_chunks

    def cast(self, origins, directions=None, **kw):
        record("tetrace", origins, directions, kw.get("threads"))
        return real_cast(self, origins, directions, **kw)

    def intersect(
        self, origins32, directions32, tfar32=None, *, threads=None, chunk=reference.CHUNK
    ):
        record("embreex", origins32, directions32, threads)
        return real_intersect(self, origins32, directions32, tfar32, threads=threads, chunk=chunk)

    def run_chunks(n, threads, fn, chunk=reference.CHUNK):
        queues.append(dict(n=n, threads=threads, chunk=chunk))
        return real_run_chunks(n, threads, fn, chunk)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(tetrace.Scene, "cast", cast)
        mp.setattr(reference.EmbreeReference, "intersect", intersect)
        mp.setattr(reference, "run_chunks", run_chunks)
        mp.setattr(matrix, "_ncpu", lambda: ALL)
        for cls in (casters.WarpCaster, casters.MitsubaCaster):

            def peer_cast(self, origins, directions, threads, real=cls.cast):
                record(self.name, origins, directions, threads)
                return real(self, origins, directions, threads)

            mp.setattr(cls, "cast", peer_cast)
        o3d, _ = casters.open3d_module()
        if o3d is not None:

            class RecordingScene(o3d.t.geometry.RaycastingScene):
                def cast_rays(self, rays, nthreads=0):
                    r = rays.numpy()
                    record("open3d", r[:, :3], r[:, 3:], nthreads)
                    return super().cast_rays(rays, nthreads=nthreads)

            mp.setattr(o3d.t.geometry, "RaycastingScene", RecordingScene)
        res = matrix.run_matrix(
            [str(default_scene_path())],
            res=16,
            repeat=1,
            out_dir=out_dir,
            out=lines.append,
            **CONFIGS,
        )
    return dict(res=res, rows=res["rows"], calls=calls, queues=queues, lines=lines, out_dir=out_dir)


def _threads(k):
    return f"{k} thread" + ("" if k == 1 else "s")


def test_matrix_writes_rows_files_and_charts(run):
    res, rows, tmp_path = run["res"], run["rows"], run["out_dir"]
    ours = [r for r in rows if r["caster"] == "tetrace"]
    assert len(ours) == 3 * 2 * 2 * 2 * 2
    assert [r["caster"] for r in rows if r["caster"] != "tetrace"][:2] == ["embreex"] * 2
    embreex_rate = {r["threads"]: r["mrays"] for r in rows if r["caster"] == "embreex"}
    assert set(embreex_rate) == {1, ALL}
    for r in rows:
        assert r["ratio"] == pytest.approx(r["mrays"] / embreex_rate[r["threads"]], rel=1e-12)
        # By definition: the same triangle (or a miss) is the same outcome, and in the same
        # plane; "right" is one of the referee's five exclusive judgements of each ray.
        assert r["agreement"] <= r["plane_agreement"] and r["agreement"] <= r["hit_agreement"]
        judged = r["right"] * r["rays"] + r["failed"] + r["leaked"] + r["late"] + r["wrong"]
        assert judged == pytest.approx(r["rays"], abs=1e-9)
    for r in rows:
        if r["caster"] == "embreex":  # its own reference: every agreement is 1 by definition
            assert r["agreement"] == r["plane_agreement"] == r["hit_agreement"] == 1.0
            assert r["p50_dt"] == r["p99_dt"] == 0.0
    for r in ours:
        # Bound 0: exact TetGen settings put the surface on the input triangles, so every
        # ray has the referee's answer; robust is exact by construction
        # (docs/robust_walk.md), and aman2022 must be right on these rays too (the old
        # bound, plane agreement >= 0.999 with Embree on 768 rays, already allowed 0).
        assert r["right"] == 1.0, r
        assert r["failed"] == r["leaked"] == r["late"] == r["wrong"] == 0, r
        assert r["tets"] > 0 and r["weight"] > 0 and r["mem_mb"] > 0 and r["tets_per_ray"] > 0
    tets = {r["setting"]: r["tets"] for r in ours}
    # With triangles whole (TetGen -Y) refinement adds points off the surface only; a
    # tighter bound adds more, and the presets build different meshes.
    assert tets["quality"] < tets["quality3"] and tets["constrained"] != tets["quality"]
    for name in ("speed_accuracy", "build", "weight_time"):
        assert res["charts"][name].read_bytes()[:8] == PNG
    assert len(json.loads((tmp_path / "matrix.json").read_text())) == len(rows)
    csv_lines = (tmp_path / "matrix.csv").read_text().strip().splitlines()
    assert len(csv_lines) == len(rows) + 1 and csv_lines[0].startswith("scene,")
    assert {"label", "schedule", "right", "leaked", "late", "wrong"} <= set(csv_lines[0].split(","))
    for r in res["pareto"]:
        assert not any(o["ratio"] > r["ratio"] and o["right"] > r["right"] for o in ours)
    # The weight against tets per ray: the reported Pearson r is that of the rows (1 thread,
    # the first method/layout/precision, relative to quality), and sorting the settings by
    # weight sorts them by tets per ray (Crofton: a line crosses faces in proportion to
    # their area; the ordering, not a threshold on r).
    first = [
        r
        for r in ours
        if r["threads"] == 1
        and (r["method"], r["layout"], r["precision"])
        == (ours[0]["method"], ours[0]["layout"], ours[0]["precision"])
    ]
    q = next(r for r in first if r["setting"] == "quality")
    w = [r["weight"] / q["weight"] for r in first]
    steps = [r["tets_per_ray"] / q["tets_per_ray"] for r in first]
    assert res["weight_steps_r"] == pytest.approx(np.corrcoef(w, steps)[0, 1], rel=1e-12)
    assert np.argsort(w).tolist() == np.argsort(steps).tolist()
    assert any("Pareto-best" in line for line in run["lines"])
    assert any(line.startswith("\nPeers (same rays, same threads") for line in run["lines"])
    again = matrix.report(
        json.loads((tmp_path / "matrix.json").read_text()), tmp_path / "re", out=lambda line: None
    )
    assert [r["setting"] for r in again["pareto"]] == [r["setting"] for r in res["pareto"]]


def test_matrix_gives_every_caster_the_same_rays(run):
    """Every array any caster received is the camera's float32 rays, bit for bit (float64
    walks: those values widened exactly), for every row, peers included."""
    v, _ = tetrace.mesh.load_triangles(str(default_scene_path()))
    o64, d64 = matrix.camera_rays(v, 16)
    o32, d32 = o64.astype(np.float32), d64.astype(np.float32)
    calls = run["calls"]
    expected = {"tetrace", "embreex"} | {
        name for name, (module, _) in casters.PEERS.items() if module()[0] is not None
    }
    assert {c["caster"] for c in calls} == expected
    for c in calls:
        for got, want in ((c["origins"], o32), (c["directions"], d32)):
            assert got.shape == want.shape and got.dtype in (np.float32, np.float64), c["caster"]
            if got.dtype == np.float32:
                assert got.tobytes() == want.tobytes(), c["caster"]
            else:
                assert got.tobytes() == want.astype(np.float64).tobytes(), c["caster"]
    # Both precisions of tetrace were given the rays, so the widened ones were checked too.
    assert {c["origins"].dtype for c in calls if c["caster"] == "tetrace"} == {
        np.dtype(np.float32),
        np.dtype(np.float64),
    }


def test_matrix_gives_every_caster_the_same_threads_and_timing(run):
    """Each caster got 1 and ALL threads (no cap), dynamic chunks, and for every row one
    untimed warm-up and `repeat` timed casts, as many as every other row."""
    rows, calls = run["rows"], run["calls"]
    names = {c["caster"] for c in calls}
    for name in names:
        assert {c["threads"] for c in calls if c["caster"] == name} == {1, ALL}, name
        per_row = [r for r in rows if r["caster"] == name]
        assert len([c for c in calls if c["caster"] == name]) == 2 * len(per_row), name
    schedules = {
        "tetrace": "{}: rayon work stealing over 4096-ray chunks",
        "embreex": "{}: 4096-ray chunks taken from one shared queue",
        "open3d": "{}: TBB parallel_for over chunks of at most 1024 rays (cast_rays nthreads={})",
        "warp": "1 thread (asked for {1}): warp runs a CPU launch's kernel threads one after "
        "another on the calling thread",
        "mitsuba": "1 thread (asked for {1}): a Python loop over the rays holds the GIL",
        "mitsuba_llvm": "{}: Dr.Jit's LLVM thread pool (drjit.set_thread_count({}))",
    }
    for r in rows:
        assert r["threads"] in (1, ALL)
        assert r["schedule"] == schedules[r["caster"]].format(_threads(r["threads"]), r["threads"])
    # embreex's threads take chunks from one queue: ALL threads even for one chunk of rays,
    # and tetrace's chunk size (src/scene.rs) in both.
    assert {q["threads"] for q in run["queues"]} == {1, ALL}
    assert {q["chunk"] for q in run["queues"]} == {reference.CHUNK}
    cast_rs = (Path(__file__).resolve().parents[1] / "src" / "scene" / "cast.rs").read_text()
    assert f"pub const CHUNK: usize = {reference.CHUNK};" in cast_rs


def test_run_chunks_hands_out_chunks_dynamically():
    """embreex's scheduler: every chunk once, on exactly `threads` threads at once, taken
    from one queue: while one thread is stuck on the first chunk, the others cast all the
    rest (with a static split, the stuck thread's share would wait for it: a timeout)."""
    n, chunk, k = 10 * 7 + 3, 7, 3
    n_chunks = 11
    together = threading.Barrier(k, timeout=30)  # the first k chunks run at the same time
    rest_done = threading.Event()
    lock, seen = threading.Lock(), []

    def fn(a, b):
        if a < k * chunk:
            together.wait()
        if a == 0:
            assert rest_done.wait(timeout=30), "the other chunks waited for the first one"
        with lock:
            seen.append((a, b))
            if len(seen) == n_chunks - 1 and (0, chunk) not in seen:
                rest_done.set()

    reference.run_chunks(n, k, fn, chunk)
    assert sorted(seen) == [(i * chunk, min(n, (i + 1) * chunk)) for i in range(n_chunks)]
    assert seen[-1] == (0, chunk)  # the stuck chunk finished last
    order = []
    reference.run_chunks(n, 1, lambda a, b: order.append((a, b)), chunk)  # 1: in order, here
    assert order == sorted(seen)

    def boom(a, b):
        if a == 3 * chunk:
            raise RuntimeError("chunk 3")

    with pytest.raises(RuntimeError, match="chunk 3"):
        reference.run_chunks(n, k, boom, chunk)
    with pytest.raises(ValueError, match="threads and chunk must be >= 1"):
        reference.run_chunks(n, 0, boom, chunk)


def test_matrix_labels_every_caster_exactly(run):
    from importlib.metadata import version

    embree = reference.embree_version()
    assert re.fullmatch(r"\d+\.\d+\.\d+", embree), embree
    for r in run["rows"]:
        if r["caster"] == "embreex":
            assert r["label"] == (
                f"embreex {version('embreex')} (Embree {embree}): "
                f"EmbreeScene.run, rtcIntersect1 one ray per call, "
                f"RTC_SCENE_FLAG_ROBUST"
            )
        elif r["caster"] == "tetrace":
            assert r["label"] == (
                f"tetrace {tetrace.__version__}: Scene.cast(method="
                f"{r['method']}, layout={r['layout']}, precision="
                f"{r['precision']}, device=cpu)"
            )
    csv_text = (run["out_dir"] / "matrix.csv").read_text()
    assert "rtcIntersect1 one ray per call" in csv_text


def test_matrix_open3d_row(run, open3d):
    """Open3D's rows are there (one per thread count) and their numbers are those of an
    independent cast of the same rays."""
    from tetrace.hits import HIT, MISS, Hits

    rows = [r for r in run["rows"] if r["caster"] == "open3d"]
    assert sorted(r["threads"] for r in rows) == [1, ALL]
    v, f = tetrace.mesh.load_triangles(str(default_scene_path()))
    o64, d64 = matrix.camera_rays(v, 16)
    o32, d32 = o64.astype(np.float32), d64.astype(np.float32)
    scene = open3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        open3d.core.Tensor(v.astype(np.float32)), open3d.core.Tensor(f.astype(np.uint32))
    )
    out = scene.cast_rays(open3d.core.Tensor(np.hstack([o32, d32])), nthreads=1)
    t = out["t_hit"].numpy()
    hit = np.isfinite(t)
    tri = np.where(hit, out["primitive_ids"].numpy().astype(np.int64), -1)
    ref = reference.embree_scene((v, f)).cast(o32, d32, threads=1)
    hit_agree = float((hit == ref.hit).mean())
    agree = float(((hit == ref.hit) & (~hit | (tri == ref.triangle))).mean())
    uv = out["primitive_uvs"].numpy()
    with np.errstate(invalid="ignore"):
        point = o32 + np.where(hit, t, np.inf)[:, None] * d32
    hits = Hits(
        t=np.where(hit, t, np.inf).astype(np.float32),
        triangle=tri.astype(np.int32),
        u=np.where(hit, uv[:, 0], np.nan).astype(np.float32),
        v=np.where(hit, uv[:, 1], np.nan).astype(np.float32),
        point=np.where(hit[:, None], point, np.nan).astype(np.float32),
        tet=np.full(len(t), -1, np.int32),
        steps=np.zeros(len(t), np.uint32),
        status=np.where(hit, np.uint8(HIT), np.uint8(MISS)),
    )
    right = float(judge(hits, Referee(v, f).first_hits(o32, d32), "f32")["right"].mean())
    embreex_rate = {r["threads"]: r["mrays"] for r in run["rows"] if r["caster"] == "embreex"}
    for r in rows:
        assert r["label"] == (
            f"Open3D {open3d.__version__}: RaycastingScene.cast_rays (its "
            f"bundled Embree, rtcIntersect1 one ray per call, "
            f"RTC_SCENE_FLAG_ROBUST)"
        )
        assert (r["setting"], r["method"], r["precision"], r["device"]) == (
            "-",
            "bvh",
            "f32",
            "cpu",
        )
        assert r["rays"] == len(o32) and np.isfinite(r["mrays"]) and r["mrays"] > 0
        assert r["ratio"] == pytest.approx(r["mrays"] / embreex_rate[r["threads"]], rel=1e-12)
        assert r["failed"] == 0  # Open3D has no failure outcome
        assert r["hit_agreement"] == hit_agree and r["agreement"] == agree
        assert r["right"] == right
        assert 0.0 <= r["p50_dt"] <= r["p99_dt"]


#: The peers of the matrix besides embreex and Open3D, by caster name: (library, variant).
PIP_PEERS = {
    "warp": "warp-lang {}: wp.mesh_query_ray in a @wp.kernel on device cpu",
    "mitsuba": "mitsuba {} (scalar_rgb): Scene.ray_intersect_preliminary, one call per ray",
    "mitsuba_llvm": "mitsuba {} (llvm_ad_rgb): Scene.ray_intersect_preliminary, one vectorised",
}


def test_matrix_warp_and_mitsuba_rows(run, warp, mitsuba):
    """warp's and both mitsuba variants' rows are there (one per thread count), on every ray,
    with a throughput, and their agreement columns are the referee's and embreex's judgement
    of an independent cast of the same rays by the same caster."""
    v, f = tetrace.mesh.load_triangles(str(default_scene_path()))
    o64, d64 = matrix.camera_rays(v, 16)
    o32, d32 = o64.astype(np.float32), d64.astype(np.float32)
    verdict = Referee(v, f).first_hits(o32, d32)
    ref = reference.embree_scene((v, f)).cast(o32, d32, threads=1)
    embreex_rate = {r["threads"]: r["mrays"] for r in run["rows"] if r["caster"] == "embreex"}
    again = {
        "warp": casters.WarpCaster(warp, v, f),
        "mitsuba": casters.MitsubaCaster(mitsuba, v, f, "scalar_rgb"),
        "mitsuba_llvm": casters.MitsubaCaster(mitsuba, v, f, "llvm_ad_rgb"),
    }
    for name, label in PIP_PEERS.items():
        rows = [r for r in run["rows"] if r["caster"] == name]
        assert sorted(r["threads"] for r in rows) == [1, ALL], name
        caster = again[name]
        hits = caster.hits(caster.cast(o32, d32, 1), o32, d32)
        right = float(judge(hits, verdict, "f32")["right"].mean())
        hit = hits.status == tetrace.HIT
        hit_agree = float((hit == ref.hit).mean())
        agree = float(((hit == ref.hit) & (~hit | (hits.triangle == ref.triangle))).mean())
        version = warp.__version__ if name == "warp" else mitsuba.__version__
        for r in rows:
            assert r["label"].startswith(label.format(version)), r["label"]
            assert (r["setting"], r["method"], r["precision"], r["device"]) == (
                "-",
                "bvh",
                "f32",
                "cpu",
            )
            assert r["rays"] == len(o32) == 768 and np.isfinite(r["mrays"]) and r["mrays"] > 0
            assert r["ratio"] == pytest.approx(r["mrays"] / embreex_rate[r["threads"]], rel=1e-12)
            assert r["failed"] == 0  # no failure outcome
            # Judged, not only printed: every ray has one of the referee's five outcomes,
            # and the row's numbers are those of the independent cast.
            judged = r["right"] * r["rays"] + r["leaked"] + r["late"] + r["wrong"]
            assert judged == pytest.approx(r["rays"], abs=1e-9)
            assert r["right"] == right and r["hit_agreement"] == hit_agree
            assert r["agreement"] == agree
            assert 0.0 <= r["p50_dt"] <= r["p99_dt"]
    # Every peer is drawn on the speed-accuracy chart, named and labelled under it.
    peers = {r["caster"] for r in run["rows"] if r["caster"] != "tetrace"}
    assert set(PIP_PEERS) <= peers


def test_warp_and_mitsuba_hits_follow_the_hits_convention(warp, mitsuba, embree):
    """The same triangle, t and barycentrics as embreex on the same rays (a few hundred, on
    Spot): warp's (u, v) weigh p0 and p1, mitsuba's prim_uv p1 and p2 like embreex's, and
    the casters map them to Hits' (point = (1 - u - v) p0 + u p1 + v p2)."""
    v, f = tetrace.mesh.load_triangles(str(default_scene_path()))
    o64, d64 = matrix.camera_rays(v, 12)
    o, d = o64.astype(np.float32), d64.astype(np.float32)
    ref = reference.embree_scene((v, f)).cast(o, d, threads=1)
    assert ref.hit.sum() > 100
    for caster in (
        casters.WarpCaster(warp, v, f),
        casters.MitsubaCaster(mitsuba, v, f, "scalar_rgb"),
        casters.MitsubaCaster(mitsuba, v, f, "llvm_ad_rgb"),
    ):
        hits = caster.hits(caster.cast(o, d, 1), o, d)
        hit = hits.status == tetrace.HIT
        np.testing.assert_array_equal(hit, ref.hit, err_msg=caster.name)
        np.testing.assert_array_equal(hits.triangle, ref.triangle, err_msg=caster.name)
        both = hit & ref.hit
        for got, want in ((hits.t, ref.t), (hits.u, ref.u), (hits.v, ref.v)):
            np.testing.assert_allclose(got[both], want[both], atol=1e-3, err_msg=caster.name)
        p = v[f[hits.triangle[hit]]]
        u, w = hits.u[hit, None], hits.v[hit, None]
        bary = (1 - u - w) * p[:, 0] + u * p[:, 1] + w * p[:, 2]
        diagonal = np.linalg.norm(v.max(0) - v.min(0))
        assert np.abs(bary - hits.point[hit]).max() < 1e-4 * diagonal, caster.name


def test_matrix_skips_a_missing_peer_and_names_why(tmp_path, monkeypatch, embree):
    missing = {name: f"{name} not available (test)" for name in casters.PEERS}
    monkeypatch.setattr(
        matrix,
        "peer_modules",
        lambda: {name: (lambda why=why: (None, why)) for name, why in missing.items()},
    )
    lines = []
    rows = matrix.run_matrix(
        [str(default_scene_path())],
        settings=["quality"],
        methods=["aman2022"],
        layouts=["tet32"],
        precisions=["f32"],
        threads=["1"],
        res=8,
        repeat=1,
        out_dir=tmp_path,
        out=lines.append,
    )["rows"]
    assert {r["caster"] for r in rows} == {"embreex", "tetrace"}
    for name, why in missing.items():
        said = f"{casters.PEER_TITLES[name]} peer skipped: {why}"
        assert any(said in line for line in lines), said


def test_matrix_command_line(tmp_path, embree):
    code = matrix.matrix_main(
        [
            "--quick",
            "--res",
            "8",
            "--repeat",
            "1",
            "--settings",
            "quality",
            "--methods",
            "aman2022",
            "--precisions",
            "f32",
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 0
    rows = json.loads((tmp_path / "matrix.json").read_text())
    assert {r["setting"] for r in rows if r["caster"] == "tetrace"} == {"quality"}
    with pytest.raises(ValueError, match="unknown settings"):
        matrix.run_matrix(
            [],
            settings=["nope"],
            methods=[],
            layouts=[],
            precisions=[],
            threads=[],
            res=8,
            repeat=1,
            out_dir=tmp_path,
        )


def test_matrix_gpu_rows(tmp_path, embree):
    from tetrace import gpu

    gpu_device()  # fails without an adapter, unless TETRACE_SKIP_GPU=1
    rows = matrix.run_matrix(
        [str(default_scene_path())],
        settings=["quality"],
        methods=["aman2022"],
        layouts=["tet32"],
        precisions=["f32"],
        threads=["1"],
        res=16,
        repeat=1,
        out_dir=tmp_path,
        gpu=True,
        out=lambda line: None,
    )["rows"]
    rows = [r for r in rows if r.get("device") == "gpu"]
    assert {(r["method"], r["layout"]) for r in rows} == set(gpu.kernels())
    for r in rows:
        # Bound 0, as for the CPU rows of an exact setting: every kernel is right on these
        # rays (the robust kernel by construction, tests/test_gpu.py).
        assert r["right"] == 1.0 and r["failed"] == r["leaked"] == r["late"] == r["wrong"] == 0, r
        assert r["kernel_mrays"] > 0 and r["threads"] == 0
        assert r["label"] == (
            f"tetrace {tetrace.__version__}: Scene.cast(method={r['method']}, "
            f"layout={r['layout']}, precision=f32, device=gpu)"
        )


def test_accuracy_counts_nearby_hits_on_neighbouring_triangles(embree):
    # A mesher whose faces name a neighbour of the triangle they lie on (as fTetWild's did
    # before the cast learnt to pick the neighbour the ray crosses): the hits are in the
    # right place on the wrong triangle. Within HIT_DISTANCE of Embree's point they agree.
    import dataclasses

    from tetrace.baselines.embree import embree_scene
    from tetrace.hits import HIT

    v, f = tetrace.mesh.load_triangles(str(default_scene_path()))
    tz = tetrahedralize((v, f))
    offsets, ids = tetrace.mesh.neighbour_triangles(tz.clean, len(f))
    shifted = ids[offsets[tz.face_triangle]]  # the first neighbour of each named triangle
    renamed = dataclasses.replace(tz, face_triangle=shifted.astype(np.uint32))
    n = 4000
    strict, loose, anywhere = (
        tetrace.accuracy.measure_accuracy(tetrace.Scene, renamed, v, f, rays=n, hit_distance=h)
        for h in (0.0, 1e-3, 1.0)
    )
    # The same rays (measure_accuracy's: seed 0), cast here: each value is an exact count.
    o, d = random_rays(np.array([v.min(0), v.max(0)]), n, 0)
    # The walks through the two tetrahedralizations (the exact BVH reads no mesher's faces).
    true = tetrace.Scene(tz, v, f).cast(o, d, precision="f64", accel="tetwalk")
    hits = tetrace.Scene(renamed, v, f).cast(o, d, precision="f64", accel="tetwalk")
    ref = embree_scene((v, f)).cast(o, d)
    hit = hits.status == HIT
    # Renaming moves no face: the same outcomes; and it renames every hit (a triangle is
    # never its own neighbour).
    np.testing.assert_array_equal(hits.status, true.status)
    assert not (hit & (hits.triangle == true.triangle)).any()
    same = hits.status == ref.status
    named = hit & (hits.triangle == ref.triangle)
    dist = np.linalg.norm(hits.point - ref.point, axis=1) / np.linalg.norm(v.max(0) - v.min(0))
    agree = lambda h: int((same & (~hit | named | (dist <= h))).sum())
    assert (strict, loose, anywhere) == (agree(0.0) / n, agree(1e-3) / n, agree(1.0) / n)
    # The cases that tell the three apart exist (bound 0), so strict < loose < anywhere:
    # renamed hits within 1e-3 of Embree's point count only from hit_distance 1e-3 on
    # (Spot's triangles are coarse: a neighbour's plane can pass farther than that).
    near = same & hit & ~named & (dist > 0)
    assert (near & (dist <= 1e-3)).sum() > 0 and (near & (dist > 1e-3) & (dist <= 1.0)).sum() > 0
    assert strict < loose < anywhere
