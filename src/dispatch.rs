//! From names (what Python passes) to the monomorphized walk: every method × layout ×
//! precision is one instance of `Scene::cast_generic`, chosen here once.

use crate::error::{Error, Result};
use crate::layout::{Layout, Plain, Tet16, Tet20, Tet32, Tet80, LAYOUTS};
use crate::mesh::TetMesh;
use crate::real::Real;
use crate::scene::{CastOptions, HitsOut, Rays, Scene};
use std::sync::OnceLock;

/// The exit methods `tetrace.methods()` lists (each is its type's `ExitMethod::NAME`).
pub const METHODS: [&str; 8] = [
    "lagae2008_plane",
    "lagae2008_halfspace",
    "lagae2008_plucker",
    "lagae2008_stp",
    "ms06",
    "maria2017",
    "aman2022",
    "robust",
];

/// Runs `$body` with the type alias `$m` bound to the method named `$name`, or evaluates to
/// an unknown-method error: the one place that maps method names to types.
macro_rules! with_method {
    ($name:expr, $m:ident => $body:expr) => {
        match $name {
            "lagae2008_plane" => {
                type $m = $crate::traverse::Lagae2008Plane;
                $body
            }
            "lagae2008_halfspace" => {
                type $m = $crate::traverse::Lagae2008Halfspace;
                $body
            }
            "lagae2008_plucker" => {
                type $m = $crate::traverse::Lagae2008Plucker;
                $body
            }
            "lagae2008_stp" => {
                type $m = $crate::traverse::Lagae2008Stp;
                $body
            }
            "ms06" => {
                type $m = $crate::traverse::Ms06;
                $body
            }
            "maria2017" => {
                type $m = $crate::traverse::Maria2017;
                $body
            }
            "aman2022" => {
                type $m = $crate::traverse::Aman2022;
                $body
            }
            "robust" => {
                type $m = $crate::traverse::Robust;
                $body
            }
            other => Err($crate::dispatch::unknown(
                "method",
                other,
                &$crate::dispatch::METHODS,
            )),
        }
    };
}
pub(crate) use with_method;

/// The default: the fastest robust combination measured. Bunny, 1024² camera, f32, one
/// thread (python -m tetrace.bench bunny.obj --method all --layout all): aman2022 and maria2017
/// on tet32 both ran at 0.62x embreex, ahead of tet20 (0.57-0.58x); aman2022 projects each
/// vertex once per ray, so neighbouring tets agree bit for bit on every edge, where
/// maria2017 recomputes side products in each tet's frame.
pub const DEFAULT_METHOD: &str = "aman2022";
pub const DEFAULT_LAYOUT: &str = "tet32";

/// Traversal layouts of a scene, each built the first time a cast asks for it.
#[derive(Default)]
pub struct Layouts {
    pub(crate) plain: OnceLock<Result<Plain>>,
    pub(crate) tet80: OnceLock<Result<Tet80>>,
    pub(crate) tet32: OnceLock<Result<Tet32>>,
    pub(crate) tet20: OnceLock<Result<Tet20>>,
    pub(crate) tet16: OnceLock<Result<Tet16>>,
}

pub(crate) fn get<'a, L: Layout>(cell: &'a OnceLock<Result<L>>, mesh: &TetMesh) -> Result<&'a L> {
    cell.get_or_init(|| L::build(mesh))
        .as_ref()
        .map_err(Clone::clone)
}

impl Layouts {
    /// Bytes of the records of each layout built so far.
    pub fn built(&self) -> Vec<(&'static str, usize)> {
        let mut out = Vec::new();
        macro_rules! add {
            ($f:ident, $t:ty) => {
                if let Some(Ok(l)) = self.$f.get() {
                    out.push((<$t>::NAME, l.bytes()));
                }
            };
        }
        add!(plain, Plain);
        add!(tet80, Tet80);
        add!(tet32, Tet32);
        add!(tet20, Tet20);
        add!(tet16, Tet16);
        out
    }

    /// Builds a layout now (so its cost is not paid by the first cast, and its errors show).
    pub fn prepare(&self, name: &str, mesh: &TetMesh) -> Result<usize> {
        Ok(match name {
            "plain" => get(&self.plain, mesh)?.bytes(),
            "tet80" => get(&self.tet80, mesh)?.bytes(),
            "tet32" => get(&self.tet32, mesh)?.bytes(),
            "tet20" => get(&self.tet20, mesh)?.bytes(),
            "tet16" => get(&self.tet16, mesh)?.bytes(),
            other => return Err(unknown("layout", other, &LAYOUTS)),
        })
    }
}

pub(crate) fn unknown(what: &str, name: &str, known: &[&str]) -> Error {
    Error::InvalidOption(format!(
        "unknown {what} {name:?}; known: {}",
        known.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traverse::ExitMethod;

    #[test]
    fn method_names_are_the_types_names() {
        for name in METHODS {
            let got: Result<&str> = with_method!(name, M => Ok(<M as ExitMethod<f32>>::NAME));
            assert_eq!(got.unwrap(), name);
        }
        let r: Result<&str> = with_method!("nope", M => Ok(<M as ExitMethod<f64>>::NAME));
        assert!(matches!(r, Err(Error::InvalidOption(m)) if m.contains("aman2022")));
    }
}

/// Scalars the scene keeps points for.
pub trait Precision: Real {
    fn points(scene: &Scene) -> &[[Self; 3]];
}

impl Precision for f32 {
    fn points(scene: &Scene) -> &[[f32; 3]] {
        &scene.points_f32
    }
}

impl Precision for f64 {
    fn points(scene: &Scene) -> &[[f64; 3]] {
        &scene.mesh.points
    }
}

impl Scene {
    /// Casts with the method and layout named, in precision R.
    pub fn cast_named<R: Precision>(
        &self,
        method: &str,
        layout: &str,
        rays: &Rays<R>,
        out: HitsOut<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        let points = R::points(self);
        let mesh = &self.mesh;
        macro_rules! with_layout {
            ($m:ty) => {
                match layout {
                    "plain" => self.cast_generic::<R, Plain, $m>(
                        points,
                        get(&self.layouts.plain, mesh)?,
                        rays,
                        out,
                        opts,
                    ),
                    "tet80" => {
                        if R::NAME != "f32" {
                            return Err(Error::InvalidOption(
                                "layout tet80 stores float32 vertices (Maria et al.'s design) and \
                                 serves precision f32 only"
                                    .into(),
                            ));
                        }
                        self.cast_generic::<R, Tet80, $m>(
                            points,
                            get(&self.layouts.tet80, mesh)?,
                            rays,
                            out,
                            opts,
                        )
                    }
                    "tet32" => self.cast_generic::<R, Tet32, $m>(
                        points,
                        get(&self.layouts.tet32, mesh)?,
                        rays,
                        out,
                        opts,
                    ),
                    "tet20" => self.cast_generic::<R, Tet20, $m>(
                        points,
                        get(&self.layouts.tet20, mesh)?,
                        rays,
                        out,
                        opts,
                    ),
                    "tet16" => self.cast_generic::<R, Tet16, $m>(
                        points,
                        get(&self.layouts.tet16, mesh)?,
                        rays,
                        out,
                        opts,
                    ),
                    other => Err(unknown("layout", other, &LAYOUTS)),
                }
            };
        }
        with_method!(method, M => with_layout!(M))
    }
}
