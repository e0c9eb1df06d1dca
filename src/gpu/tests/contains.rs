//! Containment on the GPU (`DeviceScene::contains`): every answer is the CPU's
//! (`Scene::contains`), and where a point is far enough from the surface for a float judge,
//! the parity of the winding number of two nested closed shells (geometry the code does not
//! use).

use super::*;
use crate::gpu::launch::Batching;
use crate::query::contains::tests::{jittered_shells, winding};

/// Random points first in [`points`].
const RANDOM: usize = 20_000;

/// Points in and around the unit box, on the shells' vertices, faces and edges (float32
/// roundings of them: on or within a rounding of the surface, which counts as inside), on the
/// box's faces and an ulp or two either side, and not finite.
fn points(scene: &Scene, rng: &mut Rng) -> Vec<f32> {
    let mut p: Vec<[f64; 3]> = (0..20_000)
        .map(|_| rng.p3().map(|x| 1.3 * x - 0.15))
        .collect();
    let pts = &scene.mesh.points;
    for tri in &scene.surface.triangles {
        let [a, b, c] = *tri;
        p.push(a);
        p.push([0, 1, 2].map(|x| 0.5 * (a[x] + b[x])));
        p.push([0, 1, 2].map(|x| (a[x] + b[x] + c[x]) / 3.0));
    }
    p.extend(pts.iter().step_by(7));
    let [lo, hi] = scene.mesh.bounds;
    for a in 0..3 {
        for plane in [lo[a], hi[a]] {
            for _ in 0..50 {
                let mut q = rng.p3();
                let at = plane as f32;
                for v in [at.next_down().next_down(), at.next_down(), at, at.next_up()] {
                    q[a] = v as f64;
                    p.push(q);
                }
            }
        }
    }
    let mut flat: Vec<f32> = p.iter().flatten().map(|&x| x as f32).collect();
    flat.extend([
        f32::NAN,
        0.5,
        0.5,
        0.5,
        f32::INFINITY,
        0.5,
        0.5,
        0.5,
        f32::NEG_INFINITY,
    ]);
    flat
}

#[test]
fn gpu_contains_is_the_cpu_contains() {
    let test = "gpu contains";
    if !device_or_skip(test) {
        return;
    }
    for (seed, f32_points) in [(9u64, false), (29, true)] {
        let (scene, tris) = jittered_shells(6, seed, f32_points);
        let flat = points(&scene, &mut Rng::xorshift(seed + 1));
        let n = flat.len() / 3;
        let mut cpu = vec![false; n];
        scene.contains(&flat, &mut cpu, None).unwrap();
        for batching in [
            Batching::default(),
            Batching {
                max_batch: 1000,
                max_groups: Some(3),
                copy_results: true,
                ..Default::default()
            },
        ] {
            let name = format!("{test} f32 points {f32_points} {batching:?}");
            let mut gpu = vec![false; n];
            let t = DeviceScene::default()
                .contains_with(&scene, &flat, &mut gpu, None, batching)
                .unwrap();
            eprintln!("{name}: {n} points, {} answered by the host", t.deferred);
            let differ: Vec<usize> = (0..n).filter(|&i| cpu[i] != gpu[i]).collect();
            assert!(
                differ.is_empty(),
                "{name}: {} differ, first {:?}",
                differ.len(),
                &differ[..differ.len().min(5)]
            );
            // The host answers only what the device cannot certify (the points on or near
            // the surface, the box's faces and the non-finite ones), well under a fifth.
            assert!(t.deferred > 0 && t.deferred < n / 5, "{name}: {t:?}");
            assert_eq!(t.walked, n, "{name}: {t:?}");
        }
        // The geometry's own verdict where a float judge can give one: the parity of the
        // winding number inside the box, outside it False, for the random points (those
        // made on the surface may lie on it, where the winding number says nothing).
        let mut judged = 0;
        for i in 0..RANDOM {
            let p = [0, 1, 2].map(|a| flat[3 * i + a] as f64);
            let w = winding(&tris, p);
            if (w - w.round()).abs() > 1e-6 {
                continue; // too near the surface for a float judge
            }
            let [lo, hi] = scene.mesh.bounds;
            let in_box = (0..3).all(|a| lo[a] <= p[a] && p[a] <= hi[a]);
            assert_eq!(
                cpu[i],
                in_box && (w.round() as i64) % 2 != 0,
                "{p:?}: winding {w}"
            );
            judged += 1;
        }
        assert!(judged > RANDOM * 9 / 10, "{judged} of {RANDOM} judged");
    }
}
