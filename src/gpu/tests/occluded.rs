//! Occlusion on the GPU (`DeviceScene::occluded`): the exact kernel's resumed walk with the
//! any-hit query. Every status is the CPU exact walk's (`Scene::occluded`), and the referee's:
//! HIT exactly when a triangle lies on the ray in [0, tmax].

use super::*;
use crate::layout::LayoutKind;
use crate::status::{HIT, MISS};
use crate::traverse::Method;

#[test]
fn gpu_occluded_is_the_cpu_exact_walk() {
    let test = "gpu occluded";
    if !device_or_skip(test) {
        return;
    }
    for (offset, seed) in [(0.0, 61u64), (10.0, 63)] {
        let (scene, tris) = grid_scene(8, 0.05, offset, seed);
        // Random rays and a camera (one origin: still the resumed kernel, as any-hit takes it).
        let (o, d) = rays(20_000, offset, seed + 1);
        let n = o.len() / 3;
        // Shadow-ray bounds: short, long and unbounded, so the first face decides both ways.
        let mut rng = Rng::xorshift(seed + 2);
        let tmax = mixed_tmax(n, &mut rng);
        let rays = Rays {
            origins: &o,
            directions: &d,
            tmin: &[0.0],
            tmax: &tmax,
            leaving: None,
        };
        let opts = CastOptions {
            threads: None,
            max_steps: Some(scene.mesh.len() as u32 + 1),
            ..Default::default()
        };
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
            "{test}: {differ} of {n} statuses differ from the CPU's"
        );
        // The referee, on the rays as given (each judged in [0, tmax]).
        let wide = |x: &[f32]| x.iter().map(|&v| v as f64).collect::<Vec<f64>>();
        let (ow, dw) = (wide(&o), wide(&d));
        let wrong: Vec<usize> = (0..n)
            .filter(|&i| {
                let p = |v: &[f64]| [v[3 * i], v[3 * i + 1], v[3 * i + 2]];
                let hit = crate::referee::first_hit(p(&ow), p(&dw), 0.0, tmax[i], &tris).is_some();
                gpu[i] != if hit { HIT } else { MISS }
            })
            .collect();
        let hits = gpu.iter().filter(|&&s| s == HIT).count();
        eprintln!(
            "{test} (offset {offset}): {n} rays, {hits} occluded, {} walked on the GPU, {} \
             handed back before a face",
            t.walked, t.deferred
        );
        assert!(
            wrong.is_empty(),
            "{test}: the referee disagrees on rays {wrong:?}"
        );
        assert!(t.walked > n / 4 && !t.shared_origin, "{t:?}");
        // Both answers occur often enough to judge: the rays have teeth.
        assert!(
            hits > n / 20 && hits < n - n / 20,
            "{test}: {hits} of {n} occluded"
        );
    }
}
