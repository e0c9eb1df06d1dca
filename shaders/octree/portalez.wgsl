// Portalez & Duguet's neighbour-linked octree walk (specs §(a)), one invocation per ray, in
// float32 as the paper. Standalone kernel: src/gpu/octree.rs prepends the two lookup tables
// (`OUT_FACES`, `FACE_TO_NEIGHBOR`), generated from `accel::portalez_octree`'s own derivation
// so the kernel, its CPU twin and the exact walk share one table. Its CPU twin is
// `OctreeHost::twin` in src/gpu/octree.rs: the same float32 operations in the same order
// (no dot()/cross()/min()/fma builtins, whose evaluation order is the driver's; divisions only
// as 1/x, once per ray and per triangle, so a driver lowering x/y to x*rcp(y) changes nothing).
//
// Buffers (flattened from a balanced `PortalezOctree`, see octree.rs): `records` the leaf
// record stream `tCount | tOffset | leafIndex | nCount | links…`, `boxes` per leaf its lattice
// corner and level, `grid` the per-axis split planes rounded to float32 (neighbours read the
// same plane, so their boxes share faces bit for bit), `tris` the per-leaf triangle copies
// (3 vec4 each, the caller's id bitcast into the first w), `cube` the cube map.

struct OctParams {
    lo: vec3<f32>,
    n_rays: u32,
    hi: vec3<f32>,
    max_steps: u32,
    // cube_res / (hi - lo) per axis, computed on the host.
    scale: vec3<f32>,
    cube_res: u32,
    depth: u32,
    // grid[axis * grid_stride + i] is plane i of that axis (grid_stride = 2^depth + 1).
    grid_stride: u32,
    _pad0: u32,
    _pad1: u32,
}

struct OctRayIn {
    o: vec3<f32>,
    // The record of the leaf holding o (origins inside the root box, located on the host),
    // or NO_START: enter through the root box and the cube map.
    start: u32,
    d: vec3<f32>,
    _pad: u32,
}

struct OctRayOut {
    status: u32,
    // The caller's triangle id, or NO_TRI.
    tri: u32,
    t: f32,
    // Leaves whose triangles were tested.
    leaves: u32,
}

const NO_START: u32 = 0xffffffffu;
const NO_TRI: u32 = 0xffffffffu;
// crate::status
const STATUS_MISS: u32 = 0u;
const STATUS_HIT: u32 = 1u;
const STATUS_FAILED: u32 = 2u;
const WORKGROUP: u32 = 64u;

// Faces (reading A): 0 = +y, 1 = +x, 2 = -y, 3 = -x, 4 = +z, 5 = -z.
const FACE_AXIS = array<u32, 6>(1u, 0u, 1u, 0u, 2u, 2u);
// face_of(axis, positive) = FACE_OF[2 axis + positive].
const FACE_OF = array<u32, 6>(3u, 1u, 2u, 0u, 5u, 4u);

@group(0) @binding(0) var<uniform> params: OctParams;
@group(0) @binding(1) var<storage, read> rays: array<OctRayIn>;
@group(0) @binding(2) var<storage, read_write> hits: array<OctRayOut>;
@group(0) @binding(3) var<storage, read> records: array<u32>;
@group(0) @binding(4) var<storage, read> boxes: array<vec4<u32>>;
@group(0) @binding(5) var<storage, read> grid: array<f32>;
@group(0) @binding(6) var<storage, read> tris: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> cube: array<u32>;

fn face_of(axis: u32, positive: bool) -> u32 {
    return FACE_OF[2u * axis + select(0u, 1u, positive)];
}

// The in-plane axes of a face of `axis`, u < w.
fn in_u(axis: u32) -> u32 {
    return select(0u, 1u, axis == 0u);
}

fn in_w(axis: u32) -> u32 {
    return select(2u, 1u, axis == 2u);
}

fn plane(axis: u32, i: u32) -> f32 {
    return grid[axis * params.grid_stride + i];
}

// Π_k(P) = ((P - o) × d)_k.
fn pi(k: u32, p: vec3<f32>, o: vec3<f32>, d: vec3<f32>) -> f32 {
    let k1 = (k + 1u) % 3u;
    let k2 = (k + 2u) % 3u;
    return (p[k1] - o[k1]) * d[k2] - (p[k2] - o[k2]) * d[k1];
}

// Where the links of face f start in a record: after those of faces < f.
fn links_before(nc: u32, f: u32) -> u32 {
    var off = 0u;
    for (var g = 0u; g < f; g++) {
        off += (nc >> (4u * g)) & 15u;
    }
    return off;
}

fn texel(x: f32, axis: u32) -> u32 {
    let r = f32(params.cube_res - 1u);
    var s = (x - params.lo[axis]) * params.scale[axis];
    if s < 0.0 {
        s = 0.0;
    }
    if s > r {
        s = r;
    }
    return u32(s);
}

fn done(status: u32, tri: u32, t: f32, leaves: u32) -> OctRayOut {
    var out: OctRayOut;
    out.status = status;
    out.tri = tri;
    out.t = t;
    out.leaves = leaves;
    return out;
}

fn trace(ray: OctRayIn) -> OctRayOut {
    let o = ray.o;
    let d = ray.d;
    let pos = vec3<bool>(d.x > 0.0, d.y > 0.0, d.z > 0.0);
    // The exit corner's index, fixed for the ray: outFacesLookup's row.
    let row = select(0u, 1u, pos.x) + select(0u, 2u, pos.y) + select(0u, 4u, pos.z);
    var inv: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        inv[k] = 1.0 / d[k];
    }
    // Where the table says 7 (cyclic signs, rounding near a corner): the axis of largest |d|.
    var big = 0u;
    if abs(d.y) > abs(d[big]) {
        big = 1u;
    }
    if abs(d.z) > abs(d[big]) {
        big = 2u;
    }
    var addr = ray.start;
    if addr == NO_START {
        // Branch 1: the root box's slab test; e is the entry axis (the latest near plane).
        var tn = 0.0;
        var tf = 3.40282347e38;
        var e = 3u;
        for (var k = 0u; k < 3u; k++) {
            if d[k] == 0.0 {
                if o[k] < params.lo[k] || o[k] > params.hi[k] {
                    return done(STATUS_MISS, NO_TRI, 0.0, 0u);
                }
            } else {
                let near = select(params.hi[k], params.lo[k], pos[k]);
                let far = select(params.lo[k], params.hi[k], pos[k]);
                let t0 = (near - o[k]) * inv[k];
                let t1 = (far - o[k]) * inv[k];
                if e == 3u || t0 > tn {
                    tn = t0;
                    e = k;
                }
                if t1 < tf {
                    tf = t1;
                }
            }
        }
        if e == 3u || tn > tf || tf < 0.0 {
            return done(STATUS_MISS, NO_TRI, 0.0, 0u);
        }
        // The entry point, on the entry plane exactly; the cube map's texel there.
        var ent: vec3<f32>;
        for (var k = 0u; k < 3u; k++) {
            ent[k] = o[k] + tn * d[k];
        }
        ent[e] = select(params.hi[e], params.lo[e], pos[e]);
        let u = in_u(e);
        let w = in_w(e);
        let res = params.cube_res;
        addr = cube[(face_of(e, !pos[e]) * res + texel(ent[w], w)) * res + texel(ent[u], u)];
        // A texel may span several boundary leaves (cube_res < 2^depth) and the entry point
        // is rounded: step within the root face to the leaf whose box holds it.
        var fixes = 0u;
        loop {
            let b = boxes[records[addr + 2u]];
            let size = 1u << (params.depth - b.w);
            var m = 3u;
            var up = false;
            if ent[u] < plane(u, b[u]) {
                m = u;
            } else if ent[u] > plane(u, b[u] + size) {
                m = u;
                up = true;
            } else if ent[w] < plane(w, b[w]) {
                m = w;
            } else if ent[w] > plane(w, b[w] + size) {
                m = w;
                up = true;
            }
            if m == 3u {
                break;
            }
            fixes++;
            if fixes > params.max_steps {
                return done(STATUS_FAILED, NO_TRI, 0.0, 0u);
            }
            let f = face_of(m, up);
            let nc = records[addr + 3u];
            let n = (nc >> (4u * f)) & 15u;
            if n == 0u {
                break;
            }
            var j = 0u;
            if n == 4u {
                // The four finer neighbours: j = [X_u < c_u] + 2 [X_w < c_w] (builder's order).
                let half = size >> 1u;
                let mu = in_u(m);
                let mw = in_w(m);
                j = select(0u, 1u, ent[mu] < plane(mu, b[mu] + half))
                    + select(0u, 2u, ent[mw] < plane(mw, b[mw] + half));
            }
            addr = records[addr + 4u + links_before(nc, f) + j];
        }
    }
    var best = NO_TRI;
    var best_t = 0.0;
    var visited = 0u;
    loop {
        visited++;
        if visited > params.max_steps {
            return done(STATUS_FAILED, NO_TRI, 0.0, visited);
        }
        let tc = records[addr];
        let to = records[addr + 1u];
        let leaf = records[addr + 2u];
        let nc = records[addr + 3u];
        // Branches 2 and 3: Möller–Trumbore on the leaf's triangles, the nearest kept (ties:
        // the smallest id, so the order of the lists does not matter).
        for (var j = to; j < to + tc; j++) {
            let a = tris[3u * j];
            let b = tris[3u * j + 1u];
            let c = tris[3u * j + 2u];
            let e1 = vec3<f32>(b.x - a.x, b.y - a.y, b.z - a.z);
            let e2 = vec3<f32>(c.x - a.x, c.y - a.y, c.z - a.z);
            let px = d.y * e2.z - d.z * e2.y;
            let py = d.z * e2.x - d.x * e2.z;
            let pz = d.x * e2.y - d.y * e2.x;
            let det = (e1.x * px + e1.y * py) + e1.z * pz;
            if det == 0.0 {
                continue;
            }
            let idet = 1.0 / det;
            let s = vec3<f32>(o.x - a.x, o.y - a.y, o.z - a.z);
            let uu = ((s.x * px + s.y * py) + s.z * pz) * idet;
            if !(uu >= 0.0 && uu <= 1.0) {
                continue;
            }
            let qx = s.y * e1.z - s.z * e1.y;
            let qy = s.z * e1.x - s.x * e1.z;
            let qz = s.x * e1.y - s.y * e1.x;
            let vv = ((d.x * qx + d.y * qy) + d.z * qz) * idet;
            if !(vv >= 0.0 && uu + vv <= 1.0) {
                continue;
            }
            let t = ((e2.x * qx + e2.y * qy) + e2.z * qz) * idet;
            let id = bitcast<u32>(a.w);
            if t >= 0.0 && (best == NO_TRI || t < best_t || (t == best_t && id < best)) {
                best = id;
                best_t = t;
            }
        }
        // The exit face: signs of Π at the exit corner through outFacesLookup.
        let bx = boxes[leaf];
        let size = 1u << (params.depth - bx.w);
        var corner: vec3<f32>;
        for (var k = 0u; k < 3u; k++) {
            corner[k] = plane(k, select(bx[k], bx[k] + size, pos[k]));
        }
        let bits = select(0u, 1u, pi(0u, corner, o, d) < 0.0)
            | select(0u, 2u, pi(1u, corner, o, d) < 0.0)
            | select(0u, 4u, pi(2u, corner, o, d) < 0.0);
        var f = OUT_FACES[row * 8u + bits];
        if f == 7u || d[FACE_AXIS[f]] == 0.0 {
            f = face_of(big, pos[big]);
        }
        let a = FACE_AXIS[f];
        let t_exit = (corner[a] - o[a]) * inv[a];
        // A hit inside this leaf (t up to its exit) is the nearest; one beyond waits.
        if best != NO_TRI && best_t <= t_exit {
            return done(STATUS_HIT, best, best_t, visited);
        }
        // Branch 4: no neighbour, the ray leaves the root.
        let n = (nc >> (4u * f)) & 15u;
        if n == 0u {
            if best != NO_TRI {
                return done(STATUS_HIT, best, best_t, visited);
            }
            return done(STATUS_MISS, NO_TRI, 0.0, visited);
        }
        var j = 0u;
        if n == 4u {
            // Four finer neighbours: Π on the axis lines through the exit face's centre.
            let half = size >> 1u;
            let u = in_u(a);
            let w = in_w(a);
            var c = corner;
            c[u] = plane(u, bx[u] + half);
            c[w] = plane(w, bx[w] + half);
            let qb = select(0u, 1u << u, pi(u, c, o, d) < 0.0)
                | select(0u, 1u << w, pi(w, c, o, d) < 0.0);
            j = FACE_TO_NEIGHBOR[f * 8u + qb];
        }
        addr = records[addr + 4u + links_before(nc, f) + j];
    }
    // Not reached (the loop only returns); naga wants a return on every path.
    return done(STATUS_FAILED, NO_TRI, 0.0, visited);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.y * nwg.x * WORKGROUP + gid.x;
    if i >= params.n_rays {
        return;
    }
    hits[i] = trace(rays[i]);
}
