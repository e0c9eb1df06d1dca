//! 3D Hilbert-curve order (Skilling 2004, "Programming the Hilbert curve"), as Aman et al. 2022
//! use it: points by position, tets by centroid, so that tets a ray visits one after another
//! sit close in memory.

use rayon::prelude::*;

const BITS: u32 = 21;

/// The Hilbert index of a point with 21-bit integer coordinates.
pub fn hilbert_key(mut x: [u32; 3]) -> u64 {
    // Inverse undo of excess work (Skilling's AxestoTranspose).
    let m = 1u32 << (BITS - 1);
    let mut q = m;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    for i in 1..3 {
        x[i] ^= x[i - 1];
    }
    let mut t = 0;
    let mut q = m;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for v in x.iter_mut() {
        *v ^= t;
    }
    // Interleave the transposed bits, most significant first.
    let mut key = 0u64;
    for b in (0..BITS).rev() {
        for v in x {
            key = (key << 1) | ((v >> b) & 1) as u64;
        }
    }
    key
}

fn quantize(p: [f64; 3], lo: [f64; 3], scale: [f64; 3]) -> [u32; 3] {
    let max = ((1u32 << BITS) - 1) as f64;
    [0, 1, 2].map(|a| ((p[a] - lo[a]) * scale[a]).clamp(0.0, max) as u32)
}

/// The permutation that sorts items (by their representative point) along the curve, within
/// groups when `groups` gives each item's group: `order[new] = old`.
pub fn order(points: &[[f64; 3]], bounds: [[f64; 3]; 2], groups: Option<&[u32]>) -> Vec<u32> {
    let [lo, hi] = bounds;
    let max = ((1u32 << BITS) - 1) as f64;
    let scale = [0, 1, 2].map(|a| {
        if hi[a] > lo[a] {
            max / (hi[a] - lo[a])
        } else {
            0.0
        }
    });
    let mut keyed: Vec<(u32, u64, u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, &p)| {
            (
                groups.map_or(0, |g| g[i]),
                hilbert_key(quantize(p, lo, scale)),
                i as u32,
            )
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, _, i)| i).collect()
}

/// Points, tets and faces renumbered, the tet permutation (`tet_order[new] = old`) and the
/// point permutation (`point_order[new] = old`).
pub type Reordered = (
    Vec<[f64; 3]>,
    Vec<[u32; 4]>,
    Vec<[u32; 3]>,
    Vec<u32>,
    Vec<u32>,
);

/// Reorders points, then tets by centroid (grouped by `regions` first when given: a ray stays
/// in one region between two scene triangles, so its tets then sit together), rewriting every
/// index; returns (points, tets, faces) and the permutations of tets and points
/// (`order[new] = old`).
pub fn reorder(
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    faces: &[[u32; 3]],
    bounds: [[f64; 3]; 2],
    regions: Option<&[u32]>,
) -> Reordered {
    let point_order = order(points, bounds, None);
    let mut new_id = vec![0u32; points.len()];
    for (new, &old) in point_order.iter().enumerate() {
        new_id[old as usize] = new as u32;
    }
    let new_points: Vec<[f64; 3]> = point_order.iter().map(|&o| points[o as usize]).collect();
    let centroids: Vec<[f64; 3]> = tets
        .par_iter()
        .map(|t| {
            let mut c = [0.0; 3];
            for &v in t {
                for a in 0..3 {
                    c[a] += 0.25 * points[v as usize][a];
                }
            }
            c
        })
        .collect();
    let tet_order = order(&centroids, bounds, regions);
    let new_tets = tet_order
        .iter()
        .map(|&o| tets[o as usize].map(|v| new_id[v as usize]))
        .collect();
    let new_faces = faces
        .iter()
        .map(|f| f.map(|v| new_id[v as usize]))
        .collect();
    (new_points, new_tets, new_faces, tet_order, point_order)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_a_bijection_and_steps_are_unit() {
        // On a 4×4×4 grid (top bits only), consecutive keys are face neighbours.
        let shift = BITS - 2;
        let mut cells: Vec<(u64, [u32; 3])> = Vec::new();
        for x in 0..4u32 {
            for y in 0..4u32 {
                for z in 0..4u32 {
                    let k = hilbert_key([x << shift, y << shift, z << shift]);
                    cells.push((k >> (3 * shift), [x, y, z]));
                }
            }
        }
        cells.sort();
        for (i, c) in cells.iter().enumerate() {
            assert_eq!(c.0, i as u64, "keys must be 0..64 without gaps");
        }
        for w in cells.windows(2) {
            let d: u32 = (0..3).map(|a| w[0].1[a].abs_diff(w[1].1[a])).sum();
            assert_eq!(d, 1, "{:?} -> {:?} is not a unit step", w[0].1, w[1].1);
        }
    }

    #[test]
    fn reorder_keeps_the_mesh() {
        let pts = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ];
        let tets = vec![[0, 1, 2, 3], [1, 2, 3, 4]];
        let (p, t, f, order, point_order) = reorder(
            &pts,
            &tets,
            &[[1, 2, 3]],
            [[0.0; 3], [1.0; 3]],
            Some(&[1, 0]),
        );
        assert_eq!(order, vec![1, 0], "region 0 first");
        for (new, &old) in order.iter().enumerate() {
            let a: Vec<_> = t[new].iter().map(|&v| p[v as usize]).collect();
            let b: Vec<_> = tets[old as usize]
                .iter()
                .map(|&v| pts[v as usize])
                .collect();
            assert_eq!(a, b);
        }
        let fp: Vec<_> = f[0].iter().map(|&v| p[v as usize]).collect();
        assert_eq!(fp, vec![pts[1], pts[2], pts[3]]);
        for (new, &old) in point_order.iter().enumerate() {
            assert_eq!(p[new], pts[old as usize]);
        }
    }
}
