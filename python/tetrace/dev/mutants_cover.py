"""Mutation testing with each mutant run against the tests that execute its lines.

A mutant can change only a test that executes the code it changed: every other test runs the
same instructions as against the clean code and passes as it did. ``mutants_reach.py`` uses
that per file; this script uses it per line, from source-based coverage (``-C
instrument-coverage``), so a mutant in ``sign2`` runs the tests that call ``sign2``, not all
those that enter some function of ``exact.rs``. On the 2-core VM a mutant that no test
catches cost about 2 minutes of tests in pass 1 and 6 in pass 2 (``docs/testing.md``): most
of a run's time went to the mutants that survive, and they run every test they may.

Two steps, each run in the crate root of the checkout being mutated (a worktree)::

    python3 python/tetrace/dev/mutants_cover.py collect COVDIR
    python3 python/tetrace/dev/mutants_cover.py run COVDIR OUTDIR --file src/geom/exact.rs \
        [--exclude-re RE ...] [--re RE ...] [--pass 1|2|both] [--limit N]

``run`` collects the map first when it is missing or of another ``src/``. ``collect`` builds
the library's tests with coverage (the crate at opt-level 0, features as
the mutation run's, in ``COVDIR/target``), runs each test alone with its own profile, and
writes ``COVDIR/lines.json``: per test, the lines of each source file it executed, and its
seconds. It takes about as long as the unoptimised suite (10 minutes on the 2-core VM).

``run`` lists the mutants (``cargo mutants --list --json`` with the filters given), finds for
each the tests that executed a line of its span, groups the mutants by that set and runs
cargo-mutants on each group with those tests alone, in the two passes of ``make mutants
MUTANTS_FAST=1``:

1. the crate at opt-level 0 against the group's tests that took under 1% of the suite's
   test-seconds, and its file's own tests however slow (fastest first);
2. what pass 1 did not catch at opt-level 1 against all of the group's tests.

Outcomes go to ``OUTDIR/outcomes.json`` (one entry per mutant, kept across runs: a mutant
with an outcome there is not run again) and each cargo-mutants run's own folder under
``OUTDIR/runs``. ``--limit N`` stops after N mutants (a session's share).

When the line map cannot be trusted to be complete, the mutant runs against every test:
- a mutant in a ``const fn`` (its body may run at compile time, for a constant, where no
  counter sees it);
- a span with no instrumented line (code the coverage build did not count).

A mutant whose lines no test executed is checked only for building (``--check``): no test
can catch it, so it is missed if it builds. It is recorded as ``NotRun`` with that reason.

What the map rests on: the coverage build's paths are the mutation build's. The crate is
compiled at opt-level 0 in both pass 1 and the map, and a test's path through the code does
not depend on the optimiser except where floating-point evaluation is folded differently
(stop 63 found one, ``powi``, now gone). Tests whose work is split across threads can take
different paths from run to run only where the split decides them; the map records one run.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

try:
    from .mutants_fast import order_config
except ImportError:  # run as a script: python3 python/tetrace/dev/mutants_cover.py
    from mutants_fast import order_config  # type: ignore[no-redef]

FEATURES = ["--no-default-features", "--features", "fuzz", "--lib"]
OPT0 = ["--config", "profile.test.package.tetrace.opt-level=0"]
# As `make mutants`: the dependencies at opt-level 1, no debug info.
ENV = {"CARGO_PROFILE_TEST_OPT_LEVEL": "1", "CARGO_PROFILE_TEST_DEBUG": "0"}
MUTANTS = [
    "cargo",
    "mutants",
    "--in-place",
    "--no-shuffle",
    "--baseline=skip",
    "--test-tool",
    "nextest",
    *["--no-default-features", "--features", "fuzz", "-C", "--lib"],
    *["--timeout", "600", "--cargo-test-arg=--max-fail=1:immediate"],
]
FAST_PERCENT = 1.0


def llvm_tool(name: str) -> str:
    """The LLVM tool of the active Rust toolchain (rustup's llvm-tools component)."""
    sysroot = subprocess.run(
        ["rustc", "--print", "sysroot"], capture_output=True, text=True, check=True
    ).stdout.strip()
    host = re.search(
        r"host: (\S+)", subprocess.run(["rustc", "-vV"], capture_output=True, text=True).stdout
    )
    path = Path(sysroot) / "lib" / "rustlib" / (host.group(1) if host else "") / "bin" / name
    if not path.exists():
        raise SystemExit(f"{path} is missing: rustup component add llvm-tools")
    return str(path)


def executed_lines(segments: list[list]) -> tuple[set[int], set[int]]:
    """The lines some counted code with a nonzero count covers, and the lines counted code
    covers at all, from llvm-cov's segments ``[line, col, count, has_count, entry, gap]``
    (each applies from its position to the next segment's)."""
    run, counted = set(), set()
    for k, (line, _col, count, has_count, _entry, gap) in enumerate(segments):
        if not has_count or gap:
            continue
        if k + 1 < len(segments):
            nline, ncol = segments[k + 1][0], segments[k + 1][1]
            end = nline if ncol > 1 else nline - 1
        else:
            end = line
        lines = range(line, max(line, end) + 1)
        counted.update(lines)
        if count > 0:
            run.update(lines)
    return run, counted


def ranges(lines: set[int]) -> list[list[int]]:
    """Sorted lines as [first, last] runs (the map's stored form)."""
    out: list[list[int]] = []
    for n in sorted(lines):
        if out and out[-1][1] == n - 1:
            out[-1][1] = n
        else:
            out.append([n, n])
    return out


def src_tree() -> str:
    """The git tree of src/ at HEAD: a map holds for every commit with the same one."""
    return subprocess.run(
        ["git", "rev-parse", "HEAD:src"], capture_output=True, text=True, check=True
    ).stdout.strip()


def collect(covdir: Path) -> int:
    """Build with coverage, run each library test alone, write COVDIR/lines.json."""
    root = Path.cwd()
    target = covdir / "target"
    raw = covdir / "raw"
    raw.mkdir(parents=True, exist_ok=True)
    env = {
        **os.environ,
        **ENV,
        "RUSTFLAGS": "-C instrument-coverage",
        "CARGO_TARGET_DIR": str(target),
        # The build scripts are instrumented too: their profiles go here, not into the crate.
        "LLVM_PROFILE_FILE": str(raw / "build-%p.profraw"),
    }
    build = subprocess.run(
        ["cargo", "test", "--no-run", "--message-format=json", *FEATURES, *OPT0],
        env=env,
        capture_output=True,
        text=True,
    )
    if build.returncode != 0:
        print(build.stderr[-4000:], file=sys.stderr)
        return 1
    binaries = [
        m["executable"]
        for m in map(json.loads, build.stdout.splitlines())
        if m.get("reason") == "compiler-artifact" and m.get("executable")
    ]
    if len(binaries) != 1:
        print(f"expected one test binary, got {binaries}", file=sys.stderr)
        return 1
    binary = binaries[0]
    listing = subprocess.run(
        [binary, "--list", "--format", "terse"], capture_output=True, text=True, check=True
    ).stdout
    tests = [line[: -len(": test")] for line in listing.splitlines() if line.endswith(": test")]
    print(f"{len(tests)} tests", file=sys.stderr)
    profdata, cov = llvm_tool("llvm-profdata"), llvm_tool("llvm-cov")
    sources = sorted(str(p) for p in (root / "src").rglob("*.rs"))

    def one(k: int) -> tuple[str, float, dict, dict]:
        name = tests[k]
        for old in raw.glob(f"{k}-*.profraw"):
            old.unlink()
        env1 = {**os.environ, "LLVM_PROFILE_FILE": str(raw / f"{k}-%p.profraw")}
        start = time.perf_counter()
        r = subprocess.run(
            [binary, "--exact", name, "-q", "--test-threads", "1"],
            env=env1,
            capture_output=True,
            text=True,
            cwd=root,
        )
        seconds = time.perf_counter() - start
        if r.returncode != 0:
            raise RuntimeError(f"{name} failed unmutated:\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
        merged = raw / f"{k}.profdata"
        subprocess.run(
            [profdata, "merge", "-sparse", *map(str, raw.glob(f"{k}-*.profraw")), "-o", merged],
            check=True,
        )
        out = subprocess.run(
            [
                cov,
                "export",
                "--format=text",
                "--skip-functions",
                "--skip-expansions",
                "--instr-profile",
                str(merged),
                binary,
                *sources,
            ],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        files_run, files_counted = {}, {}
        for f in json.loads(out)["data"][0]["files"]:
            rel = os.path.relpath(f["filename"], root)
            run, counted = executed_lines(f["segments"])
            files_run[rel] = ranges(run)
            files_counted[rel] = ranges(counted)
        for p in [merged, *raw.glob(f"{k}-*.profraw")]:
            p.unlink()
        print(f"{k + 1}/{len(tests)} {name}: {seconds:.1f} s", file=sys.stderr)
        return name, seconds, files_run, files_counted

    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        results = list(pool.map(one, range(len(tests))))
    counted: dict[str, set[int]] = {}
    for _, _, _, fc in results:
        for f, rs in fc.items():
            counted.setdefault(f, set()).update(n for a, b in rs for n in range(a, b + 1))
    data = {
        "src_tree": src_tree(),
        "tests": {name: {"seconds": s, "lines": fr} for name, s, fr, _ in results},
        "counted": {f: ranges(ls) for f, ls in counted.items()},
    }
    (covdir / "lines.json").write_text(json.dumps(data))
    return 0


def line_sets(stored: dict[str, list[list[int]]]) -> dict[str, set[int]]:
    return {f: {n for a, b in rs for n in range(a, b + 1)} for f, rs in stored.items()}


def is_const_fn(root: Path, mutant: dict) -> bool:
    """Whether the mutant lies in a `const fn`: the line that declares its function, the first
    from the function's span (which begins with its doc comment) naming it, says so. True also
    where that line is not found, so that such a mutant runs every test."""
    fn = mutant.get("function")
    if not fn:
        return False
    name = fn["function_name"].split("::")[-1]
    lines = (root / mutant["file"]).read_text().splitlines()
    start, end = fn["span"]["start"]["line"], fn["span"].get("end", {}).get("line", len(lines))
    declares = re.compile(r"\bfn\s+" + re.escape(name) + r"\b")
    for line in lines[start - 1 : end]:
        if declares.search(line):
            return re.search(r"\bconst\s+(unsafe\s+)?(extern\s+\S+\s+)?fn\b", line) is not None
    return True


def reach(cover: dict, root: Path, mutant: dict) -> tuple[str, list[str]]:
    """The tests a mutant may change, and why (`lines`, `const fn`, `uncounted`)."""
    all_tests = sorted(cover["tests"])
    if is_const_fn(root, mutant):
        return "const fn", all_tests
    f = mutant["file"]
    span = mutant["span"]
    lines = set(range(span["start"]["line"], span["end"]["line"] + 1))
    if not lines & cover["counted_sets"].get(f, set()):
        return "uncounted", all_tests
    return "lines", sorted(
        name for name, t in cover["tests"].items() if lines & t["line_sets"].get(f, set())
    )


def escape(s: str) -> str:
    """A regex matching `s` literally (Rust's regex syntax; spaces left as they are)."""
    return "".join("\\" + c if c in r"\.+*?()|[]{}^$#&-~" else c for c in s)


def filterset(tests: list[str]) -> str:
    return " | ".join(f"test(={t})" for t in tests)


def own_tests(file: str) -> tuple[str, ...]:
    """Name prefixes of the tests written for a source file: those of its module, and of its
    parent module's `tests` (src/geom/exact.rs: `geom::exact::`; src/accel/exact_bvh/fan.rs:
    `accel::exact_bvh::fan::` and `accel::exact_bvh::tests::`). Pass 1 keeps them even when
    slow: they are the likeliest to catch the file's mutants, which pass 2 would otherwise
    reach only after a rebuild at opt-level 1 and the rest of the tests."""
    parts = Path(file).with_suffix("").parts[1:]
    if parts and parts[-1] == "mod":
        parts = parts[:-1]
    own = "::".join(parts) + "::"
    parent = "::".join(parts[:-1])
    return (own, parent + "::tests::") if parent else (own,)


def run_group(
    names: list[str], files: list[str], tests: list[str], opt0: bool, out: Path, config: Path
) -> dict[str, str]:
    """cargo-mutants on these mutants against these tests; each mutant's outcome summary."""
    cmd = list(MUTANTS)
    if opt0:
        cmd += [f"--cargo-arg={a}" for a in OPT0]
    cmd += ["--cargo-test-arg=--config-file", f"--cargo-test-arg={config}"]
    cmd += ["--cargo-test-arg=-E", f"--cargo-test-arg={filterset(tests)}"]
    for f in files:
        cmd += ["--file", f]
    for n in names:
        cmd += ["--re", "^" + escape(n) + "$"]
    cmd += ["-o", str(out)]
    subprocess.run(cmd, env={**os.environ, **ENV})
    got = json.loads((out / "mutants.out" / "outcomes.json").read_text())
    return {
        o["scenario"]["Mutant"]["name"]: o["summary"]
        for o in got["outcomes"]
        if isinstance(o["scenario"], dict) and "Mutant" in o["scenario"]
    }


def check_group(names: list[str], files: list[str], out: Path) -> dict[str, str]:
    """Whether each mutant builds (`cargo mutants --check`): Unviable or NotRun."""
    cmd = [*MUTANTS, "--check", *[a for f in files for a in ("--file", f)]]
    for n in names:
        cmd += ["--re", "^" + escape(n) + "$"]
    subprocess.run([*cmd, "-o", str(out)], env={**os.environ, **ENV})
    got = json.loads((out / "mutants.out" / "outcomes.json").read_text())
    return {
        o["scenario"]["Mutant"]["name"]: "Unviable" if o["summary"] == "Unviable" else "NotRun"
        for o in got["outcomes"]
        if isinstance(o["scenario"], dict) and "Mutant" in o["scenario"]
    }


def run(args: list[str]) -> int:
    covdir, outdir, rest = Path(args[0]), Path(args[1]), args[2:]
    passes, limit, filters, files = "both", None, [], []
    while rest:
        opt, val, rest = rest[0], rest[1], rest[2:]
        if opt == "--pass":
            passes = val
        elif opt == "--limit":
            limit = int(val)
        elif opt in ("--file", "--exclude-re", "--re"):
            filters += [opt, val]
            if opt == "--file":
                files.append(val)
        else:
            raise SystemExit(f"unknown option {opt}")
    root = Path.cwd()
    dirty = subprocess.run(
        ["git", "status", "--porcelain", "--", "src"], capture_output=True, text=True
    ).stdout
    if dirty:
        # A map of other code than the mutated would name the wrong lines.
        raise SystemExit(f"src/ differs from HEAD (an interrupted run's mutant?):\n{dirty}")
    tree = src_tree()
    lines_json = covdir / "lines.json"
    if not lines_json.exists() or json.loads(lines_json.read_text()).get("src_tree") != tree:
        print(f"mapping the tests' lines of src/ tree {tree}", file=sys.stderr)
        if collect(covdir.resolve()) != 0:
            return 1
    cover = json.loads(lines_json.read_text())
    cover["counted_sets"] = line_sets(cover["counted"])
    for t in cover["tests"].values():
        t["line_sets"] = line_sets(t["lines"])
    total = sum(t["seconds"] for t in cover["tests"].values())
    fast = {n for n, t in cover["tests"].items() if t["seconds"] < total * FAST_PERCENT / 100}
    listed = subprocess.run(
        ["cargo", "mutants", "--list", "--json", *filters], capture_output=True, text=True
    )
    if listed.returncode != 0:
        print(listed.stderr, file=sys.stderr)
        return 1
    mutants = json.loads(listed.stdout)
    outdir.mkdir(parents=True, exist_ok=True)
    state_path = outdir / "outcomes.json"
    state = json.loads(state_path.read_text()) if state_path.exists() else {}
    config = outdir / "nextest-order.toml"
    config.write_text(order_config({n: t["seconds"] for n, t in cover["tests"].items()}))
    todo = [m for m in mutants if m["name"] not in state]
    if limit is not None:
        todo = todo[:limit]
    groups: dict[tuple, list[dict]] = {}
    for m in todo:
        why, tests = reach(cover, root, m)
        m["why"] = why
        groups.setdefault((m["file"], tuple(tests)), []).append(m)
    print(f"{len(mutants)} listed, {len(todo)} to run, in {len(groups)} groups", file=sys.stderr)
    runs = outdir / "runs"
    runs.mkdir(exist_ok=True)
    for k, ((f, tests), ms) in enumerate(groups.items()):
        names = [m["name"] for m in ms]
        base = runs / f"{len(list(runs.iterdir())):04d}"
        if not tests:
            got = check_group(names, [f], base)
            for n in names:
                state[n] = {"outcome": got.get(n, "NotRun"), "tests": 0, "why": "no test runs it"}
            state_path.write_text(json.dumps(state, indent=1))
            continue
        left = names
        if passes in ("1", "both"):
            own = own_tests(f)
            kept = [t for t in tests if t in fast or t.startswith(own)]
            if kept:
                got = run_group(left, [f], kept, True, base.with_suffix(".1"), config)
                for n in left:
                    if got.get(n) in ("CaughtMutant", "Unviable"):
                        state[n] = {"outcome": got[n], "pass": 1, "tests": len(kept)}
                        state[n]["why"] = next(m["why"] for m in ms if m["name"] == n)
                # Kept now: a run stopped in pass 2 starts again after what pass 1 caught.
                state_path.write_text(json.dumps(state, indent=1))
                left = [n for n in left if n not in state]
        if left and passes in ("2", "both"):
            got = run_group(left, [f], list(tests), False, base.with_suffix(".2"), config)
            for n in left:
                state[n] = {"outcome": got.get(n, "NotRun"), "pass": 2, "tests": len(tests)}
        for m in ms:
            if m["name"] in state:
                state[m["name"]]["why"] = m["why"]
        state_path.write_text(json.dumps(state, indent=1))
        done = sum(1 for n in names if n in state)
        print(f"group {k + 1}/{len(groups)}: {done} of {len(names)} done", file=sys.stderr)
    counts: dict[str, int] = {}
    for v in state.values():
        counts[v["outcome"]] = counts.get(v["outcome"], 0) + 1
    print(json.dumps(counts), file=sys.stderr)
    return 0


def main(argv: list[str]) -> int:
    if len(argv) >= 2 and argv[0] == "collect":
        return collect(Path(argv[1]).resolve())
    if len(argv) >= 3 and argv[0] == "run":
        return run(argv[1:])
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
