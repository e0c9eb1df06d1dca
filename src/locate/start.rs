//! Where a ray's walk starts: o + tmin·d when that lies in the domain, else where the ray enters
//! the box; the tet holding that point, found with hints carried between neighbouring rays.

use super::{BoundaryLocator, GridLocator, Located};
use crate::geom::ray::{checked_range, clip_box, Ray};
use crate::geom::real::{unit_scale, Real};
use crate::mesh::build::OUTWARD_FACES;
use crate::mesh::TetMesh;
use crate::status::{FAILED, INVALID, MISS};
use crate::traverse::packet::{DirBox, Edge};
use crate::traverse::robust::{settle_from, settle_start};
use crate::traverse::ExitMethod;

/// Where a ray's walk starts, once located.
#[derive(Clone, Copy, Debug)]
pub struct WalkStart {
    /// The ray as given (origin, direction) and its clamped [tmin, tmax].
    pub o: [f64; 3],
    pub d: [f64; 3],
    /// `d` scaled by a power of two (`real::unit_scale`, exact): what the walk is prepared with.
    pub dir: [f64; 3],
    pub tmin: f64,
    pub tmax: f64,
    /// The point the walk starts from (o + tmin d, or the entry point on the box).
    pub point: [f64; 3],
    pub tet: u32,
    /// The face of `tet` the ray enters by, when it comes from outside the box (never for a
    /// method with a perturbed start: its entry is settled like an interior start).
    pub entry: Option<usize>,
    /// The walk starts at the origin itself or at the box entry ([`Locators::locate_exact`]),
    /// not at o + tmin d: the query skips what lies before tmin.
    pub exact: bool,
    /// For a ray started from a hit: the caller's triangle it leaves ([`crate::geom::ray::Leaving`]).
    pub leaving: Option<u32>,
}

impl WalkStart {
    /// The exact walk's start of a checked ray, before location: its line and range, at its
    /// origin (`tet`, `entry` and, from outside the box, `point` are the locator's to set);
    /// Err: the status of a ray that does not walk (`checked_range`).
    pub fn exact(ray: &Ray) -> Result<WalkStart, u8> {
        let (tmin, tmax) = checked_range(ray)?;
        Ok(WalkStart {
            o: ray.o,
            d: ray.d,
            dir: unit_scale(ray.d),
            tmin,
            tmax,
            point: ray.o,
            tet: 0,
            entry: None,
            exact: true,
            leaving: ray.leaving.map(|l| l.triangle),
        })
    }

    /// The ray as method M's walk takes it (the CPU cast's and the GPU kernels' preparation).
    #[inline]
    pub fn prepare<R: Real, M: ExitMethod<R>>(&self, mesh: &TetMesh) -> M::Ray {
        // The exact walk's line is the ray's own: through o, not through a rounded start.
        let through = if M::CONTACTS { self.o } else { self.point };
        M::prepare(through, self.dir, &mesh.bounds)
    }
}

/// A located ray: done already with a status (invalid, missing the box, ...) or ready to walk.
#[derive(Clone, Copy, Debug)]
pub enum Start {
    Done(u8),
    Walk(WalkStart),
}

/// What location carries from one ray to the next within a chunk of rays: the last start tet,
/// the last camera origin's tet, the last box-entry cell, and the locator's random state. Reset
/// for every chunk (seeded by its index), so results do not depend on scheduling.
#[derive(Clone, Copy, Debug)]
pub struct LocateState {
    /// The last located point's grid cell and tet.
    hint: Option<(usize, u32)>,
    camera: Option<([f64; 3], f64, u32)>,
    entry_hint: Option<(usize, usize)>,
    entered: Option<EnteredFace>,
    /// The last origin in the box (bits), its start tet, and whether it may touch the surface
    /// there ([`LocateState::origin_may_touch`]).
    origin_touch: Option<([u64; 3], u32, bool)>,
    rng: u32,
    /// Rays whose entry face came from `entered` (tests check the shortcut ran).
    #[cfg(test)]
    reused: u32,
}

/// The boundary face the last ray from an origin outside the box entered by, seen from that
/// origin: the sides of its three edges decide, for the next ray from the same origin, whether
/// it enters by the same face ([`Locators::locate_exact`]).
#[derive(Clone, Copy, Debug)]
struct EnteredFace {
    /// The origin's bits (a NaN origin never gets here).
    origin: [u64; 3],
    tet: u32,
    face: usize,
    edges: [Edge; 3],
    /// The exact sides the ray had (all nonzero: its line crossed the face's interior).
    sides: [i8; 3],
}

impl LocateState {
    /// The state at the start of chunk k (a fixed seed per chunk: casts are reproducible).
    pub fn for_chunk(k: usize) -> LocateState {
        LocateState::seeded(0x9E37_79B9u32 ^ (k as u32).wrapping_mul(0x85EB_CA6B) | 1)
    }

    /// No hints yet, the locator's random state at `rng` (non-zero).
    pub fn seeded(rng: u32) -> LocateState {
        LocateState {
            hint: None,
            camera: None,
            entry_hint: None,
            entered: None,
            origin_touch: None,
            rng,
            #[cfg(test)]
            reused: 0,
        }
    }
}

/// The structures location reads.
#[derive(Clone, Copy)]
pub struct Locators<'a> {
    pub mesh: &'a TetMesh,
    pub grid: &'a GridLocator,
    pub entry: &'a BoundaryLocator,
}

impl Locators<'_> {
    /// Where `ray`'s walk starts. `settle`: the points the walk reads, for a method whose walk
    /// starts at the perturbed start point ([`ExitMethod::PERTURBED_START`]): the start, inside
    /// the box or entering it, then moves to the tet holding that point (`settle_start`), with
    /// no entry face (the method's start exit decides).
    #[inline]
    pub fn locate<R: Real>(
        &self,
        ray: &Ray,
        settle: Option<&[[R; 3]]>,
        st: &mut LocateState,
    ) -> Start {
        let Ray {
            o, d, tmin, tmax, ..
        } = *ray;
        let finite = o.iter().chain(&d).all(|x| x.is_finite());
        if !finite || d == [0.0; 3] || tmin.is_nan() || tmax.is_nan() {
            return Start::Done(INVALID);
        }
        let tmin = tmin.max(0.0);
        if tmax < tmin {
            return Start::Done(MISS);
        }
        let mesh = self.mesh;
        // Where the walk starts: o + tmin d if that is inside, else where the ray enters the box.
        let at = |s: f64| [0, 1, 2].map(|a| o[a] + s * d[a]);
        let mut start_point = at(tmin);
        let [lo, hi] = mesh.bounds;
        let inside = (0..3).all(|a| start_point[a] >= lo[a] && start_point[a] <= hi[a]);
        let mut entry_face = None;
        let start = if inside {
            match st.camera {
                Some((co, ct, t)) if co == o && ct == tmin => Located::Inside(t),
                _ => {
                    let mut l = self
                        .grid
                        .locate(mesh, start_point, &mut st.hint, &mut st.rng);
                    if let (Some(points), Located::Inside(t)) = (settle, l) {
                        // Depends on the start point only: cached with the camera's tet.
                        l = Located::Inside(settle_start(mesh, points, t, start_point));
                    }
                    if let Located::Inside(t) = l {
                        st.camera = Some((o, tmin, t));
                    }
                    l
                }
            }
        } else {
            let Some(entry) = clip_box(o, d, lo, hi, tmin, tmax) else {
                return Start::Done(MISS);
            };
            // Clamp: rounding may leave the entry point a hair off the box side.
            start_point = at(entry.t0);
            for a in 0..3 {
                start_point[a] = start_point[a].clamp(lo[a], hi[a]);
            }
            match entry.side {
                Some((axis, high)) => {
                    start_point[axis] = if high { hi[axis] } else { lo[axis] };
                    match self
                        .entry
                        .locate(start_point, axis, high, &mut st.entry_hint)
                    {
                        Some((t, i)) => {
                            entry_face = Some(i);
                            Located::Inside(t)
                        }
                        None => self
                            .grid
                            .locate(mesh, start_point, &mut st.hint, &mut st.rng),
                    }
                }
                None => self
                    .grid
                    .locate(mesh, start_point, &mut st.hint, &mut st.rng),
            }
        };
        let Located::Inside(mut start) = start else {
            // Inside the box but no tet holds the point: only a broken mesh can do this.
            return Start::Done(if inside { FAILED } else { MISS });
        };
        if let (Some(points), false) = (settle, inside) {
            // Entering through the box: the perturbed start lies just inside it, in the tet
            // settle_start finds; the exit from there is the method's to decide.
            start = settle_start(mesh, points, start, start_point);
            entry_face = None;
        }
        Start::Walk(WalkStart {
            o,
            d,
            // The walk needs only the direction: scaled exactly, tiny and huge ones behave.
            dir: unit_scale(d),
            tmin,
            tmax,
            point: start_point,
            tet: start,
            entry: entry_face,
            exact: false,
            leaving: ray.leaving.map(|l| l.triangle),
        })
    }

    /// Where the exact walk of `ray` starts (method M has [`ExitMethod::CONTACTS`]), and the
    /// ray prepared for it, or the status of a ray that does not walk. With the origin in the
    /// box: the tet holding o + εδ (the perturbed start, `settle_start`), whatever tmin is. From
    /// outside: the boundary face the line enters by, checked with M's exact predicates (the
    /// face under the rounded entry point first, else every boundary face), so no rounded
    /// point decides where the walk begins. `points` are those the walk reads.
    pub fn locate_exact<R: Real, M: ExitMethod<R>>(
        &self,
        ray: &Ray,
        points: &[[R; 3]],
        st: &mut LocateState,
    ) -> Result<(WalkStart, M::Ray), u8> {
        let (mut start, origin) = self.exact_line(ray)?;
        let WalkStart { o, dir, .. } = start;
        let mesh = self.mesh;
        let prepared = M::prepare(o, dir, &mesh.bounds);
        let ExactOrigin::Outside { side } = origin else {
            // A ray started from a hit starts next to the tet that hit's walk ended in (Lagae
            // & Dutré's ray connectivity): a few orientations instead of point location.
            let from_hit = ray
                .leaving
                .filter(|l| (l.tet as usize) < mesh.tets.len())
                .and_then(|l| settle_from(mesh, points, l.tet, o));
            start.tet = match (st.camera, from_hit) {
                (_, Some(t)) => t,
                (Some((co, _, t)), None) if co == o => t,
                _ => {
                    let Located::Inside(t) = self.grid.locate(mesh, o, &mut st.hint, &mut st.rng)
                    else {
                        return Err(FAILED);
                    };
                    let t = settle_start(mesh, points, t, o);
                    st.camera = Some((o, 0.0, t));
                    t
                }
            };
            return Ok((start, prepared));
        };
        let enters = |&(t, i): &(u32, usize)| {
            let tet = mesh.tets[t as usize];
            let face = OUTWARD_FACES[i].map(|k| points[tet[k] as usize]);
            M::enters(&prepared, &face)
        };
        // A ray from the last entering ray's origin whose exact sides on that face's edges are
        // that ray's (all nonzero) crosses the same face's interior the same way: it enters
        // there, and by no other face (the line meets the box's boundary once going in).
        let origin = o.map(f64::to_bits);
        let same_face = st
            .entered
            .filter(|e| M::PACKETS && e.origin == origin)
            .filter(|e| e.edges.map(|x| x.side_of(&dir)) == e.sides)
            .map(|e| (e.tet, e.face));
        #[cfg(test)]
        {
            st.reused += same_face.is_some() as u32;
        }
        let found = same_face.or_else(|| {
            let candidate = side.and_then(|(axis, high)| {
                self.entry
                    .locate(start.point, axis, high, &mut st.entry_hint)
            });
            let found = candidate
                .filter(enters)
                .or_else(|| self.entry.faces().find(enters))?;
            if M::PACKETS {
                st.entered = EnteredFace::seen(o, dir, found, mesh, points);
            }
            Some(found)
        });
        let Some((t, i)) = found else {
            // No face's interior is entered: the line misses the box, or touches it only on
            // its boundary (`GRAZES`).
            return Err(grazes_or_misses(o, start.d, mesh.bounds, start.tmax));
        };
        (start.tet, start.entry) = (t, Some(i));
        Ok((start, prepared))
    }

    /// What [`Locators::locate_exact`] decides before it looks for a tet: the ray checked (Err:
    /// the status of a ray that does not walk), its line, and whether its origin lies in the
    /// box; from outside, `point` is where the ray enters the box (rounded, then clamped onto
    /// it). `tet` and `entry` are left for the caller.
    pub fn exact_line(&self, ray: &Ray) -> Result<(WalkStart, ExactOrigin), u8> {
        let mut start = WalkStart::exact(ray)?;
        let tmax = start.tmax;
        let Ray { o, d, .. } = *ray;
        let [lo, hi] = self.mesh.bounds;
        if (0..3).all(|a| o[a] >= lo[a] && o[a] <= hi[a]) {
            return Ok((start, ExactOrigin::Inside));
        }
        // From outside, the ray must move towards each side its origin lies beyond (exact sign
        // tests). The float slabs below cannot tell: an origin 1e-310 beyond a side, moving
        // away at 1e300, crosses that side's plane at t = -1e-610, which rounds to -0.
        let away = |a: usize| (o[a] < lo[a] && d[a] <= 0.0) || (o[a] > hi[a] && d[a] >= 0.0);
        if (0..3).any(away) {
            return Err(MISS);
        }
        let Some(span) = clip_box(o, d, lo, hi, 0.0, tmax) else {
            return Err(grazes_or_misses(o, d, [lo, hi], tmax));
        };
        let mut p = [0, 1, 2].map(|a| (o[a] + span.t0 * d[a]).clamp(lo[a], hi[a]));
        if let Some((axis, high)) = span.side {
            p[axis] = if high { hi[axis] } else { lo[axis] };
        }
        start.point = p;
        Ok((start, ExactOrigin::Outside { side: span.side }))
    }
}

/// What [`Locators::locate_exact`] and [`Locators::exact_line`] give (as the `Err` of a ray
/// that does not walk) for a ray from outside the box whose line may touch the closed box
/// without entering it: at a point of an edge or a corner, or along a side's plane. It enters
/// no boundary face's interior, so the walk cannot start, yet a triangle with a point on the
/// box's boundary may be met there, and the contract makes that a hit. Never an answer: the
/// exact walk answers such a ray with the exact BVH (`TetWalk::begin_exact`), whose answers
/// are the walk's.
pub const GRAZES: u8 = u8::MAX;

/// [`GRAZES`] where the line may meet the closed box `[lo, hi]` within [0, tmax], else MISS:
/// the float slabs of a box grown by 2^-40 of each axis's magnitudes (the slabs' roundings
/// are a few 2^-53 of those), with tmax grown as much, find a span. A line that touches the
/// closed box passes through the grown one's interior, so it is never called a miss; one that
/// passes near without touching goes to the exact BVH too, which answers it right.
fn grazes_or_misses(o: [f64; 3], d: [f64; 3], [lo, hi]: [[f64; 3]; 2], tmax: f64) -> u8 {
    const GROW: f64 = 1.0 / (1u64 << 40) as f64;
    let pad = |a: usize| GROW * (lo[a].abs() + hi[a].abs() + o[a].abs()) + f64::MIN_POSITIVE;
    let lo = [0, 1, 2].map(|a| lo[a] - pad(a));
    let hi = [0, 1, 2].map(|a| hi[a] + pad(a));
    let tmax = tmax + GROW * tmax.abs();
    match clip_box(o, d, lo, hi, 0.0, tmax) {
        Some(_) => GRAZES,
        None => MISS,
    }
}

/// Where a ray's origin lies against the box ([`Locators::exact_line`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExactOrigin {
    Inside,
    /// Outside; `side`: the box side (axis, high) the ray enters by, when a slab decided it.
    Outside {
        side: Option<(usize, bool)>,
    },
}

impl LocateState {
    /// Whether a ray from origin `o` in start tet `tet` may touch the surface at its origin:
    /// `decide` once per origin and tet (it depends on nothing else), remembered for the next
    /// rays (a camera inside the box asks it of every ray).
    pub fn origin_may_touch(
        &mut self,
        o: [f64; 3],
        tet: u32,
        decide: impl FnOnce() -> bool,
    ) -> bool {
        let bits = o.map(f64::to_bits);
        match self.origin_touch {
            Some((b, t, may)) if b == bits && t == tet => may,
            _ => {
                let may = decide();
                self.origin_touch = Some((bits, tet, may));
                may
            }
        }
    }

    /// The start tet of origin `o` (in the box), when location found it for the last ray
    /// and no ray from `o` can touch the surface at its origin there
    /// ([`LocateState::origin_may_touch`] said so).
    pub fn origin_cannot_touch(&self, o: [f64; 3]) -> Option<u32> {
        let (co, _, t) = self.camera?;
        let bits = o.map(f64::to_bits);
        (co.map(f64::to_bits) == bits && self.origin_touch == Some((bits, t, false))).then_some(t)
    }

    /// The face the last ray from `origin` (outside the box) entered by, as (tet, face), when
    /// every direction in `dirs` has that ray's certain sides on the face's edges: each such
    /// ray crosses the face's interior the same way, so it enters there and by no other face
    /// (as [`Locators::locate_exact`]'s shortcut, for a box of directions at once).
    pub fn entered_by_all(&self, origin: [f64; 3], dirs: &DirBox) -> Option<(u32, usize)> {
        let e = self.entered?;
        (e.origin == origin.map(f64::to_bits) && e.edges.map(|x| x.side(dirs)) == e.sides)
            .then_some((e.tet, e.face))
    }
}

impl EnteredFace {
    /// Face i of tet t as the line (o, dir) that entered by it sees it; None when one of its
    /// sides is not certain (the line passes near an edge: the next ray locates afresh).
    fn seen<R: Real>(
        o: [f64; 3],
        dir: [f64; 3],
        (tet, face): (u32, usize),
        mesh: &TetMesh,
        points: &[[R; 3]],
    ) -> Option<EnteredFace> {
        let corners = mesh.tets[tet as usize];
        // As M::enters reads them, relative to o: P = fl(p − o) (Edge's bound covers it).
        let [p, q, r] = OUTWARD_FACES[face]
            .map(|k| [0, 1, 2].map(|a| points[corners[k] as usize][a].to_f64() - o[a]));
        let edges = Edge::around(p, q, r);
        let sides = edges.map(|e| e.side_of(&dir));
        sides.iter().all(|&s| s != 0).then_some(EnteredFace {
            origin: o.map(f64::to_bits),
            tet,
            face,
            edges,
            sides,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::real::Real;
    use crate::testing::{grid_scene, Rng};
    use crate::traverse::Exact;

    /// From origins outside the box, rays aimed at every boundary face's corners, edge
    /// midpoints and centroid (lines through the faces' edges and vertices, where the
    /// entered-face shortcut must not decide) and at random points: `locate_exact` carrying
    /// its state from ray to ray starts every ray where a fresh search does, and the shortcut
    /// ran for some of them.
    fn entries_match<R: Real>() {
        let mut rng = Rng::xorshift(11);
        // No jitter: the box's sides hold whole faces of a regular grid, with collinear edges.
        let g = grid_scene(&mut rng, 3, 0.0, 0.3);
        let (scene, points) = (&g.scene, g.scene.points::<R>());
        let locators = scene.locators();
        let mut targets: Vec<[f64; 3]> = Vec::new();
        for (t, i) in scene.entry.faces() {
            let tet = scene.mesh.tets[t as usize];
            let p = OUTWARD_FACES[i].map(|k| scene.mesh.points[tet[k] as usize]);
            let mid = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|k| (a[k] + b[k]) / 2.0);
            targets.extend(p);
            targets.extend([mid(p[0], p[1]), mid(p[1], p[2]), mid(p[2], p[0])]);
            targets.push([0, 1, 2].map(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0));
        }
        targets.extend((0..500).map(|_| [rng.f(), rng.f(), rng.f()]));
        let mut reused = 0;
        for eye in [[-0.7, 0.3, 0.45], [2.0, 1.5, -1.0], [0.5, 0.25, -3.0]] {
            let mut carried = LocateState::seeded(1);
            for (k, target) in targets.iter().enumerate() {
                let d = [0, 1, 2].map(|a| target[a] - eye[a]);
                let ray = Ray {
                    o: eye,
                    d,
                    tmin: 0.0,
                    tmax: f64::INFINITY,
                    leaving: None,
                };
                let start = |st: &mut LocateState| {
                    locators
                        .locate_exact::<R, Exact>(&ray, points, st)
                        .map(|(s, _)| (s.tet, s.entry, s.point.map(f64::to_bits)))
                };
                let fresh = start(&mut LocateState::seeded(1));
                assert_eq!(start(&mut carried), fresh, "eye {eye:?}, target {k}");
            }
            reused += carried.reused;
        }
        assert!(reused > 0, "the entered-face shortcut never ran");
    }

    #[test]
    fn shared_origin_entry_is_the_entry_a_fresh_search_finds() {
        entries_match::<f64>();
        entries_match::<f32>();
    }
}
