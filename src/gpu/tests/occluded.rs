//! Occlusion on the GPU (`DeviceScene::occluded`): the exact kernels with the any-hit query.
//! Every status is the CPU exact walk's (`Scene::occluded`), and the referee's: HIT exactly
//! when a triangle lies on the ray in [max(tmin, 0), tmax].

use super::*;
use crate::layout::LayoutKind;
use crate::status::{HIT, MISS};
use crate::traverse::Method;

/// Random rays with their own origins (the own-origin kernel), a camera's rays from one
/// origin outside the box (the shared-origin kernel), and the random rays again with ranges
/// that start after their origins; short, long and unbounded tmax ray by ray, so the first
/// face decides both ways. Each set is cast on the CPU exact walk and on the GPU, on a grid
/// scene at the origin and one moved 10 away (float32 points rounded).
#[test]
fn gpu_occluded_is_the_cpu_exact_walk() {
    let test = "gpu occluded";
    if !device_or_skip(test) {
        return;
    }
    for (offset, seed) in [(0.0, 61u64), (10.0, 63)] {
        let (scene, tris) = grid_scene(8, 0.05, offset, seed);
        let (o, d) = rays(20_000, offset, seed + 1);
        let n = o.len() / 3;
        let mut rng = Rng::xorshift(seed + 2);
        let tmax = mixed_tmax(n, &mut rng);
        let late: Vec<f64> = (0..n)
            .map(|i| match i % 3 {
                0 => 0.0,
                _ => rng.f() * tmax[i].min(1.5),
            })
            .collect();
        let (own, camera) = (0..20_000, 20_000..n);
        let sets = [
            ("own origins", own.clone(), false),
            ("one origin", camera, false),
            ("own origins, ranges after them", own, true),
        ];
        for (what, rows, after) in sets {
            let name = format!("{test} (offset {offset}), {what}");
            let pick = |x: &[f32]| x[3 * rows.start..3 * rows.end].to_vec();
            let (o, d) = (pick(&o), pick(&d));
            let (tmin, tmax) = match after {
                true => (&late[rows.clone()], &tmax[rows.clone()]),
                false => (&[0.0][..], &tmax[rows.clone()]),
            };
            let rays = Rays {
                origins: &o,
                directions: &d,
                tmin,
                tmax,
                leaving: None,
            };
            let opts = CastOptions {
                threads: None,
                max_steps: Some(scene.mesh.len() as u32 + 1),
                ..Default::default()
            };
            let n = rows.len();
            let mut cpu = vec![0u8; n];
            scene
                .occluded(Method::Exact, LayoutKind::DEFAULT, &rays, &mut cpu, &opts)
                .unwrap();
            let mut gpu = vec![0u8; n];
            let t = DeviceScene::default()
                .occluded(&scene, &rays, &mut gpu, &opts)
                .unwrap();
            let differ = (0..n).filter(|&i| cpu[i] != gpu[i]).count();
            assert_eq!(
                differ, 0,
                "{name}: {differ} of {n} statuses differ from the CPU's"
            );
            // The referee, on the rays as given (each judged over its own range).
            let wide = |x: &[f32]| x.iter().map(|&v| v as f64).collect::<Vec<f64>>();
            let (ow, dw) = (wide(&o), wide(&d));
            let at = |b: &[f64], i: usize| b[if b.len() == 1 { 0 } else { i }];
            let wrong: Vec<usize> = (0..n)
                .filter(|&i| {
                    let p = |v: &[f64]| [v[3 * i], v[3 * i + 1], v[3 * i + 2]];
                    let (lo, hi) = (at(tmin, i), at(tmax, i));
                    let hit = crate::referee::first_hit(p(&ow), p(&dw), lo, hi, &tris).is_some();
                    gpu[i] != if hit { HIT } else { MISS }
                })
                .collect();
            let hits = gpu.iter().filter(|&&s| s == HIT).count();
            eprintln!(
                "{name}: {n} rays, {hits} occluded, {} walked on the GPU, {} finished there, \
                 {} handed back",
                t.walked, t.finished, t.deferred
            );
            assert!(
                wrong.is_empty(),
                "{name}: the referee disagrees on rays {wrong:?}"
            );
            // The batch began on the device, which answered some rays itself.
            let one = what == "one origin";
            assert!(
                t.shared_origin == one && t.own_origins != one,
                "{name}: {t:?}"
            );
            assert!(t.walked == n && t.finished > 0, "{name}: {t:?}");
            // Both answers occur often enough to judge: the rays have teeth.
            assert!(
                hits > n / 20 && hits < n - n / 20,
                "{name}: {hits} of {n} occluded"
            );
        }
    }
    // Rays from hits (`start=hits`) keep the resumed kernel: `tests/test_secondary.py`.
}
