"""Closest hits on real scenes, judged by the exact referee (docs/referee.md).

For each scene: three orbit views of 256x256 camera rays and 10^5 random rays (origins in and
around the domain, uniform directions), cast with every exit method x layout x precision, and
by Embree. Each ray is right when its hit/miss, triangle (up to the exact tie set) and t
(within ulp + the float64 forward error bound) are what exact arithmetic gives for the numbers
passed in; there is no edge band and no excuse.

* Every method: no ray FAILED, and at least 99.9% right (the foundation's acceptance figure).
* float64 walks, every method (the default and ``robust`` among them): every ray right.
* float32 walks: counts printed (-s) and recorded by ``python -m tetrace.bench agreement``, not
  bounded by a number from a run. Every float32 walk walks the mesh rounded to float32, so even
  ``robust`` (exact on the points it is given) can answer for the rounded scene rather than the
  one passed in; ``test_robust_f32_answers_for_the_scene_passed_in`` pins one such ray as a
  strict xfail. That is robust's design (docs/robust_walk.md); the default exact walk reads the
  float64 points whatever the rays' precision and answers for the scene passed in.
* Embree's own answers are judged the same way and printed; they are not asserted on (it is
  the peer, not the code under test), but they must be judged on the same rays.
"""

import numpy as np
import pytest

import tetrace
from tetrace.baselines.embree import embree_scene
from tetrace.bench.agreement import ray_sets
from tetrace.dev.compare import agreement
from tetrace.referee import Referee

SCENES = ["bunny.obj", "armadillo.obj", "torus_knots_27.obj", "cornell_box.obj"]
RES = 256
N_RANDOM = 100_000


def combos():
    """Every method x layout x precision that exists (tet80 stores float32 vertices)."""
    return [
        (m, lay, p)
        for m in tetrace.methods()
        for lay in tetrace.layouts()
        for p in ("f32", "f64")
        if not (lay == "tet80" and p == "f64")
    ]


def _check(scene, name):
    bounds = np.array([scene.vertices.min(0), scene.vertices.max(0)])
    ref_scene = embree_scene((scene.vertices, scene.faces))
    referee = Referee(scene.vertices, scene.faces)
    failures = []
    for kind, o, d in ray_sets(bounds, RES, N_RANDOM):
        verdicts = {}
        for method, layout, precision in combos():
            dtype = np.float32 if precision == "f32" else np.float64
            o2, d2 = o.astype(dtype), d.astype(dtype)
            hits = scene.cast(o2, d2, method=method, layout=layout, precision=precision)
            assert hits.t.dtype == dtype
            if precision not in verdicts:
                # The referee judges the numbers cast: float32 rays are the rounded ones.
                verdicts[precision] = referee.first_hits(o2, d2, hint=hits.triangle)
                emb = ref_scene.cast(o2, d2)
                e = agreement(emb, verdicts[precision], arithmetic="f32")
                print(f"\nembree {name} {kind} {precision}: {e}")
                assert e.rays == len(o2)
            a = agreement(hits, verdicts[precision])
            msg = f"{name} {kind} {method}/{layout}/{precision}: {a}; rays {a.worst}"
            assert a.failed == 0, msg
            assert a.fraction >= 0.999, msg
            if a.bad:
                print(msg)
            if precision == "f64" and a.bad:
                failures.append(msg)
            assert (hits.status == tetrace.HIT).any(), msg
    assert not failures, "\n".join(failures)


def test_bundled_scene_agrees_with_referee(embree):
    _check(tetrace.default_scene(), "spot (bundled)")


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test_shared_scene_agrees_with_referee(name, scene_path, embree):
    _check(tetrace.Scene.from_mesh(scene_path(name)), name)


@pytest.mark.xfail(
    strict=True,
    reason="the float32 walk walks the mesh rounded to float32 "
    "(docs/robust_walk.md): exact for the rounded scene, not the one passed in",
)
def test_robust_f32_answers_for_the_scene_passed_in(scene_path):
    scene = tetrace.Scene.from_mesh(scene_path("bunny.obj"))
    bounds = np.array([scene.vertices.min(0), scene.vertices.max(0)])
    _, o, d = ray_sets(bounds, RES, 1)[2]  # view2: its ray 10259 is one such ray
    o, d = o[10259:10260].astype(np.float32), d[10259:10260].astype(np.float32)
    h = scene.cast(o, d, method="robust", precision="f32")
    a = agreement(h, Referee(scene.vertices, scene.faces).first_hits(o, d))
    assert a.right == 1, str(a)
