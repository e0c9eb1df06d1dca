// The robust walk (src/traverse/robust.rs) on Tet20, filter only: every side of an edge is the
// 2D determinant of Aman et al., certified by an error bound that holds for any evaluation
// order and any fused multiply-add (docs/gpu.md derives it). When the bound cannot certify a
// sign, the ray stops with END_DEFERRED and the host walks it again with the CPU robust walk,
// whose exact predicates decide. A ray that is not deferred took exactly the decisions of the
// exact walk, so every ray ends where the CPU robust walk ends.

struct Tet20 {
    vertex_xor: u32,
    links: array<u32, 4>,
}

@group(0) @binding(3) var<storage, read> tets: array<Tet20>;
@group(0) @binding(4) var<storage, read> points: array<vec4<f32>>;

// Sides: certified true, certified false, or too close to call.
const SIDE_FALSE: u32 = 0u;
const SIDE_TRUE: u32 = 1u;
const SIDE_UNSURE: u32 = 2u;

// Filter (docs/gpu.md): with N = |p - s~|_1, M = |x| + |y| (the projected L1 norm) and
// eta = |s - s~|_1, |computed det - exact det (scaled)| is below
//   2^-20 (N_p M_q + M_p N_q) + 2^-22 M_p M_q + 2 eta (M_p + M_q) + 2^-40 N_p N_q
//   + 2^-19 eta (N_p + N_q) + 2 eta^2 + 2^-100 (N_p + N_q + 1)
// for any evaluation order and any fused multiply-add (u = 2^-24; each coefficient is at
// least twice its first-order value). Far from s the error scales with M (the distance of
// the vertices from the ray), not with N, so distant signs are certified unless the ray
// nearly meets the edge.
const C_NM: f32 = 9.5367431640625e-7; // 2^-20
const C_MM: f32 = 2.384185791015625e-7; // 2^-22
const C_NN: f32 = 9.094947017729282e-13; // 2^-40
const C_ETA_N: f32 = 1.9073486328125e-6; // 2^-19
const C_ABS: f32 = 7.888609052210118e-31; // 2^-100

// A vertex: (x, y) projected on the basis (u, w), z = N = its L1 offset from s~.
fn project(o: vec3<f32>, u: vec3<f32>, w: vec3<f32>, id: u32) -> vec3<f32> {
    let p = points[id];
    let q = vec3<f32>(p.x - o.x, p.y - o.y, p.z - o.z);
    return vec3<f32>(
        q.x * u.x + q.y * u.y + q.z * u.z,
        q.x * w.x + q.y * w.y + q.z * w.z,
        abs(q.x) + abs(q.y) + abs(q.z),
    );
}

// The side of edge p->q seen along the ray (src/traverse/robust.rs, `side`), if certain.
fn side(p: vec3<f32>, q: vec3<f32>, eta: f32) -> u32 {
    let det = p.x * q.y - p.y * q.x;
    let mp = abs(p.x) + abs(p.y);
    let mq = abs(q.x) + abs(q.y);
    let n = p.z + q.z;
    let bound = C_NM * (p.z * mq + mp * q.z) + C_MM * mp * mq + 2.0 * eta * (mp + mq)
        + C_NN * p.z * q.z + C_ETA_N * eta * n + 2.0 * eta * eta + C_ABS * (n + 1.0);
    if det > bound {
        return SIDE_TRUE;
    }
    if -det > bound {
        return SIDE_FALSE;
    }
    return SIDE_UNSURE;
}

// The exit of the walk's decision tree, or 3u when a sign was unsure.
fn step_exit(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, d: vec3<f32>, eta: f32) -> u32 {
    let da = side(d, a, eta);
    if da == SIDE_UNSURE {
        return 3u;
    }
    if da == SIDE_TRUE {
        let db = side(d, b, eta);
        if db == SIDE_UNSURE {
            return 3u;
        }
        return select(EXIT_BCD, EXIT_ABD, db == SIDE_FALSE);
    }
    let dc = side(d, c, eta);
    if dc == SIDE_UNSURE {
        return 3u;
    }
    return select(EXIT_BCD, EXIT_CAD, dc == SIDE_TRUE);
}

// The start tet: the first face with all three edges counter-clockwise, else the first with
// the most; 4u when a sign was unsure.
fn start_exit(v: ptr<function, array<vec3<f32>, 4>>, eta: f32) -> u32 {
    var best = 0u;
    var best_n = 0u;
    for (var i = 0u; i < 4u; i++) {
        let f = outward_face(i);
        let s0 = side((*v)[f.x], (*v)[f.y], eta);
        let s1 = side((*v)[f.y], (*v)[f.z], eta);
        let s2 = side((*v)[f.z], (*v)[f.x], eta);
        if s0 == SIDE_UNSURE || s1 == SIDE_UNSURE || s2 == SIDE_UNSURE {
            return 4u;
        }
        let n = s0 + s1 + s2;
        if n == 3u {
            return i;
        }
        if n > best_n {
            best = i;
            best_n = n;
        }
    }
    return best;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    let ray = rays[i];
    let o = ray.origin;
    let u = ray.e0;
    let w = ray.e1;
    let eta = ray.slack;
    let names = ray.verts;
    var a: u32;
    var b: u32;
    var c: u32;
    var pa: vec3<f32>;
    var pb: vec3<f32>;
    var pc: vec3<f32>;
    var link: u32;
    var t = ray.tet;
    var steps: u32;
    if ray.entry < NO_ENTRY {
        let f = outward_face(ray.entry);
        a = names[f.x];
        b = names[f.z];
        c = names[f.y];
        pa = project(o, u, w, a);
        pb = project(o, u, w, b);
        pc = project(o, u, w, c);
        link = t;
        steps = 0u;
    } else {
        var vs: array<vec3<f32>, 4>;
        for (var k = 0u; k < 4u; k++) {
            vs[k] = project(o, u, w, names[k]);
        }
        let e = start_exit(&vs, eta);
        if e == 4u {
            finish(i, END_DEFERRED, 0u, t, 0u, 0u, 0u, 0u);
            return;
        }
        let f = outward_face(e);
        a = names[f.x];
        b = names[f.y];
        c = names[f.z];
        pa = vs[f.x];
        pb = vs[f.y];
        pc = vs[f.z];
        link = tets[t].links[rank(names[e], a, b, c)];
        steps = 1u;
    }
    loop {
        if (link & CONSTRAINED_BIT) != 0u {
            finish(i, link_end(link), link, t, steps, a, b, c);
            return;
        }
        if steps >= params.max_steps {
            finish(i, END_STEP_LIMIT, 0u, t, steps, a, b, c);
            return;
        }
        t = link;
        steps += 1u;
        let d = tets[t].vertex_xor ^ a ^ b ^ c;
        let pd = project(o, u, w, d);
        let e = step_exit(pa, pb, pc, pd, eta);
        if e == 3u {
            finish(i, END_DEFERRED, 0u, t, steps, a, b, c);
            return;
        }
        var opposite: u32;
        if e == EXIT_ABD {
            opposite = c;
            c = d;
            pc = pd;
        } else if e == EXIT_BCD {
            opposite = a;
            a = b;
            pa = pb;
            b = c;
            pb = pc;
            c = d;
            pc = pd;
        } else {
            opposite = b;
            let a0 = a;
            let pa0 = pa;
            a = c;
            pa = pc;
            b = a0;
            pb = pa0;
            c = d;
            pc = pd;
        }
        link = tets[t].links[rank(opposite, a, b, c)];
    }
}
