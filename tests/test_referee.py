"""The exact referee on hand-made cases, against a plain-rational brute force, and against its
Rust twin.

The brute force below is the contract of docs/referee.md written as directly as possible in
``fractions.Fraction`` (no filter, no hierarchy, no scaling): slow, small scenes only, and
obviously exact.
"""

from fractions import Fraction

import numpy as np
import pytest

from tetrace.hits import FAILED, HIT, MISS, Hits
from tetrace.referee import JUDGEMENTS, Referee, judge, ulp


def _fr_first_hit(o, d, tris, tmin=0.0, tmax=np.inf):
    """(t*, sorted tie ids) by exact rationals, or (None, [])."""
    O = [Fraction(float(x)) for x in o]
    D = [Fraction(float(x)) for x in d]

    def sub(a, b):
        return [a[i] - b[i] for i in range(3)]

    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]

    def dot(a, b):
        return sum(a[i] * b[i] for i in range(3))

    best, ties = None, []
    for k, tri in enumerate(tris):
        a, b, c = ([Fraction(float(x)) for x in p] for p in tri)
        s = [dot(D, cross(sub(p, O), sub(q, O))) for p, q in ((a, b), (b, c), (c, a))]
        if all(x == 0 for x in s) or not (all(x >= 0 for x in s) or all(x <= 0 for x in s)):
            continue
        n = cross(sub(b, a), sub(c, a))
        t = dot(sub(a, O), n) / dot(D, n)
        if t < Fraction(float(tmin)) or (np.isfinite(tmax) and t > Fraction(float(tmax))):
            continue
        if best is None or t < best:
            best, ties = t, [k]
        elif t == best:
            ties.append(k)
    return best, ties


def _check_against_fractions(v, f, o, d, tmin=0.0, tmax=np.inf):
    ver = Referee(v, f).first_hits(o, d, tmin, tmax)
    tris = np.asarray(v, np.float64)[np.asarray(f)]
    tmin = np.broadcast_to(tmin, (len(o),))
    tmax = np.broadcast_to(tmax, (len(o),))
    for i in range(len(o)):
        t, ties = _fr_first_hit(o[i], d[i], tris, tmin[i], tmax[i])
        assert bool(ver.hit[i]) == (t is not None), i
        if t is not None:
            assert ver.t[i] == float(t), i  # correctly rounded: Fraction -> float rounds to nearest
            assert ver.tie_set(i).tolist() == ties, i
    return ver


def _quad():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    return v, np.array([[0, 1, 2], [1, 3, 2]])


def test_hand_made_cases():
    v, f = _quad()
    r = Referee(v, f)
    o = np.array(
        [
            [0.25, 0.25, 1],
            [0.5, 0.5, 1],
            [0, 0, 1],
            [1, 0, 1],
            [2, 2, 1],
            [-1, 0.5, 0],
            [-1, 0.5, 1],
            [0.2, 0.2, 1],
        ],
        float,
    )
    d = np.array(
        [
            [0, 0, -1],
            [0, 0, -1],
            [0, 0, -1],
            [0, 0, -1],
            [0, 0, -1],
            [1, 0, 0],
            [1, 0, 0],
            [0, 0, -3],
        ],
        float,
    )
    ver = r.first_hits(o, d)
    # interior; on the shared diagonal (both); a vertex of one; a vertex of both; outside;
    # in the plane (never); parallel above; t = 1/3 correctly rounded
    assert ver.hit.tolist() == [True, True, True, True, False, False, False, True]
    assert [ver.tie_set(i).tolist() for i in range(8)] == [
        [0],
        [0, 1],
        [0],
        [0, 1],
        [],
        [],
        [],
        [0],
    ]
    assert ver.zero_signs.tolist()[:4] == [0, 1, 2, 2]
    assert ver.t[7] == float(Fraction(1, 3))
    assert ver.t[:4].tolist() == [1.0] * 4


def test_bounds_are_closed():
    v, f = _quad()
    o = np.array([[0.25, 0.25, 1]] * 4)
    d = np.array([[0, 0, -1.0]] * 4)
    ver = Referee(v, f).first_hits(
        o,
        d,
        tmin=np.array([1.0, 1.0, np.nextafter(1, 2), 0]),
        tmax=np.array([1.0, np.inf, np.inf, np.nextafter(1, 0)]),
    )
    assert ver.hit.tolist() == [True, True, False, False]


def test_degenerate_triangles_and_rays_never_hit():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], float)
    r = Referee(v, [[0, 1, 2], [0, 0, 3]])  # collinear, and a repeated vertex
    ver = r.first_hits([[1, 0, 1], [0, 0.5, 1]], [[0, 0, -1], [0, 0, -1]])
    assert not ver.hit.any()
    ver = r.first_hits([[0, 0, 1], [np.nan, 0, 0]], [[0, 0, 0], [0, 0, 1]])
    assert ver.invalid.tolist() == [True, True] and not ver.hit.any()


def test_overlapping_coplanar_triangles_tie():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0], [2, 0, 0], [0, 2, 0]], float)
    ver = Referee(v, [[0, 1, 2], [3, 4, 5]]).first_hits([[0.1, 0.1, 1]], [[0, 0, -1.0]])
    assert ver.tie_set(0).tolist() == [0, 1]


def test_far_from_the_origin_exactly():
    # A ray exactly through a vertex of a triangle 1e7 away, with a direction whose float64
    # components make o + t d inexact: only exact side products see the vertex crossing.
    off = 1e7
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float) + off
    o = np.array([[off + 0.1, off + 0.3, off + 1.0]])
    d = v[0:1] - o  # exact: every difference here is representable
    ver = _check_against_fractions(v, [[0, 1, 2]], o, d)
    assert ver.hit[0] and ver.zero_signs[0] == 2 and ver.t[0] == 1.0


@pytest.mark.parametrize("scale", [1e-200, 1e-30, 1.0, 1e30, 1e200])
def test_extreme_scales(scale):
    v, f = _quad()
    v = v * scale
    o = np.array([[0.5, 0.5, 1], [0.25, 0.25, 1], [0.3, 0.9, 1]]) * scale
    d = (
        np.array([[0, 0, -1.0], [0.0, 0.0, -2.0], [0.9, -0.2, -1.0]]) * scale
    )  # lands at (1.2, 0.7): outside
    ver = _check_against_fractions(v, f, o, d)
    assert ver.hit.tolist() == [True, True, False]
    assert ver.tie_set(0).tolist() == [0, 1]


def test_random_and_adversarial_rays_match_rationals():
    rng = np.random.default_rng(5)
    # a small closed mesh with dyadic vertices: an octahedron and a tetrahedron sharing space
    v = np.array(
        [
            [1, 0, 0],
            [-1, 0, 0],
            [0, 1, 0],
            [0, -1, 0],
            [0, 0, 1],
            [0, 0, -1],
            [0.5, 0.5, 0.5],
            [0.25, -0.75, 0],
            [-0.5, 0.25, 0.5],
        ],
        float,
    )
    f = np.array(
        [
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
            [6, 7, 8],
        ]
    )
    n = 300
    o = rng.integers(-8, 9, (n, 3)) / 4.0  # dyadic: many rays exactly through vertices/edges
    target = v[f[rng.integers(0, len(f), n)]]
    w = rng.integers(0, 3, (n, 3)).astype(float)
    w[w.sum(1) == 0] = 1
    d = (w[:, :, None] * target).sum(1) / w.sum(1, keepdims=True) - o
    d[::7] = rng.standard_normal((len(d[::7]), 3))
    tmin = np.where(rng.random(n) < 0.2, rng.random(n), 0.0)
    ver = _check_against_fractions(v, f, o, d, tmin=tmin)
    assert (ver.zero_signs > 0).sum() > 20  # the family is adversarial, as meant
    assert ver.exact_pairs > 0


def test_bvh_keeps_every_hit_on_a_real_sized_scene():
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=4)
    v, f = np.asarray(s.vertices), np.asarray(s.faces)
    rng = np.random.default_rng(1)
    o = rng.standard_normal((200, 3)) * 0.3
    d = rng.standard_normal((200, 3))
    ver = Referee(v, f).first_hits(o, d)
    # from inside a closed sphere every ray hits: an exact count, not a measured one
    assert ver.hit.all()
    _check_against_fractions(v, f, o[:40], d[:40])


def test_judge_outcomes():
    v, f = _quad()
    ver = Referee(v, f).first_hits(np.array([[0.25, 0.25, 1]] * 6), np.array([[0, 0, -1.0]] * 6))
    t = np.array([1.0, 1.0, np.inf, 1.0, 1.0 + 1e-6, 1.0])
    tri = np.array([0, 0, -1, 1, 0, 0])
    status = np.array([HIT, FAILED, MISS, HIT, HIT, HIT], np.uint8)
    h = Hits(
        t=t,
        triangle=tri.astype(np.int32),
        u=np.zeros(6),
        v=np.zeros(6),
        point=np.zeros((6, 3)),
        tet=np.full(6, -1, np.int32),
        steps=np.zeros(6, np.uint32),
        status=status,
    )
    j = judge(h, ver)
    got = [next(k for k in JUDGEMENTS if j[k][i]) for i in range(6)]
    assert got == ["right", "failed", "leaked", "wrong", "wrong", "right"]
    assert j["other_triangle"][3] and j["t_off"][4]
    assert sum(j[k].astype(int) for k in JUDGEMENTS).tolist() == [1] * 6


def test_ulp():
    assert ulp(1.0, np.float32) == 2.0**-23
    assert ulp(1.0, np.float64) == 2.0**-52


def test_python_and_rust_twins_agree():
    """The two referees are written independently (numpy + Python integers; Rust + BigInt):
    on random and deliberately degenerate rays they must give the same hit, t, first triangle
    and tie count, bit for bit."""
    from tetrace import _native

    rng = np.random.default_rng(12)
    g = np.stack(np.meshgrid(*[np.arange(4.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    v = g * 0.25 + rng.integers(-2, 3, g.shape) / 64.0  # dyadic, with exact coplanar runs
    f = rng.integers(0, len(v), (300, 3))
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    n = 6000
    o = rng.integers(-4, 20, (n, 3)) / 16.0
    aim = v[rng.integers(0, len(v), n)]  # exactly through vertices: ties and zero signs
    other = v[f[rng.integers(0, len(f), n)]].mean(1)
    d = np.where(rng.random((n, 1)) < 0.5, aim - o, other - o)
    free = rng.random(n) < 0.1
    d[free] = rng.standard_normal((free.sum(), 3))
    d[np.all(d == 0, axis=1)] = 1.0
    tmin = np.where(rng.random(n) < 0.2, rng.random(n), 0.0)
    tmax = np.full(n, np.inf)
    py = Referee(v, f).first_hits(o, d, tmin, tmax)
    rs = _native.referee_first_hit(v, f.astype(np.int64), o, d, tmin, tmax)
    np.testing.assert_array_equal(py.hit, rs["hit"])
    np.testing.assert_array_equal(py.t, rs["t"])
    np.testing.assert_array_equal(py.triangle, rs["triangle"])
    np.testing.assert_array_equal(py.ties, rs["ties"])
    assert (py.ties > 1).sum() > 100 and py.hit.sum() > n // 4  # the rays are the hard kind
