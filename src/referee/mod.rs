//! The exact referee of `docs/referee.md`, Rust twin of `python/tetrace/referee.py`: what the
//! right answer to a ray is, for the numbers passed in.
//!
//! A ray `(o, d)` meets the closed triangle `(a, b, c)` at one point when its three side
//! products `S_ab = d · ((a − o) × (b − o))`, `S_bc`, `S_ca` are all `≥ 0` or all `≤ 0` and not
//! all zero (all zero: the line lies in the triangle's plane, the triangle has no area or
//! `d = 0`, and it is never hit). The crossing is at `t = num / den` with
//! `num = (a − o) · ((b − o) × (c − o))`, `den = S_ab + S_bc + S_ca`. A hit is a crossing with
//! `tmin ≤ t ≤ tmax`; a ray's answer is its smallest hit `t*` and every triangle hit there.
//!
//! Everything is decided exactly on the f64 inputs. A float64 evaluation with Shewchuk's
//! certified error bound (`(7 + 56ε)ε` times the permanent) decides the clear cases; its
//! operands are kept where no product can underflow or overflow (else it is skipped). What it
//! cannot certify is evaluated in `BigInt`s: every finite f64 is `m · 2^e`, so all inputs of a
//! ray–triangle pair scaled by one power of two are integers, and every sign and every ratio
//! of two polynomials of the same degree keeps its value.
//!
//! This module reads the caller's numbers and nothing else: it shares no code with the walk
//! (`traverse`, `layout`, `scene`, `geom`).

use num_bigint::{BigInt, BigUint, Sign};
use num_traits::{ToPrimitive, Zero};
use std::cmp::Ordering;

mod exact;
mod filter;
#[cfg(test)]
mod tests;

use exact::*;
use filter::*;

/// A point or vector.
pub type P3 = [f64; 3];
/// A triangle's three vertices.
pub type Tri = [P3; 3];

/// Unit roundoff of float64.
const EPS: f64 = f64::EPSILON / 2.0;
/// Shewchuk's bound on the error of a float64 3×3 determinant of rounded differences, times its
/// permanent (orient3d's `errboundA`).
const FILTER: f64 = (7.0 + 56.0 * EPS) * EPS;
/// The filter's operands (the differences and `d`) must be zero or have a magnitude in
/// [2^-300, 2^300]: products of three then lie in [2^-900, 2^900] (normal; a cross product's
/// cancellation leaves a multiple of 2^-652, times `d` still normal), and their sums stay
/// finite. Outside, an underflowed product's absolute error could exceed the relative bound
/// (or a product overflow): the pair goes to the exact path.
const OPERAND_MIN: f64 = 4.909093465297727e-91; // 2^-300
const OPERAND_MAX: f64 = 2.037035976334486e90; // 2^300

/// Where the ray's line meets a closed triangle at one point, exactly.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Crossing {
    /// `t = num / den` exactly, `den > 0` (both scaled by the same power of two).
    pub num: BigInt,
    pub den: BigInt,
    /// How many side products are exactly zero: 0 inside, 1 on an edge, 2 at a vertex.
    pub zero_signs: u8,
}

impl Crossing {
    /// The exact `t`, rounded to the nearest float64 (ties to even).
    pub fn t(&self) -> f64 {
        round_quotient(&self.num, &self.den)
    }

    /// The sign of `t − x`, exactly (`x` finite or infinite, not NaN).
    pub fn cmp_t(&self, x: f64) -> Ordering {
        if x == f64::INFINITY {
            return Ordering::Less;
        }
        if x == f64::NEG_INFINITY {
            return Ordering::Greater;
        }
        let (m, e) = decode(x);
        // num / den vs m 2^e, den > 0: num 2^-e vs m den (or num vs m den 2^e).
        let rhs = &self.den * BigInt::from(m);
        if e >= 0 {
            self.num.cmp(&(rhs << e as usize))
        } else {
            (&self.num << (-e) as usize).cmp(&rhs)
        }
    }

    /// The sign of `t − other.t`, exactly.
    pub fn cmp_t_of(&self, other: &Crossing) -> Ordering {
        (&self.num * &other.den).cmp(&(&other.num * &self.den))
    }

    /// Whether `|x − t| ≤ ulp(t)` exactly, `ulp(t)` the spacing of `precision` in the binade
    /// of the exact `t` (its smallest subnormal spacing at 0 and below the normal range): the
    /// contract's one-ulp rule. False for a non-finite `x`.
    pub fn within_ulp(&self, x: f64, precision: Precision) -> bool {
        if !x.is_finite() {
            return false;
        }
        let (bits, emin) = match precision {
            Precision::F32 => (24, -126),
            Precision::F64 => (53, -1022),
        };
        // floor(log2 |t|): |num| / den lies in [2^(b-1), 2^(b+1)), b the bit lengths' gap.
        let k = if self.num.is_zero() {
            emin - (bits - 1)
        } else {
            let n = self.num.magnitude();
            let d = self.den.magnitude();
            let b = n.bits() as i64 - d.bits() as i64;
            let at_least = if b >= 0 {
                n >= &(d << b as usize)
            } else {
                &(n << (-b) as usize) >= d
            };
            let e = if at_least { b } else { b - 1 };
            e.max(emin) - (bits - 1)
        };
        // |m 2^ex den − num| ≤ 2^k den, all scaled by 2^-z to integers.
        let (m, ex) = decode(x);
        let z = ex.min(k).min(0);
        let shift = |v: &BigInt, s: i64| v << (s - z) as usize;
        let lhs = (shift(&(&self.den * BigInt::from(m)), ex) - shift(&self.num, 0))
            .magnitude()
            .clone();
        let rhs = shift(&self.den, k).magnitude().clone();
        lhs <= rhs
    }
}

/// The float type a caster reports `t` in: the ulp the contract allows is that type's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Precision {
    F32,
    F64,
}

/// A ray's exact answer.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    /// The exact first-hit `t*`, rounded to the nearest float64.
    pub t: f64,
    /// Every triangle hit at exactly `t*`, ascending (indices into the caller's slice).
    pub ties: Vec<usize>,
    /// Zero side products of the first tie's crossing (1: on an edge, 2: at a vertex).
    pub zero_signs: u8,
    /// `B` of docs/referee.md on the first tie ([`t_bound`]): information only (how far a
    /// plain float64 evaluation could stray); judging uses the exact `t*`.
    pub bound: f64,
    /// The first tie's crossing: `t*` exactly.
    pub exact: Crossing,
}

impl Verdict {
    /// Whether `triangle` is in the tie set.
    pub fn ties_with(&self, triangle: usize) -> bool {
        self.ties.binary_search(&triangle).is_ok()
    }
}

/// How a cast of one ray compares with the referee (docs/referee.md), in order of precedence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Outcome {
    /// Hit exactly when the referee hits, on a tied triangle, `|t − t*| ≤ ulp(t*)` exactly.
    Right,
    /// The caster gave up.
    Failed,
    /// The referee hits, the caster reports a miss.
    Leaked,
    /// Both hit; the caster's triangle is not tied and its `t` is past `t*` (by more than an
    /// ulp): the walk went through the first hit.
    Late,
    /// Anything else: a hit where the referee misses, another triangle before (or at) `t*`, or
    /// `t` more than an ulp from `t*`.
    Wrong,
}

/// Exact sign of `S = d · ((p − o) × (q − o))`: the side of the edge `p → q` seen along the
/// line (positive: counter-clockwise around `d`). Inputs must be finite (panics otherwise).
pub fn side(o: P3, d: P3, p: P3, q: P3) -> Ordering {
    assert!(
        [o, d, p, q].iter().flatten().all(|x| x.is_finite()),
        "referee::side: non-finite input"
    );
    let (u, v) = (sub(p, o), sub(q, o));
    if operands_ok(&[d, u, v]) {
        let s = dot(d, cross(u, v));
        let bound = FILTER * perm(d, u, v);
        if s > bound {
            return Ordering::Greater;
        }
        if s < -bound {
            return Ordering::Less;
        }
    }
    count_exact();
    let x = Scaled::new(&[o, d, p, q]);
    let (o, d, p, q) = (&x.v[0], &x.v[1], &x.v[2], &x.v[3]);
    let s = bdot(d, &bcross(&bsub(p, o), &bsub(q, o)));
    s.sign_ord()
}

/// Whether the line `o + t d` meets the closed triangle at one point, and where, exactly. `None`
/// when it does not, when the line lies in the triangle's plane (or the triangle has no area,
/// or `d = 0`), or when an input is not finite.
pub fn crossing(o: P3, d: P3, tri: &Tri) -> Option<Crossing> {
    if !finite(o, d, tri) {
        return None;
    }
    if let Filtered::Miss = filter(o, d, tri) {
        return None;
    }
    exact(o, d, tri).crossing()
}

/// The exact first hit of the ray among `tris` (brute force over all of them): the crossings
/// with `tmin ≤ t ≤ tmax`, the smallest `t` and every triangle tied there. `None`: a miss, or a
/// ray the referee refuses (a non-finite origin or direction, `d = 0`, a NaN bound).
/// Triangles with a non-finite vertex are never hit.
pub fn first_hit(o: P3, d: P3, tmin: f64, tmax: f64, tris: &[Tri]) -> Option<Verdict> {
    first_hit_by(o, d, tmin, tmax, tris, |_| true)
}

/// [`first_hit`] among the crossings `accept` keeps (it sees each crossing's
/// `zero_signs`; e.g. `|z| z == 0` for crossings strictly inside the triangles).
pub fn first_hit_by(
    o: P3,
    d: P3,
    tmin: f64,
    tmax: f64,
    tris: &[Tri],
    accept: impl Fn(u8) -> bool,
) -> Option<Verdict> {
    let ray_ok = o.iter().chain(&d).all(|x| x.is_finite())
        && d.iter().any(|&x| x != 0.0)
        && !tmin.is_nan()
        && !tmax.is_nan();
    if !ray_ok {
        return None;
    }
    struct Cand {
        k: usize,
        lo: f64,
        hi: f64,
        exact: Option<Crossing>,
    }
    let mut inside: Vec<Cand> = Vec::new();
    for (k, tri) in tris.iter().enumerate() {
        if !finite(o, d, tri) {
            continue;
        }
        let mut c = match filter(o, d, tri) {
            Filtered::Miss => continue,
            Filtered::Meets { lo, hi } if accept(0) => Cand {
                k,
                lo,
                hi,
                exact: None,
            },
            _ => match exact(o, d, tri).crossing() {
                Some(x) if accept(x.zero_signs) => {
                    let t = x.t();
                    Cand {
                        k,
                        lo: t.next_down(),
                        hi: t.next_up(),
                        exact: Some(x),
                    }
                }
                _ => continue,
            },
        };
        // In [tmin, tmax]: sure from the interval, else exactly.
        if c.hi < tmin || c.lo > tmax {
            continue;
        }
        if !(c.lo > tmin && c.hi < tmax) {
            let x = c.exact.get_or_insert_with(|| {
                exact(o, d, tri)
                    .crossing()
                    .expect("the filter certified a crossing")
            });
            if x.cmp_t(tmin) == Ordering::Less || x.cmp_t(tmax) == Ordering::Greater {
                continue;
            }
        }
        inside.push(c);
    }
    // The first hit has the smallest exact t; every hit whose interval reaches below the
    // smallest upper end may be it (or tie with it): those are compared exactly.
    let best_hi = inside.iter().map(|c| c.hi).fold(f64::INFINITY, f64::min);
    let mut contenders: Vec<(usize, Crossing)> = inside
        .into_iter()
        .filter(|c| c.lo <= best_hi)
        .map(|c| {
            let x = c.exact.unwrap_or_else(|| {
                exact(o, d, &tris[c.k])
                    .crossing()
                    .expect("the filter certified a crossing")
            });
            (c.k, x)
        })
        .collect();
    let mut first: Option<&Crossing> = None;
    for (_, x) in &contenders {
        if first.is_none_or(|f| x.cmp_t_of(f) == Ordering::Less) {
            first = Some(x);
        }
    }
    let first = first?.clone();
    // Contenders are in the order of `tris`: the ties come out ascending.
    contenders.retain(|(_, x)| x.cmp_t_of(&first) == Ordering::Equal);
    let k0 = contenders[0].0;
    let t = first.t();
    Some(Verdict {
        t,
        ties: contenders.iter().map(|(k, _)| *k).collect(),
        zero_signs: contenders[0].1.zero_signs,
        bound: t_bound(o, d, &tris[k0], t),
        exact: contenders.swap_remove(0).1,
    })
}

/// The derived float64 forward-error bound `B` of docs/referee.md for a float64 evaluation of
/// the ray–plane quotient on `tri` at `t_star`: the errors of `num` and `den` are at most
/// `8ε P_num` and `8ε P_den` with `P` their permanents, anchored at the ray's origin and at the
/// triangle's first vertex (both summed, so either evaluation is covered), and the quotient
/// rounds twice (`2ε|t*|`): `B = (8ε P_num + |t*| 8ε P_den) / |den| + 2ε|t*|`, `|den|` the exact
/// value (rounded). Infinite when `den = 0`.
pub fn t_bound(o: P3, d: P3, tri: &Tri, t_star: f64) -> f64 {
    let [a, b, c] = *tri;
    let (u, v, w) = (sub(a, o), sub(b, o), sub(c, o));
    let (e1, e2, tv) = (sub(b, a), sub(c, a), sub(o, a));
    let p_num = perm(u, v, w) + perm(e2, tv, e1);
    let p_den = perm(d, u, v) + perm(d, v, w) + perm(d, w, u) + perm(d, e1, e2);
    let den = exact_den_abs(o, d, tri);
    let t = t_star.abs();
    (8.0 * EPS * p_num + t * 8.0 * EPS * p_den) / den + 2.0 * EPS * t
}

/// Judges one cast of a ray against the referee's verdict (`None`: the referee misses).
/// `failed`: the caster gave up; `hit`: its triangle and `t` (as float64), `None` for a miss;
/// `precision`: the float type the caster reports `t` in (its ulp is the one allowed).
pub fn judge(
    verdict: Option<&Verdict>,
    failed: bool,
    hit: Option<(usize, f64)>,
    precision: Precision,
) -> Outcome {
    if failed {
        return Outcome::Failed;
    }
    match (verdict, hit) {
        (None, None) => Outcome::Right,
        (Some(_), None) => Outcome::Leaked,
        (None, Some(_)) => Outcome::Wrong,
        (Some(v), Some((tri, t))) => {
            let close = v.exact.within_ulp(t, precision);
            if v.ties_with(tri) {
                if close {
                    Outcome::Right
                } else {
                    Outcome::Wrong
                }
            } else if !close && v.exact.cmp_t(t) == Ordering::Less {
                Outcome::Late
            } else {
                Outcome::Wrong
            }
        }
    }
}

/// Spacing of float32 at `|t|` (rounded to float32), as float64.
pub fn ulp_f32(t: f64) -> f64 {
    let x = (t.abs() as f32).min(f32::MAX);
    (x.next_up() - x) as f64
}

/// Spacing of float64 at `|t|`.
pub fn ulp_f64(t: f64) -> f64 {
    let x = t.abs().min(f64::MAX);
    x.next_up() - x
}
