"""`python -m tetrace.dev.dump` writes what `examples/profile_cast.rs` reads: the scene's
tetrahedralization and the caller's triangles as raw little-endian arrays, and the rays."""

import numpy as np

import tetrace
from tetrace.dev.dump import dump


def test_dump_writes_the_tetrahedralization_and_rays(tmp_path):
    scene = dump(tetrace.default_scene_path(), tmp_path, width=16, n_random=50)
    tz = scene.tetrahedralization

    def read(name, dtype, width):
        return np.fromfile(tmp_path / name, dtype=dtype).reshape(-1, width)

    assert np.array_equal(read("points.f64", "<f8", 3), tz.points)
    assert np.array_equal(read("tets.u32", "<u4", 4), tz.tets)
    assert np.array_equal(read("faces.u32", "<u4", 3), np.asarray(tz.faces).reshape(-1, 3))
    assert np.array_equal(read("face_triangle.u32", "<u4", 1)[:, 0], tz.face_triangle)
    triangles = read("triangles.f64", "<f8", 9).reshape(-1, 3, 3)
    assert np.array_equal(triangles, scene.vertices[scene.faces])
    camera = read("camera.f32", "<f4", 6)
    assert camera.shape == (16 * 16, 6)
    # A pinhole camera: one origin, unit directions; the middle band is rows 7..9 of 16.
    assert (camera[:, :3] == camera[0, :3]).all()
    # Directions normalized by the float32 recipe (tetrace.camera): d / n with n the
    # correctly rounded square root of the float32 sum of squares, within (gamma_3 / 2 + U)
    # of |d|, and each quotient rounded once (U): the norm within 3.5 U of 1 (U = 2^-24;
    # 4 U written), taken in float64 (a few ulps of 2^-52).
    norm = np.linalg.norm(camera[:, 3:].astype(np.float64), axis=1)
    assert (np.abs(norm - 1.0) <= 4 * 2.0**-24 + 4 * 2.0**-52).all()
    assert np.array_equal(read("cammid.f32", "<f4", 6), camera[7 * 16 : 9 * 16])
    random = read("random.f32", "<f4", 6)
    v = scene.vertices
    lo, hi = v.min(0) - 1e-6, v.max(0) + 1e-6
    assert random.shape == (50, 6)
    assert ((random[:, :3] >= lo) & (random[:, :3] <= hi)).all()
