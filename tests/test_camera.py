"""tetrace.camera: the look-at and intrinsics pinholes, Open3D's convention, the old dev pinhole
kept bit for bit, and ``camera=`` on the ray queries."""

import dataclasses

import numpy as np
import pytest

import tetrace
from tetrace import Camera
from tetrace.dev.camera import pinhole

U32 = 2.0**-24  # float32's unit roundoff


def _old_pinhole(
    eye, target, up=(0, 1, 0), fov_deg=45.0, width=1024, height=1024, dtype=np.float32
):
    """tetrace.dev.camera.pinhole as it was before it moved to tetrace.camera, verbatim
    (validation left out): the move must not change a single bit of any picture."""

    def unit(v):
        v = np.asarray(v, dtype=np.float64)
        return v / np.linalg.norm(v)

    eye = np.asarray(eye, dtype=np.float64)
    forward = unit(np.asarray(target, dtype=np.float64) - eye)
    right = np.cross(forward, unit(up))
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)

    half_h = np.tan(np.radians(fov_deg) / 2.0)
    half_w = half_h * width / height
    x = ((np.arange(width) + 0.5) / width * 2.0 - 1.0) * half_w
    y = (1.0 - (np.arange(height) + 0.5) / height * 2.0) * half_h
    dirs = (
        forward[None, None, :]
        + x[None, :, None] * right[None, None, :]
        + y[:, None, None] * true_up[None, None, :]
    ).reshape(-1, 3)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    origins = np.tile(eye.astype(dtype), (width * height, 1))
    return origins, dirs.astype(dtype)


def _rotation(seed):
    """A random proper rotation (QR of a Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _extrinsic(seed):
    e = np.eye(4)
    e[:3, :3] = _rotation(seed)
    e[:3, 3] = np.random.default_rng(seed + 100).normal(size=3) * 3.0
    return e


#: Intrinsics: plain, with skew and an off-centre principal point, and with K[2, 2] != 1
#: (Open3D inverts K whatever it holds; the directions scale by 1 / K[2, 2]).
INTRINSICS = {
    "plain": [[80.0, 0.0, 32.0], [0.0, 80.0, 24.0], [0.0, 0.0, 1.0]],
    "skew": [[91.5, 3.25, 29.75], [0.0, 70.125, 26.5], [0.0, 0.0, 1.0]],
    "scaled": [[160.0, 0.0, 64.0], [0.0, 150.0, 47.0], [0.0, 0.0, 2.0]],
}
W, H = 64, 48


# ------------------------------------------------------------------------------ look_at


def test_look_at_centre_ray_is_forward_for_odd_sizes():
    eye, target = np.array([1.0, 2.0, 3.0]), np.array([-0.5, 0.25, 0.0])
    cam = Camera.look_at(eye, target, up=(0, 0, 1), fov_deg=60.0, width=65, height=49)
    assert cam.shape == (49, 65) and cam.n_rays == 65 * 49
    assert (cam.width, cam.height) == (65, 49)
    o, d = cam.rays(np.float64)
    assert o.shape == d.shape == (49, 65, 3)
    forward = (target - eye) / np.linalg.norm(target - eye)
    # xs[32] and ys[24] are exactly 0: the centre ray is forward, up to its normalization
    np.testing.assert_allclose(d[24, 32], forward, rtol=0, atol=4e-16)
    np.testing.assert_array_equal(o, np.broadcast_to(eye, (49, 65, 3)))
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, rtol=0, atol=4e-16)


@pytest.mark.parametrize("width, height, fov", [(64, 48, 45.0), (33, 65, 90.0), (7, 7, 10.0)])
def test_look_at_corner_rays_make_the_field_of_view(width, height, fov):
    eye, target = np.array([0.0, 0.0, 5.0]), np.zeros(3)
    cam = Camera.look_at(eye, target, fov_deg=fov, width=width, height=height)
    _, d = cam.rays(np.float64)
    # looking down -z with +y up: right is +x
    forward, right, up = np.array([0, 0, -1.0]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    np.testing.assert_allclose(cam.axes, [right, up, forward], atol=1e-15)
    half = np.tan(np.radians(fov) / 2)
    # pixel centres sit half a pixel inside the image's edges, which are fov / 2 off axis
    want_v = np.arctan((1 - 1 / height) * half)
    want_h = np.arctan((1 - 1 / width) * half * width / height)
    for i, j, sy, sx in ((0, 0, 1, -1), (0, -1, 1, 1), (-1, 0, -1, -1), (-1, -1, -1, 1)):
        a, b, c = d[i, j] @ forward, d[i, j] @ right, d[i, j] @ up
        np.testing.assert_allclose(np.arctan2(sy * c, a), want_v, rtol=1e-13)
        np.testing.assert_allclose(np.arctan2(sx * b, a), want_h, rtol=1e-13)
        # the corner ray's angle with forward
        cos = 1 / np.sqrt(1 + np.tan(want_v) ** 2 + np.tan(want_h) ** 2)
        np.testing.assert_allclose(a, cos, rtol=1e-13)
    # row 0 is the top, column 0 the left
    assert d[0, 0] @ up > 0 and d[-1, 0] @ up < 0
    assert d[0, 0] @ right < 0 and d[0, -1] @ right > 0


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize(
    "view",
    [
        dict(eye=(0.3, 0.2, 2.5), target=(0, 0, 0), width=64, height=48),
        dict(
            eye=(1, 2, 3), target=(0.1, -0.2, 0.3), up=(0, 0, 1), fov_deg=40.0, width=33, height=17
        ),
        dict(
            eye=(-4, 1, 0.5),
            target=(2, 1.5, -1),
            up=(0.2, 1, 0.1),
            fov_deg=100.0,
            width=5,
            height=9,
        ),
        dict(eye=(1e3, 0, 0), target=(0, 0, 0), fov_deg=1.0, width=1, height=1),
    ],
)
def test_dev_pinhole_is_the_camera_and_the_float32_recipe(view, dtype):
    """Float64 rays are the old dev pinhole's, bit for bit; float32 rays are the float32
    recipe (tetrace.camera's docstring), which the GPU's kernel follows too: the old float64
    rays within the recipe's derived error of them."""
    o, d = pinhole(**view, dtype=dtype)
    oo, od = _old_pinhole(**view, dtype=dtype)
    assert o.tobytes() == oo.tobytes() and o.dtype == oo.dtype
    assert d.dtype == od.dtype and d.shape == od.shape
    for new in (o, d):
        assert new.flags.c_contiguous and new.flags.writeable
    cam = Camera.look_at(**view)
    co, cd = cam.rays(dtype)
    assert cd.tobytes() == d.tobytes() and cd.shape == (view["height"], view["width"], 3)
    assert np.array_equal(co.reshape(-1, 3), oo)
    if dtype == np.float64:
        assert d.tobytes() == od.tobytes()
        return
    assert d.tobytes() == _recipe32(cam).reshape(-1, 3).tobytes()
    # Against the exact unit vector e (the old float64 rays, within U64 of it): each
    # unnormalized component is within gamma_5 S_i of the exact one (its five roundings:
    # three inputs of a product or one of forward, the product, two sums; S_i the sum of the
    # terms' magnitudes), which moves the normalized vector by at most 2 gamma_5 |S| / |d|;
    # the sum of squares (gamma_3), sqrt and the division add 1.5 gamma_3 + 2 U relative.
    f64 = np.float64
    right, up, forward = cam.axes
    x, y = cam.xs[None, :, None], cam.ys[:, None, None]
    exact = forward + x * right + y * up
    s = np.abs(forward) + np.abs(x) * np.abs(right) + np.abs(y) * np.abs(up)
    g5 = 5 * U32 / (1 - 5 * U32)
    bound = 2 * g5 * np.linalg.norm(s, axis=-1) / np.linalg.norm(exact, axis=-1) + 7 * U32
    err = np.abs(d.astype(f64) - od.astype(f64)).reshape(cam.shape + (3,)).max(axis=-1)
    assert np.all(err <= bound + U32)  # + U32: the old rays' own rounding


def _recipe32(cam):
    """The float32 recipe in numpy's float32 arithmetic (each operation rounded; numpy never
    fuses): an implementation independent of the core's."""
    right, up, forward = np.asarray(cam.axes, dtype=np.float32)
    x = np.asarray(cam.xs, dtype=np.float32)[None, :, None]
    y = np.asarray(cam.ys, dtype=np.float32)[:, None, None]
    d = (forward + x * right) + y * up
    if cam.normalize:
        n = np.sqrt((d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2])
        d = d / n[..., None]
    return d


# ---------------------------------------------------------------------- from_intrinsics


@pytest.mark.parametrize("name", sorted(INTRINSICS))
@pytest.mark.parametrize("seed", [0, 1])
def test_from_intrinsics_matches_open3d(open3d, name, seed):
    k, e = np.array(INTRINSICS[name]), _extrinsic(seed)
    want = open3d.t.geometry.RaycastingScene.create_rays_pinhole(
        open3d.core.Tensor(k), open3d.core.Tensor(e), W, H
    ).numpy()
    assert want.shape == (H, W, 6) and want.dtype == np.float32
    cam = Camera.from_intrinsics(k, e, W, H)
    o, d = cam.rays(np.float32)
    assert o.dtype == d.dtype == np.float32 and o.shape == d.shape == (H, W, 3)
    assert d.tobytes() == _recipe32(cam).tobytes()
    # Open3D rounds M = R^T K^-1 to float32 (each entry within U32 |M_ik|) and takes the
    # dot products M (u, v, 1) in float32 (u = x + 0.5 is exact; a dot product of length 3
    # is within gamma_3 ~ 3 U32 of |M| |p|, with or without FMA), so each component is
    # within 4 U32 (|M| |p|)_i of the exact R^T K^-1 p. Ours is the float32 recipe on the
    # camera's float64 numbers (error ~1e-16), rounded: within gamma_5 S_i of the exact,
    # S_i = |forward_i| + |x| |right_i| + |y| |up_i| (five roundings: three inputs or one,
    # the product, two sums). Hence 4 U32 (|M| |p|)_i + 6 U32 S_i: a few float32 ulps of the
    # terms summed (a component that cancels to ~0 can differ by more of its own).
    m = np.abs(e[:3, :3].T @ np.linalg.inv(k))
    grid = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    p = np.stack([*grid, np.ones((H, W))], -1)
    scale = np.abs(p) @ m.T
    right, up, forward = np.abs(cam.axes)
    terms = forward + np.abs(cam.xs)[None, :, None] * right + np.abs(cam.ys)[:, None, None] * up
    assert np.all(np.abs(d - want[..., 3:]) <= 4 * U32 * scale + 6 * U32 * terms)
    # not normalized: the same lengths as Open3D's (for K[2, 2] = 1, camera depth 1)
    assert not np.allclose(np.linalg.norm(d, axis=-1), 1.0)
    # origins: the camera centre -R^T t, computed in float64 by both and rounded once; the
    # two float64 values may straddle a float32 rounding point: one ulp at most.
    c = np.abs(e[:3, :3].T) @ np.abs(e[:3, 3])
    assert np.all(np.abs(o - want[..., :3]) <= 2 * U32 * c)


@pytest.mark.parametrize("name", sorted(INTRINSICS))
def test_from_intrinsics_rays_project_back_to_their_pixels(name):
    k, e = np.array(INTRINSICS[name]), _extrinsic(3)
    r, t = e[:3, :3], e[:3, 3]
    cam = Camera.from_intrinsics(k, e, W, H)
    assert cam.normalize is False
    o, d = cam.rays(np.float64)
    # the origin is the camera centre: R eye + t = 0
    np.testing.assert_allclose(r @ cam.eye + t, 0.0, atol=1e-14 * np.abs(t).max())
    # a point on each ray projects to its pixel's centre: K (R (eye + s d) + t) ~ (u, v, 1)
    for s in (1.0, 7.5):
        x = (o + s * d) @ r.T + t
        uvw = x @ k.T
        j, i = np.meshgrid(np.arange(W), np.arange(H))
        np.testing.assert_allclose(uvw[..., 0] / uvw[..., 2], j + 0.5, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(uvw[..., 1] / uvw[..., 2], i + 0.5, rtol=1e-12, atol=1e-12)
    # Open3D's scale: K R d = (u, v, 1) exactly, so the direction's camera depth is 1 / K[2, 2]
    np.testing.assert_allclose((d @ r.T)[..., 2], 1.0 / k[2, 2], rtol=1e-14)


def test_from_intrinsics_agrees_with_look_at():
    """The same camera both ways: a vertical fov with square pixels is f = H / (2 tan(fov/2))
    about the image centre, and look_at's frame is R's rows with y flipped (image y is down)."""
    eye, target = np.array([0.5, -1.0, 4.0]), np.array([0.1, 0.2, -0.3])
    fov = 50.0
    look = Camera.look_at(eye, target, fov_deg=fov, width=W, height=H)
    f = H / (2 * np.tan(np.radians(fov) / 2))
    k = np.array([[f, 0, W / 2], [0, f, H / 2], [0, 0, 1]])
    right, up, forward = look.axes
    r = np.stack([right, -up, forward])
    e = np.eye(4)
    e[:3, :3], e[:3, 3] = r, -r @ eye
    cam = Camera.from_intrinsics(k, e, W, H)
    np.testing.assert_allclose(cam.eye, eye, rtol=1e-14)
    _, d = cam.rays(np.float64)
    _, want = look.rays(np.float64)
    np.testing.assert_allclose(d / np.linalg.norm(d, axis=-1, keepdims=True), want, atol=1e-14)


def test_three_by_four_extrinsic_is_the_same_camera():
    k, e = np.array(INTRINSICS["skew"]), _extrinsic(5)
    a = Camera.from_intrinsics(k, e, W, H).rays(np.float64)
    b = Camera.from_intrinsics(k, e[:3], W, H).rays(np.float64)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


# --------------------------------------------------------------------------- validation


K0 = INTRINSICS["plain"]
E0 = np.eye(4)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), width=0), "width and height must be posi"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), height=-3), "width and height must be p"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), width=6.5), "positive integers"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), width=True), "positive integers"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), fov_deg=0.0), r"fov_deg must be in \(0"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), fov_deg=180.0), "fov_deg"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), fov_deg=np.nan), "fov_deg"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 1)), "target - eye must be a finite nonzero"),
        (lambda: Camera.look_at((0, 0, np.inf), (0, 0, 0)), "target - eye must be a finite"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), up=(0, 0, 0)), "up must be a finite"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), up=(0, 0, 2)), "up is parallel"),
        (lambda: Camera.look_at((0, 1), (0, 0, 0)), r"eye must have shape \(3,\)"),
        (lambda: Camera.from_intrinsics(np.eye(4), E0, W, H), r"intrinsic must have shape"),
        (
            lambda: Camera.from_intrinsics([[1, 0, np.nan], [0, 1, 0], [0, 0, 1]], E0, W, H),
            "intrinsic must be finite",
        ),
        (lambda: Camera.from_intrinsics([[1, 0, 0], [0.5, 1, 0], [0, 0, 1]], E0, W, H), "upper"),
        (lambda: Camera.from_intrinsics([[0, 0, 0], [0, 1, 0], [0, 0, 1]], E0, W, H), "fx="),
        (lambda: Camera.from_intrinsics([[1, 0, 0], [0, 0, 0], [0, 0, 1]], E0, W, H), "nonzero"),
        (lambda: Camera.from_intrinsics([[1, 0, 0], [0, 1, 0], [0, 0, 0]], E0, W, H), "K.2, 2."),
        (lambda: Camera.from_intrinsics(K0, np.eye(3), W, H), r"extrinsic must have shape"),
        (lambda: Camera.from_intrinsics(K0, np.full((4, 4), np.inf), W, H), "extrinsic must be"),
        (lambda: Camera.from_intrinsics(K0, np.ones((4, 4)), W, H), "last row"),
        (lambda: Camera.from_intrinsics(K0, 2 * np.eye(4)[:3], W, H), "must be a rotation"),
        (lambda: Camera.from_intrinsics(K0, np.diag([1, 1, -1, 1]), W, H), "determinant"),
        (lambda: Camera.from_intrinsics(K0, E0, 0, H), "width and height must be positive"),
        (lambda: Camera(np.zeros(2), np.eye(3), [0.0], [0.0]), r"eye must have shape \(3,\)"),
        (lambda: Camera(np.zeros(3), np.eye(2), [0.0], [0.0]), r"axes must have shape"),
        (lambda: Camera(np.zeros(3), np.eye(3), [], [0.0]), "must not be empty"),
        (lambda: Camera(np.zeros(3), np.eye(3), [np.nan], [0.0]), "xs must be finite"),
        (lambda: Camera(np.zeros(3), np.eye(3), [0.0], [0.0], normalize="yes"), "normalize"),
        (lambda: Camera.look_at((0, 0, 1), (0, 0, 0), width=2).rays(np.int32), "dtype must"),
    ],
)
def test_bad_cameras_raise_value_error_naming_the_problem(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_cameras_are_immutable():
    cam = Camera.look_at((0, 0, 1), (0, 0, 0), width=4, height=3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        cam.eye = np.zeros(3)
    for a in (cam.eye, cam.axes, cam.xs, cam.ys):
        with pytest.raises(ValueError, match="read-only"):
            a[0] = 1.0
    eye = np.array([0.0, 0.0, 1.0])
    cam = Camera(eye, np.eye(3), [0.0], [0.0])
    eye[0] = 5.0  # the camera holds its own copy
    assert cam.eye[0] == 0.0
    o, d = cam.rays()
    assert not o.flags.writeable and d.flags.writeable
    assert "width=4" in repr(Camera.look_at((0, 0, 1), (0, 0, 0), width=4, height=3))
    assert tetrace.camera.Camera is Camera and "Camera" in tetrace.__all__


# ------------------------------------------------------------------------ camera= on Scene


@pytest.fixture(scope="module")
def spot():
    return tetrace.default_scene()


def _spot_camera(scene, width=W, height=H):
    lo, hi = scene.vertices.min(0), scene.vertices.max(0)
    c = (lo + hi) / 2
    eye = c + np.array([0.3, 0.2, 1.0]) * 1.5 * np.linalg.norm(hi - lo)
    return Camera.look_at(eye, c, fov_deg=40.0, width=width, height=height)


def _assert_same_hits(a, b):
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "timings":
            continue
        assert (x is None) == (y is None), f.name
        if x is not None:
            assert x.dtype == y.dtype and x.shape == y.shape, f.name
            np.testing.assert_array_equal(x, y, err_msg=f.name)


@pytest.mark.parametrize("precision, dtype", [(None, np.float32), ("f64", np.float64)])
def test_cast_camera_equals_cast_of_its_rays(spot, precision, dtype):
    cam = _spot_camera(spot)
    got = spot.cast(camera=cam, precision=precision)
    assert got.shape == (H, W) and got.t.dtype == dtype
    o, d = cam.rays(dtype)
    want = spot.cast(o.reshape(-1, 3), d.reshape(-1, 3))
    hit = got.status == tetrace.HIT
    assert 0 < hit.sum() < hit.size  # the camera sees the cow and the background
    _assert_same_hits(got, want.reshape((H, W)))
    _assert_same_hits(got, spot.cast(*cam.rays(dtype)))
    # bounds of the image's shape apply per pixel
    tmax = np.where(np.arange(W)[None, :] < W // 2, np.inf, 0.0) * np.ones((H, 1))
    half = spot.cast(camera=cam, tmax=tmax, precision=precision)
    assert not (half.status[:, W // 2 :] == tetrace.HIT).any()
    np.testing.assert_array_equal(half.t[:, : W // 2], got.t[:, : W // 2])


def test_other_queries_take_a_camera(spot):
    cam = _spot_camera(spot, 24, 18)
    o, d = cam.rays()
    occ = spot.occluded(camera=cam)
    assert occ.shape == (18, 24)
    np.testing.assert_array_equal(occ, spot.occluded(o, d))
    count = spot.count_intersections(camera=cam)
    assert count.shape == (18, 24)
    np.testing.assert_array_equal(count, spot.count_intersections(o, d))
    every = spot.intersections(camera=cam)
    assert every.shape == (18, 24)
    want = spot.intersections(o, d)
    np.testing.assert_array_equal(every.offsets, want.offsets)
    np.testing.assert_array_equal(every.t, want.t)
    np.testing.assert_array_equal(every.counts, count)


def test_camera_and_rays_are_refused_together(spot):
    cam = _spot_camera(spot, 4, 3)
    o, d = cam.rays()
    with pytest.raises(ValueError, match="give camera or rays"):
        spot.cast(o, d, camera=cam)
    with pytest.raises(ValueError, match="give camera or rays"):
        spot.cast(None, d, camera=cam)
    with pytest.raises(ValueError, match="give camera or rays"):
        spot.occluded(camera=cam, start=spot.cast(camera=cam), directions=d)
    with pytest.raises(TypeError, match="camera must be a tetrace.Camera"):
        spot.cast(camera=(o, d))


def test_gpu_cast_takes_a_camera(spot):
    from conftest import gpu_device

    gpu_device()  # fails without an adapter unless TETRACE_SKIP_GPU=1 (conftest)
    cam = _spot_camera(spot, 32, 24)
    got = spot.cast(camera=cam, device="gpu")
    assert got.shape == (24, 32) and got.t.dtype == np.float32
    # the directions were made by the GPU's camera kernel, not uploaded
    assert got.timings["camera_rays"] and got.timings["shared_origin"]
    # a finite range: the same as the camera's rays passed with it, and as the CPU's
    o, d = cam.rays()
    hit = got.status == tetrace.HIT
    tmax = float(np.median(got.t[hit]))
    near = spot.cast(camera=cam, tmax=tmax, device="gpu")
    assert near.timings["camera_rays"] and (near.status[hit] == tetrace.MISS).any()
    _assert_same_hits(near, spot.cast(o, d, tmax=tmax, device="gpu"))
    _assert_same_hits(near, spot.cast(camera=cam, tmax=tmax, accel="tetwalk"))
    # a range after the eye (a near plane), still made and begun on the device: rays whose
    # first hit lies before it are walked on by the host, as the CPU walks them
    far = spot.cast(camera=cam, tmin=tmax, device="gpu")
    assert far.timings["camera_rays"] and far.timings["shared_origin"]
    assert ((far.status == tetrace.HIT) & hit & (far.t > got.t)).any()
    _assert_same_hits(far, spot.cast(o, d, tmin=tmax, device="gpu"))
    _assert_same_hits(far, spot.cast(camera=cam, tmin=tmax, accel="tetwalk"))
    _assert_same_hits(got, spot.cast(*cam.rays(), device="gpu"))
    # the GPU exact walk's answers are the CPU exact walk's, bit for bit (tet and steps too)
    _assert_same_hits(got, spot.cast(camera=cam, accel="tetwalk"))


def test_core_camera_directions_refuse_bad_numbers():
    from tetrace import _native

    axes, xs, ys, _ = Camera.look_at((0, 0, 3), (0, 0, 0), width=4, height=3).float32_numbers()
    assert _native.camera_directions(axes, xs, ys, True).shape == (3, 4, 3)
    with pytest.raises(ValueError, match=r"camera axes must have shape \(3, 3\)"):
        _native.camera_directions(axes[:2], xs, ys, True)
    with pytest.raises(ValueError, match="at least one pixel"):
        _native.camera_directions(axes, xs[:0], ys, True)
    with pytest.raises(ValueError, match="must be finite"):
        _native.camera_directions(axes, np.array([np.nan, 1], np.float32), ys, True)
    with pytest.raises(ValueError, match="C-contiguous"):
        _native.camera_directions(axes, np.repeat(xs, 2)[::2], ys, True)


def test_gpu_camera_ray_of_zero_length_is_invalid(spot):
    """A pixel whose direction is zero (forward + x right = 0 at y = 0): the kernel hands it
    back, and the cast raises naming it, or marks it INVALID as the CPU does."""
    from conftest import gpu_device

    gpu_device()
    centre = spot.vertices.mean(axis=0)
    axes = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    xs, ys = np.array([1.0, 0.5, 0.25]), np.array([0.1, 0.0])
    cam = Camera(centre + (-3.0, 0.0, 0.1), axes, xs, ys, normalize=False)
    with pytest.raises(ValueError, match=r"first: ray \(1, 0\), directions: zero length"):
        spot.cast(camera=cam, device="gpu")
    got = spot.cast(camera=cam, device="gpu", invalid="mark")
    assert got.timings["camera_rays"] and got.status[1, 0] == tetrace.INVALID
    _assert_same_hits(got, spot.cast(camera=cam, invalid="mark", accel="tetwalk"))
