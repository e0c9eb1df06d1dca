"""Casting a case with any method and judging every ray against the referee."""

import numpy as np

# --------------------------------------------------------------------------- casting, judging

#: What is counted per family x method x layout x precision (a ray counts in each that holds):
#: ``late``, ``leaked``, ``failed``, ``wrong`` (the referee's judgement: exactly one or none
#: per ray), ``fabricated`` (the part of ``wrong`` where the caster reports a hit and the
#: referee has none: a hit made up, e.g. on a triangle whose plane holds the line; the
#: referee's ``phantom``) and the audit's ``wrong_exit`` and ``no_exit``.
OUTCOMES = ("late", "leaked", "failed", "wrong", "fabricated", "wrong_exit", "no_exit")


def build_scene(case, **kw):
    """The :class:`tetrace.Scene` of a stress case (domain grown to its origins if asked)."""
    from ...scene import Scene

    contain = np.vstack([case.origins, case.origins + 1e-9]) if case.contain else None
    scene = Scene.from_mesh((case.vertices, case.faces), contain=contain, margin=case.margin, **kw)
    if case.domain is not None and not np.array_equal(scene.domain, case.domain):
        raise AssertionError(
            f"{case.family}: the scene's domain {scene.domain.tolist()} is not "
            f"the box the rays aim at {case.domain.tolist()}"
        )
    return scene


def audited_cast(
    scene,
    origins,
    directions,
    *,
    tmin=0.0,
    tmax=np.inf,
    method=None,
    layout=None,
    precision="f64",
    threads=None,
    max_steps=None,
):
    """Cast with the exact per-step audit (the core's ``audit=True``, a developer's check that
    ``tetrace.Scene`` does not offer: its flat rays go straight to the core).

    Returns
    -------
    hits : Hits
    audit : numpy.ndarray
        ``(N, 2)`` uint32 per ray: exit faces taken that the line does not leave by (decided
        with exact orientation predicates on the points the walk read), and steps where the
        method's own tests found no exit face.
    """
    from ...hits import Hits
    from ...rays import RayRequest

    dt = np.float32 if precision == "f32" else np.float64
    q = RayRequest(
        np.ascontiguousarray(origins, dtype=dt),
        np.ascontiguousarray(directions, dtype=dt),
        tmin=tmin,
        tmax=tmax,
        threads=threads,
        max_steps=max_steps,
        method=method,
        layout=layout,
        invalid="mark",
        audit=True,
    )
    # The audit observes the tet walk: the tetrahedralization is built if it is not yet.
    r = q.run(scene._core(q), "closest", "casting")
    audit = r.pop("audit")
    return Hits.from_core(r, scene._normal_rows(dt), scene.geometries, threads=threads), audit


def judge_cast(hits, audit, verdict):
    """Masks of :data:`OUTCOMES` (plus ``right`` and the parts of ``wrong``) for a cast,
    against the referee's verdict of the same rays (``tetrace.referee.judge``: tetrace
    evaluates ``t`` in float64 on the caller's triangle in both precisions)."""
    from ...referee import judge

    j = judge(hits, verdict)
    j["fabricated"] = j["phantom"]
    j["wrong_exit"] = audit[:, 0] > 0
    j["no_exit"] = audit[:, 1] > 0
    return j


def cast_case(case, scene, method, layout, precision, *, verdict=None, threads=None):
    """Cast a case's rays with the audit and judge them: ``(hits, audit, masks)``.

    The verdict defaults to the one :func:`certify` computed; without one the referee computes
    it with the cast's triangles as the hint (it only speeds the search up)."""
    o, d = case.rays(precision)
    h, audit = audited_cast(
        scene,
        o,
        d,
        tmin=case.tmin,
        tmax=case.tmax,
        method=method,
        layout=layout,
        precision=precision,
        threads=threads,
    )
    if verdict is None:
        verdict = case.verdicts.get(precision)
    if verdict is None:
        from ...referee import Referee

        verdict = Referee(case.vertices, case.faces).first_hits(
            o, d, case.tmin, case.tmax, hint=h.triangle
        )
    return h, audit, judge_cast(h, audit, verdict)


def count(masks):
    """Counts of :data:`OUTCOMES` (and ``rays``, ``right``) from :func:`judge_cast`'s masks (or
    ``tetrace.referee.judge``'s, whose ``phantom`` is ``fabricated``)."""
    out = {"rays": len(masks["right"]), "right": int(masks["right"].sum())}
    for k in OUTCOMES:
        m = masks[k] if k in masks or k != "fabricated" else masks["phantom"]
        out[k] = int(m.sum())
    return out


def examples(case, hits, masks, verdict, outcome, k=3):
    """Up to ``k`` rays in ``outcome``, as dicts (kind, origin, direction, tmin, tmax, the cast's
    status/triangle/t and the referee's hit/t/tie set) for reports."""
    out = []
    for i in np.flatnonzero(masks[outcome])[:k]:
        out.append(
            dict(
                i=int(i),
                kind=str(case.kind[i]),
                o=case.origins[i].tolist(),
                d=case.directions[i].tolist(),
                tmin=float(case.tmin[i]),
                tmax=float(case.tmax[i]),
                status=int(hits.status[i]),
                triangle=int(hits.triangle[i]),
                t=float(hits.t[i]),
                ref_hit=bool(verdict.hit[i]),
                ref_t=float(verdict.t[i]),
                ties=verdict.tie_set(i).tolist(),
            )
        )
    return out
