//! Hits finished on the device. Where the shared-origin kernel's walk crosses a constrained
//! face through its interior (every sign of the step certified), the kernel evaluates `t`,
//! `u`, `v` and the point on the caller's triangle in float32 double-word arithmetic with a
//! derived error bound (`shaders/methods/exact_hit.wgsl`), and keeps each value only where the
//! bound shows it is what the host would write: the float32 rounding of the host's float64
//! value (`geom::rounded`, within a float64 ulp of the exact one). That holds when no float32
//! rounding boundary lies within the bound plus 2^-50 |x| of the value. A hit it cannot
//! certify is handed back at the face, as before, and the host finishes it. So the answers
//! stay the CPU exact cast's, bit for bit (docs/gpu.md, "Hits finished on the device").
//!
//! This file is the kernel's CPU twin, operation for operation, and the table the kernel
//! reads: per constrained side the caller's triangle, and per triangle its words ([`TriWords`]:
//! the float64 corner in three float32 words, the edges as double-words).
//!
//! The arithmetic, and why it needs no fused multiply-add. A product `a b` is split as
//! `a = ah + al` by masking: `ah` keeps the 12 leading significant bits and `al = a − ah` the
//! other 12, so the four partial products are exact floats whether or not a compiler fuses
//! them into a multiply-add (a fused exact product rounds the same way). Two TwoSums (exact,
//! no products in them) gather them into `hi + lo` with `|hi + lo − ab| ≤ 10 ε² |ab|`: the
//! only roundings are two additions of terms of size at most `(ε + 2^-22 + 2^-34) |ab|`.
//! WGSL rounds `+`, `−` and `×` correctly; its division is within 2.5 ulp, which the quotient's
//! bound takes (`quotient`); a device may flush subnormal results to zero, which costs at most
//! 2^-126 a result, covered by the absolute terms below.

use super::context::Gpu;
use super::upload::upload_records;
use crate::error::Result;
use crate::scene::Scene;

/// Unit roundoff of float32.
pub const EPS: f32 = f32::from_bits(0x3380_0000); // 2^-24
/// The determinants' bound is `K ε² P + ABS` (`P` the permanent; see [`Det`]).
const K_EPS2: f32 = f32::from_bits(0x2b80_0000); // 256 ε² = 2^-40
/// Every result a device flushes to zero costs at most 2^-126; the determinants' operands
/// are scaled to magnitudes below 2 and a determinant takes fewer than 64 results, each
/// amplified by at most 8: far below this.
const ABS: f32 = f32::from_bits(0x0880_0000); // 2^-110
/// Corners and the origin: zero or of a magnitude in [2^-100, 2^100], so that their
/// differences are exact (no part of a TwoSum falls below the normal range) and the scale
/// that brings them near 1 is a normal float32 number.
const OPERAND_MIN: f32 = f32::from_bits(0x0d80_0000); // 2^-100
const OPERAND_MAX: f32 = f32::from_bits(0x7180_0000); // 2^100
/// The host's float64 value is within an ulp of the exact one: within 2^-51 |x| (2^-50 |x|
/// here, for the margin).
const HOST_SLACK: f32 = f32::from_bits(0x2680_0000); // 2^-50
/// Each bound below is formed in float32 with a few roundings, each within ε: it is
/// enlarged, and the room it is compared with reduced, by 2^-20 (≫ those roundings).
const SAFE: f32 = f32::from_bits(0x3580_0000); // 2^-20
/// 2^-126, the smallest normal float32 number.
const TINY: f32 = f32::MIN_POSITIVE;

/// A double-word value `hi + lo`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ff {
    pub hi: f32,
    pub lo: f32,
}

/// s + e = a + b exactly, s = fl(a + b) (Knuth's TwoSum).
#[inline(always)]
pub fn two_sum(a: f32, b: f32) -> (f32, f32) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// a = h + l exactly: h the 12 leading significant bits of a, l the other 12.
#[inline(always)]
fn split(a: f32) -> (f32, f32) {
    let h = f32::from_bits(a.to_bits() & 0xffff_f000);
    (h, a - h)
}

/// hi + lo within 10 ε² |a b| of a b (see the module docs), fused or not.
#[inline(always)]
pub fn two_prod(a: f32, b: f32) -> (f32, f32) {
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    let (m, me) = two_sum(ah * bl, al * bh);
    let (hi, lo) = two_sum(ah * bh, m);
    (hi, lo + (me + al * bl))
}

impl Ff {
    #[inline(always)]
    fn scaled(self, f: f32) -> Ff {
        Ff {
            hi: self.hi * f,
            lo: self.lo * f,
        }
    }
}

/// x × y for double-words x, y, and per component the sum of magnitudes of its two
/// products (which bounds its error as a multiple of ε²).
#[inline(always)]
fn cross(x: &[Ff; 3], y: &[Ff; 3]) -> ([Ff; 3], [f32; 3]) {
    let mut out = [Ff::default(); 3];
    let mut mag = [0.0; 3];
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let (p, pe) = two_prod(x[j].hi, y[k].hi);
        let (m, me) = two_prod(x[k].hi, y[j].hi);
        let (s, se) = two_sum(p, -m);
        let lo = se
            + (pe - me)
            + ((x[j].hi * y[k].lo + x[j].lo * y[k].hi) - (x[k].hi * y[j].lo + x[k].lo * y[j].hi));
        out[i] = Ff { hi: s, lo };
        mag[i] = p.abs() + m.abs();
    }
    (out, mag)
}

/// A determinant `x · c` (c a [`cross`] product with magnitudes `mag`; x a double-word with
/// a third word `x3`, see [`shifted`]), normalized, and its error bound
/// `K ε² P + 4 ε P₃ + ABS`, P = Σ (|x_i| + |x3_i|) mag_i, P₃ = Σ |x3_i| mag_i (the third word
/// is itself within 2ε of its exact value). K = 256: a cross component is within 26 ε² of its
/// magnitudes (its two products' 10 ε² each, the hi × lo products and their sums, the dropped
/// lo × lo), and the dot product adds its products' 10 ε², its lo sum's roundings (at most
/// 38 ε² P over eleven additions of terms summing to 8 ε P at most), the rounded and dropped
/// products (9 ε² P) and the cross product's error times |x|: at most 83 ε² P; the edges'
/// own representation (within 1.01 ε² of the exact edges, [`edge`]) adds at most 3 ε² P:
/// a margin near three.
#[inline(always)]
fn det(x: &[Ff; 3], x3: &[f32; 3], c: &[Ff; 3], mag: &[f32; 3]) -> (Ff, f32) {
    let (p0, e0) = two_prod(x[0].hi, c[0].hi);
    let (p1, e1) = two_prod(x[1].hi, c[1].hi);
    let (p2, e2) = two_prod(x[2].hi, c[2].hi);
    let (s, s1) = two_sum(p0, p1);
    let (s, s2) = two_sum(s, p2);
    let lo = (s1 + s2)
        + (e0 + e1 + e2)
        + (x[0].hi * c[0].lo + x[1].hi * c[1].lo + x[2].hi * c[2].lo)
        + ((x[0].lo + x3[0]) * c[0].hi + (x[1].lo + x3[1]) * c[1].hi + (x[2].lo + x3[2]) * c[2].hi);
    let p3 = x3[0].abs() * mag[0] + x3[1].abs() * mag[1] + x3[2].abs() * mag[2];
    let perm = x[0].hi.abs() * mag[0] + x[1].hi.abs() * mag[1] + x[2].hi.abs() * mag[2] + p3;
    let (hi, lo) = two_sum(s, lo);
    (Ff { hi, lo }, K_EPS2 * perm + 4.0 * EPS * p3 + ABS)
}

/// w − λ d, for w = w.hi + w.lo + w2 (w2 a small third word) and λ of at most 12 significant
/// bits (then λ d_k is exactly a double-word, [`two_prod`]'s four partial products being
/// exact): a normalized double-word, exact, and a third word (the small remainders and w2,
/// summed with two roundings: within 2ε of their sum, which [`det`] bounds). With λ near the
/// ray parameter of the corner `a`, the result is short (about the triangle's size, not the
/// origin's distance), and so are the determinants' permanents and errors: a far origin costs
/// no accuracy.
#[inline(always)]
fn shifted(w: Ff, w2: f32, lambda: f32, d: f32) -> (Ff, f32) {
    let (ph, pl) = two_prod(lambda, d);
    let (s, e) = two_sum(w.hi, -ph);
    let (f, g) = two_sum(w.lo, -pl);
    let (h, l) = two_sum(s, f);
    let (l2, g2) = two_sum(l, e);
    let (hi, lo) = two_sum(h, l2);
    (Ff { hi, lo }, (g + g2) + w2)
}

/// x cut to its 12 leading significant bits.
#[inline(always)]
fn leading12(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0xffff_f000)
}

/// n / d for double-words n, d within `n_err`, `d_err` of their exact values: `(q, c, err)`
/// with `|q + c − n*/d*| ≤ err`; None unless d is certainly nonzero. q is any approximation
/// of the quotient (WGSL's division is within 2.5 ulp); the remainder corrects it.
#[inline(always)]
fn quotient(n: Ff, n_err: f32, d: Ff, d_err: f32) -> Option<(f32, f32, f32)> {
    let dh = d.hi.abs();
    // Operands are bounded (2^100) and scaled below 2: nothing here overflows.
    if dh.partial_cmp(&(2.0 * d_err)) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let q = n.hi / d.hi;
    let (p, pe) = two_prod(q, d.hi);
    let r0 = n.hi - p;
    let r = r0 - pe;
    let ql = q * d.lo;
    let c = ((r + n.lo) - ql) / d.hi;
    // The remainder's roundings (r0, r, the sum with lo and q·dlo: ε each of its terms), the
    // product's 10 ε², the division (2.5 ulp ≤ 5 ε) and the dropped d.lo in the divisor
    // (|d.lo| ≤ ε |d.hi|, normalized), each doubled; and results flushed to zero.
    let div = 16.0 * EPS * c.abs()
        + (8.0 * EPS * (r.abs() + n.lo.abs() + ql.abs())
            + 2.0 * EPS * r0.abs()
            + 16.0 * EPS * EPS * p.abs()
            + 8.0 * TINY)
            / dh;
    // The errors of n and d, carried through the quotient.
    let prop = (n_err + (q.abs() * (1.0 + 4.0 * EPS) + c.abs()) * d_err)
        / (dh * (1.0 - 4.0 * EPS) - d_err);
    Some((q, c, (div + prop) * (1.0 + 16.0 * EPS)))
}

/// The float32 number the host writes for a value `q + c` within `err` of the exact one,
/// when certain: the float32 rounding of `q + c`, if no rounding boundary (a midpoint of
/// float32 neighbours) lies within `err` plus the host's float64 slack of it. Normal
/// results below 2^126 only.
#[inline(always)]
pub fn certify(q: f32, c: f32, err: f32) -> Option<f32> {
    let (s, e) = two_sum(q, c);
    let mag = s.abs();
    let bits = mag.to_bits();
    // Exponent field 1..=252: normal, and its upper neighbour finite.
    if !(0x0080_0000..0x7e00_0000).contains(&bits) {
        return None;
    }
    let up = f32::from_bits(bits + 1) - mag;
    let down = mag - f32::from_bits(bits - 1);
    // e, signed toward |s|'s larger neighbour.
    let es = if s > 0.0 { e } else { -e };
    let total = (err + HOST_SLACK * mag + TINY) * (1.0 + SAFE);
    let room_up = (0.5 * up - es) * (1.0 - SAFE);
    let room_down = (0.5 * down + es) * (1.0 - SAFE);
    (total < room_up && total < room_down).then_some(s)
}

/// What a finished hit writes, each value the one the host would write.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Finished {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub point: [f32; 3],
}

/// Read from the bits, as the kernel must (a device may take a subnormal for zero).
fn operand_ok(x: f32) -> bool {
    let b = x.to_bits() & 0x7fff_ffff;
    b == 0 || (OPERAND_MIN.to_bits()..=OPERAND_MAX.to_bits()).contains(&b)
}

/// Zero or normal (a direction component a device could flush is left to the host).
fn zero_or_normal(x: f32) -> bool {
    let b = x.to_bits() & 0x7fff_ffff;
    b == 0 || b & 0x7f80_0000 != 0
}

/// 2^k as a float32 number, for k in [−126, 127].
#[inline(always)]
fn pow2(k: i32) -> f32 {
    f32::from_bits(((k + 127) as u32) << 23)
}

/// The caller's triangle as the kernel reads it (21 words of the hit table): the corner `a`
/// in three float32 words per coordinate (exactly its float64 value), and the edges b − a and
/// c − a as double-words within 1.01 ε² |hi| of the exact differences, per component.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriWords {
    pub a: [[f32; 3]; 3],
    pub e1: [Ff; 3],
    pub e2: [Ff; 3],
}

/// x as three float32 words, exactly (None when it cannot be, or a word would be subnormal).
fn words3(x: f64) -> Option<[f32; 3]> {
    let hi = x as f32;
    let r = x - hi as f64;
    let mid = r as f32;
    let r2 = r - mid as f64;
    let lo = r2 as f32;
    let ok = operand_ok(hi) && zero_or_normal(mid) && zero_or_normal(lo) && lo as f64 == r2;
    ok.then_some([hi, mid, lo])
}

/// p − q as a float32 double-word within 1.01 ε² |hi| of the exact difference: the exact
/// float64 pair (TwoSum) rounded, its remainder s − hi exact, the low word rounded twice
/// (2^-53 and 2^-24 of a value at most 2^-24 |hi| (1 + 2^-28)).
fn edge(p: f64, q: f64) -> Option<Ff> {
    let s = p - q;
    let bv = s - p;
    let t = (p - (s - bv)) + (-q - bv);
    let hi = s as f32;
    let lo = ((s - hi as f64) + t) as f32;
    (operand_ok(hi) && zero_or_normal(lo)).then_some(Ff { hi, lo })
}

/// The kernel's words for a caller's triangle, or None where it must leave its hits to the
/// host (a coordinate beyond the words' range).
pub fn tri_words(tri: &[[f64; 3]; 3]) -> Option<TriWords> {
    let [a, b, c] = *tri;
    let mut out = TriWords::default();
    for k in 0..3 {
        out.a[k] = words3(a[k])?;
        out.e1[k] = edge(b[k], a[k])?;
        out.e2[k] = edge(c[k], a[k])?;
    }
    Some(out)
}

/// The hit of the ray from `o` with direction `d` on the triangle `tri` (its words), finished
/// when certain. `d` is the caller's direction times 2^`d_exp` with its largest component in
/// [1, 2), as the kernel scales it; `o` is the caller's float32 origin. None: the host finishes
/// the hit (a value not certain, t not positive, an operand out of range).
pub fn finish_hit(o: [f32; 3], d: [f32; 3], d_exp: i32, tri: &TriWords) -> Option<Finished> {
    if !o.iter().all(|&x| operand_ok(x)) || !d.iter().all(|&x| zero_or_normal(x)) {
        return None;
    }
    let (e1, e2) = (tri.e1, tri.e2);
    // w = a − o exactly: a double-word and a small third word (within ε of it).
    let w = [0, 1, 2].map(|k| {
        let [a0, a1, a2] = tri.a[k];
        let (s0, e0) = two_sum(a0, -o[k]);
        let (x, y) = two_sum(e0, a1);
        let (hi, lo) = two_sum(s0, x);
        (Ff { hi, lo }, y + a2)
    });
    // The origin moved along the line to near the corner's parameter λ (12 bits): t = λ + t'
    // with t' from the shifted determinants; u and v do not change.
    let lambda = leading12(
        (w[0].0.hi * d[0] + w[1].0.hi * d[1] + w[2].0.hi * d[2])
            / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]),
    );
    let ws = [0, 1, 2].map(|k| shifted(w[k].0, w[k].1, lambda, d[k]));
    // The short vectors scaled by one power of two to a largest magnitude in [1, 2): exact
    // (a part pushed below the normal range is flushed at worst, within ABS); t scales with it.
    let m = ws
        .iter()
        .map(|x| x.0)
        .chain(e1)
        .chain(e2)
        .fold(0.0f32, |m, x| m.max(x.hi.abs()));
    if m == 0.0 {
        return None;
    }
    let k = 127 - ((m.to_bits() >> 23) & 0xff) as i32;
    let f = pow2(k);
    let w3 = ws.map(|x| x.1 * f);
    let ws = ws.map(|x| x.0.scaled(f));
    let (e1s, e2s) = (e1.map(|x| x.scaled(f)), e2.map(|x| x.scaled(f)));
    let dd = d.map(|x| Ff { hi: x, lo: 0.0 });
    let (n, n_mag) = cross(&e1s, &e2s);
    let (m2, m2_mag) = cross(&dd, &e2s);
    let (m1, m1_mag) = cross(&e1s, &dd);
    let (num, num_err) = det(&ws, &w3, &n, &n_mag);
    let (den, den_err) = det(&dd, &[0.0; 3], &n, &n_mag);
    let (num_u, num_u_err) = det(&ws, &w3, &m2, &m2_mag);
    let (num_v, num_v_err) = det(&ws, &w3, &m1, &m1_mag);

    // t · 2^k (in units of the scaled direction) = λ 2^k + t'.
    let (q, c, err) = quotient(num, num_err, den, den_err)?;
    let (s, e) = two_sum(lambda * f, q);
    let rest = e + c;
    let ts = certify(s, rest, err + EPS * rest.abs())?;
    if ts <= 0.0 {
        return None;
    }
    // Back to the caller's units: t = ts · 2^(d_exp − k), exactly, if it stays normal.
    let e = ((ts.to_bits() >> 23) & 0xff) as i32 + d_exp - k;
    if !(1..=254).contains(&e) {
        return None;
    }
    let t = f32::from_bits((ts.to_bits() & 0x807f_ffff) | ((e as u32) << 23));
    let uq = quotient(num_u, num_u_err, den, den_err)?;
    let vq = quotient(num_v, num_v_err, den, den_err)?;
    let u = certify(uq.0, uq.1, uq.2)?;
    let v = certify(vq.0, vq.1, vq.2)?;
    let mut point = [0.0f32; 3];
    for i in 0..3 {
        point[i] = point_coordinate(tri.a[i], e1[i], e2[i], uq, vq)?;
    }
    Some(Finished { t, u, v, point })
}

/// Coordinate `a + u e1 + v e2` of the point (a in three words; u, v as [`quotient`] gives
/// them), when certain. Where both edges are flat on this axis it is `a` exactly, which the
/// host rounds to `a`'s high word (but a −0 there: the host's sign of zero follows its own
/// products).
#[inline(always)]
fn point_coordinate(
    a: [f32; 3],
    e1: Ff,
    e2: Ff,
    u: (f32, f32, f32),
    v: (f32, f32, f32),
) -> Option<f32> {
    if e1.hi == 0.0 && e1.lo == 0.0 && e2.hi == 0.0 && e2.lo == 0.0 {
        return (a[0].to_bits() != 0x8000_0000).then_some(a[0]);
    }
    let (p1, p1e) = two_prod(u.0, e1.hi);
    let (p2, p2e) = two_prod(v.0, e2.hi);
    let (s1, s1e) = two_sum(a[0], p1);
    let (s2, s2e) = two_sum(s1, p2);
    let terms = [
        a[1],
        a[2],
        p1e,
        p2e,
        s1e,
        s2e,
        u.0 * e1.lo,
        u.1 * e1.hi,
        v.0 * e2.lo,
        v.1 * e2.hi,
    ];
    let mut rest = 0.0f32;
    let mut size = 0.0f32;
    for x in terms {
        rest += x;
        size += x.abs();
    }
    // The sum's roundings (ten terms), the products' 10 ε², the dropped c·lo products
    // (≤ ε |c| |hi|), the edges' own 1.01 ε², the errors of u and v times the edges, and
    // flushed results.
    let err = 10.0 * EPS * size
        + 16.0 * EPS * EPS * (p1.abs() + p2.abs())
        + EPS * (u.1.abs() * e1.hi.abs() + v.1.abs() * e2.hi.abs())
        + 2.0 * EPS * EPS * (u.0.abs() * e1.hi.abs() + v.0.abs() * e2.hi.abs())
        + u.2 * (e1.hi.abs() + e1.lo.abs())
        + v.2 * (e2.hi.abs() + e2.lo.abs())
        + 32.0 * TINY;
    certify(s2, rest, err)
}

/// The kernel's table (binding 9): per constrained side, the caller's triangle its face lies
/// on, or [`NONE`] where the host must decide (a triangle with alternatives, or a coordinate
/// beyond the words' range); then, from word `sides`, [`TRI_WORDS`] words per triangle
/// ([`TriWords`]: a's three words per coordinate, then e1's and e2's two); last, 0 (the
/// kernel's `zero_bits`, exact_hit.wgsl).
pub struct HitTable {
    pub buffer: wgpu::Buffer,
    /// Where the triangles' words begin (the number of sides).
    pub sides: u32,
}

/// A side whose hits the kernel leaves to the host.
pub const NONE: u32 = u32::MAX;

/// Words per triangle in the table.
pub const TRI_WORDS: usize = 21;

impl HitTable {
    pub(crate) fn bytes(&self) -> u64 {
        self.buffer.size()
    }
}

impl TriWords {
    /// As the table holds them.
    fn words(&self) -> [u32; TRI_WORDS] {
        let mut w = [0u32; TRI_WORDS];
        for k in 0..3 {
            for j in 0..3 {
                w[3 * k + j] = self.a[k][j].to_bits();
            }
            w[9 + 2 * k] = self.e1[k].hi.to_bits();
            w[10 + 2 * k] = self.e1[k].lo.to_bits();
            w[15 + 2 * k] = self.e2[k].hi.to_bits();
            w[16 + 2 * k] = self.e2[k].lo.to_bits();
        }
        w
    }
}

/// The table's words (see [`HitTable`]).
pub(crate) fn hit_table(scene: &Scene) -> (Vec<u32>, u32) {
    let tris = &scene.surface.triangles;
    let words: Vec<Option<TriWords>> = tris
        .iter()
        .enumerate()
        .map(|(k, t)| {
            if scene.surface.alternatives.of(k as u32).is_empty() {
                tri_words(t)
            } else {
                None
            }
        })
        .collect();
    let sides = scene.mesh.constrained.len();
    let mut out = Vec::with_capacity(sides + TRI_WORDS * tris.len() + 1);
    out.extend(scene.mesh.constrained.iter().map(|s| {
        if words[s.triangle as usize].is_some() {
            s.triangle
        } else {
            NONE
        }
    }));
    for w in &words {
        out.extend(w.unwrap_or_default().words());
    }
    // 0, which the kernel reads as `zero_bits` (exact_hit.wgsl: a value no compiler knows).
    out.push(0);
    (out, sides as u32)
}

/// Uploads the table for the shared-origin kernel.
pub(crate) fn upload_hit_table(g: &Gpu, scene: &Scene) -> Result<HitTable> {
    let (words, sides) = hit_table(scene);
    let buffer = upload_records(g, "triangles for finishing hits", words.len(), |i| words[i])?;
    Ok(HitTable { buffer, sides })
}

#[cfg(test)]
mod tests;
