// Point location on the device, for the kernels that locate points (walks/own_origin.wgsl,
// walks/contains.wgsl; joined after begin.wgsl, whose uniform `batch` carries the box rounded
// inward, the seed grid, the slack and where the locate table's parts begin): a point's side
// of the box, exactly, and the tet strictly holding it, by the visibility walk of
// `locate::GridLocator` from its grid cell's seed tet, moving only across faces the point is
// certainly beyond (`orient_side`), kept only when the point is certainly strictly inside it
// on all four faces (then it is the one tet holding it, the tet the CPU's locators find).

// Tets the location walk visits before it gives the point back to the host.
const LOCATE_GUARD: u32 = 1024u;

// The seed grid and the constrained sides' far tets (`gpu::origin`, `LocateTable`): from
// word 0, per grid cell its seed tet and the tet's vertex ids in `mesh.tets` order (5 words);
// from `batch.beyond_at`, per constrained side the tet beyond it (or BOUNDARY).
//
// A tet the walk moves to is named in its own vertex order (positively oriented, but not
// `mesh.tets[t]`'s): the start exit it certifies is the one face all three of whose edges
// turn counter-clockwise, whatever the order, and the exact walk's later decisions do not
// depend on which vertex of a face comes first (its plain steps are signs, its exact steps
// signs of a perturbed ray: `Exact::step_exact`), so the walk goes through the same tets.
@group(0) @binding(10) var<storage, read> locate: array<u32>;

// Orient filter (docs/gpu.md): with x, y, z the float32 differences a - o, b - o, c - o,
// P = the permanent of |x|, |y|, |z|, N their L1 norms, S = N_x + N_y + N_z,
// Q = N_x N_y + N_y N_z + N_z N_x and e = eta + 2^-118 (eta: the points' rounding), the
// computed det(x, y, z) is within
//   2^-19 P + 2 e (Q + e S + e^2) + 2^-118 (S + 1)
// of the exact det(a - o, b - o, c - o) on the caller's float64 points, for any evaluation
// order, any fused multiply-add and subnormals flushed (each coefficient at least twice its
// first-order value); the host keeps every coordinate within 2^32, so nothing overflows.
const C_PERM: f32 = 1.9073486328125e-6; // 2^-19
const C_FLUSH: f32 = 3.009265538105056e-36; // 2^-118

// Where the finite float32 point with bits `bits` lies against the float64 domain box, per
// axis (-1 below, 0 within, 1 above), exactly: o < lo exactly when o < round_up(lo) (no
// float32 number lies between round_down(lo) and round_up(lo)), o > hi when o >
// round_down(hi).
fn box_side(bits: vec3<u32>) -> vec3<i32> {
    var beyond = vec3<i32>(0);
    for (var k = 0u; k < 3u; k++) {
        if less_bits(bits[k], bitcast<u32>(batch.in_lo[k])) {
            beyond[k] = -1;
        } else if less_bits(bitcast<u32>(batch.in_hi[k]), bits[k]) {
            beyond[k] = 1;
        }
    }
    return beyond;
}

// x < y for the float32 numbers with bits x and y (not NaN; -0 equals 0), compared as
// integers: no subnormal is flushed.
fn less_bits(x: u32, y: u32) -> bool {
    return order_key(x) < order_key(y);
}

fn order_key(bits: u32) -> u32 {
    let b = select(bits, 0u, bits == 0x80000000u);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

// The tet `locate_origin` found, or BOUNDARY.
var<private> located: u32;

// The tet strictly holding o (in `located`), by the visibility walk from its grid cell's
// seed, and its vertex ids, positively oriented; `located` is BOUNDARY when a sign the walk
// needs is uncertain, the walk leaves the domain or passes the guard. `i`: the invocation's
// index (the walk's random seed).
fn locate_origin(i: u32, o: vec3<f32>) -> vec4<u32> {
    located = BOUNDARY;
    let none = vec4<u32>(0u);
    let dims = batch.grid_dims;
    // As the CPU's truncation, clamped to the grid (a float32 cell: any start would do).
    let x = min(vec3<u32>(max((o - batch.grid_lo) * batch.grid_inv, vec3<f32>(0.0))),
        dims - vec3<u32>(1u));
    let cell = 5u * (x.x + dims.x * (x.y + dims.y * x.z));
    var t = locate[cell];
    var v = vec4<u32>(locate[cell + 1u], locate[cell + 2u], locate[cell + 3u], locate[cell + 4u]);
    let eta = batch.slack;
    // The face the walk came in by (certainly not beyond), 4 at the seed.
    var came = 4u;
    // Devillers et al.'s stochastic walk: each tet's faces from a random one, so that the walk
    // cannot cycle for ever in a mesh that is not Delaunay.
    var rng = (i + 1u) * 0x9E3779B9u | 1u;
    for (var step = 0u; step < LOCATE_GUARD; step++) {
        var p = array<vec3<f32>, 4>(position(v.x), position(v.y), position(v.z), position(v.w));
        rng ^= rng << 13u;
        rng ^= rng >> 17u;
        rng ^= rng << 5u;
        let first = rng >> 30u;
        var certain = 0u;
        var next = BOUNDARY;
        var face = vec3<u32>(0u);
        for (var k = 0u; k < 4u; k++) {
            let f = (first + k) & 3u;
            if f == came {
                certain++;
                continue;
            }
            let fv = outward_face(f);
            let s = orient_side(p[fv.x], p[fv.y], p[fv.z], o, eta);
            if s == SIDE_FALSE {
                certain++;
            } else if s == SIDE_TRUE {
                // Certainly beyond this face: cross it.
                face = vec3<u32>(v[fv.x], v[fv.y], v[fv.z]);
                var link = link_opposite(t, v[f], face.x, face.y, face.z);
                if link == BOUNDARY {
                    return none;
                }
                if (link & CONSTRAINED_BIT) != 0u {
                    link = locate[batch.beyond_at + (link & ~CONSTRAINED_BIT)];
                    if link == BOUNDARY {
                        return none;
                    }
                }
                next = link;
                break;
            }
        }
        if next == BOUNDARY {
            if certain == 4u {
                located = t;
                return v;
            }
            return none;
        }
        // The tet beyond (a, b, c), positively oriented: its fourth vertex d first, then the
        // face reversed (its outward side faces away from d).
        let d = fourth_vertex(next, face.x, face.y, face.z);
        t = next;
        v = vec4<u32>(d, face.x, face.z, face.y);
        came = 0u;
    }
    return none;
}

// Where o lies against the outward face (a, b, c): SIDE_TRUE certainly beyond it (the CPU's
// `orient(a, b, c, o) > 0`), SIDE_FALSE certainly on the tet's side, else SIDE_UNSURE.
fn orient_side(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, o: vec3<f32>, eta: f32) -> u32 {
    let x = a - o;
    let y = b - o;
    let z = c - o;
    let det = x.x * (y.y * z.z - y.z * z.y) + x.y * (y.z * z.x - y.x * z.z)
        + x.z * (y.x * z.y - y.y * z.x);
    let ax = abs(x);
    let ay = abs(y);
    let az = abs(z);
    let perm = ax.x * (ay.y * az.z + ay.z * az.y) + ax.y * (ay.z * az.x + ay.x * az.z)
        + ax.z * (ay.x * az.y + ay.y * az.x);
    let nx = ax.x + ax.y + ax.z;
    let ny = ay.x + ay.y + ay.z;
    let nz = az.x + az.y + az.z;
    let s = nx + ny + nz;
    let q = nx * ny + ny * nz + nz * nx;
    let e = eta + C_FLUSH;
    let bound = C_PERM * perm + 2.0 * e * (q + e * s + e * e) + C_FLUSH * (s + 1.0);
    // det(a - o, b - o, c - o) is minus the CPU's orientation.
    if det < -bound {
        return SIDE_TRUE;
    }
    if det > bound {
        return SIDE_FALSE;
    }
    return SIDE_UNSURE;
}
