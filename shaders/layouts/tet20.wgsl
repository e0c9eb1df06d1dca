// Aman et al. 2022's Tet20 (src/layout/tet20.rs): 20 bytes a tet, vertices named by id and
// read from the point array. Walked by shaders/walks/by_id.wgsl.

// Tet20Record: the xor of the four vertex ids, and the four links ordered by the rank of the
// opposite vertex's id.
struct Tet20 {
    vertex_xor: u32,
    links: array<u32, 4>,
}

@group(0) @binding(3) var<storage, read> tets: array<Tet20>;
// Scene points in float32, padded to 16 bytes (w = 0).
@group(0) @binding(4) var<storage, read> points: array<vec4<f32>>;

// The position of vertex `id`.
fn position(id: u32) -> vec3<f32> {
    let p = points[id];
    return vec3<f32>(p.x, p.y, p.z);
}

// The vertex of tet t other than a, b and c.
fn fourth_vertex(t: u32, a: u32, b: u32, c: u32) -> u32 {
    return tets[t].vertex_xor ^ a ^ b ^ c;
}

// What lies across the face of tet t opposite vertex x; a, b, c are its other vertices.
fn link_opposite(t: u32, x: u32, a: u32, b: u32, c: u32) -> u32 {
    return tets[t].links[rank(x, a, b, c)];
}
