"""``mesher="auto"``: the cheapest tetrahedralization that meets an accuracy target.

Lagae & Dutre (2008) found render time roughly proportional to a tetrahedralization's
*weight*, the total area of its faces (by Crofton's formula the number of faces a
random line crosses is proportional to it). Nobody had used it to *build* CTs; here it
ranks candidate settings the way SAH ranks BVH splits:

1. The exact route first (TetGen): the radius-edge ladder :data:`AUTO_RATIOS`, from the
   default bound upwards while the weight stays within ``tolerance`` of the lowest seen
   (and on to no refinement, ``"constrained"``, if it still does at the loosest bound),
   then downwards while it keeps falling. Its constrained faces are pieces of the
   caller's triangles, so its accuracy is 1 unless the scene had to be repaired or
   snap-rounded; then it is measured.
2. If no exact candidate meets the target (TetGen failed, or snap rounding moved the
   surface too far), fTetWild's envelopes :data:`AUTO_EPSILONS`, coarsest (fewest tets)
   first, until one meets it.
3. Of the candidates that meet the target, those whose weight is within ``tolerance``
   of the lowest count as equally fast (``python -m tetrace.bench matrix`` charts weight
   against measured time; spot's bounds 3 and 5 differ by 1.5% in weight and not
   measurably in time), and the one with the fewest tets wins: less memory, faster build.

Accuracy is measured on random rays in and around the scene against Embree on the
caller's mesh (embreex): the fraction with the same hit/miss outcome and the same
triangle or a hit point within :data:`HIT_DISTANCE` of the diagonal.

The domain stays the scene's bounding box plus ``margin``, grown only to ``contain``
the ray origins the caller names.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import MeshingError
from ..io import load_triangles
from ..progress import counter

#: Radius-edge bounds tried on the exact route, in order: the default first, then
#: looser (fewer tets), then tighter (lower weight on some scenes).
AUTO_RATIOS = (5.0, 7.0, 10.0, 14.0, 20.0, 3.0, 2.0)
#: fTetWild envelopes tried when no exact candidate meets the target, coarsest first.
AUTO_EPSILONS = (3e-3, 1e-3, 3e-4)
#: Default accuracy target: agreement with Embree on the caller's mesh.
DEFAULT_ACCURACY = 0.999
#: Candidates whose weight is within this fraction of the lowest count as equally fast.
WEIGHT_TOLERANCE = 0.10
#: Random rays the accuracy of an inexact candidate is measured on.
ACCURACY_RAYS = 20_000
#: A hit on another triangle still agrees when it lies within this fraction of the
#: diagonal of Embree's hit point: the remeshed surface of fTetWild lies within its
#: envelope (1e-3 by default) of the input, so a ray can cross it where the input has
#: another triangle (a hit names the one it crosses among the face's nearest triangle
#: and that triangle's neighbours).
HIT_DISTANCE = 1e-3


def _exact(tz) -> bool:
    return tz.mesher == "tetgen" and not tz.repaired and not tz.snap


def auto_tetrahedralize(
    mesh,
    *,
    build,
    measure=None,
    accuracy=DEFAULT_ACCURACY,
    tolerance=WEIGHT_TOLERANCE,
    margin=0.02,
    contain=None,
    timeout=None,
    rays=ACCURACY_RAYS,
    seed=0,
):
    """Build the candidate settings and keep the cheapest that meets ``accuracy``.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or os.PathLike or tuple
        Anything :func:`tetrace.io.load_triangles` takes.
    build : callable
        ``build((vertices, faces), **settings)`` meshes one setting
        (:func:`tetrace.mesh.tetrahedralize`, which passes itself).
    measure : callable, optional
        ``measure(tz, vertices, faces, rays=, seed=)``: the accuracy of an inexact candidate
        (:meth:`tetrace.Scene.from_mesh` passes
        :func:`tetrace.accuracy.measure_accuracy` with the ``Scene`` class,
        agreement with Embree). Without it, inexact candidates are not measured and cannot
        be chosen.
    accuracy : float
        Target in (0, 1]: the fraction of random rays that must agree with Embree on
        the caller's mesh (see :func:`measure_accuracy`).
    tolerance : float
        Weights within this fraction of the lowest count as equally fast.
    margin, contain, timeout
        As in :func:`tetrace.mesh.tetrahedralize`.
    rays, seed : int
        Rays the accuracy of inexact candidates is measured on.

    Returns
    -------
    tetrace.mesh.Tetrahedralization
        The chosen one; its ``auto`` dict has the target, the tolerance, the chosen
        ``setting`` and every ``candidate`` (setting, tets, weight, accuracy, seconds,
        or the error that stopped it).

    Raises
    ------
    ValueError
        ``accuracy`` not in (0, 1] or ``tolerance`` negative.
    tetrace.MeshingError
        No candidate meets the target; the message gives the best accuracy reached.
    """
    if not (0.0 < float(accuracy) <= 1.0):
        raise ValueError(f"accuracy must be in (0, 1], got {accuracy!r}")
    if not (float(tolerance) >= 0.0):
        raise ValueError(f"tolerance must be >= 0, got {tolerance!r}")
    t_start = time.perf_counter()
    v, f = load_triangles(mesh)
    built = []  # (row, tetrahedralization or None)

    def attempt(setting, **kwargs):
        t0 = time.perf_counter()
        row = dict(setting=setting)
        candidates.set_postfix_str(setting)
        candidates.update()
        try:
            tz = build((v, f), margin=margin, contain=contain, timeout=timeout, **kwargs)
        except MeshingError as exc:
            row.update(error=str(exc), seconds=time.perf_counter() - t0)
            built.append((row, None))
            return None
        row.update(
            mesher=tz.mesher,
            tets=int(len(tz.tets)),
            weight=tz.weight(),
            repaired=bool(tz.repaired),
            snap=float(tz.snap),
        )
        if _exact(tz):
            row["accuracy"] = 1.0
        else:
            if measure is None:
                row.update(
                    accuracy=None,
                    error="accuracy not measured: no measure given "
                    "(Scene.from_mesh measures against Embree)",
                )
            else:
                try:
                    row["accuracy"] = measure(tz, v, f, rays=rays, seed=seed)
                except ImportError as exc:
                    row.update(accuracy=None, error=f"accuracy not measured: {exc}")
        row["seconds"] = time.perf_counter() - t0
        built.append((row, tz))
        return row

    def meets(row):
        return row is not None and row.get("accuracy") is not None and row["accuracy"] >= accuracy

    def lowest_weight():
        return min((r["weight"] for r, t in built if t is not None and meets(r)), default=np.inf)

    most = len(AUTO_RATIOS) + 1 + len(AUTO_EPSILONS)
    with counter("mesher='auto': candidates", total=most) as candidates:
        _search(attempt, meets, lowest_weight, built, tolerance)
    return _choose(built, meets, accuracy, tolerance, t_start)


def _search(attempt, meets, lowest_weight, built, tolerance):
    """Build the candidates: the radius-edge ladder, then fTetWild's envelopes if needed."""
    first = attempt("quality", preset="quality", mesher="tetgen")
    if first is not None:
        up = [r for r in AUTO_RATIOS if r > 5.0]
        down = [r for r in AUTO_RATIOS if r < 5.0]
        for ratio in up:
            row = attempt(f"quality{ratio:g}", preset=f"quality{ratio:g}", mesher="tetgen")
            if row is None or row["weight"] > (1.0 + tolerance) * lowest_weight():
                break
        else:
            # Still as light at the loosest bound (boxy scenes such as cornell_box):
            # no refinement at all may be lighter yet.
            attempt("constrained", preset="constrained", mesher="tetgen")
        previous = first["weight"]
        for ratio in down:
            row = attempt(f"quality{ratio:g}", preset=f"quality{ratio:g}", mesher="tetgen")
            if row is None or row["weight"] >= previous:
                break
            previous = row["weight"]
    if not any(meets(r) for r, _ in built):
        for eps in AUTO_EPSILONS:
            if meets(attempt(f"ftetwild{eps:g}", mesher="ftetwild", epsilon=eps)):
                break


def _choose(built, meets, accuracy, tolerance, t_start):
    """The candidate with the fewest tets among those that meet the target at a near-lowest
    weight."""
    ok = [(r, t) for r, t in built if t is not None and meets(r)]
    if not ok:
        best = max((r.get("accuracy") or 0.0 for r, _ in built), default=0.0)
        reasons = "; ".join(f"{r['setting']}: {r['error']}" for r, _ in built if "error" in r)
        raise MeshingError(
            f"mesher='auto': no setting reached accuracy {accuracy:g} "
            f"(best {best:.6f}){'; ' + reasons if reasons else ''}"
        )
    w_min = min(r["weight"] for r, _ in ok)
    near = [(r, t) for r, t in ok if r["weight"] <= (1.0 + tolerance) * w_min]
    row, tz = min(near, key=lambda rt: (rt[0]["tets"], rt[0]["weight"]))
    tz.auto = dict(
        accuracy=float(accuracy),
        tolerance=float(tolerance),
        setting=row["setting"],
        seconds=time.perf_counter() - t_start,
        candidates=[r for r, _ in built],
    )
    tz.timings["auto"] = tz.auto["seconds"]
    return tz
