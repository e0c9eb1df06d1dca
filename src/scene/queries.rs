//! The query table: every ray query a caller can ask a scene for, one row each. A row is a
//! type implementing [`RayJob`] (its name, its output buffers, how the scene fills them and the
//! named columns it answers with); `query_table!` makes the [`QueryName`] enum, the names
//! Python lists (`tetrace._native.queries()`) and the dispatch ([`QueryName::visit`]) from the
//! rows. The bindings take a query by name and one request for every kind, so a new query kind
//! is its job type here (over a `query/` policy) and a row.

use super::{AccelKind, CastOptions, HitBuffers, Rays, Scene};
use crate::error::{try_vec, try_with_capacity, try_zeroed_vec, Error, Result};
use crate::geom::real::Real;
use crate::layout::LayoutKind;
use crate::query::Listed;
use crate::traverse::Method;

/// What a ray query asks besides the rays and the cast options: the tet walk's exit method and
/// layout (None: the core's defaults), and whether a closest-hit cast audits its exit faces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ask {
    pub method: Option<Method>,
    pub layout: Option<LayoutKind>,
    pub audit: bool,
}

impl Ask {
    /// The accelerator a CPU query takes when none is named: the exact 8-wide BVH
    /// (`accel::exact_bvh`) where the exact method's answers are asked for with no layout, no
    /// step guard (`max_steps`) and no audit (its status, triangle, t, u, v and point are the
    /// exact walk's, bit for bit; issue 35), else the tet walk, which is what a named method,
    /// a layout, a step guard or the audit of rejected exit faces is about.
    pub fn default_accel(&self, max_steps: Option<u32>) -> AccelKind {
        let exact = self.method.is_none_or(|m| m == Method::DEFAULT);
        if exact && self.layout.is_none() && max_steps.is_none() && !self.audit {
            AccelKind::ExactBvh
        } else {
            AccelKind::TetWalk
        }
    }

    pub fn method(&self) -> Method {
        self.method.unwrap_or(Method::DEFAULT)
    }
    pub fn layout(&self) -> LayoutKind {
        self.layout.unwrap_or(LayoutKind::DEFAULT)
    }
}

/// One named output array: the values (a `Vec` of a plain number type, handed to numpy without
/// a copy) and the columns per row (1, or 3 for points).
pub struct Column {
    pub name: &'static str,
    pub values: Box<dyn std::any::Any + Send>,
    pub width: usize,
}

impl Column {
    pub fn new<T: Send + 'static>(name: &'static str, values: Vec<T>) -> Column {
        Column {
            name,
            values: Box::new(values),
            width: 1,
        }
    }
    pub fn rows3<T: Send + 'static>(name: &'static str, values: Vec<T>) -> Column {
        Column {
            width: 3,
            ..Column::new(name, values)
        }
    }
}

/// A ray query as a row of the table.
pub trait RayJob {
    /// Its name in `tetrace._native.queries()`.
    const NAME: &'static str;
    /// The buffers it fills for rays of precision R.
    type Out<R: Real>: Send;
    /// Buffers for `n` rays (`MemoryError`, not an abort, when they cannot be allocated).
    fn output<R: Real>(n: usize, ask: &Ask) -> Result<Self::Out<R>>;
    /// Fills `out`; called with the GIL released.
    fn run<R: Real>(
        scene: &Scene,
        ask: &Ask,
        rays: &Rays<R>,
        out: &mut Self::Out<R>,
        opts: &CastOptions,
    ) -> Result<()>;
    /// The answer as named columns.
    fn columns<R: Real>(out: Self::Out<R>) -> Result<Vec<Column>>;
}

/// Something to do with a query of any type: [`QueryName::visit`] calls it with the one named.
pub trait JobVisitor {
    type Out;
    fn visit<J: RayJob>(self) -> Self::Out;
}

macro_rules! query_table {
    ($($variant:ident),* $(,)?) => {
        /// A ray query, as the bindings name it.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum QueryName {
            $($variant),*
        }

        /// The names `tetrace._native.queries()` lists (each is its job's `RayJob::NAME`).
        pub const QUERIES: &[&str] = &[$(<$variant as RayJob>::NAME),*];

        impl QueryName {
            pub const ALL: &'static [QueryName] = &[$(QueryName::$variant),*];

            pub fn name(self) -> &'static str {
                match self {
                    $(QueryName::$variant => <$variant as RayJob>::NAME),*
                }
            }

            /// Calls `v` with the query's job type.
            pub fn visit<V: JobVisitor>(self, v: V) -> V::Out {
                match self {
                    $(QueryName::$variant => v.visit::<$variant>()),*
                }
            }
        }
    };
}

query_table! {
    Closest,
    Any,
    All,
    Count,
}

impl QueryName {
    /// The query named `name`, or an error listing the known ones.
    pub fn from_name(name: &str) -> Result<QueryName> {
        QueryName::ALL
            .iter()
            .copied()
            .find(|q| q.name() == name)
            .ok_or_else(|| Error::unknown("query", name, QUERIES))
    }
}

/// Closest hits: `t`, `u`, `v`, `point`, `triangle`, `tet`, `steps`, `status` (and `audit`).
pub struct Closest;

impl RayJob for Closest {
    const NAME: &'static str = "closest";
    type Out<R: Real> = HitBuffers<R>;
    fn output<R: Real>(n: usize, ask: &Ask) -> Result<HitBuffers<R>> {
        HitBuffers::try_new(n, ask.audit)
    }
    fn run<R: Real>(
        scene: &Scene,
        ask: &Ask,
        rays: &Rays<R>,
        out: &mut HitBuffers<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        scene.cast_with(ask.method(), ask.layout(), rays, out.out(), opts)
    }
    fn columns<R: Real>(b: HitBuffers<R>) -> Result<Vec<Column>> {
        let mut c = vec![
            Column::new("t", b.t),
            Column::new("u", b.u),
            Column::new("v", b.v),
            Column::rows3("point", b.point),
            Column::new("triangle", b.triangle),
            Column::new("tet", b.tet),
            Column::new("steps", b.steps),
            Column::new("status", b.status),
        ];
        if !b.audit.is_empty() {
            c.push(Column {
                width: 2,
                ..Column::new("audit", b.audit)
            });
        }
        Ok(c)
    }
}

/// Any hit (occlusion): `status`, HIT when a scene triangle lies on the ray in [tmin, tmax].
pub struct Any;

impl RayJob for Any {
    const NAME: &'static str = "any";
    type Out<R: Real> = Vec<u8>;
    fn output<R: Real>(n: usize, _: &Ask) -> Result<Vec<u8>> {
        try_zeroed_vec(n, "the answers of occluded")
    }
    fn run<R: Real>(
        scene: &Scene,
        ask: &Ask,
        rays: &Rays<R>,
        out: &mut Vec<u8>,
        opts: &CastOptions,
    ) -> Result<()> {
        scene.occluded(ask.method(), ask.layout(), rays, out, opts)
    }
    fn columns<R: Real>(status: Vec<u8>) -> Result<Vec<Column>> {
        Ok(vec![Column::new("status", status)])
    }
}

/// Every point where each ray meets the surface in [tmin, tmax], sorted by t: flat `t`,
/// `triangle`, `u`, `v`, `point` with `offsets` (N + 1) per ray, and `status`.
pub struct All;

/// Every point per ray, counted: `count` (int32) and `status`.
pub struct Count;

/// The exact walk lists every point (the points at vertices and edges are its touches): no
/// other method can, so only it (or None) is taken.
fn all_hits<R: Real>(
    scene: &Scene,
    ask: &Ask,
    rays: &Rays<R>,
    out: &mut [Listed],
    opts: &CastOptions,
) -> Result<()> {
    if ask.method() != Method::Exact {
        return Err(Error::InvalidOption(format!(
            "all hits and counts need the exact method, not {:?}",
            ask.method().name()
        )));
    }
    scene.intersections_in(ask.layout(), rays, out, opts)
}

impl RayJob for All {
    const NAME: &'static str = "all";
    type Out<R: Real> = Vec<Listed>;
    fn output<R: Real>(n: usize, _: &Ask) -> Result<Vec<Listed>> {
        try_vec(n, Listed::default(), "the hits of each ray")
    }
    fn run<R: Real>(
        scene: &Scene,
        ask: &Ask,
        rays: &Rays<R>,
        out: &mut Vec<Listed>,
        opts: &CastOptions,
    ) -> Result<()> {
        all_hits(scene, ask, rays, out, opts)
    }
    fn columns<R: Real>(listed: Vec<Listed>) -> Result<Vec<Column>> {
        let total: usize = listed.iter().map(|l| l.meets.len()).sum();
        let what = "the intersections";
        let (mut t, mut triangle, mut u, mut v) = (
            try_with_capacity(total, what)?,
            try_with_capacity(total, what)?,
            try_with_capacity(total, what)?,
            try_with_capacity(total, what)?,
        );
        let mut point = try_with_capacity(3 * total, what)?;
        let mut offsets = try_with_capacity(listed.len() + 1, "the offsets of the intersections")?;
        let mut status = try_with_capacity(listed.len(), "the statuses")?;
        offsets.push(0i64);
        for l in &listed {
            for m in &l.meets {
                t.push(m.t);
                triangle.push(m.triangle as i32);
                u.push(m.u);
                v.push(m.v);
                point.extend(m.point);
            }
            offsets.push(t.len() as i64);
            status.push(l.status);
        }
        Ok(vec![
            Column::new("offsets", offsets),
            Column::new("t", t),
            Column::new("triangle", triangle),
            Column::new("u", u),
            Column::new("v", v),
            Column::rows3("point", point),
            Column::new("status", status),
        ])
    }
}

/// The same walk as all hits, counted.
impl RayJob for Count {
    const NAME: &'static str = "count";
    type Out<R: Real> = Vec<Listed>;
    fn output<R: Real>(n: usize, ask: &Ask) -> Result<Vec<Listed>> {
        All::output::<R>(n, ask)
    }
    fn run<R: Real>(
        scene: &Scene,
        ask: &Ask,
        rays: &Rays<R>,
        out: &mut Vec<Listed>,
        opts: &CastOptions,
    ) -> Result<()> {
        All::run(scene, ask, rays, out, opts)
    }
    fn columns<R: Real>(listed: Vec<Listed>) -> Result<Vec<Column>> {
        let count: Vec<i32> = listed.iter().map(|l| l.meets.len() as i32).collect();
        let status: Vec<u8> = listed.iter().map(|l| l.status).collect();
        Ok(vec![
            Column::new("count", count),
            Column::new("status", status),
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every name in QUERIES parses to the query that names itself so, and nothing else
    /// parses.
    #[test]
    fn query_names_round_trip() {
        for name in QUERIES {
            assert_eq!(QueryName::from_name(name).unwrap().name(), *name);
        }
        assert_eq!(QUERIES.len(), QueryName::ALL.len());
        assert!(QueryName::from_name("nearest").is_err());
    }
}
