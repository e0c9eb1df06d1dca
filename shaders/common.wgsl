// Shared by every traversal kernel. src/gpu/kernels.rs assembles a kernel from this file,
// its layout's records (shaders/layouts/), its exit method (shaders/methods/) and its layout's
// walk (shaders/walks/), joined in that order. Every struct here is mirrored by a #[repr(C)]
// Pod struct in src/gpu/structs.rs whose size and field offsets are asserted there.
//
// One invocation walks one ray, from the start tet the host located (`Scene::locate_one`), to
// the first constrained face or the domain boundary; the host then finishes the hit on the
// caller's triangle in float64 (`Scene::finish`), as the CPU cast does.
//
// What each part provides (WGSL resolves module-scope names in any order):
// - layout: `tets` (binding 3) and its accessors; id layouts also `points` (binding 4);
// - method: `alias Vert` (a vertex as the exit test takes it), `vertex(ray, p)` (a position
//   made a Vert), `start_exit(ray, &verts)` and `step_exit(ray, a, b, c, d)`;
// - walk: the one `main`, the walk of src/traverse/mod.rs for its kind of layout.

// Links, as in src/mesh/build.rs: a neighbour tet id, the domain BOUNDARY, or
// CONSTRAINED_BIT | index into the constrained-side table.
const BOUNDARY: u32 = 0xffffffffu;
const CONSTRAINED_BIT: u32 = 0x80000000u;
// RayIn.entry when the ray starts inside its tet (no entry face).
const NO_ENTRY: u32 = 4u;

// RayOut.end
const END_BOUNDARY: u32 = 0u;
const END_HIT: u32 = 1u;
const END_STEP_LIMIT: u32 = 2u;
// Robust kernel only: a sign was too close to call in float32; the host walks the ray again.
const END_DEFERRED: u32 = 3u;

// Exits of the walk (src/traverse/mod.rs, `Exit`): the face opposite c, a or b.
const EXIT_ABD: u32 = 0u;
const EXIT_BCD: u32 = 1u;
const EXIT_CAD: u32 = 2u;
// What start_exit and step_exit return when a sign is too close to call (the robust filter):
// the walk stops with END_DEFERRED. Not a face (0..3) nor an exit (0..2).
const EXIT_UNSURE: u32 = 4u;

const WORKGROUP: u32 = 64u;

struct Params {
    n_rays: u32,
    max_steps: u32,
    // The own-origin kernel: where the batch's origins begin in its ray buffer (in floats,
    // after the directions); 0 for every other kernel.
    origins_at: u32,
    _pad1: u32,
}

// One ray, prepared on the host exactly as the CPU walk prepares it (`ExitMethod::prepare`,
// in float64, rounded to float32): for aman2022 and robust `origin` is the start point and
// (e0, e1) the 2D basis (u, w); for maria2017 e0 is the direction and e1 the moment o x u.
struct RayIn {
    origin: vec3<f32>,
    // The start tet.
    tet: u32,
    e0: vec3<f32>,
    // The face of `tet` the ray enters by (0..3), or NO_ENTRY.
    entry: u32,
    e1: vec3<f32>,
    // Robust only: |s - origin|_1 rounded up, the float32 rounding of the start point s.
    slack: f32,
    // Vertex ids of the start tet, positively oriented (layouts that name vertices by id).
    verts: vec4<u32>,
}

struct RayOut {
    end: u32,
    // END_HIT: index into the constrained-side table.
    constrained: u32,
    // The tet the walk ended in, and tets visited (the start tet included).
    tet: u32,
    steps: u32,
    // The face it left by, counter-clockwise around the ray: vertex ids, or local slots
    // 0..3 for tet80 (which knows no ids). w is unused. A hit finished on the device
    // (END_FINISHED, shared_origin.wgsl): the point's coordinates, as float bits.
    face: vec4<u32>,
    // END_FINISHED: t, u, v (w unused); unused by every other end.
    hit: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rays: array<RayIn>;
@group(0) @binding(2) var<storage, read_write> hits: array<RayOut>;

// OUTWARD_FACES of src/mesh/build.rs: face i is opposite vertex i, ordered so its normal
// points out of the tet.
fn outward_face(i: u32) -> vec3<u32> {
    switch i {
        case 0u: { return vec3<u32>(1u, 2u, 3u); }
        case 1u: { return vec3<u32>(0u, 3u, 2u); }
        case 2u: { return vec3<u32>(0u, 1u, 3u); }
        default: { return vec3<u32>(0u, 2u, 1u); }
    }
}

// Rank of vertex id x among the tet's other three (src/layout/mod.rs, `rank`).
fn rank(x: u32, a: u32, b: u32, c: u32) -> u32 {
    return select(0u, 1u, a < x) + select(0u, 1u, b < x) + select(0u, 1u, c < x);
}

// The invocation's ray index; the host dispatches a 2D grid when one row is not enough.
fn ray_index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.y * nwg.x * WORKGROUP + gid.x;
}

fn finish(i: u32, end: u32, link: u32, tet: u32, steps: u32, a: u32, b: u32, c: u32) {
    var out: RayOut;
    out.end = end;
    out.constrained = link & ~CONSTRAINED_BIT;
    out.tet = tet;
    out.steps = steps;
    out.face = vec4<u32>(a, b, c, 0u);
    hits[i] = out;
}

// The end of a walk that reached a link with CONSTRAINED_BIT set (BOUNDARY has it too).
fn link_end(link: u32) -> u32 {
    return select(END_HIT, END_BOUNDARY, link == BOUNDARY);
}

// One step of the walk: the tet was entered by face (a, b, c), counter-clockwise around the
// ray, and is left by exit e; d is its fourth vertex. Makes (a, b, c) the exit face, again
// counter-clockwise, and returns the vertex opposite it (which names the next link).
fn turn(
    e: u32,
    d: u32,
    pd: Vert,
    a: ptr<function, u32>,
    b: ptr<function, u32>,
    c: ptr<function, u32>,
    pa: ptr<function, Vert>,
    pb: ptr<function, Vert>,
    pc: ptr<function, Vert>,
) -> u32 {
    var opposite: u32;
    if e == EXIT_ABD {
        opposite = *c;
        *c = d;
        *pc = pd;
    } else if e == EXIT_BCD {
        opposite = *a;
        *a = *b;
        *pa = *pb;
        *b = *c;
        *pb = *pc;
        *c = d;
        *pc = pd;
    } else {
        opposite = *b;
        let a0 = *a;
        let pa0 = *pa;
        *a = *c;
        *pa = *pc;
        *b = a0;
        *pb = pa0;
        *c = d;
        *pc = pd;
    }
    return opposite;
}
