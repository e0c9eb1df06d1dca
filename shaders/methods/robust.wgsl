// The robust walk (src/traverse/robust.rs), filter only: every side of an edge is the 2D
// determinant of Aman et al., certified by an error bound that holds for any evaluation order
// and any fused multiply-add (docs/gpu.md derives it). When the bound cannot certify a sign,
// the exit is EXIT_UNSURE: the ray stops with END_DEFERRED and the host walks it again with
// the CPU robust walk, whose exact predicates decide. A ray that is not deferred took exactly
// the decisions of the exact walk, so every ray ends where the CPU robust walk ends.
//
// RayIn: `origin` is s~, the float32 start point of the exact line; (e0, e1) the 2D basis
// built from b - s; `slack` is eta = |s - s~|_1 rounded up.

// A vertex: (x, y) projected on the basis (u, w), z = N = its L1 offset from s~.
alias Vert = vec3<f32>;

// Sides: certified true, certified false, or too close to call.
const SIDE_FALSE: u32 = 0u;
const SIDE_TRUE: u32 = 1u;
const SIDE_UNSURE: u32 = 2u;

// Filter (docs/gpu.md): with N = |p - s~|_1, M = |x| + |y| (the projected L1 norm) and
// eta = |s - s~|_1, |computed det - exact det (scaled)| is below
//   2^-20 (N_p M_q + M_p N_q) + 2^-22 M_p M_q + 2 eta (M_p + M_q) + 2^-39 N_p N_q
//   + 2^-19 eta (N_p + N_q) + 2 eta^2 + 2^-100 (N_p + N_q + 1)
// for any evaluation order and any fused multiply-add (u = 2^-24; each coefficient is at
// least twice its first-order value). Far from s the error scales with M (the distance of
// the vertices from the ray), not with N, so distant signs are certified unless the ray
// nearly meets the edge.
const C_NM: f32 = 9.5367431640625e-7; // 2^-20
const C_MM: f32 = 2.384185791015625e-7; // 2^-22
const C_NN: f32 = 1.8189894035458565e-12; // 2^-39
const C_ETA_N: f32 = 1.9073486328125e-6; // 2^-19
const C_ABS: f32 = 7.888609052210118e-31; // 2^-100

fn vertex(ray: RayIn, p: vec3<f32>) -> Vert {
    let o = ray.origin;
    let u = ray.e0;
    let w = ray.e1;
    let q = vec3<f32>(p.x - o.x, p.y - o.y, p.z - o.z);
    return vec3<f32>(
        q.x * u.x + q.y * u.y + q.z * u.z,
        q.x * w.x + q.y * w.y + q.z * w.z,
        abs(q.x) + abs(q.y) + abs(q.z),
    );
}

// The side of edge p->q seen along the ray (src/traverse/robust.rs, `side`), if certain.
fn side(p: Vert, q: Vert, eta: f32) -> u32 {
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

// The exit of the walk's decision tree, or EXIT_UNSURE.
fn step_exit(ray: RayIn, a: Vert, b: Vert, c: Vert, d: Vert) -> u32 {
    let eta = ray.slack;
    let da = side(d, a, eta);
    if da == SIDE_UNSURE {
        return EXIT_UNSURE;
    }
    if da == SIDE_TRUE {
        let db = side(d, b, eta);
        if db == SIDE_UNSURE {
            return EXIT_UNSURE;
        }
        return select(EXIT_BCD, EXIT_ABD, db == SIDE_FALSE);
    }
    let dc = side(d, c, eta);
    if dc == SIDE_UNSURE {
        return EXIT_UNSURE;
    }
    return select(EXIT_BCD, EXIT_CAD, dc == SIDE_TRUE);
}

// The start tet: the first face with all three edges counter-clockwise, else the first with
// the most; EXIT_UNSURE when a sign was unsure.
fn start_exit(ray: RayIn, v: ptr<function, array<Vert, 4>>) -> u32 {
    let eta = ray.slack;
    var best = 0u;
    var best_n = 0u;
    for (var i = 0u; i < 4u; i++) {
        let f = outward_face(i);
        let s0 = side((*v)[f.x], (*v)[f.y], eta);
        let s1 = side((*v)[f.y], (*v)[f.z], eta);
        let s2 = side((*v)[f.z], (*v)[f.x], eta);
        if s0 == SIDE_UNSURE || s1 == SIDE_UNSURE || s2 == SIDE_UNSURE {
            return EXIT_UNSURE;
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
