"""tetrace.memory_cache: the freed answer blocks the extension keeps for the next cast
(src/py/alloc.rs). The answers do not depend on it; what it holds and gives back does."""

import gc

import numpy as np
import pytest

import tetrace


@pytest.fixture
def restore_limit():
    before = tetrace.memory_cache()["limit"]
    yield
    tetrace.memory_cache(before)


def test_a_casts_freed_columns_are_kept_and_limit_zero_gives_them_back(restore_limit):
    assert tetrace.memory_cache()["limit"] == 256 << 20  # the documented default
    scene = tetrace.default_scene()
    rng = np.random.default_rng(5)
    n = 400_000  # a float32 column of n rays is 1.6 MB, above the 1 MiB kept
    lo, hi = scene.vertices.min(0), scene.vertices.max(0)
    o = (lo + (hi - lo) * rng.random((n, 3))).astype(np.float32)
    d = rng.normal(size=(n, 3)).astype(np.float32)
    first = scene.cast(o, d, threads=1)
    t, tri = first.t.copy(), first.triangle.copy()
    assert first.normal.shape == (n, 3)  # normals are made when first read (hits.py)
    tetrace.memory_cache(0)
    assert tetrace.memory_cache()["bytes"] == 0
    tetrace.memory_cache(256 << 20)
    del first
    gc.collect()
    kept = tetrace.memory_cache()
    # t, u, v, triangle, tet, steps (n * 4 bytes each), point (n * 12), the normals read
    # above (n * 12).
    assert kept["blocks"] >= 8
    assert kept["bytes"] >= 6 * 4 * n + 2 * 12 * n
    again = scene.cast(o, d, threads=1)  # takes the kept blocks back
    assert tetrace.memory_cache()["bytes"] < kept["bytes"]
    np.testing.assert_array_equal(again.t.view(np.uint32), t.view(np.uint32))
    np.testing.assert_array_equal(again.triangle, tri)
    assert tetrace.memory_cache(0) == {"blocks": 0, "bytes": 0, "limit": 0}
    del again
    gc.collect()
    assert tetrace.memory_cache()["bytes"] == 0  # nothing kept at limit 0


@pytest.mark.parametrize(
    "bad, error", [(-1, ValueError), ("1", TypeError), (1.5, TypeError), (True, TypeError)]
)
def test_a_bad_limit_is_refused(bad, error, restore_limit):
    before = tetrace.memory_cache()
    with pytest.raises(error, match="limit"):
        tetrace.memory_cache(bad)
    assert tetrace.memory_cache() == before
