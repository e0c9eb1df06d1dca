//! The camera kernel (shaders/camera.wgsl) against its CPU twin (`camera::direction`): the
//! same directions bit for bit, or NaN for a ray it hands back; and its correctly rounded
//! square root and quotient from guesses several ulps off (a real GPU's `sqrt` and `/` are;
//! lavapipe's are exact, so the test moves the guesses itself).

use super::*;
use crate::camera::{direction, CameraF32};
use crate::gpu::camera::{CameraKernel, FILE};
use crate::gpu::gpu;
use crate::gpu::{Batching, DeviceScene};
use crate::scene::CastOptions;

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|x| x / n)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A right-handed frame from a random rotation (the rows of a look-at camera's `axes`).
fn frame(rng: &mut Rng) -> [[f32; 3]; 3] {
    let v = |rng: &mut Rng| [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5];
    let f = unit(v(rng));
    let r = unit(cross(f, v(rng)));
    let u = cross(r, f);
    [r, u, f].map(|a| a.map(|x| x as f32))
}

/// Pixel centres' coordinates as `Camera.look_at` makes them: `n` values across
/// [-half, half].
fn centres(n: usize, half: f64) -> Vec<f32> {
    (0..n)
        .map(|j| (((j as f64 + 0.5) / n as f64 * 2.0 - 1.0) * half) as f32)
        .collect()
}

fn cameras() -> Vec<(&'static str, CameraF32)> {
    let mut rng = Rng::xorshift(41);
    let mut out = Vec::new();
    let look = |[right, up, forward]: [[f32; 3]; 3], w, h, half: f64, normalize| CameraF32 {
        right,
        up,
        forward,
        xs: centres(w, half * w as f64 / h as f64),
        ys: centres(h, half).into_iter().rev().collect(),
        normalize,
    };
    for (name, half) in [
        ("45°", 0.414),
        ("1°", 0.0087),
        ("179°", 114.6),
        ("0.001°", 8.7e-6),
    ] {
        out.push((name, look(frame(&mut rng), 61, 37, half, true)));
    }
    // Axis-aligned: zero components, and centre rows and columns where x = 0 or y = 0.
    let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
    let mut centred = look(axes, 9, 7, 0.5, true);
    centred.xs[4] = 0.0;
    centred.ys[3] = 0.0;
    out.push(("axis-aligned", centred));
    // Sums that cancel exactly (forward.x + x right.x = 0) or almost (a few ulps of 0.5).
    let mut cancel = look(
        [[-1.0, 0.25, 0.0], [0.0, 1.0, 0.5], [0.5, 0.0, -1.0]],
        8,
        5,
        1.0,
        true,
    );
    cancel.xs = vec![0.5, 0.5000001, 0.49999997, -0.5, 1.0, 0.0, 2.0, 1e-9];
    cancel.ys = vec![0.0, 1.0, -2.0, 0.5000001, 3.0];
    out.push(("cancelling", cancel.clone()));
    out.push((
        "cancelling, not normalized",
        CameraF32 {
            normalize: false,
            ..cancel
        },
    ));
    // Intrinsics (not normalized, a sheared vertical axis, depth scaled), as from_intrinsics.
    let [r, u, f] = frame(&mut rng);
    out.push((
        "intrinsics",
        CameraF32 {
            right: r,
            up: std::array::from_fn(|k| u[k] - 0.01 * r[k]),
            forward: f.map(|x| x / 1.5),
            xs: (0..40)
                .map(|j| ((j as f64 + 0.5 - 19.7) / 500.0) as f32)
                .collect(),
            ys: (0..30)
                .map(|i| ((i as f64 + 0.5 - 15.2) / 510.0) as f32)
                .collect(),
            normalize: false,
        },
    ));
    // Near the kernel's limits: coordinates of 2^-59 (components that fall below 2^-60 are
    // handed back) and of 2^29.
    let tiny = 2f32.powi(-59);
    let edge = CameraF32 {
        right: [1.0, tiny, 0.0],
        up: [0.0, 0.0, 1.0],
        forward: [0.0, 0.0, tiny],
        xs: vec![tiny, -tiny, 2f32.powi(29), 1.0, 0.0, 3.0],
        ys: vec![0.75, 0.25, -0.25, -0.75],
        normalize: true,
    };
    out.push(("extreme", edge));
    out
}

/// Every direction the kernel makes is the twin's, bit for bit, and only the extreme camera
/// has rays handed back.
#[test]
fn device_camera_rays_are_the_twins() {
    if !device_or_skip("device camera rays") {
        return;
    }
    let g = gpu().unwrap();
    let kernel = CameraKernel::new(&g).unwrap();
    let mut handed_extreme = 0;
    for (name, c) in cameras() {
        assert!(c.fits_device(), "{name}");
        let got = kernel.directions(&g, &c).unwrap();
        assert_eq!(got.len(), 3 * c.n_rays(), "{name}");
        let mut handed = 0;
        for (p, d) in got.chunks(3).enumerate() {
            if d.iter().any(|x| x.is_nan()) {
                assert!(d.iter().all(|x| x.is_nan()), "{name} ray {p}: {d:?}");
                handed += 1;
                continue;
            }
            let want = c.ray(p);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(d),
                bits(&want),
                "{name} ray {p}: {d:?} against {want:?}"
            );
        }
        if name == "extreme" {
            handed_extreme = handed;
        } else {
            assert_eq!(handed, 0, "{name}: handed back");
        }
    }
    // x = ±2^-59 with right = (1, 2^-59, 0) and forward.y = up.y = 0: d.y = ±2^-118, nonzero
    // below 2^-60, so those two columns' 8 rays are handed back, and only those.
    assert_eq!(handed_extreme, 8);
}

/// Runs `body` (WGSL statements reading `coords[words * i ..]`, writing `dirs[i]`) over `n`
/// cases with camera.wgsl's functions in scope.
fn run_cases(body: &str, inp: &[f32], n: usize) -> Vec<f32> {
    let source = format!(
        "{FILE}\n@compute @workgroup_size(64) fn harness(@builtin(global_invocation_id) g: vec3<u32>) {{\n\
         let i = g.x; if i >= cam.n_rays {{ return; }}\n\
         zero_bits = bitcast<u32>(coords[arrayLength(&coords) - 1u]);\n{body}\n}}"
    );
    let params = crate::gpu::camera::CamParams {
        n_rays: n as u32,
        ..Default::default()
    };
    run_harness(&source, "harness", bytemuck::bytes_of(&params), inp, n, 1)
}

/// `x` moved by `k` ulps (through its bits: a positive float's neighbours).
fn ulps(x: f32, k: i32) -> f32 {
    f32::from_bits((x.to_bits() as i64 + k as i64) as u32)
}

/// Positive normals across the range the kernel's norms take, with the awkward ones: powers
/// of two (even and odd exponents) and their neighbours, exact squares, random significands.
fn positives(rng: &mut Rng) -> Vec<f32> {
    let mut xs = Vec::new();
    for e in -120..=125 {
        let p = 2f32.powi(e);
        xs.extend([
            p,
            ulps(p, 1),
            ulps(p, -1),
            ulps(p, 2),
            1.5 * p,
            ulps(2.0 * p, -1),
        ]);
        xs.push(((1.0 + rng.f()) * p as f64) as f32);
        let r = ((1.0 + rng.f()) as f32) * 2f32.powi(e / 2);
        xs.push(r * r); // an exact square or its rounding
    }
    xs
}

/// The square root and the quotient the kernel corrects are the correctly rounded ones, from
/// guesses up to six ulps off either way and from the device's own `sqrt` and `/`. (Rounding
/// the float64 result of a float64 operation on float32 numbers to float32 gives the
/// correctly rounded float32 result: float64 has more than 2 · 24 + 2 bits.)
#[test]
fn device_sqrt_and_division_are_correctly_rounded_from_nearby_guesses() {
    if !device_or_skip("device correctly rounded sqrt") {
        return;
    }
    let mut rng = Rng::xorshift(7);
    let xs = positives(&mut rng);
    // sqrt: (x, guess, 1 to take the device's sqrt(x) instead) per case. (Not a NaN guess
    // for that: lavapipe compiles with no-NaN assumptions and folds `s0 != s0` to false.)
    let (mut inp, mut want) = (Vec::new(), Vec::new());
    for &x in &xs {
        let s = (x as f64).sqrt() as f32;
        for k in (-6..=6).chain([99]) {
            inp.extend([x, ulps(s, k.min(6)), (k == 99) as u8 as f32]);
            want.push(s);
        }
    }
    let body = "let x = coords[3u * i]; let s0 = coords[3u * i + 1u];\n\
                dirs[i] = select(sqrt_rn_from(x, s0), sqrt_rn(x), coords[3u * i + 2u] == 1.0);";
    let got = run_cases(body, &inp, want.len());
    for (c, (g, w)) in got.iter().zip(&want).enumerate() {
        let (x, s0) = (inp[3 * c], inp[3 * c + 1]);
        assert_eq!(
            g.to_bits(),
            w.to_bits(),
            "sqrt({x:e}) from {s0:e}: {g:e}, not {w:e}"
        );
    }
    // division: (a, n, guess) per case, a of either sign and of any size against n, the
    // quotient's exact value normal.
    let (mut inp, mut want) = (Vec::new(), Vec::new());
    for (c, &n) in xs.iter().enumerate() {
        let m = xs[(c * 7 + 3) % xs.len()];
        for a in [
            n,
            -n,
            ulps(n, 1),
            ulps(n, -1),
            m,
            -m,
            0.0,
            -0.0,
            3.0 * n,
            n / 3.0,
        ] {
            let q = (a as f64 / n as f64) as f32;
            if a != 0.0 && !(q.abs() >= f32::MIN_POSITIVE && q.is_finite()) {
                continue; // the kernel is given no quotient outside the normal range
            }
            if a == 0.0 {
                inp.extend([a, n, 1.0, 1.0]); // no guess: a zero is answered at once
                want.push(q);
                continue;
            }
            for k in (-6..=6).chain([99]) {
                inp.extend([a, n, ulps(q.abs(), k.min(6)), (k == 99) as u8 as f32]);
                want.push(q);
            }
        }
    }
    let body =
        "let a = coords[4u * i]; let n = coords[4u * i + 1u]; let q0 = coords[4u * i + 2u];\n\
                dirs[i] = select(div_rn_from(a, n, q0), div_rn(a, n), coords[4u * i + 3u] == 1.0);";
    let got = run_cases(body, &inp, want.len());
    for (c, (g, w)) in got.iter().zip(&want).enumerate() {
        let (a, n, q0) = (inp[4 * c], inp[4 * c + 1], inp[4 * c + 2]);
        assert_eq!(
            g.to_bits(),
            w.to_bits(),
            "{a:e} / {n:e} from {q0:e}: {g:e}, not {w:e}"
        );
    }
}

/// The twin itself is the recipe of `camera` (its module's test); here the cameras above go
/// through it once more on several threads, in one call, as `Camera.rays` takes them.
#[test]
fn twin_directions_in_parallel_are_ray_by_ray() {
    for (name, c) in cameras() {
        let all = crate::camera::directions(&c, Some(3)).unwrap();
        for p in 0..c.n_rays() {
            let d = direction(&c, c.xs[p % c.width()], c.ys[p / c.width()]);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&all[3 * p..3 * p + 3]), bits(&d), "{name} ray {p}");
        }
    }
}

/// A look-at camera's float32 numbers (as `Camera.look_at` makes them, then rounded).
fn look_at(eye: [f64; 3], target: [f64; 3], w: usize, h: usize, half: f64) -> CameraF32 {
    let f = unit([0, 1, 2].map(|k| target[k] - eye[k]));
    let r = unit(cross(f, [0.0, 1.0, 0.1]));
    let u = cross(r, f);
    CameraF32 {
        right: r.map(|x| x as f32),
        up: u.map(|x| x as f32),
        forward: f.map(|x| x as f32),
        xs: centres(w, half * w as f64 / h as f64),
        ys: centres(h, half).into_iter().rev().collect(),
        normalize: true,
    }
}

/// `DeviceScene::cast_camera_at` answers as the CPU exact cast of the camera's rays, every
/// column bit for bit and every ray right by the referee, whether the directions are made on
/// the device (eye inside or outside the box, normalized or not, rays handed back) or, for a
/// camera or an eye the kernels do not take, uploaded.
#[test]
fn gpu_camera_cast_is_the_cpu_exact_cast() {
    let test = "gpu camera cast";
    if !device_or_skip(test) {
        return;
    }
    let (scene, tris) = grid_scene(6, 0.08, 0.0, 71);
    let opts = CastOptions {
        threads: None,
        max_steps: Some(scene.mesh.len() as u32 + 1),
        ..Default::default()
    };
    let centre = [0.5, 0.5, 0.5];
    let vertex = scene.mesh.points[scene.mesh.tets[7][2] as usize].map(|x| x as f32);
    let mut intrinsics = look_at([1.6, -0.55, 2.2], centre, 40, 30, 0.4);
    intrinsics.normalize = false;
    intrinsics.forward = intrinsics.forward.map(|x| x / 1.5);
    let mut far_out = look_at([0.4, 0.5, -2.0], centre, 33, 21, 0.5);
    far_out.xs[5] = 1e-30; // outside the camera kernel's range: the rays are uploaded
    let mut extreme = cameras().pop().expect("the extreme camera").1;
    extreme.forward = [0.0, 0.0, 2f32.powi(-59)];
    let cases: [(&str, [f32; 3], CameraF32, bool); 6] = [
        (
            "outside",
            [0.5, 0.45, -1.2],
            look_at([0.5, 0.45, -1.2], centre, 48, 40, 0.6),
            true,
        ),
        (
            "inside, 179°",
            [0.437, 0.519, 0.283],
            look_at([0.437, 0.519, 0.283], [0.9, 0.1, 0.7], 31, 23, 114.6),
            true,
        ),
        ("intrinsics", [1.6, -0.55, 2.2], intrinsics, true),
        ("extreme, inside", [0.437, 0.519, 0.283], extreme, true),
        ("kernel's range", [0.4, 0.5, -2.0], far_out, false),
        (
            "eye on a vertex",
            vertex,
            look_at(vertex.map(f64::from), centre, 20, 16, 0.7),
            false,
        ),
    ];
    for (name, eye, cam, on_device) in cases {
        let name = format!("{test}: {name}");
        let d = crate::camera::directions(&cam, None).unwrap();
        let o: Vec<f32> = (0..cam.n_rays()).flat_map(|_| eye).collect();
        let cpu = run(&scene, &o, &d, |r, out| scene.cast(r, out, &opts));
        let range = (0.0, f64::INFINITY);
        let mut timings = None;
        let gpu = run(&scene, &o, &d, |_, out| {
            let t = DeviceScene::default().cast_camera_at(&scene, &cam, eye, range, out, &opts)?;
            timings = Some(t);
            Ok(())
        });
        let t = timings.expect("the GPU cast ran");
        // Batches of 100 rays in rows of one workgroup (each batch's rays made from its first
        // pixel, the 2D dispatch), and the discrete GPU's copies: the same answers.
        for batching in [
            Batching {
                max_batch: 100,
                max_groups: Some(1),
                ..Default::default()
            },
            Batching {
                copy_results: true,
                ..Default::default()
            },
        ] {
            let scene_gpu = DeviceScene::default();
            let again = run(&scene, &o, &d, |_, out| {
                let t = scene_gpu
                    .cast_camera_at_with(&scene, &cam, eye, range, out, &opts, batching)?;
                assert_eq!(t.camera_rays, on_device, "{name}: {batching:?}");
                Ok(())
            });
            super::parity::assert_same_answers(&format!("{name}, {batching:?}"), &cpu, &again);
        }
        eprintln!(
            "{name}: {} rays, shared origin {}, made on the device {}, {} handed back",
            cam.n_rays(),
            t.shared_origin,
            t.camera_rays,
            t.deferred
        );
        super::parity::assert_same_answers(&name, &cpu, &gpu);
        let c = judged(&name, &verdicts32(&o, &d, &tris), &gpu);
        assert_eq!(c.bad(), 0, "{name}: {c:?}");
        assert_eq!(t.camera_rays, on_device, "{name}");
        assert_eq!(
            t.camera > 0.0,
            on_device,
            "{name}: the camera kernel's time"
        );
        if name.ends_with("extreme, inside") {
            assert!(
                t.deferred >= 8,
                "{name}: the kernel's NaN rays are handed back"
            );
        }
    }
}
