//! Times (or, under callgrind, counts) the default exact cast on a dumped scene, without Python:
//! what `docs/performance.md`'s per-stage table is measured with.
//!
//! ```text
//! python -m tetrace.dev.dump bunny.obj /tmp/bunny        # raw arrays + camera and random rays
//! cargo run --release --example profile_cast -- /tmp/bunny camera 5
//! valgrind --tool=callgrind target/release/examples/profile_cast /tmp/bunny camera 1
//! ```
//! Arguments: the dump folder, the ray file (`camera` or `random`), repetitions (best is
//! printed), and optionally `f64` to cast the rays as float64. Environment: `RAYS=k` casts the
//! first k rays only, `LANES=on|off` forces the lanes' choice, `PACKETS=off` turns
//! packets off, `TETRACE_SIMD=scalar` caps the SIMD level.

use std::time::Instant;
use tetrace::geom::real::Real;
use tetrace::scene::{AccelKind, CastOptions, HitBuffers, Lanes, Packets, Rays, Scene};

/// A raw little-endian array of N-tuples of 4- or 8-byte numbers, as numpy's `tofile` writes.
fn read<T: Copy + Default, const N: usize>(path: &str, parse: fn(&[u8]) -> T) -> Vec<[T; N]> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let size = std::mem::size_of::<T>();
    bytes
        .chunks_exact(size * N)
        .map(|c| {
            let mut x = [T::default(); N];
            for (k, v) in x.iter_mut().enumerate() {
                *v = parse(&c[k * size..(k + 1) * size]);
            }
            x
        })
        .collect()
}

fn f64le(b: &[u8]) -> f64 {
    f64::from_le_bytes(b.try_into().expect("8 bytes"))
}
fn f32le(b: &[u8]) -> f32 {
    f32::from_le_bytes(b.try_into().expect("4 bytes"))
}
fn u32le(b: &[u8]) -> u32 {
    u32::from_le_bytes(b.try_into().expect("4 bytes"))
}

/// The best of `repeat` casts of the rays (seconds), and the total steps and hits of the last.
fn time_cast<R: Real>(
    scene: &Scene,
    origins: &[R],
    directions: &[R],
    opts: &CastOptions,
    repeat: usize,
) -> (f64, u64, usize) {
    let rays = Rays {
        origins,
        directions,
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    let (mut best, mut steps, mut hits) = (f64::INFINITY, 0u64, 0usize);
    for _ in 0..repeat {
        let mut buf = HitBuffers::<R>::new(rays.len(), false);
        let t = Instant::now();
        // LAYOUT=name: the exact walk on that layout (default: the default layout).
        match std::env::var("LAYOUT") {
            Ok(layout) => scene.cast_named("exact", &layout, &rays, buf.out(), opts),
            Err(_) => scene.cast(&rays, buf.out(), opts),
        }
        .expect("cast");
        best = best.min(t.elapsed().as_secs_f64());
        steps = buf.steps.iter().map(|&s| s as u64).sum();
        hits = buf.status.iter().filter(|&&s| s == tetrace::HIT).count();
    }
    (best, steps, hits)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .expect("usage: profile_cast DIR [camera|random] [REPEAT] [f64]");
    let which = args.get(2).map_or("camera", |s| s.as_str());
    let repeat: usize = args.get(3).map_or(3, |s| s.parse().expect("REPEAT"));
    let points: Vec<[f64; 3]> = read(&format!("{dir}/points.f64"), f64le);
    let tets: Vec<[u32; 4]> = read(&format!("{dir}/tets.u32"), u32le);
    let faces: Vec<[u32; 3]> = read(&format!("{dir}/faces.u32"), u32le);
    let face_triangle: Vec<u32> = read::<u32, 1>(&format!("{dir}/face_triangle.u32"), u32le)
        .into_iter()
        .map(|[x]| x)
        .collect();
    let triangles: Vec<[[f64; 3]; 3]> = read::<f64, 9>(&format!("{dir}/triangles.f64"), f64le)
        .into_iter()
        .map(|t| [[t[0], t[1], t[2]], [t[3], t[4], t[5]], [t[6], t[7], t[8]]])
        .collect();
    let mut rays: Vec<[f32; 6]> = read(&format!("{dir}/{which}.f32"), f32le);
    // RAYS=k: the first k rays only (callgrind is slow).
    if let Some(k) = std::env::var("RAYS").ok().and_then(|k| k.parse().ok()) {
        rays.truncate(k);
    }
    let t0 = Instant::now();
    let scene = Scene::build(points, &tets, &faces, &face_triangle, triangles).expect("scene");
    eprintln!(
        "built in {:.2} s: {} tets",
        t0.elapsed().as_secs_f64(),
        scene.mesh.len()
    );
    let origins: Vec<f32> = rays.iter().flat_map(|r| [r[0], r[1], r[2]]).collect();
    let directions: Vec<f32> = rays.iter().flat_map(|r| [r[3], r[4], r[5]]).collect();
    let n = rays.len();
    let opts = CastOptions {
        threads: Some(1),
        max_steps: None,
        // LANES=on / off forces the lanes' choice (default: auto).
        lanes: match std::env::var("LANES").as_deref() {
            Ok("on") => Lanes::On,
            Ok("off") => Lanes::Off,
            _ => Lanes::Auto,
        },
        packets: match std::env::var("PACKETS").as_deref() {
            Ok("off") => Packets::Off,
            _ => Packets::Auto,
        },
        // The best SIMD level, capped by TETRACE_SIMD (scalar / avx2).
        simd: None,
        // ACCEL=reshetov_bvh casts on the BVH instead of the tet walk.
        accel: AccelKind::from_name(&std::env::var("ACCEL").unwrap_or("tetwalk".into()))
            .expect("ACCEL names an accelerator"),
    };
    let (best, steps, hits) = if args.get(4).map(|s| s.as_str()) == Some("f64") {
        let widen = |v: &[f32]| v.iter().map(|&x| x as f64).collect::<Vec<f64>>();
        time_cast(&scene, &widen(&origins), &widen(&directions), &opts, repeat)
    } else {
        time_cast(&scene, &origins, &directions, &opts, repeat)
    };
    println!(
        "{which}: {n} rays, {:.3} Mrays/s, {:.0} ns/ray, {:.1} steps/ray, {hits} hits",
        n as f64 / best / 1e6,
        best / n as f64 * 1e9,
        steps as f64 / n as f64
    );
}
