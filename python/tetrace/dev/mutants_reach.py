"""The library tests that enter any function of the given source files, as a nextest filterset.

A mutant that cargo-mutants plants inside a function body can change only a test that runs
that body; every other test passes against it exactly as it passes against the clean code.
So a mutation run over some files loses nothing by running only the tests that enter one of
their functions, and on this 2-core machine the rest of the suite is most of a survivor's
two minutes (``docs/testing.md``).

How the tests are found: ``std::process::abort();`` is put first in every function body of
the files, the library's tests are run by cargo-nextest without stopping at the first
failure (each test in a process of its own, so an abort fails that test alone, and no
``catch_unwind`` or ``should_panic`` can hide it), and the tests that fail are the ones
that entered a body. The files are restored afterwards, whatever happens.

Narrowing the tests can only turn a caught mutant into a missed one: it never hides a
survivor. A mutant missed by a narrowed run is run again against the whole suite before it
is looked at (``docs/testing.md``). That matters where a body runs without an abort in
front of it: a ``const fn`` (it cannot abort; its body may run at compile time for a
constant, or at run time from another file), which the tool names on stderr.

Run it in the crate root (it needs only Python and cargo-nextest, not the built package),
with the same environment as the mutation run so that the build is shared::

    python3 python/tetrace/dev/mutants_reach.py 'src/accel/exact_bvh/**/*.rs' ...

It prints the filterset on stdout (for ``cargo mutants --cargo-test-arg=-E
--cargo-test-arg=...``) and what it found on stderr. ``make mutants MUTANTS_REACH=1`` uses it.
"""

from __future__ import annotations

import glob
import re
import subprocess
import sys

FN = re.compile(r"\bfn\s+([A-Za-z_]\w*)")
NEXTEST = [
    "cargo",
    "nextest",
    "run",
    "--no-fail-fast",
    "--no-default-features",
    "--features",
    "fuzz",
    "--lib",
]


def instrument(text: str) -> tuple[str, int, list[str]]:
    """Put an abort first in every non-const function body of `text`.

    Returns the new text, how many bodies got one, and the names of the const fns.
    A declaration without a body (a trait's required method) ends at a `;` outside
    brackets; the body is the first `{` outside brackets after the name.
    """
    out, pos, count, consts = [], 0, 0, []
    for m in FN.finditer(text):
        line_start = text.rfind("\n", 0, m.start()) + 1
        head = text[line_start : m.start()]
        if "//" in head:
            continue
        if "const" in head.split():
            consts.append(m.group(1))
            continue
        depth, i = 0, m.end()
        while i < len(text):
            c = text[i]
            if c in "([":
                depth += 1
            elif c in ")]":
                depth -= 1
            elif depth == 0 and c == ";":
                break
            elif depth == 0 and c == "{":
                out.append(text[pos : i + 1])
                out.append(" std::process::abort();")
                pos = i + 1
                count += 1
                break
            i += 1
    out.append(text[pos:])
    return "".join(out), count, consts


def main(patterns: list[str]) -> int:
    files = sorted({p for pat in patterns for p in glob.glob(pat, recursive=True)})
    if not files:
        print(f"no source files match {patterns}", file=sys.stderr)
        return 2
    saved = {f: open(f).read() for f in files}
    consts: list[str] = []
    try:
        for f, text in saved.items():
            new, count, c = instrument(text)
            consts += c
            with open(f, "w") as out:
                out.write(new)
            print(f"{f}: {count} function bodies", file=sys.stderr)
        if consts:
            print(
                f"const fns, not instrumented (a missed mutant in them: rerun it against "
                f"the whole suite): {consts}",
                file=sys.stderr,
            )
        run = subprocess.run(NEXTEST, capture_output=True, text=True)
    finally:
        for f, text in saved.items():
            with open(f, "w") as out:
                out.write(text)
    summary = re.search(r"Summary.*", run.stderr)
    if summary is None:
        print(run.stderr[-4000:], file=sys.stderr)
        print("the instrumented tests did not run", file=sys.stderr)
        return 1
    entered = sorted(
        set(
            re.findall(
                r"^\s*(?:FAIL|SIGABRT|ABORT|SIGSEGV|TIMEOUT)\b.*?tetrace (\S+)\s*$",
                run.stderr,
                re.MULTILINE,
            )
        )
    )
    print(summary.group(0).strip(), file=sys.stderr)
    print(f"{len(entered)} tests enter a function of the files", file=sys.stderr)
    if not entered:
        print(
            "no test enters them: every mutant there survives; run the whole suite", file=sys.stderr
        )
        print("all()")
        return 0
    print(" | ".join(f"test(={name})" for name in entered))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
