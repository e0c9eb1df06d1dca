# Developer and CI entry points. `make test` is what .ci/run calls.
PY ?= python3
PIP ?= $(PY) -m pip
CARGO ?= cargo
# pytest-xdist workers (CI has 2 cores).
PYTEST_WORKERS ?= 2
# Extra pytest arguments, e.g. `make test PYTEST_EXTRA="-k reference -x"`.
PYTEST_EXTRA ?=
# Notebooks run as tests through nbmake; the folder is passed only if it exists.
NOTEBOOKS := $(wildcard notebooks)

# rustup installs cargo in ~/.cargo/bin, which non-login shells often lack.
export PATH := $(HOME)/.cargo/bin:$(PATH)

.PHONY: setup demo lint test test-rust test-python

# Editable install: maturin builds the Rust extension (tetrace._native) into python/tetrace/.
setup:
	$(PIP) install -q -e ".[test]"

demo: setup
	$(PY) -m tetrace.dev.demo

# Style and static checks, all of which must pass in CI: rustfmt, clippy with warnings as
# errors (every allow is named, with its reason beside it), the CPU-only build (no wgpu/naga),
# ruff (lint and format) and stubtest (the hand-written _native.pyi against the built
# extension, so the stub cannot drift). Runs every check and fails if any failed.
lint: setup
	@status=0; \
	for cmd in "$(CARGO) fmt --check" \
	           "$(CARGO) clippy --all-targets --features python -- -D warnings" \
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
test: setup
	@status=0; \
	echo "+ $(CARGO) test"; \
	$(CARGO) test || status=1; \
	echo "+ $(PY) -m pytest -n $(PYTEST_WORKERS) -ra tests $(if $(NOTEBOOKS),--nbmake $(NOTEBOOKS)) $(PYTEST_EXTRA)"; \
	$(PY) -m pytest -n $(PYTEST_WORKERS) -ra tests $(if $(NOTEBOOKS),--nbmake $(NOTEBOOKS)) $(PYTEST_EXTRA) || status=1; \
	exit $$status

# The two halves on their own (no setup step).
test-rust:
	$(CARGO) test

test-python:
	$(PY) -m pytest -n $(PYTEST_WORKERS) -ra tests $(if $(NOTEBOOKS),--nbmake $(NOTEBOOKS)) $(PYTEST_EXTRA)
