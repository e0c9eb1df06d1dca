# Developer and CI entry points. `make demo` and `make test` are the README's two commands;
# .ci/run calls `make lint` and `make test` with CI=true, so CI runs what the README says.
#
# Python: a virtual environment in .venv, made from $(PYTHON) on first use (Python >= 3.10).
# `make test PY=/path/to/python` uses that interpreter as it is instead (no venv is made).
PYTHON ?= python3
VENV ?= .venv
PY ?= $(VENV)/bin/python
PIP ?= $(PY) -m pip
CARGO ?= cargo
# Cargo profile of the extension (passed to maturin): the tests and lint build `quick`
# (Cargo.toml: release without fat LTO, parallel codegen; they check answers, not speed), the
# demo `release` (fat LTO: its throughput is the point). Each keeps its own target/ folder.
TEST_PROFILE ?= quick
DEMO_PROFILE ?= release
# The Debian packages the tests need (.ci/system-packages): `install` installs the missing
# ones when run as root (otherwise names them and fails), `check` names them and fails,
# `skip` does neither (a system that is not Debian, with the equivalents installed).
SYSTEM_PACKAGES ?= install
# pytest-xdist workers (CI has 2 cores).
PYTEST_WORKERS ?= 2
# Extra pytest arguments, e.g. `make test PYTEST_EXTRA="-k reference -x"`.
PYTEST_EXTRA ?=
# Cargo features the Rust tests and clippy turn on beyond the default ones: test tooling that
# stays out of the wheel (Cargo.toml: `fuzz`, the fuzz targets; `gpu-octree`, the GPU octree
# walk its tests measure).
TEST_FEATURES ?= fuzz,gpu-octree
# Notebooks run as tests through nbmake; the folder is passed only if it exists.
NOTEBOOKS := $(wildcard notebooks)
# The Rust tests, built in the extension's profile with its features (`python` too) so that
# every dependency (wgpu and naga are most of the build) is the one `setup` compiled for the
# extension, not compiled again: CI's time goes mostly to compiling. Only the crate itself is
# built again, once, as its own test harness (`--lib`: the crate-wide tests live in src/tests/,
# so no integration test needs it built a second time as a library; there are no doctests),
# with debug assertions and overflow checks on, as a test build has them.
RUST_TEST = $(CARGO) test --profile $(TEST_PROFILE) --features python,$(TEST_FEATURES) --lib \
	--config 'profile.$(TEST_PROFILE).package.tetrace.debug-assertions=true' \
	--config 'profile.$(TEST_PROFILE).package.tetrace.overflow-checks=true'

REPO := $(patsubst %/,%,$(dir $(abspath $(lastword $(MAKEFILE_LIST)))))
RUST_VERSION := $(shell sed -n 's/^rust-version *= *"\(.*\)"/\1/p' $(REPO)/Cargo.toml)

# The shared test scenes (not in the repository): ../shared/scenes beside the checkout,
# unless TETRACE_SCENES points elsewhere. Without them the tests that need them skip, and
# pytest says so once (tests/conftest.py); under CI=true they fail.
ifeq ($(origin TETRACE_SCENES),undefined)
ifneq ($(wildcard $(REPO)/../shared/scenes),)
export TETRACE_SCENES := $(abspath $(REPO)/../shared/scenes)
endif
endif

# rustup installs cargo in ~/.cargo/bin, which non-login shells often lack.
export PATH := $(HOME)/.cargo/bin:$(PATH)

.PHONY: venv toolchain system-packages setup setup-demo demo lint test test-rust test-python

# The venv (unless PY names another interpreter), and a check of the Python version.
venv:
	@if [ "$(PY)" = "$(VENV)/bin/python" ] && [ ! -x "$(PY)" ]; then \
	    if ! $(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 10))' 2>/dev/null; then \
	        echo "error: tetrace needs Python >= 3.10 to make $(VENV); $(PYTHON) is" \
	             "'$$($(PYTHON) --version 2>&1)'. Name another: make PYTHON=python3.11 ..." >&2; \
	        exit 1; \
	    fi; \
	    echo "+ $(PYTHON) -m venv $(VENV)"; \
	    if ! $(PYTHON) -m venv $(VENV); then \
	        rm -rf $(VENV); \
	        echo "error: $(PYTHON) cannot make a virtual environment (Debian's own python3" \
	             "needs: apt-get install python3-venv)" >&2; \
	        exit 1; \
	    fi; \
	    $(PY) -m pip install -q --upgrade pip; \
	fi
	@$(PY) -c 'import sys; sys.exit(sys.version_info < (3, 10))' || { \
	    echo "error: tetrace needs Python >= 3.10; $(PY) is '$$($(PY) --version 2>&1)'" >&2; \
	    exit 1; }

# Rust (Cargo.toml's rust-version or newer) and the C linker it needs.
toolchain:
	@command -v $(CARGO) >/dev/null || { \
	    echo "error: cargo not found: tetrace's core is Rust ($(RUST_VERSION) or newer)." \
	         "Install it with rustup: curl --proto '=https' --tlsv1.2 -sSf" \
	         "https://sh.rustup.rs | sh -s -- -y" >&2; \
	    exit 1; }
	@have=$$(rustc --version | cut -d' ' -f2); \
	if [ "$$(printf '%s\n' "$(RUST_VERSION)" "$$have" | sort -V | head -n1)" != "$(RUST_VERSION)" ]; then \
	    echo "error: Rust $$have is older than $(RUST_VERSION) (Cargo.toml rust-version):" \
	         "rustup update stable" >&2; \
	    exit 1; \
	fi
	@command -v cc >/dev/null || { \
	    echo "error: no C compiler (cc), which Rust links with (Debian: apt-get install gcc)" >&2; \
	    exit 1; }

system-packages:
	@$(if $(filter skip,$(SYSTEM_PACKAGES)),:,$(REPO)/.ci/system-packages $(SYSTEM_PACKAGES))

# Editable install: maturin builds the Rust extension (tetrace._native) into python/tetrace/.
# The first build compiles every crate (wgpu and naga are most of it): minutes; later ones
# rebuild what changed.
setup: venv toolchain
	@echo "+ $(PIP) install -e '.[test]'  (Rust extension, profile $(TEST_PROFILE))"
	@MATURIN_PEP517_ARGS="--profile $(TEST_PROFILE)" $(PIP) install -q -e ".[test]"

# The demo needs only embreex and matplotlib beside tetrace (the `demo` extra; peers already
# installed, as by `make test`, are timed too).
setup-demo: venv toolchain
	@echo "+ $(PIP) install -e '.[demo]'  (Rust extension, profile $(DEMO_PROFILE))"
	@MATURIN_PEP517_ARGS="--profile $(DEMO_PROFILE)" $(PIP) install -q -e ".[demo]"

# Builds the bundled scene (Spot), casts a 1024x1024 camera, writes tetrace_demo.png and
# prints Mrays/s against Embree (python -m tetrace.demo --help).
demo: setup-demo
	$(PY) -m tetrace.demo

# Style and static checks, all of which must pass in CI: rustfmt, clippy with warnings as
# errors (every allow is named, with its reason beside it), the CPU-only build (no wgpu/naga),
# ruff (lint and format) and stubtest (the hand-written _native.pyi against the built
# extension, so the stub cannot drift). Runs every check and fails if any failed.
lint: setup
	@status=0; \
	for cmd in "$(CARGO) fmt --check" \
	           "$(CARGO) clippy --all-targets --features python,$(TEST_FEATURES) -- -D warnings" \
	           "$(CARGO) check --no-default-features" \
	           "$(PY) -m ruff check python tests" \
	           "$(PY) -m ruff format --check python tests" \
	           "$(PY) -m mypy.stubtest tetrace._native"; do \
		echo "+ $$cmd"; $$cmd || status=1; \
	done; \
	exit $$status

# Runs the Rust tests and the Python tests (and notebooks) even if the first part
# fails, so one run reports everything; exits non-zero if either failed. pytest's
# exit code 5 (no tests collected) counts as a failure.
test: system-packages setup
	@status=0; \
	echo "+ $(RUST_TEST)"; \
	$(RUST_TEST) || status=1; \
	echo "+ $(PY) -m pytest -n $(PYTEST_WORKERS) -ra tests $(if $(NOTEBOOKS),--nbmake $(NOTEBOOKS)) $(PYTEST_EXTRA)"; \
	$(PY) -m pytest -n $(PYTEST_WORKERS) -ra tests $(if $(NOTEBOOKS),--nbmake $(NOTEBOOKS)) $(PYTEST_EXTRA) || status=1; \
	exit $$status

# The two halves on their own (no setup step).
test-rust:
	$(RUST_TEST)

test-python:
	$(PY) -m pytest -n $(PYTEST_WORKERS) -ra tests $(if $(NOTEBOOKS),--nbmake $(NOTEBOOKS)) $(PYTEST_EXTRA)

# The core's Rust tests built for aarch64 and run under qemu's user-mode emulation (not in CI:
# about 2.5 minutes to build and 9 to run on the 2-core VM). On aarch64 the portable level is
# the only one (src/simd.rs), so this runs the scalar walks, filters and roundings against the
# referee as an aarch64 machine would. Needs Debian's qemu-user, gcc-aarch64-linux-gnu and
# libc6-dev-arm64-cross, and `rustup target add aarch64-unknown-linux-gnu`; no GPU or Python.
AARCH64 := aarch64-unknown-linux-gnu
.PHONY: test-aarch64
test-aarch64: toolchain
	rustup target add $(AARCH64)
	CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc \
	CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER="qemu-aarch64 -L /usr/aarch64-linux-gnu" \
	$(CARGO) test --target $(AARCH64) --no-default-features --features fuzz --lib \
	  --profile $(TEST_PROFILE) --target-dir target/aarch64 -- --test-threads $(PYTEST_WORKERS)

# The GPU bench on the bundled scene, small enough for CI (issue 34's host-time measure: the
# whole GPU cast less the kernel, 512² camera, best of 3, printed in CI's log on lavapipe; a
# goal of the bench, not a test: a crash or a ray the referee finds wrong fails it, a time never).
.PHONY: bench-gpu-smoke
bench-gpu-smoke:
	$(PY) -m tetrace.bench gpu --width 512 --height 512 --random 100000 --sample 20000 --repeat 3 --check

# Mutation testing of the exact core (issue 37; not in CI: hours on 2 cores). cargo-mutants
# changes one function at a time in the files below and runs the Rust library tests against
# each change; a mutant no test catches is a path no test reaches (docs/testing.md).
# MUTANTS_SHARD=k/n runs the k-th of n parts (a session can take one part).
MUTANTS_FILES ?= src/query/*.rs src/traverse/exact.rs src/traverse/walk.rs src/traverse/packet.rs src/geom/*.rs src/locate/*.rs src/accel/**/*.rs
MUTANTS_SHARD ?= 0/1
# The fast, filtered test command each mutant runs: the CPU core alone (no wgpu to link), the
# library's tests (src/query/tests/closest_order.rs, the Kuhn-grid order test, among them), by cargo-nextest,
# which stops at the first failure. `--in-place` mutates this checkout (restored after each
# mutant): run it in a worktree of its own (git worktree add ../mut) while you work here.
# The test profile at opt-level 1 without debug info: a mutant's rebuild took 52 s on a 2-core
# Zen 3 VM (87 s with the profile's full debug info, 4 min at its opt-level 2; stop 72), and
# the tests still run in about 5 minutes there. The timeout also bounds the unmutated
# baseline: on that VM, niced beside other work, its 172 tests took 299.5 s and the run
# stopped at 300 (stop 71); 600 leaves room, and a mutant that loops still ends. nextest
# stops at the first failure without waiting for the tests still running.
MUTANTS_ARGS ?= --in-place --no-shuffle --test-tool nextest --no-default-features --features fuzz -C --lib --timeout 600 --cargo-test-arg=--max-fail=1:immediate
# MUTANTS_REACH=1 runs each mutant against only the tests that enter a function of
# MUTANTS_FILES (python/tetrace/dev/mutants_reach.py finds them first, in the same checkout
# and build): a mutant in a body no other test runs cannot change their outcome, and for a
# file few tests reach the rest of the suite is most of a survivor's time.
MUTANTS_REACH ?= 0
# MUTANTS_FAST=1 runs two passes (python/tetrace/dev/mutants_fast.py says why): every mutant
# with the crate at opt-level 0 (an 8.5 s rebuild there) against the tests that each took
# under MUTANTS_FAST_PERCENT of the suite's time unoptimised, then what that pass did not
# catch at opt-level 1 against the whole suite (--iterate skips the caught). The two miss
# exactly what one full run misses.
# Both run the fastest tests first (a nextest config the script writes), so that a caught
# mutant's first failure comes sooner.
MUTANTS_FAST ?= 0
MUTANTS_FAST_PERCENT ?= 1
MUTANTS_OPT0 = --cargo-arg=--config --cargo-arg=profile.test.package.tetrace.opt-level=0
# MUTANTS_COVER=1 runs each mutant against the tests that executed a line of it, by
# source-based coverage (python/tetrace/dev/mutants_cover.py says how and why), in the same two
# passes, resumably: MUTANTS_COVER_OUT keeps each mutant's outcome, and a mutant with one is
# not run again. MUTANTS_COVER_ARGS passes cargo-mutants' filters on (`--exclude-re RE`,
# `--re RE`) and `--limit N` (stop after N mutants). MUTANTS_ARGS and MUTANTS_SHARD do not apply.
MUTANTS_COVER ?= 0
MUTANTS_COVER_DIR ?= target/mutants-cover
MUTANTS_COVER_OUT ?= mutants-cover.out
MUTANTS_COVER_ARGS ?=
.PHONY: mutants
mutants: toolchain
	@$(CARGO) mutants --version >/dev/null 2>&1 || $(CARGO) install --locked cargo-mutants
	@$(CARGO) nextest --version >/dev/null 2>&1 || $(CARGO) install --locked cargo-nextest
ifeq ($(MUTANTS_COVER),1)
	rustup component add llvm-tools >/dev/null && \
	python3 python/tetrace/dev/mutants_cover.py run $(MUTANTS_COVER_DIR) $(MUTANTS_COVER_OUT) \
	  $(foreach f,$(MUTANTS_FILES),--file '$(f)') $(MUTANTS_COVER_ARGS)
else
	export CARGO_PROFILE_TEST_OPT_LEVEL=1 CARGO_PROFILE_TEST_DEBUG=0 && \
	reach=$$(if [ "$(MUTANTS_REACH)" = 1 ]; then python3 python/tetrace/dev/mutants_reach.py $(foreach f,$(MUTANTS_FILES),'$(f)'); else echo 'all()'; fi) && \
	run() { $(CARGO) mutants $(MUTANTS_ARGS) $(foreach f,$(MUTANTS_FILES),--file '$(f)') --shard $(MUTANTS_SHARD) "$$@"; } && \
	if [ "$(MUTANTS_FAST)" = 1 ]; then \
	  order="$(CURDIR)/target/mutants-nextest.toml" && mkdir -p target && \
	  fast=$$(python3 python/tetrace/dev/mutants_fast.py $(MUTANTS_FAST_PERCENT) "$$order") && \
	  { run $(MUTANTS_OPT0) --cargo-test-arg=--config-file --cargo-test-arg="$$order" \
	      --cargo-test-arg=-E --cargo-test-arg="($$reach) & ($$fast)"; \
	    rc=$$?; [ $$rc = 0 ] || [ $$rc = 2 ] || [ $$rc = 3 ] || exit $$rc; } && \
	  run --iterate --cargo-test-arg=--config-file --cargo-test-arg="$$order" \
	    --cargo-test-arg=-E --cargo-test-arg="$$reach"; \
	else \
	  run --cargo-test-arg=-E --cargo-test-arg="$$reach"; \
	fi
endif
