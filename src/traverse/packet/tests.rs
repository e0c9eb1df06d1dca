use super::{DirBox, Edge, Packet, PacketRay};
use crate::geom::exact::side;
use crate::simd::Simd;

/// A small deterministic generator (the tests need no statistics, only many cases).
struct Lcg(u64);
impl Lcg {
    fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Wherever the box test is certain, every direction in the box (its corners and random
/// points) has that exact side, judged by `geom::exact::side`; and boxes straddling an
/// edge's plane are found uncertain. The points lie within 2 of zero or are scaled by
/// 2^±40 (exactly: the same geometry, its products' rounding 2^±80 times as large), where
/// the bound must grow with the edge's norms, or by 2^-530 (products underflow: the bound's
/// absolute term decides); the directions are scaled by 2^±40 too (their
/// sides unchanged, exactly), where it must grow with the box's reach. A direction's side
/// within the box's bound is certain most of the time.
#[test]
fn box_side_is_the_exact_side_of_every_direction_in_the_box() {
    let mut rng = Lcg(7);
    let (mut certain, mut uncertain, mut within_certain) = (0, 0, 0);
    for case in 0..30000 {
        // 2^-530 from its bits: `powi` need not be exact where it is not folded (stop 63).
        let tiny = f64::from_bits((1023 - 530) << 52);
        let scale = [1.0, 2f64.powi(40), 2f64.powi(-40), tiny][case / 8 % 4];
        let dscale = [1.0, 2f64.powi(40), 2f64.powi(-40)][case / 24 % 3];
        let o = [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0);
        let p = [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0);
        // Every other q on the plane through o, p and the box's centre direction, up to
        // rounding: sides at the rounding's scale, where the bound decides.
        let centre = [0, 1, 2].map(|_| rng.unit() * 2.0 - 1.0);
        let q = if case % 2 == 0 {
            let (s, r) = (rng.unit() * 3.0 - 1.5, rng.unit() * 3.0 - 1.5);
            [0, 1, 2].map(|k| o[k] + (p[k] - o[k]) * s + centre[k] * r)
        } else {
            [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0)
        };
        let [o, p, q] = [o, p, q].map(|x| x.map(|c| c * scale));
        let width = [1e-1, 1e-4, 1e-12, 0.0][case / 2 % 4];
        let dirs: Vec<[f64; 3]> = (0..6)
            .map(|_| [0, 1, 2].map(|k| (centre[k] + (rng.unit() - 0.5) * width) * dscale))
            .collect();
        let b = DirBox::of(dirs.iter());
        let rel = |x: [f64; 3]| [0, 1, 2].map(|k| x[k] - o[k]);
        let edge = Edge::new(rel(p), rel(q));
        let s = edge.side(&b);
        // One direction alone, with its own bound or the box's: its exact side, or
        // uncertain.
        for v in &dirs {
            let one = edge.side_of(v);
            assert!(one == 0 || one == side(*v, o, p, q), "case {case}: one ray");
            let within = edge.side_within(v, edge.bound(&b));
            within_certain += (within != 0) as usize;
            assert!(
                within == 0 || within == side(*v, o, p, q),
                "case {case}: in the box"
            );
        }
        let corners =
            (0..8).map(|m| [0, 1, 2].map(|k| if m >> k & 1 == 0 { b.lo[k] } else { b.hi[k] }));
        let sides: Vec<i8> = dirs
            .iter()
            .copied()
            .chain(corners)
            .map(|v| side(v, o, p, q))
            .collect();
        if s == 0 {
            uncertain += 1;
        } else {
            certain += 1;
            assert!(
                sides.iter().all(|&x| x == s),
                "case {case}: box says {s}, rays {sides:?}"
            );
        }
        if sides.iter().any(|&x| x != sides[0]) || sides[0] == 0 {
            assert_eq!(s, 0, "case {case}: a straddled box must be uncertain");
        }
    }
    // Both outcomes occur, so neither branch is vacuous.
    assert!(
        certain > 1000 && uncertain > 1000,
        "{certain} certain, {uncertain} uncertain"
    );
    assert!(
        within_certain > 30000,
        "{within_certain} directions certain in their box"
    );
}

/// The per-ray exits are the same at every SIMD level, ray by ray, and each certain one
/// is the exit the exact sides name (`geom::exact::side`): on directions near the edges'
/// planes (uncertain exits) and far from them, in groups of every length (whole groups of
/// four and the rest).
#[test]
fn per_ray_exits_agree_at_every_simd_level_and_with_exact_sides() {
    let levels = Simd::supported_levels();
    if cfg!(target_arch = "x86_64") && std::env::var("CI").is_ok_and(|v| v == "true") {
        assert!(
            levels.len() > 1,
            "CI's machine runs AVX2: both levels must be compared"
        );
    }
    let mut rng = Lcg(11);
    let before = super::avx2_rays();
    let (mut certain, mut uncertain) = (0, 0);
    for case in 0..3000 {
        let o = [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0);
        let d = [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0);
        let [a, b, c] = [0, 1, 2].map(|_| [0, 1, 2].map(|_| rng.unit() * 4.0 - 2.0));
        let rel = |x: [f64; 3]| [0, 1, 2].map(|k| x[k] - o[k]);
        let edges = [a, b, c].map(|p| Edge::new(rel(d), rel(p)));
        // Directions near the plane of (o, d, a), at the rounding's scale for some.
        let width = [1e-1, 1e-9, 1e-15, 0.0][case % 4];
        let s = rng.unit();
        let base = [0, 1, 2].map(|k| (d[k] - o[k]) * s + (a[k] - o[k]));
        let n = case % 11 + 1;
        let rays: Vec<PacketRay> = (0..n)
            .map(|i| {
                let v = [0, 1, 2].map(|k| base[k] + (rng.unit() - 0.5) * width);
                PacketRay::new(i as u32, v)
            })
            .collect();
        let dirs = DirBox::of(rays.iter().map(|r| &r.dir));
        let bounds = edges.map(|e| e.bound(&dirs));
        let mut first: Option<(Vec<u8>, [usize; 4])> = None;
        for &level in &levels {
            let (mut exits, mut counts) = (vec![9u8; n], [0usize; 4]);
            let kernel = super::avx2_rays();
            Packet::exits_of(&edges, &bounds, &rays, &mut exits, &mut counts, level);
            // Each level runs its own code: the AVX2 kernel takes the whole groups of four
            // at that level and no ray at the portable one.
            let want = if level == Simd::Avx2 { n / 4 * 4 } else { 0 };
            assert_eq!(
                super::avx2_rays() - kernel,
                want as u64,
                "case {case}: rays the AVX2 kernel decided at {level:?}"
            );
            for (r, &e) in rays.iter().zip(&exits) {
                assert_eq!(e, Packet::exit_of(&edges, &bounds, &r.dir), "case {case}");
                if e == 3 {
                    uncertain += 1;
                    continue;
                }
                certain += 1;
                let sides = [a, b, c].map(|p| side(r.dir, o, d, p));
                let code = |s: i8| if s > 0 { 1 } else { 2 };
                let exact = super::EXITS[sides
                    .iter()
                    .enumerate()
                    .fold(0, |acc, (i, &s)| acc | code(s) << (2 * i))];
                assert!(
                    sides.iter().all(|&s| s != 0),
                    "case {case}: certain at a zero"
                );
                assert_eq!(e, exact, "case {case}: exit against the exact sides");
            }
            assert_eq!(counts.iter().sum::<usize>(), n);
            match &first {
                None => first = Some((exits, counts)),
                Some(f) => assert_eq!(f, &(exits, counts), "case {case}: {level:?}"),
            }
        }
    }
    assert!(
        certain > 1000 && uncertain > 1000,
        "{certain} certain, {uncertain} uncertain"
    );
    if levels.contains(&Simd::Avx2) {
        assert!(super::avx2_rays() - before > 5000, "the AVX2 kernel ran");
    }
}
