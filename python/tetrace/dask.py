"""Scale casts and meshing out on a Dask ``distributed`` cluster (``docs/dask.md``).

:func:`cast_dask` casts a Dask array of rays, chunked along the rays, and returns the hits
as Dask arrays in the same chunks; the scene is scattered to every worker and loaded there
once (from its scene file bytes, without meshing), and every block's task refers to that
copy. :func:`mesh_many` meshes scenes in
parallel, one task per scene. Needs ``dask[array]`` and ``distributed``; ``import tetrace``
does not import this module.

>>> from distributed import Client, LocalCluster                    # doctest: +SKIP
>>> client = Client(LocalCluster(n_workers=2, threads_per_worker=1))  # doctest: +SKIP
>>> rays = dask.array.from_array(rays_np, chunks=(100_000, 6))       # doctest: +SKIP
>>> hits = tetrace.dask.cast_dask(scene, rays)                        # doctest: +SKIP
>>> t, triangle = dask.compute(hits["t"], hits["triangle"])          # doctest: +SKIP
"""

from __future__ import annotations

import threading
import uuid
from collections import OrderedDict

import numpy as np

from .scene import Scene

__all__ = ["scatter_scene", "cast_dask", "mesh_many", "FIELDS"]

#: The :class:`tetrace.Hits` fields :func:`cast_dask` can return, in order.
FIELDS = (
    "t",
    "triangle",
    "u",
    "v",
    "point",
    "normal",
    "tet",
    "steps",
    "status",
    "geometry",
    "scene_triangle",
)


def _client(client):
    if client is None:
        from distributed import get_client

        client = get_client()
    return client


class _Shipped:
    """A scene scattered to workers, under a token drawn when it was scattered.

    Dask's Active Memory Manager drops the replicas no task waits on yet (every 2 s), and a
    worker that needs the scene again fetches it again. Unpickling goes through
    :func:`_arrive`, which looks the token up first: a worker loads each scattered scene
    once (:meth:`tetrace.Scene.from_bytes`), however often its bytes reach it.
    """

    __slots__ = ("scene", "token")

    def __init__(self, scene, token):
        self.scene = scene
        self.token = token

    def __reduce__(self):
        return (_arrive, (self.token, self.scene.to_bytes()))


#: On a worker: the scenes loaded lately, by token (the last :data:`_KEEP`; a cast reads a
#: scene and never changes it, so tasks may share one).
_LOADED = OrderedDict()
_KEEP = 2
_LOADED_LOCK = threading.Lock()


def _arrive(token, data):
    """Unpickle a :class:`_Shipped`: the scene this process already loaded, or a new load."""
    with _LOADED_LOCK:
        scene = _LOADED.get(token)
        if scene is not None:
            _LOADED.move_to_end(token)
            return _Shipped(scene, token)
    scene = Scene.from_bytes(data, source="<dask>")
    with _LOADED_LOCK:
        scene = _LOADED.setdefault(token, scene)
        while len(_LOADED) > _KEEP:
            _LOADED.popitem(last=False)
    return _Shipped(scene, token)


def scatter_scene(scene, client=None):
    """Ship a scene to every worker of a cluster, to be loaded there once.

    Parameters
    ----------
    scene : tetrace.Scene
    client : distributed.Client, optional
        Default: the current client (:func:`distributed.get_client`).

    Returns
    -------
    distributed.Future
        The scene on every worker (pickled as :meth:`tetrace.Scene.to_bytes`); pass it to
        :func:`cast_dask` for several casts. A worker loads it once: when Dask drops a
        worker's copy and fetches it again, the bytes travel again but the worker keeps
        its loaded scene (its last two scattered scenes are kept).
    """
    return _client(client).scatter(_Shipped(scene, uuid.uuid4().hex), broadcast=True, hash=False)


def _scene_of(value):
    """The scene in a scattered :class:`_Shipped` or in a :func:`mesh_many` future's value."""
    return value.scene if isinstance(value, _Shipped) else value


def _cast_block(block, scene, options, names):
    """One block of rays ``(n, 6)`` cast on the worker's scene: a record array."""
    hits = _scene_of(scene).cast(block[:, :3], block[:, 3:], **options)
    out = np.empty(len(block), dtype=_record_dtype(hits, names))
    for name in names:
        out[name] = getattr(hits, name)
    return out


def _record_dtype(hits, names):
    return np.dtype([(n, getattr(hits, n).dtype, getattr(hits, n).shape[1:]) for n in names])


def _field(block, name):
    return np.ascontiguousarray(block[name])


def cast_dask(
    scene,
    rays,
    directions=None,
    *,
    fields=("t", "triangle", "u", "v", "status"),
    client=None,
    local_scene=None,
    **cast_options,
):
    """Cast a Dask array of rays on a cluster; the hits come back as Dask arrays.

    Parameters
    ----------
    scene : tetrace.Scene or distributed.Future
        The scene, scattered to every worker once here (:func:`scatter_scene`), or the
        future :func:`scatter_scene` returned (then also pass ``local_scene``, or the
        scene is fetched once to learn the fields' dtypes).
    rays : dask.array.Array or array_like
        ``(N, 6)`` rays ``[ox, oy, oz, dx, dy, dz]``, chunked along the rays only; or,
        with ``directions``, ``(N, 3)`` origins.
    directions : dask.array.Array or array_like, optional
        ``(N, 3)`` directions (rechunked to the origins' chunks).
    fields : sequence of str
        The :class:`tetrace.Hits` fields to return (:data:`FIELDS`).
    client : distributed.Client, optional
        Default: the current client.
    local_scene : tetrace.Scene, optional
        With a scattered ``scene``: the same scene here, to learn the fields' dtypes.
    **cast_options
        Passed to :meth:`tetrace.Scene.cast` for every block (``tmin``/``tmax`` scalars
        only; not ``start``).

    Returns
    -------
    dict of str to dask.array.Array
        One array per field, chunked as the rays (``point`` and ``normal`` add an axis of
        3). Computing several of them together (``dask.compute(*d.values())``) casts each
        block once.
    """
    import dask.array as da

    if "start" in cast_options:
        raise ValueError("cast_dask casts rays from origins; start=hits is not chunked")
    for key in ("tmin", "tmax"):
        if key in cast_options and np.ndim(cast_options[key]) != 0:
            raise ValueError(
                f"cast_dask takes scalar {key} only, got shape {np.shape(cast_options[key])}"
            )
    unknown = [f for f in fields if f not in FIELDS]
    if unknown or not fields:
        raise ValueError(f"fields must name some of {FIELDS}, got {list(fields)}")
    rays = da.asarray(rays)
    if directions is not None:
        d = da.asarray(directions)
        if rays.ndim != 2 or rays.shape[1] != 3 or d.shape != rays.shape:
            raise ValueError(
                f"origins and directions must both be (N, 3), got {rays.shape} and {d.shape}"
            )
        rays = da.concatenate([rays, d.rechunk(rays.chunks)], axis=1)
    if rays.ndim != 2 or rays.shape[1] != 6:
        raise ValueError(
            f"rays must be (N, 6) (or (N, 3) origins with directions), got {rays.shape}"
        )
    rays = rays.rechunk({1: 6})
    client = _client(client)
    if isinstance(scene, Scene):
        local_scene, scene = scene, scatter_scene(scene, client)
    elif local_scene is None:
        local_scene = _scene_of(scene.result())
    # The fields' dtypes: one ray cast here with the same options.
    lo, hi = local_scene.domain
    probe = np.concatenate([(lo + hi) / 2, [1.0, 0.0, 0.0]]).astype(rays.dtype)[None]
    names = tuple(fields)
    dtype = _record_dtype(local_scene.cast(probe[:, :3], probe[:, 3:], **cast_options), names)
    records = da.map_blocks(
        _cast_block,
        rays,
        scene,
        dict(cast_options),
        names,
        dtype=dtype,
        drop_axis=1,
        chunks=(rays.chunks[0],),
        meta=np.empty((0,), dtype),
    )
    out = {}
    for name in names:
        sub = dtype[name]
        if sub.shape:
            out[name] = records.map_blocks(
                _field,
                name,
                dtype=sub.base,
                chunks=(rays.chunks[0],) + sub.shape,
                new_axis=list(range(1, 1 + len(sub.shape))),
                meta=np.empty((0,) + sub.shape, sub.base),
            )
        else:
            out[name] = records.map_blocks(_field, name, dtype=sub, meta=np.empty((0,), sub))
    return out


def mesh_many(meshes, *, client=None, **options):
    """Mesh several scenes in parallel, one task per scene.

    Parameters
    ----------
    meshes : iterable
        Each anything :meth:`tetrace.Scene.from_mesh` takes (a path the workers can read,
        ``(vertices, faces)``, ...), or a list of meshes for :meth:`tetrace.Scene.from_meshes`.
    client : distributed.Client, optional
        Default: the current client.
    **options
        Passed to :meth:`tetrace.Scene.from_mesh` (``preset``, ``mesher``, ...).

    Returns
    -------
    list of distributed.Future
        One per mesh, in order: ``client.gather(futures)`` brings the scenes back (as scene
        file bytes, not re-meshed); or pass a future to :func:`cast_dask` to cast where it
        was built.
    """
    client = _client(client)
    futures = []
    for mesh in meshes:
        build = Scene.from_meshes if isinstance(mesh, list) else Scene.from_mesh
        futures.append(client.submit(build, mesh, pure=False, **options))
    return futures
