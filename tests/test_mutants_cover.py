"""The mutation run by coverage (``tetrace.dev.mutants_cover``; docs/testing.md) runs each
mutant against the tests that executed a line of it. A line it wrongly took for unexecuted
would leave out a test that might catch the mutant, and a mutant it calls missed could be a
caught one. These check how it reads llvm-cov's segments, which tests it gives a mutant, and
the regex that names one mutant."""

import re

from tetrace.dev.mutants_cover import (
    escape,
    executed_lines,
    line_sets,
    own_tests,
    ranges,
    reach,
)

# llvm-cov export's segments for one file: [line, col, count, has_count, entry, gap]. A
# function over lines 10-16 entered 5 times, whose branch on lines 12:9-13:6 never ran, a gap
# between two regions on line 14, and counted code on line 20 that ran once.
SEGMENTS = [
    [10, 1, 5, True, True, False],
    [12, 9, 0, True, True, False],
    [13, 6, 5, True, False, False],
    [14, 3, 5, True, False, True],
    [14, 9, 5, True, True, False],
    [16, 2, 0, False, False, False],
    [20, 5, 1, True, True, False],
    [20, 30, 0, False, False, False],
]


def test_a_line_counts_as_run_when_any_part_of_it_ran():
    run, counted = executed_lines(SEGMENTS)
    # Line 12 ran up to column 9 and line 13 from column 6: a line any part of which ran
    # counts as run (the branch lies on no line of its own here; the next test has one).
    assert run == {10, 11, 12, 13, 14, 15, 16, 20}
    assert counted == run


def test_lines_wholly_in_a_region_that_never_ran_are_not_run_but_counted():
    segments = [
        [1, 1, 3, True, True, False],
        [2, 5, 0, True, True, False],  # lines 2 (from col 5) to 4: never ran
        [5, 1, 3, True, False, False],
        [6, 2, 0, False, False, False],
    ]
    run, counted = executed_lines(segments)
    assert run == {1, 2, 5, 6}
    assert counted == {1, 2, 3, 4, 5, 6}
    assert 3 not in run and 4 not in run


def test_uncounted_code_is_neither_run_nor_counted():
    segments = [
        [1, 1, 0, False, False, False],
        [3, 1, 2, True, True, False],
        [3, 9, 0, False, False, False],
    ]
    run, counted = executed_lines(segments)
    assert run == counted == {3}


def test_ranges_round_trip():
    lines = {1, 2, 3, 7, 9, 10}
    assert ranges(lines) == [[1, 3], [7, 7], [9, 10]]
    assert line_sets({"f": ranges(lines)}) == {"f": lines}


def cover_of(tests: dict[str, set[int]], counted: set[int]) -> dict:
    return {
        "tests": {n: {"line_sets": {"src/a.rs": ls}} for n, ls in tests.items()},
        "counted_sets": {"src/a.rs": counted},
    }


def mutant(start: int, end: int, fn_line: int, name: str) -> dict:
    # cargo-mutants' function span starts at the doc comment.
    return {
        "file": "src/a.rs",
        "span": {"start": {"line": start}, "end": {"line": end}},
        "function": {"function_name": name, "span": {"start": {"line": fn_line}}},
    }


def test_a_mutant_runs_the_tests_that_ran_any_line_of_its_span(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "a.rs").write_text(
        "fn f() {\n    1\n}\n/// g's doc\npub const fn g() -> u32 {\n    2\n}\n\n\n"
    )
    cover = cover_of({"t1": {1, 2}, "t2": {2, 3}, "t3": {5}}, counted={1, 2, 3, 5, 6})
    assert reach(cover, tmp_path, mutant(1, 1, 1, "f")) == ("lines", ["t1"])
    assert reach(cover, tmp_path, mutant(2, 3, 1, "f")) == ("lines", ["t1", "t2"])
    # Counted but run by no test: no test can catch it.
    cover["counted_sets"]["src/a.rs"].add(8)
    assert reach(cover, tmp_path, mutant(8, 8, 1, "f")) == ("lines", [])
    # A const fn's body may run at compile time, which no counter sees: every test.
    every = ["t1", "t2", "t3"]
    assert reach(cover, tmp_path, mutant(6, 6, 4, "<impl T for U>::g")) == ("const fn", every)
    # A function whose declaration is not found: taken for a const fn.
    assert reach(cover, tmp_path, mutant(2, 2, 1, "h"))[1] == every
    # Lines the coverage build counted nowhere: every test.
    assert reach(cover, tmp_path, mutant(9, 9, 1, "f")) == ("uncounted", every)


def test_the_regex_names_one_mutant_and_no_other():
    names = [
        "src/geom/exact.rs:55:25: replace && with || in side",
        "src/geom/exact.rs:24:5: replace rat -> Dyadic with Default::default()",
        "src/accel/exact_bvh.rs:1101:9: replace |= with ^= in <impl BoxTest for Avx2>::test",
        "src/geom/real.rs:90:20: replace * with + in times_pow2",
        "src/geom/real.rs:90:20: replace * with - in times_pow2",
    ]
    for name in names:
        pattern = "^" + escape(name) + "$"
        # Python's re reads these escapes as Rust's regex does: each a literal character.
        assert [n for n in names if re.search(pattern, n)] == [name]
    # '.' matches itself alone.
    assert not re.search("^" + escape("a.rs") + "$", "axrs")


def test_a_files_own_tests_are_its_modules_and_its_parents_tests():
    assert own_tests("src/geom/exact.rs") == ("geom::exact::", "geom::tests::")
    assert own_tests("src/accel/exact_bvh/fan.rs") == (
        "accel::exact_bvh::fan::",
        "accel::exact_bvh::tests::",
    )
    assert own_tests("src/query/mod.rs") == ("query::",)
    names = ["geom::exact::tests::a", "geom::tests::b", "geom::exactly::c", "geom::rounded::d"]
    assert [n for n in names if n.startswith(own_tests("src/geom/exact.rs"))] == names[:2]
