// Maria et al. 2017's 80-byte tet (src/layout/tet80.rs): the four vertices inline, named by
// their slot 0..3 in the current tet; a step reads one record and no point array. Walked by
// shaders/walks/inline.wgsl.

// Tet80Face: the constrained side's index (u32::MAX for a free face) and
// neighbour << 2 | the same face's index in the neighbour (u32::MAX on the domain boundary).
struct Face80 {
    constrained: u32,
    neighbor: u32,
}

// Tet80Record: 4 x 3 float32 vertices, then faces[i] opposite vertex i.
struct Tet80 {
    vertices: array<f32, 12>,
    faces: array<Face80, 4>,
}

@group(0) @binding(3) var<storage, read> tets: array<Tet80>;

// The position of the vertex in slot k of tet t.
fn slot_position(t: u32, k: u32) -> vec3<f32> {
    return vec3<f32>(tets[t].vertices[3u * k], tets[t].vertices[3u * k + 1u], tets[t].vertices[3u * k + 2u]);
}

// What lies across face i of tet t (a link), and that face's index in the neighbour.
fn across(t: u32, i: u32) -> vec2<u32> {
    let f = tets[t].faces[i];
    if f.constrained != 0xffffffffu {
        return vec2<u32>(CONSTRAINED_BIT | f.constrained, 0u);
    }
    if f.neighbor == 0xffffffffu {
        return vec2<u32>(BOUNDARY, 0u);
    }
    return vec2<u32>(f.neighbor >> 2u, f.neighbor & 3u);
}
