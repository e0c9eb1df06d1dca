"""Bad mesh input (issue 18, item 1): every case gives a typed error whose message names the
file or argument and the problem (never an unrelated cause, such as a missing module), or a
scene whose rays the exact referee judges right; either way a second scene builds after it."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import tetrace
from tetrace.errors import MeshingError
from tetrace.referee import Referee, judge

# A closed tetrahedron: the good mesh most cases break.
V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int64)

OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def _binary_stl():
    import trimesh

    return trimesh.Trimesh(V, F, process=False).export(file_type="stl")


def _ply():
    import trimesh

    return trimesh.Trimesh(V, F, process=False).export(file_type="ply")


def _file(name, data):
    """A mesh argument: a file ``name`` holding ``data`` (bytes or str), written under tmp."""

    def make(tmp):
        path = tmp / name
        content = data() if callable(data) else data
        path.write_bytes(content.encode() if isinstance(content, str) else content)
        return path

    return make


def _arrays(v, f):
    return lambda tmp: (np.asarray(v), np.asarray(f))


def _with(row, value, array=V):
    a = np.array(array)
    a[row] = value
    return a


RANDOM = np.random.default_rng(7).bytes(3000)

# Needles: a long thin triangle, its apex 1e-12 off its long edge, beside a closed tetrahedron.
NEEDLE_V = np.vstack([V, [[3, 0, 0], [5, 0, 0], [4, 1e-12, 0]]])
NEEDLE_F = np.vstack([F, [[4, 5, 6]]])
# Three triangles on one edge (a fin), plus an isolated triangle away from them.
SOUP_V = np.array(
    [[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1], [3, 3, 3], [4, 3, 3], [3, 4, 3]],
    np.float64,
)
SOUP_F = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4], [5, 6, 7]], np.int64)

# (id, make(tmp) -> mesh argument, expected: (exception type, words the message must hold)
#  or "scene" for a correct scene)
CASES = [
    ("corrupt-obj", _file("junk.obj", RANDOM), (MeshingError, ["junk.obj"])),
    ("corrupt-ply", _file("junk.ply", RANDOM), (MeshingError, ["junk.ply"])),
    ("corrupt-stl", _file("junk.stl", RANDOM), (MeshingError, ["junk.stl"])),
    # OBJ has no length header: a cut one is a shorter mesh (trimesh reads the whole faces).
    ("truncated-obj", _file("cut.obj", OBJ[: len(OBJ) - 20]), "scene"),
    ("truncated-ply", _file("cut.ply", lambda: _ply()[:-30]), (MeshingError, ["cut.ply"])),
    ("truncated-stl", _file("cut.stl", lambda: _binary_stl()[:-30]), (MeshingError, ["cut.stl"])),
    ("empty-file", _file("empty.obj", b""), (MeshingError, ["empty.obj"])),
    ("faces-no-vertices", _file("novert.obj", "f 1 2 3\nf 2 3 4\n"), (MeshingError, ["novert"])),
    ("nan-vertex", _arrays(_with(1, np.nan), F), (MeshingError, ["non-finite", "vertex 1"])),
    ("inf-vertex", _arrays(_with(2, np.inf), F), (MeshingError, ["non-finite", "vertex 2"])),
    ("huge-vertex", _arrays(_with(3, 1e300), F), (MeshingError, ["vertex 3", "1e+300"])),
    ("index-out-of-range", _arrays(V, _with(0, [0, 1, 9], F)), (MeshingError, ["out of range"])),
    ("index-negative", _arrays(V, _with(0, [0, -1, 2], F)), (MeshingError, ["negative"])),
    ("faces-float-dtype", _arrays(V, F.astype(float)), (TypeError, ["faces", "float64"])),
    ("faces-quads", _arrays(V, np.zeros((2, 4), int)), (MeshingError, ["faces", "(2, 4)"])),
    ("zero-triangles", _arrays(V, np.zeros((0, 3), int)), (MeshingError, ["no faces"])),
    (
        "all-degenerate",
        _arrays(V, np.array([[0, 0, 1], [0, 1, 1], [1, 2, 1]])),
        (MeshingError, ["degenerate"]),
    ),
    # Width 5e-13 of its edge: collinear up to rounding, dropped by cleaning (reported).
    ("needle", _arrays(NEEDLE_V, NEEDLE_F), "scene-without-4"),
    ("non-manifold-soup", _arrays(SOUP_V, SOUP_F), "scene"),
    ("directory", lambda tmp: tmp, (MeshingError, ["directory"])),
    ("missing", lambda tmp: tmp / "absent.obj", (FileNotFoundError, ["absent.obj", "not found"])),
]

# Messages that blame something unrelated to the input.
UNRELATED = ("No module named", "charset_normalizer", "ModuleNotFoundError", "ImportError")


def _judge_scene(scene, vertices, faces, skip=()):
    """Rays through every triangle's centroid (but ``skip``'s), from a point off the scene:
    judged right."""
    c = np.delete(vertices[faces], list(skip), axis=0).mean(axis=1)
    o = c + np.array([0.3, 0.7, 1.9])
    d = c - o
    hits = scene.cast(o, d)
    verdict = Referee(vertices, faces).first_hits(o, d)
    masks = judge(hits, verdict)
    assert masks["right"].all(), {k: np.flatnonzero(m).tolist() for k, m in masks.items()}


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_mesh(case, tmp_path):
    _, make, expected = case
    mesh = make(tmp_path)
    if isinstance(expected, str):
        skip = [int(expected.rsplit("-", 1)[1])] if "without" in expected else []
        v, f = tetrace.io.load_triangles(mesh)
        scene = tetrace.Scene.from_mesh(mesh, timeout=15, lazy=False)
        assert scene.n_triangles == len(f)
        # Dropped by cleaning (collinear up to rounding), and only those.
        kept = scene.tetrahedralization.clean.triangle_ids
        assert sorted(set(range(len(f))) - set(kept.tolist())) == skip
        _judge_scene(scene, v, f, skip)
    else:
        kind, words = expected
        with pytest.raises(kind) as info:
            tetrace.Scene.from_mesh(mesh, timeout=15, lazy=False)
        message = str(info.value)
        assert isinstance(info.value, (MeshingError, ValueError, TypeError)), type(info.value)
        for word in words:
            assert word in message, (word, message)
        for word in UNRELATED:
            assert word not in message, message
    # The process is unharmed: a good scene still builds and casts right.
    _judge_scene(tetrace.Scene.from_mesh((V, F)), V, F)


def test_needles_are_not_called_self_intersections():
    """TetGen takes a needle (width 5e-10 of its edge, not dropped by cleaning) for a
    self-intersection: the attempts name the needle and say libigl finds no intersection."""
    v = NEEDLE_V.copy()
    v[6, 1] = 1e-9
    tz = tetrace.mesh.tetrahedralize((v, NEEDLE_F), timeout=15)
    first = tz.attempts[0]
    assert "triangle 4 (a needle" in first and "no intersecting pair" in first, first


# --- why a file is unreadable (issue 32, item 4) -------------------------------------


@pytest.mark.parametrize("charset_normalizer", ["installed", "missing"])
def test_unreadable_files_say_why_not_which_module(tmp_path, monkeypatch, charset_normalizer):
    """A corrupt (binary) OBJ and a truncated binary STL are named with what is wrong with
    their bytes, whether or not trimesh's text decoder (charset_normalizer) imports: without
    it trimesh's own error was "No module named 'charset_normalizer'"."""
    if charset_normalizer == "missing":
        monkeypatch.setitem(sys.modules, "charset_normalizer", None)  # import fails
    cases = {
        "junk.obj": (RANDOM, ["junk.obj", "binary data, not OBJ text", "not UTF-8"]),
        # 4 triangles: 84 + 50 * 4 = 284 bytes, 30 cut off
        "cut.stl": (
            _binary_stl()[:-30],
            ["cut.stl", "truncated", "announces 4 triangles", "284 bytes", "has 254 bytes"],
        ),
        "short.stl": (_binary_stl()[:50], ["short.stl", "50 bytes, shorter than its 84-byte"]),
        "empty.off": (b"", ["empty.off", "the file is empty"]),
    }
    for name, (data, words) in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(MeshingError) as info:
            tetrace.io.load_triangles(path)
        message = str(info.value)
        for word in words:
            assert word in message, (word, message)
        for word in UNRELATED:
            assert word not in message, message


def test_text_in_another_encoding(tmp_path, monkeypatch):
    """A Latin-1 OBJ is a mesh: it loads (charset-normalizer is a dependency); without the
    decoder the message says the file is not UTF-8 and what would read it."""
    path = tmp_path / "latin.obj"
    path.write_bytes("# café\n".encode("latin-1") + OBJ.encode())
    v, f = tetrace.io.load_triangles(path)
    assert np.array_equal(v[f], V[F])  # OBJ holds the tetrahedron V, F
    monkeypatch.setitem(sys.modules, "charset_normalizer", None)
    with pytest.raises(MeshingError) as info:
        tetrace.io.load_triangles(path)
    message = str(info.value)
    assert "latin.obj" in message and "not UTF-8 text (byte 0xe9 at offset 5)" in message
    assert "pip install charset-normalizer" in message and "No module named" not in message


def test_readable_files_are_not_diagnosed(tmp_path):
    """The diagnosis finds nothing wrong with whole files: a binary STL (its header may
    start with "solid", as some exporters write), an ASCII STL, an OBJ."""
    import trimesh

    binary = _binary_stl()
    files = {
        "ok.stl": binary,
        "solid.stl": b"solid exported" + binary[14:],
        "ascii.stl": trimesh.Trimesh(V, F, process=False).export(file_type="stl_ascii"),
        "ok.obj": OBJ,
    }
    for name, data in files.items():
        path = tmp_path / name
        path.write_bytes(data.encode() if isinstance(data, str) else data)
        assert tetrace.io.unreadable_reason(path) is None, name
        assert len(tetrace.io.load_triangles(path)[1]) == 4, name


# --- a missing file (issue 36) ---------------------------------------------------------


def test_missing_file_prints_a_sentence(tmp_path, monkeypatch):
    """It printed as a tuple, ``(2, 'mesh file not found: ...', '...')``: now a sentence that
    names the path (and the directory a relative path is looked up in), with
    FileNotFoundError's errno and filename, also after pickling (Dask sends errors so)."""
    import errno
    import pickle
    import traceback

    path = tmp_path / "absent.obj"
    with pytest.raises(tetrace.MeshFileNotFoundError) as info:
        tetrace.Scene.from_mesh(path)
    err = info.value
    assert str(err) == f"mesh file not found: {path}"
    shown = traceback.format_exception_only(type(err), err)[-1]
    assert shown == f"tetrace.errors.MeshFileNotFoundError: mesh file not found: {path}\n"
    assert isinstance(err, FileNotFoundError) and isinstance(err, MeshingError)
    assert (err.errno, err.filename) == (errno.ENOENT, str(path))
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is type(err) and str(back) == str(err)
    assert (back.errno, back.filename) == (errno.ENOENT, str(path))

    monkeypatch.chdir(tmp_path)
    with pytest.raises(FileNotFoundError) as info:
        tetrace.io.load_triangles("absent.obj")
    assert str(info.value) == f"mesh file not found: absent.obj (relative to {tmp_path})"
    # a directory exists: it is not a mesh file, and no FileNotFoundError
    with pytest.raises(MeshingError) as info:
        tetrace.io.load_triangles(tmp_path)
    assert str(info.value) == f"{tmp_path} is a directory, not a mesh file"
    assert not isinstance(info.value, FileNotFoundError)
    # a missing scene file the same way
    with pytest.raises(tetrace.SceneFileNotFoundError) as info:
        tetrace.Scene.load(tmp_path / "absent.tetrace")
    err = info.value
    assert str(err) == f"{tmp_path / 'absent.tetrace'}: no such scene file"
    assert (err.errno, err.filename) == (errno.ENOENT, str(tmp_path / "absent.tetrace"))
