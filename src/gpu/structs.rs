//! Rust mirrors of the WGSL structs in `shaders/common.wgsl` and `shaders/layouts/`: `#[repr(C)]`, Pod (uploaded and read back
//! with bytemuck), with their sizes and field offsets asserted at compile time against the
//! WGSL layout rules (vec3<f32> aligns to 16 bytes and takes 12, so a u32 may follow it).

use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};

/// `Params` (uniform): rays in the batch, the step guard and, for the own-origin kernel,
/// where the batch's origins begin in its ray buffer (in floats, after the directions).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Params {
    pub n_rays: u32,
    pub max_steps: u32,
    pub origins_at: u32,
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

/// `RayOut`: how a walk ended. A hit finished on the device ([`END_FINISHED`]) has the
/// caller's triangle in `constrained`, the point's coordinates (float bits) in `face` and
/// t, u, v in `hit`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RayOut {
    pub end: u32,
    pub constrained: u32,
    pub tet: u32,
    pub steps: u32,
    pub face: [u32; 4],
    pub hit: [f32; 4],
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

/// `GridSide` of shaders/walks/shared_origin.wgsl: one side of the domain box's entry grid
/// (`locate::boundary::SideGrid`), its cells' starts at `cells` in the cell buffer and its
/// faces at `faces` in the face buffer.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GridSide {
    pub lo: [f32; 2],
    pub inv_cell: [f32; 2],
    pub dims: [u32; 2],
    pub cells: u32,
    pub faces: u32,
}

/// `Shared` (uniform) of shaders/walks/shared_origin.wgsl: what every ray of a batch from one
/// origin shares, located once on the host.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Shared {
    /// The origin (a float32 number: the rays are float32) and η, the points' slack.
    pub origin: [f32; 3],
    pub slack: f32,
    /// Inside the box: the start tet's vertex ids (positively oriented, as `mesh.tets`).
    pub verts: [u32; 4],
    /// The domain box rounded outward to float32.
    pub box_lo: [f32; 3],
    pub start_tet: u32,
    pub box_hi: [f32; 3],
    /// 1 when the origin lies strictly inside `start_tet`, 0 when it is outside the box.
    pub inside: u32,
    /// Per axis, where the origin lies against the box (exactly): −1 below, 0 within, 1 above.
    pub beyond: [i32; 3],
    /// Where the hit table's corners begin (`finish::HitTable::sides`), or `finish::NONE`:
    /// the kernel then finishes no hit.
    pub finish: u32,
    pub sides: [GridSide; 6],
    /// The own-origin kernel's (the shared-origin kernel ignores them, `gpu::origin`): the
    /// box rounded inward, so that a float32 origin's side against the float64 box is a
    /// float32 comparison.
    pub in_lo: [f32; 3],
    pub _pad3: u32,
    pub in_hi: [f32; 3],
    /// Where the constrained sides' far tets begin in the locate table (`gpu::origin`).
    pub beyond_at: u32,
    /// The seed grid (`locate::GridLocator`), in float32 (it only picks a start).
    pub grid_lo: [f32; 3],
    pub _pad1: u32,
    pub grid_inv: [f32; 3],
    pub _pad: u32,
    pub grid_dims: [u32; 3],
    pub _pad2: u32,
}

/// `END_*` of shaders/common.wgsl (any other end is END_STEP_LIMIT).
pub const END_BOUNDARY: u32 = 0;
pub const END_HIT: u32 = 1;
pub const END_DEFERRED: u32 = 3;
/// Shared-origin kernel only: the ray's start could not be certified on the device (the host
/// begins and walks it), or it certainly misses the domain box.
pub const END_UNBEGUN: u32 = 5;
pub const END_MISS_BOX: u32 = 6;
/// Shared-origin kernel only: a hit the kernel finished (`gpu::finish`), the host's answer.
pub const END_FINISHED: u32 = 7;
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
    assert!(size_of::<RayOut>() == 48);
    assert!(offset_of!(RayOut, end) == 0);
    assert!(offset_of!(RayOut, constrained) == 4);
    assert!(offset_of!(RayOut, tet) == 8);
    assert!(offset_of!(RayOut, steps) == 12);
    assert!(offset_of!(RayOut, face) == 16);
    assert!(offset_of!(RayOut, hit) == 32);
    assert!(size_of::<GridSide>() == 32);
    assert!(offset_of!(GridSide, inv_cell) == 8);
    assert!(offset_of!(GridSide, dims) == 16);
    assert!(offset_of!(GridSide, cells) == 24);
    assert!(offset_of!(GridSide, faces) == 28);
    assert!(size_of::<Shared>() == 80 + 6 * 32 + 80);
    assert!(offset_of!(Shared, slack) == 12);
    assert!(offset_of!(Shared, verts) == 16);
    assert!(offset_of!(Shared, box_lo) == 32);
    assert!(offset_of!(Shared, start_tet) == 44);
    assert!(offset_of!(Shared, box_hi) == 48);
    assert!(offset_of!(Shared, inside) == 60);
    assert!(offset_of!(Shared, beyond) == 64);
    assert!(offset_of!(Shared, finish) == 76);
    assert!(offset_of!(Shared, sides) == 80);
    assert!(offset_of!(Shared, in_lo) == 272);
    assert!(offset_of!(Shared, _pad3) == 284);
    assert!(offset_of!(Shared, in_hi) == 288);
    assert!(offset_of!(Shared, beyond_at) == 300);
    assert!(offset_of!(Shared, grid_lo) == 304);
    assert!(offset_of!(Shared, grid_inv) == 320);
    assert!(offset_of!(Shared, grid_dims) == 336);
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
