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
use crate::geom::real::{Real, V3};
use crate::layout::Layout;
use crate::mesh::build::CONSTRAINED_BIT;

/// The box holding the directions of a packet's rays (each as the walk's line has it: the
/// caller's direction times a power of two, which changes no side).
#[derive(Clone, Copy, Debug)]
pub struct DirBox {
    lo: V3<f64>,
    hi: V3<f64>,
    /// max(|lo|, |hi|) per axis: the largest |v_k| in the box.
    reach: V3<f64>,
}

impl DirBox {
    /// The box of `dirs` (at least one).
    pub fn of<'a>(mut dirs: impl Iterator<Item = &'a V3<f64>>) -> DirBox {
        let first = *dirs.next().expect("a packet holds a ray");
        let (mut lo, mut hi) = (first, first);
        for v in dirs {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        let reach = [0, 1, 2].map(|k| lo[k].abs().max(hi[k].abs()));
        DirBox { lo, hi, reach }
    }
}

/// An edge p→q of a tet seen from the packet's shared origin o: the side of a line (o, v) is
/// the sign of det(v, p − o, q − o) = v · n with n = (p − o) × (q − o).
#[derive(Clone, Copy, Debug)]
pub struct Edge {
    n: V3<f64>,
    /// |P_y Q_z| + |P_z Q_y| and its rotations: what bounds n's rounding.
    m: V3<f64>,
}

impl Edge {
    /// From P = fl(p − o) and Q = fl(q − o) (float64 points and origin).
    #[inline(always)]
    pub fn new(p: V3<f64>, q: V3<f64>) -> Edge {
        Edge {
            n: [
                p[1] * q[2] - p[2] * q[1],
                p[2] * q[0] - p[0] * q[2],
                p[0] * q[1] - p[1] * q[0],
            ],
            m: [
                (p[1] * q[2]).abs() + (p[2] * q[1]).abs(),
                (p[2] * q[0]).abs() + (p[0] * q[2]).abs(),
                (p[0] * q[1]).abs() + (p[1] * q[0]).abs(),
            ],
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
    /// Bound (u = 2⁻⁵³): each component n_x = fl(fl(P_y Q_z) − fl(P_z Q_y)) differs from the
    /// exact (p − o) × (q − o) by at most 4u·m_x + O(u²) (two inputs' subtraction errors, the
    /// product's and the difference's roundings); the box's extremes Σ min/max(lo_k n_k,
    /// hi_k n_k) are computed with at most 3u·Σ reach_k |n_k|. Since |n_k| ≤ m_k (1 + u),
    /// 8u·Σ reach_k m_k covers both with room for the O(u²) terms and the bound's own
    /// rounding (scaled up by 1 + 2⁻²⁰). Products that underflow lose at most 2⁻¹⁰⁷⁴ each:
    /// the absolute term covers them. NaN or infinity fails the comparisons: not certain.
    #[inline(always)]
    pub fn side(&self, b: &DirBox) -> i8 {
        let (mut low, mut high) = (0.0, 0.0);
        for k in 0..3 {
            let (x, y) = (b.lo[k] * self.n[k], b.hi[k] * self.n[k]);
            low += x.min(y);
            high += x.max(y);
        }
        certain_sign(low, high, self.bound(b))
    }

    /// The bound [`Edge::side`] allows for rounding over the box `b`: since every direction
    /// v in the box has |v_k| ≤ reach_k, it bounds the rounding of each one's v · n too
    /// ([`Edge::side_within`]).
    #[inline(always)]
    pub fn bound(&self, b: &DirBox) -> f64 {
        let size = (0..3).map(|k| b.reach[k] * self.m[k]).sum();
        rounding_bound(size)
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
        let size = v[0].abs() * self.m[0] + v[1].abs() * self.m[1] + v[2].abs() * self.m[2];
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
    pa: V3<f64>,
    pb: V3<f64>,
    pc: V3<f64>,
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
    ) -> Option<(u32, V3<f64>, [Edge; 3])> {
        debug_assert!(!L::INLINE);
        if self.link & CONSTRAINED_BIT != 0 || self.steps >= setup.max_steps {
            return None;
        }
        let d = setup.layout.new_vertex(self.link, self.a, self.b, self.c);
        let pd = relative(setup, origin, d);
        let edges = [
            Edge::new(pd, self.pa),
            Edge::new(pd, self.pb),
            Edge::new(pd, self.pc),
        ];
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

    /// Takes the step [`Packet::next`] found, leaving by `Exit::ROTATIONS[rotation]`, as
    /// `walk::plain_step` takes it for one ray.
    #[inline(always)]
    pub fn advance<R: Real, L: Layout>(
        &mut self,
        setup: &WalkSetup<R, L>,
        (d, pd): (u32, V3<f64>),
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

/// fl(p − o) for vertex v: what [`DirBox::side`] takes.
#[inline(always)]
fn relative<R: Real, L: Layout>(setup: &WalkSetup<R, L>, origin: V3<f64>, v: u32) -> V3<f64> {
    let p = setup.points[v as usize];
    [0, 1, 2].map(|k| p[k].to_f64() - origin[k])
}

#[cfg(test)]
mod tests {
    use super::{DirBox, Edge};
    use crate::geom::exact::side;

    /// A small deterministic generator (the tests need no statistics, only many cases).
    struct Lcg(u64);
    impl Lcg {
        fn unit(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Wherever the box test is certain, every direction in the box (its corners and random
    /// points) has that exact side, judged by `geom::exact::side`; and boxes straddling an
    /// edge's plane are found uncertain.
    #[test]
    fn box_side_is_the_exact_side_of_every_direction_in_the_box() {
        let mut rng = Lcg(7);
        let (mut certain, mut uncertain) = (0, 0);
        for case in 0..20000 {
            let o = [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0);
            let p = [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0);
            // Every other q on the plane through o, p and the box's centre direction, up to
            // rounding: sides at the rounding's scale, where the bound decides.
            let centre = [0, 1, 2].map(|_| rng.unit() * 2.0 - 1.0);
            let q = if case % 2 == 0 {
                let (s, r) = (rng.unit() * 3.0 - 1.5, rng.unit() * 3.0 - 1.5);
                [0, 1, 2].map(|k| o[k] + (p[k] - o[k]) * s + centre[k] * r)
            } else {
                [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0)
            };
            let width = [1e-1, 1e-4, 1e-12, 0.0][case / 2 % 4];
            let dirs: Vec<[f64; 3]> = (0..6)
                .map(|_| [0, 1, 2].map(|k| centre[k] + (rng.unit() - 0.5) * width))
                .collect();
            let b = DirBox::of(dirs.iter());
            let rel = |x: [f64; 3]| [0, 1, 2].map(|k| x[k] - o[k]);
            let edge = Edge::new(rel(p), rel(q));
            let s = edge.side(&b);
            // One direction alone, with its own bound or the box's: its exact side, or
            // uncertain.
            for v in &dirs {
                let one = edge.side_of(v);
                assert!(one == 0 || one == side(*v, o, p, q), "case {case}: one ray");
                let within = edge.side_within(v, edge.bound(&b));
                assert!(
                    within == 0 || within == side(*v, o, p, q),
                    "case {case}: in the box"
                );
            }
            let corners =
                (0..8).map(|m| [0, 1, 2].map(|k| if m >> k & 1 == 0 { b.lo[k] } else { b.hi[k] }));
            let sides: Vec<i8> = dirs
                .iter()
                .copied()
                .chain(corners)
                .map(|v| side(v, o, p, q))
                .collect();
            if s == 0 {
                uncertain += 1;
            } else {
                certain += 1;
                assert!(
                    sides.iter().all(|&x| x == s),
                    "case {case}: box says {s}, rays {sides:?}"
                );
            }
            if sides.iter().any(|&x| x != sides[0]) || sides[0] == 0 {
                assert_eq!(s, 0, "case {case}: a straddled box must be uncertain");
            }
        }
        // Both outcomes occur, so neither branch is vacuous.
        assert!(
            certain > 1000 && uncertain > 1000,
            "{certain} certain, {uncertain} uncertain"
        );
    }
}
