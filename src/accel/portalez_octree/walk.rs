//! The walk from leaf to leaf: the ray's frame (its exact Plücker signs and t comparisons),
//! the start leaf (inside the root, or its entry by the cube map), and the exit face and
//! quadrant each step reads from the paper's two tables.

use super::tables::{
    delta_sign, face_of, face_to_neighbor_index, in_plane, out_faces_lookup, FACE_AXIS,
    FACE_POSITIVE,
};
use super::{OctreeState, PortalezOctree, Walked, NODE_TAG};
use crate::geom::exact::sign2;
use crate::query::gather::{Gather, Line};
use std::sync::OnceLock;

/// Relative error of (x − o) / d in float64: two roundings, padded as in `reshetov_bvh`.
const PAD: f64 = 4.0 * f64::EPSILON;
const TINY: f64 = 4.0 * f64::MIN_POSITIVE;
/// The ray as the walk reads it: the origin, the scaled direction (signs only), its octant.
struct Frame {
    o: [f64; 3],
    d: [f64; 3],
    dir: [f64; 3],
    s: [i32; 3],
    pos: [bool; 3],
    row: usize,
    all_active: bool,
}

impl Frame {
    fn new(line: &Line) -> Frame {
        let dir = line.dir;
        let s = dir.map(|x| (x > 0.0) as i32 - (x < 0.0) as i32);
        let pos = dir.map(|x| x > 0.0);
        Frame {
            o: line.o,
            d: line.d,
            dir,
            s,
            pos,
            row: pos[0] as usize + 2 * pos[1] as usize + 4 * pos[2] as usize,
            all_active: s.iter().all(|&x| x != 0),
        }
    }

    /// The exact sign of Π_k(P) = ((P − o) × d)_k.
    #[inline]
    fn pi(&self, k: usize, p: [f64; 3]) -> i32 {
        let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
        sign2(
            p[k1],
            self.o[k1],
            self.dir[k2],
            p[k2],
            self.o[k2],
            self.dir[k1],
        )
    }

    /// The sign of t_i(x) − t_j(y), t_i(x) being where the line crosses the plane x_i = x
    /// (both axes active).
    fn cmp_t(&self, i: usize, x: f64, j: usize, y: f64) -> i32 {
        sign2(x, self.o[i], self.dir[j], y, self.o[j], self.dir[i]) * self.s[i] * self.s[j]
    }

    /// The sign of E_a − v, E being where the line crosses the plane x_e = f (e active).
    fn cmp_on_plane(&self, e: usize, f: f64, a: usize, v: f64) -> i32 {
        if self.s[a] == 0 {
            return (self.o[a] > v) as i32 - (self.o[a] < v) as i32;
        }
        // E_a − v = d_a (t_e(f) − t_a(v)).
        self.s[a] * self.cmp_t(e, f, a, v)
    }
}

/// outFacesLookup and faceToNeighborIndex.
type Tables = ([[u8; 8]; 8], [[u8; 8]; 6]);

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| (out_faces_lookup(), face_to_neighbor_index()))
}

impl PortalezOctree {
    /// The leaf record holding point p (in the root box), by exact comparisons with the split
    /// planes; on a plane, the side `dir` goes to.
    fn locate(&self, fr: &Frame, side: impl Fn(usize, f64) -> i32) -> usize {
        let mut k = 0usize;
        loop {
            let n = self.nodes[k];
            if n.child == 0 {
                return self.leaf_record[n.leaf as usize] as usize;
            }
            let half = 1u32 << (self.params.max_depth - n.level - 1);
            let mut c = 0u32;
            for a in 0..3 {
                let s = side(a, self.grid[a][(n.at[a] + half) as usize]);
                if s > 0 || (s == 0 && fr.pos[a]) {
                    c |= 1 << a;
                }
            }
            k = (n.child + c) as usize;
        }
    }

    /// The first leaf's record and a lower bound on where the ray enters it (in t of d);
    /// None: the ray misses the root box.
    fn start(&self, fr: &Frame, state: &mut OctreeState) -> Option<(usize, f64)> {
        let (lo, hi, o) = (self.lo, self.hi, fr.o);
        if (0..3).all(|k| lo[k] <= o[k] && o[k] <= hi[k]) {
            let at = self.locate(fr, |a, s| (o[a] > s) as i32 - (o[a] < s) as i32);
            return Some((at, f64::NEG_INFINITY));
        }
        let near = [0, 1, 2].map(|k| if fr.pos[k] { lo[k] } else { hi[k] });
        let far = [0, 1, 2].map(|k| if fr.pos[k] { hi[k] } else { lo[k] });
        for k in 0..3 {
            if fr.s[k] == 0 {
                if !(lo[k] <= o[k] && o[k] <= hi[k]) {
                    return None;
                }
            } else if (far[k] - o[k]) * (fr.s[k] as f64) < 0.0 {
                return None; // the box lies behind
            }
        }
        let act: Vec<usize> = (0..3).filter(|&k| fr.s[k] != 0).collect();
        // The entry axis: the latest near plane (exact comparisons; ties: the first).
        let e = *act
            .iter()
            .find(|&&i| {
                act.iter()
                    .all(|&j| j == i || fr.cmp_t(i, near[i], j, near[j]) >= 0)
            })
            .expect("a greatest entry");
        if act
            .iter()
            .any(|&k| k != e && fr.cmp_t(e, near[e], k, far[k]) > 0)
        {
            return None;
        }
        let fe = near[e];
        let face = face_of(e, !fr.pos[e]);
        let (u, w) = in_plane(e);
        // The cube map's guess, from the rounded entry point.
        let t = (fe - o[e]) / fr.dir[e];
        let texel = |a: usize| {
            let x = o[a] + t * fr.dir[a];
            let r = self.cube_res;
            (((x - lo[a]) / (hi[a] - lo[a]) * r as f64) as usize).min(r - 1)
        };
        let guess = self.cube_map[(face * self.cube_res + texel(w)) * self.cube_res + texel(u)];
        let (blo, bhi) = self.leaf_box(self.records[guess as usize + 2] as usize);
        let holds = [u, w].iter().all(|&a| {
            fr.cmp_on_plane(e, fe, a, blo[a]) >= 0 && fr.cmp_on_plane(e, fe, a, bhi[a]) <= 0
        });
        let at = if holds {
            guess as usize
        } else {
            state.entry_fixes += 1;
            self.locate(fr, |a, s| {
                if a == e {
                    // On the entry face: the side inside the root.
                    if fr.pos[e] {
                        -1
                    } else {
                        1
                    }
                } else {
                    fr.cmp_on_plane(e, fe, a, s)
                }
            })
        };
        let te = (fe - o[e]) / fr.d[e];
        Some((at, te - PAD * te.abs() - TINY))
    }

    /// The exit face of the box whose exit corner is `c`: the table where every sign is
    /// non-zero and every axis active, else the least exit distance by exact comparison
    /// (ties: the first axis), which is what the table gives where it applies.
    #[inline]
    fn exit_face(&self, fr: &Frame, c: [f64; 3]) -> usize {
        let pi = [0, 1, 2].map(|k| fr.pi(k, c));
        if fr.all_active && pi.iter().all(|&s| s != 0) {
            let bits =
                (pi[0] < 0) as usize | ((pi[1] < 0) as usize) << 1 | ((pi[2] < 0) as usize) << 2;
            let f = tables().0[fr.row][bits];
            if f != 7 {
                return f as usize;
            }
        }
        // sign(t_i − t_j) from Π_k = d_{k+1} d_{k+2} (t_{k+1} − t_{k+2}).
        let cmp = |i: usize, j: usize| {
            let k = 3 - i - j;
            let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
            let s = pi[k] * fr.s[k1] * fr.s[k2];
            if i == k1 {
                s
            } else {
                -s
            }
        };
        let act = fr.s.map(|s| s != 0);
        for i in 0..3 {
            if act[i] && (0..3).all(|j| j == i || !act[j] || cmp(i, j) <= 0) {
                return face_of(i, fr.pos[i]);
            }
        }
        unreachable!("exit distances are ordered")
    }

    /// Which of the four finer cells across face `f` (centre `c`) holds the exit point: the
    /// table where both in-plane signs are non-zero; on a dividing line, the side the ray
    /// goes to (so the walk moves on rather than back).
    #[inline]
    fn quadrant(&self, fr: &Frame, f: usize, c: [f64; 3]) -> usize {
        let a = FACE_AXIS[f];
        let (u, w) = in_plane(a);
        let (pu, pw) = (fr.pi(u, c), fr.pi(w, c));
        if pu != 0 && pw != 0 {
            let bits = ((pu < 0) as usize) << u | ((pw < 0) as usize) << w;
            return tables().1[f][bits] as usize;
        }
        let sn = if FACE_POSITIVE[f] { 1 } else { -1 };
        let delta = |m: usize, pi: i32| {
            let s = delta_sign(a, m, pi, sn);
            if s != 0 {
                s
            } else if fr.pos[m] {
                -1 // δ = c − X < 0 just past X: the upper half
            } else {
                1
            }
        };
        (delta(u, pw) > 0) as usize + 2 * (delta(w, pu) > 0) as usize
    }

    /// Offers `gather` every triangle the ray meets in the leaves it passes, in order,
    /// stopping where the next leaf lies beyond its reach.
    pub fn walk<G: Gather>(&self, line: &Line, gather: &mut G, state: &mut OctreeState) -> Walked {
        let fr = Frame::new(line);
        state.offered.clear();
        let Some((mut addr, low)) = self.start(&fr, state) else {
            return Walked::Done(0);
        };
        if low > gather.reach() {
            return Walked::Done(0);
        }
        let cap = self.leaves() as u32 + 8;
        let depth = self.params.max_depth;
        let mut visited = 0u32;
        loop {
            visited += 1;
            if visited > cap {
                state.guards += 1;
                return Walked::Guard(visited);
            }
            let [tc, to, leaf, nc] = self.record(addr);
            for j in to as usize..(to + tc) as usize {
                let id = self.ids[j];
                let Some(at) = line.meets_at(&self.triangles[j]) else {
                    continue;
                };
                if !state.offered.contains(&id) {
                    state.offered.push(id);
                    if gather.offer(id, &self.triangles[j], at) {
                        return Walked::Done(visited);
                    }
                }
            }
            let (lo, hi) = self.leaf_box(leaf as usize);
            let corner = [0, 1, 2].map(|k| if fr.pos[k] { hi[k] } else { lo[k] });
            let f = self.exit_face(&fr, corner);
            let n = nc >> (4 * f) & 15;
            if n == 0 {
                return Walked::Done(visited);
            }
            let a = FACE_AXIS[f];
            let t = (corner[a] - fr.o[a]) / fr.d[a];
            if t - PAD * t.abs() - TINY > gather.reach() {
                return Walked::Done(visited);
            }
            let off: u32 = (0..f).map(|g| nc >> (4 * g) & 15).sum();
            let j = if n == 4 {
                let b = self.boxes[leaf as usize];
                let half = 1u32 << (depth - b[3] - 1);
                let mut c = corner;
                let (u, w) = in_plane(a);
                for m in [u, w] {
                    c[m] = self.grid[m][(b[m] + half) as usize];
                }
                self.quadrant(&fr, f, c)
            } else {
                0
            };
            let mut link = self.records[addr + 4 + (off as usize) + j];
            // Unbalanced trees: descend from a node to the leaf holding the exit point.
            while link & NODE_TAG != 0 {
                let node = self.nodes[(link & !NODE_TAG) as usize];
                let half = 1u32 << (depth - node.level - 1);
                let mut c = corner;
                let (u, w) = in_plane(a);
                for m in [u, w] {
                    c[m] = self.grid[m][(node.at[m] + half) as usize];
                }
                let q = self.quadrant(&fr, f, c) as u32;
                let bits =
                    ((!FACE_POSITIVE[f]) as u32) << a | (1 - (q & 1)) << u | (1 - (q >> 1)) << w;
                let ch = self.nodes[(node.child + bits) as usize];
                link = if ch.child == 0 {
                    self.leaf_record[ch.leaf as usize]
                } else {
                    NODE_TAG | (node.child + bits)
                };
            }
            addr = link as usize;
        }
    }
}
