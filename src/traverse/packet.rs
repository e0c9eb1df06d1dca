//! Rays that share an origin, walked as one packet (Reshetov et al.'s frustum test, applied to
//! tets): where every ray of the packet leaves a tet by the same face, the packet takes that
//! step once.
//!
//! The exact walk leaves a tet entered through (a, b, c) by the face that the exact signs of
//! the new vertex d's three edges d→a, d→b, d→c name (`exact::Exact::step_plain`). For a line
//! (o, v) the side of edge p→q is the sign of det(v, p − o, q − o) = v · n with
//! n = (p − o) × (q − o): with o shared, n is the packet's ([`Edge`]) and the side is linear
//! in the direction v. Over a box of directions holding every ray's ([`DirBox`]), the extremes
//! of v · n are at the box's corners; when the whole interval, widened by a bound on the
//! rounding of n and of the interval, lies on one side of zero, every ray of the packet has
//! that exact side — nonzero, so no ray touches the edge either. Three such edges decide the
//! exit for every ray at once, and it is the exit each ray's own walk takes (bit for bit:
//! same tets, same faces, same step counts). Where the box is not decisive, each ray's side
//! is v · n with the same bound for v alone (three dot products per ray, no memory wait), and
//! the caller regroups the rays by exit (`accel::tetwalk`).

use super::walk::WalkSetup;
use super::Exit;
use crate::geom::real::{greater, lesser, Real, V3};
use crate::layout::Layout;
use crate::mesh::build::CONSTRAINED_BIT;
use crate::simd::Simd;

/// The box holding the directions of a packet's rays (each as the walk's line has it: the
/// caller's direction times a power of two, which changes no side).
#[derive(Clone, Copy, Debug)]
pub struct DirBox {
    lo: V3<f64>,
    hi: V3<f64>,
    /// Σ_k max(|lo_k|, |hi_k|): bounds |v_0| + |v_1| + |v_2| for every v in the box.
    reach: f64,
}

impl DirBox {
    /// The box of `dirs` (at least one).
    pub fn of<'a>(mut dirs: impl Iterator<Item = &'a V3<f64>>) -> DirBox {
        let first = *dirs.next().expect("a packet holds a ray");
        let (mut lo, mut hi) = (first, first);
        for v in dirs {
            for k in 0..3 {
                lo[k] = lesser(lo[k], v[k]);
                hi[k] = greater(hi[k], v[k]);
            }
        }
        let reach = (0..3).map(|k| greater(lo[k].abs(), hi[k].abs())).sum();
        DirBox { lo, hi, reach }
    }
}

/// A ray of a packet: its direction (as its walk's line has it) and its index in the run.
/// `repr(C)`, 32 bytes, every byte a field: the AVX2 kernel loads `dir` as four lanes
/// (`index` and `spare` fill the fourth, which it never uses).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct PacketRay {
    pub dir: V3<f64>,
    pub index: u32,
    spare: u32,
}

const _: () = assert!(std::mem::size_of::<PacketRay>() == 32);

impl PacketRay {
    pub fn new(index: u32, dir: V3<f64>) -> PacketRay {
        PacketRay {
            dir,
            index,
            spare: 0,
        }
    }
}

/// An edge p→q of a tet seen from the packet's shared origin o: the side of a line (o, v) is
/// the sign of det(v, p − o, q − o) = v · n with n = (p − o) × (q − o).
#[derive(Clone, Copy, Debug)]
pub struct Edge {
    n: V3<f64>,
    /// 2‖P‖∞‖Q‖∞, at least every |P_y Q_z| + |P_z Q_y| (and rotations): what bounds n's
    /// rounding. One product per edge where the vertices' norms are known
    /// ([`Edge::with_norms`]); a looser bound than the per-axis sums only where it is ~1e-15
    /// of the sides, so it rarely makes a side uncertain.
    scale: f64,
}

/// ‖p‖∞, the norm [`Edge::with_norms`] takes. (A NaN in p need not show here: it makes the
/// edge's n NaN, and every side that uses it uncertain.)
#[inline(always)]
pub fn norm(p: &V3<f64>) -> f64 {
    greater(greater(p[0].abs(), p[1].abs()), p[2].abs())
}

impl Edge {
    /// From P = fl(p − o) and Q = fl(q − o) (float64 points and origin).
    #[inline(always)]
    pub fn new(p: V3<f64>, q: V3<f64>) -> Edge {
        Edge::with_norms(p, norm(&p), q, norm(&q))
    }

    /// [`Edge::new`] with `np` = ‖P‖∞ and `nq` = ‖Q‖∞ already known ([`norm`]).
    #[inline(always)]
    pub fn with_norms(p: V3<f64>, np: f64, q: V3<f64>, nq: f64) -> Edge {
        Edge {
            n: [
                p[1] * q[2] - p[2] * q[1],
                p[2] * q[0] - p[0] * q[2],
                p[0] * q[1] - p[1] * q[0],
            ],
            scale: 2.0 * np * nq,
        }
    }

    /// The edges p→q, q→r, r→p of a face (P = fl(p − o) and so on, as [`Edge::new`] takes
    /// them): the sides that decide whether a line from o crosses its interior, and which way.
    #[inline(always)]
    pub fn around(p: V3<f64>, q: V3<f64>, r: V3<f64>) -> [Edge; 3] {
        [Edge::new(p, q), Edge::new(q, r), Edge::new(r, p)]
    }

    /// The exact side of every direction in the box, when it is one and certain; 0 when not
    /// (some directions may have another sign, or a zero, or the bound failed).
    ///
    /// Bound (u = 2⁻⁵³; m_x = |P_y Q_z| + |P_z Q_y| and rotations; reach_k = max(|lo_k|,
    /// |hi_k|)): each component n_x = fl(fl(P_y Q_z) − fl(P_z Q_y)) differs from the exact
    /// (p − o) × (q − o) by at most 4u·m_x + O(u²) (two inputs' subtraction errors, the
    /// product's and the difference's roundings); the box's extremes Σ min/max(lo_k n_k,
    /// hi_k n_k) are computed with at most 3u·Σ reach_k |n_k|. Since |n_k| ≤ m_k (1 + u),
    /// 8u·Σ reach_k m_k covers both with room for the O(u²) terms; m_k ≤ 2‖P‖∞‖Q‖∞ = scale,
    /// so 8u·scale·Σ reach_k does too, and the few roundings of scale and of the sum
    /// (relative 5u) fit in the bound's own margin (scaled up by 1 + 2⁻²⁰). Products that
    /// underflow lose at most 2⁻¹⁰⁷⁴ each: the absolute term covers them. NaN or infinity
    /// fails the comparisons: not certain.
    #[inline(always)]
    pub fn side(&self, b: &DirBox) -> i8 {
        // lo_k ≤ hi_k, so lo_k n_k ≤ hi_k n_k exactly when n_k ≥ 0 (rounding is monotone):
        // the extremes without comparing the products (a NaN n_k fails the sign test below).
        let (mut low, mut high) = (0.0, 0.0);
        for k in 0..3 {
            let (near, far) = if self.n[k] >= 0.0 {
                (b.lo[k], b.hi[k])
            } else {
                (b.hi[k], b.lo[k])
            };
            low += near * self.n[k];
            high += far * self.n[k];
        }
        certain_sign(low, high, self.bound(b))
    }

    /// The bound [`Edge::side`] allows for rounding over the box `b`: since every direction
    /// v in the box has |v_k| ≤ reach_k, it bounds the rounding of each one's v · n too
    /// ([`Edge::side_within`]): Σ_k |v_k| ≤ reach.
    #[inline(always)]
    pub fn bound(&self, b: &DirBox) -> f64 {
        rounding_bound(self.scale * b.reach)
    }

    /// The exact side of a direction v of a box whose [`Edge::bound`] is `bound`, when
    /// certain; 0 when not. Three products: the bound is the box's, not v's own.
    #[inline(always)]
    pub fn side_within(&self, v: &V3<f64>, bound: f64) -> i8 {
        let (positive, negative) = self.signs_within(v, bound);
        positive as i8 - negative as i8
    }

    /// [`Edge::side_within`] as (certainly positive, certainly negative).
    #[inline(always)]
    fn signs_within(&self, v: &V3<f64>, bound: f64) -> (bool, bool) {
        let dot = v[0] * self.n[0] + v[1] * self.n[1] + v[2] * self.n[2];
        (dot > bound, dot < -bound)
    }

    /// The exact side of the one direction v, when certain (the same bound as [`Edge::side`]
    /// for a box holding v alone); 0 when not.
    #[inline(always)]
    pub fn side_of(&self, v: &V3<f64>) -> i8 {
        let dot = v[0] * self.n[0] + v[1] * self.n[1] + v[2] * self.n[2];
        let size = self.scale * (v[0].abs() + v[1].abs() + v[2].abs());
        certain_sign(dot, dot, rounding_bound(size))
    }
}

/// The error bound 8u·size (see [`Edge::side`]), rounded up.
#[inline(always)]
fn rounding_bound(size: f64) -> f64 {
    const U: f64 = f64::EPSILON / 2.0;
    8.0 * U * size * (1.0 + 1.0 / 1048576.0) + 16.0 * f64::MIN_POSITIVE
}

/// The sign of every value in [low, high] given an error bound `bound` on each end (see
/// [`Edge::side`]); 0 when not certain.
#[inline(always)]
fn certain_sign(low: f64, high: f64, bound: f64) -> i8 {
    if low > bound {
        1
    } else if high < -bound {
        -1
    } else {
        0
    }
}

/// `Exact::step_plain`'s choice from the exact sides of d→a, d→b, d→c (all nonzero): the
/// index into `Exit::ROTATIONS`.
#[inline(always)]
const fn rotation([sa, sb, sc]: [i8; 3]) -> u8 {
    let (sa, sb, sc) = (sa > 0, sb < 0, sc > 0);
    (sa & !sb) as u8 + (!sa) as u8 * (1 + sc as u8)
}

/// [`Packet::exit_of`]'s answer for each code of the three sides (two bits per edge: 1 for
/// positive, 2 for negative, 0 for uncertain): the rotation where all three are certain, else 3.
const EXITS: [u8; 64] = {
    let mut table = [3u8; 64];
    let mut code = 0;
    while code < 64 {
        let mut sides = [0i8; 3];
        let mut i = 0;
        while i < 3 {
            sides[i] = match (code >> (2 * i)) & 3 {
                1 => 1,
                2 => -1,
                _ => 0,
            };
            i += 1;
        }
        if sides[0] != 0 && sides[1] != 0 && sides[2] != 0 {
            table[code] = rotation(sides);
        }
        code += 1;
    }
    table
};

/// A packet between two steps, as `walk::WalkState` has a ray: in tet `t`, leaving by
/// (a, b, c) (ids, counter-clockwise around every ray of the packet), `link` across it; the
/// vertices' positions are kept relative to the shared origin.
#[derive(Clone, Copy, Debug)]
pub struct Packet {
    pub a: u32,
    pub b: u32,
    pub c: u32,
    pa: Rel,
    pb: Rel,
    pc: Rel,
    pub link: u32,
    pub t: u32,
    pub steps: u32,
}

impl Packet {
    /// The packet standing where a ray's walk stands: in tet `t`, leaving by (a, b, c).
    pub fn new<R: Real, L: Layout>(
        setup: &WalkSetup<R, L>,
        origin: V3<f64>,
        [a, b, c]: [u32; 3],
        link: u32,
        t: u32,
        steps: u32,
    ) -> Packet {
        let at = |v: u32| relative(setup, origin, v);
        Packet {
            a,
            b,
            c,
            pa: at(a),
            pb: at(b),
            pc: at(c),
            link,
            t,
            steps,
        }
    }

    /// The next tet when the next step may be plain (not across a constrained face or the
    /// boundary, the step guard far): its fourth vertex (id, fl(p − o)) and the three edges
    /// d→a, d→b, d→c that decide the exit. None: each ray's own walk takes the step.
    #[inline(always)]
    pub fn next<R: Real, L: Layout>(
        &self,
        setup: &WalkSetup<R, L>,
        origin: V3<f64>,
    ) -> Option<(u32, Rel, [Edge; 3])> {
        debug_assert!(!L::INLINE);
        if self.link & CONSTRAINED_BIT != 0 || self.steps >= setup.max_steps {
            return None;
        }
        let d = setup.layout.new_vertex(self.link, self.a, self.b, self.c);
        let pd = relative(setup, origin, d);
        let edges = [self.pa, self.pb, self.pc].map(|q| pd.edge_to(&q));
        Some((d, pd, edges))
    }

    /// The exit every ray of `dirs` takes from the next tet, if one and certain (the three
    /// sides nonzero, so no ray touches the new exit face's edges either).
    #[inline(always)]
    pub fn exit_of_box(edges: &[Edge; 3], dirs: &DirBox) -> Option<u8> {
        let s = edges.map(|e| e.side(dirs));
        (s[0] != 0 && s[1] != 0 && s[2] != 0).then(|| rotation(s))
    }

    /// The exit the ray of direction v (in a box whose [`Edge::bound`]s on `edges` are
    /// `bounds`) takes from the next tet, if certain: 0, 1, 2 (index into `Exit::ROTATIONS`),
    /// or 3 when not.
    #[inline(always)]
    pub fn exit_of(edges: &[Edge; 3], bounds: &[f64; 3], v: &V3<f64>) -> u8 {
        // Two bits per edge, (positive, negative) for certain sides; no branches.
        let mut code = 0;
        for i in 0..3 {
            let (positive, negative) = edges[i].signs_within(v, bounds[i]);
            code |= (positive as usize) << (2 * i) | (negative as usize) << (2 * i + 1);
        }
        EXITS[code]
    }

    /// [`Packet::exit_of`] for every ray of `rays` (directions in a box whose bounds on
    /// `edges` are `bounds`) into `exits`, counting each exit in `counts`; at level `simd`,
    /// with the same answers at every level.
    #[inline(always)]
    pub fn exits_of(
        edges: &[Edge; 3],
        bounds: &[f64; 3],
        rays: &[PacketRay],
        exits: &mut [u8],
        counts: &mut [usize; 4],
        simd: Simd,
    ) {
        debug_assert_eq!(rays.len(), exits.len());
        // Only x86-64 has a SIMD level to take part of the rays first.
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        if simd == Simd::Avx2 {
            // SAFETY: the level is only Avx2 where the CPU has AVX2 (`Simd::checked`,
            // `Simd::from_env`).
            done = unsafe { avx2::exits_of(edges, bounds, rays, exits, counts) };
        }
        let _ = simd;
        for (ray, exit) in rays[done..].iter().zip(&mut exits[done..]) {
            *exit = Packet::exit_of(edges, bounds, &ray.dir);
            counts[*exit as usize] += 1;
        }
    }

    /// Takes the step [`Packet::next`] found, leaving by `Exit::ROTATIONS[rotation]`, as
    /// `walk::plain_step` takes it for one ray.
    #[inline(always)]
    pub fn advance<R: Real, L: Layout>(
        &mut self,
        setup: &WalkSetup<R, L>,
        (d, pd): (u32, Rel),
        rotation: u8,
    ) {
        let t = self.link;
        let opposite = match Exit::ROTATIONS[rotation as usize] {
            Exit::Abd => {
                let o = self.c;
                (self.c, self.pc) = (d, pd);
                o
            }
            Exit::Bcd => {
                let o = self.a;
                (self.a, self.pa, self.b, self.pb, self.c, self.pc) =
                    (self.b, self.pb, self.c, self.pc, d, pd);
                o
            }
            Exit::Cad => {
                let o = self.b;
                (self.a, self.pa, self.b, self.pb, self.c, self.pc) =
                    (self.c, self.pc, self.a, self.pa, d, pd);
                o
            }
        };
        self.t = t;
        self.steps += 1;
        self.link = setup
            .layout
            .link_opposite(t, opposite, [self.a, self.b, self.c]);
        setup.layout.prefetch(self.link);
    }
}

/// A vertex seen from the packet's origin: P = fl(p − o) and ‖P‖∞ (what [`Edge`]s take).
#[derive(Clone, Copy, Debug)]
pub struct Rel {
    p: V3<f64>,
    norm: f64,
}

impl Rel {
    /// The edge from this vertex to `q`.
    #[inline(always)]
    fn edge_to(&self, q: &Rel) -> Edge {
        Edge::with_norms(self.p, self.norm, q.p, q.norm)
    }
}

/// Vertex v seen from `origin`, with its norm.
#[inline(always)]
fn relative<R: Real, L: Layout>(setup: &WalkSetup<R, L>, origin: V3<f64>, v: u32) -> Rel {
    let p = seen_from(setup, origin, v);
    Rel { p, norm: norm(&p) }
}

/// fl(p − o) for vertex v (in the walk's points) and origin o: what [`Edge`]s are made of.
#[inline(always)]
pub fn seen_from<R: Real, L: Layout>(setup: &WalkSetup<R, L>, origin: V3<f64>, v: u32) -> V3<f64> {
    let p = setup.points[v as usize];
    [0, 1, 2].map(|k| p[k].to_f64() - origin[k])
}

/// The per-ray exits four rays at a time.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Edge, PacketRay, EXITS};
    use std::arch::x86_64::*;

    /// Bit j of the 4-bit mask `m` moved to bit 8j: lane j's bit in byte j.
    #[inline(always)]
    fn spread(m: i32) -> u32 {
        (m as u32).wrapping_mul(0x0020_4081) & 0x0101_0101
    }

    /// `Packet::exit_of` for the rays of `rays` in whole groups of four (the same products,
    /// sums and comparisons, lane by lane); returns how many it did.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn exits_of(
        edges: &[Edge; 3],
        bounds: &[f64; 3],
        rays: &[PacketRay],
        exits: &mut [u8],
        counts: &mut [usize; 4],
    ) -> usize {
        let full = rays.len() / 4 * 4;
        let n = edges.map(|e| e.n.map(|x| _mm256_set1_pd(x)));
        let above = bounds.map(|b| _mm256_set1_pd(b));
        let below = bounds.map(|b| _mm256_set1_pd(-b));
        for k in (0..full).step_by(4) {
            // Four rays' (x, y, z, -) rows, transposed into x, y and z columns.
            let at = rays.as_ptr().add(k) as *const f64;
            let [r0, r1, r2, r3] = [0, 4, 8, 12].map(|i| _mm256_loadu_pd(at.add(i)));
            let (t0, t1) = (_mm256_unpacklo_pd(r0, r1), _mm256_unpackhi_pd(r0, r1));
            let (t2, t3) = (_mm256_unpacklo_pd(r2, r3), _mm256_unpackhi_pd(r2, r3));
            let x = _mm256_permute2f128_pd::<0x20>(t0, t2);
            let y = _mm256_permute2f128_pd::<0x20>(t1, t3);
            let z = _mm256_permute2f128_pd::<0x31>(t0, t2);
            // Byte j: ray k + j's code, two bits per edge as `Packet::exit_of` makes it.
            let mut codes = 0u32;
            for i in 0..3 {
                let xy = _mm256_add_pd(_mm256_mul_pd(x, n[i][0]), _mm256_mul_pd(y, n[i][1]));
                let dot = _mm256_add_pd(xy, _mm256_mul_pd(z, n[i][2]));
                let positive = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(dot, above[i]));
                let negative = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(dot, below[i]));
                codes |= spread(positive) << (2 * i) | spread(negative) << (2 * i + 1);
            }
            for j in 0..4 {
                let exit = EXITS[(codes >> (8 * j) & 0x3f) as usize];
                exits[k + j] = exit;
                counts[exit as usize] += 1;
            }
        }
        test_count!(super::AVX2_RAYS += full);
        full
    }
}

test_count!(
    /// Rays whose exits the AVX2 kernel decided on this thread (tests: that it ran).
    AVX2_RAYS,
    avx2_rays
);

#[cfg(test)]
mod tests;
