"""Stress families (``tetrace.dev.stress``) are what they say, and the robust walk is right on them.

Every family's rays are certified by the exact referee and by exact integer checks (through a
vertex, along an edge, in a face's plane, from a point on the surface, at tmin, through the
domain box's corners and edges ...); the tests below check each family's claim on the rays as
cast in each precision. Then every method is cast on every family in both precisions on the
default layout (and the robust walk on every layout) and judged by the referee: late, leaked,
failed (the step guard: a cycle), wrong, and the exact audit's wrong_exit and no_exit.

The robust walk must have none of them. Where it has some, the case is a strict xfail naming
the cause (``ROBUST_KNOWN``): it fails today, and the suite notices when it is fixed. The
other methods' counts, the default's first, are printed (``-s``) and recorded in the stability
bench's rows; the exact-default issue turns them into 0 assertions.
"""

import numpy as np
import pytest

import tetrace
from tetrace import _native
from tetrace.bench.stability import layouts_for, run_family
from tetrace.dev.stress import (
    EXACT_FAMILIES,
    FAMILIES,
    OUTCOMES,
    REAL_FAMILIES,
    SHARED_SCENES,
    audited_cast,
    build_scene,
    cases,
    cast_case,
    exact_in_plane,
    exact_through,
    make_case,
)
from tetrace.referee import Referee

N = 1_000  # candidate rays per family (21 families here: 21,000 rays per method and precision)
PRECISIONS = ("f32", "f64")
DEFAULT = (_native.DEFAULT_METHOD, _native.DEFAULT_LAYOUT)
#: The shared scene cast here (the bench also casts the bunny).
SHARED = "fandisk"
LOCAL = [f for f in FAMILIES if f not in SHARED_SCENES]

# -- where the robust walk is wrong today, and why --------------------------------------------

TOUCH = (
    "touching contacts: the exact line meets the surface at a vertex or edge without "
    "passing from one side to the other (along an edge; in a face's plane; at a vertex on "
    "an open surface's border). The referee counts the touch "
    "(closed triangles) and never an in-plane triangle; the robust walk follows its "
    "symbolically perturbed line, which passes the contact on one side (leaked, late) or "
    "crosses the in-plane triangle (wrong)"
)
START = (
    "starts on the surface: an origin exactly on a triangle with tmin = 0, or a crossing "
    "exactly at t = tmin, is a hit at tmin (closed interval); the robust walk starts at "
    "the perturbed point (settle_start) and never reports the triangle under its start "
    "(leaked, late)"
)
START32 = (
    "float32 start point: the float32 walk starts at fl32(o + tmin d), which for tmin = "
    "2^-40 or a crossing 2^-30 before tmin rounds back onto the surface; it reports the "
    "triangle there with t clamped to tmin though its crossing is before tmin (wrong)"
)
POINTS32 = (
    "float32 tetrahedralization: the float32 walk reads the tet points rounded to "
    "float32; at 1e7 the domain box corners and Steiner points are not float32 numbers "
    "and most tets become flat or inverted, so the walk leaves the line (late)"
)

#: (family, precision) -> (the ray kinds affected, or None for all; cause). Rays of other kinds
#: in the same family and precision are still asserted right (test_robust_is_right).
ROBUST_KNOWN = {
    **{(f, p): (None, TOUCH) for f in ("along_edges", "planes", "grazing") for p in PRECISIONS},
    **{("on_surface", p): (None, START) for p in PRECISIONS},
    ("on_surface_tmin", "f32"): (None, START32),
    ("tmin", "f32"): ({"tmin_at", "tmin_after"}, START + "; " + START32),
    ("tmin", "f64"): ({"tmin_at"}, START),
    ("far1e7", "f32"): (None, POINTS32),
    **{
        (f, p): (
            {"in_plane", "on_surface_vertex", "on_surface_edge", "on_surface_face"}
            | ({"edge"} if f == "fandisk" else set()),
            TOUCH + "; " + START,
        )
        for f in ("spot", "fandisk")
        for p in PRECISIONS
    },
}


def _bad(row, kinds=None, exclude=None):
    """Rays of ``row`` (a bench row) with any outcome, restricted to / excluding kinds."""
    n = 0
    for counts in row["bad_kinds"].values():
        for k, c in counts.items():
            if (kinds is None or k in kinds) and (exclude is None or k not in exclude):
                n += c
    return n


def _robust_cases(families):
    out = []
    for f in families:
        for p in PRECISIONS:
            kinds, cause = ROBUST_KNOWN.get((f, p), (set(), None))
            if kinds is None:
                marks = [pytest.mark.xfail(strict=True, reason=cause)]
            else:
                marks = []
            out.append(pytest.param(f, p, id=f"{f}-{p}", marks=marks))
    return out


def _known_cases(families):
    return [
        pytest.param(
            f,
            p,
            id=f"{f}-{p}",
            marks=[pytest.mark.xfail(strict=True, reason=ROBUST_KNOWN[f, p][1])],
        )
        for f in families
        for p in PRECISIONS
        if (f, p) in ROBUST_KNOWN and ROBUST_KNOWN[f, p][0] is not None
    ]


# -- casting everything once ------------------------------------------------------------------


def _run(case):
    rows = run_family(case, tetrace.methods(), [_native.DEFAULT_LAYOUT], PRECISIONS)
    others = [lay for lay in tetrace.layouts() if lay != _native.DEFAULT_LAYOUT]
    rows += run_family(case, ["robust"], others, PRECISIONS)
    return rows


@pytest.fixture(scope="module")
def local_cases():
    return {c.family: c for c in cases(N, seed=0, families=LOCAL)}


@pytest.fixture(scope="module")
def shared_case(scene_path):
    path = scene_path(SHARED_SCENES[SHARED])
    return make_case(SHARED, N, seed=0, path=path)


@pytest.fixture(scope="module")
def results(local_cases):
    return {c.family: _run(c) for c in local_cases.values()}


@pytest.fixture(scope="module")
def shared_results(shared_case):
    return {SHARED: _run(shared_case)}


def _row(rows, method, layout, precision):
    (r,) = [
        r for r in rows if (r["method"], r["layout"], r["precision"]) == (method, layout, precision)
    ]
    return r


# -- the families are what they say ---------------------------------------------------------


def test_families_are_reproducible():
    a = list(cases(100, seed=3, families=LOCAL))
    b = list(cases(100, seed=3, families=LOCAL))
    assert [c.family for c in a] == LOCAL
    for x, y in zip(a, b):
        for k in ("origins", "directions", "tmin", "tmax"):
            assert np.array_equal(getattr(x, k), getattr(y, k)), (x.family, k)
    # a family's rays do not depend on which other families are built
    (e,) = cases(100, seed=3, families=["edges"])
    assert np.array_equal(e.origins, a[LOCAL.index("edges")].origins)


def _kind_zs(case):
    """The zero_signs a ray's kind names (vertex 2, edge 1, face 0; -1: none)."""
    zs = np.full(len(case), -1)
    for name, k in (("vertex", 2), ("edge", 1), ("face", 0)):
        zs[np.char.find(case.kind.astype(str), name) >= 0] = k
    return zs


def _on_box(p, box, k):
    """Points with exactly ``k`` coordinates on the box's bounding planes, all inside it."""
    lo, hi = box
    on = (p == lo) | (p == hi)
    return ((p >= lo) & (p <= hi)).all(1) & (on.sum(1) == k)


def _claim(case, v):
    """Whether each ray is what its family says, from the referee's verdict ``v`` and exact
    checks, written here independently of the families' own per-ray claims where it can be."""
    f, kind, c = case.family, case.kind.astype(str), case.claims
    one = np.ones(len(case), bool)
    zs = _kind_zs(case)
    aimed = v.hit & (zs >= 0) & (v.zero_signs == zs)
    if f == "vertices":
        return v.hit & (v.zero_signs == 2) & (v.t == 1)
    if f == "edges":
        return v.hit & (v.zero_signs == 1) & (v.t == 1)
    if f in ("along_edges", "planes", "grazing"):
        o, d = case.origins, case.directions
        plane = exact_in_plane(o, d, case.vertices[case.faces[c["plane"]]])
        zs_ok = (v.zero_signs == 2) if f == "along_edges" else (v.zero_signs >= 1)
        return v.hit & zs_ok & plane & ~v.in_ties(c["plane"])
    if f == "on_surface":
        return aimed & (v.t == 0) & (case.tmin == 0)
    if f == "on_surface_tmin":
        into = np.char.startswith(kind, "into_")
        return (case.tmin > 0) & (v.hit == into) & (~v.hit | (v.t > case.tmin))
    if f == "tmin":
        hit = np.isin(kind, ["tmax_at", "tmin_at", "bracket", "past_near_side"])
        return (v.hit == hit) & (~v.hit | (v.t == 1))
    if f == "domain":
        # through a corner (corner_*, and along_edge: from beyond the edge's end), a point
        # of an edge (edge_*), a point of a face (face_plane)
        k = np.where(
            np.char.startswith(kind, "corner") | (kind == "along_edge"),
            3,
            np.where(np.char.startswith(kind, "edge"), 2, 1),
        )
        through = exact_through(case.origins, case.directions, c["through"], c["through_t"])
        return (
            through
            & _on_box(c["through"], case.domain, k)
            & (v.hit == np.char.endswith(kind, "_in"))
        )
    if f == "axis":
        return v.hit & np.isin(case.directions, (-1.0, 0.0, 1.0)).all(1)
    if f == "long":
        return v.hit & v.in_ties(c["in_tie"])
    if f in REAL_FAMILIES:
        return one  # checked in _check_family with the certified per-ray claims
    # tiny, huge, flat, terrain, dirscale, far*: every ray hits; aimed rays at their point
    t_aim = np.ones(len(case))
    if f == "dirscale":
        t_aim = 2.0 ** -np.array([int(k.split("_2^")[1]) for k in kind], float)
    return v.hit & ((zs < 0) | (aimed & (v.t == t_aim)))


def _check_family(case):
    """Claims hold on 100% of the kept rays in both precisions (verdicts recomputed here on the
    rays as cast); returns the verdicts."""
    from tetrace.dev.stress import check_claims

    ref = Referee(case.vertices, case.faces)
    out = {}
    o64, d64 = case.rays("f64")
    for p in PRECISIONS:
        o, d = case.rays(p)
        if case.exact32:  # the float32 rays are the same numbers
            assert np.array_equal(o.astype(np.float64), o64), case.family
            assert np.array_equal(d.astype(np.float64), d64), case.family
        v = ref.first_hits(o, d, case.tmin, case.tmax)
        ok = _claim(case, v)
        assert ok.all(), (case.family, p, int((~ok).sum()), np.unique(case.kind[~ok]))
        ok, fail = check_claims(case, v, p)
        assert ok.all(), (case.family, p, {k: int(m.sum()) for k, m in fail.items() if m.any()})
        out[p] = v
    return out


@pytest.mark.parametrize("family", LOCAL)
def test_family_is_what_it_says(local_cases, family):
    case = local_cases[family]
    assert len(case) > 0
    if family in EXACT_FAMILIES:
        # built exact: every candidate certifies, in both precisions
        assert case.certified == {"f64": 1.0, "f32": 1.0}, case.certified
        assert len(case) == case.candidates
    print(
        f"\n{family}: {len(case)}/{case.candidates} rays certified "
        f"(f32 {case.certified['f32']:.2%}, f64 {case.certified['f64']:.2%}): {case.what}"
    )
    _check_family(case)


def test_shared_family_is_what_it_says(shared_case):
    assert len(shared_case) > 0
    print(
        f"\n{SHARED}: {len(shared_case)}/{shared_case.candidates} rays certified "
        f"(f32 {shared_case.certified['f32']:.2%}, f64 {shared_case.certified['f64']:.2%})"
    )
    _check_family(shared_case)


def test_vertex_family_rays_pass_exactly_through_vertices(local_cases):
    """The issue's example: 100% of vertex-family rays have zero_signs == 2 at their first hit,
    at t = 1 where o + d is exactly a vertex of the scene (exact rationals), in both
    precisions."""
    case = local_cases["vertices"]
    tip = case.origins + case.directions  # exact (checked below)
    assert exact_through(case.origins, case.directions, tip, np.ones(len(case))).all()
    assert (tip[:, None, :] == case.vertices[None]).all(2).any(1).all()
    for p in PRECISIONS:
        o, d = case.rays(p)
        v = Referee(case.vertices, case.faces).first_hits(o, d)
        assert (v.hit & (v.zero_signs == 2) & (v.t == 1.0)).all(), p


def test_domain_family_aims_at_the_scene_domain(local_cases):
    case = local_cases["domain"]
    scene = build_scene(case)
    assert np.array_equal(scene.domain, case.domain)
    lo, hi = case.domain
    assert not case.contain and ((case.origins < lo) | (case.origins > hi)).any(1).all()


def test_hint_does_not_change_the_verdict(local_cases):
    """cast_case without a stored verdict asks the referee with the cast's triangles as the
    hint: the verdict is the one certified."""
    case = local_cases["edges"]
    scene = build_scene(case)
    _, _, with_stored = cast_case(case, scene, "aman2022", None, "f64")
    stored = case.verdicts
    case.verdicts = {}
    try:
        _, _, hinted = cast_case(case, scene, "aman2022", None, "f64")
    finally:
        case.verdicts = stored
    for k in OUTCOMES + ("right",):
        assert np.array_equal(with_stored[k], hinted[k]), k


# -- the robust walk --------------------------------------------------------------------------


def _assert_robust(rows, family, precision):
    r = _row(rows, "robust", _native.DEFAULT_LAYOUT, precision)
    kinds, _ = ROBUST_KNOWN.get((family, precision), (set(), None))
    if kinds is None:  # the whole case is known wrong (strict xfail): assert everything
        kinds = set()
    bad = _bad(r, exclude=kinds)
    assert bad == 0, (family, precision, {k: r[k] for k in OUTCOMES}, r["bad_kinds"], r["examples"])
    assert r["rays"] > 0


@pytest.mark.parametrize("family, precision", _robust_cases(LOCAL))
def test_robust_is_right(results, family, precision):
    """0 late, leaked, failed, wrong, wrong_exit, no_exit for the robust walk (rays of the kinds
    a strict xfail below names are left to it)."""
    _assert_robust(results[family], family, precision)


@pytest.mark.parametrize("family, precision", _robust_cases([SHARED]))
def test_robust_is_right_on_shared_scene(shared_results, family, precision):
    _assert_robust(shared_results[family], family, precision)


@pytest.mark.parametrize("family, precision", _known_cases(LOCAL + [SHARED]))
def test_robust_known_wrong(results, request, family, precision):
    """The kinds of rays on which the robust walk is wrong today (strict xfail: the cause is in
    ROBUST_KNOWN); passes, and so fails the suite, once they are right."""
    rows = (results if family in results else request.getfixturevalue("shared_results"))[family]
    r = _row(rows, "robust", _native.DEFAULT_LAYOUT, precision)
    kinds = ROBUST_KNOWN[family, precision][0]
    assert _bad(r, kinds=kinds) == 0, (family, precision, r["bad_kinds"], r["examples"])


def test_robust_does_not_depend_on_layout(results):
    """The robust walk's decisions are exact: every layout gives the same counts."""
    for family, rows in results.items():
        for p in PRECISIONS:
            ref = _row(rows, "robust", _native.DEFAULT_LAYOUT, p)
            for lay in layouts_for(p, tetrace.layouts()):
                r = _row(rows, "robust", lay, p)
                assert {k: r[k] for k in OUTCOMES} == {k: ref[k] for k in OUTCOMES}, (
                    family,
                    p,
                    lay,
                )


# -- every method's counts, recorded ----------------------------------------------------------


def test_counts_are_recorded(results, capsys):
    """Every family x method x precision has a row (the default's printed first), and each
    valid ray is judged exactly once: right + late + leaked + failed + wrong == rays (the
    referee's judgements are disjoint and cover every valid ray; the families have no invalid
    ray)."""
    methods = [DEFAULT[0]] + [m for m in tetrace.methods() if m != DEFAULT[0]]
    with capsys.disabled():
        print()
        for m in methods:
            for p in PRECISIONS:
                tot = {k: 0 for k in OUTCOMES}
                n = 0
                for family, rows in results.items():
                    r = _row(rows, m, _native.DEFAULT_LAYOUT, p)
                    n += r["rays"]
                    for k in OUTCOMES:
                        tot[k] += r[k]
                    if any(r[k] for k in OUTCOMES):
                        print(
                            f"stress {family} {m} {p}: "
                            + ", ".join(f"{k} {r[k]}" for k in OUTCOMES if r[k])
                        )
                tag = " (default)" if m == DEFAULT[0] else ""
                print(
                    f"stress ALL {m}{tag} {_native.DEFAULT_LAYOUT} {p}: {n} rays, "
                    + ", ".join(f"{k} {v}" for k, v in tot.items())
                )
    for family, rows in results.items():
        for m in tetrace.methods():
            for p in PRECISIONS:
                r = _row(rows, m, _native.DEFAULT_LAYOUT, p)
                assert (
                    r["right"] + sum(r[k] for k in ("late", "leaked", "failed", "wrong"))
                    == r["rays"]
                ), (family, m, p)
    # The families are adversarial: every method that decides exit faces in floating point is
    # caught taking a wrong exit face, and answering some ray wrong, in both precisions.
    for m in tetrace.methods():
        if m == "robust":
            continue
        for p in PRECISIONS:
            rs = [_row(rows, m, _native.DEFAULT_LAYOUT, p) for rows in results.values()]
            assert any(r["wrong_exit"] for r in rs), (m, p)
            assert any(r["rays"] - r["right"] for r in rs), (m, p)


# -- the audit ------------------------------------------------------------------------------


def test_audit_does_not_depend_on_layout():
    """Id layouts store the same vertices and name the entry face alike: every method takes
    the same exit faces on each. Tet80 names the entry face's vertices in its own slot order,
    so a float method may break a tie differently there (on rays through edges); the robust
    walk's exact decisions cannot differ."""
    case = make_case("edges", 2_000, seed=1)
    scene = build_scene(case)
    o, d = case.rays("f32")
    for method in ("aman2022", "lagae2008_plucker", "robust"):
        ref = None
        for layout in tetrace.layouts():
            if layout == "tet80" and method != "robust":
                continue
            h, audit = audited_cast(scene, o, d, method=method, layout=layout, precision="f32")
            got = (h.triangle, h.steps, audit)
            if ref is None:
                ref = got
            else:
                assert all(np.array_equal(x, y) for x, y in zip(ref, got)), (method, layout)


def test_audit_sees_a_wrong_exit():
    """The audit is not blind: rays through mesh vertices (exactly, certified) make a float
    walk choose faces the exact line does not cross (counted), while the robust walk never
    does."""
    case = make_case("vertices", 3_000, seed=2)
    assert case.certified == {"f64": 1.0, "f32": 1.0}
    scene = build_scene(case)
    _, a = audited_cast(scene, case.origins, case.directions, method="aman2022")
    _, r = audited_cast(scene, case.origins, case.directions, method="robust")
    assert a[:, 0].sum() > 0
    assert r.sum() == 0
