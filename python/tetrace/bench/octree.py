"""Portalez & Duguet's octree (``accel="portalez_octree"``): their Tables 1 and 4 on one scene,
with and without the 2:1 balance, beside the tet walk and embreex on the same camera rays.

``python -m tetrace.bench octree [mesh] [--res 512] [--depths 8] [--leaf-sizes 8]`` builds the
octree once per (max depth, leaf size, balance) and casts a pinhole camera of ``res``² float32
rays on one thread; every row is judged by the exact referee. Columns: build seconds, leaves,
neighbours per leaf, triangles per leaf, MB per part (cube map, octree records, triangles,
boxes: Table 4; hierarchy: the tree kept to locate origins inside the root box, which the paper
does not keep), Mrays/s, × embreex, leaves visited per ray, right (referee).
"""

from __future__ import annotations

import argparse
import time

DEPTHS = (8,)
LEAF_SIZES = (12,)


def run_octree_stats(
    path=None,
    *,
    res=512,
    depths=DEPTHS,
    leaf_sizes=LEAF_SIZES,
    repeat=3,
    distance=1.6,
    out=print,
):
    """Build the octree balanced and unbalanced for each (depth, leaf size); print and return
    its statistics and the camera's throughput.

    Parameters
    ----------
    path : str, optional
        Mesh file; None uses the bundled scene.
    res : int
        Camera resolution (``res`` × ``res`` float32 rays, one thread).
    depths : sequence of int
        Maximum leaf depths.
    leaf_sizes : sequence of int
        A node splits while it holds more triangles than this.
    repeat : int
        Timed casts per row; the best is kept.
    distance : float
        Camera distance from the scene centre, in bounding radii.
    out : callable

    Returns
    -------
    list of dict
        One per octree (and one for the tet walk, ``accel`` ``"tetwalk"``): what
        :meth:`Scene.octree_info` returns, ``build_s``, ``mrays_per_s``,
        ``ratio_to_embree``, ``leaves_per_ray`` and ``right`` (the share of rays the referee
        finds right).
    """
    from .casters import CameraRun
    from .scene_bench import _table

    run = CameraRun(path, res, distance, repeat)
    scene, path, f, embree_rate = run.scene, run.path, run.scene.faces, run.embree_rate

    def measure(method):
        m = run.measure(method)
        m["leaves_per_ray"] = m.pop("steps_per_ray")
        return m

    rows = [dict(accel="tetwalk", **measure("exact"))]
    for depth in depths:
        for leaf_size in leaf_sizes:
            for balance in (True, False):
                t0 = time.perf_counter()
                info = scene.build_octree(max_depth=depth, leaf_size=leaf_size, balance=balance)
                built = time.perf_counter() - t0
                rows.append(
                    dict(
                        accel="portalez_octree", build_s=built, **info, **measure("portalez_octree")
                    )
                )
    out(
        f"Octree: {path.split('/')[-1]} ({len(f):,} triangles), {res}x{res} float32 camera, "
        f"one thread, best of {repeat}; embreex {embree_rate:.2f} Mrays/s; MB per part as "
        "Portalez & Duguet's Table 4; 'leaves/ray': leaves visited (tet walk: tets)"
    )

    def mb(r, key):
        return f"{r[key] / 1e6:.1f}" if key in r else "-"

    table = [
        [
            r["accel"],
            r.get("max_depth", "-"),
            r.get("leaf_size", "-"),
            {True: "2:1", False: "off"}.get(r.get("balance"), "-"),
            f"{r['build_s']:.2f}" if "build_s" in r else "-",
            r.get("leaves", "-"),
            f"{r['neighbours_per_leaf']:.2f}" if "neighbours_per_leaf" in r else "-",
            f"{r['triangles_per_leaf']:.2f}" if "triangles_per_leaf" in r else "-",
            mb(r, "bytes_cube_map"),
            mb(r, "bytes_octree"),
            mb(r, "bytes_triangles"),
            mb(r, "bytes_boxes"),
            mb(r, "bytes_hierarchy"),
            mb(r, "bytes"),
            f"{r['mrays_per_s']:.2f}",
            f"{r['ratio_to_embree']:.2f}",
            f"{r['leaves_per_ray']:.1f}",
            f"{r['right'] * 100:.3f}%",
        ]
        for r in rows
    ]
    header = [
        "accel",
        "max depth",
        "leaf size",
        "balance",
        "build s",
        "leaves",
        "neighbours/leaf",
        "tris/leaf",
        "cube map MB",
        "octree MB",
        "triangles MB",
        "boxes MB",
        "hierarchy MB",
        "total MB",
        "Mrays/s",
        "x embreex",
        "leaves/ray",
        "right (referee)",
    ]
    out(_table(table, header))
    return rows


def octree_main(argv):
    """Command line of ``python -m tetrace.bench octree``."""
    p = argparse.ArgumentParser(prog="python -m tetrace.bench octree", description=__doc__)
    p.add_argument("scene", nargs="?", default=None, help="mesh file (default: the bundled scene)")
    p.add_argument("--res", type=int, default=512)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--depths", default=",".join(map(str, DEPTHS)))
    p.add_argument("--leaf-sizes", default=",".join(map(str, LEAF_SIZES)))
    args = p.parse_args(argv)
    run_octree_stats(
        args.scene,
        res=args.res,
        repeat=args.repeat,
        depths=[int(x) for x in args.depths.split(",")],
        leaf_sizes=[int(x) for x in args.leaf_sizes.split(",")],
    )
    return 0
