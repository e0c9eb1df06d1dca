"""Progress reporting (issue 18, item 4): with progress on, stderr names each stage and
TetGen attempt; off (progress=False, CI set, or auto without a terminal) nothing is written;
the scene is the same either way."""

from __future__ import annotations

import io

import numpy as np
import pytest

import tetrace
from tetrace import progress

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
    ha, hb = a.cast(o, d), b.cast(o, d)
    for field in ("t", "triangle", "u", "v", "status", "tet", "steps"):
        np.testing.assert_array_equal(getattr(ha, field), getattr(hb, field))
    np.testing.assert_array_equal(a.tetrahedralization.tets, b.tetrahedralization.tets)


def test_progress_names_each_stage_and_attempt(capsys, monkeypatch):
    monkeypatch.setenv("CI", "true")  # an explicit True wins over CI
    on = tetrace.Scene.from_mesh((V, F), progress=True)
    err = capsys.readouterr().err
    assert "clean the mesh (4 triangles)" in err, err
    assert "TetGen attempt 1: preset 'quality', on the scene as given" in err, err
    assert "build the scene" in err, err
    assert " s, done" in err, err
    off = tetrace.Scene.from_mesh((V, F), progress=False)
    assert capsys.readouterr().err == ""
    _same(on, off)


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
    tetrace.Scene.from_mesh((V, F))
    assert capsys.readouterr().err == ""


def test_auto_follows_the_terminal(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setattr("sys.stderr", io.StringIO())
    assert not progress.enabled(None)
    tetrace.Scene.from_mesh((V, F))
    assert __import__("sys").stderr.getvalue() == ""
    tty = _Tty()
    monkeypatch.setattr("sys.stderr", tty)
    assert progress.enabled(None)
    tetrace.Scene.from_mesh((V, F))
    assert "TetGen attempt 1" in tty.getvalue()


def test_auto_mesher_counts_candidates(capsys):
    tetrace.Scene.from_mesh((V, F), mesher="auto", progress=True)
    err = capsys.readouterr().err
    assert "mesher='auto': candidates" in err, err
    assert "quality7" in err, err


def test_progress_must_be_a_bool():
    with pytest.raises(TypeError, match="progress"):
        tetrace.Scene.from_mesh((V, F), progress="yes")
