"""The core's tables are the one source of names, codes and defaults: Python's copies (the status
codes of ``tetrace.hits``, the lists ``tetrace`` shows, the defaults in the signatures of
``Scene.build_bvh``/``build_octree``) must be the core's, and every query kind and accelerator
the tables list must answer through the one request binding."""

import inspect
import re

import numpy as np
import pytest

import tetrace
from tetrace import _native, hits


def test_status_codes_are_the_cores():
    py = {"miss": hits.MISS, "hit": hits.HIT, "failed": hits.FAILED, "invalid": hits.INVALID}
    core = {
        "miss": _native.MISS,
        "hit": _native.HIT,
        "failed": _native.FAILED,
        "invalid": _native.INVALID,
    }
    assert py == core
    assert list(hits.STATUS_NAMES) == list(_native.STATUS_NAMES)
    for name, code in core.items():
        assert _native.STATUS_NAMES[code] == name


def test_python_lists_are_the_tables():
    assert tetrace.accels() == list(_native.accels())
    assert tetrace.methods() == list(_native.methods())
    assert set(_native.queries()) == {"closest", "any", "all", "count"}
    assert tetrace.accels()[0] == "tetwalk"


@pytest.mark.parametrize(
    "structure, build",
    [("bvh", "build_bvh"), ("octree", "build_octree"), ("exact_bvh", "build_exact_bvh")],
)
def test_structure_defaults_are_the_cores(structure, build):
    """The signature's defaults are read from the core, so they cannot drift from it."""
    defaults = _native.structure_defaults()[structure]
    params = inspect.signature(getattr(tetrace.Scene, build)).parameters
    shown = {k: p.default for k, p in params.items() if k in defaults}
    assert shown == defaults


def _rays(scene, n=300, seed=3):
    lo, hi = (np.asarray(x) for x in scene.domain)
    rng = np.random.default_rng(seed)
    o = lo + rng.random((n, 3)) * (hi - lo)
    d = rng.normal(size=(n, 3))
    return o, d


@pytest.mark.parametrize("accel", tetrace.accels())
@pytest.mark.parametrize("precision", ["f32", "f64"])
def test_every_query_kind_answers_on_every_accel(accel, precision):
    """Each row of the query table, on each row of the accelerator table, through one request:
    any-hit agrees with closest hits (HIT exactly where a closest hit exists) and the counts
    with the lists (judged against each other's definitions, which are independent walks of
    different policies; the referee judges the answers themselves in test_queries)."""
    scene = tetrace.default_scene()
    o, d = _rays(scene)
    dt = np.float32 if precision == "f32" else np.float64
    o, d = o.astype(dt), d.astype(dt)
    req = _native.RayRequest(
        o, d, np.array([0.0]), np.array([np.inf]), precision=precision, accel=accel, threads=2
    )
    assert len(req) == len(o) and req.precision == precision
    out = {k: scene._native.query(k, req) for k in _native.queries()}
    closest, anyhit = out["closest"], out["any"]
    assert closest["t"].dtype == dt
    np.testing.assert_array_equal(anyhit["status"] == hits.HIT, closest["status"] == hits.HIT)
    counts, listed = out["count"], out["all"]
    np.testing.assert_array_equal(np.diff(listed["offsets"]), counts["count"])
    assert ((counts["count"] > 0) == (closest["status"] == hits.HIT)).all()


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(precision="f16"), ValueError, "precision"),
        (dict(precision="f64", threads=True), TypeError, "threads must be an int"),
        (dict(precision="f64", threads=2.0), TypeError, "threads must be an int"),
        (dict(precision="f64", threads=0), ValueError, "threads"),
        (dict(precision="f64", threads=10**9), ValueError, "threads"),
        (dict(precision="f64", max_steps=0), ValueError, "max_steps"),
        (dict(precision="f64", max_steps=2**32), ValueError, "max_steps"),
        (dict(precision="f64", packet=1), TypeError, "packet"),
        (dict(precision="f64", accel="kdtree"), ValueError, "accel"),
        (dict(precision="f64", method="nope"), ValueError, "method"),
        (dict(precision="f32"), TypeError, "precision asked for"),
    ],
)
def test_the_request_checks_each_argument_once(kwargs, error, match):
    o = np.zeros((4, 3))
    d = np.ones((4, 3))
    with pytest.raises(error, match=match):
        _native.RayRequest(o, d, np.array([0.0]), np.array([np.inf]), **kwargs)


def test_a_request_with_rows_that_disagree_is_refused():
    with pytest.raises(ValueError, match="same number of rows"):
        _native.RayRequest(
            np.zeros((4, 3)), np.ones((5, 3)), np.array([0.0]), np.array([np.inf]), precision="f64"
        )
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        _native.RayRequest(
            np.zeros((4, 2)), np.ones((4, 2)), np.array([0.0]), np.array([np.inf]), precision="f64"
        )


def test_unknown_query_is_named():
    scene = tetrace.default_scene()
    req = _native.RayRequest(
        np.zeros((1, 3)), np.ones((1, 3)), np.array([0.0]), np.array([np.inf]), precision="f64"
    )
    with pytest.raises(ValueError, match="unknown query"):
        scene._native.query("nearest", req)


@pytest.mark.parametrize("threads", [None, 1, 2, np.int64(2), np.uint8(3), _native.MAX_THREADS])
def test_thread_counts_the_core_takes(threads):
    """One rule for every query: the ray request and the point queries' check are the core's
    (ints and numpy integers in [1, MAX_THREADS], or None)."""
    assert _native.check_threads(threads) == (None if threads is None else int(threads))
    o = np.zeros((2, 3))
    req = _native.RayRequest(
        o, o + 1, np.zeros(1), np.full(1, np.inf), precision="f64", threads=threads
    )
    assert len(req) == 2


@pytest.mark.parametrize(
    "threads, error",
    [
        (True, TypeError),
        (np.True_, TypeError),
        (2.0, TypeError),
        ("2", TypeError),
        (0, ValueError),
        (-1, ValueError),
        (_native.MAX_THREADS + 1, ValueError),
    ],
)
def test_thread_counts_the_core_refuses(threads, error):
    with pytest.raises(error, match="threads"):
        _native.check_threads(threads)
    scene = tetrace.default_scene()
    with pytest.raises(error, match="threads"):
        scene.contains(np.zeros((1, 3)), threads=threads)


_ENTRY = re.compile(r"^(\*{0,2}\w+(?:, \*{0,2}\w+)*)(?: :|$)", re.M)


def _documented_parameters(doc):
    """The names a numpydoc Parameters section lists (``a, b : ...`` lists two)."""
    section = re.search(
        r"^Parameters\n-+\n(.*?)(?=^\w+\n-+\n|\Z)", inspect.cleandoc(doc or ""), re.M | re.S
    )
    if section is None:
        return []
    return [n.lstrip("*") for m in _ENTRY.finditer(section.group(1)) for n in m[1].split(", ")]


def _public_callables():
    for name, f in inspect.getmembers(tetrace.Scene):
        if not name.startswith("_") and callable(f):
            yield f"Scene.{name}", f
    for name in tetrace.__all__:
        if inspect.isfunction(getattr(tetrace, name)):
            yield name, getattr(tetrace, name)


@pytest.mark.parametrize("name, f", [pytest.param(n, f, id=n) for n, f in _public_callables()])
def test_every_argument_is_documented_once(name, f):
    # The ray queries' argument docs are written once (rays.ARG_DOCS) and put into each
    # query's docstring by rays.documented: a query that takes an argument must list it
    # once, and list nothing it does not take.
    takes = [p for p in inspect.signature(f).parameters if p not in ("self", "cls")]
    listed = _documented_parameters(f.__doc__)
    assert sorted(listed) == sorted(takes), (name, takes, listed)
