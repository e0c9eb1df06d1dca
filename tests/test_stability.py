"""Stress families: every ray ends; the robust walk never leaks, and fails only on degenerate lines.

The counts of the other methods are recorded (printed with -s, and in the stability bench);
they are not zero and are not asserted to be. What the robust walk still gets wrong on
degenerate lines (rays through box corners, rays lying in a face's plane) is counted and
bounded at the measured value: see docs/robust_walk.md, "Degenerate lines".
"""

import numpy as np
import pytest

import tetrace
from tetrace.stress import FAMILIES, brute_bounds, cases, classify

N = 15_000  # per family: 7 families -> 105,000 rays per method and precision


@pytest.fixture(scope="module")
def results():
    out = {}
    for case in cases(N, seed=0):
        scene = tetrace.Scene.from_mesh((case.vertices, case.faces),
                                        contain=np.vstack([case.origins, case.origins + 1e-9]))
        for precision in ("f32", "f64"):
            dt = np.float32 if precision == "f32" else np.float64
            o, d = case.origins.astype(dt), case.directions.astype(dt)
            band = 1e-4 if precision == "f32" else 1e-9
            for method in tetrace.methods():
                h = scene.cast(o, d, method=method, precision=precision, invalid="mark")
                out[case.family, method, precision] = classify(
                    h, o, d, case.vertices, case.faces, case.closed, band=band)
    return out


def test_families_are_reproducible():
    a = [c.origins for c in cases(100, seed=3)]
    b = [c.origins for c in cases(100, seed=3)]
    assert len(a) == len(FAMILIES)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))


# The robust walk hits the step guard on some rays lying in the box's face planes, where its
# tie-break for exact zeros is not realizable by a perturbed line (docs/robust_walk.md,
# "Degenerate lines"): 0 of these 15,000 (seed 0), 86 of the bench's 20,000. The bound allows
# that rate; leaks stay at 0.
ROBUST_FAILED_MAX = {"grazing": 70}


def test_robust_walk_never_leaks_and_fails_only_on_degenerate_lines(results):
    total = 0
    for (family, method, precision), c in results.items():
        if method != "robust":
            continue
        total += sum(c.values())
        assert c["failed"] <= ROBUST_FAILED_MAX.get(family, 0), (family, precision, c)
        assert c["leak"] == 0, (family, precision, c)
    assert total >= 2 * 100_000


# Wrong answers of the robust walk on degenerate lines (a hit behind the start on a box
# diagonal; a hit on a triangle the line only lies in): 2 axis rays of 15,000 here; 1 axis and
# 19 grazing rays of 20,000 in the bench.
ROBUST_WRONG_MAX = {"axis": 10, "grazing": 150}


def test_robust_wrong_answers_are_only_on_degenerate_lines(results):
    for (family, method, precision), c in results.items():
        if method != "robust":
            continue
        if family in ("far1e6",) and precision == "f32":
            continue  # float32 cannot represent this scene: vertices round by 1/16 of its size
        assert c["wrong"] <= ROBUST_WRONG_MAX.get(family, 0), (family, precision, c)


def test_other_methods_counts_are_recorded(results, capsys):
    rows = [(f, m, p, c) for (f, m, p), c in results.items()]
    with capsys.disabled():
        for f, m, p, c in rows:
            if c["wrong"] or c["leak"] or c["failed"]:
                print(f"stress {f} {m} {p}: {c}")
    # The families are adversarial: some method somewhere must be caught by them.
    assert any(c["failed"] or c["wrong"] for _, _, _, c in rows)


def test_brute_bounds_bracket_a_plain_hit():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    f = np.array([[0, 1, 2]])
    o = np.array([[0.2, 0.2, 1.0], [0.0, 0.0, 1.0], [2.0, 2.0, 1.0]])
    d = np.array([[0, 0, -1.0]] * 3)
    touch, sure = brute_bounds(o, d, v, f, 1e-9)
    assert touch[0] == pytest.approx(1.0) and sure[0] == pytest.approx(1.0)
    assert touch[1] == pytest.approx(1.0) and np.isinf(sure[1])  # through a vertex: touch only
    assert np.isinf(touch[2]) and np.isinf(sure[2])
