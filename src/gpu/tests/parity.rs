//! Each kernel against its CPU twin and the referee, on lavapipe or any adapter.

use super::*;
use crate::gpu::kernels::{KernelSpec, KERNELS};
use crate::gpu::launch::Batching;
use crate::status::{FAILED, HIT};

/// A GPU cast against its CPU twin's.
struct Parity {
    /// Rays cast.
    n: usize,
    /// Rays with a different triangle or status.
    differ: usize,
    /// The worst relative t error over rays with the same triangle.
    worst: f64,
    /// Rays FAILED on the GPU.
    failed: usize,
    cpu: Out,
    gpu: Out,
    timings: crate::gpu::GpuTimings,
}

/// GPU against its CPU twin.
fn parity(scene: &Scene, kernel: &KernelSpec, o: &[f32], d: &[f32]) -> Parity {
    let opts = CastOptions {
        threads: None,
        max_steps: Some(scene.mesh.len() as u32 + 1),
        ..Default::default()
    };
    let cpu = run(scene, o, d, |r, out| {
        scene.cast_named(kernel.method, kernel.layout.name, r, out, &opts)
    });
    let mut timings = Default::default();
    let gpu = run(scene, o, d, |r, out| {
        timings = cast_gpu(
            scene,
            Some(kernel.method),
            Some(kernel.layout.name),
            r,
            out,
            &opts,
        )?;
        Ok(())
    });
    let n = cpu.t.len();
    let mut differ = 0;
    let mut worst = 0f64;
    for i in 0..n {
        if cpu.tri[i] != gpu.tri[i] || cpu.status[i] != gpu.status[i] {
            differ += 1;
        } else if cpu.status[i] == HIT {
            let (a, b) = (cpu.t[i] as f64, gpu.t[i] as f64);
            worst = worst.max((a - b).abs() / a.abs().max(f64::MIN_POSITIVE));
        }
    }
    let failed = gpu.status.iter().filter(|&&s| s == FAILED).count();
    Parity {
        n,
        differ,
        worst,
        failed,
        cpu,
        gpu,
        timings,
    }
}

fn check_kernel(kernel: &KernelSpec) {
    let test = format!("gpu parity {}", kernel.name());
    if !device_or_skip(&test) {
        return;
    }
    for (offset, seed) in [(0.0, 3u64), (10.0, 5)] {
        let (scene, tris) = grid_scene(10, 0.05, offset, seed);
        let (o, d) = rays(40_000, offset, seed + 1);
        let Parity {
            n,
            differ,
            worst,
            failed,
            cpu,
            gpu,
            timings: t,
        } = parity(&scene, kernel, &o, &d);
        let hits = gpu.status.iter().filter(|&&s| s == HIT).count();
        eprintln!(
            "{test} offset {offset}: {n} rays, {hits} hits, {differ} differ from the CPU twin, \
             worst relative t {worst:.2e}, {failed} failed, {} walked on the GPU, {} deferred",
            t.walked, t.deferred
        );
        assert!(
            hits > n / 10,
            "{test}: too few hits ({hits}) to mean anything"
        );
        assert_eq!(failed, 0, "{test}");
        assert!(worst <= 1e-6, "{test}: t differs by {worst:e}");
        // The GPU's answers against the referee; the CPU twin's, printed beside them.
        let want = verdicts32(&o, &d, &tris);
        judged(&format!("{test} offset {offset}"), &want, &gpu);
        judged(&format!("{test} offset {offset}, CPU twin"), &want, &cpu);
        if kernel.method == "robust" {
            // Exact on the line it walks: asserted. Against the ray itself only recorded
            // (above): a ray entering the box is walked from its entry point rounded to
            // float32, up to an ulp off the ray's line, so a ray crossing a triangle that
            // close to an edge can come out late, leaked or wrong (a finding, not a bound).
            assert_robust_bracket(&scene, &o, &d, &tris, &gpu);
        }
        if kernel.method == "robust" {
            // Exact signs on both sides: the same walk, ray for ray.
            assert_eq!(differ, 0, "{test}");
            assert_eq!(cpu.tet, gpu.tet, "{test}: end tets");
            assert_eq!(cpu.steps, gpu.steps, "{test}: steps");
        } else {
            float_kernel_parity(&test, differ, n);
        }
    }
}

/// Drivers that evaluate WGSL's float32 arithmetic as written: Mesa's llvmpipe (lavapipe)
/// lowers every fused multiply-add back to a multiply and an add (`lower_ffma32` in gallivm's
/// NIR options) and emits LLVM IR without the `contract` flag (tests/test_gpu.py says more).
const NO_FMA_DRIVERS: &[&str] = &["llvmpipe"];

/// The float32 kernels against their CPU twin. Each kernel does the twin's float32 operations
/// in the twin's order; a driver can differ only by contracting `a*b + c` into an FMA or by
/// flushing subnormals. On a driver in [`NO_FMA_DRIVERS`] the first cannot happen and the
/// second needs a product below ~1e-31, which these rays do not produce: the bound is 0.
/// Elsewhere a sign within an ulp of zero may flip: the differing rays are printed (and the
/// referee judges the GPU's answers above), with no bound from a run.
pub(super) fn float_kernel_parity(test: &str, differ: usize, n: usize) {
    let name = crate::gpu::gpu()
        .map(|g| g.adapter.name.clone())
        .unwrap_or_default();
    let exact = NO_FMA_DRIVERS
        .iter()
        .any(|d| name.to_lowercase().contains(d));
    if exact {
        assert_eq!(
            differ, 0,
            "{test}: {differ} of {n} rays differ from the twin on {name}"
        );
    } else {
        eprintln!("{test}: {differ} of {n} rays differ from the CPU twin on {name} (may fuse)");
    }
}

/// Every column of two casts (the CPU's and the GPU's, or two GPU casts), bit for bit (NaNs
/// compared by their bits too); a difference is reported by its count and first ray, not by
/// dumping the columns.
pub(super) fn assert_same_answers(test: &str, cpu: &Out, gpu: &Out) {
    fn same<T: PartialEq + std::fmt::Debug>(test: &str, what: &str, a: &[T], b: &[T]) {
        assert_eq!(a.len(), b.len(), "{test}: {what}");
        let differ: Vec<usize> = (0..a.len()).filter(|&i| a[i] != b[i]).collect();
        if let Some(&i) = differ.first() {
            panic!(
                "{test}: {what} differs on {} of {} rays, first ray {i}: CPU {:?}, GPU {:?}",
                differ.len(),
                a.len(),
                a[i],
                b[i]
            );
        }
    }
    let bits = |x: &[f32]| x.iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
    same(test, "status", &cpu.status, &gpu.status);
    same(test, "triangle", &cpu.tri, &gpu.tri);
    same(test, "t", &bits(&cpu.t), &bits(&gpu.t));
    same(test, "u", &bits(&cpu.u), &bits(&gpu.u));
    same(test, "v", &bits(&cpu.v), &bits(&gpu.v));
    same(test, "point", &bits(&cpu.point), &bits(&gpu.point));
    same(test, "tet", &cpu.tet, &gpu.tet);
    same(test, "steps", &cpu.steps, &gpu.steps);
}

/// The GPU's default cast of rays `o`, `d` against the CPU exact cast: every column bit for
/// bit, and the referee's verdict on every ray. Returns the GPU cast's timings.
fn assert_gpu_is_cpu_exact(
    name: &str,
    scene: &Scene,
    tris: &[[[f64; 3]; 3]],
    o: &[f32],
    d: &[f32],
    batching: Batching,
) -> crate::gpu::GpuTimings {
    assert_gpu_is_cpu_exact_within(name, scene, tris, (o, d, f64::INFINITY), batching)
}

/// [`assert_gpu_is_cpu_exact`] with every ray's range [0, tmax]; the referee judges the rays
/// of an infinite range (a finite one is the CPU exact cast's to clip, compared column by
/// column).
fn assert_gpu_is_cpu_exact_within(
    name: &str,
    scene: &Scene,
    tris: &[[[f64; 3]; 3]],
    (o, d, tmax): (&[f32], &[f32], f64),
    batching: Batching,
) -> crate::gpu::GpuTimings {
    assert_gpu_is_cpu_exact_ranges(name, scene, tris, (o, d, &[0.0], &[tmax]), batching)
}

/// [`assert_gpu_is_cpu_exact`] with the ranges `[tmin, tmax]` (one for every ray, or one per
/// ray); the referee judges every ray over its range where the CPU takes that range (no NaN
/// bound, tmax ≥ max(tmin, 0)); the others are compared with the CPU exact cast column by
/// column only.
fn assert_gpu_is_cpu_exact_ranges(
    name: &str,
    scene: &Scene,
    tris: &[[[f64; 3]; 3]],
    (o, d, tmin, tmax): (&[f32], &[f32], &[f64], &[f64]),
    batching: Batching,
) -> crate::gpu::GpuTimings {
    let opts = CastOptions {
        threads: None,
        max_steps: Some(scene.mesh.len() as u32 + 1),
        ..Default::default()
    };
    let ranges = (tmin, tmax);
    let cpu = run_ranges(o, d, ranges, |r, out| scene.cast(r, out, &opts));
    let mut timings = None;
    let gpu = run_ranges(o, d, ranges, |r, out| {
        let device = DeviceScene::default();
        timings = Some(device.cast_with(scene, &KERNELS[0], r, out, &opts, batching)?);
        Ok(())
    });
    let t = timings.expect("the GPU cast ran");
    eprintln!(
        "{name}: {} rays, {} walked on the GPU (shared origin: {}, own origins: {}), {} \
         handed back before a face, {} hits finished on the GPU",
        o.len() / 3,
        t.walked,
        t.shared_origin,
        t.own_origins,
        t.deferred,
        t.finished
    );
    assert_same_answers(name, &cpu, &gpu);
    let n = o.len() / 3;
    let at = |b: &[f64], i: usize| b[if b.len() == 1 { 0 } else { i }];
    // (NaN.max(0.0) is 0: a NaN tmin is checked before it is raised.)
    let range = |i: usize| (at(tmin, i).max(0.0), at(tmax, i));
    let judged_rays: Vec<usize> = (0..n)
        .filter(|&i| !at(tmin, i).is_nan() && matches!(range(i), (lo, hi) if hi >= lo))
        .collect();
    let p = |x: &[f32], i: usize| [0, 1, 2].map(|a| f64::from(x[3 * i + a]));
    let want: Vec<_> = judged_rays
        .iter()
        .map(|&i| {
            let (lo, hi) = range(i);
            crate::referee::first_hit(p(o, i), p(d, i), lo, hi, tris)
        })
        .collect();
    let c = judged(name, &want, &gpu.rows(&judged_rays));
    assert_eq!(c.bad(), 0, "{name}: {c:?}");
    t
}

/// Rays the float32 filter cannot decide: along the grid's lines from outside the box and
/// from inside it, and in the face plane x = 0 through its vertices (exact zeros everywhere).
pub(super) fn degenerate_rays(n: usize) -> (Vec<f32>, Vec<f32>) {
    let (mut o, mut d) = (Vec::new(), Vec::new());
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            o.extend([x, 0.0, -0.5]);
            d.extend([0.0, 0.0, 1.0]);
            o.extend([0.0, y, 0.25]);
            d.extend([0.0, 1.0, 0.5]);
            o.extend([0.0, x, y]);
            d.extend([0.0, 0.5 - x, 0.5 - y]);
        }
    }
    (o, d)
}

/// The exact kernel, the GPU's default: the CPU exact walk's answers (the default CPU cast's),
/// bit for bit in every column, and the referee's, on random rays near and far from the
/// origin, on rays through every mesh vertex, along grid lines and in face planes (touches and
/// in-plane lines, which the kernel hands back), and with directions scaled from 1e-30 to
/// 1e30.
#[test]
fn gpu_exact_is_the_cpu_exact_walk() {
    let test = "gpu exact";
    if !device_or_skip(test) {
        return;
    }
    let kernel = &KERNELS[0];
    assert_eq!((kernel.method, kernel.layout.name), ("exact", "tet20"));
    let mut handed_back = 0;
    // The last scene's points are float64 numbers: the device's float32 copies are off by up
    // to half an ulp, which the kernel's slack must cover (`LayoutBuffers::points_slack`).
    for (offset, seed, f32_points) in [
        (0.0, 41u64, true),
        (10.0, 43, true),
        (1000.0, 45, true),
        (10.0, 47, false),
    ] {
        let (scene, tris) = grid_scene_with(8, 0.05, offset, seed, f32_points);
        let mut rng = Rng::xorshift(seed + 1);
        let (mut o, mut d0) = rays(20_000, offset, seed + 2);
        // From every mesh vertex: the origin is on a vertex (and, for some, on a triangle).
        for p in &scene.points_f32 {
            o.extend(p);
            d0.extend([0, 1, 2].map(|_| (rng.f() - 0.5) as f32));
        }
        let (go, gd) = degenerate_rays(8);
        let off = offset as f32;
        o.extend(go.iter().map(|x| x + off));
        d0.extend(gd);
        // Aimed at a vertex and at the midpoint of an edge of every tet, from random origins:
        // these rays pass through the point or within a rounding of it, where float32 signs go
        // wrong. Points inside the box only: a ray grazing the box at a triangle's vertex is a
        // known miss of the CPU exact walk (query/tests/grazing.rs), which the GPU repeats.
        let [lo, hi] = scene.mesh.bounds;
        let inside = |p: &[f64; 3]| (0..3).all(|a| lo[a] < p[a] && p[a] < hi[a]);
        for (k, tet) in scene.mesh.tets.iter().enumerate() {
            let p = scene.mesh.points[tet[k % 4] as usize];
            let q = scene.mesh.points[tet[(k + 1) % 4] as usize];
            let mid = [0, 1, 2].map(|a| 0.5 * (p[a] + q[a]));
            for target in [p, mid].into_iter().filter(inside) {
                let from = [0, 1, 2].map(|_| (offset + rng.f() * 2.0 - 0.5) as f32);
                o.extend(from);
                d0.extend([0, 1, 2].map(|a| (target[a] - from[a] as f64) as f32));
            }
        }
        for scale in [1e-30f32, 1.0, 1e30] {
            let d: Vec<f32> = d0.iter().map(|x| x * scale).collect();
            // Begun by the host (the resumed kernel), and where it can, by the device (the
            // own-origin kernel: gpu_own_origins_is_the_cpu_exact_walk).
            for begin_on_device in [false, true] {
                let name = format!(
                    "{test} offset {offset} f32 points {f32_points} |d| x {scale:e} begun on \
                     the device {begin_on_device}"
                );
                let batching = Batching {
                    begin_on_device,
                    ..Default::default()
                };
                let t = assert_gpu_is_cpu_exact(&name, &scene, &tris, &o, &d, batching);
                assert_eq!(t.own_origins, begin_on_device, "{name}");
                assert!(t.walked > o.len() / 6, "{name}: {t:?}");
                handed_back += t.deferred;
            }
        }
    }
    // The degenerate rays reach the CPU's predicates through the hand-back.
    assert!(handed_back > 0);
}

/// The shared-origin exact kernel (`gpu::origin`), which begins each walk on the device from
/// the direction alone: for origins strictly inside a tet and outside the box on one side, on
/// two, on three, every column equals the CPU exact cast's and the referee's verdict, on
/// random directions, directions at every mesh vertex and edge midpoint (where the device's
/// float32 signs cannot certify and the host walks the ray from its start), along the axes,
/// at the box's sides, and scaled from 1e-30 to 1e30. An origin on a mesh vertex takes the
/// resumed path with the same answers.
#[test]
fn gpu_shared_origin_is_the_cpu_exact_walk() {
    let test = "gpu shared origin";
    if !device_or_skip(test) {
        return;
    }
    let (mut took, mut finished) = ([0usize; 2], 0);
    for (offset, seed, f32_points) in [(0.0, 61u64, true), (10.0, 63, false), (1000.0, 65, true)] {
        let (scene, tris) = grid_scene_with(6, 0.08, offset, seed, f32_points);
        let mut rng = Rng::xorshift(seed + 1);
        let [lo, hi] = scene.mesh.bounds;
        // Targets the rays pass through exactly (up to the direction's rounding): vertices
        // and edge midpoints with at most one coordinate on the box (a ray through a box edge
        // or corner from outside may graze the box at one point: query/tests/grazing.rs).
        let on_box = |p: &[f64; 3]| (0..3).filter(|&a| p[a] == lo[a] || p[a] == hi[a]).count();
        let mut targets: Vec<[f64; 3]> = scene.mesh.points.clone();
        for tet in scene.mesh.tets.iter().step_by(3) {
            let (p, q) = (
                scene.mesh.points[tet[0] as usize],
                scene.mesh.points[tet[1] as usize],
            );
            targets.push([0, 1, 2].map(|a| 0.5 * (p[a] + q[a])));
        }
        targets.retain(|p| on_box(p) <= 1);
        let at = |x: f64, y: f64, z: f64| [x, y, z].map(|v| (offset + v) as f32);
        // A mesh vertex, as float32: on the float64-points scene it is off the vertex by a
        // rounding, strictly inside a tet, and takes the shared-origin kernel (whose signs
        // near the vertex are all too close to call: every ray is walked by the host).
        let vertex = scene.points_f32[scene.mesh.tets[7][2] as usize];
        let on_vertex = scene.mesh.points.contains(&vertex.map(f64::from));
        assert_eq!(on_vertex, f32_points);
        for (origin, shared) in [
            (at(0.437, 0.519, 0.283), true),
            (at(-0.71, 0.313, 0.472), true),
            (at(1.93, 1.71, 0.42), true),
            (at(1.6, -0.55, 2.2), true),
            (at(0.5, 0.5, -3.0), true),
            (vertex, !on_vertex),
        ] {
            let o64 = origin.map(f64::from);
            let mut d0: Vec<f32> = Vec::new();
            for _ in 0..6000 {
                d0.extend([0, 1, 2].map(|_| (rng.f() - 0.5) as f32));
            }
            for p in &targets {
                d0.extend([0, 1, 2].map(|a| (p[a] - o64[a]) as f32));
            }
            for a in 0..3 {
                for s in [-1.0f32, 1.0] {
                    let mut v = [0.0f32; 3];
                    v[a] = s;
                    d0.extend(v);
                    v[(a + 1) % 3] = 0.5 * s;
                    d0.extend(v);
                }
            }
            for corner in 0..8 {
                let c = [0, 1, 2].map(|a| if corner >> a & 1 == 1 { hi[a] } else { lo[a] });
                d0.extend([0, 1, 2].map(|a| (0.9 * c[a] + 0.1 * offset + 0.05 - o64[a]) as f32));
            }
            // Within a few float32 ulps of each box edge, on either side: directions at a
            // point of the edge, stepped by 1 to 3 ulps in one component across it. There the kernel's
            // slab test and entry faces cannot tell a miss from an entry in float32 alone.
            // (Not on the edge itself: a ray touching the box at one point of a triangle's edge
            // is the CPU's known miss, query/tests/grazing.rs.)
            for a in 0..3 {
                let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                for corner in 0..4 {
                    for k in 0..8 {
                        let mut q = [0.0; 3];
                        q[a] = lo[a] + (hi[a] - lo[a]) * (k as f64 + 0.37) / 8.0;
                        q[b] = if corner & 1 != 0 { hi[b] } else { lo[b] };
                        q[c] = if corner & 2 != 0 { hi[c] } else { lo[c] };
                        let d = [0, 1, 2].map(|x| (q[x] - o64[x]) as f32);
                        // Rounded, the direction itself passes within half an ulp of the edge,
                        // unless it is exact across it (then it meets the edge).
                        if [b, c].iter().any(|&x| d[x] as f64 != q[x] - o64[x]) {
                            d0.extend(d);
                        }
                        for m in [b, c] {
                            for steps in [-3i32, -2, -1, 1, 2, 3] {
                                let mut v = d;
                                for _ in 0..steps.abs() {
                                    v[m] = if steps > 0 {
                                        v[m].next_up()
                                    } else {
                                        v[m].next_down()
                                    };
                                }
                                d0.extend(v);
                            }
                        }
                    }
                }
            }
            // Grazing a box edge within half an ulp: t_near(a) = t_far(b) solved for d_b in
            // float64, rounded: the slab comparison's float32 products decide nothing here.
            let o32 = origin.map(f64::from);
            for a in 0..3 {
                for b in (0..3).filter(|&b| b != a) {
                    for _ in 0..150 {
                        let mut v = [0, 1, 2].map(|_| rng.f() * 2.0 - 1.0);
                        let (near, far) = (
                            if v[a] > 0.0 { lo[a] } else { hi[a] } - o32[a],
                            if v[b] > 0.0 { hi[b] } else { lo[b] } - o32[b],
                        );
                        v[b] = far * v[a] / near;
                        d0.extend(v.map(|x| x as f32));
                    }
                }
            }
            let n = d0.len() / 3;
            let o: Vec<f32> = (0..n).flat_map(|_| origin).collect();
            for scale in [1e-30f32, 1.0, 1e30] {
                let d: Vec<f32> = d0.iter().map(|x| x * scale).collect();
                let name = format!("{test} offset {offset} origin {origin:?} |d| x {scale:e}");
                let t = assert_gpu_is_cpu_exact(&name, &scene, &tris, &o, &d, Batching::default());
                assert_eq!(t.shared_origin, shared, "{name}");
                took[shared as usize] += 1;
                finished += t.finished;
            }
        }
    }
    assert!(took[0] > 0 && took[1] > 0, "{took:?}");
    // The kernel finished hits (gpu::finish), each one of the columns compared above.
    assert!(finished > 0, "no hit was finished on the device");
    eprintln!("{test}: {finished} hits finished on the device");
}

/// The own-origin exact kernel (`gpu::origin::own_origins`), which locates each ray's origin
/// on the device (or, outside the box, finds its entry there): every column equals the CPU
/// exact cast's and the referee's verdict, for origins at random in and around the box, on
/// mesh vertices, edge midpoints and face centroids (rounded to float32: on or within a
/// rounding of the faces, where no orientation certifies), on the box's faces and an ulp or
/// two either side of them; rays aimed at vertices and random, directions scaled from 1e-30
/// to 1e30; with an infinite tmax and a finite one (then the host skips the rays from outside
/// the box that end before it, as the CPU does).
#[test]
fn gpu_own_origins_is_the_cpu_exact_walk() {
    let test = "gpu own origins";
    if !device_or_skip(test) {
        return;
    }
    let (mut begun, mut finished, mut rays_cast) = (0usize, 0usize, 0usize);
    for (offset, seed, f32_points) in [(0.0, 81u64, true), (10.0, 83, false), (1000.0, 85, true)] {
        let (scene, tris) = grid_scene_with(6, 0.08, offset, seed, f32_points);
        let mut rng = Rng::xorshift(seed + 1);
        let [lo, hi] = scene.mesh.bounds;
        let pts = &scene.mesh.points;
        let mut origins: Vec<[f64; 3]> = Vec::new();
        for _ in 0..6000 {
            origins.push([0, 1, 2].map(|_| offset + rng.f() * 1.6 - 0.3));
        }
        origins.extend(pts.iter().step_by(2));
        for tet in scene.mesh.tets.iter().step_by(5) {
            let [a, b, c] = [0, 1, 2].map(|k| pts[tet[k] as usize]);
            origins.push([0, 1, 2].map(|x| 0.5 * (a[x] + b[x])));
            origins.push([0, 1, 2].map(|x| (a[x] + b[x] + c[x]) / 3.0));
        }
        // On each face of the box and one and two float32 ulps either side of it.
        for a in 0..3 {
            for plane in [lo[a], hi[a]] {
                for _ in 0..40 {
                    let mut p = [0, 1, 2].map(|x| lo[x] + rng.f() * (hi[x] - lo[x]));
                    let at = plane as f32;
                    for v in [at.next_down().next_down(), at.next_down(), at, at.next_up()] {
                        p[a] = v as f64;
                        origins.push(p);
                    }
                }
            }
        }
        let inner: Vec<[f64; 3]> = (pts.iter().copied())
            .filter(|p| (0..3).all(|a| lo[a] < p[a] && p[a] < hi[a]))
            .collect();
        let (mut o, mut d0): (Vec<f32>, Vec<f32>) = (Vec::new(), Vec::new());
        for (k, p) in origins.iter().enumerate() {
            let from = p.map(|x| x as f32);
            o.extend(from);
            if k % 2 == 0 {
                d0.extend([0, 1, 2].map(|_| (rng.f() - 0.5) as f32));
            } else {
                // Vertices strictly inside the box: a ray grazing the box at a triangle's
                // vertex is a known miss of the CPU exact walk (query/tests/grazing.rs).
                let target = inner[(rng.u64() % inner.len() as u64) as usize];
                d0.extend([0, 1, 2].map(|x| (target[x] - from[x] as f64) as f32));
            }
        }
        let n = o.len() / 3;
        for (scale, tmax) in [(1e-30f32, f64::INFINITY), (1.0, f64::INFINITY), (1e30, 0.7)] {
            let d: Vec<f32> = d0.iter().map(|x| x * scale).collect();
            let name = format!("{test} offset {offset} |d| x {scale:e} tmax {tmax}");
            let rays = (&o[..], &d[..], tmax);
            let t = assert_gpu_is_cpu_exact_within(&name, &scene, &tris, rays, Batching::default());
            assert!(t.own_origins && !t.shared_origin, "{name}: {t:?}");
            // Most rays begin on the device.
            assert!(t.deferred < n / 2, "{name}: {t:?}");
            begun += n - t.deferred;
            finished += t.finished;
            rays_cast += n;
        }
        // Random origins strictly inside the box, random directions: nearly every origin is
        // located on the device, and nearly every walk goes on there.
        let (mut o, mut d) = (Vec::new(), Vec::new());
        for _ in 0..3000 {
            o.extend([0, 1, 2].map(|a| (lo[a] + (0.01 + 0.98 * rng.f()) * (hi[a] - lo[a])) as f32));
            d.extend([0, 1, 2].map(|_| (rng.f() - 0.5) as f32));
        }
        // Along mesh edges, exactly: from o = 2p - q toward q - p through vertices p and q
        // (where both are float32 numbers), so the walk meets vertices exactly (where its
        // exact steps decide on a perturbed ray), from origins located away from their cell's
        // seed (then named in the device walk's own vertex order, not `mesh.tets`').
        for tet in &scene.mesh.tets {
            for (i, j) in [(0, 1), (2, 3), (1, 3)] {
                let (p, q) = (pts[tet[i] as usize], pts[tet[j] as usize]);
                let from = [0, 1, 2].map(|a| 2.0 * p[a] - q[a]);
                let dir = [0, 1, 2].map(|a| q[a] - p[a]);
                let f32_exact = |v: &[f64; 3]| v.iter().all(|&x| x as f32 as f64 == x);
                let inside = (0..3).all(|a| lo[a] < from[a] && from[a] < hi[a]);
                if inside && f32_exact(&from) && f32_exact(&dir) && o.len() < 3 * 6000 {
                    o.extend(from.map(|x| x as f32));
                    d.extend(dir.map(|x| x as f32));
                }
            }
        }
        let n = o.len() / 3;
        let name = format!("{test} offset {offset} from inside");
        let t = assert_gpu_is_cpu_exact(&name, &scene, &tris, &o, &d, Batching::default());
        // The rays along edges are handed back where they meet a vertex; the others begin
        // and walk on the device.
        assert!(
            t.own_origins && t.deferred <= n - 3000 + 3000 / 50,
            "{name}: {t:?}"
        );
    }
    eprintln!(
        "{test}: {begun} of {rays_cast} rays begun on the device, {finished} hits finished there"
    );
    assert!(finished > 0, "no hit was finished on the device");
}

/// A batch the shared-origin kernel must not take: rays with their own origins, a non-finite
/// origin. Every range, one or one per ray, finite or not, after the origin or one the CPU
/// refuses, is taken, from inside the box and from outside (the host applies each ray's range:
/// `gpu_per_ray_ranges_begin_on_the_device`).
#[test]
fn gpu_shared_origin_is_taken_only_where_it_holds() {
    if !device_or_skip("gpu shared origin batches") {
        return;
    }
    let (scene, _) = grid_scene(4, 0.1, 0.0, 71);
    let query = scene.closest();
    let take = |o: &[f32], d: &[f32], tmin: f64, tmax: f64| {
        let rays = Rays {
            origins: o,
            directions: d,
            tmin: &[tmin],
            tmax: &[tmax],
            leaving: None,
        };
        crate::gpu::origin::shared_origin(&scene, &rays, &query, 0.0, None).is_some()
    };
    let inside = [0.431f32, 0.377, 0.619, 0.431, 0.377, 0.619];
    let outside = [-0.5f32, 0.377, 0.619, -0.5, 0.377, 0.619];
    let d = [1.0f32, 0.1, 0.2, 0.3, 1.0, -0.4];
    assert!(take(&inside, &d, 0.0, f64::INFINITY));
    assert!(take(&inside, &d, -1.0, 2.0));
    assert!(take(&inside, &d, 0.5, f64::INFINITY));
    assert!(take(&inside, &d, 3.0, 2.0));
    assert!(take(&inside, &d, f64::NAN, 2.0));
    assert!(take(&outside, &d, 0.0, f64::INFINITY));
    assert!(take(&outside, &d, 0.0, 5.0));
    assert!(take(&outside, &d, 0.5, 5.0));
    // Per-ray ranges.
    let ranged = |o: &[f32], tmin: &[f64], tmax: &[f64]| {
        let rays = Rays {
            origins: o,
            directions: &d,
            tmin,
            tmax,
            leaving: None,
        };
        crate::gpu::origin::shared_origin(&scene, &rays, &query, 0.0, None).is_some()
    };
    let inf = f64::INFINITY;
    assert!(ranged(&inside, &[0.0, -2.0], &[inf, 0.5]));
    assert!(ranged(&inside, &[0.0], &[0.0, 0.5]));
    assert!(ranged(&inside, &[0.0, 0.5], &[inf, inf]));
    assert!(ranged(&outside, &[0.0, 0.0], &[inf, inf]));
    assert!(ranged(&outside, &[0.0], &[inf, 5.0]));
    let mut apart = inside;
    apart[3] = 0.432;
    assert!(!take(&apart, &d, 0.0, f64::INFINITY));
    assert!(!take(&[f32::NAN, 0.0, 0.0], &d[..3], 0.0, f64::INFINITY));

    // Rays with their own origins: the own-origin kernel, beginning origins inside and outside
    // the box, whatever the ranges; not rays from hits, a scene whose faces split its
    // triangles, nor coordinates beyond 2^32.
    use crate::gpu::origin::own_origins;
    let own = |scene: &Scene, tmin: &[f64], tmax: &[f64]| {
        let rays = Rays {
            origins: &apart,
            directions: &d,
            tmin,
            tmax,
            leaving: None,
        };
        own_origins(scene, &rays, 0.0).is_some()
    };
    let inf = f64::INFINITY;
    assert!(own(&scene, &[0.0], &[inf]));
    assert!(own(&scene, &[-1.0], &[2.0]));
    assert!(own(&scene, &[0.5], &[inf]));
    // Per-ray ranges.
    assert!(own(&scene, &[0.0, 0.0], &[inf, inf]));
    assert!(own(&scene, &[0.0, -1.0], &[inf, 3.0]));
    assert!(own(&scene, &[f64::NEG_INFINITY], &[inf, 0.0]));
    assert!(own(&scene, &[0.0, 1e-300], &[inf, inf]));
    assert!(own(&scene, &[0.0], &[inf, -1e-300]));
    assert!(own(&scene, &[0.0], &[inf, f64::NAN]));
    assert!(own(&scene, &[f64::NAN, 0.0], &[inf]));
    let (mut split, _) = grid_scene(4, 0.1, 0.0, 71);
    split.incidence.split = true;
    assert!(!own(&split, &[0.0], &[inf]));
    let (far, _) = grid_scene_with(2, 0.1, 5e9, 73, false);
    assert!(!own(&far, &[0.0], &[inf]));
    let leaving = crate::scene::buffers::LeavingRays {
        triangle: &[-1, -1],
        tet: &[-1, -1],
        triangles: &[],
    };
    let rays = Rays {
        origins: &apart,
        directions: &d,
        tmin: &[0.0],
        tmax: &[inf],
        leaving: Some(leaving),
    };
    assert!(own_origins(&scene, &rays, 0.0).is_none());
}

/// Per-ray ranges begin on the device: rays with their own origins (the own-origin kernel)
/// and rays from one origin inside or outside the box (the shared-origin kernel), with ranges
/// [0, t], [-1, t] and [-∞, t] mixed ray by ray (t = ∞ for every third ray, one t = 0, the
/// others short of the box's far side or of the box itself), answer as the CPU exact cast
/// does with the same ranges, every column bit for bit, and right by the referee over each
/// range. So they do with a tmax on a hit's float32 t, a float32 either side of it or a
/// quarter of the gap either side; with a tmin there (ranges starting after their origins),
/// or random, some above tmax; with a NaN bound; and with one range [0.25, ∞] for a batch
/// from one origin.
#[test]
fn gpu_per_ray_ranges_begin_on_the_device() {
    let test = "gpu per-ray ranges";
    if !device_or_skip(test) {
        return;
    }
    let (scene, tris) = grid_scene(6, 0.1, 0.0, 91);
    let mut rng = Rng::xorshift(93);
    let (o, d) = rays(6_000, 0.0, 95);
    let (o, d) = (&o[..3 * 6_000], &d[..3 * 6_000]);
    let n = o.len() / 3;
    let mut tmax = mixed_tmax(n, &mut rng);
    tmax[7] = 0.0;
    let tmin: Vec<f64> = (0..n)
        .map(|i| match i % 5 {
            0 => -1.0,
            1 => f64::NEG_INFINITY,
            _ => 0.0,
        })
        .collect();
    let infinite = vec![f64::INFINITY; n];
    // Own origins, one origin inside the box, one outside it; with every tmax infinite the
    // device also finishes hits.
    let inside: Vec<f32> = [0.431f32, 0.377, 0.619].repeat(n);
    let outside: Vec<f32> = [-0.5f32, 0.377, 0.619].repeat(n);
    for (what, origins) in [("own", o), ("inside", &inside), ("outside", &outside)] {
        for (bounds, tmax) in [("mixed", &tmax), ("∞", &infinite)] {
            let name = format!("{test}: {what} origins, tmax {bounds}");
            let rays = (origins, d, &tmin[..], &tmax[..]);
            let t = assert_gpu_is_cpu_exact_ranges(&name, &scene, &tris, rays, Batching::default());
            assert_eq!(t.own_origins, what == "own", "{name}: {t:?}");
            assert_eq!(t.shared_origin, what != "own", "{name}: {t:?}");
            assert!(t.deferred < n / 10, "{name}: {t:?}");
            assert!(t.finished > 0 || what == "outside", "{name}: {t:?}");
        }
    }
    // tmax on the hits' own t (float32), a float32 either side and a quarter of the gap either
    // side: the host decides the finished hits within an ulp of tmax by walking them again.
    let opts = CastOptions::default();
    let whole = run_ranges(o, d, (&tmin, &infinite), |r, out| scene.cast(r, out, &opts));
    let at_hits: Vec<f64> = (0..n)
        .map(|i| {
            let t = whole.t[i];
            let (below, at, above) = (t.next_down() as f64, t as f64, t.next_up() as f64);
            match (whole.status[i] == HIT, i % 5) {
                (false, _) => f64::INFINITY,
                (true, 0) => at,
                (true, 1) => above,
                (true, 2) => below,
                // A quarter of the gap either side, where the exact t may lie on either side.
                (true, 3) => at - (at - below) / 4.0,
                (true, _) => at + (above - at) / 4.0,
            }
        })
        .collect();
    let name = format!("{test}: tmax at the hits");
    let rays = (o, d, &tmin[..], &at_hits[..]);
    let t = assert_gpu_is_cpu_exact_ranges(&name, &scene, &tris, rays, Batching::default());
    assert!(
        t.own_origins && t.finished > 0 && t.deferred > 0,
        "{name}: {t:?}"
    );
    // Ranges that start after their origins: each walk begins on the device, from its origin
    // as the CPU's does, and the host compares each finished hit's t with tmin. tmin on the
    // hits' own t, a float32 either side and a quarter of the gap either side (the host walks
    // those within an ulp again), a random tmin with the mixed tmax (some above it: the CPU
    // answers MISS without walking), and a NaN bound at either end.
    let mut late: Vec<f64> = at_hits
        .iter()
        .zip(&tmax)
        .map(|(&t, &hi)| match t {
            f64::INFINITY => rng.f() * hi.min(2.0),
            t => t,
        })
        .collect();
    late[11] = f64::NAN;
    let mut upto = tmax.clone();
    upto[12] = f64::NAN;
    for (what, origins) in [("own", o), ("inside", &inside), ("outside", &outside)] {
        for (bounds, hi) in [("mixed", &upto), ("∞", &infinite)] {
            let name = format!("{test}: ranges after their {what} origins, tmax {bounds}");
            let rays = (origins, d, &late[..], &hi[..]);
            let t = assert_gpu_is_cpu_exact_ranges(&name, &scene, &tris, rays, Batching::default());
            assert_eq!(t.own_origins, what == "own", "{name}: {t:?}");
            assert_eq!(t.shared_origin, what != "own", "{name}: {t:?}");
            assert!(t.finished > 0 || what == "outside", "{name}: {t:?}");
        }
    }
    // One range for the batch, after the origin: a camera's near plane.
    let name = format!("{test}: one range after one origin");
    let rays = (&inside[..], d, &[0.25][..], &[f64::INFINITY][..]);
    let t = assert_gpu_is_cpu_exact_ranges(&name, &scene, &tris, rays, Batching::default());
    assert!(t.shared_origin && t.finished > 0, "{name}: {t:?}");
}

#[test]
fn gpu_aman2022_tet20_matches_cpu_twin() {
    check_kernel(kernel("aman2022", "tet20"));
}

#[test]
fn gpu_maria2017_tet80_matches_cpu_twin() {
    check_kernel(kernel("maria2017", "tet80"));
}

#[test]
fn gpu_robust_tet20_matches_cpu_robust() {
    check_kernel(kernel("robust", "tet20"));
}

/// Batching and the 2D dispatch: small batches and a grid of at most 7 workgroups a row give
/// the results of one dispatch, bit for bit; so do rays and results copied through staging
/// and readback buffers (a discrete GPU's path) and mapped where the kernel reads and writes
/// them (lavapipe's).
#[test]
fn gpu_batches_do_not_change_results() {
    if !device_or_skip("gpu batches") {
        return;
    }
    let (scene, tris) = grid_scene(6, 0.1, 0.0, 9);
    let (o, d) = rays(20_000, 0.0, 11);
    let opts = CastOptions {
        threads: None,
        max_steps: Some(1 << 20),
        ..Default::default()
    };
    // One dispatch (mapped on lavapipe), and batches of 1000 rays copied through staging and
    // readback buffers on a 2D grid of at most 7 workgroups a row.
    let one = |o: &[f32], d: &[f32]| {
        run(&scene, o, d, |r, out| {
            cast_gpu(&scene, None, None, r, out, &opts).map(|_| ())
        })
    };
    let batched = |o: &[f32], d: &[f32]| {
        let mut timings = None;
        let out = run(&scene, o, d, |r, out| {
            let batching = Batching {
                max_batch: 1000,
                max_groups: Some(7),
                copy_results: true,
                ..Default::default()
            };
            let device = DeviceScene::default();
            timings = Some(device.cast_with(&scene, &KERNELS[0], r, out, &opts, batching)?);
            Ok(())
        });
        (out, timings.expect("the GPU cast ran"))
    };
    let (many, t) = batched(&o, &d);
    assert_eq!(t.batches, t.walked.div_ceil(1000), "{t:?}");
    assert!(t.batches > 10, "{t:?}");
    // Rays with their own origins: the own-origin kernel, its origins after each batch's
    // directions in the buffer.
    assert!(!t.shared_origin && t.own_origins, "{t:?}");
    assert_same_answers("gpu batches", &one(&o, &d), &many);
    judged("gpu batches", &verdicts32(&o, &d, &tris), &many);

    // The camera rays alone share one origin: the shared-origin kernel. Its results come
    // back batch by batch too; a chunk of 4096 rays is cut by the batches' ends (1000 rays)
    // and answered when the batch that completes it comes.
    let (oc, dc) = (&o[3 * 20_000..], &d[3 * 20_000..]);
    let (many, t) = batched(oc, dc);
    assert!(t.shared_origin, "{t:?}");
    assert_eq!(t.batches, (oc.len() / 3).div_ceil(1000), "{t:?}");
    assert_same_answers("gpu batches, one origin", &one(oc, dc), &many);
    judged("gpu batches, one origin", &verdicts32(oc, dc, &tris), &many);
}

/// Rays the float32 filter cannot decide (along grid lines and in the box's face planes,
/// where orientations are exactly zero) are deferred, walked by the CPU robust walk, and end
/// exactly where the CPU robust cast ends.
#[test]
fn gpu_robust_defers_degenerate_rays() {
    if !device_or_skip("gpu robust deferral") {
        return;
    }
    let (scene, tris) = grid_scene(8, 0.05, 0.0, 21);
    let (o, d) = degenerate_rays(8);
    let opts = CastOptions {
        threads: None,
        max_steps: Some(scene.mesh.len() as u32 + 1),
        ..Default::default()
    };
    let cpu = run(&scene, &o, &d, |r, out| {
        scene.cast_named("robust", "tet20", r, out, &opts)
    });
    let mut timings = None;
    let gpu = run(&scene, &o, &d, |r, out| {
        timings = Some(cast_gpu(
            &scene,
            Some("robust"),
            Some("tet20"),
            r,
            out,
            &opts,
        )?);
        Ok(())
    });
    let t = timings.unwrap();
    eprintln!(
        "gpu robust deferral: {} rays walked, {} deferred",
        t.walked, t.deferred
    );
    assert!(t.deferred > 0, "{t:?}");
    assert_eq!(cpu.status, gpu.status);
    assert_eq!(cpu.tri, gpu.tri);
    assert_eq!(cpu.tet, gpu.tet);
    assert_eq!(cpu.steps, gpu.steps);
    assert_eq!(cpu.t, gpu.t);
    assert!(!gpu.status.contains(&FAILED));
    let want = verdicts32(&o, &d, &tris);
    judged("gpu robust deferral", &want, &gpu);
    assert_robust_bracket(&scene, &o, &d, &tris, &gpu);
}

/// The host prepares each kernel's rays as the CPU cast does: directions of any length
/// (scaled exactly by `real::unit_scale` before `prepare`), and robust starts on mesh vertices
/// and box faces settled in the perturbed start point's tet (`robust::settle_start`). Robust
/// ends exactly where the CPU robust cast ends, ray for ray; the float32 kernels keep parity.
#[test]
fn gpu_prepares_rays_as_the_cpu_cast() {
    if !device_or_skip("gpu ray preparation") {
        return;
    }
    let (scene, tris) = grid_scene(8, 0.05, 0.0, 31);
    let mut rng = Rng::xorshift(32);
    let (mut o, mut d0) = (Vec::new(), Vec::new());
    // From every mesh vertex (float32, as the walk reads them): the start is on a vertex.
    for p in &scene.points_f32 {
        o.extend(p);
        d0.extend([0, 1, 2].map(|_| (rng.f() - 0.5) as f32));
    }
    // And a camera from outside, and random rays from around the box.
    let (ro, rd) = rays(5_000, 0.0, 33);
    o.extend(ro);
    d0.extend(rd);
    let opts = CastOptions {
        threads: None,
        max_steps: Some(scene.mesh.len() as u32 + 1),
        ..Default::default()
    };
    for scale in [1e-30f32, 1e-3, 1.0, 1e30] {
        let d: Vec<f32> = d0.iter().map(|x| x * scale).collect();
        let want = verdicts32(&o, &d, &tris);
        for kernel in &KERNELS {
            let cpu = run(&scene, &o, &d, |r, out| {
                scene.cast_named(kernel.method, kernel.layout.name, r, out, &opts)
            });
            let mut timings = None;
            let gpu = run(&scene, &o, &d, |r, out| {
                timings = Some(cast_gpu(
                    &scene,
                    Some(kernel.method),
                    Some(kernel.layout.name),
                    r,
                    out,
                    &opts,
                )?);
                Ok(())
            });
            let n = cpu.status.len();
            let differ = (0..n)
                .filter(|&i| cpu.tri[i] != gpu.tri[i] || cpu.status[i] != gpu.status[i])
                .count();
            let hits = gpu.status.iter().filter(|&&s| s == HIT).count();
            let test = format!("{} |d| x {scale:e}", kernel.name());
            eprintln!(
                "gpu ray preparation {test}: {n} rays, {hits} hits, {differ} differ, {:?} \
                 deferred",
                timings.map(|t| t.deferred)
            );
            assert!(hits > n / 10, "{test}: {hits} hits");
            judged(&format!("gpu ray preparation {test}"), &want, &gpu);
            if kernel.resumes {
                assert_same_answers(&test, &cpu, &gpu);
            } else if kernel.method == "robust" {
                assert_robust_bracket(&scene, &o, &d, &tris, &gpu);
                assert_eq!(cpu.status, gpu.status, "{test}");
                assert_eq!(cpu.tri, gpu.tri, "{test}");
                assert_eq!(cpu.tet, gpu.tet, "{test}");
                assert_eq!(cpu.steps, gpu.steps, "{test}");
                assert_eq!(cpu.t, gpu.t, "{test}");
                // Starts on the box's sides (the box-face vertices) perturb inward
                // (`robust::start_delta`): no ray fails, on the CPU or the GPU.
                let failed = gpu.status.iter().filter(|&&s| s == FAILED).count();
                assert_eq!(failed, 0, "{test}: {failed} failed");
            } else {
                float_kernel_parity(&test, differ, n);
            }
        }
    }
}

/// The kernel's time is the GPU's own where the device writes timestamps: positive, and
/// within the host's wall time from each submission to its end (the pass runs inside it).
#[test]
fn gpu_kernel_time_comes_from_timestamps() {
    if !device_or_skip("gpu timestamps") {
        return;
    }
    let g = crate::gpu::gpu().unwrap();
    let (scene, _) = grid_scene(6, 0.1, 0.0, 51);
    let (o, d) = rays(5_000, 0.0, 53);
    let opts = CastOptions::default();
    let mut t = None;
    run(&scene, &o, &d, |r, out| {
        t = Some(cast_gpu(&scene, None, None, r, out, &opts)?);
        Ok(())
    });
    let t = t.unwrap();
    eprintln!(
        "gpu timestamps on {}: {} (kernel {:.3e} s, wall {:.3e} s)",
        g.adapter.name, g.timestamps, t.kernel, t.kernel_wall
    );
    assert!(t.kernel > 0.0 && t.kernel_wall > 0.0, "{t:?}");
    if g.timestamps {
        assert!(t.kernel <= t.kernel_wall, "{t:?}");
    } else {
        assert_eq!(t.kernel, t.kernel_wall, "{t:?}");
    }
}

/// A scene's ray buffers are made by its first GPU cast and kept: a cast of as many rays or
/// fewer reuses them, a larger batch remakes them larger, and the answers are a fresh
/// device copy's.
#[test]
fn gpu_ray_buffers_are_kept_between_casts() {
    if !device_or_skip("gpu ray buffers") {
        return;
    }
    let (scene, _) = grid_scene(6, 0.1, 0.0, 61);
    let (o, d) = rays(4_000, 0.0, 63);
    let opts = CastOptions::default();
    let device = DeviceScene::default();
    let rays_bytes = || {
        device
            .bytes()
            .into_iter()
            .find(|(k, _)| *k == "rays")
            .map_or(0, |(_, b)| b)
    };
    let cast = |o: &[f32], d: &[f32]| {
        run(&scene, o, d, |r, out| {
            device.cast(&scene, None, None, r, out, &opts).map(|_| ())
        })
    };
    let (small_o, small_d) = (&o[..3000], &d[..3000]);
    let first = cast(small_o, small_d);
    let kept = rays_bytes();
    assert!(kept > 0);
    let again = cast(small_o, small_d);
    assert_eq!(
        rays_bytes(),
        kept,
        "a cast of as many rays reuses the buffers"
    );
    cast(&o, &d);
    let grown = rays_bytes();
    assert!(grown > kept, "{grown} <= {kept}");
    let after = cast(small_o, small_d);
    assert_eq!(
        rays_bytes(),
        grown,
        "a smaller cast reuses the larger buffers"
    );
    let fresh = run(&scene, small_o, small_d, |r, out| {
        cast_gpu(&scene, None, None, r, out, &opts).map(|_| ())
    });
    for out in [&again, &after, &fresh] {
        assert_same_answers("gpu ray buffers", &first, out);
    }
}

/// Rays whose line touches the domain box without entering it (at a point of an edge, at a
/// corner, along a side's plane) on a grid whose interior faces reach the box: the GPU cast
/// answers them as the CPU exact cast (which hands them to the exact BVH: `locate::GRAZES`),
/// and the referee finds every one right. Coordinates are multiples of 1/8 and directions
/// small integers, exact in float32.
#[test]
fn gpu_grazing_rays_are_the_cpu_exact_walk() {
    let test = "gpu grazing";
    if !device_or_skip(test) {
        return;
    }
    let (scene, tris) = grid_scene(4, 1.0, 0.0, 51);
    let (mut o, mut d) = (Vec::new(), Vec::new());
    let mut push = |p: [f32; 3], dir: [f32; 3], t: f32| {
        o.extend((0..3).map(|a| p[a] - t * dir[a]));
        d.extend(dir);
    };
    for k in 0..=8 {
        let x = k as f32 / 8.0;
        for z in [0.0, 1.0] {
            // In the sides z = 0 and z = 1, from beyond x = 0.
            push([0.0, x, z], [1.0, 0.0, 0.0], 1.0);
            push([0.0, x, z], [2.0, 1.0, 0.0], 1.0);
        }
        // Touching the edge y = 0, z = 0 at one point (outside the box on both sides).
        for a in [-2.0, 0.0, 1.0] {
            push([x, 0.0, 0.0], [a, 1.0, -1.0], 2.0);
        }
    }
    for (c, dir) in [
        ([1.0, 1.0, 1.0], [1.0, -1.0, -1.0]),
        ([0.0, 0.0, 0.0], [-1.0, 1.0, 1.0]),
        ([1.0, 0.0, 1.0], [1.0, 1.0, -2.0]),
    ] {
        push(c, dir, 3.0);
    }
    assert_gpu_is_cpu_exact(test, &scene, &tris, &o, &d, Batching::default());
}
