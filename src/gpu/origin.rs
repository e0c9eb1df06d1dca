//! The exact kernel for a batch whose rays share one origin (a camera, rays from one point):
//! the host locates the origin once, and the kernel begins every walk from the direction
//! alone (`shaders/walks/shared_origin.wgsl`). Each ray uploads its 12 bytes of direction
//! straight from the caller's array; there is no per-ray work on the host before the kernel.
//!
//! - Origin strictly inside a tet (and touching no triangle's plane): that tet, its vertex ids,
//!   go in the uniform; the kernel takes the first exit as `walk_begin` does.
//! - Origin outside the domain box: per axis, where the origin lies (exactly), the box rounded
//!   outward to float32, and the box's entry grid (`locate::boundary`) on the device; the
//!   kernel certifies a miss of the box or the boundary face the ray enters by, as
//!   `Locators::locate_exact` finds it, then takes the first step.
//!
//! Rays with their own origins take the own-origin kernel (`shaders/walks/own_origin.wgsl`,
//! [`own_origins`]): per ray, where the origin lies against the box (exactly), then outside
//! the box as above, inside it located on the device by the seed grid's visibility walk on
//! certified orientations ([`LocateTable`]).
//!
//! Every range is taken, one for the batch or one per ray: the CPU exact walk starts at the
//! origin (or where the ray enters the box) whatever tmin is, and skips what it meets before
//! tmin, so the kernels walk every ray from its origin and the host compares each finished
//! hit's t with the ray's range (`cast_shared`): a hit before tmin, or within an ulp of either
//! end, is walked again on the host. The host also answers the rays whose range the CPU
//! refuses (`checked_range`) and skips a ray from outside the box that ends before it, as the
//! CPU's `exact_line` does. Any other batch (an origin on a face, edge or vertex; rays started
//! from hits; a scene whose faces split the caller's triangles) takes the resumed path
//! (`cast::resumed`). A ray whose start the kernel cannot certify is walked by the host from
//! its start; every answer is the CPU exact walk's (docs/gpu.md).

use super::context::Gpu;
use super::structs::{GridSide, Shared};
use super::upload::upload_records;
use crate::accel::tetwalk::PlainState;
use crate::error::Result;
use crate::geom::predicates::orient;
use crate::locate::LocateState;
use crate::mesh::build::OUTWARD_FACES;
use crate::query::{ClosestHit, QueryKind};
use crate::scene::{Rays, Scene};
use crate::traverse::Exact;

/// The scene's entry grid on the device: each box side's cells (CSR starts) and, per entry,
/// the boundary face (tet << 2 | local face, its vertex ids in outward order).
pub struct EntryGrid {
    /// Where each side's cells and faces begin in the buffers, as the uniform names them.
    pub sides: [GridSide; 6],
    pub cells: wgpu::Buffer,
    pub faces: wgpu::Buffer,
}

impl EntryGrid {
    pub(crate) fn bytes(&self) -> u64 {
        self.cells.size() + self.faces.size()
    }
}

/// Uploads the scene's entry grid (`Scene::entry`) for the shared-origin kernel: each side's
/// cells and faces, one after another, and where each side's begin (the uniform's sides).
pub(crate) fn upload_entry_grid(g: &Gpu, scene: &Scene) -> Result<EntryGrid> {
    let mesh = &scene.mesh;
    let (mut cells, mut faces): (Vec<u32>, Vec<[u32; 4]>) = (Vec::new(), Vec::new());
    let sides = std::array::from_fn(|k| {
        let grid = scene.entry.side_grid(k);
        let side = GridSide {
            lo: grid.lo.map(|x| x as f32),
            inv_cell: grid.inv_cell.map(|x| x as f32),
            dims: grid.dims.map(|x| x as u32),
            cells: cells.len() as u32,
            faces: faces.len() as u32,
        };
        cells.extend_from_slice(grid.start);
        faces.extend(grid.faces.iter().map(|&(t, i)| {
            let tet = mesh.tets[t as usize];
            let [a, b, c] = OUTWARD_FACES[i as usize].map(|x| tet[x]);
            [t << 2 | i as u32, a, b, c]
        }));
        side
    });
    let cells = upload_records(g, "entry grid cells", cells.len(), |i| cells[i])?;
    // upload_records makes at least one record: a side-less grid still binds.
    let faces = upload_records(g, "entry grid faces", faces.len(), |i| faces[i])?;
    Ok(EntryGrid {
        sides,
        cells,
        faces,
    })
}

/// The own-origin kernel's locate table (binding 10): the seed grid's cells (each its seed tet
/// and that tet's vertex ids: Tet20 names a tet's vertices only by their xor), then each
/// constrained side's far tet (the walk crosses the surface; Tet20's link there names the
/// side).
pub struct LocateTable {
    pub buffer: wgpu::Buffer,
    /// Where the sides' far tets begin (words).
    pub beyond_at: u32,
}

impl LocateTable {
    pub(crate) fn bytes(&self) -> u64 {
        self.buffer.size()
    }
}

/// Uploads the scene's locate table for the own-origin kernel.
pub(crate) fn upload_locate_table(g: &Gpu, scene: &Scene) -> Result<LocateTable> {
    let mesh = &scene.mesh;
    let (_, _, _, seeds) = scene.locator.parts();
    let beyond_at = 5 * seeds.len();
    let words = beyond_at + mesh.constrained.len();
    let buffer = upload_records(g, "locate table", words, |i| {
        match i.checked_sub(beyond_at) {
            Some(side) => mesh.constrained[side].beyond,
            None => match (seeds[i / 5], i % 5) {
                (t, 0) => t,
                (t, k) => mesh.tets[t as usize][k - 1],
            },
        }
    })?;
    Ok(LocateTable {
        buffer,
        beyond_at: beyond_at as u32,
    })
}

/// The uniform of a batch of rays with their own origins for the own-origin kernel, or None
/// where it does not take them: rays from hits, a scene whose faces split the caller's
/// triangles (an origin strictly inside a tet may then lie in a triangle's plane: the host's
/// `origin_may_touch` asks), or one [`locate_uniform`] refuses. The caller sets the entry grid's sides, the hit table and the locate table's
/// offset.
pub(crate) fn own_origins(scene: &Scene, rays: &Rays<f32>, points_slack: f32) -> Option<Shared> {
    if rays.is_empty() || rays.leaving.is_some() || scene.incidence.split {
        return None;
    }
    locate_uniform(scene, points_slack)
}

/// What a kernel that locates points on the device (`shaders/walks/locate.wgsl`) reads in its
/// uniform: the points' slack, the box rounded outward and inward, the seed grid. None for an
/// empty scene or one with a coordinate beyond 2^32 (the orientation filter's bound must not
/// overflow).
pub(crate) fn locate_uniform(scene: &Scene, points_slack: f32) -> Option<Shared> {
    const LIMIT: f64 = 4294967296.0; // 2^32
    let mesh = &scene.mesh;
    let [lo, hi] = mesh.bounds;
    if mesh.is_empty() || !lo.iter().chain(&hi).all(|x| x.abs() <= LIMIT) {
        return None;
    }
    let (glo, inv, dims, _) = scene.locator.parts();
    Some(Shared {
        slack: points_slack,
        box_lo: lo.map(round_down),
        box_hi: hi.map(round_up),
        in_lo: lo.map(round_up),
        in_hi: hi.map(round_down),
        grid_lo: glo.map(|x| x as f32),
        grid_inv: inv.map(|x| x as f32),
        grid_dims: dims.map(|x| x as u32),
        ..Default::default()
    })
}

/// The uniform of a batch whose rays all leave one origin, or None when the batch is not one
/// the shared-origin kernel takes (see the module docs). `points_slack`: the device points'
/// rounding (`LayoutBuffers::points_slack`). The entry grid's sides are left for the caller,
/// from the grid on the device ([`EntryGrid::sides`]).
pub(crate) fn shared_origin(
    scene: &Scene,
    rays: &Rays<f32>,
    query: &ClosestHit,
    points_slack: f32,
    threads: Option<usize>,
) -> Option<Shared> {
    let o32 = crate::scene::cast::shared_origin(rays, threads)?;
    // The origin is located as for any range: the walk starts there whatever tmin is.
    shared_at(scene, o32.map(f64::from), query, points_slack)
}

/// [`shared_origin`] for rays known to share the origin `o` (a camera's): None where the
/// shared-origin kernel does not take them. Only the origin counts: each ray's direction and
/// range are the host's to check (`cast_shared`).
pub(crate) fn shared_at(
    scene: &Scene,
    o: [f64; 3],
    query: &ClosestHit,
    points_slack: f32,
) -> Option<Shared> {
    let o32 = o.map(|x| x as f32);
    if !o32.iter().all(|x| x.is_finite()) || o32.map(f64::from) != o {
        return None;
    }
    let mesh = &scene.mesh;
    let [lo, hi] = mesh.bounds;
    let beyond = [0, 1, 2].map(|a| {
        if o[a] < lo[a] {
            -1
        } else if o[a] > hi[a] {
            1
        } else {
            0
        }
    });
    let mut shared = Shared {
        origin: o32,
        slack: points_slack,
        box_lo: lo.map(round_down),
        box_hi: hi.map(round_up),
        beyond,
        ..Default::default()
    };
    if beyond != [0; 3] {
        // From outside, the kernel certifies a miss of the whole box or the face the line
        // enters by; a ray ending before the box is the host's to skip (`cast_shared`).
        return Some(shared);
    }
    // Inside: the start tet as the CPU exact walk locates it, for any ray from this origin
    // (from inside the box, location reads neither the direction nor the range: a probe
    // stands for the batch's rays, whose first might be one the CPU refuses).
    let locators = scene.locators();
    let mut st = LocateState::for_chunk(0);
    let probe = crate::geom::ray::Ray::new(o, [1.0, 0.0, 0.0], 0.0, f64::INFINITY);
    let (s, _) = locators
        .locate_exact::<f64, Exact>(&probe, &mesh.points, &mut st)
        .ok()?;
    let tet = mesh.tets[s.tet as usize];
    let p = |k: usize| mesh.points[tet[k] as usize];
    // Strictly inside (then the tet is the only one holding o), and in no triangle's plane
    // there (`TetWalk::begin_exact` asks the same once per origin).
    let strictly = OUTWARD_FACES.iter().enumerate().all(|(i, f)| {
        let (a, b, c) = (p(f[0]), p(f[1]), p(f[2]));
        let (own, at) = (orient(a, b, c, p(i)), orient(a, b, c, o));
        own != 0.0 && at != 0.0 && (own > 0.0) == (at > 0.0)
    });
    if s.entry.is_some() || !strictly || query.origin_may_touch(&s) {
        return None;
    }
    shared.inside = 1;
    shared.start_tet = s.tet;
    shared.verts = tet;
    Some(shared)
}

/// x rounded to a float32 number at most x.
fn round_down(x: f64) -> f32 {
    let r = x as f32;
    if (r as f64) > x {
        r.next_down()
    } else {
        r
    }
}

/// x rounded to a float32 number at least x.
fn round_up(x: f64) -> f32 {
    let r = x as f32;
    if (r as f64) < x {
        r.next_up()
    } else {
        r
    }
}

/// The state a kernel handed back, as the host's walk takes it on.
pub(crate) fn plain_state(o: &super::structs::RayOut) -> PlainState {
    PlainState {
        face: [o.face[0], o.face[1], o.face[2]],
        link: o.constrained,
        t: o.tet,
        steps: o.steps,
    }
}

/// The answer of an exact walk that ended with no meet: handed back at the domain boundary, or
/// finished at a face it crosses past its tmax (the CPU's policy stops there): a miss, in the
/// tet and after the steps the walk took. What `TetWalk::walk_on_from` answers there with a
/// fresh policy (no touch was told to it, so it kept no earlier meet), without preparing the
/// ray.
pub(crate) fn boundary_miss(o: &super::structs::RayOut) -> crate::query::RayHit {
    crate::query::RayHit {
        tet: o.tet as i32,
        steps: o.steps,
        ..crate::query::RayHit::nothing(crate::status::MISS)
    }
}

/// The answer of a hit the kernel finished (`gpu::finish`): what the host's exact walk
/// answers there, its values already the float32 ones the host writes.
pub(crate) fn finished_hit(o: &super::structs::RayOut) -> crate::query::RayHit {
    crate::query::RayHit {
        status: crate::status::HIT,
        t: o.hit[0] as f64,
        u: o.hit[1] as f64,
        v: o.hit[2] as f64,
        point: [0, 1, 2].map(|k| f32::from_bits(o.face[k]) as f64),
        triangle: o.constrained as i32,
        tet: o.tet as i32,
        steps: o.steps,
        audit: [0, 0],
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::cast::all_at;

    /// The parallel scan answers as a scan of every origin, wherever the one that differs
    /// lies (the first piece, a later piece, the last coordinate), for a -0 against 0 too.
    #[test]
    fn all_at_finds_any_origin_that_differs() {
        let o = [0.25f32, -3.0, 0.0];
        let n = 100_003; // several pieces and a short last one
        let same: Vec<f32> = o.iter().copied().cycle().take(3 * n).collect();
        for threads in [None, Some(1), Some(3)] {
            assert!(all_at(&same, o, threads));
            assert!(all_at(&same[..3], o, threads));
            for at in [1, 3 * 7 + 2, 3 * 16_384, 3 * 50_000 + 1, 3 * n - 1] {
                let mut apart = same.clone();
                apart[at] = if apart[at] == 0.0 { -0.0 } else { f32::NAN };
                assert!(
                    !all_at(&apart, o, threads),
                    "differs at {at}, threads {threads:?}"
                );
            }
        }
    }
}
