//! One ray in float64, and the ray against the domain box.

/// One ray as the caller gave it (in float64; float32 rays convert exactly) with its
/// [tmin, tmax] as given (not yet clamped).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: [f64; 3],
    pub d: [f64; 3],
    pub tmin: f64,
    pub tmax: f64,
    /// Set for a ray that leaves the surface (a secondary ray started from a hit).
    pub leaving: Option<Leaving>,
}

impl Ray {
    /// A ray that starts nowhere in particular (not from a hit).
    pub fn new(o: [f64; 3], d: [f64; 3], tmin: f64, tmax: f64) -> Ray {
        Ray {
            o,
            d,
            tmin,
            tmax,
            leaving: None,
        }
    }
}

/// What a ray started from a hit (`start=hits`) knows of where it starts: the caller's
/// triangle it leaves and the tet the hit's walk ended in. Its hits lie strictly beyond the
/// point where its line crosses that triangle's plane (beyond its origin when the line is
/// parallel to the plane, [`crate::geom::exact::beyond`]): it never hits the triangle it
/// leaves, nor what its line meets before leaving it, however the hit point was rounded; and
/// it needs no offset origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leaving {
    /// The caller's triangle (its id and corners, as the scene holds them).
    pub triangle: u32,
    pub corners: [[f64; 3]; 3],
    /// Where location starts instead of the point locator (Lagae & Dutré's ray
    /// connectivity); `u32::MAX` when the hit names no tet (an accelerator that tests
    /// triangles found it).
    pub tet: u32,
}

/// The range [tmin, tmax] of a ray every exact query walks or tests: tmin raised to 0. Err:
/// the status of a ray no query traces (INVALID: a non-finite number, a zero direction or a
/// NaN bound; MISS: tmax below that range's start).
#[inline(always)]
pub fn checked_range(ray: &Ray) -> Result<(f64, f64), u8> {
    let Ray {
        o, d, tmin, tmax, ..
    } = *ray;
    let finite = o.iter().chain(&d).all(|x| x.is_finite());
    // A direction whose components span more than float64's exponent range cannot be scaled
    // by a power of two exactly (every exact predicate takes it so): refused, not answered
    // for a nearby line.
    let scalable = crate::geom::real::unit_scale_is_exact(d);
    if !finite || d == [0.0; 3] || !scalable || tmin.is_nan() || tmax.is_nan() {
        return Err(crate::status::INVALID);
    }
    valid_range(tmin, tmax)
}

/// [`checked_range`] of a ray that passes its INVALID checks (finite numbers, a direction
/// that scales exactly, bounds that are not NaN): for a caller that has shown those in bulk.
#[inline(always)]
pub fn valid_range(tmin: f64, tmax: f64) -> Result<(f64, f64), u8> {
    let tmin = tmin.max(0.0);
    if tmax < tmin {
        return Err(crate::status::MISS);
    }
    Ok((tmin, tmax))
}

/// Where a ray meets the domain box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxSpan {
    pub t0: f64,
    pub t1: f64,
    /// The side it enters by (axis, high side), or None when it starts inside.
    pub side: Option<(usize, bool)>,
}

/// The parameter range where the ray o + t d is inside the box, within [tmin, tmax].
pub fn clip_box(
    o: [f64; 3],
    d: [f64; 3],
    lo: [f64; 3],
    hi: [f64; 3],
    tmin: f64,
    tmax: f64,
) -> Option<BoxSpan> {
    let (mut t0, mut t1) = (tmin, tmax);
    let mut side = None;
    for a in 0..3 {
        if d[a] == 0.0 {
            // Parallel to the slab (either zero's sign): in it or never.
            if !(o[a] >= lo[a] && o[a] <= hi[a]) {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d[a];
        let (mut n, mut f) = ((lo[a] - o[a]) * inv, (hi[a] - o[a]) * inv);
        if n > f {
            std::mem::swap(&mut n, &mut f);
        }
        // 0 * inf is NaN when the ray is parallel and on a slab plane: treat as inside.
        if !n.is_nan() && n > t0 {
            t0 = n;
            side = Some((a, d[a] < 0.0));
        }
        if !f.is_nan() {
            t1 = t1.min(f);
        }
    }
    (t0 <= t1).then_some(BoxSpan { t0, t1, side })
}
