"""Command line of the benchmarks (see ``python -m tetrace.bench --help``)."""

import argparse
import difflib
import importlib
import os
import sys
import textwrap

from .scene_bench import run_scene_bench


def agreement_main(argv):
    from .agreement import run_agreement

    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench agreement",
        description="tetrace and embreex judged by the exact referee on the acceptance rays.",
    )
    p.add_argument("scenes", nargs="*", help="mesh files (default: the bundled scene)")
    p.add_argument("--res", type=int, default=1024)
    p.add_argument("--random", type=int, default=100_000)
    args = p.parse_args(argv)
    run_agreement(args.scenes or [None], res=args.res, n_random=args.random)
    return 0


def scenes_main(argv):
    from .scenes import default_scenes_dir, run_scenes, scene_files

    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench scenes",
        description="Build every shared scene (mesher fallback: TetGen exact, snap-rounded, "
        "then fTetWild) and compare camera and random rays with embreex: one row "
        "per scene (mesher, tets, build seconds, agreement).",
    )
    p.add_argument("scenes", nargs="*", help="mesh files (default: every mesh in --dir)")
    p.add_argument(
        "--dir", default=None, help="scenes folder (default: $TETRACE_SCENES or ../shared/scenes)"
    )
    p.add_argument(
        "--mesher", default="fallback", choices=["tetgen", "ftetwild", "fallback", "auto"]
    )
    p.add_argument(
        "--accuracy",
        type=float,
        default=None,
        help="mesher auto: agreement with Embree to reach (default 0.999)",
    )
    p.add_argument("--preset", default="quality")
    p.add_argument(
        "--epsilon", type=float, default=None, help="fTetWild envelope (of the diagonal)"
    )
    p.add_argument("--res", type=int, default=512, help="camera resolution (3 views)")
    p.add_argument("--random", type=int, default=100_000, help="random rays")
    p.add_argument(
        "--timeout",
        type=float,
        default=None,
        help="seconds per meshing stage (default: grows with the scene)",
    )
    p.add_argument("--json", default=None, help="also write the rows as JSON here")
    args = p.parse_args(argv)
    paths = args.scenes or scene_files(args.dir or default_scenes_dir())
    run_scenes(
        paths,
        mesher=args.mesher,
        preset=args.preset,
        res=args.res,
        n_random=args.random,
        timeout=args.timeout,
        epsilon=args.epsilon,
        accuracy=args.accuracy,
        json_path=args.json,
    )
    return 0


def gpu_main(argv):
    from .gpu_bench import run_gpu_bench, save_scenes

    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench gpu",
        description="The GPU cast numpy to numpy, phase by phase, on saved scenes: a pinhole "
        "camera and random rays per scene; kernel Grays/s, Mrays/s numpy to numpy, host ns "
        "per ray (the call less the kernel), the share handed back to the CPU, the exact "
        "referee on a sample, and the CPU exact walk and embreex on every core. A machine "
        "lent with a GPU has no mesher: --save writes .tetrace files where one is installed.",
    )
    p.add_argument(
        "scenes", nargs="*", help=".tetrace files, or meshes (default: the bundled scene)"
    )
    p.add_argument("--width", type=int, default=1920)
    p.add_argument("--height", type=int, default=1440)
    p.add_argument("--random", type=int, default=1_000_000, help="random rays (0: none)")
    p.add_argument("--sample", type=int, default=100_000, help="rays the referee judges")
    p.add_argument("--repeat", type=int, default=3, help="timed casts; the best is kept")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--preset", default="quality", help="meshing preset for mesh files")
    p.add_argument("--json", default=None, help="also write the rows as JSON here")
    p.add_argument(
        "--check",
        action="store_true",
        help="exit with status 1 when the referee finds a ray not right (CI's smoke run)",
    )
    p.add_argument(
        "--save",
        default=None,
        metavar="DIR",
        help="mesh the scenes and write them to DIR as .tetrace files instead of benching",
    )
    p.add_argument(
        "--stress",
        type=int,
        default=0,
        metavar="N",
        help="instead of benching, cast N certified rays of each stress family (needs a "
        "mesher) and print where each was answered, the handed-back share, whether every "
        "column is the CPU exact walk's and the referee's count",
    )
    args = p.parse_args(argv)
    if args.save:
        save_scenes(args.scenes, args.save, preset=args.preset)
        return 0
    if args.stress:
        from .gpu_bench import run_gpu_stress

        rows = run_gpu_stress(args.stress, seed=args.seed)
        bad = [r for r in rows if r["differ"] or r["right"] != r["rays"]]
        for r in bad:
            print(f"not the CPU's or not right: {r}", file=sys.stderr)
        return 1 if args.check and bad else 0
    results = run_gpu_bench(
        args.scenes,
        width=args.width,
        height=args.height,
        n_random=args.random,
        sample=args.sample,
        repeat=args.repeat,
        seed=args.seed,
        preset=args.preset,
        json_path=args.json,
    )
    bad = [r for r in results["rows"] if r["right"] != r["judged"]]
    for r in bad:
        print(f"not right: {r['scene']}, {r['rays']}: {r['not_right']}", file=sys.stderr)
    return 1 if args.check and bad else 0


def exitface_main(argv):
    from .. import _native
    from .scene_bench import _table

    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench exitface",
        description="Exit-face micro-benchmark (after Maria et al. 2017, Table 5): random tets, "
        "random rays stabbing them, ns per exit-face decision, one thread.",
    )
    p.add_argument("--tets", type=int, default=10_000)
    p.add_argument("--rays-per-tet", type=int, default=16)
    p.add_argument("--repeat", type=int, default=5, help="passes; the best is kept")
    p.add_argument("--seed", type=int, default=1)
    args = p.parse_args(argv)
    rows = _native.exitface_bench(args.tets, args.rays_per_tet, args.seed, args.repeat)
    n = args.tets * args.rays_per_tet
    print(
        f"exit-face decisions: {args.tets:,} random tets x {args.rays_per_tet} rays = {n:,} "
        f"decisions per method, best of {args.repeat}, one thread"
    )
    print(
        _table(
            [[m, p, f"{ns:.2f}", f"{wrong}"] for m, p, ns, wrong in rows],
            ["method", "precision", "ns/decision", "not an exact exit face"],
        )
    )
    return 0


def stability_main(argv):
    from .stability import run_stability

    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench stability",
        description="Outcomes of every method on the stress families.",
    )
    p.add_argument("--rays", type=int, default=20_000, help="rays per family")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--family", action="append", default=None, help="stress family (repeatable; default: all)"
    )
    p.add_argument(
        "--method", action="append", default=None, help="exit method (repeatable; default: all)"
    )
    p.add_argument(
        "--layout",
        action="append",
        default=None,
        help="tet layout (repeatable, or 'all'; default: the default layout)",
    )
    p.add_argument("--precision", choices=["f32", "f64", "both"], default="both")
    p.add_argument("--json", default=None, help="also write the rows as JSON here")
    args = p.parse_args(argv)
    from .. import _native

    layouts = args.layout or [_native.DEFAULT_LAYOUT]
    if layouts == ["all"]:
        layouts = [name for name, _ in _native.layouts()]
    precisions = ["f32", "f64"] if args.precision == "both" else [args.precision]
    run_stability(
        args.rays, args.seed, args.family, args.method, layouts, precisions, json_path=args.json
    )
    return 0


def queries_main(argv):
    import json

    from .queries import run_queries

    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench queries",
        description="Every query kind (closest, any, all hits, counts, containment) timed "
        "against embreex and Open3D (closest hits also against warp-lang and mitsuba) on the "
        "same float32 rays, and judged ray by ray by the exact referee, on the scene and on "
        "the stress families.",
    )
    p.add_argument("scene", nargs="?", default=None, help="mesh file (default: the bundled scene)")
    p.add_argument("--res", type=int, default=256, help="camera resolution")
    p.add_argument("--random", type=int, default=20_000, help="random rays and points")
    p.add_argument("--repeat", type=int, default=3, help="timed repetitions; the best is kept")
    p.add_argument(
        "--stress", type=int, default=300, help="rays per stress family judged (0: none)"
    )
    p.add_argument("--json", default=None, help="also write the rows as JSON here")
    args = p.parse_args(argv)
    rows = run_queries(
        args.scene, res=args.res, n_random=args.random, repeat=args.repeat, stress=args.stress
    )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


def _lazy(module, function):
    """The ``main(argv)`` of a subcommand in another module, imported when it runs (each
    pulls in its own peers and scenes)."""

    def run(argv):
        return getattr(importlib.import_module(f"{__package__}.{module}"), function)(argv)

    return run


#: Every subcommand: name -> (one line for ``--help``, its ``main(argv)``). The dispatch and
#: the help both read this table, so a subcommand cannot run without being listed.
SUBCOMMANDS = {
    "agreement": (
        "tetrace and embreex judged by the exact referee on the acceptance rays",
        agreement_main,
    ),
    "bvh": (
        "Reshetov's BVH and its packets: SAH-ratio sweep, tree size against speed",
        _lazy("bvh", "bvh_main"),
    ),
    "dask": (
        "casting throughput on a Dask LocalCluster of 1, 2, ... worker processes",
        _lazy("dask_scale", "dask_main"),
    ),
    "deform": (
        "moving the tetrahedralization over N frames against re-meshing and embreex",
        _lazy("deform", "deform_main"),
    ),
    "distance": (
        "t against its exact value as the origin moves away (1e0..1e8), every accelerator",
        _lazy("distance", "distance_main"),
    ),
    "exitface": (
        "exit-face micro-benchmark: ns per exit-face decision on random tets",
        exitface_main,
    ),
    "first": (
        "time to first answers: from_mesh and one cast in a fresh process, against embreex",
        _lazy("first_answer", "first_main"),
    ),
    "gpu": (
        "the GPU cast numpy to numpy, phase by phase, on saved scenes, beside CPU and embreex",
        gpu_main,
    ),
    "growth": (
        "local complexity: one object and one camera in ever bigger worlds",
        _lazy("growth", "growth_main"),
    ),
    "matrix": (
        "speed against accuracy: scenes x meshers x methods x layouts x precisions",
        _lazy("matrix", "matrix_main"),
    ),
    "octree": (
        "Portalez & Duguet's octree, with and without 2:1 balance, beside the walk",
        _lazy("octree", "octree_main"),
    ),
    "occupancy": (
        "inside/outside of a scan with holes: tetrace's winding number against trimesh and Open3D",
        _lazy("occupancy", "occupancy_main"),
    ),
    "queries": (
        "every query kind timed against the peers and judged by the exact referee",
        queries_main,
    ),
    "scenes": (
        "build every shared scene; mesher, tets, build time, agreement with embreex",
        scenes_main,
    ),
    "secondary": (
        "shadow and bounce rays from a camera's hits (start=hits) against relocating",
        _lazy("secondary", "secondary_main"),
    ),
    "stability": ("outcomes of every method on the stress families", stability_main),
}

_DESCRIPTION = (
    "Full-scene benchmark: a pinhole camera cast by tetrace, by embreex and by the peers "
    "that import (Open3D, warp-lang, mitsuba scalar_rgb and llvm_ad_rgb) on the same rays, "
    "with build times, structure size and hit agreement. A subcommand runs another "
    "benchmark instead."
)


def _epilog():
    width = max(len(name) for name in SUBCOMMANDS)
    lines = [f"  {name:<{width}}  {line}" for name, (line, _) in SUBCOMMANDS.items()]
    return "\n".join(
        ["subcommands (python -m tetrace.bench SUBCOMMAND --help for their options):", *lines]
    )


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] and argv[0] in SUBCOMMANDS:
        return SUBCOMMANDS[argv[0]][1](argv[1:])
    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench",
        usage="%(prog)s SUBCOMMAND [options]\n       %(prog)s [options] [scene]",
        description="\n".join(textwrap.wrap(_DESCRIPTION, 88)),
        epilog=_epilog(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "scene", nargs="?", default=None, help="mesh file (default: the bundled scene, Spot)"
    )
    p.add_argument("--preset", default="quality", help="meshing preset (default: quality)")
    p.add_argument("--width", type=int, default=1024)
    p.add_argument("--height", type=int, default=1024)
    p.add_argument("--repeat", type=int, default=3, help="timed repetitions; the best is kept")
    p.add_argument(
        "--distance",
        type=float,
        default=1.6,
        help="camera distance from the scene centre, in bounding radii",
    )
    p.add_argument(
        "--rays",
        choices=["camera", "random"],
        default="camera",
        help="camera: the pinhole camera (default); random: width x height rays from "
        "anywhere in the grown scene box in any direction",
    )
    p.add_argument("--image", default=None, help="write a shaded PNG of the camera's hits here")
    p.add_argument("--json", default=None, help="also write the results as JSON here")
    p.add_argument(
        "--method",
        action="append",
        default=None,
        help="exit method, or an accelerator (one of tetrace.accels() but 'tetwalk': exact "
        "answers from a BVH, its packets or an octree) "
        "(repeatable, or 'all'; default: the default method)",
    )
    p.add_argument(
        "--layout",
        action="append",
        default=None,
        help="tet layout (repeatable, or 'all'; default: the default layout)",
    )
    p.add_argument("--precision", choices=["f32", "f64", "both"], default="both")
    p.add_argument(
        "--order",
        choices=["hilbert", "mesher", "both"],
        default="hilbert",
        help="point/tet order: Hilbert within regions, TetGen's, or both",
    )
    p.add_argument("--threads", choices=["1", "all", "both"], default="both")
    p.add_argument(
        "--device",
        choices=["cpu", "gpu", "both"],
        default="cpu",
        help="cpu: the CPU walks (default); gpu: only the GPU kernels (kernel "
        "Mrays/s, upload and readback timed apart); both",
    )
    args = p.parse_args(argv)
    scene = args.scene
    if scene is not None and not os.path.exists(scene) and not os.path.splitext(scene)[1]:
        # A word that is no file and has no extension is a mistyped subcommand, not a mesh.
        near = difflib.get_close_matches(scene, SUBCOMMANDS, n=1)
        hint = f"did you mean {near[0]!r}? " if near else ""
        p.error(
            f"{scene!r} is neither a subcommand nor a mesh file; {hint}"
            f"subcommands: {', '.join(SUBCOMMANDS)}"
        )
    both = lambda x, pair: pair if x == "both" else (x,)
    run_scene_bench(
        args.scene,
        preset=args.preset,
        width=args.width,
        height=args.height,
        repeat=args.repeat,
        distance=args.distance,
        image=args.image,
        json_path=args.json,
        methods=args.method,
        layouts=args.layout,
        precisions=both(args.precision, ("f32", "f64")),
        orders=both(args.order, ("hilbert", "mesher")),
        threads=both(args.threads, ("1", "all")),
        devices=both(args.device, ("cpu", "gpu")),
        rays=args.rays,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
