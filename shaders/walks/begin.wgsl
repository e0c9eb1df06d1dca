// What the exact kernels that begin their walks on the device share (joined after
// robust.wgsl, exact.wgsl and exact_hit.wgsl, before the walk's `main`): per ray, from its
// origin (`origin`, set by `main`) and direction, the 2D basis and the start as the CPU exact
// walk takes it (the first exit from the tet strictly holding the origin, or from outside the
// box a certified miss or the boundary face the ray enters by), then the plain steps of the
// resumed walk, and at a constrained face the hit finished on the device where it can be
// certified. Each decision is a certified sign, so it is the CPU exact walk's; a ray whose
// start cannot be certified ends END_UNBEGUN (the host walks it from the start), one that
// certainly misses the box ends END_MISS_BOX (a miss, as `Locators::exact_line` says).
//
// RayOut: as resume.wgsl's (exact.wgsl's `resumed`: the walk's state when handed back).

const END_UNBEGUN: u32 = 5u;
const END_MISS_BOX: u32 = 6u;
// A hit finished on the device (exact_hit.wgsl): RayOut.constrained is the caller's
// triangle, face.xyz the point (float bits), hit.xyz t, u and v: the host's answer.
const END_FINISHED: u32 = 7u;
// Shared.finish, or a hit table entry: no hit finished on the device.
const NO_TRIANGLE: u32 = 0xffffffffu;

// One side of the box's entry grid (`locate::boundary::SideGrid`): cells on the side's axes
// ((axis + 1) % 3, (axis + 2) % 3); cell c's faces are face_ids[cells[cells + c] ..
// cells[cells + c + 1]] offset by `faces`.
struct GridSide {
    lo: vec2<f32>,
    inv_cell: vec2<f32>,
    dims: vec2<u32>,
    cells: u32,
    faces: u32,
}

struct Shared {
    origin: vec3<f32>,
    slack: f32,
    verts: vec4<u32>,
    box_lo: vec3<f32>,
    start_tet: u32,
    box_hi: vec3<f32>,
    inside: u32,
    beyond: vec3<i32>,
    // Where the hit table's corners begin, or NO_TRIANGLE: hits are then all the host's.
    // (With a finite tmax the host compares each finished hit's t with it.)
    finish: u32,
    sides: array<GridSide, 6>,
    // The own-origin kernel's (walks/own_origin.wgsl); the shared-origin kernel ignores them.
    // The box rounded inward: a float32 o lies below the box's low plane on axis k exactly
    // when o < in_lo[k], above its high plane exactly when o > in_hi[k].
    in_lo: vec3<f32>,
    _pad3: u32,
    in_hi: vec3<f32>,
    // Where the constrained sides' far tets begin in the `locate` table.
    beyond_at: u32,
    // The seed grid (`locate::GridLocator`): cell of p = (p - grid_lo) * grid_inv, clamped.
    grid_lo: vec3<f32>,
    _pad1: u32,
    grid_inv: vec3<f32>,
    _pad: u32,
    grid_dims: vec3<u32>,
    _pad2: u32,
}

@group(0) @binding(5) var<uniform> batch: Shared;
// The rays' directions, three float32 a ray, as the caller passed them (the own-origin
// kernel: then, from word params.origins_at, the batch's origins).
@group(0) @binding(6) var<storage, read> dirs: array<f32>;
// CSR starts of every side's cells, and per boundary face (tet << 2 | local face, then its
// vertex ids in outward order).
@group(0) @binding(7) var<storage, read> cells: array<u32>;
@group(0) @binding(8) var<storage, read> faces: array<vec4<u32>>;
// The hit table (src/gpu/finish.rs, `HitTable`): per constrained side the caller's triangle
// (or NO_TRIANGLE), then from word `batch.finish` 21 words per triangle (`Tri`), and last 0
// (exact_hit.wgsl's `zero_bits`).
@group(0) @binding(9) var<storage, read> hit_table: array<u32>;

// This invocation's origin, and its direction as the walk takes it (the caller's times
// 2^dir_exp).
var<private> origin: vec3<f32>;
var<private> dir: vec3<f32>;
var<private> dir_exp: i32;

// 2^-21: twice the error of a slab comparison's products (docs/gpu.md).
const C_SLAB: f32 = 4.76837158203125e-7;

fn is_positive(bits: u32) -> bool {
    return (bits & 0x80000000u) == 0u && (bits & 0x7fffffffu) != 0u;
}

fn is_negative(bits: u32) -> bool {
    return (bits & 0x80000000u) != 0u && (bits & 0x7fffffffu) != 0u;
}

// Begins ray i's walk from `origin` (set by the caller) and takes its plain steps. `inside`:
// the origin lies strictly inside tet `start_tet`, whose vertex ids are `names` (in
// `mesh.tets` order) and it touches no triangle's plane there; else it lies outside the box,
// beyond it per axis as `beyond` says (-1 below, 0 within, 1 above: exactly).
fn begin(i: u32, beyond: vec3<i32>, inside: bool, start_tet: u32, names: vec4<u32>) {
    let d0 = vec3<f32>(dirs[3u * i], dirs[3u * i + 1u], dirs[3u * i + 2u]);
    // Signs and magnitudes from the bits: comparisons may flush subnormals to zero.
    let bits = bitcast<vec3<u32>>(d0);
    let mag = bits & vec3<u32>(0x7fffffffu);
    let top = max(mag.x, max(mag.y, mag.z));
    // Not finite, zero (INVALID: the host says so), or too large or small to scale exactly.
    if top >= 0x7f800000u || (top >> 23u) < 2u || (top >> 23u) > 253u {
        unbegun(i);
        return;
    }
    // The direction scaled by a power of two (exact): its largest component in [1, 2).
    let d = d0 * bitcast<f32>((254u - (top >> 23u)) << 23u);
    dir = d;
    dir_exp = 127 - i32(top >> 23u);
    zero_bits = hit_table[arrayLength(&hit_table) - 1u];
    var ray: RayIn;
    ray.origin = origin;
    ray.slack = batch.slack;
    let basis = direction_basis(d);
    ray.e0 = basis[0];
    ray.e1 = basis[1];

    var a: u32;
    var b: u32;
    var c: u32;
    var pa: Vert;
    var pb: Vert;
    var pc: Vert;
    var t: u32;
    var link: u32;
    if inside {
        // `walk_begin` from inside: the face turning counter-clockwise on all three edges.
        var vs: array<Vert, 4>;
        for (var k = 0u; k < 4u; k++) {
            vs[k] = vertex(ray, position(names[k]));
        }
        let e = start_exit(ray, &vs);
        if e == EXIT_UNSURE {
            unbegun(i);
            return;
        }
        t = start_tet;
        let f = outward_face(e);
        a = names[f.x];
        b = names[f.y];
        c = names[f.z];
        pa = vs[f.x];
        pb = vs[f.y];
        pc = vs[f.z];
        link = link_opposite(t, names[e], a, b, c);
    } else {
        // From outside: a ray moving away from a side its origin lies beyond misses the box
        // (`exact_line`'s exact test); then the box lies ahead of the origin.
        for (var k = 0u; k < 3u; k++) {
            let s = beyond[k];
            if (s < 0 && !is_positive(bits[k])) || (s > 0 && !is_negative(bits[k])) {
                finish_miss(i);
                return;
            }
        }
        let side = entry_side(d, bits);
        if side == 6u {
            finish_miss(i);
            return;
        }
        if side > 6u {
            unbegun(i);
            return;
        }
        let found = entry_face(ray, d, side);
        if found.x == 0xffffffffu {
            unbegun(i);
            return;
        }
        // Entering by the face, reversed from its outward order: counter-clockwise around
        // the ray, as an exit face of the tet behind it would be; then the first step.
        let into = found.x >> 2u;
        a = found.y;
        b = found.w;
        c = found.z;
        pa = vertex(ray, position(a));
        pb = vertex(ray, position(b));
        pc = vertex(ray, position(c));
        let dv = fourth_vertex(into, a, b, c);
        let pd = vertex(ray, position(dv));
        let e = plain_exit(ray, pa, pb, pc, pd);
        if e == EXIT_UNSURE {
            unbegun(i);
            return;
        }
        t = into;
        let opposite = turn(e, dv, pd, &a, &b, &c, &pa, &pb, &pc);
        link = link_opposite(t, opposite, a, b, c);
    }
    // Plain steps, as the resumed kernel takes them (exact.wgsl).
    let p = array<Vert, 3>(pa, pb, pc);
    plain_steps(i, ray, vec4<u32>(t, link, 1u, 0u), vec3<u32>(a, b, c), p);
}

// An orthonormal basis (u, w) of the plane perpendicular to d, u x w along +d, within the
// bound docs/gpu.md derives: u = d x e_k (exact: e_k is the axis of d's smallest component),
// w = d x u (one rounding a component, two for the sum of squares), each normalized.
fn direction_basis(d: vec3<f32>) -> array<vec3<f32>, 2> {
    let ad = abs(d);
    var ek = vec3<f32>(0.0, 0.0, 1.0);
    if ad.x <= ad.y && ad.x <= ad.z {
        ek = vec3<f32>(1.0, 0.0, 0.0);
    } else if ad.y <= ad.z {
        ek = vec3<f32>(0.0, 1.0, 0.0);
    }
    let u0 = cross(d, ek);
    let w0 = cross(d, u0);
    return array<vec3<f32>, 2>(u0 * inverseSqrt(dot(u0, u0)), w0 * inverseSqrt(dot(w0, w0)));
}

// The box side the ray enters by (2 x axis + high), 6 when it certainly misses the box (the
// box rounded outward: a ray that misses it misses the box), 7 when no slab can say. Only
// called when the box lies ahead of the origin. The slab parameters are compared
// cross-multiplied, with a certified bound, never divided.
fn entry_side(d: vec3<f32>, bits: vec3<u32>) -> u32 {
    let o = origin;
    var near: vec3<f32>;
    var far: vec3<f32>;
    var moving: vec3<bool>;
    for (var k = 0u; k < 3u; k++) {
        let up = is_positive(bits[k]);
        moving[k] = (bits[k] & 0x7fffffffu) != 0u && d[k] != 0.0;
        near[k] = select(batch.box_hi[k], batch.box_lo[k], up) - o[k];
        far[k] = select(batch.box_lo[k], batch.box_hi[k], up) - o[k];
    }
    // A miss: some slab is entered after another is left (t_near(a) > t_far(b)).
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            if a == b || !moving[a] || !moving[b] {
                continue;
            }
            let p = near[a] * d[b];
            let q = far[b] * d[a];
            let bound = C_SLAB * (abs(p) + abs(q)) + C_ABS;
            let s = select(-1.0, 1.0, (d[a] > 0.0) == (d[b] > 0.0));
            if s * (p - q) > bound {
                return 6u;
            }
        }
    }
    // The entry: the largest t_near among the moving axes (float: the faces decide).
    var best = 7u;
    var tbest = -3.4e38;
    for (var k = 0u; k < 3u; k++) {
        if moving[k] {
            let tk = near[k] / d[k];
            if tk > tbest {
                tbest = tk;
                best = 2u * k + select(0u, 1u, !is_positive(bits[k]));
            }
        }
    }
    return best;
}

// The boundary face the ray certainly enters by, among the faces of the grid cell of side
// `by` that holds the rounded entry point: (tet << 2 | face, its vertex ids in outward
// order), x = 0xffffffff when none is certain.
fn entry_face(ray: RayIn, d: vec3<f32>, by: u32) -> vec4<u32> {
    let axis = by / 2u;
    let high = (by & 1u) == 1u;
    let o = origin;
    let plane = select(batch.box_lo[axis], batch.box_hi[axis], high);
    let tk = (plane - o[axis]) / d[axis];
    let g = batch.sides[by];
    let a0 = (axis + 1u) % 3u;
    let a1 = (axis + 2u) % 3u;
    let q = vec2<f32>(o[a0] + tk * d[a0], o[a1] + tk * d[a1]);
    // As the CPU's truncation, clamped to the grid (min also bounds whatever a NaN becomes).
    let x = min(vec2<u32>(max((q - g.lo) * g.inv_cell, vec2<f32>(0.0))), g.dims - vec2<u32>(1u));
    let cell = g.cells + x.x + g.dims.x * x.y;
    let eta = ray.slack;
    for (var e = cells[cell]; e < cells[cell + 1u]; e++) {
        let f = faces[g.faces + e];
        let p0 = vertex(ray, position(f.y));
        let p1 = vertex(ray, position(f.z));
        let p2 = vertex(ray, position(f.w));
        // `Exact::enters`: clockwise around the ray on every edge of the outward face.
        if side(p0, p1, eta) == SIDE_FALSE && side(p1, p2, eta) == SIDE_FALSE
            && side(p2, p0, eta) == SIDE_FALSE {
            return f;
        }
    }
    return vec4<u32>(0xffffffffu);
}

fn unbegun(i: u32) {
    var out: RayOut;
    out.end = END_UNBEGUN;
    hits[i] = out;
}

fn finish_miss(i: u32) {
    var out: RayOut;
    out.end = END_MISS_BOX;
    hits[i] = out;
}

// At a constrained face, crossed through its interior (every sign of the walk so far was
// certified, so no edge or vertex was touched and nothing was met before): the hit, finished
// here when its values are certain; else, and at the boundary, handed back as it stands.
fn at_constrained(i: u32, link: u32, t: u32, steps: u32, a: u32, b: u32, c: u32) {
    if link != BOUNDARY && batch.finish != NO_TRIANGLE {
        let tri = hit_table[link & ~CONSTRAINED_BIT];
        if tri != NO_TRIANGLE {
            // The triangle's 21 words (`finish::TriWords`).
            let at = batch.finish + 21u * tri;
            var t3: Tri;
            for (var k = 0u; k < 3u; k++) {
                t3.a0[k] = bitcast<f32>(hit_table[at + 3u * k]);
                t3.a1[k] = bitcast<f32>(hit_table[at + 3u * k + 1u]);
                t3.a2[k] = bitcast<f32>(hit_table[at + 3u * k + 2u]);
                t3.e1.hi[k] = bitcast<f32>(hit_table[at + 9u + 2u * k]);
                t3.e1.lo[k] = bitcast<f32>(hit_table[at + 10u + 2u * k]);
                t3.e2.hi[k] = bitcast<f32>(hit_table[at + 15u + 2u * k]);
                t3.e2.lo[k] = bitcast<f32>(hit_table[at + 16u + 2u * k]);
            }
            let h = finish_hit(origin, dir, dir_exp, t3);
            if h.ok {
                var out: RayOut;
                out.end = END_FINISHED;
                out.constrained = tri;
                out.tet = t;
                out.steps = steps;
                out.face = vec4<u32>(bitcast<vec3<u32>>(h.p), 0u);
                out.hit = vec4<f32>(h.t, h.u, h.v, 0.0);
                hits[i] = out;
                return;
            }
        }
    }
    resumed(i, link_end(link), link, t, steps, a, b, c);
}
