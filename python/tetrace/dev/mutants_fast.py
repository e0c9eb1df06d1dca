"""The library tests that run fast with the crate unoptimised, as a nextest filterset.

A mutation run's time goes mostly to rebuilding the crate for each mutant. With the test
profile at opt-level 1 and full debug info, one mutant's rebuild took 87 s on a 2-core Zen 3
VM; with the crate alone at opt-level 0 and no debug info (its dependencies still at
opt-level 1), 8.5 s. Unoptimised, though, the whole library suite takes 9.4 minutes there,
and a survivor runs all of it.

So ``make mutants MUTANTS_FAST=1`` runs in two passes (``docs/testing.md``):

1. every mutant at opt-level 0 against the tests this script keeps: those that took less
   than a given share of the whole suite's test-seconds in one unoptimised run (most mutants
   are caught there, in seconds);
2. the mutants pass 1 did not catch (missed, timed out, unviable) again, at opt-level 1
   against the whole suite (cargo-mutants' ``--iterate`` skips the caught ones).

The limit is a share of the suite's time rather than seconds because the machine's load
moves the times: on the Zen 3 VM, quiet, 1% of the suite was 11.1 s and left out 18 slow
tests; beside another mutation run the same suite took 2,946 test-seconds instead of 1,109,
and a 12 s limit left out 35.

Leaving tests out can only turn a caught mutant into a missed one, never hide a survivor,
and pass 2 gives every such mutant the whole suite, so the two passes miss exactly what one
full run misses.

A caught mutant's test phase lasts until its first failing test ends (nextest stops there),
and nextest runs tests in their names' order: a mutant in ``geom/`` waited about 28 s at
opt-level 0 for the ``accel::`` tests before ``geom::rounded``'s 0.14 s test failed. So the
script also writes a nextest config that runs the fastest tests first (nextest's per-test
``priority``), which both passes use. The order changes when a mutant is caught, never
whether.

Run it in the crate root, with the environment of pass 1 (so that the build is shared)::

    python3 python/tetrace/dev/mutants_fast.py 1 "$PWD/target/mutants-nextest.toml"

It prints the filterset on stdout (for ``cargo mutants --cargo-test-arg=-E
--cargo-test-arg=...``), writes the config (for ``--cargo-test-arg=--config-file``) and says
what it measured on stderr.
"""

from __future__ import annotations

import re
import subprocess
import sys

try:
    from .mutants_reach import NEXTEST as REACH_NEXTEST
except ImportError:  # run as a script: python3 python/tetrace/dev/mutants_fast.py
    from mutants_reach import NEXTEST as REACH_NEXTEST  # type: ignore[no-redef]

# The crate alone unoptimised: its dependencies keep the profile's level (rayon and the
# rest stay fast), and a mutant rebuilds only tetrace.
OPT0 = ["--config", "profile.test.package.tetrace.opt-level=0"]
# The reach finder's nextest command (every library test, no stopping), unoptimised.
NEXTEST = [*REACH_NEXTEST, *OPT0]
DONE = re.compile(r"^\s*PASS \[\s*([0-9.]+)s\].*?tetrace (\S+)\s*$", re.MULTILINE)


def durations(log: str) -> dict[str, float]:
    """Each passed test's seconds, from nextest's output."""
    return {name: float(s) for s, name in DONE.findall(log)}


def slow_tests(times: dict[str, float], percent: float) -> list[str]:
    """The tests that took `percent` % of all tests' time or more, by name."""
    limit = sum(times.values()) * percent / 100
    return sorted(name for name, s in times.items() if s >= limit)


def left_out(times: dict[str, float], percent: float) -> str:
    """A filterset of every test but the slow ones."""
    slow = slow_tests(times, percent)
    if not slow:
        return "all()"
    return "not (" + " | ".join(f"test(={name})" for name in slow) + ")"


def order_config(times: dict[str, float]) -> str:
    """A nextest config whose overrides run the tests in order of their time, fastest first.

    Priorities run from 100 (first) down to -99; tests of equal priority (more than 200
    tests) run in name order.
    """
    ranked = sorted(times, key=lambda name: (times[name], name))
    parts = ["# Written by python/tetrace/dev/mutants_fast.py: the fastest tests first.\n"]
    for rank, name in enumerate(ranked):
        priority = 100 - (200 * rank) // len(ranked)
        parts.append(
            f"[[profile.default.overrides]]\nfilter = 'test(={name})'\npriority = {priority}\n"
        )
    return "\n".join(parts)


def main(args: list[str]) -> int:
    if len(args) != 2:
        print("usage: mutants_fast.py PERCENT NEXTEST_CONFIG_OUT", file=sys.stderr)
        return 2
    percent, config = float(args[0]), args[1]
    run = subprocess.run(NEXTEST, capture_output=True, text=True)
    times = durations(run.stderr)
    if run.returncode != 0 or not times:
        # A test failing here would be counted as catching every mutant: refuse.
        print(run.stderr[-4000:], file=sys.stderr)
        print("the unmutated suite did not pass at opt-level 0", file=sys.stderr)
        return 1
    slow = slow_tests(times, percent)
    print(
        f"{len(times) - len(slow)} of {len(times)} tests kept ({percent}% of the suite's "
        f"{sum(times.values()):.0f} test-seconds is the limit); left out: {slow}",
        file=sys.stderr,
    )
    with open(config, "w") as out:
        out.write(order_config(times))
    print(left_out(times, percent))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
