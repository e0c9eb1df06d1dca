// The exact walk's plain step (src/traverse/exact.rs, `Exact::step_plain`) on the robust
// kernel's certified signs (shaders/methods/robust.wgsl, joined before this file): the exit
// is taken only when all three sides d->a, d->b, d->c are certified. A certified sign is the
// exact sign of det(d, p - o, q - o) on the caller's float64 points (docs/gpu.md: the slack
// covers the points' rounding to float32), so a step taken here is the CPU exact walk's step,
// and its exit face has three certain edges: no touch of an edge or vertex there. Anything
// else is left to the CPU, from the state the kernel stopped in.
//
// RayIn (resumed walks, shaders/walks/resume.wgsl): `origin` is o (exact in float32 for
// float32 rays), (e0, e1) the float32 basis of the exact walk's line, `slack` its eta:
// |o - origin|_1 plus the points' rounding bound, rounded up.

fn plain_exit(ray: RayIn, a: Vert, b: Vert, c: Vert, d: Vert) -> u32 {
    let eta = ray.slack;
    let da = side(d, a, eta);
    let db = side(d, b, eta);
    let dc = side(d, c, eta);
    if da == SIDE_UNSURE || db == SIDE_UNSURE || dc == SIDE_UNSURE {
        return EXIT_UNSURE;
    }
    // `step`'s decision tree (src/traverse/exact.rs), on the three certain signs.
    if da == SIDE_TRUE {
        return select(EXIT_BCD, EXIT_ABD, db == SIDE_FALSE);
    }
    return select(EXIT_BCD, EXIT_CAD, dc == SIDE_TRUE);
}

// The exact walk's plain steps from the exit face (a, b, c) of tet t, counter-clockwise
// around the ray, with `link` across it, after `steps` tets: taken while certified, then the
// state handed back to the host (`resumed`) at a constrained face or the box, at the step
// guard, or at a step it cannot certify (END_DEFERRED). Both exact kernels end this way.
fn plain_steps(
    i: u32,
    ray: RayIn,
    at: vec4<u32>,
    face: vec3<u32>,
    p: array<Vert, 3>,
) {
    var t = at.x;
    var link = at.y;
    var steps = at.z;
    var a = face.x;
    var b = face.y;
    var c = face.z;
    var pa = p[0];
    var pb = p[1];
    var pc = p[2];
    loop {
        if (link & CONSTRAINED_BIT) != 0u {
            // The walk's own kernel says what the face means (`at_constrained`: its walk file).
            at_constrained(i, link, t, steps, a, b, c);
            return;
        }
        if steps >= params.max_steps {
            resumed(i, END_STEP_LIMIT, link, t, steps, a, b, c);
            return;
        }
        let next = link;
        let d = fourth_vertex(next, a, b, c);
        let pd = vertex(ray, position(d));
        let e = plain_exit(ray, pa, pb, pc, pd);
        if e == EXIT_UNSURE {
            resumed(i, END_DEFERRED, link, t, steps, a, b, c);
            return;
        }
        t = next;
        steps += 1u;
        let opposite = turn(e, d, pd, &a, &b, &c, &pa, &pb, &pc);
        link = link_opposite(t, opposite, a, b, c);
    }
}

// The state the walk stands in, for the host to walk on from: RayOut.constrained holds the
// link across the face.
fn resumed(i: u32, end: u32, link: u32, tet: u32, steps: u32, a: u32, b: u32, c: u32) {
    var out: RayOut;
    out.end = end;
    out.constrained = link;
    out.tet = tet;
    out.steps = steps;
    out.face = vec4<u32>(a, b, c, 0u);
    hits[i] = out;
}
