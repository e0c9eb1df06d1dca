"""Command line of the benchmarks (see ``python -m tetrace.bench --help``)."""

import argparse
import sys

from .scene_bench import run_scene_bench


def agreement_main(argv):
    from .agreement import run_agreement

    p = argparse.ArgumentParser(prog="python -m tetrace.bench agreement",
                                description="Agreement with embreex on the acceptance rays.")
    p.add_argument("scenes", nargs="*", help="mesh files (default: the bundled scene)")
    p.add_argument("--res", type=int, default=1024)
    p.add_argument("--random", type=int, default=100_000)
    args = p.parse_args(argv)
    run_agreement(args.scenes or [None], res=args.res, n_random=args.random)
    return 0


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["agreement"]:
        return agreement_main(argv[1:])
    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench",
        description="Full-scene benchmark: a pinhole camera cast by tetrace and by embreex on "
                    "the same rays, with build times, structure size and hit agreement. "
                    "'python -m tetrace.bench agreement [mesh ...]' reports agreement on the "
                    "acceptance rays instead.",
    )
    p.add_argument("scene", nargs="?", default=None,
                   help="mesh file (default: the bundled scene, Spot)")
    p.add_argument("--preset", default="quality", help="meshing preset (default: quality)")
    p.add_argument("--width", type=int, default=1024)
    p.add_argument("--height", type=int, default=1024)
    p.add_argument("--repeat", type=int, default=3, help="timed repetitions; the best is kept")
    p.add_argument("--distance", type=float, default=1.6,
                   help="camera distance from the scene centre, in bounding radii")
    p.add_argument("--image", default=None, help="write a shaded PNG of the camera's hits here")
    p.add_argument("--json", default=None, help="also write the results as JSON here")
    args = p.parse_args(argv)
    run_scene_bench(args.scene, preset=args.preset, width=args.width, height=args.height,
                    repeat=args.repeat, distance=args.distance, image=args.image,
                    json_path=args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
