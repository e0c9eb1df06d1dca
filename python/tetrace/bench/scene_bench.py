"""The full-scene benchmark of the foundation: camera rays, tetrace against embreex and the
peers that install with pip (Open3D, warp-lang, mitsuba: :data:`tetrace.bench.casters.PEERS`)."""

from __future__ import annotations

import json
import os

import numpy as np

from ..dev.camera import orbit_view, pinhole, random_rays
from ..dev.compare import agreement
from ..scene import LAYOUT_BYTES, Scene, default_scene_path, simd_levels

#: Vertical field of view of the bench's pinhole camera, in degrees.
FOV_DEG = 40.0


def configurations(methods, layouts, precisions, threads):
    """Every (method, layout, precision, threads) of a bench run, but tet80 in float64
    (its records hold float32 coordinates: there is no such walk); a method that names an
    accelerator (``reshetov_bvh``) runs once, with layout ``"-"``."""
    from .casters import is_accel

    for method in methods:
        for layout in ["-"] if is_accel(method) else layouts:
            for prec in precisions:
                if layout == "tet80" and prec == "f64":
                    continue
                for label in threads:
                    yield method, layout, prec, label


class _Judge:
    """Scores casts of one set of rays against the exact referee (``docs/referee.md``); the
    verdict is computed once, on the first cast's triangles as a hint (it only speeds up the
    search: the verdict does not depend on it)."""

    def __init__(self, v, f, o, d):
        from ..referee import Referee

        self.referee, self.o, self.d, self.verdict = Referee(v, f), o, d, None

    def __call__(self, hits, arithmetic="f64"):
        if self.verdict is None:
            self.verdict = self.referee.first_hits(self.o, self.d, hint=hits.triangle)
        return agreement(hits, self.verdict, arithmetic)


def _table(rows, header):
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    line = lambda r: "| " + " | ".join(str(c).rjust(w) for c, w in zip(r, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return "\n".join([line(header), sep] + [line(r) for r in rows])


def _gpu_runs(scene, o32, d32, judge, methods, layouts, repeat, results):
    """GPU rows of the bench table, and the last kernel's hits."""
    from .. import gpu
    from .casters import gpu_cast_timed

    kernels = gpu.kernels()
    if methods not in (["all"], "all") and methods:
        kernels = [k for k in kernels if k[0] in methods]
    if layouts not in (["all"], "all") and layouts:
        kernels = [k for k in kernels if k[1] in layouts]
    if not methods and not layouts:
        kernels = [gpu.DEFAULT_KERNEL]
    results["gpu_device"] = gpu.device()
    results["gpu_runs"] = []
    rows, hits = [], None
    n = len(o32)
    for method, layout in kernels:
        best, host, hits, scene_upload = gpu_cast_timed(
            scene, o32, d32, repeat, method=method, layout=layout
        )
        a = judge(hits)
        kernel_rate = best["walked"] / best["kernel_min"] / 1e6
        e2e = n / best["wall"] / 1e6
        rows.append(
            [
                method,
                layout,
                f"{kernel_rate:.2f}",
                f"{e2e:.2f}",
                f"{host * 1e9:,.0f}",
                f"{best['deferred'] / n * 100:.3f}%",
                f"{best['kernel']:.3f}",
                f"{best['upload']:.3f}",
                f"{best['readback']:.3f}",
                f"{best['locate']:.3f}",
                f"{best['finish']:.3f}",
                f"{scene_upload:.3f}",
                f"{hits.steps.mean():.1f}",
                f"{a.fraction * 100:.3f}%",
            ]
        )
        results["runs"].append(
            {
                "caster": "tetrace-gpu",
                "method": method,
                "layout": layout,
                "precision": "f32",
                "device": results["gpu_device"]["name"],
                "kernel_mrays_per_s": kernel_rate,
                "mrays_per_s": e2e,
                "host_ns_per_ray": host * 1e9,
                "handed_back": best["deferred"] / n,
                "seconds": best,
                "scene_upload_seconds": scene_upload,
                "tets_per_ray": float(hits.steps.mean()),
                "right": a.fraction,
                "failed": a.failed,
                "leaked": a.leaked,
                "late": a.late,
                "wrong": a.wrong,
            }
        )
    return rows, hits


def run_scene_bench(
    path=None,
    *,
    preset="quality",
    width=1024,
    height=1024,
    repeat=3,
    distance=1.6,
    azimuth=30.0,
    elevation=25.0,
    image=None,
    json_path=None,
    methods=None,
    layouts=None,
    precisions=("f32", "f64"),
    orders=("hilbert",),
    threads=("1", "all"),
    devices=("cpu",),
    rays="camera",
    out=print,
):
    """Build a scene, cast a pinhole camera with tetrace, embreex and the peers that import
    (:func:`tetrace.bench.casters.optional_peers`; the others are named with the reason),
    print one report.

    Parameters
    ----------
    path : str, optional
        Mesh file; None uses the bundled scene.
    preset : str
        Meshing preset passed to :meth:`tetrace.Scene.from_mesh`.
    width, height : int
        Camera resolution.
    repeat : int
        Timed repetitions per configuration; the best time is reported.
    distance : float
        Camera distance from the scene centre in bounding radii.
    azimuth, elevation : float
        Camera direction from the scene centre in degrees (:func:`tetrace.dev.camera.orbit_view`;
        the defaults are the first of :func:`~tetrace.dev.camera.orbit_views`).
    image : str, optional
        Write a shaded PNG of tetrace's float32 hits there.
    json_path : str, optional
        Write the results as JSON there.
    methods, layouts : list of str, optional
        Exit methods and layouts to run (default: the defaults; ``["all"]``: every one).
        Pairs that cannot run (tet80 in float64) are skipped.
    precisions : sequence of {"f32", "f64"}
    orders : sequence of {"hilbert", "mesher"}
        Point/tet order: Hilbert within regions (default) or TetGen's own.
    threads : sequence of {"1", "all"}
    devices : sequence of {"cpu", "gpu"}
        ``"gpu"`` also casts with each GPU kernel that fits ``methods``/``layouts`` (default:
        the default kernel; ``"all"``: every kernel) and reports kernel Mrays/s (rays the GPU
        walked per second of kernel time) apart from ray upload, readback, the CPU's start
        location and hit finishing, and the one-time scene upload.
    rays : {"camera", "random"}
        ``"camera"``: the pinhole camera's ``width x height`` rays, in image order;
        ``"random"``: as many rays with origins uniform in the scene's box grown by a quarter
        on each side and directions uniform on the sphere (seed 0).
    out : callable
        Where lines go (print by default).

    Returns
    -------
    dict
        Everything printed, as numbers.
    """
    from .. import _native
    from ..baselines.embree import cpu_count
    from ..scene import layouts as all_layouts
    from ..scene import methods as all_methods
    from .casters import (
        EmbreexCaster,
        TetraceCaster,
        is_accel,
        optional_peers,
        rays_for,
        timed_in_turn,
    )

    if rays not in ("camera", "random"):
        raise ValueError(f"rays must be 'camera' or 'random', got {rays!r}")

    methods_arg, layouts_arg = methods, layouts
    methods = (
        all_methods() + [a for a in _native.accels() if a != "tetwalk"]
        if methods in (["all"], "all")
        # By default the exact walk (the method of the papers' tables) and the CPU default,
        # the exact BVH.
        else (methods or [_native.DEFAULT_METHOD, "exact_bvh"])
    )
    layouts = (
        all_layouts() if layouts in (["all"], "all") else (layouts or [_native.DEFAULT_LAYOUT])
    )
    path = str(path) if path is not None else str(default_scene_path())
    name = os.path.basename(path)
    # A file Scene.save wrote (".tetrace") is loaded, not meshed again: what a machine
    # without the meshers (a GPU box) benches.
    # The tetrahedralization is meshed only when something walks tets: an accelerator's
    # rows (the exact BVH) need none, and TetGen takes minutes on some scenes.
    walks = (
        any(m == "tetwalk" or not is_accel(m) for m in methods)
        or "gpu" in devices
        or "mesher" in orders
    )
    scene = (
        Scene.load(path)
        if path.endswith(".tetrace")
        else Scene.from_mesh(path, preset, lazy=not walks)
    )
    scenes = {"hilbert": scene}
    if "mesher" in orders:
        scenes["mesher"] = Scene(
            scene.tetrahedralization, scene.vertices, scene.faces, hilbert=False
        )
    bt = scene.build_times
    v, f = scene.vertices, scene.faces
    bounds = np.array([v.min(0), v.max(0)])
    if rays == "camera":
        eye, target, up = orbit_view(bounds, azimuth, elevation, distance)
        o64, d64 = pinhole(
            eye, target, up, fov_deg=FOV_DEG, width=width, height=height, dtype=np.float64
        )
    else:
        o64, d64 = random_rays(bounds, width * height, seed=0, dtype=np.float64)
    n = len(o64)
    # Every caster gets these float32 rays (float64 walks: the same values, widened exactly).
    o32, d32 = o64.astype(np.float32), d64.astype(np.float32)
    ncpu = cpu_count()
    thread_counts = {"1": 1, "all": ncpu}
    embreex = EmbreexCaster(v, f)
    others, skipped = optional_peers(v, f)
    peers = [embreex, *others]

    results = {
        "scene": name,
        "preset": preset,
        "rays": n,
        "triangles": int(len(f)),
        "rays_kind": rays,
        "tets": scene.n_tets if scene.has_ct else None,
        "points": scene.n_points if scene.has_ct else None,
        "build_seconds": {k: float(x) for k, x in bt.items()},
        "embree_build_seconds": float(embreex.build_seconds),
        "runs": [],
        "peers_skipped": list(skipped.values()),
    }
    rows = []
    embree_rate = {}
    judge = _Judge(v, f, o32, d32)
    # Every cast is timed in turn, round by round (timed_in_turn), so that each ratio to
    # embreex compares casts made moments apart; the rows are then read in this order.
    peer_runs = [(peer, label) for peer in peers for label in threads]
    tetrace_runs = [
        (order, TetraceCaster(scenes[order], method, layout, prec), prec, label)
        for order in (orders if "cpu" in devices else ())
        for method, layout, prec, label in configurations(methods, layouts, precisions, threads)
    ]
    # The image's hits: the first float32 tetrace run's; every other run's are judged as its
    # last cast returns and dropped (a bench of every configuration holds hundreds of them).
    image_run = next(
        (len(peer_runs) + j for j, run in enumerate(tetrace_runs) if run[2] == "f32"), None
    )

    def digest(j, raw):
        if j < len(peer_runs):
            peer = peer_runs[j][0]
            return judge(peer.hits(raw, o32, d32), peer.arithmetic), None
        caster = tetrace_runs[j - len(peer_runs)][1]
        kept = raw if j == image_run else None
        return judge(raw, caster.arithmetic), (float(raw.steps.mean()), kept)

    timings = iter(
        timed_in_turn(
            [(peer, o32, d32, thread_counts[label]) for peer, label in peer_runs]
            + [
                (caster, *rays_for(prec, o32, d32), thread_counts[label])
                for _, caster, prec, label in tetrace_runs
            ],
            repeat,
            digest=digest,
        )
    )
    for peer, label in peer_runs:
        k = thread_counts[label]
        te, (a, _) = next(timings)
        rate = n / te / 1e6
        if peer is embreex:
            embree_rate[label] = rate
        shown = "1" if k == 1 else f"all ({ncpu})"
        rows.append(
            [
                peer.name,
                "bvh",
                "-",
                "f32",
                "-",
                shown,
                f"{rate:.2f}",
                f"{rate / embree_rate[label]:.2f}",
                "-",
                "-",
                f"{a.fraction * 100:.3f}%",
            ]
        )
        results["runs"].append(
            {
                "caster": peer.name,
                "label": peer.label,
                "schedule": peer.schedule(k),
                "precision": "f32",
                "threads": k,
                "mrays_per_s": rate,
                "ratio_to_embree": rate / embree_rate[label],
                "right": a.fraction,
                "leaked": a.leaked,
                "late": a.late,
                "wrong": a.wrong,
            }
        )
    last32 = None
    for order, caster, prec, label in tetrace_runs:
        method, layout = caster.method, caster.layout
        k = thread_counts[label]
        tt, (a, (steps, hits)) = next(timings)
        rate = n / tt / 1e6
        shown = "1" if k == 1 else f"all ({ncpu})"
        rows.append(
            [
                "tetrace",
                method,
                layout,
                prec,
                order,
                shown,
                f"{rate:.2f}",
                f"{rate / embree_rate[label]:.2f}",
                f"{steps:.1f}",
                LAYOUT_BYTES.get(layout, "-"),
                f"{a.fraction * 100:.3f}%",
            ]
        )
        results["runs"].append(
            {
                "caster": "tetrace",
                "label": caster.label,
                "schedule": caster.schedule(k),
                "method": method,
                "layout": layout,
                "precision": prec,
                "order": order,
                "threads": k,
                "mrays_per_s": rate,
                "ratio_to_embree": rate / embree_rate[label],
                "tets_per_ray": steps,
                "bytes_per_tet": LAYOUT_BYTES.get(layout),
                "right": a.fraction,
                "failed": a.failed,
                "leaked": a.leaked,
                "late": a.late,
                "wrong": a.wrong,
                "max_t_ulps": a.max_t_ulps,
            }
        )
        if hits is not None:  # the image's run (image_run)
            last32 = hits

    gpu_rows = []
    if "gpu" in devices:
        gpu_rows, gpu_hits = _gpu_runs(
            scene, o32, d32, judge, methods_arg, layouts_arg, repeat, results
        )
        last32 = gpu_hits if last32 is None else last32

    hit_frac = float(judge.verdict.hit.mean())  # the exact share, not a caster's
    out(
        f"tetrace bench: {name} ({len(f):,} triangles), preset {preset!r}, "
        + (
            f"{width}x{height} pinhole camera"
            if rays == "camera"
            else f"{width * height:,} random rays (origins in the grown box, any direction)"
        )
        + f", {hit_frac * 100:.1f}% of rays hit, best of {repeat}"
    )
    out(
        f"build: tetgen {bt.get('tetgen', 0):.2f} s (clean {bt.get('clean', 0):.2f} s, "
        f"repair {bt.get('repair', 0):.2f} s), rust construction {bt['rust']:.2f} s; "
        f"embreex BVH {embreex.build_seconds:.2f} s"
    )
    mem = scene.memory()
    results["memory"] = mem
    out(
        (
            f"structure: {scene.n_tets:,} tets, {scene.n_points:,} points; memory MB: "
            if scene.has_ct
            else "structure: no tetrahedralization (nothing benched walks tets); memory MB: "
        )
        + ", ".join(f"{k} {b / 1e6:.1f}" for k, b in mem.items())
    )
    out(
        "peers: "
        + "; ".join(f"{p.name} = {p.label}" for p in peers)
        + "".join(f"; skipped: {w}" for w in results["peers_skipped"])
    )
    ours = TetraceCaster(scene, methods[0], layouts[0])
    levels, simd = simd_levels()
    results["simd"] = simd
    out(f"tetrace SIMD level: {simd} (this CPU runs {', '.join(levels)}; TETRACE_SIMD caps it)")
    out(
        "every caster: the same float32 rays, an untimed warm-up, then rounds that cast each "
        "configuration once in turn, the best of its casts; "
        "at 'all': " + "; ".join(f"{c.name} on {c.schedule(ncpu)}" for c in [ours] + peers)
    )
    out(
        _table(
            rows,
            [
                "caster",
                "method",
                "layout",
                "precision",
                "order",
                "threads",
                "Mrays/s",
                "x embreex",
                "tets/ray",
                "bytes/tet",
                "right (referee)",
            ],
        )
    )
    if gpu_rows:
        dev = results["gpu_device"]
        out(
            f"GPU: {dev['name']} ({dev['backend']}, {dev['device_type']}); kernel Mrays/s = rays "
            f"walked on the GPU / kernel seconds (GPU timestamps where the device has them); "
            f"end-to-end includes the CPU's start location and hit finishing; host ns/ray = "
            f"(whole call - kernel) / rays, best run; handed back = rays the kernel left to the "
            f"CPU walk before a face; seconds are the best run's"
        )
        out(
            _table(
                gpu_rows,
                [
                    "method",
                    "layout",
                    "kernel Mrays/s",
                    "end-to-end Mrays/s",
                    "host ns/ray",
                    "handed back",
                    "kernel s",
                    "upload s",
                    "readback s",
                    "locate s",
                    "finish s",
                    "scene upload s",
                    "tets/ray",
                    "right (referee)",
                ],
            )
        )
    if image and last32 is not None and rays == "camera":
        from ..dev.image import lambert, save_png

        save_png(image, lambert(last32, d32, v, f, width, height), cmap="gray", vmin=0, vmax=1)
        out(f"image: {image}")
    if json_path:
        with open(json_path, "w") as fh:
            json.dump(results, fh, indent=2)
    return results
