"""The mutation run's first pass (``tetrace.dev.mutants_fast``; docs/testing.md) leaves out
the tests slow without optimisation and runs the rest fastest first. A test left out that it
should keep would only move a catch to the second pass; a test kept that it should leave out,
or an order config nextest reads wrongly, would cost time or fail the run. These check what
it reads from nextest and what it writes for it."""

import tomllib

from tetrace.dev.mutants_fast import durations, left_out, order_config

# nextest's lines as cargo-mutants logs them (a SLOW line names no time and is not a result).
LOG = """\
    Starting 4 tests across 1 binary
        PASS [   0.012s] (  1/4) tetrace geom::exact::tests::a
        SLOW [> 60.000s] (───────) tetrace fuzz::tests::c
        PASS [  24.633s] (  2/4) tetrace accel::exact_bvh::tests::b
        PASS [ 101.222s] (  3/4) tetrace fuzz::tests::c
        PASS [   0.012s] (  4/4) tetrace geom::exact::tests::d
     Summary [ 125.000s] 4 tests run: 4 passed, 0 skipped
"""


def test_durations_are_read_from_each_passing_tests_line():
    assert durations(LOG) == {
        "geom::exact::tests::a": 0.012,
        "accel::exact_bvh::tests::b": 24.633,
        "fuzz::tests::c": 101.222,
        "geom::exact::tests::d": 0.012,
    }


def test_tests_at_or_over_the_share_are_left_out_and_none_else():
    # Shares of the suite's time: the limit scales with the machine's load.
    times = {"a": 1.0, "b": 24.0, "c": 75.0}
    assert left_out(times, 24) == "not (test(=b) | test(=c))"
    assert left_out(times, 25) == "not (test(=c))"
    assert left_out(times, 76) == "all()"
    slower = {name: 3 * s for name, s in times.items()}
    assert left_out(slower, 24) == left_out(times, 24)


def test_the_order_config_runs_faster_tests_first_and_ties_by_name():
    times = durations(LOG)
    overrides = tomllib.loads(order_config(times))["profile"]["default"]["overrides"]
    # One override per test, each naming exactly one test.
    assert sorted(o["filter"] for o in overrides) == sorted(f"test(={n})" for n in times)
    priority = {o["filter"][len("test(=") : -1]: o["priority"] for o in overrides}
    assert all(-100 <= p <= 100 for p in priority.values())
    # nextest runs higher priorities first: the fastest first, a tie in time by name.
    first_to_last = sorted(times, key=lambda n: -priority[n])
    assert first_to_last == [
        "geom::exact::tests::a",
        "geom::exact::tests::d",
        "accel::exact_bvh::tests::b",
        "fuzz::tests::c",
    ]
    assert len(set(priority.values())) == len(times)


def test_more_tests_than_priorities_share_them_in_time_order():
    times = {f"t{k:03}": float(k) for k in range(450)}
    overrides = tomllib.loads(order_config(times))["profile"]["default"]["overrides"]
    priorities = [o["priority"] for o in overrides]
    assert len(overrides) == 450
    assert priorities[0] == 100 and -100 <= priorities[-1]
    # Never a slower test before a faster one.
    assert all(a >= b for a, b in zip(priorities, priorities[1:]))
