//! Where a ray from outside enters the domain box: a 2D grid of boundary faces on each of the
//! six sides. Cheaper than a 3D walk for camera rays, which all start outside and enter at
//! different points.

use crate::mesh::build::OUTWARD_FACES;
use crate::mesh::{TetMesh, BOUNDARY};

#[derive(Clone)]
struct Side {
    /// The two in-plane axes.
    axes: [usize; 2],
    lo: [f64; 2],
    inv_cell: [f64; 2],
    dims: [usize; 2],
    /// CSR: faces of cell c are entries[start[c]..start[c+1]].
    start: Vec<u32>,
    /// (tet, its local face on the side, the face's corners in the side's 2D coordinates)
    entries: Vec<(u32, u8, [[f64; 2]; 3])>,
}

/// Whether the 2D triangle holds q (its boundary included), exactly.
#[inline]
fn contains(tri: &[[f64; 2]; 3], q: [f64; 2]) -> bool {
    let p = |v: [f64; 2]| robust::Coord { x: v[0], y: v[1] };
    let (a, b, c, x) = (p(tri[0]), p(tri[1]), p(tri[2]), p(q));
    let o = [
        robust::orient2d(a, b, x),
        robust::orient2d(b, c, x),
        robust::orient2d(c, a, x),
    ];
    // Either winding: a side's faces are seen from outside or inside depending on the side.
    o.iter().all(|&x| x >= 0.0) || o.iter().all(|&x| x <= 0.0)
}

/// One side's grid, exported for the device ([`BoundaryLocator::side_grid`]).
pub struct SideGrid<'a> {
    pub lo: [f64; 2],
    pub inv_cell: [f64; 2],
    pub dims: [usize; 2],
    pub start: &'a [u32],
    pub faces: Vec<(u32, u8)>,
}

#[derive(Clone)]
pub struct BoundaryLocator {
    /// Index 2*axis + (0 for the low side, 1 for the high side).
    sides: Vec<Side>,
}

/// A boundary face: its tet, the face's index in it, and its corners (in 3D, then projected
/// onto the box side's two axes).
type SideFace = (u32, u8, [[f64; 3]; 3]);
type ProjectedFace = (u32, u8, [[f64; 2]; 3]);

impl BoundaryLocator {
    pub fn build(mesh: &TetMesh) -> BoundaryLocator {
        let [lo, hi] = mesh.bounds;
        let mut per_side: Vec<Vec<SideFace>> = vec![Vec::new(); 6];
        for (t, tet) in mesh.tets.iter().enumerate() {
            for (i, f) in OUTWARD_FACES.iter().enumerate() {
                if mesh.links[t][i] != BOUNDARY {
                    continue;
                }
                let p = f.map(|k| mesh.points[tet[k] as usize]);
                for a in 0..3 {
                    for (s, bound) in [lo[a], hi[a]].into_iter().enumerate() {
                        if p.iter().all(|q| q[a] == bound) {
                            per_side[2 * a + s].push((t as u32, i as u8, p));
                        }
                    }
                }
            }
        }
        let sides = per_side
            .into_iter()
            .enumerate()
            .map(|(k, faces)| {
                let a = k / 2;
                let axes = [(a + 1) % 3, (a + 2) % 3];
                let slo = axes.map(|x| lo[x]);
                let ext = axes.map(|x| (hi[x] - lo[x]).max(f64::MIN_POSITIVE));
                let n = ((faces.len() as f64).sqrt().ceil() as usize).clamp(1, 256);
                let dims = [n, n];
                let inv_cell = [dims[0] as f64 / ext[0], dims[1] as f64 / ext[1]];
                let cell = |x: f64, d: usize| -> usize {
                    (((x - slo[d]) * inv_cell[d]) as usize).min(dims[d] - 1)
                };
                let mut buckets: Vec<Vec<ProjectedFace>> = vec![Vec::new(); n * n];
                for (t, i, p) in faces {
                    let q = p.map(|v| [v[axes[0]], v[axes[1]]]);
                    let (mut x0, mut x1, mut y0, mut y1) = (usize::MAX, 0, usize::MAX, 0);
                    for v in &q {
                        let (cx, cy) = (cell(v[0], 0), cell(v[1], 1));
                        x0 = x0.min(cx);
                        x1 = x1.max(cx);
                        y0 = y0.min(cy);
                        y1 = y1.max(cy);
                    }
                    for y in y0..=y1 {
                        for x in x0..=x1 {
                            buckets[x + dims[0] * y].push((t, i, q));
                        }
                    }
                }
                let mut start = Vec::with_capacity(n * n + 1);
                let mut entries = Vec::new();
                start.push(0);
                for b in buckets {
                    entries.extend(b);
                    start.push(entries.len() as u32);
                }
                Side {
                    axes,
                    lo: slo,
                    inv_cell,
                    dims,
                    start,
                    entries,
                }
            })
            .collect();
        BoundaryLocator { sides }
    }

    pub fn bytes(&self) -> usize {
        self.sides
            .iter()
            .map(|s| {
                s.start.len() * 4
                    + s.entries.len() * std::mem::size_of::<(u32, u8, [[f64; 2]; 3])>()
            })
            .sum()
    }

    /// Every boundary face on the box's sides (tet, local face), some more than once: the
    /// exact start's last resort.
    pub fn faces(&self) -> impl Iterator<Item = (u32, usize)> + '_ {
        self.sides
            .iter()
            .flat_map(|s| s.entries.iter().map(|(t, i, _)| (*t, *i as usize)))
    }

    /// The grid of side `k` (2 × axis + high) as the GPU reads it (`gpu::origin`): the
    /// lower corner and cells per unit on the side's two axes ((axis + 1) % 3, (axis + 2) % 3),
    /// cells per axis, the CSR starts, and each entry's (tet, local face).
    pub fn side_grid(&self, k: usize) -> SideGrid<'_> {
        let s = &self.sides[k];
        SideGrid {
            lo: s.lo,
            inv_cell: s.inv_cell,
            dims: s.dims,
            start: &s.start,
            faces: s.entries.iter().map(|(t, i, _)| (*t, *i)).collect(),
        }
    }

    /// The boundary tet, and its local face, on side (`axis`, `high`) that holds point p (on
    /// that side). `hint` remembers the last face found: a camera's neighbouring rays mostly
    /// enter by it.
    pub fn locate(
        &self,
        p: [f64; 3],
        axis: usize,
        high: bool,
        hint: &mut Option<(usize, usize)>,
    ) -> Option<(u32, usize)> {
        let side = 2 * axis + high as usize;
        let s = &self.sides[side];
        let q = [p[s.axes[0]], p[s.axes[1]]];
        if let Some((hs, he)) = *hint {
            if hs == side {
                let (t, i, tri) = &s.entries[he];
                if contains(tri, q) {
                    return Some((*t, *i as usize));
                }
            }
        }
        // `as usize` truncates toward zero and saturates negatives and NaN to 0: floor for
        // the in-range values that matter, without a libm call.
        let c = [0, 1].map(|d| (((q[d] - s.lo[d]) * s.inv_cell[d]) as usize).min(s.dims[d] - 1));
        let cell = c[0] + s.dims[0] * c[1];
        for e in s.start[cell] as usize..s.start[cell + 1] as usize {
            let (t, i, tri) = &s.entries[e];
            if contains(tri, q) {
                *hint = Some((side, e));
                return Some((*t, *i as usize));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{grid_scene, Rng};

    /// Each side's grid as the GPU reads it (`side_grid`): its cells span the box's side
    /// (lower corner, cells per unit length), it lists exactly the boundary faces that lie on
    /// that side, each in the cell of its centroid (found from the exported numbers), and
    /// `bytes` counts the starts and the entries.
    #[test]
    fn side_grids_list_the_boundary_faces_of_their_cells() {
        let g = grid_scene(&mut Rng::xorshift(7), 4, 0.3, 0.2);
        let mesh = &g.scene.mesh;
        let locator = BoundaryLocator::build(mesh);
        let [lo, hi] = mesh.bounds;
        let mut bytes = 0;
        for k in 0..6 {
            let (axis, plane) = (k / 2, if k % 2 == 1 { hi[k / 2] } else { lo[k / 2] });
            let axes = [(axis + 1) % 3, (axis + 2) % 3];
            let side = locator.side_grid(k);
            assert_eq!(side.lo, axes.map(|a| lo[a]), "side {k}");
            assert_eq!(
                side.start.len(),
                side.dims[0] * side.dims[1] + 1,
                "side {k}"
            );
            assert!(
                side.dims[0] > 1 && side.dims[1] > 1,
                "side {k}: {:?}",
                side.dims
            );
            for j in 0..2 {
                // inv_cell = dims / extent, one rounding.
                let spanned = side.inv_cell[j] * (hi[axes[j]] - lo[axes[j]]);
                let cells = side.dims[j] as f64;
                assert!(
                    (spanned - cells).abs() <= 4.0 * f64::EPSILON * cells,
                    "side {k}"
                );
            }
            let mut on_side = Vec::new();
            for (t, tet) in mesh.tets.iter().enumerate() {
                for (i, f) in OUTWARD_FACES.iter().enumerate() {
                    let p = f.map(|v| mesh.points[tet[v] as usize]);
                    if mesh.links[t][i] == BOUNDARY && p.iter().all(|q| q[axis] == plane) {
                        on_side.push(((t as u32, i as u8), p));
                    }
                }
            }
            assert!(on_side.len() > 4, "side {k}: {} faces", on_side.len());
            let mut listed = side.faces.clone();
            listed.sort();
            listed.dedup();
            let mut want: Vec<(u32, u8)> = on_side.iter().map(|&(f, _)| f).collect();
            want.sort();
            assert_eq!(listed, want, "side {k}");
            for (face, p) in on_side {
                let centre = [0, 1].map(|j| (p[0][axes[j]] + p[1][axes[j]] + p[2][axes[j]]) / 3.0);
                let [cx, cy] = [0, 1].map(|j| {
                    (((centre[j] - side.lo[j]) * side.inv_cell[j]) as usize).min(side.dims[j] - 1)
                });
                let c = cx + side.dims[0] * cy;
                let cell = &side.faces[side.start[c] as usize..side.start[c + 1] as usize];
                assert!(
                    cell.contains(&face),
                    "side {k}: {face:?} not in its centre's cell"
                );
            }
            bytes += side.start.len() * 4
                + side.faces.len() * std::mem::size_of::<(u32, u8, [[f64; 2]; 3])>();
        }
        assert_eq!(locator.bytes(), bytes);
    }
}
