"""Shared fixtures: where the real test scenes live, and how their absence is reported.

The scenes are not in the repository. They sit in ``shared/scenes`` beside the
checkout (``<repo>/../shared/scenes``) or wherever ``TETRACE_SCENES`` points.
Locally a missing folder skips the tests that need it, said once in the report's
header and once at its end; under CI (``CI=true``) it fails them, so CI cannot pass
by skipping.

GPU tests are stricter: without a GPU adapter (Mesa's software drivers count: lavapipe
through Vulkan, llvmpipe through OpenGL) they fail,
locally too, unless ``TETRACE_SKIP_GPU=1`` says to skip them (:func:`gpu_device`).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCENES_NOT_FOUND = "shared scenes folder not found"


def in_ci() -> bool:
    """Return whether we run under CI (``CI=true``, as GitHub Actions and GitLab set it)."""
    return os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")


# The package must be installed (``make setup``): a tree that does not import is a failure.
import tetrace  # noqa: E402

TETRACE_IMPORT = f"installed package {Path(tetrace.__file__).parent}"


def skip_or_fail(reason: str):
    """Skip the test locally; fail it under CI, where a skip would hide missing coverage."""
    if in_ci():
        pytest.fail(f"{reason} (CI=true: failing instead of skipping)", pytrace=False)
    pytest.skip(reason)


#: The one opt-out of the GPU tests: set to ``1``, a missing adapter skips them instead of
#: failing them. Nothing else (not even ``CI``) makes a GPU test skip.
SKIP_GPU_VARIABLE = "TETRACE_SKIP_GPU"


def skip_gpu() -> bool:
    """Return whether ``TETRACE_SKIP_GPU=1`` is set (exactly ``1``)."""
    return os.environ.get(SKIP_GPU_VARIABLE, "").strip() == "1"


def gpu_device() -> dict:
    """The GPU adapter in use, for tests that need one.

    Without an adapter the test fails, with the error and what to install, unless
    ``TETRACE_SKIP_GPU=1`` is set: then it is skipped, saying so. An adapter that is
    found is always used, whatever the variable says.
    """
    from tetrace import gpu

    try:
        return gpu.device()
    except gpu.GpuError as e:
        reason = f"no GPU adapter: {e}"
        if skip_gpu():
            pytest.skip(f"{reason} ({SKIP_GPU_VARIABLE}=1)")
        pytest.fail(
            f"{reason}. Install a Vulkan driver (Mesa's lavapipe: apt-get install "
            f"mesa-vulkan-drivers libvulkan1; `make test` does, as root), or set "
            f"{SKIP_GPU_VARIABLE}=1 to skip the GPU tests",
            pytrace=False,
        )


def _scenes_missing_line() -> str:
    """The one line that says the shared scenes are missing, where, and what to do."""
    effect = "fail (CI=true)" if in_ci() else "skip"
    return (
        f"{SCENES_NOT_FOUND} at {_scenes_dir()}: the tests that need it {effect}. Set "
        f"TETRACE_SCENES to the folder (README.md, Tests; `make test` looks in ../shared/scenes)"
    )


def pytest_report_header(config):
    scenes = _scenes_dir()
    where = (
        f"tetrace scenes: {scenes}"
        if scenes.is_dir()
        else f"tetrace scenes: {_scenes_missing_line()}"
    )
    return [f"tetrace: {TETRACE_IMPORT}", where]


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Missing scenes are said once at the end, with how many tests skipped for them (their
    skips share one reason, so ``-ra`` folds them into one line too)."""
    skipped = terminalreporter.stats.get("skipped", [])
    n = sum(SCENES_NOT_FOUND in str(getattr(r, "longrepr", "")) for r in skipped)
    if n:
        terminalreporter.write_sep("-", "tetrace scenes")
        terminalreporter.write_line(f"{n} test{'s' * (n != 1)} skipped: {_scenes_missing_line()}")


def _scenes_dir() -> Path:
    env = os.environ.get("TETRACE_SCENES")
    if env:
        return Path(env).expanduser().resolve()
    return Path(__file__).resolve().parents[2] / "shared" / "scenes"


@pytest.fixture(scope="session")
def scenes_dir() -> Path:
    """Folder of the shared test scenes (it may not exist; use ``scene_path`` to require it)."""
    return _scenes_dir()


@pytest.fixture(scope="session")
def scene_path(scenes_dir):
    """Return a function ``name -> Path`` of a shared scene file.

    A missing scenes folder skips the test (fails it when ``CI=true``). A folder
    that exists but lacks the named file fails the test: that is a typo or an
    incomplete copy, not a missing optional resource.
    """

    def get(name: str) -> Path:
        if not scenes_dir.is_dir():
            # One reason for every test (not naming the file), so -ra folds them into one line.
            skip_or_fail(f"{SCENES_NOT_FOUND} at {scenes_dir}; set TETRACE_SCENES")
        path = scenes_dir / name
        if not path.is_file():
            pytest.fail(f"{name}: not in the shared scenes folder {scenes_dir}", pytrace=False)
        return path

    return get


@pytest.fixture(scope="session")
def open3d():
    """Require Open3D (``open3d-cpu`` in the ``test`` extra; it needs Debian's
    ``libusb-1.0-0``): skip without it locally, fail under CI. Returns the module."""
    from tetrace.bench.casters import open3d_module

    o3d, why = open3d_module()
    if o3d is None:
        skip_or_fail(f"{why} (pip install open3d-cpu; apt-get install libusb-1.0-0)")
    return o3d


@pytest.fixture(scope="session")
def embree():
    """Require the ``embreex`` reference: skip without it locally, fail under CI."""
    from tetrace.baselines.embree import embree_available

    if not embree_available():
        skip_or_fail("embreex is not installed (pip install embreex)")
    return True


@pytest.fixture(scope="session")
def warp():
    """Require warp-lang (``warp-lang`` in the ``test`` extra; its CPU device needs no GPU):
    skip without it locally, fail under CI. Returns the module."""
    from tetrace.bench.casters import warp_module

    wp, why = warp_module()
    if wp is None:
        skip_or_fail(f"{why} (pip install warp-lang)")
    return wp


@pytest.fixture(scope="session")
def mitsuba():
    """Require mitsuba with both variants the benches run, ``scalar_rgb`` and ``llvm_ad_rgb``
    (``mitsuba`` in the ``test`` extra; the LLVM variant needs the system's libLLVM, which
    Mesa's lavapipe brings): skip without them locally, fail under CI. Returns the module."""
    from tetrace.bench.casters import mitsuba_module

    for variant in ("llvm_ad_rgb", "scalar_rgb"):
        mi, why = mitsuba_module(variant)
        if mi is None:
            skip_or_fail(f"{why} (pip install mitsuba; apt-get install libllvm15)")
    return mi


def own_default_scene():
    """The bundled scene as an object of the test's own, for tests that rebuild its structures.

    :func:`tetrace.default_scene` returns one cached object per process, which every test
    on the worker shares; a test that builds its BVH, exact BVH or octree with other
    parameters would change the answers (``steps``) that later tests see. This copy shares
    the cached scene's tetrahedralization (no second meshing) and nothing else.
    """
    shared = tetrace.default_scene()
    return tetrace.Scene(shared.tetrahedralization, shared.vertices, shared.faces)
