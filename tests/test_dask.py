"""Casting and meshing on a Dask ``distributed`` cluster (issue 18, item 6; docs/dask.md).

A ``LocalCluster`` of 2 worker processes casts a chunked Dask array of rays: every field
must equal a local cast's, bit for bit, in the same chunks, and each worker must load the
scene once (counted on the workers: one ``Scene.from_bytes`` per worker, however many blocks
it casts, even when Dask drops its copy and fetches it again). Meshing two scenes as tasks
must give scenes that cast as locally built ones do.
"""

import dataclasses
import logging

import numpy as np
import pytest

import tetrace

from conftest import skip_or_fail

try:
    import dask
    import dask.array as da
    import distributed

    import tetrace.dask
except ImportError:  # pragma: no cover - the test extra installs them
    dask = None

# Every per-ray field (``timings``, a GPU cast's, is not one).
FIELDS = [f.name for f in dataclasses.fields(tetrace.Hits) if f.name != "timings"]


def _count_calls():
    """On a worker: count ``Scene.from_bytes`` (unpickling) and ``Scene.cast`` calls."""
    import tetrace as t

    counts = {"from_bytes": 0, "cast": 0}
    load, cast = t.Scene.from_bytes.__func__, t.Scene.cast

    def from_bytes(cls, *args, **kwargs):
        counts["from_bytes"] += 1
        return load(cls, *args, **kwargs)

    def counted_cast(self, *args, **kwargs):
        counts["cast"] += 1
        return cast(self, *args, **kwargs)

    t.Scene.from_bytes = classmethod(from_bytes)
    t.Scene.cast = counted_cast
    t._test_counts = counts


def _read_counts():
    import tetrace as t

    return dict(t._test_counts)


@pytest.fixture(scope="module")
def client():
    if dask is None:
        skip_or_fail("dask[array] and distributed are not installed (pip install -e '.[test]')")
    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def random_rays(n, seed=3):
    rng = np.random.default_rng(seed)
    scene = tetrace.default_scene()
    lo, hi = scene.domain
    o = lo + (hi - lo) * rng.uniform(0, 1, (n, 3))
    d = rng.normal(size=(n, 3))
    return np.concatenate([o, d], axis=1)


def test_cast_matches_a_local_cast_and_ships_the_scene_once(client):
    client.run(_count_calls)
    scene = tetrace.default_scene()
    rays = random_rays(24_000)
    chunks = 3000
    hits = tetrace.dask.cast_dask(scene, da.from_array(rays, chunks=(chunks, 6)), fields=FIELDS)
    # Dask's Active Memory Manager drops replicas no task waits on yet (every 2 s; CI's load
    # once let it run here): run it now, so that a worker has to fetch the scene again.
    client.amm.run_once()
    assert set(hits) == {f for f in FIELDS if getattr(scene.cast(rays[:1]), f) is not None}
    computed = dict(zip(hits, dask.compute(*hits.values())))
    local = scene.cast(rays)
    assert np.count_nonzero(local.status == tetrace.HIT) > 1000
    for name, arr in hits.items():
        assert arr.chunks[0] == (chunks,) * 8, name
        want = getattr(local, name)
        assert computed[name].dtype == want.dtype, name
        assert np.array_equal(computed[name], want, equal_nan=want.dtype.kind == "f"), name
    counts = client.run(_read_counts)
    assert len(counts) == 2
    # Each worker loaded the scene once, however many of the 8 blocks it cast and though one
    # fetched it again; a scene sent with every task would count once per block.
    assert sorted(c["from_bytes"] for c in counts.values()) == [1, 1], counts
    assert sum(c["cast"] for c in counts.values()) == 8, counts


def test_scattered_scene_origins_directions_float32(client):
    scene = tetrace.default_scene()
    rays = random_rays(5000, seed=4).astype(np.float32)
    future = tetrace.dask.scatter_scene(scene, client)
    o = da.from_array(rays[:, :3], chunks=1000)
    d = da.from_array(rays[:, 3:], chunks=2500)  # rechunked to the origins' chunks
    hits = tetrace.dask.cast_dask(
        future, o, d, fields=("t", "point", "status"), local_scene=scene, tmax=2.0
    )
    assert hits["point"].chunks == ((1000,) * 5, (3,))
    t, point, status = dask.compute(hits["t"], hits["point"], hits["status"])
    local = scene.cast(rays[:, :3], rays[:, 3:], tmax=2.0)
    assert t.dtype == np.float32
    assert np.array_equal(t, local.t) and np.array_equal(status, local.status)
    assert np.array_equal(point, local.point, equal_nan=True)
    with pytest.raises(ValueError, match="scalar tmax"):
        tetrace.dask.cast_dask(future, o, d, local_scene=scene, tmax=np.ones(5000))
    with pytest.raises(ValueError, match="fields"):
        tetrace.dask.cast_dask(future, o, d, local_scene=scene, fields=("nope",))


def test_mesh_many_builds_scenes_as_tasks(client):
    import trimesh

    meshes = [
        trimesh.creation.icosphere(subdivisions=2),
        trimesh.creation.box(extents=(1.0, 2.0, 0.5)),
    ]
    meshes = [(np.asarray(m.vertices), np.asarray(m.faces)) for m in meshes]
    futures = tetrace.dask.mesh_many(meshes, client=client, preset="quality")
    remote = client.gather(futures)
    rng = np.random.default_rng(5)
    for (v, f), scene in zip(meshes, remote):
        here = tetrace.Scene.from_mesh((v, f), preset="quality")
        assert scene.n_tets == here.n_tets and np.array_equal(scene.points(), here.points())
        o = rng.uniform(-2, 2, (2000, 3))
        d = rng.normal(size=(2000, 3))
        a, b = scene.cast(o, d), here.cast(o, d)
        for name in ("t", "triangle", "u", "v", "tet", "status"):
            assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name
        assert np.count_nonzero(a.status == tetrace.HIT) > 100
