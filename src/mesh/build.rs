//! Construction of the topology from what a mesher gives: points, tets and constrained faces.
//!
//! Tets are re-oriented positively, faces are matched by sorting their vertex triples (no hash
//! map: a sort of 4T keys is cache-friendly and parallel), constrained faces are attached to
//! both tets that share them, and the result is validated so that the walk can trust it.

use crate::error::{Error, Result};
use crate::geom::predicates::orient;
use rayon::prelude::*;

/// Marks a face on the domain boundary: nothing lies beyond it.
pub const BOUNDARY: u32 = u32::MAX;
/// Bit set in a [`Link`] when the face is a scene triangle (a constrained face).
pub const CONSTRAINED_BIT: u32 = 1 << 31;
/// Largest tet count a 31-bit link can address (u32::MAX itself is BOUNDARY).
pub const MAX_TETS: usize = (CONSTRAINED_BIT - 1) as usize;

/// What lies across one face of a tet, packed into 32 bits so layouts can store it as is:
/// `BOUNDARY`, a neighbour tet id, or `CONSTRAINED_BIT | index` into [`TetMesh::constrained`].
pub type Link = u32;

/// One side of a constrained face: the scene triangle it lies on and the tet beyond it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConstrainedSide {
    pub triangle: u32,
    /// The tet on the other side, or BOUNDARY when the triangle lies on the domain boundary.
    pub beyond: u32,
}

/// Local vertex indices of the face opposite vertex i, ordered so that its normal points out of
/// a positively oriented tet (det(v1-v0, v2-v0, v3-v0) > 0).
pub const OUTWARD_FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

#[derive(Clone, Debug)]
pub struct TetMesh {
    pub points: Vec<[f64; 3]>,
    /// Positively oriented tets.
    pub tets: Vec<[u32; 4]>,
    /// `links[t][i]`: what lies across the face of tet t opposite its vertex i.
    pub links: Vec<[Link; 4]>,
    pub constrained: Vec<ConstrainedSide>,
    /// Axis-aligned bounds of all points.
    pub bounds: [[f64; 3]; 2],
    /// True when every boundary face lies on a side of `bounds`, so the domain is that box and
    /// rays from outside can enter by clipping against it.
    pub domain_is_box: bool,
    pub boundary_faces: usize,
}

pub fn bounds_of(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// Snaps coordinates within 1e-10 of the box's largest extent of a side of box `[lo, hi]`
/// onto it: a mesher's Steiner points on the box's sides can be an ulp or two off their plane.
pub fn snap_to_box(points: &mut [[f64; 3]], lo: [f64; 3], hi: [f64; 3]) {
    let tol = 1e-10 * (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    for p in points.iter_mut() {
        for a in 0..3 {
            if (p[a] - lo[a]).abs() <= tol {
                p[a] = lo[a];
            } else if (hi[a] - p[a]).abs() <= tol {
                p[a] = hi[a];
            }
        }
    }
}

/// Whether point `p` lies on a side of box `[lo, hi]`.
#[inline]
pub fn on_box(p: &[f64; 3], [lo, hi]: &[[f64; 3]; 2]) -> bool {
    (0..3).any(|a| p[a] == lo[a] || p[a] == hi[a])
}

/// A tet's face in the face-matching sort: its sorted point triple in the high 96 bits, the
/// side (tet * 4 + local face) in the low 32.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct FaceKey(u128);

impl FaceKey {
    fn new(triple: [u32; 3], side: u32) -> FaceKey {
        let [a, b, c] = triple.map(u128::from);
        FaceKey(a << 96 | b << 64 | c << 32 | u128::from(side))
    }
    /// The triple alone, for comparing faces.
    fn face(self) -> u128 {
        self.0 >> 32
    }
    fn triple(self) -> [u32; 3] {
        [
            (self.0 >> 96) as u32,
            (self.0 >> 64) as u32,
            (self.0 >> 32) as u32,
        ]
    }
    fn side(self) -> u32 {
        self.0 as u32
    }
}

#[inline]
fn sorted3(mut k: [u32; 3]) -> [u32; 3] {
    if k[0] > k[1] {
        k.swap(0, 1);
    }
    if k[1] > k[2] {
        k.swap(1, 2);
    }
    if k[0] > k[1] {
        k.swap(0, 1);
    }
    k
}

impl TetMesh {
    /// Builds and validates the topology.
    ///
    /// `faces[k]` is a constrained face (three point ids) lying on scene triangle
    /// `face_triangle[k]`. A face listed twice keeps the first triangle id.
    pub fn build(
        mut points: Vec<[f64; 3]>,
        tets: &[[u32; 4]],
        faces: &[[u32; 3]],
        face_triangle: &[u32],
    ) -> Result<TetMesh> {
        if tets.is_empty() {
            return Err(Error::InvalidInput("no tetrahedra".into()));
        }
        if tets.len() > MAX_TETS {
            return Err(Error::TooLarge(format!(
                "{} tets; links address at most {MAX_TETS}",
                tets.len()
            )));
        }
        if faces.len() != face_triangle.len() {
            return Err(Error::InvalidInput(format!(
                "{} constrained faces but {} triangle ids",
                faces.len(),
                face_triangle.len()
            )));
        }
        if points.len() >= u32::MAX as usize {
            return Err(Error::TooLarge(format!("{} points", points.len())));
        }
        if let Some(i) = points.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
            return Err(Error::InvalidInput(format!(
                "point {i} is not finite: {:?}",
                points[i]
            )));
        }
        let np = points.len() as u32;
        if let Some(t) = tets.iter().position(|t| t.iter().any(|&v| v >= np)) {
            return Err(Error::InvalidInput(format!(
                "tet {t} {:?} refers to a point beyond the {np} given",
                tets[t]
            )));
        }
        if let Some(f) = faces.iter().position(|f| f.iter().any(|&v| v >= np)) {
            return Err(Error::InvalidInput(format!(
                "constrained face {f} {:?} refers to a point beyond the {np} given",
                faces[f]
            )));
        }

        // Steiner points a mesher puts on the domain box's sides can be off their plane by an
        // ulp or two; snap them so that the domain is exactly the box (rays from outside are
        // clipped against it). Orientation is checked after, exactly, on the snapped points.
        let (lo, hi) = bounds_of(&points);
        snap_to_box(&mut points, lo, hi);

        // Orient positively with exact predicates; a flat tet cannot be walked through.
        let oriented: Vec<[u32; 4]> = tets
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let [a, b, c, d] = t.map(|v| points[v as usize]);
                let o = orient(a, b, c, d);
                if o > 0.0 {
                    Ok(*t)
                } else if o < 0.0 {
                    Ok([t[0], t[1], t[3], t[2]])
                } else {
                    Err(Error::InvalidMesh(format!("tet {i} {t:?} has zero volume")))
                }
            })
            .collect::<Result<_>>()?;
        crate::threads::checkpoint()?;

        // Match faces: sort (sorted vertex triple, tet*4+local) and pair equal neighbours.
        // Packed into one u128 (the triple, then the side), whose comparisons are one or two
        // integer compares: the sort is this build's longest step (and, between checkpoints,
        // what bounds how soon Ctrl-C stops it).
        let mut keys: Vec<FaceKey> = oriented
            .par_iter()
            .enumerate()
            .flat_map_iter(|(t, tet)| {
                OUTWARD_FACES.iter().enumerate().map(move |(i, f)| {
                    FaceKey::new(
                        sorted3([tet[f[0]], tet[f[1]], tet[f[2]]]),
                        (t as u32) * 4 + i as u32,
                    )
                })
            })
            .collect();
        crate::threads::checkpoint()?;
        keys.par_sort_unstable();
        crate::threads::checkpoint()?;
        let mut links = vec![[BOUNDARY; 4]; oriented.len()];
        let mut boundary_faces = 0usize;
        let mut j = 0;
        while j < keys.len() {
            let mut k = j + 1;
            while k < keys.len() && keys[k].face() == keys[j].face() {
                k += 1;
            }
            match k - j {
                1 => boundary_faces += 1,
                2 => {
                    let (x, y) = (keys[j].side(), keys[j + 1].side());
                    links[(x / 4) as usize][(x % 4) as usize] = y / 4;
                    links[(y / 4) as usize][(y % 4) as usize] = x / 4;
                }
                n => {
                    return Err(Error::InvalidMesh(format!(
                        "face {:?} is shared by {n} tets (at most 2 allowed)",
                        keys[j].triple()
                    )))
                }
            }
            j = k;
        }

        crate::threads::checkpoint()?;
        // Attach constrained faces to both sides.
        let mut constrained: Vec<ConstrainedSide> = Vec::with_capacity(faces.len() * 2);
        for (f, (&face, &tri)) in faces.iter().zip(face_triangle).enumerate() {
            let key = FaceKey::new(sorted3(face), 0).face();
            let lo = keys.partition_point(|e| e.face() < key);
            let sides: Vec<u32> = keys[lo..]
                .iter()
                .take_while(|e| e.face() == key)
                .map(|e| e.side())
                .collect();
            if sides.is_empty() {
                return Err(Error::InvalidMesh(format!(
                    "constrained face {f} {face:?} is not a face of any tet"
                )));
            }
            for &s in &sides {
                let (t, i) = ((s / 4) as usize, (s % 4) as usize);
                if links[t][i] & CONSTRAINED_BIT != 0 && links[t][i] != BOUNDARY {
                    continue; // listed twice: keep the first triangle id
                }
                let beyond = links[t][i];
                if constrained.len() >= MAX_TETS {
                    return Err(Error::TooLarge("too many constrained faces".into()));
                }
                links[t][i] = CONSTRAINED_BIT | constrained.len() as u32;
                constrained.push(ConstrainedSide {
                    triangle: tri,
                    beyond,
                });
            }
        }

        let on_box_side = |f: [u32; 3]| {
            (0..3).any(|a| {
                f.iter().all(|&v| points[v as usize][a] == lo[a])
                    || f.iter().all(|&v| points[v as usize][a] == hi[a])
            })
        };
        // A face on the domain's boundary has nothing beyond it: its link is BOUNDARY, or,
        // where it is constrained, its constrained side's `beyond` is. Both kinds must lie on
        // the box's sides (a domain wrapped only in scene triangles is no box either).
        let on_boundary = |l: Link| {
            l == BOUNDARY
                || (l & CONSTRAINED_BIT != 0
                    && constrained[(l & !CONSTRAINED_BIT) as usize].beyond == BOUNDARY)
        };
        let domain_is_box = links.iter().zip(&oriented).all(|(l, tet)| {
            (0..4).all(|i| !on_boundary(l[i]) || on_box_side(OUTWARD_FACES[i].map(|k| tet[k])))
        });

        Ok(TetMesh {
            points,
            tets: oriented,
            links,
            constrained,
            bounds: [lo, hi],
            domain_is_box,
            boundary_faces,
        })
    }

    pub fn len(&self) -> usize {
        self.tets.len()
    }

    /// Regions: sets of tets connected across faces that are not scene triangles, numbered
    /// so that region ids follow the order of their first tet. A ray walks within one region
    /// between hits, so tets grouped by region sit together in memory.
    pub fn regions(&self) -> Vec<u32> {
        // Union-find with path halving over free interior faces.
        let mut parent: Vec<u32> = (0..self.len() as u32).collect();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        for (t, links) in self.links.iter().enumerate() {
            for &l in links {
                if l & CONSTRAINED_BIT == 0 {
                    let (a, b) = (find(&mut parent, t as u32), find(&mut parent, l));
                    if a != b {
                        parent[a.max(b) as usize] = a.min(b);
                    }
                }
            }
        }
        let mut id = vec![u32::MAX; self.len()];
        let mut next = 0;
        (0..self.len() as u32)
            .map(|t| {
                let r = find(&mut parent, t) as usize;
                if id[r] == u32::MAX {
                    id[r] = next;
                    next += 1;
                }
                id[r]
            })
            .collect()
    }

    pub fn is_empty(&self) -> bool {
        self.tets.is_empty()
    }

    /// The neighbour across face i for point location and construction, which cross
    /// constrained faces freely.
    #[inline]
    pub fn neighbor(&self, t: u32, i: usize) -> u32 {
        let l = self.links[t as usize][i];
        if l == BOUNDARY {
            BOUNDARY
        } else if l & CONSTRAINED_BIT != 0 {
            self.constrained[(l & !CONSTRAINED_BIT) as usize].beyond
        } else {
            l
        }
    }

    #[inline]
    pub fn tet_points(&self, t: u32) -> [[f64; 3]; 4] {
        self.tets[t as usize].map(|v| self.points[v as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube split into 5 tets (one central, four corners), both windings mixed.
    pub(crate) fn cube5() -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
        let p = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        let t = vec![
            [0, 1, 2, 4],
            [3, 1, 2, 7],
            [5, 1, 4, 7],
            [6, 2, 7, 4],
            [1, 2, 4, 7],
        ];
        (p, t)
    }

    #[test]
    fn cube_topology() {
        let (p, t) = cube5();
        let m = TetMesh::build(p, &t, &[], &[]).unwrap();
        assert_eq!(m.boundary_faces, 12);
        assert!(m.domain_is_box);
        for (ti, tet) in m.tets.iter().enumerate() {
            let [a, b, c, d] = tet.map(|v| m.points[v as usize]);
            assert!(orient(a, b, c, d) > 0.0, "tet {ti} not positive");
        }
        // The central tet touches the other four, each once.
        let mut n = m.links[4];
        n.sort();
        assert_eq!(n, [0, 1, 2, 3]);
        // Links are symmetric.
        for t in 0..5u32 {
            for i in 0..4 {
                let u = m.neighbor(t, i);
                if u != BOUNDARY {
                    assert!((0..4).any(|j| m.neighbor(u, j) == t));
                }
            }
        }
    }

    /// The domain must be a box whether its boundary faces are constrained or not: a cube with
    /// a corner pulled out along its diagonal is no box, and constraining its twelve boundary
    /// faces (a domain wrapped in scene triangles) must not hide that. The cube itself, with
    /// the same faces constrained, is a box.
    #[test]
    fn a_domain_off_the_box_is_found_when_its_boundary_is_constrained() {
        let (p, t) = cube5();
        let m = TetMesh::build(p.clone(), &t, &[], &[]).unwrap();
        let boundary: Vec<[u32; 3]> = (0..m.tets.len())
            .flat_map(|ti| (0..4).map(move |i| (ti, i)))
            .filter(|&(ti, i)| m.links[ti][i] == BOUNDARY)
            .map(|(ti, i)| OUTWARD_FACES[i].map(|k| m.tets[ti][k]))
            .collect();
        assert_eq!(boundary.len(), 12);
        let tri = vec![0u32; boundary.len()];
        let mut pulled = p.clone();
        pulled[7] = [1.25, 1.25, 1.25];
        for (points, faces, is_box) in [
            (p.clone(), &boundary[..], true),
            (pulled.clone(), &[][..], false),
            (pulled, &boundary[..], false),
        ] {
            let m = TetMesh::build(points, &t, faces, &tri[..faces.len()]).unwrap();
            assert_eq!(m.domain_is_box, is_box, "{} faces constrained", faces.len());
        }
    }

    #[test]
    fn outward_faces_point_away() {
        let (p, t) = cube5();
        let m = TetMesh::build(p, &t, &[], &[]).unwrap();
        for tet in &m.tets {
            let v = tet.map(|i| m.points[i as usize]);
            for (i, f) in OUTWARD_FACES.iter().enumerate() {
                // The opposite vertex is behind an outward face.
                assert!(orient(v[f[0]], v[f[1]], v[f[2]], v[i]) < 0.0);
            }
        }
    }

    #[test]
    fn constrained_faces_attach_to_both_sides() {
        let (p, t) = cube5();
        // The face (1,2,4) is shared by the central tet and the corner tet at 0.
        let m = TetMesh::build(p, &t, &[[4, 2, 1], [0, 1, 2]], &[7, 9]).unwrap();
        let cs: Vec<_> = m
            .constrained
            .iter()
            .map(|c| (c.triangle, c.beyond))
            .collect();
        assert_eq!(cs.len(), 3);
        assert!(cs.contains(&(7, 0)) && cs.contains(&(7, 4)) && cs.contains(&(9, BOUNDARY)));
        // Location crosses constrained faces.
        assert!((0..4).any(|i| m.neighbor(0, i) == 4));
    }

    #[test]
    fn regions_split_at_constrained_faces() {
        let (p, t) = cube5();
        // Constrain the central tet's four faces: it becomes a region of its own.
        let m0 = TetMesh::build(p.clone(), &t, &[], &[]).unwrap();
        assert_eq!(m0.regions(), vec![0; 5]);
        let c = m0.tets[4];
        let faces: Vec<[u32; 3]> = OUTWARD_FACES.iter().map(|f| f.map(|k| c[k])).collect();
        let m = TetMesh::build(p, &t, &faces, &[0, 1, 2, 3]).unwrap();
        let r = m.regions();
        assert_eq!(
            r,
            vec![0, 1, 2, 3, 4],
            "corners are cut off from each other by the centre"
        );
    }

    #[test]
    fn errors_not_panics() {
        let (p, t) = cube5();
        let flat = vec![[0u32, 1, 2, 3]]; // four points of one cube face
        assert!(matches!(
            TetMesh::build(p.clone(), &flat, &[], &[]),
            Err(Error::InvalidMesh(_))
        ));
        let bad = vec![[0u32, 1, 2, 99]];
        assert!(matches!(
            TetMesh::build(p.clone(), &bad, &[], &[]),
            Err(Error::InvalidInput(_))
        ));
        let mut dup = t.clone();
        dup.push(t[4]);
        dup.push(t[4]);
        assert!(matches!(
            TetMesh::build(p.clone(), &dup, &[], &[]),
            Err(Error::InvalidMesh(_))
        ));
        assert!(matches!(
            TetMesh::build(p.clone(), &t, &[[0, 3, 5]], &[0]),
            Err(Error::InvalidMesh(_))
        ));
        let mut nan = p.clone();
        nan[0][1] = f64::NAN;
        assert!(matches!(
            TetMesh::build(nan, &t, &[], &[]),
            Err(Error::InvalidInput(_))
        ));
        assert!(matches!(
            TetMesh::build(p, &[], &[], &[]),
            Err(Error::InvalidInput(_))
        ));
    }
}
