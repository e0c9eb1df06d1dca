// Hits finished on the device (src/gpu/finish.rs is its CPU twin, operation for operation, and
// says why each step is exact or bounded): t, u, v and the point of a ray's hit on the
// caller's triangle, in float32 double-word arithmetic, each kept only where its bound shows
// it is the float32 rounding of the host's float64 value (no rounding boundary within the
// bound plus 2^-50 |x|). Products are split by masking, so their partial products are exact
// whether or not the compiler fuses them; what must stay exact is kept from algebraic
// rewriting (`opaque`);
// finiteness and zero are read from the bits, since WGSL may assume finite math and devices
// may flush subnormals.

const F_EPS: f32 = 0x1p-24f;
const F_K_EPS2: f32 = 0x1p-40f;
const F_ABS: f32 = 0x1p-110f;
const F_HOST_SLACK: f32 = 0x1p-50f;
const F_SAFE: f32 = 0x1p-20f;
const F_TINY: f32 = 0x1p-126f;
// Bits of 2^-100 and 2^100: operands are zero or have a magnitude between them.
const F_OPERAND_MIN_BITS: u32 = 0x0d800000u;
const F_OPERAND_MAX_BITS: u32 = 0x71800000u;

struct Ff {
    hi: f32,
    lo: f32,
}

// Three double-words (a vector), and a cross product with its magnitudes.
struct V3 {
    hi: vec3<f32>,
    lo: vec3<f32>,
}

struct Cross {
    v: V3,
    mag: vec3<f32>,
}

struct Det {
    v: Ff,
    err: f32,
}

struct Quo {
    q: f32,
    c: f32,
    err: f32,
    ok: bool,
}

struct Cert {
    x: f32,
    ok: bool,
}

struct Finished {
    t: f32,
    u: f32,
    v: f32,
    p: vec3<f32>,
    ok: bool,
}

// 0, read by the kernel's main from a storage buffer (the hit table's last word), so that no
// compiler can know it: `opaque` xors a value's bits with it. WGSL has no `precise`, naga
// marks no operation NoContraction, and a driver may compile float arithmetic with
// reassociation allowed (lavapipe's LLVM does: it rewrote (a + b) − a to b, and factored out
// and cancelled a multiplication by a 1.0 meant to hide the sum). An integer xor with an
// unknown value is a wall no float rewrite crosses; a uniform will not do either (lavapipe
// inlines small uniform buffers' values into the shader).
var<private> zero_bits: u32;

// x, unchanged, as a value the compiler knows nothing about.
fn opaque(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) ^ zero_bits);
}

fn opaque3(x: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(x) ^ vec3<u32>(zero_bits));
}

// Knuth's TwoSum, each step behind `opaque` so that no rewrite sees the cancellations it
// relies on.
fn two_sum(a: f32, b: f32) -> Ff {
    let s = opaque(a + b);
    let bv = opaque(s - a);
    let av = opaque(s - bv);
    return Ff(s, opaque(a - av) + opaque(b - bv));
}

fn split(a: f32) -> vec2<f32> {
    let x = opaque(a);
    let h = bitcast<f32>(bitcast<u32>(x) & 0xfffff000u);
    return vec2<f32>(h, opaque(x - h));
}

fn two_prod(a: f32, b: f32) -> Ff {
    let x = split(a);
    let y = split(b);
    let m = two_sum(x.x * y.y, x.y * y.x);
    let h = two_sum(x.x * y.x, m.hi);
    return Ff(h.hi, h.lo + (m.lo + x.y * y.y));
}

fn cross_ff(x: V3, y: V3) -> Cross {
    var out: Cross;
    for (var i = 0u; i < 3u; i++) {
        let j = (i + 1u) % 3u;
        let k = (i + 2u) % 3u;
        let p = two_prod(x.hi[j], y.hi[k]);
        let m = two_prod(x.hi[k], y.hi[j]);
        let s = two_sum(p.hi, -m.hi);
        let lo = s.lo + (p.lo - m.lo)
            + ((x.hi[j] * y.lo[k] + x.lo[j] * y.hi[k]) - (x.hi[k] * y.lo[j] + x.lo[k] * y.hi[j]));
        out.v.hi[i] = s.hi;
        out.v.lo[i] = lo;
        out.mag[i] = abs(p.hi) + abs(m.hi);
    }
    return out;
}

fn det_ff(x: V3, x3: vec3<f32>, c: Cross) -> Det {
    let p0 = two_prod(x.hi.x, c.v.hi.x);
    let p1 = two_prod(x.hi.y, c.v.hi.y);
    let p2 = two_prod(x.hi.z, c.v.hi.z);
    let s01 = two_sum(p0.hi, p1.hi);
    let s = two_sum(s01.hi, p2.hi);
    let lo = (s01.lo + s.lo)
        + (p0.lo + p1.lo + p2.lo)
        + (x.hi.x * c.v.lo.x + x.hi.y * c.v.lo.y + x.hi.z * c.v.lo.z)
        + ((x.lo.x + x3.x) * c.v.hi.x + (x.lo.y + x3.y) * c.v.hi.y + (x.lo.z + x3.z) * c.v.hi.z);
    let p3 = abs(x3.x) * c.mag.x + abs(x3.y) * c.mag.y + abs(x3.z) * c.mag.z;
    let perm = abs(x.hi.x) * c.mag.x + abs(x.hi.y) * c.mag.y + abs(x.hi.z) * c.mag.z + p3;
    return Det(two_sum(s.hi, lo), F_K_EPS2 * perm + 4.0 * F_EPS * p3 + F_ABS);
}

fn quotient_ff(n: Det, d: Det) -> Quo {
    var out: Quo;
    let dh = abs(d.v.hi);
    if !(dh > 2.0 * d.err) {
        return out;
    }
    let q = n.v.hi / d.v.hi;
    let pp = two_prod(q, d.v.hi);
    // Behind `opaque`: (n − p) − pe must not become n − (p + pe), which would drop pe.
    let r0 = opaque(n.v.hi - pp.hi);
    let r = r0 - pp.lo;
    let ql = q * d.v.lo;
    let c = ((r + n.v.lo) - ql) / d.v.hi;
    let div = 16.0 * F_EPS * abs(c)
        + (8.0 * F_EPS * (abs(r) + abs(n.v.lo) + abs(ql))
            + 2.0 * F_EPS * abs(r0)
            + 16.0 * F_EPS * F_EPS * abs(pp.hi)
            + 8.0 * F_TINY)
            / dh;
    let prop = (n.err + (abs(q) * (1.0 + 4.0 * F_EPS) + abs(c)) * d.err)
        / (dh * (1.0 - 4.0 * F_EPS) - d.err);
    return Quo(q, c, (div + prop) * (1.0 + 16.0 * F_EPS), true);
}

fn certify(q: f32, c: f32, err: f32) -> Cert {
    let se = two_sum(q, c);
    let mag = abs(se.hi);
    let bits = bitcast<u32>(mag);
    if bits < 0x00800000u || bits >= 0x7e000000u {
        return Cert(0.0, false);
    }
    let up = opaque(bitcast<f32>(bits + 1u) - mag);
    let down = opaque(mag - bitcast<f32>(bits - 1u));
    let es = select(-se.lo, se.lo, se.hi > 0.0);
    let total = (err + F_HOST_SLACK * mag + F_TINY) * (1.0 + F_SAFE);
    let room_up = (0.5 * up - es) * (1.0 - F_SAFE);
    let room_down = (0.5 * down + es) * (1.0 - F_SAFE);
    return Cert(se.hi, total < room_up && total < room_down);
}

fn operands_ok(x: vec3<f32>) -> bool {
    let b = bitcast<vec3<u32>>(x) & vec3<u32>(0x7fffffffu);
    let ok = b == vec3<u32>(0u)
        | (b >= vec3<u32>(F_OPERAND_MIN_BITS) & b <= vec3<u32>(F_OPERAND_MAX_BITS));
    return all(ok);
}

// Zero or normal, from the bits.
fn zero_or_normal(x: vec3<f32>) -> bool {
    let b = bitcast<vec3<u32>>(x) & vec3<u32>(0x7fffffffu);
    return all(b == vec3<u32>(0u) | (b & vec3<u32>(0x7f800000u)) != vec3<u32>(0u));
}

fn leading12(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) & 0xfffff000u);
}

fn pow2(k: i32) -> f32 {
    return bitcast<f32>(u32(k + 127) << 23u);
}

// The caller's triangle as the hit table holds it (`finish::TriWords`): the corner a in three
// words per coordinate (exactly), the edges b − a and c − a as double-words.
struct Tri {
    a0: vec3<f32>,
    a1: vec3<f32>,
    a2: vec3<f32>,
    e1: V3,
    e2: V3,
}

// The hit of the ray from o with direction d (the caller's times 2^d_exp, largest component
// in [1, 2)) on the triangle, finished when certain (`finish::finish_hit`).
fn finish_hit(o: vec3<f32>, d: vec3<f32>, d_exp: i32, tri: Tri) -> Finished {
    var out: Finished;
    if !(operands_ok(o) && zero_or_normal(d)) {
        return out;
    }
    let e1 = tri.e1;
    let e2 = tri.e2;
    // w = a − o exactly: a double-word and a small third word.
    var w: V3;
    var w2: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        let s0 = two_sum(tri.a0[k], -o[k]);
        let x = two_sum(s0.lo, tri.a1[k]);
        let h = two_sum(s0.hi, x.hi);
        w.hi[k] = h.hi;
        w.lo[k] = h.lo;
        w2[k] = x.lo + tri.a2[k];
    }
    let lambda = opaque(leading12((w.hi.x * d.x + w.hi.y * d.y + w.hi.z * d.z) / (d.x * d.x + d.y * d.y + d.z * d.z)));
    // w − λ d, exactly (`finish::shifted`).
    var ws: V3;
    var w3: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        let p = two_prod(lambda, d[k]);
        let s = two_sum(w.hi[k], -p.hi);
        let f = two_sum(w.lo[k], -p.lo);
        let h = two_sum(s.hi, f.hi);
        let l2 = two_sum(h.lo, s.lo);
        let n = two_sum(h.hi, l2.hi);
        ws.hi[k] = n.hi;
        ws.lo[k] = n.lo;
        w3[k] = (f.lo + l2.lo) + w2[k];
    }
    let m = max(max(abs(ws.hi), abs(e1.hi)), abs(e2.hi));
    let mm = max(m.x, max(m.y, m.z));
    if mm == 0.0 {
        return out;
    }
    let k = 127 - i32((bitcast<u32>(mm) >> 23u) & 0xffu);
    let f = pow2(k);
    w3 = opaque3(w3 * f);
    let wf = V3(opaque3(ws.hi * f), opaque3(ws.lo * f));
    let e1s = V3(opaque3(e1.hi * f), opaque3(e1.lo * f));
    let e2s = V3(opaque3(e2.hi * f), opaque3(e2.lo * f));
    let dd = V3(d, vec3<f32>(0.0));
    let n = cross_ff(e1s, e2s);
    let m2 = cross_ff(dd, e2s);
    let m1 = cross_ff(e1s, dd);
    let num = det_ff(wf, w3, n);
    let den = det_ff(dd, vec3<f32>(0.0), n);
    let num_u = det_ff(wf, w3, m2);
    let num_v = det_ff(wf, w3, m1);

    let tq = quotient_ff(num, den);
    if !tq.ok {
        return out;
    }
    let s = two_sum(lambda * f, tq.q);
    let rest = s.lo + tq.c;
    let ts = certify(s.hi, rest, tq.err + F_EPS * abs(rest));
    if !ts.ok || !(ts.x > 0.0) {
        return out;
    }
    let tb = bitcast<u32>(ts.x);
    let e = i32((tb >> 23u) & 0xffu) + d_exp - k;
    if e < 1 || e > 254 {
        return out;
    }
    let uq = quotient_ff(num_u, den);
    let vq = quotient_ff(num_v, den);
    if !uq.ok || !vq.ok {
        return out;
    }
    let u = certify(uq.q, uq.c, uq.err);
    let v = certify(vq.q, vq.c, vq.err);
    if !u.ok || !v.ok {
        return out;
    }
    for (var i = 0u; i < 3u; i++) {
        let a = vec3<f32>(tri.a0[i], tri.a1[i], tri.a2[i]);
        let x = point_coordinate(a, Ff(e1.hi[i], e1.lo[i]), Ff(e2.hi[i], e2.lo[i]), uq, vq);
        if !x.ok {
            return out;
        }
        out.p[i] = x.x;
    }
    out.t = bitcast<f32>((tb & 0x807fffffu) | (u32(e) << 23u));
    out.u = u.x;
    out.v = v.x;
    out.ok = true;
    return out;
}

fn point_coordinate(a: vec3<f32>, e1: Ff, e2: Ff, u: Quo, v: Quo) -> Cert {
    if e1.hi == 0.0 && e1.lo == 0.0 && e2.hi == 0.0 && e2.lo == 0.0 {
        return Cert(a.x, bitcast<u32>(a.x) != 0x80000000u);
    }
    let p1 = two_prod(u.q, e1.hi);
    let p2 = two_prod(v.q, e2.hi);
    let s1 = two_sum(a.x, p1.hi);
    let s2 = two_sum(s1.hi, p2.hi);
    var terms = array<f32, 10>(
        a.y,
        a.z,
        p1.lo,
        p2.lo,
        s1.lo,
        s2.lo,
        u.q * e1.lo,
        u.c * e1.hi,
        v.q * e2.lo,
        v.c * e2.hi,
    );
    var rest = 0.0;
    var size = 0.0;
    for (var i = 0u; i < 10u; i++) {
        rest += terms[i];
        size += abs(terms[i]);
    }
    let err = 10.0 * F_EPS * size
        + 16.0 * F_EPS * F_EPS * (abs(p1.hi) + abs(p2.hi))
        + F_EPS * (abs(u.c) * abs(e1.hi) + abs(v.c) * abs(e2.hi))
        + 2.0 * F_EPS * F_EPS * (abs(u.q) * abs(e1.hi) + abs(v.q) * abs(e2.hi))
        + u.err * (abs(e1.hi) + abs(e1.lo))
        + v.err * (abs(e2.hi) + abs(e2.lo))
        + 32.0 * F_TINY;
    return certify(s2.hi, rest, err);
}
