//! Rust mirrors of the WGSL structs in `shaders/common.wgsl` and `shaders/layouts/`: `#[repr(C)]`, Pod (uploaded and read back
//! with bytemuck), with their sizes and field offsets asserted at compile time against the
//! WGSL layout rules (vec3<f32> aligns to 16 bytes and takes 12, so a u32 may follow it).

use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};

/// `Params` (uniform): rays in the batch and the step guard.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Params {
    pub n_rays: u32,
    pub max_steps: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// `RayIn`: a located, prepared ray (see shaders/common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RayIn {
    pub origin: [f32; 3],
    pub tet: u32,
    pub e0: [f32; 3],
    pub entry: u32,
    pub e1: [f32; 3],
    pub slack: f32,
    pub verts: [u32; 4],
}

/// `RayOut`: how a walk ended.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct RayOut {
    pub end: u32,
    pub constrained: u32,
    pub tet: u32,
    pub steps: u32,
    pub face: [u32; 4],
}

/// `Tet20` of shaders/layouts/tet20.wgsl (layout::tet20::Tet20Record).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Tet20 {
    pub vertex_xor: u32,
    pub links: [u32; 4],
}

/// `Face80` of shaders/layouts/tet80.wgsl (layout::tet80::Tet80Face).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Face80 {
    pub constrained: u32,
    pub neighbor: u32,
}

/// `Tet80` of shaders/layouts/tet80.wgsl (layout::tet80::Tet80Record).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Tet80 {
    pub vertices: [f32; 12],
    pub faces: [Face80; 4],
}

/// `END_*` of shaders/common.wgsl (any other end is END_STEP_LIMIT).
pub const END_BOUNDARY: u32 = 0;
pub const END_HIT: u32 = 1;
pub const END_DEFERRED: u32 = 3;
/// `NO_ENTRY` of shaders/common.wgsl.
pub const NO_ENTRY: u32 = 4;
/// `WORKGROUP` of shaders/common.wgsl.
pub const WORKGROUP: u32 = 64;

// WGSL layout: sizes are multiples of the struct's alignment (16 for structs holding a vec3 or
// vec4, 4 otherwise); array strides equal the sizes.
const _: () = {
    assert!(size_of::<Params>() == 16);
    assert!(size_of::<RayIn>() == 64);
    assert!(offset_of!(RayIn, origin) == 0);
    assert!(offset_of!(RayIn, tet) == 12);
    assert!(offset_of!(RayIn, e0) == 16);
    assert!(offset_of!(RayIn, entry) == 28);
    assert!(offset_of!(RayIn, e1) == 32);
    assert!(offset_of!(RayIn, slack) == 44);
    assert!(offset_of!(RayIn, verts) == 48);
    assert!(size_of::<RayOut>() == 32);
    assert!(offset_of!(RayOut, end) == 0);
    assert!(offset_of!(RayOut, constrained) == 4);
    assert!(offset_of!(RayOut, tet) == 8);
    assert!(offset_of!(RayOut, steps) == 12);
    assert!(offset_of!(RayOut, face) == 16);
    assert!(size_of::<Tet20>() == 20);
    assert!(offset_of!(Tet20, vertex_xor) == 0);
    assert!(offset_of!(Tet20, links) == 4);
    assert!(size_of::<Face80>() == 8);
    assert!(offset_of!(Face80, neighbor) == 4);
    assert!(size_of::<Tet80>() == 80);
    assert!(offset_of!(Tet80, vertices) == 0);
    assert!(offset_of!(Tet80, faces) == 48);
    // The GPU records are the CPU layouts' records, field for field.
    assert!(size_of::<Tet20>() == size_of::<crate::layout::tet20::Tet20Record>());
    assert!(size_of::<Tet80>() == size_of::<crate::layout::tet80::Tet80Record>());
};
