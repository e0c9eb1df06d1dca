"""Progress reporting (issue 18, item 4): with progress on, stderr names each stage and
TetGen attempt; off (progress=False, CI set, or auto without a terminal) nothing is written;
the scene is the same either way."""

from __future__ import annotations

import io

import numpy as np
import pytest

import tetrace
from tetrace import _native, progress

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int64)


class _Tty(io.StringIO):
    def isatty(self):
        return True


def _rays():
    rng = np.random.default_rng(3)
    o = rng.uniform(-1, 2, (64, 3))
    d = rng.normal(size=(64, 3))
    return o, d


def _same(a, b):
    o, d = _rays()
    ha, hb = a.cast(o, d, accel="tetwalk"), b.cast(o, d, accel="tetwalk")
    for field in ("t", "triangle", "u", "v", "status", "tet", "steps"):
        np.testing.assert_array_equal(getattr(ha, field), getattr(hb, field))
    np.testing.assert_array_equal(a.tetrahedralization.tets, b.tetrahedralization.tets)


def test_progress_names_each_stage_and_attempt(capsys, monkeypatch):
    monkeypatch.setenv("CI", "true")  # an explicit True wins over CI
    on = tetrace.Scene.from_mesh((V, F), progress=True, lazy=False)
    err = capsys.readouterr().err
    assert "clean the mesh (4 triangles)" in err, err
    assert "TetGen attempt 1: preset 'quality', on the scene as given" in err, err
    assert "build the scene" in err, err
    assert " s, done" in err, err
    off = tetrace.Scene.from_mesh((V, F), progress=False, lazy=False)
    assert capsys.readouterr().err == ""
    _same(on, off)
    # Meshing deferred to build_ct reports the same stages.
    later = tetrace.Scene.from_mesh((V, F), progress=True)
    assert capsys.readouterr().err == ""  # nothing meshed yet
    later.build_ct(progress=True)
    err = capsys.readouterr().err
    assert "TetGen attempt 1: preset 'quality', on the scene as given" in err, err
    _same(on, later)


def test_failed_attempts_are_each_shown(capsys):
    """A needle TetGen refuses: each attempt gets its line, the failed ones say so."""
    v = np.vstack([V, [[3, 0, 0], [5, 0, 0], [4, 1e-9, 0]]])
    f = np.vstack([F, [[4, 5, 6]]])
    tetrace.mesh.tetrahedralize((v, f), timeout=15, progress=True)
    err = capsys.readouterr().err
    assert "TetGen attempt 1" in err and "TetGen attempt 2" in err, err
    assert " s, failed" in err, err
    assert "repair (snap rounding" in err, err


@pytest.mark.parametrize("ci", ["true", "1"])
def test_ci_turns_auto_off(capsys, monkeypatch, ci):
    monkeypatch.setenv("CI", ci)
    monkeypatch.setattr("sys.stderr", _Tty())
    assert not progress.enabled(None)
    tetrace.Scene.from_mesh((V, F), lazy=False)
    assert capsys.readouterr().err == ""


def test_auto_follows_the_terminal(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setattr("sys.stderr", io.StringIO())
    assert not progress.enabled(None)
    tetrace.Scene.from_mesh((V, F), lazy=False)
    assert __import__("sys").stderr.getvalue() == ""
    tty = _Tty()
    monkeypatch.setattr("sys.stderr", tty)
    assert progress.enabled(None)
    tetrace.Scene.from_mesh((V, F), lazy=False)
    assert "TetGen attempt 1" in tty.getvalue()


def test_auto_mesher_counts_candidates(capsys):
    tetrace.Scene.from_mesh((V, F), mesher="auto", progress=True, lazy=False)
    err = capsys.readouterr().err
    assert "mesher='auto': candidates" in err, err
    assert "quality7" in err, err


def test_progress_must_be_a_bool():
    with pytest.raises(TypeError, match="progress"):
        tetrace.Scene.from_mesh((V, F), progress="yes")


# ----------------------------------------------------------------------------- ray queries


@pytest.fixture(scope="module")
def spot():
    return tetrace.default_scene()


def _many_rays(scene, n):
    rng = np.random.default_rng(5)
    lo, hi = scene.domain
    return lo + (hi - lo) * rng.random((n, 3)), rng.normal(size=(n, 3))


def _request(o, d, threads):
    n = len(o)
    return _native.RayRequest(
        o, d, np.zeros(n), np.full(n, np.inf), precision="f64", threads=threads
    )


def test_the_core_reports_chunks_done_while_a_query_runs(spot):
    """The core calls progress(done, total) once before the first chunk of 4096 rays (done
    0) and then every 50 ms: growing, never past their number, however fast the machine;
    answers are those of a query without it."""
    o, d = _many_rays(spot, 300_000)
    chunks = -(-len(o) // 4096)
    for kind in ("closest", "count"):
        calls = []
        report = lambda *p, log=calls: log.append(p)  # noqa: E731
        r = spot._native.query(kind, _request(o, d, 1), report)
        assert calls and calls[0] == (0, chunks), calls
        assert all(total == chunks and 0 <= done < total for done, total in calls), calls
        assert all(a[0] <= b[0] for a, b in zip(calls, calls[1:])), calls
        plain = spot._native.query(kind, _request(o, d, 1))
        np.testing.assert_array_equal(r["status"], plain["status"])


def test_an_error_in_the_progress_callback_stops_the_query(spot):
    """The callback is called at the start of a query of several chunks, so its error
    stops the query however fast it would have run (CI once finished 300,000 rays before
    the first 50 ms poll)."""
    o, d = _many_rays(spot, 300_000)

    def stop(done, total):
        raise ValueError(f"stop at {done} of {total}")

    for threads in (1, 2):
        with pytest.raises(ValueError, match="stop at"):
            spot._native.query("closest", _request(o, d, threads), stop)
    assert spot.cast(o[:10], d[:10]).status.shape == (10,)


def test_progress_bar_for_casts(spot, capsys, monkeypatch):
    """progress=True: a bar of rays on stderr that ends at the ray count; the answers are
    the same as with progress=False, which writes nothing."""
    monkeypatch.setattr(progress, "CAST_DELAY_S", 0.0)
    o, d = _many_rays(spot, 200_000)
    on = spot.cast(o, d, threads=1, progress=True)
    err = capsys.readouterr().err
    assert "casting" in err and "200k/200k" in err, err
    off = spot.cast(o, d, threads=1, progress=False)
    assert capsys.readouterr().err == ""
    for field in ("t", "triangle", "status", "tet"):
        np.testing.assert_array_equal(getattr(on, field), getattr(off, field))
    count = spot.count_intersections(o, d, threads=1, progress=True)
    err = capsys.readouterr().err
    assert "counting" in err and "200k/200k" in err, err
    np.testing.assert_array_equal(count, spot.count_intersections(o, d, threads=1))


def test_short_casts_and_auto_stay_silent(spot, capsys, monkeypatch):
    """With the default delay a short cast shows no bar; auto (None) is off without a
    terminal or with CI set."""
    o, d = _many_rays(spot, 1000)
    spot.cast(o, d, progress=True)
    spot.occluded(o, d, progress=True)
    monkeypatch.setattr(progress, "CAST_DELAY_S", 0.0)
    monkeypatch.setenv("CI", "true")
    monkeypatch.setattr("sys.stderr", _Tty())
    spot.intersections(o, d)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("value", ["yes", 1, 0.5])
def test_progress_must_be_a_bool_or_none(spot, value):
    o, d = _many_rays(spot, 4)
    with pytest.raises(TypeError, match="progress"):
        spot.cast(o, d, progress=value)
