//! GPU tests, and the fixtures they share. The shader checks (`shaders.rs`) need no GPU: naga
//! (the WGSL front end wgpu itself uses) parses and validates every kernel, and its layouter
//! checks the Rust mirrors of the WGSL structs. The parity tests (`parity.rs`) need an adapter
//! (Mesa's lavapipe is enough): without one they fail, unless `TETRACE_SKIP_GPU=1` is set
//! (then they skip, saying so). Every GPU result is also judged by the exact referee
//! (`crate::referee`): the GPU's twin on the CPU is no judge of either, and `t` is finished on
//! the CPU from the same triangle on both. `host.rs` tests the host's side (location, ray
//! preparation, the kernel table, limits) without a GPU.

mod camera;
mod contains;
mod finish;
mod host;
mod intersections;
mod occluded;
#[cfg(feature = "gpu-octree")]
mod octree;
mod parity;
mod shaders;

use crate::gpu::device_scene::DeviceScene;
use crate::gpu::kernels::KernelSpec;
use crate::scene::{CastOptions, HitsOut, Rays, Scene};
use crate::traverse::tests::{
    assert_between_touch_and_inside, kuhn_grid, tally, verdicts, Rng, Tally,
};

/// A GPU cast through a device copy of `scene` made for it (as a binding keeps one beside its
/// scene).
fn cast_gpu(
    scene: &Scene,
    method: Option<&str>,
    layout: Option<&str>,
    rays: &Rays<f32>,
    out: HitsOut<f32>,
    opts: &CastOptions,
) -> crate::Result<crate::gpu::GpuTimings> {
    DeviceScene::default().cast(scene, method, layout, rays, out, opts)
}

/// Runs entry point `entry` of WGSL `source` over `n` cases, one invocation each (a
/// workgroup of 64), with `uniform` at binding 0 (its first word the case count the entry
/// compares with), `inp` and then a 0.0 (what the kernels read as `zero_bits`) at binding 1,
/// and `words` f32 a case written at binding 2; returns binding 2 (the finishing's and the
/// camera kernel's function-by-function tests).
fn run_harness(
    source: &str,
    entry: &str,
    uniform: &[u8],
    inp: &[f32],
    n: usize,
    words: usize,
) -> Vec<f32> {
    use wgpu::util::DeviceExt;
    use wgpu::BufferUsages as U;
    let g = crate::gpu::gpu().unwrap();
    let pipeline = g.compute_pipeline("test harness", source, entry);
    let init = |contents: &[u8], usage| {
        g.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: None,
                contents,
                usage,
            })
    };
    let pbuf = init(uniform, U::UNIFORM);
    let inp: Vec<f32> = inp.iter().copied().chain([0.0]).collect();
    let ibuf = init(bytemuck::cast_slice(&inp), U::STORAGE);
    let size = (n * words * 4) as u64;
    let mk = |usage| {
        g.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size,
            usage,
            mapped_at_creation: false,
        })
    };
    let (obuf, rbuf) = (mk(U::STORAGE | U::COPY_SRC), mk(U::MAP_READ | U::COPY_DST));
    let entries: Vec<_> = [&pbuf, &ibuf, &obuf]
        .iter()
        .enumerate()
        .map(|(k, b)| wgpu::BindGroupEntry {
            binding: k as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    let bind = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let mut enc = g.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
    }
    enc.copy_buffer_to_buffer(&obuf, 0, &rbuf, 0, size);
    g.queue.submit([enc.finish()]);
    let mut out = Vec::new();
    g.read_mapped(&rbuf, size, &mut out, "harness results")
        .unwrap();
    out
}

/// The kernel named `method`/`layout` (it must exist).
fn kernel(method: &str, layout: &str) -> &'static KernelSpec {
    KernelSpec::find(Some(method), Some(layout)).unwrap()
}

/// The one opt-out: `TETRACE_SKIP_GPU=1` (exactly 1) turns a missing adapter into a skip.
fn skip_gpu() -> bool {
    std::env::var("TETRACE_SKIP_GPU").is_ok_and(|v| v.trim() == "1")
}

/// Whether the device is there. Without one the test fails with what to install, unless
/// `TETRACE_SKIP_GPU=1`: then it prints why it skips and the test returns. An adapter that
/// is found is always used.
fn device_or_skip(test: &str) -> bool {
    match crate::gpu::gpu() {
        Ok(_) => true,
        Err(e) if skip_gpu() => {
            eprintln!("SKIPPED {test}: no GPU adapter: {e} (TETRACE_SKIP_GPU=1)");
            false
        }
        Err(e) => panic!(
            "{test}: no GPU adapter: {e}. Install a Vulkan driver (Mesa's lavapipe: apt-get \
             install mesa-vulkan-drivers libvulkan1), or set TETRACE_SKIP_GPU=1 to skip the GPU \
             tests"
        ),
    }
}

/// The referee's verdicts for float32 rays (taken exactly).
fn verdicts32(
    o: &[f32],
    d: &[f32],
    tris: &[[[f64; 3]; 3]],
) -> Vec<Option<crate::referee::Verdict>> {
    let wide = |x: &[f32]| x.iter().map(|&x| x as f64).collect::<Vec<f64>>();
    verdicts(&wide(o), &wide(d), tris)
}

/// Judges a cast by the referee and prints the outcome counts. Asserted for every kernel:
/// no `t_off` (a tied triangle with `t` more than a float32 ulp from `t*`: the CPU finishes
/// every GPU hit with `t` within a float64 ulp of the exact value on the caller's triangle,
/// which rounds to within a float32 ulp).
fn judged(test: &str, want: &[Option<crate::referee::Verdict>], out: &Out) -> Tally {
    let c = tally(test, want, &out.status, &out.tri, &out.t);
    eprintln!("{test}: referee {c:?}");
    assert_eq!(c.t_off, 0, "{test}: t outside ulp + B on a tied triangle");
    c
}

/// The lines the float32 robust walk follows, as rays the referee can judge: the walk's line
/// runs through its start s (the ray's origin, or where it enters the box, rounded to
/// float32: `robust::exact_line`) and b = s + k d, so where b − s = k d exactly (checked:
/// the subtraction's rounding error is zero) it is the ray (s, d) from s on. Rays that do not
/// walk (they miss the box, or are refused) keep their own line; so do the (rare) rays whose
/// b − s is not exact, counted in the second value.
fn walked_lines(scene: &Scene, o: &[f32], d: &[f32]) -> (Vec<f64>, usize) {
    let rays = Rays {
        origins: o,
        directions: d,
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    let points = Some(&scene.points_f32[..]);
    let mut st = crate::locate::LocateState::seeded(1);
    let (mut out, mut inexact) = (Vec::with_capacity(o.len()), 0);
    for i in 0..o.len() / 3 {
        let start = scene.locate_one(&rays, i, points, &mut st);
        let own = [0, 1, 2].map(|a| o[3 * i + a] as f64);
        let origin = match start {
            crate::locate::Start::Walk(w) => {
                let (s, b) =
                    crate::traverse::robust::exact_line::<f32>(w.point, w.dir, &scene.mesh.bounds);
                let dir = [0, 1, 2].map(|a| d[3 * i + a] as f64);
                if walks_the_ray(s, b, dir) {
                    s
                } else {
                    inexact += 1;
                    own
                }
            }
            _ => own,
        };
        out.extend(origin);
    }
    (out, inexact)
}

/// Whether the line through s and b is the ray from s along `dir`: b − s is computed without
/// rounding (TwoSum's remainder is zero) and equals 2^e dir for one power of two.
fn walks_the_ray(s: [f64; 3], b: [f64; 3], dir: [f64; 3]) -> bool {
    let exact_diff = |x: f64, y: f64| {
        let (z, ny) = (x - y, -y);
        let x1 = z - ny;
        let y1 = z - x1;
        (x - x1) + (ny - y1) == 0.0
    };
    if !(0..3).all(|a| exact_diff(b[a], s[a])) {
        return false;
    }
    let big = (0..3)
        .max_by(|&i, &j| dir[i].abs().total_cmp(&dir[j].abs()))
        .unwrap();
    let r = (b[big] - s[big]) / dir[big];
    let power_of_two = r > 0.0 && r.is_normal() && r.to_bits() & ((1 << 52) - 1) == 0;
    power_of_two && (0..3).all(|a| b[a] - s[a] == r * dir[a])
}

/// The robust kernel's guarantee, exactly, on every ray: on the line it walks
/// ([`walked_lines`]), a hit between the first touch and the first sure hit on a triangle
/// that line crosses, a miss only with no sure hit ([`assert_between_touch_and_inside`]).
/// Where the walked line is not the ray's own (it starts from the entry point rounded to
/// float32), the referee's judgement of the ray itself may differ: that is printed by the
/// caller ([`judged`]), not asserted.
fn assert_robust_bracket(scene: &Scene, o: &[f32], d: &[f32], tris: &[[[f64; 3]; 3]], out: &Out) {
    use rayon::prelude::*;
    let (starts, inexact) = walked_lines(scene, o, d);
    let d64: Vec<f64> = d.iter().map(|&x| x as f64).collect();
    let want = verdicts(&starts, &d64, tris);
    let entering = (0..want.len())
        .filter(|&k| (0..3).any(|a| starts[3 * k + a] != o[3 * k + a] as f64))
        .count();
    eprintln!(
        "robust bracket: {} rays, {entering} walked from their box entry rounded to float32, \
         {inexact} with an inexact walked line (judged on their own)",
        want.len()
    );
    (0..want.len()).into_par_iter().for_each(|k| {
        let p = |v: &[f64]| [0, 1, 2].map(|a| v[3 * k + a]);
        if d[3 * k..3 * k + 3] == [0.0; 3] {
            assert_eq!(out.status[k], crate::status::INVALID, "ray {k}: d = 0");
            return;
        }
        // `t` is on the ray, not on the walked line: judged() checks it on the ray.
        assert_between_touch_and_inside::<f32>(
            k,
            out.status[k],
            out.tri[k],
            None,
            p(&starts),
            p(&d64),
            tris,
            want[k].as_ref(),
        );
    });
}

/// A jittered Kuhn grid over [0,1]³ moved by `offset`, a fraction `frac` of its interior faces
/// constrained (each its own triangle), and those triangles. The points are rounded to
/// float32 after the move (by at most 2^-21 at offset 10, far below the jitter): the GPU and
/// the float32 CPU walks then read the very mesh whose triangles the referee judges.
fn grid_scene(n: usize, frac: f64, offset: f64, seed: u64) -> (Scene, Vec<[[f64; 3]; 3]>) {
    grid_scene_with(n, frac, offset, seed, true)
}

/// [`grid_scene`], its points rounded to float32 or not (`f32_points`): then the device's
/// float32 copies are up to half an ulp off the mesh's points.
fn grid_scene_with(
    n: usize,
    frac: f64,
    offset: f64,
    seed: u64,
    f32_points: bool,
) -> (Scene, Vec<[[f64; 3]; 3]>) {
    let mut rng = Rng::xorshift(seed);
    let (mut pts, tets) = kuhn_grid(n, 0.3, &mut rng);
    for p in &mut pts {
        for x in p.iter_mut() {
            *x += offset;
            if f32_points {
                *x = (*x as f32) as f64;
            }
        }
    }
    let interior: Vec<[u32; 3]> = crate::testing::all_faces(&tets)
        .into_iter()
        .filter(|_| rng.f() < frac)
        .collect();
    let tris: Vec<[[f64; 3]; 3]> = interior
        .iter()
        .map(|f| f.map(|v| pts[v as usize]))
        .collect();
    let ids: Vec<u32> = (0..interior.len() as u32).collect();
    let scene = Scene::build(pts, &tets, &interior, &ids, tris.clone()).unwrap();
    (scene, tris)
}

/// Ray bounds that end some walks early: every third unbounded, the others uniform in
/// [0, 1.5) (the grid scenes' box is about 1 across).
fn mixed_tmax(n: usize, rng: &mut Rng) -> Vec<f64> {
    (0..n)
        .map(|i| match i % 3 {
            0 => f64::INFINITY,
            _ => rng.f() * 1.5,
        })
        .collect()
}

/// Random rays from inside and around the scene, and a pinhole camera from outside the box.
fn rays(n: usize, offset: f64, seed: u64) -> (Vec<f32>, Vec<f32>) {
    let mut rng = Rng::xorshift(seed);
    let (mut o, mut d) = (Vec::new(), Vec::new());
    for _ in 0..n {
        for _ in 0..3 {
            o.push((offset + rng.f() * 2.0 - 0.5) as f32);
            d.push((rng.f() - 0.5) as f32);
        }
    }
    let res = 128;
    let eye = [offset + 0.5, offset + 0.45, offset - 1.2];
    for y in 0..res {
        for x in 0..res {
            o.extend(eye.map(|e| e as f32));
            let px = (x as f64 + 0.5) / res as f64 - 0.5;
            let py = (y as f64 + 0.5) / res as f64 - 0.5;
            d.extend([px * 0.9, py * 0.9, 1.0].map(|v| v as f32));
        }
    }
    (o, d)
}

#[derive(Debug)]
struct Out {
    t: Vec<f32>,
    u: Vec<f32>,
    v: Vec<f32>,
    point: Vec<f32>,
    tri: Vec<i32>,
    tet: Vec<i32>,
    steps: Vec<u32>,
    status: Vec<u8>,
}

impl Out {
    /// The answers of rays `rows`, in that order.
    fn rows(&self, rows: &[usize]) -> Out {
        let pick = |n: usize| rows.iter().flat_map(move |&i| n * i..n * i + n);
        fn take<T: Copy>(x: &[T], at: impl Iterator<Item = usize>) -> Vec<T> {
            at.map(|i| x[i]).collect()
        }
        Out {
            t: take(&self.t, pick(1)),
            u: take(&self.u, pick(1)),
            v: take(&self.v, pick(1)),
            point: take(&self.point, pick(3)),
            tri: take(&self.tri, pick(1)),
            tet: take(&self.tet, pick(1)),
            steps: take(&self.steps, pick(1)),
            status: take(&self.status, pick(1)),
        }
    }
}

fn run(
    scene: &Scene,
    o: &[f32],
    d: &[f32],
    f: impl FnOnce(&Rays<f32>, HitsOut<f32>) -> crate::Result<()>,
) -> Out {
    let _ = scene;
    run_within(o, d, f64::INFINITY, f)
}

/// [`run`] with every ray's range [0, tmax].
fn run_within(
    o: &[f32],
    d: &[f32],
    tmax: f64,
    f: impl FnOnce(&Rays<f32>, HitsOut<f32>) -> crate::Result<()>,
) -> Out {
    run_ranges(o, d, (&[0.0], &[tmax]), f)
}

/// [`run`] with the ranges `[tmin, tmax]`: one for every ray, or one per ray.
fn run_ranges(
    o: &[f32],
    d: &[f32],
    (tmin, tmax): (&[f64], &[f64]),
    f: impl FnOnce(&Rays<f32>, HitsOut<f32>) -> crate::Result<()>,
) -> Out {
    let n = o.len() / 3;
    let (mut t, mut u, mut v, mut p) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; 3 * n]);
    let (mut tri, mut tet, mut steps, mut status) =
        (vec![0; n], vec![0; n], vec![0; n], vec![0; n]);
    let rays = Rays {
        origins: o,
        directions: d,
        tmin,
        tmax,
        leaving: None,
    };
    let out = HitsOut {
        t: &mut t,
        u: &mut u,
        v: &mut v,
        point: &mut p,
        triangle: &mut tri,
        tet: &mut tet,
        steps: &mut steps,
        status: &mut status,
        audit: &mut [],
    };
    f(&rays, out).unwrap();
    Out {
        t,
        u,
        v,
        point: p,
        tri,
        tet,
        steps,
        status,
    }
}
