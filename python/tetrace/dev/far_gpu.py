"""The far-origin GPU check for a machine without a mesher (``docs/gpu.md``, issue 32).

``python -m tetrace.dev.far_gpu SCENE.tetrace``: on a saved scene (made elsewhere with
``Scene.save``), 20,000 float32 rays per distance from 1e2 to 1e8, each aimed at a random
point of a random triangle, cast on the GPU; prints per distance the hits, the rays whose
first hit is not right (the GPU's float walk) and the hits whose ``t``, ``u``, ``v`` or
point is more than an ulp from its exact value (the CPU's finishing), all judged by the
exact referee.
"""

import sys

import numpy as np


def main(argv=None):
    import tetrace
    from tetrace.bench.distance import aimed_rays
    from tetrace.referee import Referee, judge, judge_values

    argv = sys.argv[1:] if argv is None else argv
    scene = tetrace.Scene.load(argv[0] if argv else "out/ball.tetrace")
    v, f = np.asarray(scene.vertices, float), np.asarray(scene.faces, np.int64)
    ref = Referee(v, f)
    print("adapter:", tetrace.gpu.device())
    for r in (1e2, 1e4, 1e6, 1e8):
        n = 20000
        o, d = aimed_rays(np.random.default_rng(int(np.log10(r))), v, f, r, n)
        o, d = o.astype(np.float32), d.astype(np.float32)
        h = scene.cast(o, d, device="gpu")
        j = judge(h, ref.first_hits(o, d))
        hit = np.asarray(h.status) == tetrace.HIT
        off = judge_values(h, ref.hit_values(o, d, np.where(hit, h.triangle, -1)))
        print(
            f"R={r:g}: {n} rays, {int(hit.sum())} hits, not right {int((~j['right']).sum())}, "
            f"t_off {int(j['t_off'].sum())}, u/v/point off {int(off['u_off'].sum())}/"
            f"{int(off['v_off'].sum())}/{int(off['point_off'].sum())}",
            flush=True,
        )


if __name__ == "__main__":
    main()
