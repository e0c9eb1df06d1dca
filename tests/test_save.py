"""Save/load, pickle and deepcopy of scenes (issue 18, item 3; docs/save_format.md).

A saved scene is rebuilt from its tetrahedralization without meshing, so every query must
answer bit for bit as before: each test casts the same rays before and after and compares
every field with ``array_equal``, for the tet walk and for Reshetov's BVH, on a scene as
built and on one moved by ``update_vertices`` (which must stay moved and keep deforming as
the original does). Broken files (wrong magic, newer version, truncated, a flipped byte in an
array or in the header, a missing file, a directory) must raise ``tetrace.SceneFileError``
naming the file and what is wrong, and leave nothing broken behind.
"""

import copy
import dataclasses
import io
import json
import pickle
import struct
import zlib

import numpy as np
import pytest

import tetrace
from tetrace import scenefile

FIELDS = [f.name for f in dataclasses.fields(tetrace.Hits)]


def icosphere(subdivisions):
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.asarray(s.vertices, np.float64), np.asarray(s.faces, np.int64)


@pytest.fixture(scope="module")
def spot():
    return tetrace.Scene.from_mesh(tetrace.default_scene_path(), lazy=False)


def bend(rest, k, amplitude=0.005):
    """A smooth bend of ``amplitude`` x the diagonal (no tet of Spot's mesh inverts)."""
    lo, hi = rest.min(0), rest.max(0)
    size = float(np.linalg.norm(hi - lo))
    y = (rest[:, 1] - lo[1]) / (hi[1] - lo[1])
    out = rest.copy()
    out[:, 0] += amplitude * size * np.sin(0.7 * k + 1) * np.sin(np.pi * y)
    out[:, 2] += 0.5 * amplitude * size * np.cos(0.7 * k) * np.cos(np.pi * y)
    return out


def rays(scene, n=3000, seed=1):
    """Random rays through the scene's box, from outside and inside it."""
    rng = np.random.default_rng(seed)
    lo, hi = np.asarray(scene.vertices).min(0), np.asarray(scene.vertices).max(0)
    o = lo + (hi - lo) * rng.uniform(-0.5, 1.5, (n, 3))
    d = lo + (hi - lo) * rng.uniform(0, 1, (n, 3)) - o
    return o, d


def assert_same_answers(a, b, accels=("tetwalk", "reshetov_bvh"), tets=True):
    """Every field of every query kind equal, bit for bit (NaN where NaN); the tets and
    points too unless not ``tets`` (scenes whose tetrahedralization must stay unbuilt)."""
    o, d = rays(a)
    for accel in accels:
        for dtype in (np.float64, np.float32):
            ha = a.cast(o.astype(dtype), d.astype(dtype), accel=accel)
            hb = b.cast(o.astype(dtype), d.astype(dtype), accel=accel)
            assert np.count_nonzero(ha.status == tetrace.HIT) > 100
            for name in FIELDS:
                fa, fb = getattr(ha, name), getattr(hb, name)
                assert (fa is None) == (fb is None), name
                if fa is not None:
                    assert fa.dtype == fb.dtype, name
                    assert np.array_equal(fa, fb, equal_nan=fa.dtype.kind == "f"), (accel, name)
        ia, ib = a.intersections(o, d, accel=accel), b.intersections(o, d, accel=accel)
        assert np.array_equal(ia.offsets, ib.offsets) and np.array_equal(ia.t, ib.t)
        assert np.array_equal(ia.triangle, ib.triangle)
    assert np.array_equal(a.occluded(o, d), b.occluded(o, d))
    mode = None if tets else "winding"  # parity walks the tetrahedralization
    assert np.array_equal(a.contains(o, mode=mode), b.contains(o, mode=mode))
    # Secondary rays start from the hit's tet: tet numbering must be the same too.
    h = a.cast(o, d)
    s = d * np.array([1.0, -1.0, 1.0])
    sa, sb = a.cast(start=h, directions=s), b.cast(start=h, directions=s)
    assert np.array_equal(sa.t, sb.t) and np.array_equal(sa.triangle, sb.triangle)
    if tets:
        assert np.array_equal(a.tets(), b.tets()) and np.array_equal(a.points(), b.points())


def assert_same_python_state(a, b):
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert a.vertices.dtype == b.vertices.dtype and a.faces.dtype == b.faces.dtype
    assert a.build_times == b.build_times
    assert a._build_options.keys() == b._build_options.keys()
    ta, tb = a.tetrahedralization, b.tetrahedralization
    for f in dataclasses.fields(ta):
        if f.name in ("_weight", "clean"):
            continue
        va, vb = getattr(ta, f.name), getattr(tb, f.name)
        if isinstance(va, np.ndarray):
            assert va.dtype == vb.dtype and np.array_equal(va, vb), f.name
        else:
            assert va == vb, f.name
    for f in dataclasses.fields(ta.clean):
        va, vb = getattr(ta.clean, f.name), getattr(tb.clean, f.name)
        assert np.array_equal(va, vb), f.name
    assert a.last_deformation == b.last_deformation
    assert a._frames == b._frames and a.hilbert == b.hilbert
    assert repr(a) == repr(b)


def test_round_trip_gives_the_same_hits(spot, tmp_path):
    path = tmp_path / "spot.tetrace"
    spot.save(path)
    loaded = tetrace.Scene.load(path)
    assert_same_python_state(spot, loaded)
    assert_same_answers(spot, loaded)
    # str paths and file objects too; the bytes are deterministic (both scenes have built
    # the BVH by now, which the file records).
    spot.save(str(tmp_path / "again"))
    assert (tmp_path / "again").read_bytes() == spot.to_bytes() == loaded.to_bytes()
    buf = io.BytesIO()
    spot.save(buf)
    buf.seek(0)
    assert tetrace.Scene.load(buf).to_bytes() == spot.to_bytes()


def test_the_header_is_endian_explicit_json(spot):
    data = spot.to_bytes()
    assert data.startswith(scenefile.MAGIC)
    version, length, crc = struct.unpack_from("<IQI", data, len(scenefile.MAGIC))
    # A scene with its tetrahedralization is written as version 1 (older builds read it);
    # version 2 is a scene saved without one (test_a_lazy_scene_saves_and_pickles_unmeshed).
    assert spot.has_ct and version == 1 and scenefile.FORMAT_VERSION == 2
    start = len(scenefile.MAGIC) + 16
    header = json.loads(data[start : start + length])
    assert zlib.crc32(data[start : start + length]) == crc
    assert header["version"] == tetrace.__version__
    dtypes = {a["name"]: a["dtype"] for a in header["arrays"]}
    assert dtypes["tz/points"] == "<f8" and dtypes["tz/tets"] == "<u4"
    for a in header["arrays"]:
        assert a["dtype"][0] in "<|" and a["offset"] % 8 == 0


def test_deformed_scene_round_trip_stays_moved_and_keeps_deforming(tmp_path):
    scene = tetrace.Scene.from_mesh(tetrace.default_scene_path(), lazy=False)  # not the shared one
    rest = np.array(scene.vertices)
    for k in (1, 2):
        assert scene.update_vertices(bend(rest, k)).action == "moved"
    path = tmp_path / "moved.tetrace"
    scene.save(path)
    loaded = tetrace.Scene.load(path)
    assert_same_python_state(scene, loaded)
    assert np.array_equal(loaded.vertices, bend(rest, 2))
    assert_same_answers(scene, loaded)
    # Both keep deforming from the same rest state, and agree after the next frame too.
    for s in (scene, loaded):
        assert s.update_vertices(bend(rest, 3)).action == "moved"
    assert loaded.last_deformation.frames == scene.last_deformation.frames == 3
    assert_same_answers(scene, loaded)
    # A move that inverts tets rebuilds both the same way (from the saved build options).
    for s in (scene, loaded):
        assert s.update_vertices(bend(rest, 3, amplitude=0.3)).action == "rebuilt"
    assert_same_answers(scene, loaded, accels=("tetwalk",))


def test_bvh_and_octree_parameters_come_back(spot):
    scene = copy.deepcopy(spot)
    scene.build_bvh(cost_ratio=3.0, max_leaf=4, bins=8, aperture=False)
    scene.build_octree(max_depth=5, leaf_size=20, balance=False)
    loaded = tetrace.Scene.from_bytes(scene.to_bytes())
    for key in ("cost_ratio", "max_leaf", "bins", "aperture", "nodes", "leaves", "depth"):
        assert loaded.bvh_info()[key] == scene.bvh_info()[key], key
    for key in ("max_depth", "leaf_size", "balance", "leaves", "depth"):
        assert loaded.octree_info()[key] == scene.octree_info()[key], key
    assert_same_answers(scene, loaded, accels=("reshetov_bvh", "portalez_octree"))
    # A scene without them loads without them (a fresh one: the module's `spot` may have
    # built its octree in another test on this worker).
    plain = tetrace.Scene.from_mesh((spot.vertices, spot.faces))
    assert plain.octree_info() is None
    assert tetrace.Scene.from_bytes(plain.to_bytes()).octree_info() is None


def test_pickle_and_deepcopy_do_not_mesh_and_are_independent(spot, monkeypatch):
    def no_meshing(*args, **kwargs):
        raise AssertionError("unpickling must not mesh")

    monkeypatch.setattr(tetrace.Scene, "from_mesh", no_meshing)
    for protocol in (2, pickle.HIGHEST_PROTOCOL):
        back = pickle.loads(pickle.dumps(spot, protocol=protocol))
        assert_same_python_state(spot, back)
    assert_same_answers(spot, back, accels=("tetwalk",))
    twin = copy.deepcopy(spot)
    assert twin._native is not spot._native and twin.vertices is not spot.vertices
    before = spot.cast(*rays(spot))
    rest = np.array(twin.vertices)
    assert twin.update_vertices(bend(rest, 1)).action == "moved"
    assert spot.last_deformation is None and np.array_equal(spot.vertices, rest)
    after = spot.cast(*rays(spot))
    assert np.array_equal(before.t, after.t) and np.array_equal(before.tet, after.tet)
    assert not np.array_equal(twin.cast(*rays(spot)).t, before.t, equal_nan=True)
    # A moved scene pickles moved.
    again = pickle.loads(pickle.dumps(twin))
    assert np.array_equal(again.vertices, twin.vertices)
    assert_same_answers(twin, again, accels=("tetwalk",))


def test_a_lazy_scene_saves_and_pickles_unmeshed(spot, tmp_path, monkeypatch):
    """A scene whose tetrahedralization is not built is saved without it (format version 2):
    nothing is meshed to save, pickle or load it, the loaded scene answers every query
    without a tetrahedralization as the original does, and when something walks tets it is
    meshed from the same triangles and options (the same tets as the original's)."""
    from tetrace import construct

    meshed = []
    mesh = construct._tetrahedralize
    monkeypatch.setattr(construct, "_tetrahedralize", lambda *a: meshed.append(1) or mesh(*a))
    lazy = tetrace.Scene.from_mesh(tetrace.default_scene_path(), margin=0.25)
    lazy.build_bvh(max_leaf=3)
    rest = np.array(lazy.vertices)
    assert lazy.update_vertices(bend(rest, 1)).action == "moved"  # triangles alone
    data = lazy.to_bytes()
    assert struct.unpack_from("<I", data, len(scenefile.MAGIC))[0] == 2
    path = tmp_path / "lazy.tetrace"
    lazy.save(path)
    copies = [
        tetrace.Scene.load(path),
        pickle.loads(pickle.dumps(lazy)),
        copy.deepcopy(lazy),
    ]
    assert meshed == [] and not lazy.has_ct
    for back in copies:
        assert not back.has_ct and "not built" in repr(back)
        assert np.array_equal(back.vertices, lazy.vertices) and back.hilbert == lazy.hilbert
        assert back.build_times == lazy.build_times and back._frames == lazy._frames == 1
        assert back.last_deformation == lazy.last_deformation
        assert back._build_options.keys() == lazy._build_options.keys()
        assert back._build_options["margin"] == 0.25
        assert back.bvh_info()["max_leaf"] == 3
        assert back.to_bytes() == data
        assert_same_answers(lazy, back, accels=("exact_bvh", "reshetov_bvh"), tets=False)
    assert meshed == [] and not any(s.has_ct for s in [lazy, *copies])
    # Meshed when a query walks tets: the same tetrahedralization from the same options.
    back = copies[0]
    o, d = rays(lazy)
    walked, walked_back = lazy.cast(o, d, accel="tetwalk"), back.cast(o, d, accel="tetwalk")
    assert meshed == [1, 1] and lazy.has_ct and back.has_ct
    assert np.array_equal(lazy.tets(), back.tets()) and np.array_equal(lazy.points(), back.points())
    for name in ("t", "triangle", "tet", "status"):
        assert np.array_equal(getattr(walked, name), getattr(walked_back, name), equal_nan=True)
    # Saved once meshed, it is version 1 again.
    assert struct.unpack_from("<I", back.to_bytes(), len(scenefile.MAGIC))[0] == 1


def test_from_meshes_scene_keeps_its_geometries(tmp_path):
    v, f = icosphere(2)
    scene = tetrace.Scene.from_meshes(
        [(v, f), (v * 0.5 + [3.0, 0, 0], f)],
        preset="constrained",
        contain=np.array([[0.0, 0.0, 4.0]]),
        lazy=False,
    )
    scene.save(tmp_path / "two.tetrace")
    loaded = tetrace.Scene.load(tmp_path / "two.tetrace")
    assert loaded.geometries is not None and len(loaded.geometries) == 2
    options = loaded._build_options
    assert options.keys() == scene._build_options.keys() and options["preset"] == "constrained"
    assert np.array_equal(options["contain"], [[0.0, 0.0, 4.0]])
    for name in ("triangle_offsets", "vertex_offsets"):
        assert np.array_equal(getattr(loaded.geometries, name), getattr(scene.geometries, name))
    o = np.array([[-5.0, 0.01, 0.02], [10.0, 0.01, 0.02]])
    d = np.array([[1.0, 0, 0], [-1.0, 0, 0]])
    h = loaded.cast(o, d)
    assert h.geometry.tolist() == [0, 1]
    assert_same_answers(scene, loaded, accels=("tetwalk",))


def test_ftetwild_scene_round_trip():
    # fTetWild's faces name neighbour triangles (recomputed on load from the saved cleaned
    # mesh): the hits must still be the same.
    scene = tetrace.Scene.from_mesh(icosphere(2), mesher="ftetwild", lazy=False)
    loaded = tetrace.Scene.from_bytes(scene.to_bytes())
    assert loaded.tetrahedralization.mesher == "ftetwild"
    assert loaded.tetrahedralization.surface_distance == scene.tetrahedralization.surface_distance
    assert_same_answers(scene, loaded, accels=("tetwalk",))


def test_metadata_encoding_round_trips_exactly():
    a = np.arange(6, dtype=np.int32).reshape(2, 3)
    value = {
        "tuple": (1.0, 2),
        "floats": [0.1, float("inf"), float("nan"), -0.0, 1e-300],
        "array": a,
        "same": a,
        "keys": {1: "one", (2, 3): "pair"},
        "__odd": np.float32(0.5),
        "none": None,
        "flag": np.bool_(True),
    }
    arrays = {}
    meta = scenefile.encode(value, arrays, "m")
    assert len(arrays) == 1  # shared arrays are stored once
    data = scenefile.pack(arrays, meta)
    back_arrays, back_meta, _ = scenefile.unpack(data)
    back = scenefile.decode(back_meta, back_arrays)
    assert back["tuple"] == (1.0, 2) and isinstance(back["tuple"], tuple)
    assert back["floats"][:2] == [0.1, float("inf")] and np.isnan(back["floats"][2])
    assert str(back["floats"][3]) == "-0.0" and back["floats"][4] == 1e-300
    assert back["array"].dtype == np.int32 and np.array_equal(back["array"], a)
    assert back["same"] is back["array"]
    assert back["keys"] == {1: "one", (2, 3): "pair"}
    assert back["__odd"] == 0.5 and back["none"] is None and back["flag"] is True


# ----------------------------------------------------------------------- broken files


@pytest.fixture(scope="module")
def small():
    return tetrace.Scene.from_mesh(icosphere(1), preset="constrained", lazy=False)


def header_span(data):
    _, length, _ = struct.unpack_from("<IQI", data, len(scenefile.MAGIC))
    start = len(scenefile.MAGIC) + 16
    return start, start + length


def load_error(tmp_path, data, name="broken.tetrace"):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(tetrace.SceneFileError) as info:
        tetrace.Scene.load(path)
    assert str(path) in str(info.value)
    return str(info.value)


def test_wrong_magic(small, tmp_path):
    data = small.to_bytes()
    assert "not a tetrace scene file" in load_error(tmp_path, b"PK\x03\x04" + data[4:])
    assert "not a tetrace scene file" in load_error(tmp_path, b"hello world, no scene here")


def test_newer_version_names_both(small, tmp_path):
    data = bytearray(small.to_bytes())
    struct.pack_into("<I", data, len(scenefile.MAGIC), 7)
    msg = load_error(tmp_path, bytes(data))
    assert "format version 7" in msg and f"format version {scenefile.FORMAT_VERSION}" in msg


def test_truncated_at_many_offsets(small, tmp_path):
    data = small.to_bytes()
    h0, h1 = header_span(data)
    cuts = {0, 5, len(scenefile.MAGIC), h0 - 1, h0 + 10, h1, h1 + 3, len(data) // 2}
    cuts |= {len(data) - 1, len(data) - 100}
    for cut in sorted(cuts):
        msg = load_error(tmp_path, data[:cut], f"cut{cut}")
        assert "truncated" in msg, (cut, msg)
    assert "unexpected bytes" in load_error(tmp_path, data + b"\0" * 8)


def test_flipped_byte_in_an_array_fails_its_crc(small, tmp_path):
    data = small.to_bytes()
    _, h1 = header_span(data)
    header = json.loads(data[header_span(data)[0] : h1])
    base = h1 + (-h1 % 8)
    for entry in header["arrays"]:
        if entry["nbytes"] == 0:
            continue
        bad = bytearray(data)
        bad[base + entry["offset"] + entry["nbytes"] // 2] ^= 0x10
        msg = load_error(tmp_path, bytes(bad))
        assert f"array {entry['name']!r} is corrupt" in msg and "CRC32" in msg


def test_flipped_byte_in_the_header(small, tmp_path):
    data = small.to_bytes()
    h0, h1 = header_span(data)
    for at in (h0, (h0 + h1) // 2, h1 - 1):
        bad = bytearray(data)
        bad[at] ^= 0x01
        assert "corrupt header" in load_error(tmp_path, bytes(bad))
    # A consistent header (CRC right) whose content is wrong is caught too.
    bad = bytearray(data)
    header = json.loads(data[h0:h1])
    header["meta"]["kind"] = "tetrace.Scenx"
    raw = json.dumps(header, separators=(",", ":")).encode()
    raw = raw + b" " * (h1 - h0 - len(raw))
    assert len(raw) == h1 - h0
    bad[h0:h1] = raw
    struct.pack_into("<I", bad, len(scenefile.MAGIC) + 12, zlib.crc32(raw))
    assert "not a tetrace.Scene" in load_error(tmp_path, bytes(bad))


def test_missing_file_and_directory(small, tmp_path):
    with pytest.raises(tetrace.SceneFileNotFoundError, match="no such scene file") as info:
        tetrace.Scene.load(tmp_path / "nope.tetrace")
    assert isinstance(info.value, FileNotFoundError) and isinstance(info.value, ValueError)
    assert str(tmp_path / "nope.tetrace") in str(info.value)
    with pytest.raises(tetrace.SceneFileError, match="is a directory"):
        tetrace.Scene.load(tmp_path)
    with pytest.raises(tetrace.SceneFileError, match="<pickle>"):
        bad = bytearray(pickle.dumps(small))
        bad[len(bad) // 2] ^= 0x04  # inside the scene file's bytes
        pickle.loads(bytes(bad))


def test_scene_still_usable_after_failed_loads(small, tmp_path):
    o, d = rays(small, 500)
    before = small.cast(o, d)
    for data in (b"", small.to_bytes()[:100], b"x" * 50):
        with pytest.raises(tetrace.SceneFileError):
            tetrace.Scene.from_bytes(data)
    after = small.cast(o, d)
    assert np.array_equal(before.t, after.t) and np.array_equal(before.triangle, after.triangle)
    # A failed save leaves no file and no temporary behind.
    with pytest.raises(OSError):
        small.save(tmp_path / "no_such_dir" / "x.tetrace")
    assert list(tmp_path.iterdir()) == []


def test_errors_are_exported():
    assert issubclass(tetrace.SceneFileError, ValueError)
    assert issubclass(tetrace.SceneFileNotFoundError, tetrace.SceneFileError)
    assert tetrace.errors.SceneFileError is tetrace.SceneFileError
