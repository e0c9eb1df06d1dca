"""Reshetov's BVH (``accel="reshetov_bvh"``) and its packets with vertex culling
(``"reshetov_bvh_packets"``, 4×4, and ``"reshetov_bvh_packets8"``, 8×8): the SAH-ratio sweep of
Reshetov 2007, tree size against speed and the share of ray-triangle tests culled, on one scene,
beside the tet walk and embreex on the same camera rays.

``python -m tetrace.bench bvh [mesh] [--res 512] [--ratios 0.25,0.5,1,2,4,8]
[--leaves 4,8,16]`` builds the tree once per (cost ratio, max leaf size) and casts a pinhole
camera of ``res``² float32 rays on one thread; every tetrace row is judged by the exact
referee. Columns: build seconds, nodes, leaves, depth, MB, Mrays/s, × embreex, nodes visited
per ray, culled (packets: the share of ray-triangle tests at leaves the frustum culled), right
(referee).
"""

from __future__ import annotations

import argparse
import time

RATIOS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
LEAVES = (4, 8, 16)
#: The ways each tree is walked: one ray at a time, and packets of 16 and 64 rays.
ACCELS = ("reshetov_bvh", "reshetov_bvh_packets", "reshetov_bvh_packets8")


def run_bvh_sweep(
    path=None,
    *,
    res=512,
    ratios=RATIOS,
    leaves=LEAVES,
    accels=ACCELS,
    repeat=3,
    distance=1.6,
    out=print,
):
    """Sweep the BVH's SAH cost ratio and leaf size on one scene; print and return the rows.

    Parameters
    ----------
    path : str, optional
        Mesh file; None uses the bundled scene.
    res : int
        Camera resolution (``res`` × ``res`` float32 rays, one thread).
    ratios : sequence of float
        SAH cost of visiting a node over testing a triangle.
    leaves : sequence of int
        Most triangles per leaf.
    accels : sequence of str
        How each tree is walked (names from :func:`tetrace.accels`).
    repeat : int
        Timed casts per row; the best is kept.
    distance : float
        Camera distance from the scene centre, in bounding radii.
    out : callable

    Returns
    -------
    list of dict
        One per tree (and one for the tet walk, ``accel`` ``"tetwalk"``): its shape, memory,
        ``mrays_per_s``, ``ratio_to_embree``, ``nodes_per_ray``, ``right`` (the share of
        rays the referee finds right) and, for packets, ``culled`` (the share of ray-triangle
        tests at leaves that the frustum culled, over the timed casts).
    """
    from .casters import CameraRun
    from .scene_bench import _table

    run = CameraRun(path, res, distance, repeat)
    scene, path, f, embree_rate = run.scene, run.path, run.scene.faces, run.embree_rate

    def measure(method):
        m = run.measure(method)
        m["nodes_per_ray"] = m.pop("steps_per_ray")
        return m

    rows = [dict(accel="tetwalk", **measure("exact"))]
    for ratio in ratios:
        for leaf in leaves:
            t0 = time.perf_counter()
            shape = scene.build_bvh(cost_ratio=ratio, max_leaf=leaf)
            built = time.perf_counter() - t0
            shape = {k: v for k, v in shape.items() if not k.startswith("packet_")}
            for accel in accels:
                before = scene.bvh_info()
                row = dict(accel=accel, build_s=built, **shape, **measure(accel))
                after = scene.bvh_info()
                tests = after["packet_tests"] - before["packet_tests"]
                if tests:
                    row["culled"] = (after["packet_culled"] - before["packet_culled"]) / tests
                rows.append(row)
    out(
        f"BVH sweep: {path.split('/')[-1]} ({len(f):,} triangles, {scene.n_tets:,} tets), "
        f"{res}x{res} float32 camera, one thread, best of {repeat}; embreex {embree_rate:.2f} "
        "Mrays/s; 'nodes/ray': BVH nodes visited (tet walk: tets)"
    )
    table = [
        [
            r["accel"],
            r.get("cost_ratio", "-"),
            r.get("max_leaf", "-"),
            f"{r['build_s']:.2f}" if "build_s" in r else "-",
            r.get("nodes", "-"),
            r.get("leaves", "-"),
            r.get("depth", "-"),
            f"{r['bytes'] / 1e6:.1f}" if "bytes" in r else "-",
            f"{r['mrays_per_s']:.2f}",
            f"{r['ratio_to_embree']:.2f}",
            f"{r['nodes_per_ray']:.1f}",
            f"{r['culled'] * 100:.1f}%" if "culled" in r else "-",
            f"{r['right'] * 100:.3f}%",
        ]
        for r in rows
    ]
    header = [
        "accel",
        "cost ratio",
        "max leaf",
        "build s",
        "nodes",
        "leaves",
        "depth",
        "MB",
        "Mrays/s",
        "x embreex",
        "nodes/ray",
        "culled",
        "right (referee)",
    ]
    out(_table(table, header))
    return rows


def bvh_main(argv):
    """Command line of ``python -m tetrace.bench bvh``."""
    p = argparse.ArgumentParser(prog="python -m tetrace.bench bvh", description=__doc__)
    p.add_argument("scene", nargs="?", default=None, help="mesh file (default: the bundled scene)")
    p.add_argument("--res", type=int, default=512)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--ratios", default=",".join(map(str, RATIOS)))
    p.add_argument("--leaves", default=",".join(map(str, LEAVES)))
    p.add_argument("--accels", default=",".join(ACCELS))
    args = p.parse_args(argv)
    run_bvh_sweep(
        args.scene,
        res=args.res,
        repeat=args.repeat,
        ratios=[float(x) for x in args.ratios.split(",")],
        leaves=[int(x) for x in args.leaves.split(",")],
        accels=args.accels.split(","),
    )
    return 0
