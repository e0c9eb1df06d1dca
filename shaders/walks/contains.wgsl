// Containment of points on the device (`Scene::contains`'s parity rule, `query::contains`):
// a point is inside when the tet holding it lies in a region an odd number of constrained
// faces from outside. Per point: outside the box (exactly: locate.wgsl's `box_side`) it is
// outside; inside, the tet strictly holding it (locate.wgsl's walk on certified signs) gives
// its region's parity. A point on or near a face (where it may lie on the surface, which
// counts as inside), whose walk leaves the domain or passes the guard, or that is not finite
// ends END_UNBEGUN: the host answers it (`Containment::point`). Joined after begin.wgsl (the
// uniform `batch`, the points in `dirs`) and locate.wgsl.
//
// RayOut.end: CONTAINS_OUT, CONTAINS_IN or END_UNBEGUN; the other fields are unused.

const CONTAINS_OUT: u32 = 8u;
const CONTAINS_IN: u32 = 9u;

// Per tet one bit (32 a word, the lowest first): its region is odd (`Parity`).
@group(0) @binding(11) var<storage, read> parity: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    let p = vec3<f32>(dirs[3u * i], dirs[3u * i + 1u], dirs[3u * i + 2u]);
    // From the bits: comparisons may flush subnormals to zero.
    let bits = bitcast<vec3<u32>>(p);
    let mag = bits & vec3<u32>(0x7fffffffu);
    var out: RayOut;
    out.end = END_UNBEGUN;
    if max(mag.x, max(mag.y, mag.z)) < 0x7f800000u {
        if any(box_side(bits) != vec3<i32>(0)) {
            out.end = CONTAINS_OUT;
        } else {
            let names = locate_origin(i, p);
            if located != BOUNDARY {
                let odd = (parity[located >> 5u] >> (located & 31u)) & 1u;
                out.end = select(CONTAINS_OUT, CONTAINS_IN, odd == 1u);
            }
        }
    }
    hits[i] = out;
}
