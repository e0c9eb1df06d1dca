"""The README's commands are what CI runs, and what it states matches the repository (issue 36).

CI (``.ci/run``) runs the README's ``make test``, so a fresh clone that passes CI passes with
the README's steps; these checks keep the two from drifting apart: the commands, the
requirements (Python, Rust, the Debian packages), the profiles the Makefile builds, and the
files the README links to.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text()


def _toml(name):
    try:
        import tomllib
    except ImportError:  # Python 3.10
        tomllib = pytest.importorskip("tomli")
    with open(REPO / name, "rb") as f:
        return tomllib.load(f)


def test_readme_opens_with_the_two_commands():
    first_block = re.search(r"```bash\n(.*?)```", README, re.S).group(1)
    commands = [line.split("#")[0].strip() for line in first_block.splitlines()]
    assert commands == ["make demo", "make test"]
    # nothing but the title and one paragraph before them
    assert README.index("```bash") < README.index("\n## ")


def test_ci_runs_the_readmes_test_command():
    run = (REPO / ".ci" / "run").read_text()
    steps = [ln.strip() for ln in run.splitlines() if re.match(r"\s*make \w", ln)]
    # then the GPU bench's smoke run, which prints issue 34's host time (a benchmark)
    assert [s.split()[1] for s in steps] == ["lint", "test", "bench-gpu-smoke"], steps
    # CI does not point make at another interpreter: it uses the venv the README describes
    assert not any(re.search(r"\bPY=", s) for s in steps), steps
    assert not re.search(r"^\s*export PY=", run, re.M)
    assert "CI=" in run and ".ci/system-packages" in run


def test_makefile_targets_and_profiles():
    make = (REPO / "Makefile").read_text()
    assert re.search(r"^test: system-packages setup$", make, re.M)
    assert re.search(r"^demo: setup-demo$", make, re.M)
    assert re.search(r"^PY \?= \$\(VENV\)/bin/python$", make, re.M)
    profiles = _toml("Cargo.toml")["profile"]
    test_profile = re.search(r"^TEST_PROFILE \?= (\S+)$", make, re.M).group(1)
    demo_profile = re.search(r"^DEMO_PROFILE \?= (\S+)$", make, re.M).group(1)
    assert demo_profile == "release"
    # the demo's extra holds what python -m tetrace.demo imports beyond tetrace's dependencies
    demo_extra = _toml("pyproject.toml")["project"]["optional-dependencies"]["demo"]
    assert {re.split(r"[<>=]", d)[0] for d in demo_extra} == {"embreex", "matplotlib"}
    assert re.search(r'install -q -e "\.\[demo\]"', make)
    assert profiles[test_profile]["inherits"] == "release"
    assert profiles[test_profile]["lto"] is False


def test_readme_requirements_match_the_project():
    rust = _toml("Cargo.toml")["package"]["rust-version"]
    python = _toml("pyproject.toml")["project"]["requires-python"]
    assert python == ">=3.10"
    assert f"| Rust | ≥ {rust} " in README
    assert "| Python | ≥ 3.10 " in README


def test_readme_lists_the_system_packages():
    listed = subprocess.run(
        ["bash", str(REPO / ".ci" / "system-packages"), "list"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    assert listed
    assert f"`{' '.join(listed)}`" in README


def test_readme_links_exist():
    for path in set(re.findall(r"\]\(((?:docs|python)/[^)#]+)\)", README)) | set(
        re.findall(r"`((?:docs|python/tetrace)/[\w/.]+\.(?:md|py|obj))`", README)
    ):
        assert (REPO / path).exists(), path


def test_every_bench_subcommand_is_documented():
    from tetrace.bench.__main__ import SUBCOMMANDS

    text = (REPO / "docs" / "benchmarks.md").read_text()
    missing = [name for name in SUBCOMMANDS if f"python -m tetrace.bench {name}" not in text]
    assert not missing, f"add a paragraph on each to docs/benchmarks.md: {missing}"


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_make_test_dry_run_uses_the_venv_and_the_quick_profile():
    out = subprocess.run(
        ["make", "-n", "test"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout
    assert ".ci/system-packages install" in out
    assert "-m venv .venv" in out
    assert 'MATURIN_PEP517_ARGS="--profile quick"' in out
    assert ".venv/bin/python -m pytest" in out
