//! Containment (occupancy): is a point inside the scene's surface? Exact, with no ray cast.
//!
//! **The rule.** A point is inside when the fewest scene-triangle crossings needed to go from
//! it to outside the domain box is odd. For a closed (watertight) surface that is exactly
//! "inside the closed surface", and nested shells alternate (inside the outer shell but
//! inside the inner one too is outside). For an open surface it is a rule of its own: the
//! inside of a cup, or of a sphere with a hole, is reached from outside with no crossing, so it
//! is outside. Points exactly on the surface (on a scene triangle, its edge or its corner,
//! decided by exact predicates) are inside. Points outside the domain box are outside, and so
//! are points with a NaN or infinite coordinate (no separate status).
//!
//! **How.** Tets connected across faces that are not scene triangles form a region
//! ([`TetMesh::regions`]); every point of a region (off the surface) needs the same fewest
//! number of crossings. A breadth-first search over the region graph, whose edges are the
//! constrained faces, from the outside (regions with a free boundary face are at distance 0,
//! a scene triangle on the box is one crossing from outside) gives each region that number;
//! [`Parity`] keeps its parity per tet, built once per scene. A point is then located (the seed
//! grid and a walk), its tet is confirmed with the four exact orientations (walking on when the
//! locator's float answer was wrong), and the zeros among them say whether it lies on a face,
//! an edge or a vertex of the tet, where [`Incidence`] tells whether a scene triangle is there.

use crate::error::{Error, Result};
use crate::geom::predicates::orient;
use crate::geom::real::Real;
use crate::locate::{GridLocator, Located};
use crate::mesh::build::{CONSTRAINED_BIT, OUTWARD_FACES};
use crate::mesh::{Incidence, TetMesh, BOUNDARY};
use crate::threads::run_pieces;
use std::collections::VecDeque;

/// Points per parallel task; each task starts from fresh state, so answers do not depend on
/// the thread count (they are exact anyway).
pub const CHUNK: usize = 4096;

/// Steps of the exact walk that confirms a located tet before it falls back to a scan.
const SETTLE_STEPS: u32 = 1 << 12;

/// Per tet, whether the fewest scene-triangle crossings from its region to outside the domain
/// is odd (one bit per tet).
#[derive(Clone, Debug, Default)]
pub struct Parity {
    odd: Vec<u64>,
}

impl Parity {
    /// Regions, then a breadth-first search from outside over the constrained faces. Regions
    /// the search never reaches (a mesh piece that touches neither the box nor any other
    /// piece) count as even: outside.
    pub fn build(mesh: &TetMesh) -> Parity {
        let region = mesh.regions();
        let nr = region.iter().max().map_or(0, |&r| r as usize + 1);
        let outside = nr; // the node beyond the domain box
        let across = |l: u32| -> Option<usize> {
            if l == BOUNDARY || l & CONSTRAINED_BIT == 0 {
                return None;
            }
            let beyond = mesh.constrained[(l & !CONSTRAINED_BIT) as usize].beyond;
            Some(if beyond == BOUNDARY {
                outside
            } else {
                region[beyond as usize] as usize
            })
        };
        // Edges as compressed rows over nr + 1 nodes. Each constrained side is listed by the
        // tet it belongs to, so a face between two tets gives both directions; a scene
        // triangle on the box has one side, and outside's edge to it is added here.
        let mut offsets = vec![0u32; nr + 2];
        let mut free = vec![false; nr];
        for (t, links) in mesh.links.iter().enumerate() {
            let r = region[t] as usize;
            for &l in links {
                if l == BOUNDARY {
                    free[r] = true;
                } else if let Some(o) = across(l) {
                    offsets[r + 1] += 1;
                    if o == outside {
                        offsets[outside + 1] += 1;
                    }
                }
            }
        }
        for k in 0..=nr {
            offsets[k + 1] += offsets[k];
        }
        let mut fill = offsets.clone();
        let mut adj = vec![0u32; offsets[nr + 1] as usize];
        for (t, links) in mesh.links.iter().enumerate() {
            let r = region[t] as usize;
            for &l in links {
                if let Some(o) = across(l) {
                    adj[fill[r] as usize] = o as u32;
                    fill[r] += 1;
                    if o == outside {
                        adj[fill[outside] as usize] = r as u32;
                        fill[outside] += 1;
                    }
                }
            }
        }
        // Distance 0: outside and every region it reaches through a free boundary face.
        let mut dist = vec![u32::MAX; nr + 1];
        let mut queue = VecDeque::new();
        dist[outside] = 0;
        queue.push_back(outside);
        for r in (0..nr).filter(|&r| free[r]) {
            dist[r] = 0;
            queue.push_back(r);
        }
        while let Some(a) = queue.pop_front() {
            for &b in &adj[offsets[a] as usize..offsets[a + 1] as usize] {
                if dist[b as usize] == u32::MAX {
                    dist[b as usize] = dist[a] + 1;
                    queue.push_back(b as usize);
                }
            }
        }
        let mut odd = vec![0u64; mesh.len().div_ceil(64)];
        for (t, &r) in region.iter().enumerate() {
            let d = dist[r as usize];
            if d != u32::MAX && d % 2 == 1 {
                odd[t / 64] |= 1 << (t % 64);
            }
        }
        Parity { odd }
    }

    /// Whether tet t's region needs an odd number of crossings to get outside.
    #[inline]
    pub fn odd(&self, t: u32) -> bool {
        let t = t as usize;
        self.odd.get(t / 64).is_some_and(|w| w >> (t % 64) & 1 == 1)
    }

    /// The bits as 32-bit words (tet t: bit t % 32 of word t / 32), as the GPU reads them.
    pub fn word32(&self, k: usize) -> u32 {
        (self.odd.get(k / 2).map_or(0, |w| w >> (32 * (k % 2)))) as u32
    }

    pub fn bytes(&self) -> usize {
        self.odd.len() * 8
    }
}

/// What containment reads: the topology, the seed grid, the constrained faces by vertex and the
/// parity of each tet's region.
pub struct Containment<'a> {
    pub mesh: &'a TetMesh,
    pub grid: &'a GridLocator,
    pub incidence: &'a Incidence,
    pub parity: &'a Parity,
}

/// `answer(p, state)` for every point p (`points`: x y z of each, 3N values) into `out` (N),
/// in pieces of [`CHUNK`] points on the pool's threads (interruptible, `run_pieces`), after
/// [`check`]; `state(k)` is made fresh for piece k, so answers do not depend on the schedule.
/// The driver of every point query (containment, by the tetrahedralization or by rays, and
/// the closest points).
pub fn per_point<R: Real, O: Send, S>(
    points: &[R],
    out: &mut [O],
    threads: Option<usize>,
    state: impl Fn(usize) -> S + Sync + Send,
    answer: impl Fn([f64; 3], &mut S) -> O + Sync + Send,
) -> Result<()> {
    check(points.len(), out.len(), threads)?;
    let pieces: Vec<_> = points
        .chunks(3 * CHUNK)
        .zip(out.chunks_mut(CHUNK))
        .enumerate()
        .collect();
    run_pieces(
        pieces,
        threads,
        |(k, (pts, o)): (usize, (&[R], &mut [O]))| {
            let mut st = state(k);
            for (j, slot) in o.iter_mut().enumerate() {
                *slot = answer([0, 1, 2].map(|a| pts[3 * j + a].to_f64()), &mut st);
            }
        },
    )
}

/// Refuses arguments no containment query can run with: `points` must hold 3 values per
/// entry of `out`, and `threads` must not be `Some(0)`.
pub fn check(n_values: usize, n_out: usize, threads: Option<usize>) -> Result<()> {
    if n_values != 3 * n_out {
        return Err(Error::InvalidInput(format!(
            "{n_out} answers expected 3N = {} point coordinates, got {n_values}",
            3 * n_out
        )));
    }
    if threads == Some(0) {
        return Err(Error::InvalidOption(
            "threads must be at least 1 (or None for all cores)".into(),
        ));
    }
    Ok(())
}

impl Containment<'_> {
    /// `out[i]`: whether point i (`points[3i..3i+3]`, x y z, in either precision: float32
    /// values convert to f64 exactly) is inside (see the module's rule). Runs over chunks of
    /// [`CHUNK`] points on `threads` (None: all cores; Some(1): this thread only).
    pub fn points<R: Real>(
        &self,
        points: &[R],
        out: &mut [bool],
        threads: Option<usize>,
    ) -> Result<()> {
        per_point(
            points,
            out,
            threads,
            // A nonzero xorshift seed per chunk (the walks' random face order).
            |k| 0x9E37_79B9u32 ^ (k as u32).wrapping_mul(0x85EB_CA6B) | 1,
            |p, rng| self.point(p, rng),
        )
    }

    /// Whether the point p is inside; `rng`: the walks' xorshift state (nonzero).
    pub fn point(&self, p: [f64; 3], rng: &mut u32) -> bool {
        if !p.iter().all(|x| x.is_finite()) {
            return false;
        }
        let t = match self.grid.locate(self.mesh, p, &mut None, rng) {
            Located::Inside(t) => t,
            Located::Outside => return false,
        };
        let Some((t, side)) = self.settle(t, p, rng) else {
            return false;
        };
        // side[i] == 0: p lies on the plane of face i (opposite vertex i); the others are < 0.
        let zero = |i: usize| side[i] == 0.0;
        let tet = self.mesh.tets[t as usize];
        let on_surface = match (0..4).filter(|&i| zero(i)).count() {
            0 => false,
            1 => {
                let i = (0..4).find(|&i| zero(i)).unwrap();
                let l = self.mesh.links[t as usize][i];
                l != BOUNDARY && l & CONSTRAINED_BIT != 0
            }
            2 => {
                // The edge shared by the two faces: the two vertices they do not exclude.
                let mut ends = (0..4).filter(|&k| !zero(k)).map(|k| tet[k]);
                let (a, b) = (ends.next().unwrap(), ends.next().unwrap());
                self.incidence.at_edge(a, b).next().is_some()
            }
            3 => {
                let v = (0..4).find(|&k| !zero(k)).unwrap();
                !self.incidence.at_vertex(tet[v]).is_empty()
            }
            _ => false, // four zeros: a flat tet, which construction refuses
        };
        on_surface || self.parity.odd(t)
    }

    /// From the located tet t, a tet that holds p by exact predicates, with the orientation of
    /// p against each of its outward faces (all ≤ 0: positive would be beyond that face). The
    /// grid walk already decides with `orient` but may stop early (it skips the face it came
    /// through); an exact visibility walk confirms, and a scan ends it if that walk stalls.
    /// None: p is outside the domain.
    fn settle(&self, mut t: u32, p: [f64; 3], rng: &mut u32) -> Option<(u32, [f64; 4])> {
        let mesh = self.mesh;
        let sides = |t: u32| {
            let v = mesh.tet_points(t);
            OUTWARD_FACES.map(|f| orient(v[f[0]], v[f[1]], v[f[2]], p))
        };
        for _ in 0..SETTLE_STEPS {
            let s = sides(t);
            *rng ^= *rng << 13;
            *rng ^= *rng >> 17;
            *rng ^= *rng << 5;
            let first = (*rng % 4) as usize;
            match (0..4).map(|k| (first + k) % 4).find(|&i| s[i] > 0.0) {
                None => return Some((t, s)),
                Some(i) => {
                    t = mesh.neighbor(t, i);
                    if t == BOUNDARY {
                        return None;
                    }
                }
            }
        }
        (0..mesh.len() as u32)
            .map(|t| (t, sides(t)))
            .find(|(_, s)| s.iter().all(|&x| x <= 0.0))
    }
}

#[cfg(test)]
pub(crate) mod tests;
