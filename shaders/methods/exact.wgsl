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
