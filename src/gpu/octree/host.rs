//! The octree flattened for the kernel, origins located on the host, and the kernel's CPU twin.

use super::*;
use crate::accel::portalez_octree::{
    face_of, face_to_neighbor_index, in_plane, out_faces_lookup, PortalezOctree, NODE_TAG,
};
use crate::error::{Error, Result};
use crate::status::{FAILED, HIT, INVALID, MISS};
use std::collections::HashMap;

/// A balanced octree flattened for the kernel (and its twin).
pub struct OctreeHost {
    pub params: OctParams,
    pub records: Vec<u32>,
    /// Per leaf: lattice x, y, z and level.
    pub boxes: Vec<[u32; 4]>,
    /// The split planes rounded to float32, axis after axis (`grid_stride` each).
    pub grid: Vec<f32>,
    /// Per triangle copy its three corners; the caller's id bitcast into the first w.
    pub tris: Vec<[f32; 4]>,
    pub cube: Vec<u32>,
    /// (level, lattice corner) → leaf record, to locate origins inside the root.
    leaf_at: HashMap<(u32, [u32; 3]), u32>,
    out_faces: [[u8; 8]; 8],
    to_neighbor: [[u8; 8]; 6],
}

impl OctreeHost {
    /// Flattens `oct`. Refused: unbalanced trees (their links to hierarchy nodes need the
    /// hierarchy, which only the CPU walk keeps), and planes that float32 cannot tell apart.
    pub fn new(oct: &PortalezOctree) -> Result<OctreeHost> {
        if !oct.params.balance || oct.records.iter().any(|&w| w & NODE_TAG != 0) {
            // Every link of a balanced tree is a leaf record; a tagged word in an unbalanced
            // one is a hierarchy node (or a count that large: refused either way).
            return Err(Error::InvalidOption(
                "the GPU octree walks balanced octrees only (OctreeParams::balance = true): an \
                 unbalanced tree links faces to hierarchy nodes, which only the CPU walk keeps"
                    .into(),
            ));
        }
        let depth = oct.params.max_depth;
        let stride = (1usize << depth) + 1;
        let mut grid = Vec::with_capacity(3 * stride);
        for g in &oct.grid {
            assert_eq!(g.len(), stride);
            grid.extend(g.iter().map(|&x| x as f32));
        }
        if grid
            .chunks(stride)
            .any(|g| g.windows(2).any(|w| w[0] >= w[1]))
        {
            return Err(Error::InvalidInput(format!(
                "the octree's split planes at depth {depth} are too close for float32 (two \
                 round to the same number); build it with a smaller max_depth"
            )));
        }
        let tris = oct
            .triangles
            .iter()
            .zip(&oct.ids)
            .flat_map(|(t, &id)| {
                let p = |k: usize| t[k].map(|x| x as f32);
                let (a, b, c) = (p(0), p(1), p(2));
                [
                    [a[0], a[1], a[2], f32::from_bits(id)],
                    [b[0], b[1], b[2], 0.0],
                    [c[0], c[1], c[2], 0.0],
                ]
            })
            .collect();
        let lo = [0, 1, 2].map(|k| grid[k * stride]);
        let hi = [0, 1, 2].map(|k| grid[k * stride + stride - 1]);
        let res = oct.cube_res;
        let params = OctParams {
            lo,
            hi,
            scale: [0, 1, 2].map(|k| (res as f64 / (hi[k] as f64 - lo[k] as f64)) as f32),
            cube_res: res as u32,
            depth,
            grid_stride: stride as u32,
            max_steps: oct.boxes.len() as u32 + 8,
            ..Default::default()
        };
        let leaf_at = oct
            .boxes
            .iter()
            .zip(&oct.leaf_record)
            .map(|(b, &r)| ((b[3], [b[0], b[1], b[2]]), r))
            .collect();
        Ok(OctreeHost {
            params,
            records: oct.records.clone(),
            boxes: oct.boxes.clone(),
            grid,
            tris,
            cube: oct.cube_map.clone(),
            leaf_at,
            out_faces: out_faces_lookup(),
            to_neighbor: face_to_neighbor_index(),
        })
    }

    #[inline]
    fn plane(&self, axis: usize, i: u32) -> f32 {
        self.grid[axis * self.params.grid_stride as usize + i as usize]
    }

    /// The ray as the kernel reads it; Err(INVALID) for a non-finite number or d = 0. An
    /// origin inside the root box (float32 comparisons) starts in the leaf holding it: per
    /// axis the cell between the planes around o (on a plane, the side d goes to), then the
    /// leaf covering that cell.
    pub fn prepare(&self, o: [f32; 3], d: [f32; 3]) -> std::result::Result<OctRayIn, u8> {
        if !o.iter().chain(&d).all(|x| x.is_finite()) || d == [0.0; 3] {
            return Err(INVALID);
        }
        let p = &self.params;
        let inside = (0..3).all(|k| p.lo[k] <= o[k] && o[k] <= p.hi[k]);
        let start = if inside {
            let cells = p.grid_stride - 1;
            let cell = [0, 1, 2].map(|k| {
                let g = &self.grid[k * p.grid_stride as usize..][1..cells as usize];
                g.partition_point(|&x| x < o[k] || (x == o[k] && d[k] > 0.0)) as u32
            });
            (0..=p.depth)
                .rev()
                .find_map(|level| {
                    let mask = !((1u32 << (p.depth - level)) - 1);
                    self.leaf_at.get(&(level, cell.map(|c| c & mask))).copied()
                })
                .expect("every lattice cell is in a leaf")
        } else {
            NO_START
        };
        Ok(OctRayIn {
            o,
            start,
            d,
            _pad: 0,
        })
    }

    #[inline]
    fn links_before(nc: u32, f: usize) -> u32 {
        let mut off = 0;
        for g in 0..f {
            off += (nc >> (4 * g)) & 15;
        }
        off
    }

    fn texel(&self, x: f32, axis: usize) -> u32 {
        let r = (self.params.cube_res - 1) as f32;
        let mut s = (x - self.params.lo[axis]) * self.params.scale[axis];
        if s < 0.0 {
            s = 0.0;
        }
        if s > r {
            s = r;
        }
        s as u32
    }

    /// The kernel's entry from outside the root box: the slab test (Err: a miss), the cube
    /// map's leaf at the entry point, and the steps within the root face to the leaf holding
    /// it. Ok: the first leaf's record and those steps (tests read them).
    pub fn entry(
        &self,
        ray: &OctRayIn,
        max_steps: u32,
    ) -> std::result::Result<(usize, u32), OctRayOut> {
        self.enter(ray, &ray.d.map(|x| 1.0 / x), max_steps)
    }

    fn enter(
        &self,
        ray: &OctRayIn,
        inv: &[f32; 3],
        max_steps: u32,
    ) -> std::result::Result<(usize, u32), OctRayOut> {
        let (o, d) = (ray.o, ray.d);
        let p = &self.params;
        let pos = d.map(|x| x > 0.0);
        let miss = OctRayOut::new(MISS, NO_TRI, 0.0, 0);
        let (mut tn, mut tf, mut e) = (0f32, f32::MAX, 3usize);
        for k in 0..3 {
            if d[k] == 0.0 {
                if o[k] < p.lo[k] || o[k] > p.hi[k] {
                    return Err(miss);
                }
            } else {
                let near = if pos[k] { p.lo[k] } else { p.hi[k] };
                let far = if pos[k] { p.hi[k] } else { p.lo[k] };
                let t0 = (near - o[k]) * inv[k];
                let t1 = (far - o[k]) * inv[k];
                if e == 3 || t0 > tn {
                    tn = t0;
                    e = k;
                }
                if t1 < tf {
                    tf = t1;
                }
            }
        }
        if e == 3 || tn > tf || tf < 0.0 {
            return Err(miss);
        }
        let mut ent = [0f32; 3];
        for k in 0..3 {
            ent[k] = o[k] + tn * d[k];
        }
        ent[e] = if pos[e] { p.lo[e] } else { p.hi[e] };
        let (u, w) = in_plane(e);
        let res = p.cube_res as usize;
        let face = face_of(e, !pos[e]);
        let mut addr = self.cube
            [(face * res + self.texel(ent[w], w) as usize) * res + self.texel(ent[u], u) as usize]
            as usize;
        let mut fixes = 0u32;
        loop {
            let b = self.boxes[self.records[addr + 2] as usize];
            let size = 1u32 << (p.depth - b[3]);
            let m = if ent[u] < self.plane(u, b[u]) {
                Some((u, false))
            } else if ent[u] > self.plane(u, b[u] + size) {
                Some((u, true))
            } else if ent[w] < self.plane(w, b[w]) {
                Some((w, false))
            } else if ent[w] > self.plane(w, b[w] + size) {
                Some((w, true))
            } else {
                None
            };
            let Some((m, up)) = m else {
                break;
            };
            fixes += 1;
            if fixes > max_steps {
                return Err(OctRayOut::new(FAILED, NO_TRI, 0.0, 0));
            }
            let f = face_of(m, up);
            let nc = self.records[addr + 3];
            let n = (nc >> (4 * f)) & 15;
            if n == 0 {
                break;
            }
            let mut j = 0;
            if n == 4 {
                let half = size >> 1;
                let (mu, mw) = in_plane(m);
                j = (ent[mu] < self.plane(mu, b[mu] + half)) as u32
                    + 2 * (ent[mw] < self.plane(mw, b[mw] + half)) as u32;
            }
            addr = self.records[addr + 4 + (Self::links_before(nc, f) + j) as usize] as usize;
        }
        Ok((addr, fixes))
    }

    /// The kernel's `trace`, operation for operation (see the WGSL for the why of each step).
    pub fn twin(&self, ray: &OctRayIn, max_steps: u32) -> OctRayOut {
        let (o, d) = (ray.o, ray.d);
        let p = &self.params;
        let pos = d.map(|x| x > 0.0);
        let row = pos[0] as usize + 2 * pos[1] as usize + 4 * pos[2] as usize;
        let inv = d.map(|x| 1.0 / x);
        let mut big = 0;
        if d[1].abs() > d[big].abs() {
            big = 1;
        }
        if d[2].abs() > d[big].abs() {
            big = 2;
        }
        let pi = |k: usize, q: [f32; 3]| {
            let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
            (q[k1] - o[k1]) * d[k2] - (q[k2] - o[k2]) * d[k1]
        };
        let mut addr = ray.start as usize;
        if ray.start == NO_START {
            match self.enter(ray, &inv, max_steps) {
                Ok((a, _)) => addr = a,
                Err(out) => return out,
            }
        }
        let (mut best, mut best_t, mut visited) = (NO_TRI, 0f32, 0u32);
        loop {
            visited += 1;
            if visited > max_steps {
                return OctRayOut::new(FAILED, NO_TRI, 0.0, visited);
            }
            let [tc, to, leaf, nc] = [0, 1, 2, 3].map(|i| self.records[addr + i]);
            for j in to as usize..(to + tc) as usize {
                let [a, b, c] = [0, 1, 2].map(|i| self.tris[3 * j + i]);
                let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let px = d[1] * e2[2] - d[2] * e2[1];
                let py = d[2] * e2[0] - d[0] * e2[2];
                let pz = d[0] * e2[1] - d[1] * e2[0];
                let det = (e1[0] * px + e1[1] * py) + e1[2] * pz;
                if det == 0.0 {
                    continue;
                }
                let idet = 1.0 / det;
                let s = [o[0] - a[0], o[1] - a[1], o[2] - a[2]];
                let uu = ((s[0] * px + s[1] * py) + s[2] * pz) * idet;
                if !((0.0..=1.0).contains(&uu)) {
                    continue;
                }
                let qx = s[1] * e1[2] - s[2] * e1[1];
                let qy = s[2] * e1[0] - s[0] * e1[2];
                let qz = s[0] * e1[1] - s[1] * e1[0];
                let vv = ((d[0] * qx + d[1] * qy) + d[2] * qz) * idet;
                if !(vv >= 0.0 && uu + vv <= 1.0) {
                    continue;
                }
                let t = ((e2[0] * qx + e2[1] * qy) + e2[2] * qz) * idet;
                let id = a[3].to_bits();
                if t >= 0.0 && (best == NO_TRI || t < best_t || (t == best_t && id < best)) {
                    best = id;
                    best_t = t;
                }
            }
            let bx = self.boxes[leaf as usize];
            let size = 1u32 << (p.depth - bx[3]);
            let corner =
                [0, 1, 2].map(|k| self.plane(k, if pos[k] { bx[k] + size } else { bx[k] }));
            let bits = (pi(0, corner) < 0.0) as usize
                | ((pi(1, corner) < 0.0) as usize) << 1
                | ((pi(2, corner) < 0.0) as usize) << 2;
            let mut f = self.out_faces[row][bits] as usize;
            if f == 7 || d[FACE_AXIS[f]] == 0.0 {
                f = face_of(big, pos[big]);
            }
            let a = FACE_AXIS[f];
            let t_exit = (corner[a] - o[a]) * inv[a];
            if best != NO_TRI && best_t <= t_exit {
                return OctRayOut::new(HIT, best, best_t, visited);
            }
            let n = (nc >> (4 * f)) & 15;
            if n == 0 {
                if best != NO_TRI {
                    return OctRayOut::new(HIT, best, best_t, visited);
                }
                return OctRayOut::new(MISS, NO_TRI, 0.0, visited);
            }
            let mut j = 0;
            if n == 4 {
                let half = size >> 1;
                let (u, w) = in_plane(a);
                let mut c = corner;
                c[u] = self.plane(u, bx[u] + half);
                c[w] = self.plane(w, bx[w] + half);
                let qb = ((pi(u, c) < 0.0) as usize) << u | ((pi(w, c) < 0.0) as usize) << w;
                j = self.to_neighbor[f][qb] as u32;
            }
            addr = self.records[addr + 4 + (Self::links_before(nc, f) + j) as usize] as usize;
        }
    }

    /// Prepares and traces every ray on the CPU (the twin); `max_steps` None: leaves + 8.
    pub fn cast_twin(&self, o: &[f32], d: &[f32], max_steps: Option<u32>) -> Vec<OctRayOut> {
        use rayon::prelude::*;
        let steps = max_steps.unwrap_or(self.params.max_steps);
        (0..o.len() / 3)
            .into_par_iter()
            .map(|i| {
                let v = |x: &[f32]| [x[3 * i], x[3 * i + 1], x[3 * i + 2]];
                match self.prepare(v(o), v(d)) {
                    Ok(r) => self.twin(&r, steps),
                    Err(s) => OctRayOut::new(s, NO_TRI, 0.0, 0),
                }
            })
            .collect()
    }
}
