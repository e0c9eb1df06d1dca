//! Every point of each ray on the GPU (`DeviceScene::intersections`, which `intersections` and
//! `count_intersections` take): the exact kernels with the all-hits query. Every
//! list is the CPU exact walk's (`Scene::intersections_in`), bit for bit, on random rays, rays
//! from every mesh vertex and rays along grid lines and in face planes (touches at edges and
//! vertices, in-plane lines: the points the CPU's predicates decide).

use super::parity::degenerate_rays;
use super::*;
use crate::layout::LayoutKind;
use crate::query::Listed;
use crate::status::HIT;

/// One point's t, u, v, point (as bits) and triangle.
type MeetBits = (u64, u64, u64, [u64; 3], u32);

/// A list's numbers as bits, so that equal means bit for bit (and NaN equals NaN).
fn bits(l: &Listed) -> (u8, Vec<MeetBits>) {
    let meets = l.meets.iter().map(|m| {
        (
            m.t.to_bits(),
            m.u.to_bits(),
            m.v.to_bits(),
            m.point.map(f64::to_bits),
            m.triangle,
        )
    });
    (l.status, meets.collect())
}

/// Random rays, rays from every mesh vertex and degenerate rays with their own origins (the
/// own-origin kernel begins most; the host those from vertices), a camera's rays from one
/// origin (the shared-origin kernel), and the first set again with ranges that start after
/// their origins; short, long and unbounded tmax ray by ray.
#[test]
fn gpu_intersections_are_the_cpu_exact_walk() {
    let test = "gpu intersections";
    if !device_or_skip(test) {
        return;
    }
    for (offset, seed) in [(0.0, 71u64), (10.0, 73)] {
        let (scene, _) = grid_scene(8, 0.05, offset, seed);
        let (mut o, mut d) = rays(10_000, offset, seed + 1);
        let camera = 10_000..o.len() / 3;
        let mut rng = Rng::xorshift(seed + 2);
        for p in &scene.points_f32 {
            o.extend(p);
            d.extend([0, 1, 2].map(|_| (rng.f() - 0.5) as f32));
        }
        let (go, gd) = degenerate_rays(8);
        o.extend(go.iter().map(|x| x + offset as f32));
        d.extend(gd);
        let n = o.len() / 3;
        // Bounds that end some lists early: short, long and unbounded.
        let tmax = mixed_tmax(n, &mut rng);
        let late: Vec<f64> = (0..n)
            .map(|i| match i % 3 {
                0 => 0.0,
                _ => rng.f() * tmax[i].min(1.5),
            })
            .collect();
        let sets = [
            ("own origins", 0..n, false),
            ("one origin", camera, false),
            ("own origins, ranges after them", 0..n, true),
        ];
        for (what, rows, after) in sets {
            let name = format!("{test} (offset {offset}), {what}");
            let pick = |x: &[f32]| x[3 * rows.start..3 * rows.end].to_vec();
            let (o, d) = (pick(&o), pick(&d));
            let tmin = match after {
                true => &late[rows.clone()],
                false => &[0.0][..],
            };
            let rays = Rays {
                origins: &o,
                directions: &d,
                tmin,
                tmax: &tmax[rows.clone()],
                leaving: None,
            };
            let opts = CastOptions {
                max_steps: Some(scene.mesh.len() as u32 + 1),
                ..Default::default()
            };
            let n = rows.len();
            let mut cpu = vec![Listed::default(); n];
            scene
                .intersections_in(LayoutKind::DEFAULT, &rays, &mut cpu, &opts)
                .unwrap();
            let mut gpu = vec![Listed::default(); n];
            let t = DeviceScene::default()
                .intersections(&scene, &rays, &mut gpu, &opts)
                .unwrap();
            let differ: Vec<usize> = (0..n).filter(|&i| bits(&cpu[i]) != bits(&gpu[i])).collect();
            assert!(
                differ.is_empty(),
                "{name}: {} of {n} lists differ from the CPU's, first {:?}",
                differ.len(),
                &differ[..differ.len().min(8)]
            );
            let points: usize = gpu.iter().map(|l| l.meets.len()).sum();
            let several = gpu.iter().filter(|l| l.meets.len() > 1).count();
            eprintln!(
                "{name}: {n} rays, {points} points, {several} rays with several, {} walked on \
                 the GPU, {} handed back before a face",
                t.walked, t.deferred
            );
            // The rays have teeth: many cross the surface more than once, some not at all.
            assert!(
                several > n / 40,
                "{name}: {several} of {n} rays cross twice or more"
            );
            assert!(gpu.iter().filter(|l| l.status == HIT).count() < n);
            // The batch began on the device, which finished no hit (the walk goes on).
            let one = what == "one origin";
            assert!(
                t.shared_origin == one && t.own_origins != one,
                "{name}: {t:?}"
            );
            assert!(t.walked == n && t.finished == 0, "{name}: {t:?}");
        }
    }
}
