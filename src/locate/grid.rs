//! A coarse uniform grid of seed tets plus a stochastic visibility walk with exact predicates.
//!
//! The grid brings the walk within a few tets of the point; the walk (Devillers et al.'s
//! "remembering stochastic walk": start each test at a random face) terminates with
//! probability one even in non-Delaunay meshes. A hint tet (the previous point's) replaces the
//! grid seed when the point falls in the hint's cell: coherent points start next to their
//! answer, scattered ones (random ray origins) from their own cell's seed, never from a tet
//! across the domain. A step guard falls back to a scan so that location always ends.

use crate::geom::predicates::orient;
use crate::mesh::build::OUTWARD_FACES;
use crate::mesh::{TetMesh, BOUNDARY};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Located {
    Inside(u32),
    Outside,
}

#[derive(Clone)]
pub struct GridLocator {
    lo: [f64; 3],
    inv_cell: [f64; 3],
    dims: [usize; 3],
    seeds: Vec<u32>,
}

/// Walks before the guard falls back to a linear scan.
const WALK_GUARD: u32 = 1 << 16;

impl GridLocator {
    pub fn build(mesh: &TetMesh) -> GridLocator {
        let [lo, hi] = mesh.bounds;
        let ext = [0, 1, 2].map(|a| (hi[a] - lo[a]).max(f64::MIN_POSITIVE));
        // About two tets per cell, at most 128 cells per axis, cells roughly cubic.
        let target = (mesh.len() as f64 / 2.0).max(1.0);
        let vol = ext[0] * ext[1] * ext[2];
        let side = (vol / target).cbrt();
        let dims = ext.map(|e| ((e / side).ceil() as usize).clamp(1, 128));
        let inv_cell = [0, 1, 2].map(|a| dims[a] as f64 / ext[a]);
        let n = dims[0] * dims[1] * dims[2];
        let mut seeds = vec![BOUNDARY; n];
        let mut g = GridLocator {
            lo,
            inv_cell,
            dims,
            seeds: Vec::new(),
        };
        for (t, tet) in mesh.tets.iter().enumerate() {
            let mut c = [0.0; 3];
            for &v in tet {
                for (ca, p) in c.iter_mut().zip(mesh.points[v as usize]) {
                    *ca += 0.25 * p;
                }
            }
            seeds[g.cell(c)] = t as u32;
        }
        // Fill empty cells from filled neighbours, layer by layer.
        let mut frontier: Vec<usize> = (0..n).filter(|&i| seeds[i] != BOUNDARY).collect();
        while !frontier.is_empty() {
            let mut next = Vec::new();
            for &i in &frontier {
                let (x, y, z) = (
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    i / (dims[0] * dims[1]),
                );
                let mut visit = |xx: usize, yy: usize, zz: usize| {
                    let j = xx + dims[0] * (yy + dims[1] * zz);
                    if seeds[j] == BOUNDARY {
                        seeds[j] = seeds[i];
                        next.push(j);
                    }
                };
                if x > 0 {
                    visit(x - 1, y, z)
                }
                if x + 1 < dims[0] {
                    visit(x + 1, y, z)
                }
                if y > 0 {
                    visit(x, y - 1, z)
                }
                if y + 1 < dims[1] {
                    visit(x, y + 1, z)
                }
                if z > 0 {
                    visit(x, y, z - 1)
                }
                if z + 1 < dims[2] {
                    visit(x, y, z + 1)
                }
            }
            frontier = next;
        }
        g.seeds = seeds;
        g
    }

    #[inline]
    fn cell(&self, p: [f64; 3]) -> usize {
        // `as usize` saturates negatives and NaN to 0 and truncates: floor without libm.
        let i = [0, 1, 2]
            .map(|a| (((p[a] - self.lo[a]) * self.inv_cell[a]) as usize).min(self.dims[a] - 1));
        i[0] + self.dims[0] * (i[1] + self.dims[1] * i[2])
    }

    pub fn bytes(&self) -> usize {
        self.seeds.len() * 4
    }

    /// The grid's lower corner, cells per unit length and cells per axis, and each cell's
    /// seed tet (x fastest, then y, then z), as the GPU's locator reads them (`gpu::origin`).
    pub fn parts(&self) -> ([f64; 3], [f64; 3], [usize; 3], &[u32]) {
        (self.lo, self.inv_cell, self.dims, &self.seeds)
    }

    /// The tet holding `p` (on its boundary counts), or Outside when p is outside the domain.
    /// `hint`: the previous point's cell and tet, used when p falls in that cell, and set to
    /// p's cell and tet when p is found.
    pub fn locate(
        &self,
        mesh: &TetMesh,
        p: [f64; 3],
        hint: &mut Option<(usize, u32)>,
        rng: &mut u32,
    ) -> Located {
        let [lo, hi] = mesh.bounds;
        if mesh.domain_is_box && (0..3).any(|a| !(p[a] >= lo[a] && p[a] <= hi[a])) {
            return Located::Outside;
        }
        let cell = self.cell(p);
        let start = match *hint {
            Some((c, t)) if c == cell => t,
            _ => self.seeds[cell],
        };
        let found = self.walk_to(mesh, p, start, rng);
        if let Located::Inside(t) = found {
            *hint = Some((cell, t));
        }
        found
    }

    /// The visibility walk from tet `t` to the tet holding p.
    fn walk_to(&self, mesh: &TetMesh, p: [f64; 3], mut t: u32, rng: &mut u32) -> Located {
        let mut prev = BOUNDARY;
        for _ in 0..WALK_GUARD {
            let v = mesh.tet_points(t);
            *rng ^= *rng << 13;
            *rng ^= *rng >> 17;
            *rng ^= *rng << 5;
            let first = (*rng % 4) as usize;
            let mut moved = false;
            for k in 0..4 {
                let i = (first + k) % 4;
                let n = mesh.neighbor(t, i);
                if n == prev && n != BOUNDARY {
                    continue; // we came from there: p is not behind that face
                }
                let f = OUTWARD_FACES[i];
                if orient(v[f[0]], v[f[1]], v[f[2]], p) > 0.0 {
                    if n == BOUNDARY {
                        return Located::Outside;
                    }
                    prev = t;
                    t = n;
                    moved = true;
                    break;
                }
            }
            if !moved {
                return Located::Inside(t);
            }
        }
        self.scan(mesh, p)
    }

    fn scan(&self, mesh: &TetMesh, p: [f64; 3]) -> Located {
        (0..mesh.len() as u32)
            .find(|&t| {
                let v = mesh.tet_points(t);
                OUTWARD_FACES
                    .iter()
                    .all(|f| orient(v[f[0]], v[f[1]], v[f[2]], p) <= 0.0)
            })
            .map_or(Located::Outside, Located::Inside)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{grid_scene, Rng};

    /// The grid as the GPU reads it (`parts`): its lower corner is the domain's, its cells
    /// span the domain (cells per unit length times the extent is the cell count), one seed per
    /// cell, and a cell holding a tet's centroid (found from the exported numbers) is seeded
    /// with a tet whose centroid lies in that cell too.
    #[test]
    fn exported_grid_seeds_each_cell_with_a_tet_of_that_cell() {
        let g = grid_scene(&mut Rng::xorshift(5), 6, 0.3, 0.2);
        let mesh = &g.scene.mesh;
        let grid = GridLocator::build(mesh);
        let (lo, inv_cell, dims, seeds) = grid.parts();
        let [mlo, mhi] = mesh.bounds;
        assert_eq!(lo, mlo);
        assert!(dims.iter().all(|&d| (2..=128).contains(&d)), "{dims:?}");
        assert_eq!(seeds.len(), dims[0] * dims[1] * dims[2]);
        // What the scene's memory report counts for the grid: a u32 seed per cell.
        assert_eq!(grid.bytes(), dims[0] * dims[1] * dims[2] * 4);
        for a in 0..3 {
            let spanned = inv_cell[a] * (mhi[a] - mlo[a]);
            let cells = dims[a] as f64;
            assert!(
                (spanned - cells).abs() <= 4.0 * f64::EPSILON * cells,
                "axis {a}"
            );
        }
        let cell_of = |t: usize| {
            let mut c = [0.0; 3];
            for &v in &mesh.tets[t] {
                for (ca, p) in c.iter_mut().zip(mesh.points[v as usize]) {
                    *ca += 0.25 * p;
                }
            }
            let i = [0, 1, 2].map(|a| (((c[a] - lo[a]) * inv_cell[a]) as usize).min(dims[a] - 1));
            i[0] + dims[0] * (i[1] + dims[1] * i[2])
        };
        assert!(seeds.iter().all(|&s| (s as usize) < mesh.len()));
        for t in 0..mesh.len() {
            let c = cell_of(t);
            assert_eq!(cell_of(seeds[c] as usize), c, "tet {t}'s cell {c}");
        }
    }

    /// The last resort after the walk's guard, `scan`: a tet's centroid lies in that tet
    /// alone, a mesh vertex only in tets it is a corner of (found on their faces, where
    /// `orient` is 0), and a point beyond the domain box in none.
    #[test]
    fn the_scan_finds_the_tet_holding_a_point() {
        let g = grid_scene(&mut Rng::xorshift(9), 3, 0.3, 0.2);
        let mesh = &g.scene.mesh;
        let grid = GridLocator::build(mesh);
        for t in 0..mesh.len() {
            let v = mesh.tet_points(t as u32);
            let c = [0, 1, 2].map(|a| (v[0][a] + v[1][a] + v[2][a] + v[3][a]) / 4.0);
            assert_eq!(
                grid.scan(mesh, c),
                Located::Inside(t as u32),
                "centroid of tet {t}"
            );
        }
        for (k, &p) in mesh.points.iter().enumerate() {
            let Located::Inside(t) = grid.scan(mesh, p) else {
                panic!("vertex {k} not found");
            };
            assert!(
                mesh.tets[t as usize].contains(&(k as u32)),
                "vertex {k} in tet {t}"
            );
        }
        let [lo, hi] = mesh.bounds;
        for a in 0..3 {
            let mut p = [0, 1, 2].map(|b| (lo[b] + hi[b]) / 2.0);
            p[a] = hi[a] + (hi[a] - lo[a]);
            assert_eq!(grid.scan(mesh, p), Located::Outside, "beyond axis {a}");
        }
    }
}
