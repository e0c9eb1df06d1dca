//! The traversal kernels, one table row each. A kernel is one exit method on one layout,
//! walking in float32; its WGSL module is joined at compile time from four files:
//! `shaders/common.wgsl`, the layout's records (`shaders/layouts/`), the method's exit test
//! (`shaders/methods/`) and the layout's walk (`shaders/walks/`, one `main` per kind of
//! layout). Each kernel has a CPU twin, `walk::<f32, L, M>` on the same layout and method.
//!
//! Adding a kernel: a method file in `shaders/methods/` declaring what
//! `shaders/common.wgsl` lists, a [`GpuRay`] impl for the CPU twin's prepared ray (if it is
//! a new kind of ray), and one row in [`KERNELS`]. Adding a layout: its records file, a walk
//! (or an existing one, if the layout provides the same accessors), an upload function in
//! `upload.rs`, and one row in [`GPU_LAYOUTS`].

use super::context::KernelKey;
use super::structs::{RayIn, NO_ENTRY};
use super::upload::{slack, upload_tet20, upload_tet80, LayoutBuffers};
use super::Gpu;
use crate::error::{Error, Result};
use crate::locate::WalkStart;
use crate::mesh::TetMesh;
use crate::scene::Scene;
use crate::traverse::aman2022::BasisRay;
use crate::traverse::exact::ExactRay;
use crate::traverse::lagae2008_plucker::PluckerRay;
use crate::traverse::robust::LineRay;
use crate::traverse::{walk, Aman2022, Exact, ExitMethod, Maria2017, Robust, Walk};
use std::sync::Arc;

/// One WGSL file: its path under `shaders/` and its text, embedded at compile time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wgsl {
    pub path: &'static str,
    pub source: &'static str,
}

macro_rules! wgsl {
    ($path:literal) => {
        Wgsl {
            path: $path,
            source: include_str!(concat!("../../shaders/", $path)),
        }
    };
}

/// Shared structs, bindings and helpers of every kernel.
pub const COMMON: Wgsl = wgsl!("common.wgsl");

/// A layout the GPU walks.
pub struct GpuLayout {
    /// The layout's name (`tetrace.layouts()`).
    pub name: &'static str,
    /// Its records and their accessors (`shaders/layouts/`).
    pub wgsl: Wgsl,
    /// The walk for its kind of layout (`shaders/walks/`).
    pub walk: Wgsl,
    /// Whether the walk names a face's vertices by their slot 0..3 in the tet (inline
    /// layouts) rather than by id (`Walk::slots`).
    pub slots: bool,
    /// Fills the scene's device buffers for it (records, and points for id layouts).
    pub(crate) upload: fn(&Gpu, &Scene) -> Result<LayoutBuffers>,
}

/// Every layout a kernel walks.
pub static GPU_LAYOUTS: [GpuLayout; 2] = [
    GpuLayout {
        name: "tet20",
        wgsl: wgsl!("layouts/tet20.wgsl"),
        walk: wgsl!("walks/by_id.wgsl"),
        slots: false,
        upload: upload_tet20,
    },
    GpuLayout {
        name: "tet80",
        wgsl: wgsl!("layouts/tet80.wgsl"),
        walk: wgsl!("walks/inline.wgsl"),
        slots: true,
        upload: upload_tet80,
    },
];

/// The CPU walk of a ray its kernel deferred, from the same start, up to a step guard.
pub(crate) type CpuWalk<'a> = Box<dyn Fn(&WalkStart, u32) -> Walk + Sync + 'a>;

/// A GPU kernel: one exit method on one layout, walking in float32.
pub struct KernelSpec {
    /// The exit method's name (`tetrace.methods()`; the CPU twin's `ExitMethod::NAME`).
    pub method: &'static str,
    pub layout: &'static GpuLayout,
    /// The method's exit test (`shaders/methods/`): one file, or files joined in order (the
    /// exact kernel's plain step builds on the robust kernel's certified signs).
    pub wgsl: &'static [Wgsl],
    /// The walk, when not the layout's (`shaders/walks/`): the exact kernel resumes walks.
    pub walk: Option<Wgsl>,
    /// Whether the kernel resumes walks the host began (`TetWalk::begin_elsewhere`) and hands
    /// them back as they stand, for the host's exact walk to finish: RayIn carries the walk's
    /// state (shaders/walks/resume.wgsl), not a start.
    pub resumes: bool,
    /// Whether the CPU twin's walk starts in the tet holding the perturbed start point
    /// (`ExitMethod::PERTURBED_START`): the host then locates as the twin's cast does.
    pub perturbed_start: bool,
    /// The ray as the CPU twin prepares it (`WalkStart::prepare`), as the kernel reads it.
    pub(crate) prepare: fn(&WalkStart, &TetMesh) -> RayIn,
    /// For kernels that may end a ray with `END_DEFERRED`: the CPU walk that decides it.
    pub(crate) deferred_to: Option<fn(&Scene) -> Result<CpuWalk<'_>>>,
}

/// The robust kernel's certified signs, on which the exact kernel's plain step builds.
const ROBUST: Wgsl = wgsl!("methods/robust.wgsl");

/// Every kernel, the default first: the exact walk's plain steps on Tet20, the rest of each
/// walk on the CPU exact walk (the contract, as on the CPU). Then the papers' float32 kernels.
pub static KERNELS: [KernelSpec; 4] = [
    KernelSpec {
        resumes: true,
        walk: Some(wgsl!("walks/resume.wgsl")),
        ..KernelSpec::of::<Exact>(
            &GPU_LAYOUTS[0],
            &[ROBUST, wgsl!("methods/exact.wgsl")],
            None,
        )
    },
    KernelSpec::of::<Aman2022>(&GPU_LAYOUTS[0], &[wgsl!("methods/aman2022.wgsl")], None),
    KernelSpec::of::<Maria2017>(&GPU_LAYOUTS[1], &[wgsl!("methods/maria2017.wgsl")], None),
    // The robust walk's float32 filter; rays it cannot certify go back to
    // `walk::<f32, Tet20, Robust>`.
    KernelSpec::of::<Robust>(&GPU_LAYOUTS[0], &[ROBUST], Some(robust_tet20_on_cpu)),
];

/// What the exact kernels that begin their walks on the device share (`shaders/walks/begin.wgsl`),
/// after the exact kernel's plain step and the hit finishing.
const BEGIN: [Wgsl; 4] = [
    ROBUST,
    wgsl!("methods/exact.wgsl"),
    wgsl!("methods/exact_hit.wgsl"),
    wgsl!("walks/begin.wgsl"),
];

/// The exact kernel for batches whose rays share one origin (`gpu::origin`): chosen by the
/// exact kernel's cast, never named by a caller. It begins each walk on the device from the
/// ray's direction, walks on as the exact kernel does, and finishes the hits it can certify
/// (`gpu::finish`).
pub static SHARED_ORIGIN: KernelSpec = KernelSpec {
    resumes: true,
    walk: Some(wgsl!("walks/shared_origin.wgsl")),
    ..KernelSpec::of::<Exact>(&GPU_LAYOUTS[0], &BEGIN, None)
};

/// [`BEGIN`] and the location of points on the device (`shaders/walks/locate.wgsl`).
const LOCATE: [Wgsl; 5] = [
    BEGIN[0],
    BEGIN[1],
    BEGIN[2],
    BEGIN[3],
    wgsl!("walks/locate.wgsl"),
];

/// The exact kernel for rays with their own origins (`gpu::origin::own_origins`): as
/// [`SHARED_ORIGIN`], with each ray's origin located on the device (the seed grid's walk on
/// certified orientations) or, outside the box, its entry found there.
pub static OWN_ORIGINS: KernelSpec = KernelSpec {
    resumes: true,
    walk: Some(wgsl!("walks/own_origin.wgsl")),
    ..KernelSpec::of::<Exact>(&GPU_LAYOUTS[0], &LOCATE, None)
};

/// Containment of points (`gpu::contains`): each point located on the device, its tet's
/// region parity answering (no walk along a ray; the exact walk names the kernel's kind).
pub static CONTAINS: KernelSpec = KernelSpec {
    walk: Some(wgsl!("walks/contains.wgsl")),
    ..KernelSpec::of::<Exact>(&GPU_LAYOUTS[0], &LOCATE, None)
};

/// Every kernel the device may compile: [`KERNELS`], the exact kernels that begin their
/// walks on the device, and containment.
pub fn all_kernels() -> impl Iterator<Item = &'static KernelSpec> {
    KERNELS
        .iter()
        .chain([&SHARED_ORIGIN, &OWN_ORIGINS, &CONTAINS])
}

impl KernelSpec {
    /// What names its pipeline and kept ray buffers: method, layout and walk.
    pub fn key(&self) -> KernelKey {
        (
            self.method,
            self.layout.name,
            self.walk.unwrap_or(self.layout.walk).path,
        )
    }

    /// The kernel of method M (its CPU twin's method) on `layout`.
    const fn of<M: ExitMethod<f32>>(
        layout: &'static GpuLayout,
        wgsl: &'static [Wgsl],
        deferred_to: Option<fn(&Scene) -> Result<CpuWalk<'_>>>,
    ) -> KernelSpec
    where
        M::Ray: GpuRay,
    {
        KernelSpec {
            method: M::NAME,
            layout,
            wgsl,
            walk: None,
            resumes: false,
            perturbed_start: M::PERTURBED_START,
            prepare: prepare_as::<M>,
            deferred_to,
        }
    }

    /// `method/layout`, as error messages and labels name a kernel.
    pub fn name(&self) -> String {
        format!("{}/{}", self.method, self.layout.name)
    }

    /// The parts of the WGSL module, in the order they are joined.
    pub fn parts(&self) -> Vec<Wgsl> {
        let mut parts = vec![COMMON, self.layout.wgsl];
        parts.extend_from_slice(self.wgsl);
        parts.push(self.walk.unwrap_or(self.layout.walk));
        parts
    }

    /// The full WGSL module the device compiles.
    pub fn source(&self) -> String {
        let mut s = String::new();
        for (k, p) in self.parts().iter().enumerate() {
            if k > 0 {
                s.push_str(&format!("\n// ---- {} ----\n", p.path));
            }
            s.push_str(p.source);
        }
        s
    }

    /// The kernel for a method and layout, or an error listing those that exist. A missing
    /// method means the default kernel's; a missing layout, the layout of the first kernel
    /// with that method (the default kernel's for a method with none).
    pub fn find(method: Option<&str>, layout: Option<&str>) -> Result<&'static KernelSpec> {
        let default = &KERNELS[0];
        let method = method.unwrap_or(default.method);
        let layout = layout.unwrap_or_else(|| {
            KERNELS
                .iter()
                .find(|k| k.method == method)
                .unwrap_or(default)
                .layout
                .name
        });
        KERNELS
            .iter()
            .find(|k| k.method == method && k.layout.name == layout)
            .ok_or_else(|| {
                let have: Vec<String> = KERNELS.iter().map(KernelSpec::name).collect();
                Error::InvalidOption(format!(
                    "no GPU kernel for method {method:?} on layout {layout:?}; GPU kernels \
                     (method/layout, float32): {}",
                    have.join(", ")
                ))
            })
    }
}

impl std::fmt::Debug for KernelSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "KernelSpec({})", self.name())
    }
}

impl Gpu {
    /// The kernel's compute pipeline, compiled on first use (the device keeps it).
    pub fn pipeline(&self, kernel: &KernelSpec) -> Result<Arc<wgpu::ComputePipeline>> {
        let key = kernel.key();
        let mut p = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(x) = p.get(&key) {
            return Ok(x.clone());
        }
        let source = kernel.source();
        let label = format!("kernel {}", kernel.name());
        let files: Vec<&str> = kernel.parts().iter().map(|w| w.path).collect();
        let what = format!("compiling {label} (shaders/{{{}}})", files.join(", "));
        let pipeline = self.scoped(&what, || self.compute_pipeline(&label, &source, "main"))?;
        let pipeline = Arc::new(pipeline);
        p.insert(key, pipeline.clone());
        Ok(pipeline)
    }
}

/// A CPU twin's prepared ray, as `RayIn` carries it to the kernel (`origin`, `e0`, `e1`,
/// `slack`; what each means is the method file's to say).
pub(crate) trait GpuRay {
    fn fill(&self, ray: RayIn) -> RayIn;
}

/// Aman et al.: the start point and the 2D basis (u, w).
impl GpuRay for BasisRay<f32> {
    fn fill(&self, ray: RayIn) -> RayIn {
        RayIn {
            origin: self.origin,
            e0: self.u,
            e1: self.w,
            ..ray
        }
    }
}

/// The exact walk: o in float32 and the basis perpendicular to its direction. `slack` is the
/// host's to set (the exact kernel adds the points' rounding, `DeviceScene`'s).
impl GpuRay for ExactRay<f32> {
    fn fill(&self, ray: RayIn) -> RayIn {
        RayIn {
            origin: self.or,
            e0: self.u,
            e1: self.w,
            slack: slack(self.o, self.or),
            ..ray
        }
    }
}

/// Maria et al.: the direction and the moment o × u.
impl GpuRay for PluckerRay<f32> {
    fn fill(&self, ray: RayIn) -> RayIn {
        RayIn {
            e0: self.u,
            e1: self.v,
            ..ray
        }
    }
}

/// The robust walk's exact line: s (already float32, so the slack is 0 unless that changes)
/// and b = s + k d; the kernel projects on the basis built from b − s.
impl GpuRay for LineRay<f32> {
    fn fill(&self, ray: RayIn) -> RayIn {
        RayIn {
            origin: self.sr,
            e0: self.u,
            e1: self.w,
            slack: slack(self.s, self.sr),
            ..ray
        }
    }
}

/// The ray as method M's CPU twin prepares it (`WalkStart::prepare`, as the CPU cast does).
fn prepare_as<M: ExitMethod<f32>>(s: &WalkStart, mesh: &TetMesh) -> RayIn
where
    M::Ray: GpuRay,
{
    let base = RayIn {
        tet: s.tet,
        entry: s.entry.map_or(NO_ENTRY, |i| i as u32),
        verts: mesh.tets[s.tet as usize],
        ..Default::default()
    };
    s.prepare::<f32, M>(mesh).fill(base)
}

/// The CPU robust walk on Tet20, which decides the rays the robust kernel defers.
fn robust_tet20_on_cpu(scene: &Scene) -> Result<CpuWalk<'_>> {
    let tet20 = crate::layout::get(&scene.layouts.tet20, &scene.mesh)?;
    Ok(Box::new(move |s: &WalkStart, max_steps: u32| {
        let ray = s.prepare::<f32, Robust>(&scene.mesh);
        walk::<f32, _, Robust>(
            tet20,
            &scene.points_f32,
            &ray,
            (s.tet, scene.mesh.tets[s.tet as usize]),
            s.entry,
            max_steps,
        )
    }))
}
