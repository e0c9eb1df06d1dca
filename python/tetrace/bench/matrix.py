"""Speed against accuracy: ``python -m tetrace.bench matrix``.

Runs scenes x mesher settings x methods x layouts x precisions x threads (x GPU kernels
with ``--gpu``) on the same camera rays (three orbit views), with embreex and, when
installed, Open3D's ``RaycastingScene``, warp-lang's ``wp.mesh_query_ray`` (CPU) and mitsuba's
``ray_intersect_preliminary`` (``scalar_rgb`` and ``llvm_ad_rgb``) as peers timed in the same
run. Every caster gets the
same float32 rays (widened exactly for float64 walks), the same thread count with dynamic
chunks, one untimed warm-up and the best of ``repeat`` (:mod:`tetrace.bench.casters`). It
writes:

* ``matrix.csv`` and ``matrix.json``: one row per (scene, setting, caster, method, layout,
  precision, threads, device): ``label`` (exactly what the caster is: library, version,
  call, flags) and ``schedule`` (threads and chunks); Mrays/s and the ratio to embreex at
  the same thread count; agreement with embreex on the input mesh (same outcome and
  triangle; "plane": or a triangle in the same plane at the hit point; "hit": the same
  hit/miss outcome), p50/p99 |dt| over the diagonal on every ray both hit (the position
  error), FAILED rays; the exact referee's judgement (:mod:`tetrace.referee`): the
  fraction of rays ``right`` and the counts ``leaked``, ``late`` and ``wrong``; the
  build (mesher and Rust seconds, tets, points, weight, memory per part, and for
  fTetWild how far its surface lies from the input over the diagonal) and tets per ray;
* ``speed_accuracy.png``: throughput (x embreex) against disagreement, per scene;
* ``build.png``: tets, weight, mesher seconds and memory per setting and scene;
* ``weight_time.png``: time per ray against weight across settings (Lagae & Dutre's
  heuristic), both relative to the ``quality`` preset of the same scene;

and prints the peers (label, schedule, speed, referee's judgement) and the table of
Pareto-best settings per scene (no other row is both faster and more accurate). ``--quick``
runs the bundled scene with a few settings in a few minutes.

Over 500 lines on purpose: the speed-accuracy matrix is one command (settings grid, runs,
table, Pareto summary, CLI) whose parts only it uses.
"""

from __future__ import annotations

import argparse
import csv
import json
import textwrap
import time
from pathlib import Path

import numpy as np

from ..dev.camera import orbit_views, pinhole
from ..dev.compare import compare, same_plane
from ..hits import FAILED, HIT
from .casters import (
    PEER_TITLES,
    PEERS,
    EmbreexCaster,
    TetraceCaster,
    is_accel,
    optional_peers,
    rays_for,
    structure_bytes,
    timed,
)
from .scene_bench import _table, configurations

#: Mesher settings by name: keyword arguments of :meth:`tetrace.Scene.from_mesh`.
SETTINGS = {
    "constrained": dict(mesher="tetgen", preset="constrained"),
    "quality10": dict(mesher="tetgen", preset="quality10"),
    "quality": dict(mesher="tetgen", preset="quality"),
    "quality3": dict(mesher="tetgen", preset="quality3"),
    "quality1.5": dict(mesher="tetgen", preset="quality1.5"),
    "graded": dict(mesher="tetgen", preset="graded"),
    "ftetwild3e-3": dict(mesher="ftetwild", epsilon=3e-3),
    "ftetwild1e-3": dict(mesher="ftetwild", epsilon=1e-3),
    "auto": dict(mesher="auto"),
}
#: The full run's shared scenes (the bundled Spot is always first).
FULL_SCENES = ("cornell_box.obj", "teapot.obj", "bunny.obj", "armadillo.obj", "torus_knots_27.obj")
FULL = dict(
    settings=list(SETTINGS),
    methods=[
        "lagae2008_plane",
        "maria2017",
        "aman2022",
        "robust",
        "reshetov_bvh",
        "reshetov_bvh_packets",
        "portalez_octree",
    ],
    layouts=["tet32", "tet20"],
    precisions=["f32", "f64"],
    threads=["1", "all"],
    res=256,
    repeat=3,
)
QUICK = dict(
    settings=["constrained", "quality", "quality3", "graded", "ftetwild3e-3", "auto"],
    methods=["maria2017", "aman2022", "robust"],
    layouts=["tet32", "tet20"],
    precisions=["f32", "f64"],
    threads=["1"],
    res=96,
    repeat=2,
)


def _ncpu():
    from ..baselines.embree import cpu_count

    return cpu_count()


def camera_rays(vertices, res):
    """Three orbit views of the scene at ``res`` x ``res``, float64, concatenated."""
    v = np.asarray(vertices, np.float64)
    views = orbit_views(np.array([v.min(0), v.max(0)]), n=3, distance=1.6)
    rays = [
        pinhole(e, t, u, fov_deg=40.0, width=res, height=res, dtype=np.float64) for e, t, u in views
    ]
    return np.concatenate([r[0] for r in rays]), np.concatenate([r[1] for r in rays])


def hardware_gpu():
    """Whether wgpu finds an adapter that is not a CPU emulation (lavapipe, llvmpipe)."""
    try:
        from .. import gpu

        return any(a["device_type"] != "Cpu" and a["compute"] for a in gpu.info())
    except Exception:  # no wgpu backend at all: no GPU rows
        return False


def peer_modules():
    """The module getters of the peers besides embreex, by caster name
    (:data:`tetrace.bench.casters.PEERS`): each returns the module, or None with the reason it
    cannot run."""
    return {name: module for name, (module, _) in PEERS.items()}


def _accuracy(hits, ref, verdict, arithmetic, v, f, diagonal, d):
    """Accuracy columns of one row: against embreex's hits and against the exact referee."""
    from ..referee import judge

    a = compare(hits, ref, v, f, diagonal=diagonal)
    plane = a.agree + same_plane(hits, ref, v, f, diagonal=diagonal)
    both = (hits.status == HIT) & (ref.status == HIT)
    # |dt| over every ray both hit, on whichever triangle: the position error.
    dt = (
        np.abs(hits.t[both].astype(np.float64) - ref.t[both])
        * np.linalg.norm(d[both], axis=1)
        / diagonal
    )
    j = judge(hits, verdict, arithmetic)
    return dict(
        agreement=a.agree / a.rays,
        plane_agreement=plane / a.rays,
        hit_agreement=float((hits.status == ref.status).mean()),
        p50_dt=float(np.median(dt)) if len(dt) else 0.0,
        p99_dt=float(np.quantile(dt, 0.99)) if len(dt) else 0.0,
        failed=int((hits.status == FAILED).sum()),
        right=float(j["right"].mean()),
        leaked=int(j["leaked"].sum()),
        late=int(j["late"].sum()),
        wrong=int(j["wrong"].sum()),
    )


def run_scene_settings(
    path, settings, *, methods, layouts, precisions, threads, res, repeat, gpu=False, out=print
):
    """Rows of one scene: peers first, then every setting x configuration.

    Every caster gets the same float32 camera rays (widened exactly for float64 walks), the
    same thread counts and the same timing (:func:`tetrace.bench.casters.timed`); every row
    is judged by the exact referee on those rays.
    """
    from ..errors import MeshingError
    from ..io import load_triangles
    from ..referee import Referee
    from ..scene import Scene

    name = Path(path).name
    v, f = load_triangles(path)
    diagonal = float(np.linalg.norm(v.max(0) - v.min(0)))
    o64, d64 = camera_rays(v, res)
    o32, d32 = o64.astype(np.float32), d64.astype(np.float32)
    n = len(o32)
    counts = {"1": 1, "all": _ncpu()}
    base = dict(scene=name, triangles=int(len(f)), rays=n)
    verdict = Referee(v, f).first_hits(o32, d32)
    rows, embree_rate, ref = [], {}, None

    def row(caster, label, k, seconds, hits, **extra):
        o, d = rays_for(caster.precision, o32, d32)
        mrays = n / seconds / 1e6
        if caster.name == "embreex":
            embree_rate[label] = mrays
        return dict(
            base,
            **extra,
            caster=caster.name,
            label=caster.label,
            schedule=caster.schedule(k),
            threads=k if k is not None else 0,
            mrays=mrays,
            ratio=mrays / embree_rate[label],
            **_accuracy(hits, ref, verdict, caster.arithmetic, v, f, diagonal, d),
        )

    others, skipped = optional_peers(v, f, peer_modules())
    for peer, why in skipped.items():
        out(f"  {name}: {PEER_TITLES[peer]} peer skipped: {why}")
    peers = [EmbreexCaster(v, f), *others]
    for peer in peers:
        for label in threads:
            k = counts[label]
            seconds, raw = timed(peer, o32, d32, k, repeat)
            hits = peer.hits(raw, o32, d32)
            if ref is None:  # embreex, the first peer: the reference of the agreement columns
                ref = hits
            rows.append(
                row(
                    peer,
                    label,
                    k,
                    seconds,
                    hits,
                    setting="-",
                    method="bvh",
                    layout="-",
                    precision="f32",
                    device="cpu",
                    mesher_s=peer.build_seconds,
                )
            )

    for setting in settings:
        kwargs = SETTINGS[setting]
        t0 = time.perf_counter()
        try:
            scene = Scene.from_mesh((v, f), lazy=False, **kwargs)
        except MeshingError as exc:
            out(f"  {name} / {setting}: not built: {exc}")
            rows.append(
                dict(
                    base,
                    setting=setting,
                    caster="tetrace",
                    error=str(exc),
                    mesher_s=time.perf_counter() - t0,
                )
            )
            continue
        tz, bt = scene.tetrahedralization, scene.build_times
        mesher_s = tz.auto["seconds"] if tz.auto else bt["total"] - bt["rust"]
        chosen = f" -> {tz.auto['setting']}" if tz.auto else ""
        build = dict(
            setting=setting,
            chosen=tz.auto["setting"] if tz.auto else setting,
            mesher=tz.mesher,
            tets=int(scene.n_tets),
            points=int(scene.n_points),
            weight=tz.weight(),
            mesher_s=mesher_s,
            rust_s=bt["rust"],
            surface_max=(tz.surface_distance["max"] / diagonal if tz.surface_distance else 0.0),
        )
        out(
            f"  {name} / {setting}{chosen}: {scene.n_tets:,} tets, weight {build['weight']:.4g}, "
            f"mesher {mesher_s:.2f} s, rust {bt['rust']:.2f} s"
        )
        for method, layout, prec, label in configurations(methods, layouts, precisions, threads):
            caster = TetraceCaster(scene, method, layout, prec)
            k = counts[label]
            seconds, hits = timed(caster, *rays_for(prec, o32, d32), k, repeat)
            mem = scene.memory()
            rows.append(
                row(
                    caster,
                    label,
                    k,
                    seconds,
                    hits,
                    **build,
                    method=method,
                    layout=layout,
                    precision=prec,
                    device="cpu",
                    tets_per_ray=float(hits.steps.mean()),
                    mem_mb=(
                        structure_bytes(mem, method, layout)
                        if is_accel(method)
                        else mem["points_f64"]
                        + mem["points_f32"]
                        + mem["constrained"]
                        + mem["locator"]
                        + mem[f"tets_{layout}"]
                    )
                    / 1e6,
                    mem_layout_mb=structure_bytes(mem, method, layout) / 1e6,
                )
            )
        if gpu:
            from .. import gpu as tgpu

            for method, layout in tgpu.kernels():
                caster = TetraceCaster(scene, method, layout, "f32", device="gpu")
                seconds, hits = timed(caster, o32, d32, None, repeat)
                rows.append(
                    row(
                        caster,
                        threads[-1],
                        None,
                        seconds,
                        hits,
                        **build,
                        method=method,
                        layout=layout,
                        precision="f32",
                        device="gpu",
                        kernel_mrays=hits.timings["walked"] / hits.timings["kernel"] / 1e6,
                        tets_per_ray=float(hits.steps.mean()),
                    )
                )
        del scene
    return rows


def pareto(rows):
    """Rows no other row of the same scene beats on both speed (ratio) and accuracy.

    Accuracy is ``right``, the share of rays the exact referee finds right; rows equal on both
    keep the first.
    """
    best = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        rs = [r for r in rows if r["scene"] == scene and "ratio" in r]
        rs.sort(key=lambda r: (-r["ratio"], -r["right"]))
        top = -1.0
        for r in rs:
            if r["right"] > top:
                best.append(r)
                top = r["right"]
    return best


def _disagreement(r):
    """Share of rays not right by the referee, floored at half a ray for the log axis."""
    return max(1.0 - r["right"], 0.5 / r["rays"])


def charts(rows, folder):
    """Write the three PNG charts into ``folder``; returns their paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    ok = [r for r in rows if "ratio" in r]
    settings = list(dict.fromkeys(r["setting"] for r in ok if r["caster"] == "tetrace"))
    colors = {s: plt.cm.tab10(i % 10) for i, s in enumerate(settings)}
    paths = {}

    # 1. Throughput against accuracy.
    cols = min(len(scenes), 3)
    nrow = -(-len(scenes) // cols)
    fig, axes = plt.subplots(nrow, cols, figsize=(5.2 * cols, 4.2 * nrow), squeeze=False)
    for ax, scene in zip(axes.flat, scenes):
        rs = [r for r in ok if r["scene"] == scene]
        top = max(r["threads"] for r in rs)
        for r in rs:
            if r["threads"] not in (top, 0):
                continue
            if r["caster"] == "tetrace":
                ax.scatter(
                    r["ratio"],
                    _disagreement(r),
                    color=colors[r["setting"]],
                    s=18,
                    marker="o" if r["precision"] == "f32" else "^",
                    edgecolors="k" if r["device"] == "gpu" else "none",
                )
            else:
                ax.scatter(r["ratio"], _disagreement(r), color="k", marker="*", s=80)
                ax.annotate(r["caster"], (r["ratio"], _disagreement(r)), fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(f"{scene} ({top} threads)", fontsize=9)
        ax.set_xlabel("throughput / embreex")
        ax.set_ylabel("not right (exact referee)")
    for ax in list(axes.flat)[len(scenes) :]:
        ax.axis("off")
    handles = [plt.Line2D([], [], marker="o", ls="", color=colors[s], label=s) for s in settings]
    handles += [
        plt.Line2D([], [], marker="o", ls="", color="gray", label="f32"),
        plt.Line2D([], [], marker="^", ls="", color="gray", label="f64"),
    ]
    # What each peer is, exactly (its label), under the legend, wrapped to the figure.
    peers = dict.fromkeys(
        (r["caster"], r.get("label", r["caster"])) for r in ok if r["caster"] != "tetrace"
    )
    width = int(fig.get_figwidth() * 20)  # characters of 6-point text per line
    notes = [
        line
        for caster, label in peers
        for line in textwrap.wrap(f"{caster}: {label}", width, subsequent_indent="    ")
    ]
    line_h = 0.12 / fig.get_figheight()  # 6-point lines, in figure fractions
    for i, note in enumerate(notes):
        fig.text(0.01, 0.01 + line_h * (len(notes) - 1 - i), note, fontsize=6)
    fig.legend(
        handles=handles,
        loc="lower center",
        bbox_to_anchor=(0.5, line_h * len(notes)),
        ncol=min(len(handles), 6),
        fontsize=8,
    )
    fig.tight_layout(rect=(0, 0.08 + line_h * len(notes), 1, 1))
    paths["speed_accuracy"] = folder / "speed_accuracy.png"
    fig.savefig(paths["speed_accuracy"], dpi=110)
    plt.close(fig)

    # 2. Build: one bar group per scene, one bar per setting.
    builds = {}
    for r in ok:
        if r["caster"] == "tetrace" and "mem_mb" in r:
            builds.setdefault((r["scene"], r["setting"]), r)
    fig, axes = plt.subplots(1, 4, figsize=(18, 4))
    width = 0.8 / max(len(settings), 1)
    for ax, (key, label) in zip(
        axes,
        [
            ("tets", "tets"),
            ("weight_rel", "weight / quality's"),
            ("mesher_s", "mesher seconds"),
            ("mem_mb", "memory MB"),
        ],
    ):
        for j, s in enumerate(settings):
            ys = []
            for scene in scenes:
                b = builds.get((scene, s))
                q = builds.get((scene, "quality"))
                if b is None:
                    ys.append(np.nan)
                elif key == "weight_rel":
                    ys.append(b["weight"] / q["weight"] if q else np.nan)
                else:
                    ys.append(b[key])
            ax.bar(np.arange(len(scenes)) + j * width, ys, width, color=colors[s], label=s)
        ax.set_xticks(np.arange(len(scenes)) + 0.4 - width / 2)
        ax.set_xticklabels(scenes, rotation=30, fontsize=7)
        ax.set_title(label, fontsize=9)
        if key != "weight_rel":
            ax.set_yscale("log")
    fig.legend(handles=handles[:-2], loc="lower center", ncol=min(len(settings), 9), fontsize=8)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    paths["build"] = folder / "build.png"
    fig.savefig(paths["build"], dpi=110)
    plt.close(fig)

    # 3. Weight against time per ray, relative to each scene's quality preset.
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    xs, ys, zs = [], [], []
    for scene in scenes:
        timing = [
            r
            for r in ok
            if r["scene"] == scene
            and r["caster"] == "tetrace"
            and r["device"] == "cpu"
            and r["threads"] == 1
        ]
        if not timing:
            continue
        method, layout, prec = timing[0]["method"], timing[0]["layout"], timing[0]["precision"]
        by = {
            r["setting"]: r
            for r in timing
            if (r["method"], r["layout"], r["precision"]) == (method, layout, prec)
        }
        q = by.get("quality")
        if q is None:
            continue
        for s, r in by.items():
            x, y = r["weight"] / q["weight"], q["mrays"] / r["mrays"]
            xs.append(x)
            ys.append(y)
            zs.append(r["tets_per_ray"] / q["tets_per_ray"])
            axes[0].scatter(x, y, color=colors[s], s=20)
            axes[1].scatter(x, r["tets_per_ray"] / q["tets_per_ray"], color=colors[s], s=20)
    r_time = float(np.corrcoef(xs, ys)[0, 1]) if len(xs) > 2 else float("nan")
    r_steps = float(np.corrcoef(xs, zs)[0, 1]) if len(xs) > 2 else float("nan")
    for ax, what in zip(axes, ["time per ray", "tets per ray"]):
        ax.plot([0.5, 3], [0.5, 3], "k:", lw=0.8)
        ax.set_xlabel("weight / quality's weight (same scene)")
        ax.set_ylabel(f"{what} / quality's")
    axes[0].set_title(f"1 thread, {method} {layout} {prec}; Pearson r = {r_time:.3f}", fontsize=9)
    axes[1].set_title(f"Pearson r = {r_steps:.3f}", fontsize=9)
    axes[1].legend(handles=handles[:-2], fontsize=7)
    fig.tight_layout()
    paths["weight_time"] = folder / "weight_time.png"
    fig.savefig(paths["weight_time"], dpi=110)
    plt.close(fig)
    return paths, r_time, r_steps


COLUMNS = [
    "scene",
    "triangles",
    "rays",
    "setting",
    "chosen",
    "mesher",
    "tets",
    "points",
    "weight",
    "mesher_s",
    "rust_s",
    "surface_max",
    "mem_mb",
    "mem_layout_mb",
    "caster",
    "method",
    "layout",
    "precision",
    "threads",
    "device",
    "mrays",
    "kernel_mrays",
    "ratio",
    "tets_per_ray",
    "agreement",
    "plane_agreement",
    "hit_agreement",
    "p50_dt",
    "p99_dt",
    "failed",
    "right",
    "leaked",
    "late",
    "wrong",
    "label",
    "schedule",
    "error",
]


def run_matrix(
    scenes,
    *,
    settings,
    methods,
    layouts,
    precisions,
    threads,
    res,
    repeat,
    out_dir,
    gpu=False,
    out=print,
):
    """Run the matrix over ``scenes`` (mesh paths), write CSV/JSON/PNGs into ``out_dir``.

    Returns
    -------
    dict
        ``rows``, ``pareto`` (the Pareto-best rows), ``charts`` (paths),
        ``weight_time_r`` and ``weight_steps_r`` (Pearson r of weight against time and
        against tets per ray, each relative to the scene's ``quality``), ``seconds``.
    """
    unknown = [s for s in settings if s not in SETTINGS]
    if unknown:
        raise ValueError(f"unknown settings {unknown}; choose from {list(SETTINGS)}")
    t0 = time.perf_counter()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for path in scenes:
        out(f"{Path(path).name}:")
        rows += run_scene_settings(
            path,
            settings,
            methods=methods,
            layouts=layouts,
            precisions=precisions,
            threads=threads,
            res=res,
            repeat=repeat,
            gpu=gpu,
            out=out,
        )
    with open(out_dir / "matrix.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    with open(out_dir / "matrix.json", "w") as fh:
        json.dump(rows, fh, indent=1)
    res = report(rows, out_dir, out=out)
    res["seconds"] = time.perf_counter() - t0
    return res


def report(rows, out_dir, out=print):
    """Charts into ``out_dir`` and the Pareto table of matrix rows; see :func:`run_matrix`."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths, r_time, r_steps = charts(rows, out_dir)
    best = pareto(
        [
            r
            for r in rows
            if r["caster"] == "tetrace"
            and "ratio" in r
            and r["threads"]
            == max(x["threads"] for x in rows if "ratio" in x and x["scene"] == r["scene"])
        ]
    )
    peers = [r for r in rows if r["caster"] != "tetrace" and "ratio" in r]
    out("\nPeers (same rays, same threads, dynamic chunks; judged by the exact referee):")
    out(
        _table(
            [
                [
                    r["scene"],
                    r.get("label", r["caster"]),
                    r.get("schedule", f"{r['threads']}"),
                    f"{r['mrays']:.2f}",
                    f"{r.get('right', float('nan')) * 100:.3f}%",
                    r.get("leaked", "-"),
                    r.get("late", "-"),
                    r.get("wrong", "-"),
                ]
                for r in peers
            ],
            ["scene", "peer", "schedule", "Mrays/s", "right", "leaked", "late", "wrong"],
        )
    )
    out(
        "\nPareto-best tetrace settings per scene (no other is both faster and more accurate; "
        "most threads measured):"
    )
    out(
        _table(
            [
                [
                    r["scene"],
                    r["setting"] + (f" ({r['chosen']})" if r["chosen"] != r["setting"] else ""),
                    r["method"],
                    r["layout"],
                    r["precision"],
                    r["device"],
                    f"{r['tets']:,}",
                    f"{r['mrays']:.2f}",
                    f"{r['ratio']:.2f}",
                    f"{r['right'] * 100:.3f}%",
                    f"{r['p99_dt']:.1e}",
                ]
                for r in best
            ],
            [
                "scene",
                "setting",
                "method",
                "layout",
                "prec",
                "device",
                "tets",
                "Mrays/s",
                "x embreex",
                "right (referee)",
                "p99 |dt|/diag",
            ],
        )
    )
    out(
        f"weight against time per ray (1 thread, relative to quality): Pearson r = {r_time:.3f}; "
        f"against tets per ray: r = {r_steps:.3f}"
    )
    out(f"wrote into {out_dir}: " + ", ".join(p.name for p in paths.values()))
    return dict(rows=rows, pareto=best, charts=paths, weight_time_r=r_time, weight_steps_r=r_steps)


def matrix_main(argv):
    """Command line of ``python -m tetrace.bench matrix``."""
    from ..scene import default_scene_path
    from .scenes import default_scenes_dir

    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench matrix",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "scenes",
        nargs="*",
        help="mesh files (default: Spot, plus the full run's "
        f"shared scenes {', '.join(FULL_SCENES)} unless --quick)",
    )
    p.add_argument("--quick", action="store_true", help="Spot, 6 settings, 3 methods, 1 thread")
    p.add_argument(
        "--dir",
        default=None,
        help="shared scenes folder (default: $TETRACE_SCENES or ../shared/scenes)",
    )
    for name in ("settings", "methods", "layouts", "precisions", "threads"):
        p.add_argument(
            f"--{name}",
            default=None,
            help=f"comma-separated {name} (default: "
            f"full {','.join(FULL[name])}; quick {','.join(QUICK[name])})",
        )
    p.add_argument("--res", type=int, default=None, help="camera resolution of each of 3 views")
    p.add_argument("--repeat", type=int, default=None)
    p.add_argument(
        "--gpu",
        choices=["auto", "yes", "no"],
        default="auto",
        help="also every GPU kernel: auto (default) when a hardware adapter is found "
        "(not a software one such as lavapipe)",
    )
    p.add_argument("--out", default="matrix-out", help="folder for CSV, JSON and PNGs")
    p.add_argument(
        "--replot",
        default=None,
        metavar="JSON",
        help="redraw the charts and the Pareto table of an earlier run's matrix.json",
    )
    args = p.parse_args(argv)
    if args.replot:
        with open(args.replot) as fh:
            report(json.load(fh), args.out)
        return 0
    cfg = dict(QUICK if args.quick else FULL)
    for name in ("settings", "methods", "layouts", "precisions", "threads"):
        if getattr(args, name):
            cfg[name] = getattr(args, name).split(",")
    for name in ("res", "repeat"):
        if getattr(args, name):
            cfg[name] = getattr(args, name)
    scenes = args.scenes
    if not scenes:
        scenes = [str(default_scene_path())]
        if not args.quick:
            folder = Path(args.dir) if args.dir else default_scenes_dir()
            missing = [s for s in FULL_SCENES if not (folder / s).exists()]
            if missing:
                print(
                    f"shared scenes not found in {folder}: {missing}; running the bundled "
                    f"scene only"
                )
            scenes += [str(folder / s) for s in FULL_SCENES if (folder / s).exists()]
    gpu = args.gpu == "yes" or (args.gpu == "auto" and hardware_gpu())
    run_matrix(scenes, out_dir=args.out, gpu=gpu, **cfg)
    return 0
