"""Lifecycle (issue 18, item 2): a forked child casts; Ctrl-C stops casts (CPU and GPU), the
compiled scene's build and meshing;
an allocation the machine cannot satisfy raises MemoryError; many Python threads share a
scene (tests/test_bad_input.py). The risky cases run in child processes with time limits, so
that a regression fails instead of hanging or killing the test run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import tetrace

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork (POSIX)")


@pytest.fixture(scope="module")
def spot():
    return tetrace.default_scene()


def _rays(scene, n=2000, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = scene.domain
    o = lo + (hi - lo) * rng.random((n, 3))
    return o, rng.normal(size=(n, 3))


def _answers(scene, o, d, threads):
    h = scene.cast(o, d, threads=threads)
    return h.status, h.triangle, h.t


def _wait(pid, seconds):
    """The child's exit status, or None (and the child killed) after `seconds`."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return status
        time.sleep(0.02)
    os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
    return None


def test_a_forked_child_casts_and_builds(spot):
    o, d = _rays(spot)
    # The parent casts first on every kind of pool, so that their threads exist, then forks.
    want = {k: _answers(spot, o, d, k) for k in (None, 2, 1)}
    tets = spot.tetrahedralization
    pid = os.fork()
    if pid == 0:  # the child: never return into pytest
        code = 1
        try:
            same = all(
                all(np.array_equal(a, b) for a, b in zip(_answers(spot, o, d, k), want[None]))
                for k in (None, 2, 3, 1)  # 3: a pool the parent never had
            )
            # Building a scene runs parallel sorts: on tetrace's pool too, not rayon's global.
            again = tetrace.Scene(tets, spot.vertices, spot.faces)
            same &= np.array_equal(again.cast(o, d).triangle, want[None][1])
            code = 0 if same else 1
        except BaseException:  # noqa: BLE001  (reported as the exit status)
            import traceback

            traceback.print_exc()
            code = 2
        finally:
            os._exit(code)
    status = _wait(pid, 120)
    assert status is not None, "the forked child hung (timed out after 120 s)"
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, f"child status {status}"
    # The parent still casts, on the same pools.
    for k in (None, 2, 1):
        assert all(np.array_equal(a, b) for a, b in zip(_answers(spot, o, d, k), want[k]))


def _cast_in_child(spot, o, d, conn):
    conn.send([a.tolist() for a in _answers(spot, o, d, None)])
    conn.close()


def test_multiprocessing_fork_children_cast(spot):
    import multiprocessing

    o, d = _rays(spot, 500)
    want = [a.tolist() for a in _answers(spot, o, d, None)]
    ctx = multiprocessing.get_context("fork")
    here, there = ctx.Pipe()
    p = ctx.Process(target=_cast_in_child, args=(spot, o, d, there))
    p.start()
    try:
        assert here.poll(120), "the forked child hung (no answer in 120 s)"
        assert here.recv() == want
    finally:
        p.join(10)
        if p.is_alive():
            p.kill()
    assert p.exitcode == 0


# A child that casts for long (at least 20 s uninterrupted, judged from a timed sample) and
# reports how its cast ended.
INTERRUPTED_CAST = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    import tetrace

    query, threads = sys.argv[1], None if sys.argv[2] == "None" else int(sys.argv[2])
    s = tetrace.default_scene()
    rng = np.random.default_rng(1)
    lo, hi = s.domain
    def rays(n):
        return (lo + (hi - lo) * rng.random((n, 3))).astype(np.float32), rng.normal(
            size=(n, 3)).astype(np.float32)
    if query == "cast_gpu":
        run = lambda o, d, threads: s.cast(o, d, threads=threads, device="gpu")
    else:
        run = getattr(s, query)
    # The time per ray from a sample that runs at least 0.3 s (a fast machine's small sample
    # is mostly overhead), then as many rays as 20 s take, at most 12 million (memory).
    run(*rays(1000), threads=threads)  # a first call's one-time costs (GPU: compile, upload)
    sample = 20000
    while True:
        t0 = time.perf_counter()
        run(*rays(sample), threads=threads)
        took = time.perf_counter() - t0
        if took >= 0.3 or sample >= 3_000_000:
            break
        sample *= 4
    per_ray = took / sample
    n = int(min(20.0 / per_ray, 12_000_000))
    o, d = rays(n)
    print(f"expected {n * per_ray:.3f}", flush=True)
    try:
        run(o, d, threads=threads)
        print("finished", flush=True)
    except KeyboardInterrupt:
        print("KeyboardInterrupt", flush=True)
        h = s.cast(o[:1000], d[:1000], threads=threads)  # the scene still works
        print("after", int((h.status == tetrace.HIT).sum()), flush=True)
    """
)


@pytest.mark.parametrize(
    "query, threads",
    [("cast", "1"), ("cast", "None"), ("count_intersections", "2"), ("cast_gpu", "None")],
)
def test_ctrl_c_interrupts_a_long_cast(query, threads):
    if query == "cast_gpu":
        from conftest import gpu_device

        gpu_device()  # fails without an adapter (or skips with TETRACE_SKIP_GPU=1)
    p = subprocess.Popen(
        [sys.executable, "-c", INTERRUPTED_CAST, query, threads],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = p.stdout.readline()
        assert line.startswith("expected"), line + p.stderr.read()
        expected = float(line.split()[1])
        # A fifth in (a fast machine's 12 million rays may take under a second).
        time.sleep(min(1.0, expected / 5))
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
        stopped = time.monotonic() - sent
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert "KeyboardInterrupt" in out, out + err
    assert "finished" not in out
    assert "after" in out, out + err
    # A generous bound for 2 loaded cores (the poll is every 50 ms, a chunk is 4096 rays),
    # and on a fast machine half of what the uninterrupted cast would have taken.
    assert expected > 0.5, f"the cast is too short to tell ({expected} s)"
    assert stopped < min(5.0, expected / 2), f"stopped {stopped:.2f} s after SIGINT"


# A child that builds a compiled scene of 3 million tets (a Kuhn grid: 6 tets per cube of an
# 80^3 grid) twice: once to time it, once interrupted a quarter of that time in (a fixed delay
# made the test depend on the machine's speed); it reports both times.
INTERRUPTED_BUILD = textwrap.dedent(
    """
    import itertools, signal, threading, time
    import numpy as np
    from tetrace import _native

    n = 80
    ax = np.arange(n + 1)
    pts = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), -1).reshape(-1, 3).astype(float)
    i, j, k = [a.ravel() for a in np.meshgrid(*[np.arange(n)] * 3, indexing="ij")]
    corner = [((i + (b >> 2 & 1)) * (n + 1) + j + (b >> 1 & 1)) * (n + 1) + k + (b & 1)
              for b in range(8)]
    paths = []
    for perm in itertools.permutations(range(3)):
        b, path = 0, [0]
        for a in perm:
            b |= 4 >> a
            path.append(b)
        paths.append(path)
    tets = np.concatenate([np.stack([corner[p] for p in q], 1) for q in paths]).astype(np.uint32)
    none = (np.zeros((0, 3), np.uint32), np.zeros(0, np.uint32), np.zeros((0, 3, 3)))

    t0 = time.perf_counter()
    _native.NativeScene(pts, tets, *none)
    full = time.perf_counter() - t0
    print(f"full {full:.3f}", flush=True)
    # SIGINT to this process a quarter into the second build (from a thread: the main thread is
    # in the build, with the GIL released).
    threading.Timer(full / 4, signal.raise_signal, (signal.SIGINT,)).start()
    t0 = time.perf_counter()
    try:
        _native.NativeScene(pts, tets, *none)
        print("finished", flush=True)
    except KeyboardInterrupt:
        print(f"KeyboardInterrupt {time.perf_counter() - t0:.3f}", flush=True)
    """
)


def test_ctrl_c_interrupts_the_scene_build():
    """The compiled scene's build (connectivity, Hilbert order, locators) stops at its next
    stage: well before it would have finished."""
    out = subprocess.run(
        [sys.executable, "-c", INTERRUPTED_BUILD],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = out.stdout.split()
    assert "KeyboardInterrupt" in lines, out.stdout + out.stderr
    full = float(lines[lines.index("full") + 1])
    stopped = float(lines[lines.index("KeyboardInterrupt") + 1])
    # Signalled a quarter in, stopped at the next stage: well before the end, on a machine of
    # any speed (the build has several stages; 0.4 s leaves room for the thread's start).
    assert full > 0.4, f"the build is too short to tell ({full} s)"
    assert stopped < 0.75 * full, f"stopped after {stopped} s of a {full} s build"


INTERRUPTED_MESHING = textwrap.dedent(
    """
    import os, time
    from tetrace.mesh.isolate import _call_forked

    print("started", flush=True)
    try:
        _call_forked(time.sleep, 60)
        print("finished", flush=True)
    except KeyboardInterrupt:
        try:
            os.waitpid(-1, os.WNOHANG)
            print("KeyboardInterrupt, child left", flush=True)
        except ChildProcessError:
            print("KeyboardInterrupt, no child", flush=True)
    """
)


def test_ctrl_c_interrupts_meshing():
    # Meshing stages run in forked children (tetrace.mesh.isolate): Ctrl-C in the caller must
    # raise KeyboardInterrupt there and kill the child.
    p = subprocess.Popen(
        [sys.executable, "-c", INTERRUPTED_MESHING],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert p.stdout.readline().strip() == "started"
        time.sleep(1.0)
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=30)
        stopped = time.monotonic() - sent
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert "KeyboardInterrupt, no child" in out, out + err
    assert stopped < 5.0


# A child that limits its address space so that its ray arrays fit but a cast's outputs do not.
OUT_OF_MEMORY = textwrap.dedent(
    """
    import resource, sys
    import numpy as np
    import tetrace

    s = tetrace.default_scene()
    query = sys.argv[1]
    n = 10_000_000
    o = np.zeros((n, 3), np.float32)
    d = np.zeros((n, 3), np.float32)
    d[:, 2] = -1.0
    s.cast(o[:10], d[:10], threads=1)
    with open("/proc/self/status") as f:
        vm = next(int(l.split()[1]) * 1024 for l in f if l.startswith("VmSize:"))
    # Room for 8 bytes per ray: less than any query's outputs (occluded: 1 per ray, but
    # checked on 100x the rays through intersections' per-ray lists).
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    resource.setrlimit(resource.RLIMIT_AS, (vm + 8 * n, hard))
    try:
        if query == "cast":
            s.cast(o, d, threads=1)
        else:
            s.intersections(o, d, threads=1)
        print("no error", flush=True)
    except MemoryError as e:
        print("MemoryError:", e, flush=True)
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
    h = s.cast(o[:1000], d[:1000], threads=1)
    print("after", len(h), flush=True)
    """
)


@pytest.mark.parametrize("query", ["cast", "intersections"])
def test_allocation_failure_raises_memory_error(query):
    r = subprocess.run(
        [sys.executable, "-c", OUT_OF_MEMORY, query],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, f"status {r.returncode}: {r.stdout}{r.stderr[-2000:]}"
    assert "MemoryError: cannot allocate" in r.stdout, r.stdout + r.stderr[-2000:]
    if query == "cast":  # the size of all the outputs of 10M float32 rays: 37 bytes each
        assert "cannot allocate 370000000 bytes" in r.stdout, r.stdout
        assert "the hits of 10000000 rays" in r.stdout, r.stdout
    assert "after 1000" in r.stdout
