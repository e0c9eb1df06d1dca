"""Local complexity (issue 5): does a ray's cost grow with the scene, or only with what is near it?

Lagae & Dutré (2008) claim that a constrained-tetrahedralization ray caster's cost depends on
the geometry near the ray, not on the scene's size. This bench keeps one object and one camera
and grows the world around them: far copies of the object (out of the camera's view) and a big
low-poly bowl that catches every ray missing the object. tetrace and embreex cast the same rays
in every world, and the exact referee (:mod:`tetrace.referee`) judges tetrace's answers and says
which rays hit the object: the object's rays are the referee's, not either caster's.
"""

from __future__ import annotations

import argparse
import json
import os
import re

import numpy as np

from ..dev.camera import orbit_views, pinhole
from ..dev.compare import agreement, compare
from ..referee import Referee
from ..scene import Scene, default_scene_path
from .casters import EmbreexCaster, TetraceCaster, timed
from .scene_bench import _table

WORLDS = ("alone", "+1", "+10", "+100", "stadium", "stadium+100")
QUICK = ("alone", "+1", "+10", "stadium")


def _parse_world(name):
    """``"alone"``, ``"+N"``, ``"stadium"`` or ``"stadium+N"`` -> (copies, stadium)."""
    m = re.fullmatch(r"(alone|stadium)?(?:\+(\d+))?", name)
    if not m or not (m.group(1) or m.group(2)) or (m.group(1) == "alone" and m.group(2)):
        raise ValueError(f"unknown world {name!r}: use alone, +N, stadium or stadium+N")
    return int(m.group(2) or 0), m.group(1) == "stadium"


def copy_offsets(n, centre, eye, radius, cone_deg=35.0):
    """Centres of ``n`` far copies: a Fibonacci sphere of ``radius`` about ``centre``.

    Directions within ``cone_deg`` of the camera's view axis are left empty, so the camera sees
    only the original while the rays that miss it still cross the far world (the camera's
    half-diagonal field of a 40-degree view is 27 degrees; a copy spans about 1 more).

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` translations to add to the object's vertices.
    """
    forward = (centre - eye) / np.linalg.norm(centre - eye)
    k = n
    while True:
        i = np.arange(k) + 0.5
        y = 1.0 - 2.0 * i / k
        phi = i * np.pi * (3.0 - np.sqrt(5.0))  # golden angle: even cover for any k
        r = np.sqrt(1.0 - y * y)
        pts = centre + radius * np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1)
        to = pts - eye
        ok = to @ forward < np.cos(np.radians(cone_deg)) * np.linalg.norm(to, axis=1)
        if ok.sum() >= n:
            pts = pts[ok]
            return pts[np.linspace(0, len(pts) - 1, n).round().astype(int)] - centre
        k += 1


def stadium_mesh(centre, radius, segments=24, rings=8, top_deg=100.0):
    """An open bowl (a sphere from its bottom pole up to ``top_deg``) about ``centre``.

    Every camera ray of :func:`run_growth` points downwards, so the bowl, reaching 10 degrees
    above the horizon, catches all the rays that miss the object.

    Returns
    -------
    vertices : numpy.ndarray
        ``(1 + segments * rings, 3)`` float64.
    faces : numpy.ndarray
        ``(segments * (2 * rings - 1), 3)`` int64 (360 triangles by default).
    """
    theta = np.radians(top_deg) * np.arange(1, rings + 1) / rings  # polar angle from the bottom
    phi = 2 * np.pi * np.arange(segments) / segments
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), -np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    v = centre + radius * np.vstack([[0.0, -1.0, 0.0], ring])
    j = np.arange(segments)
    idx = lambda r, s: 1 + r * segments + s % segments
    faces = [np.stack([np.zeros_like(j), idx(0, j), idx(0, j + 1)], 1)]
    for r in range(rings - 1):
        a, b, c, d = idx(r, j), idx(r, j + 1), idx(r + 1, j), idx(r + 1, j + 1)
        faces += [np.stack([a, c, b], 1), np.stack([b, c, d], 1)]
    return v, np.vstack(faces).astype(np.int64)


def make_world(v, f, name, *, eye, spacing=30.0, stadium_size=100.0):
    """The object (its triangles first, so ids below ``len(f)`` are the original), far copies
    at ``spacing`` object diagonals, and for stadium worlds a bowl ``stadium_size`` diagonals
    across. Returns vertices, faces and the stadium's triangle count."""
    copies, stadium = _parse_world(name)
    centre = 0.5 * (v.min(0) + v.max(0))
    diag = float(np.linalg.norm(v.max(0) - v.min(0)))
    vs, fs = [v], [f]
    for off in copy_offsets(copies, centre, eye, spacing * diag) if copies else ():
        fs.append(f + sum(len(x) for x in vs))
        vs.append(v + off)
    n_stadium = 0
    if stadium:
        sv, sf = stadium_mesh(centre, 0.5 * stadium_size * diag)
        fs.append(sf + sum(len(x) for x in vs))
        vs.append(sv)
        n_stadium = len(sf)
    return np.vstack(vs), np.vstack(fs), n_stadium


def run_growth(
    path=None,
    worlds=QUICK,
    *,
    preset="quality",
    res=512,
    repeat=3,
    spacing=30.0,
    stadium_size=100.0,
    json_path=None,
    png_path=None,
    out=print,
):
    """Cast one camera at one object in ever bigger worlds, with tetrace and embreex.

    Parameters
    ----------
    path : str, optional
        Object mesh; None uses the bundled scene (Spot).
    worlds : sequence of str
        ``"alone"``, ``"+N"`` (N far copies), ``"stadium"`` (a 360-triangle bowl),
        ``"stadium+N"``.
    preset : str
        Meshing preset for :meth:`tetrace.Scene.from_mesh`.
    res : int
        Camera resolution (square, 40-degree field, 1.6 bounding radii from the object).
    repeat : int
        Timed repetitions; the best is kept.
    spacing, stadium_size : float
        Distance of the copies and diameter of the bowl, in object diagonals.
    json_path, png_path : str, optional
        Also write the rows as JSON, and a chart, there.
    out : callable
        Where lines go.

    Returns
    -------
    list of dict
        One row per world, with everything printed as numbers.
    """
    from .. import _native
    from ..baselines.embree import cpu_count
    from ..io import load_triangles

    v, f = load_triangles(str(path) if path is not None else str(default_scene_path()))
    n_obj = len(f)
    eye, target, up = orbit_views(np.array([v.min(0), v.max(0)]), n=1, distance=1.6)[0]
    o32, d32 = pinhole(eye, target, up, fov_deg=40.0, width=res, height=res, dtype=np.float32)
    n = len(o32)
    ncpu = cpu_count()
    rows, table = [], []
    for name in worlds:
        wv, wf, n_stadium = make_world(
            v, f, name, eye=eye, spacing=spacing, stadium_size=stadium_size
        )
        # The domain holds the eye in every world, so every walk starts inside it alike.
        scene = Scene.from_mesh((wv, wf), preset, contain=eye[None], lazy=False)
        bt = scene.build_times
        ours = TetraceCaster(scene, _native.DEFAULT_METHOD, _native.DEFAULT_LAYOUT, "f32")
        embreex = EmbreexCaster(wv, wf)
        # Both casters alike (casters.timed): the same rays and threads, dynamic chunks, an
        # untimed warm-up (caches and lazy state), then the best of `repeat`.
        rate = lambda caster, o, d, k: len(o) / timed(caster, o, d, k, repeat)[0] / 1e6
        tt1, tea = rate(ours, o32, d32, 1), rate(embreex, o32, d32, ncpu)
        te1, tta = rate(embreex, o32, d32, 1), rate(ours, o32, d32, ncpu)
        hits = ours.cast(o32, d32, ncpu)
        ref = embreex.hits(embreex.cast(o32, d32, ncpu), o32, d32)
        # The exact answers for the float32 rays on this world's triangles: the object's rays
        # (first hit on one of its triangles, ids below n_obj) and the judgement of tetrace.
        exact = Referee(wv, wf).first_hits(o32, d32, hint=hits.triangle)
        score = agreement(hits, exact)
        on = exact.hit & (exact.triangle < n_obj)
        # The same timings on the object's rays alone: the rays whose surroundings never change.
        oo, od = np.ascontiguousarray(o32[on]), np.ascontiguousarray(d32[on])
        to1 = eo1 = float("nan")
        if on.any():
            to1, eo1 = rate(ours, oo, od, 1), rate(embreex, oo, od, 1)
        a = compare(hits, ref, wv, wf)
        steps = hits.steps.astype(np.float64)
        mean = lambda m, steps=steps: float(steps[m].mean()) if m.any() else float("nan")
        row = dict(
            world=name,
            object_triangles=n_obj,
            copies=_parse_world(name)[0],
            stadium_triangles=n_stadium,
            triangles=int(len(wf)),
            tets=scene.n_tets,
            points=scene.n_points,
            mesh_s=float(bt.get("mesher", bt.get("tetgen", 0.0))),
            clean_repair_s=float(bt.get("clean", 0.0) + bt.get("repair", 0.0)),
            rust_s=float(bt["rust"]),
            embree_build_s=float(embreex.build_seconds),
            rays=n,
            object_fraction=float(on.mean()),
            nothing_fraction=float((~exact.hit).mean()),
            tetrace_object_fraction=float(((hits.triangle >= 0) & (hits.triangle < n_obj)).mean()),
            tets_per_ray=float(steps.mean()),
            tets_per_object_ray=mean(on),
            tets_per_miss_ray=mean(~on),
            tetrace_mrays_1=tt1,
            embreex_mrays_1=te1,
            ratio_1=tt1 / te1,
            threads_all=ncpu,
            tetrace_mrays_all=tta,
            embreex_mrays_all=tea,
            ratio_all=tta / tea,
            tetrace_object_mrays_1=to1,
            embreex_object_mrays_1=eo1,
            embreex_agreement=a.fraction,
            right=score.fraction,
            leaked=score.leaked,
            late=score.late,
            wrong=score.wrong,
            t_off=score.t_off,
            failed=score.failed,
            tetrace_label=ours.label,
            embreex_label=embreex.label,
            tetrace_schedule=ours.schedule(ncpu),
            embreex_schedule=embreex.schedule(ncpu),
        )
        rows.append(row)
        table.append(
            [
                name,
                f"{row['triangles']:,}",
                f"{row['tets']:,}",
                f"{row['mesh_s']:.2f}",
                f"{row['rust_s']:.2f}",
                f"{row['object_fraction'] * 100:.1f}",
                f"{row['nothing_fraction'] * 100:.1f}",
                f"{row['tets_per_ray']:.1f}",
                f"{row['tets_per_object_ray']:.1f}",
                f"{row['tets_per_miss_ray']:.1f}",
                f"{tt1:.2f}",
                f"{te1:.2f}",
                f"{tt1 / te1:.2f}",
                f"{tta:.2f}",
                f"{tea:.2f}",
                f"{tta / tea:.2f}",
                f"{to1:.2f}",
                f"{eo1:.2f}",
                f"{score.fraction * 100:.3f}%",
                f"{score.leaked}/{score.late}/{score.wrong}",
                f"{a.fraction * 100:.3f}%",
            ]
        )
        # the next world may be 100x bigger: free this one first
        del scene, ours, embreex, hits, ref, exact
    out(
        f"local complexity: {os.path.basename(str(path or default_scene_path()))} ({n_obj:,} "
        f"triangles), preset {preset!r}, {res}x{res} camera at 1.6 bounding radii, copies at "
        f"{spacing:g} diagonals, stadium {stadium_size:g} diagonals across, best of {repeat}; "
        f"Mrays/s on 1 thread and on all {ncpu}; 'obj rays' = only the rays whose first hit the "
        f"exact referee finds on the object; 'right' and 'leaked/late/wrong': tetrace judged by "
        f"the referee; 'same as embreex': same outcome and triangle id"
    )
    if rows:
        out(f"tetrace = {rows[0]['tetrace_label']}; {rows[0]['tetrace_schedule']} (at {ncpu})")
        out(f"embreex = {rows[0]['embreex_label']}; {rows[0]['embreex_schedule']} (at {ncpu})")
    out(
        _table(
            table,
            [
                "world",
                "triangles",
                "tets",
                "mesh s",
                "rust s",
                "obj %",
                "nothing %",
                "tets/ray",
                "tets/obj ray",
                "tets/miss ray",
                "tetrace 1T",
                "embreex 1T",
                "x",
                f"tetrace {ncpu}T",
                f"embreex {ncpu}T",
                "x",
                "tetrace obj rays 1T",
                "embreex obj rays 1T",
                "right",
                "leaked/late/wrong",
                "same as embreex",
            ],
        )
    )
    out(verdict(rows))
    if json_path:
        with open(json_path, "w") as fh:
            json.dump(rows, fh, indent=2)
    if png_path:
        _plot(rows, png_path)
        out(f"chart: {png_path}")
    return rows


def verdict(rows):
    """One paragraph comparing the "alone" world (else the first) with the biggest one."""
    a = next((r for r in rows if r["world"] == "alone"), rows[0])
    b = max(rows, key=lambda r: r["triangles"])
    if a is b:
        return "verdict: one world only, nothing to compare."
    x = lambda k: b[k] / a[k]
    ch = lambda k, d=1: f"{a[k]:.{d}f} -> {b[k]:.{d}f} (x{x(k):.2f})"
    # Local: the object's rays walk about as many tets and run at least 2/3 as fast.
    local = abs(x("tets_per_object_ray") - 1) < 0.2 and x("tetrace_object_mrays_1") > 0.67
    return (
        f"verdict: from {a['world']} ({a['triangles']:,} triangles, {a['tets']:,} tets) to "
        f"{b['world']} ({b['triangles']:,} triangles, x{x('triangles'):.0f}; {b['tets']:,} "
        f"tets), the rays that hit the object walked {ch('tets_per_object_ray')} tets, and "
        f"tetrace cast them at {ch('tetrace_object_mrays_1', 2)} Mrays/s on 1 thread, against "
        f"embreex's {ch('embreex_object_mrays_1', 2)}. Over all rays tetrace went "
        f"x{x('tetrace_mrays_1'):.2f} and embreex x{x('embreex_mrays_1'):.2f}: the rays that "
        f"miss the object walked {ch('tets_per_miss_ray')} tets, their surroundings having "
        f"changed. tetrace was right (exact referee) on >= "
        f"{min(r['right'] for r in rows) * 100:.3f}% of rays in every world. "
        + (
            "Consistent with Lagae & Dutré: where a ray's neighbourhood is unchanged, tetrace's "
            "cost did not follow the scene's size."
            if local
            else "Not consistent with a purely local cost: the object's rays got dearer (over 20% "
            "more or fewer tets, or a third slower) as the world grew."
        )
    )


def _plot(rows, path):
    """Mrays/s (left) and tets per ray (right) against the world's triangles (log)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = sorted(rows, key=lambda r: r["triangles"])
    # Lines join the copies-only worlds; the stadium worlds are another family: hollow markers.
    groups = [
        ([r for r in rows if not r["stadium_triangles"]], "-", None),
        ([r for r in rows if r["stadium_triangles"]], "none", "none"),
    ]
    fig, ax = plt.subplots(figsize=(9, 6))
    ax2 = ax.twinx()
    series = [
        (ax, "tetrace_mrays_1", "tetrace, all rays", "o", "C0", "-"),
        (ax, "tetrace_object_mrays_1", "tetrace, object rays", "o", "C0", "--"),
        (ax, "embreex_mrays_1", "embreex, all rays", "s", "C1", "-"),
        (ax, "embreex_object_mrays_1", "embreex, object rays", "s", "C1", "--"),
        (ax2, "tets_per_object_ray", "tets/ray, object rays", "^", "C2", ":"),
        (ax2, "tets_per_miss_ray", "tets/ray, other rays", "v", "C3", ":"),
    ]
    for axis, key, label, marker, color, line in series:
        for group, joined, face in groups:
            axis.plot(
                [r["triangles"] for r in group],
                [r[key] for r in group],
                marker=marker,
                color=color,
                mfc=face,
                ls=line if joined == "-" else "none",
                label=label if face is None else None,
            )
    for r in rows:
        ax.annotate(
            r["world"],
            (r["triangles"], r["tetrace_mrays_1"]),
            fontsize=8,
            textcoords="offset points",
            xytext=(3, 5),
        )
    ax.plot([], [], "o", color="gray", mfc="none", label="hollow: stadium worlds")
    ax.set_xscale("log")
    ax.margins(x=0.1)  # room for the last world's label
    ax.set_xlabel("world triangles")
    ax.set_ylabel("Mrays/s, 1 thread")
    ax.set_ylim(bottom=0)
    ax2.set_ylabel("tets per ray")
    ax2.set_ylim(bottom=0)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=4)
    ax.set_title("Local complexity: one object and camera, growing world")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def growth_main(argv):
    """``python -m tetrace.bench growth``: see ``--help``."""
    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench growth",
        description="Local complexity (Lagae & Dutre 2008): one object and one camera in ever "
        "bigger worlds (far copies, a stadium bowl); tetrace and embreex rates, "
        "tets per ray on the object's rays and the others, tetrace judged by the "
        "exact referee.",
    )
    p.add_argument("--scene", default=None, help="object mesh (default: the bundled Spot)")
    p.add_argument("--worlds", default=None, help=f"comma-separated (default: {','.join(WORLDS)})")
    p.add_argument("--quick", action="store_true", help=f"worlds {','.join(QUICK)}")
    p.add_argument("--preset", default="quality")
    p.add_argument("--res", type=int, default=512)
    p.add_argument("--repeat", type=int, default=3, help="timed repetitions; the best is kept")
    p.add_argument("--spacing", type=float, default=30.0, help="copy distance, in diagonals")
    p.add_argument("--stadium-size", type=float, default=100.0, help="bowl diameter, in diagonals")
    p.add_argument("--json", default=None, help="also write the rows as JSON here")
    p.add_argument("--png", default=None, help="also draw a chart here")
    args = p.parse_args(argv)
    worlds = args.worlds.split(",") if args.worlds else (QUICK if args.quick else WORLDS)
    for w in worlds:
        _parse_world(w)  # fail before any meshing
    run_growth(
        args.scene,
        worlds,
        preset=args.preset,
        res=args.res,
        repeat=args.repeat,
        spacing=args.spacing,
        stadium_size=args.stadium_size,
        json_path=args.json,
        png_path=args.png,
    )
    return 0
