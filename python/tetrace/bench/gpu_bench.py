"""``python -m tetrace.bench gpu``: the GPU cast from numpy to numpy, phase by phase (issue 34).

A machine lent with a GPU has no mesher, so it benches scenes saved as ``.tetrace`` files
(:meth:`tetrace.Scene.save`); ``--save DIR`` writes them here, where the meshers run. Per scene
and ray set (a pinhole camera and uniform random rays) it prints where the time of
``scene.cast(o, d, device="gpu")`` went, the kernel's rate from the GPU's timestamps, the rate
numpy to numpy, the host time per ray (the whole call less the kernel: issue 34's measure),
the share of rays handed back to the CPU, the exact referee's verdict on a sample, and the CPU
exact walk, the CPU default (the exact BVH) and embreex on every core of the same machine.
"""

from __future__ import annotations

import json
import os
import time

import numpy as np

from ..camera import Camera
from ..dev.camera import orbit_view, pinhole, random_rays
from ..hits import HIT
from .casters import TetraceCaster, gpu_cast_timed, timed
from .scene_bench import FOV_DEG, _table

#: What the bench prints per ray set, in order: (JSON key, column header).
COLUMNS = [
    ("scene", "scene"),
    ("rays", "rays"),
    ("n", "n"),
    ("kernel_grays_per_s", "kernel Grays/s"),
    ("mrays_per_s", "numpy→numpy Mrays/s"),
    ("host_ns_per_ray", "host ns/ray"),
    ("handed_back", "handed back"),
    ("locate_ms", "locate ms"),
    ("upload_ms", "upload ms"),
    ("kernel_ms", "kernel ms"),
    ("readback_ms", "readback ms"),
    ("finish_ms", "finish ms"),
    ("wall_ms", "wall ms"),
    ("camera_mrays_per_s", "camera= Mrays/s"),
    ("right", "referee right"),
    ("cpu_exact_mrays_per_s", "CPU exact walk Mrays/s"),
    ("cpu_default_mrays_per_s", "CPU default (exact BVH) Mrays/s"),
    ("embreex_mrays_per_s", "embreex Mrays/s"),
]


def load_scene(path, preset="quality"):
    """A ``.tetrace`` file is loaded as saved; a mesh file is meshed (needs a mesher)."""
    from ..scene import Scene, default_scene_path

    path = str(path) if path is not None else str(default_scene_path())
    if path.endswith(".tetrace"):
        return Scene.load(path), path
    return Scene.from_mesh(path, preset), path


def save_scenes(paths, out_dir, preset="quality", out=print):
    """Mesh each file and save it as ``out_dir/<stem>.tetrace`` for a machine without meshers.

    Returns
    -------
    list of str
        The files written.
    """
    os.makedirs(out_dir, exist_ok=True)
    written = []
    for path in paths or [None]:
        t0 = time.perf_counter()
        scene, path = load_scene(path, preset)
        stem = os.path.splitext(os.path.basename(path))[0]
        dest = os.path.join(out_dir, stem + ".tetrace")
        scene.save(dest)
        out(
            f"{dest}: {scene.n_tets:,} tets, {len(scene.faces):,} triangles, "
            f"{os.path.getsize(dest) / 1e6:.1f} MB ({time.perf_counter() - t0:.1f} s)"
        )
        written.append(dest)
    return written


class _CameraCaster:
    """``scene.cast(camera=cam, device="gpu")`` as :func:`~tetrace.bench.casters.timed` takes
    a caster (the rays passed in are ignored: the camera makes its own)."""

    def __init__(self, scene, cam):
        self.scene, self.cam = scene, cam

    def cast(self, origins, directions, threads):
        return self.scene.cast(camera=self.cam, device="gpu")


def bench_rays(scene, name, label, o, d, *, repeat, sample, seed, embreex, ncpu, camera=None):
    """One row: the GPU cast of rays ``o, d`` phase by phase, judged on a sample, beside the
    CPU exact walk and embreex on ``ncpu`` threads."""
    from ..dev.compare import agreement
    from ..referee import Referee

    n = len(o)
    best, host, hits, scene_upload = gpu_cast_timed(scene, o, d, repeat)
    # The referee's verdict on a sample (it is exact and slower than any caster).
    rng = np.random.default_rng(seed)
    idx = np.sort(rng.choice(n, size=min(sample, n), replace=False))
    verdict = Referee(scene.vertices, scene.faces).first_hits(
        o[idx], d[idx], hint=hits.triangle[idx]
    )
    score = agreement(hits[idx], verdict, "f64")
    rate = lambda caster: n / timed(caster, o, d, ncpu, repeat)[0] / 1e6
    cpu = rate(TetraceCaster(scene, "exact", "tet20", "f32"))  # the walk the GPU takes
    cpu_default = rate(TetraceCaster(scene, None, None, "f32"))  # the exact BVH
    emb = rate(embreex)
    cam = None
    if camera is not None:
        *view, width, height = camera
        lens = Camera.look_at(*view, fov_deg=FOV_DEG, width=width, height=height)
        cam = rate(_CameraCaster(scene, lens))
    ms = lambda k: best[k] * 1e3
    return {
        "scene": name,
        "rays": label,
        "n": n,
        "kernel_grays_per_s": (
            best["walked"] / best["kernel_min"] / 1e9 if best["kernel_min"] else None
        ),
        "mrays_per_s": n / best["wall"] / 1e6,
        "host_ns_per_ray": host * 1e9,
        "handed_back": best["deferred"] / n,
        "walked": best["walked"],
        "locate_ms": ms("locate"),
        "upload_ms": ms("upload"),
        "kernel_ms": ms("kernel"),
        "kernel_wall_ms": ms("kernel_wall"),
        "readback_ms": ms("readback"),
        "finish_ms": ms("finish"),
        "wall_ms": ms("wall"),
        "scene_upload_ms": scene_upload * 1e3,
        "camera_mrays_per_s": cam,
        "right": score.right,
        "judged": score.rays,
        "not_right": {k: getattr(score, k) for k in ("failed", "leaked", "late", "wrong")},
        "cpu_exact_mrays_per_s": cpu,
        "cpu_default_mrays_per_s": cpu_default,
        "embreex_mrays_per_s": emb,
    }


def _cell(key, value, row):
    if value is None:
        return "—"
    if key == "handed_back":
        return f"{value * 100:.3f}%"
    if key == "right":
        return f"{value:,}/{row['judged']:,}"
    if key in ("n", "rays", "scene"):
        return f"{value:,}" if isinstance(value, int) else str(value)
    if key == "host_ns_per_ray":
        return f"{value:,.0f}"
    if key == "kernel_grays_per_s":
        return f"{value:.3g}"
    return f"{value:,.1f}" if value >= 10 else f"{value:.2f}"


def run_gpu_bench(
    paths=None,
    *,
    width=1920,
    height=1440,
    n_random=1_000_000,
    sample=100_000,
    repeat=3,
    seed=0,
    preset="quality",
    json_path=None,
    out=print,
):
    """Bench the GPU cast on each scene: a ``width`` × ``height`` camera and ``n_random``
    random rays (either set is skipped when its size is 0).

    Parameters
    ----------
    paths : list of str, optional
        ``.tetrace`` files (or meshes, where a mesher is installed); default: the bundled
        scene.
    width, height : int
        Camera resolution (float32 rays from one eye).
    n_random : int
        Random rays in and around the scene's box.
    sample : int
        Rays of each set the exact referee judges.
    repeat : int
        Timed casts per measurement; the best is kept.
    seed : int
    preset : str
        Meshing preset for mesh files.
    json_path : str, optional
        Also write the rows as JSON there.

    Returns
    -------
    dict
        ``device`` (the adapter), ``threads`` and ``rows`` (one dict per scene and ray set,
        keys as :data:`COLUMNS` plus details).
    """
    from .. import gpu
    from ..baselines.embree import cpu_count
    from .casters import EmbreexCaster

    dev = gpu.device()  # GpuError naming what was looked for when there is no adapter
    ncpu = cpu_count()
    out(
        f"GPU: {dev['name']} ({dev['backend']}, {dev['device_type']}); "
        f"CPU exact walk and embreex on {ncpu} threads; referee on {sample:,} rays per set"
    )
    rows = []
    for path in paths or [None]:
        scene, path = load_scene(path, preset)
        name = os.path.basename(path)
        v, f = scene.vertices, scene.faces
        bounds = np.array([v.min(0), v.max(0)])
        embreex = EmbreexCaster(v, f)
        sets = []
        if width > 0 and height > 0:
            view = orbit_view(bounds, distance=1.6)
            o, d = pinhole(*view, fov_deg=FOV_DEG, width=width, height=height)
            sets.append((f"camera {width}×{height}", o, d, (*view, width, height)))
        if n_random > 0:
            o, d = random_rays(bounds, n_random, seed, dtype=np.float32)
            sets.append((f"random {n_random:,}", o, d, None))
        for label, o, d, camera in sets:
            row = bench_rays(
                scene,
                name,
                label,
                o,
                d,
                repeat=repeat,
                sample=sample,
                seed=seed,
                embreex=embreex,
                ncpu=ncpu,
                camera=camera,
            )
            rows.append(row)
            out(
                f"{name}, {label}: host {row['host_ns_per_ray']:,.0f} ns/ray, "
                f"{row['mrays_per_s']:,.1f} Mrays/s numpy to numpy"
            )
    out("")
    out(
        "kernel Grays/s = rays walked on the GPU / kernel seconds (timestamps where the device "
        "has them); host ns/ray = (whole call − kernel) / rays, best of the timed casts; "
        "handed back = rays the GPU handed to the CPU exact walk before a face; camera= = "
        "scene.cast(camera=..., device='gpu') (directions made by the camera kernel on the "
        "device; the host also makes them, for the rays handed back)"
    )
    out(
        _table(
            [[_cell(k, r[k], r) for k, _ in COLUMNS] for r in rows],
            [h for _, h in COLUMNS],
        )
    )
    results = {"device": dev, "threads": ncpu, "rows": rows}
    if json_path:
        with open(json_path, "w") as fh:
            json.dump(results, fh, indent=2, default=str)
    return results


#: Columns of the stress-family table (:func:`run_gpu_stress`).
STRESS_COLUMNS = [
    ("family", "family"),
    ("rays", "rays"),
    ("kernel", "kernel"),
    ("walked", "walked on the GPU"),
    ("finished", "finished on the GPU"),
    ("handed_back", "handed back"),
    ("differ", "columns ≠ CPU exact walk"),
    ("right", "referee right"),
    ("others", "other queries ≠ CPU"),
]


def _differing(a, b, fields):
    """The names of ``fields`` whose arrays differ between ``a`` and ``b`` (NaNs equal)."""
    return [f for f in fields if not np.array_equal(getattr(a, f), getattr(b, f), equal_nan=True)]


def _other_queries_differ(scene, o, d, ranges, got, cpu):
    """The GPU's other queries on a stress family's rays, each against the CPU exact walk's
    (``accel="tetwalk"``, float32): ``occluded`` (and against ``got``'s hits, which the
    referee judged: a ray is occluded exactly when its closest hit lies in range),
    ``count_intersections`` and ``intersections`` (every column and the counts), mirror
    bounces from ``got``'s hits (``start=hits``: closest hit and ``occluded``), and
    ``contains`` of the origins where the surface is closed (parity). Returns the names of
    those that differ."""
    cpu_kw = dict(precision="f32", accel="tetwalk")
    differ = []
    occ, occ_status = scene.occluded(o, d, device="gpu", return_status=True, **ranges)
    want = scene.occluded(o, d, return_status=True, **ranges, **cpu_kw)
    if not (np.array_equal(occ_status, want[1]) and np.array_equal(occ, got.status == HIT)):
        differ.append("occluded")
    lists = scene.intersections(o, d, device="gpu", **ranges)
    want = scene.intersections(o, d, **ranges, **cpu_kw)
    if _differing(lists, want, ("offsets", "ray", "t", "triangle", "u", "v", "point", "status")):
        differ.append("intersections")
    count, status = scene.count_intersections(o, d, device="gpu", return_status=True, **ranges)
    if not (np.array_equal(count, np.diff(want.offsets)) and np.array_equal(status, want.status)):
        differ.append("count_intersections")
    hit = got.status == HIT
    n = np.nan_to_num(got.normal)
    bounce = np.where(hit[:, None], d - 2 * np.sum(d * n, axis=-1, keepdims=True) * n, 1)
    bounce = bounce.astype(np.float32)
    on_gpu = scene.cast(start=got, directions=bounce, device="gpu")
    on_cpu = scene.cast(start=cpu, directions=bounce, **cpu_kw)
    if _differing(on_gpu, on_cpu, ("status", "triangle", "t", "u", "v", "point")):
        differ.append("start=hits cast")
    if not np.array_equal(
        scene.occluded(start=got, directions=bounce, device="gpu"),
        scene.occluded(start=cpu, directions=bounce, **cpu_kw),
    ):
        differ.append("start=hits occluded")
    if scene.is_closed and not np.array_equal(
        scene.contains(o, device="gpu"), scene.contains(o.astype(np.float64), mode="parity")
    ):
        differ.append("contains")
    return differ


def run_gpu_stress(n_per_family=2_000, seed=0, families=None, out=print):
    """The exact default on the GPU on each stress family's certified float32 rays (the
    families that need no shared scene, unless named): where each ray was answered (begun on
    the device by the shared- or own-origin kernel, finished there, or handed back to the CPU
    exact walk), whether every column equals the CPU exact walk's, and the referee's count
    of right rays. Needs a mesher (each family's scene is built here).

    Returns
    -------
    list of dict
        One row per family, keys as :data:`STRESS_COLUMNS` (``differ`` lists the columns
        that differ; ``right`` counts the rays the referee finds right).
    """
    from ..dev.compare import agreement
    from ..dev.stress import FAMILIES, SHARED_SCENES, build_scene, cases

    cols = ("status", "triangle", "t", "u", "v", "point", "tet", "steps")
    if families is None:
        families = [f for f in FAMILIES if f not in SHARED_SCENES]
    rows = []
    for case in cases(n_per_family, seed, families):
        scene = build_scene(case)
        o, d = case.rays("f32")
        ranges = dict(tmin=case.tmin, tmax=case.tmax)
        got = scene.cast(o, d, device="gpu", **ranges)
        cpu = scene.cast(o, d, precision="f32", accel="tetwalk", **ranges)
        tm = got.timings
        kernel = (
            "shared origin"
            if tm["shared_origin"]
            else "own origins"
            if tm["own_origins"]
            else "host begins"
        )
        row = dict(
            family=case.family,
            rays=len(d),
            kernel=kernel,
            walked=tm["walked"],
            finished=tm["finished"],
            handed_back=tm["deferred"],
            differ=_differing(got, cpu, cols),
            right=agreement(got, case.verdicts["f32"], "f32").right,
            others=_other_queries_differ(scene, o, d, ranges, got, cpu),
        )
        rows.append(row)
    out(
        "stress families on the GPU, exact default, float32 rays as certified: walked = rays "
        "the device walked (begun there, or by the host on the resumed kernel); finished = "
        "hits it finished; handed back = rays the CPU exact walk took over (or began)"
    )

    def cell(k, r):
        if k == "handed_back":
            return f"{r[k]:,} ({r[k] / max(r['rays'], 1):.1%})"
        if k in ("differ", "others"):
            return ", ".join(r[k]) or "none"
        return f"{r[k]:,}" if isinstance(r[k], int) else str(r[k])

    out(
        _table(
            [[cell(k, r) for k, _ in STRESS_COLUMNS] for r in rows], [h for _, h in STRESS_COLUMNS]
        )
    )
    return rows
