//! The construction target: `Scene::build` / `Scene::build_with` on random inputs and on
//! valid Kuhn grids then mutated; every case must give `Ok` or an [`Error`].

use super::scenes::{grid_input, BuildInput};
use super::walk::walk_once;
use super::{coord, Rng, ODD};
use crate::error::Error;
use std::sync::Arc;

/// A random point cloud with random tets, faces and triangles (indices mostly in range).
fn random_input(rng: &mut Rng) -> BuildInput {
    let np = rng.below(12);
    let odd = rng.pick(&[0.0, 0.0, 0.02, 0.2]);
    let points: Vec<[f64; 3]> = (0..np)
        .map(|_| [0, 1, 2].map(|_| coord(rng, odd)))
        .collect();
    let idx = |rng: &mut Rng| {
        if np == 0 || rng.chance(0.02) {
            rng.below(np + 3) as u32
        } else {
            rng.below(np) as u32
        }
    };
    let tets = (0..rng.below(10))
        .map(|_| [0; 4].map(|_| idx(rng)))
        .collect::<Vec<_>>();
    let mut faces: Vec<[u32; 3]> = (0..rng.below(6))
        .map(|_| [0; 3].map(|_| idx(rng)))
        .collect();
    if rng.chance(0.5) && !tets.is_empty() {
        let t: [u32; 4] = tets[rng.below(tets.len())];
        faces.push([t[0], t[1], t[2]]);
    }
    let nt = rng.below(5);
    let triangles: Vec<[[f64; 3]; 3]> = (0..nt)
        .map(|_| [0; 3].map(|_| [0, 1, 2].map(|_| coord(rng, odd))))
        .collect();
    let face_triangle = (0..faces.len())
        .map(|_| {
            let extra = usize::from(rng.chance(0.1));
            rng.below(nt + extra) as u32
        })
        .collect();
    BuildInput {
        points,
        tets,
        faces,
        face_triangle,
        triangles,
        hilbert: rng.chance(0.5),
    }
}

/// One mutation of a (usually valid) input.
fn mutate(rng: &mut Rng, b: &mut BuildInput) {
    let np = b.points.len();
    match rng.below(18) {
        0 if !b.tets.is_empty() => {
            // An index out of range.
            let t = rng.below(b.tets.len());
            b.tets[t][rng.below(4)] = rng.pick(&[np as u32, np as u32 + 1, u32::MAX, u32::MAX - 1]);
        }
        1 if !b.tets.is_empty() => {
            // A repeated index (a flat tet).
            let t = rng.below(b.tets.len());
            b.tets[t][1] = b.tets[t][0];
        }
        2 if !b.tets.is_empty() => {
            // Flipped orientation.
            let t = rng.below(b.tets.len());
            b.tets[t].swap(2, 3);
        }
        3 if !b.tets.is_empty() => {
            // A duplicate tet.
            let t = b.tets[rng.below(b.tets.len())];
            b.tets.push(t);
        }
        4 if !b.tets.is_empty() => {
            // A tet removed (a hole: the domain is no longer a box, or a face dangles).
            let t = rng.below(b.tets.len());
            b.tets.remove(t);
        }
        5 if np > 0 => {
            // An odd coordinate.
            let p = rng.below(np);
            b.points[p][rng.below(3)] = rng.pick(&ODD);
        }
        6 if np > 0 => {
            // A point moved (tets may invert or flatten, the box may change).
            let p = rng.below(np);
            b.points[p] = [0, 1, 2].map(|_| coord(rng, 0.1));
        }
        7 if np > 1 => {
            // Two points made equal.
            let (p, q) = (rng.below(np), rng.below(np));
            b.points[p] = b.points[q];
        }
        8 => {
            // A face that is no tet face.
            b.faces.push([0; 3].map(|_| rng.below(np.max(1)) as u32));
            b.face_triangle.push(0);
        }
        9 if !b.face_triangle.is_empty() => {
            // A triangle id out of range.
            let k = rng.below(b.face_triangle.len());
            b.face_triangle[k] = b.triangles.len() as u32 + rng.below(3) as u32;
        }
        10 if !b.faces.is_empty() => {
            // A face listed twice (with another triangle id).
            let k = rng.below(b.faces.len());
            b.faces.push(b.faces[k]);
            b.face_triangle
                .push(rng.below(b.triangles.len().max(1)) as u32);
        }
        11 => {
            // Lengths that disagree.
            if rng.chance(0.5) {
                b.face_triangle.pop();
            } else {
                b.face_triangle.push(0);
            }
        }
        12 if !b.triangles.is_empty() => {
            // An odd triangle corner.
            let k = rng.below(b.triangles.len());
            b.triangles[k][rng.below(3)][rng.below(3)] = rng.pick(&ODD);
        }
        13 => {
            // Empty inputs.
            match rng.below(4) {
                0 => b.tets.clear(),
                1 => {
                    b.faces.clear();
                    b.face_triangle.clear();
                }
                2 => b.triangles.clear(),
                _ => b.points.clear(),
            }
        }
        14 if np > 0 => {
            // Every point scaled or shifted by a huge or tiny amount.
            // 2^-1070 from its bits: `2f64.powi(-1070)` is 1/inf = 0 unless LLVM folds it.
            let s = rng.pick(&[1e-300, 1e300, 1e-160, 1e160, f64::from_bits(1 << 4)]);
            let shift = rng.chance(0.5);
            for p in &mut b.points {
                for x in p.iter_mut() {
                    *x = if shift { *x + s } else { *x * s };
                }
            }
        }
        15 if !b.tets.is_empty() => {
            // A tet's corners permuted (any orientation is accepted).
            let t = rng.below(b.tets.len());
            b.tets[t].rotate_left(1 + rng.below(3));
        }
        16 if !b.faces.is_empty() => {
            // A face's corners permuted or a corner repeated.
            let k = rng.below(b.faces.len());
            if rng.chance(0.5) {
                b.faces[k].rotate_left(1);
            } else {
                b.faces[k][2] = b.faces[k][0];
            }
        }
        _ => {
            // An extra point, used by nothing or by a new tet sticking out of the box.
            b.points.push([0, 1, 2].map(|_| coord(rng, 0.05)));
            if rng.chance(0.5) && !b.tets.is_empty() {
                let t = b.tets[rng.below(b.tets.len())];
                b.tets.push([t[0], t[1], t[2], np as u32]);
            }
        }
    }
}

/// One construction case: must return, with `Ok` or an error of the crate; a scene that builds
/// must cast. `Err(message)` when an invariant fails (a panic is caught by [`run`](super::run)).
pub fn construct_case(seed: u64) -> Result<(), String> {
    let mut rng = Rng::new(seed);
    let mut input = if rng.chance(0.3) {
        random_input(&mut rng)
    } else {
        let n = 1 + rng.below(2);
        let jitter = rng.pick(&[0.0, 0.3]);
        let frac = rng.pick(&[0.0, 0.2, 1.0]);
        let rng_inside = rng.chance(0.5);
        grid_input(&mut rng, n, jitter, frac, rng_inside)
    };
    for _ in 0..rng.below(4) {
        mutate(&mut rng, &mut input);
    }
    match input.build() {
        Err(
            Error::InvalidInput(_)
            | Error::InvalidMesh(_)
            | Error::TooLarge(_)
            | Error::InvalidOption(_)
            | Error::OutOfMemory { .. },
        ) => Ok(()),
        Err(e) => Err(format!("unexpected error from build: {e}")),
        Ok(scene) => {
            let scene = Arc::new(scene);
            let ntri = input.triangles.len();
            for _ in 0..2 {
                walk_once(&mut rng, &scene, ntri, false, false)?;
            }
            Ok(())
        }
    }
}
