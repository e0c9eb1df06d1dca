//! The traversal kernels: which method × layout each one is, and its WGSL source (the common
//! file in front of the kernel's own file, joined at compile time).

use crate::error::{Error, Result};

/// Shared structs, bindings and helpers of every kernel.
pub const COMMON_WGSL: &str = include_str!("../../shaders/common.wgsl");

/// A GPU kernel: one exit method on one layout, walking in float32.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Aman et al. 2022 on Tet20; CPU twin `walk::<f32, Tet20, Aman2022>`.
    Aman2022Tet20,
    /// Maria et al. 2017 on Tet80; CPU twin `walk::<f32, Tet80, Maria2017>`.
    Maria2017Tet80,
    /// The robust walk's filter on Tet20; uncertain rays go back to `walk::<f32, Tet20, Robust>`.
    RobustTet20,
}

/// Every kernel, the default (Aman et al. on Tet20, their GPU design) first.
pub const KERNELS: [Kernel; 3] = [
    Kernel::Aman2022Tet20,
    Kernel::Maria2017Tet80,
    Kernel::RobustTet20,
];

impl Kernel {
    /// The exit method's name (`tetrace.methods()`).
    pub fn method(self) -> &'static str {
        match self {
            Kernel::Aman2022Tet20 => "aman2022",
            Kernel::Maria2017Tet80 => "maria2017",
            Kernel::RobustTet20 => "robust",
        }
    }

    /// The layout's name (`tetrace.layouts()`).
    pub fn layout(self) -> &'static str {
        match self {
            Kernel::Aman2022Tet20 | Kernel::RobustTet20 => "tet20",
            Kernel::Maria2017Tet80 => "tet80",
        }
    }

    /// Whether the CPU twin's walk starts in the tet holding the perturbed start point
    /// (`ExitMethod::PERTURBED_START`): the host then locates as the twin's cast does.
    pub fn perturbed_start(self) -> bool {
        use crate::traverse::{Aman2022, ExitMethod, Maria2017, Robust};
        match self {
            Kernel::Aman2022Tet20 => <Aman2022 as ExitMethod<f32>>::PERTURBED_START,
            Kernel::Maria2017Tet80 => <Maria2017 as ExitMethod<f32>>::PERTURBED_START,
            Kernel::RobustTet20 => <Robust as ExitMethod<f32>>::PERTURBED_START,
        }
    }

    /// The kernel's own file under shaders/.
    pub fn file(self) -> &'static str {
        match self {
            Kernel::Aman2022Tet20 => "aman2022_tet20.wgsl",
            Kernel::Maria2017Tet80 => "maria2017_tet80.wgsl",
            Kernel::RobustTet20 => "robust_tet20.wgsl",
        }
    }

    fn own_source(self) -> &'static str {
        match self {
            Kernel::Aman2022Tet20 => include_str!("../../shaders/aman2022_tet20.wgsl"),
            Kernel::Maria2017Tet80 => include_str!("../../shaders/maria2017_tet80.wgsl"),
            Kernel::RobustTet20 => include_str!("../../shaders/robust_tet20.wgsl"),
        }
    }

    /// The full WGSL module: the common file, then the kernel's.
    pub fn source(self) -> String {
        format!(
            "{COMMON_WGSL}\n// ---- {} ----\n{}",
            self.file(),
            self.own_source()
        )
    }

    /// Whether the kernel reads the point array (id layouts) besides the tet records.
    pub fn uses_points(self) -> bool {
        !matches!(self, Kernel::Maria2017Tet80)
    }

    /// The kernel for a method and layout, or an error listing those that exist. `None`
    /// picks the default kernel's.
    pub fn find(method: Option<&str>, layout: Option<&str>) -> Result<Kernel> {
        let method = method.unwrap_or(KERNELS[0].method());
        let layout = layout.unwrap_or(match method {
            "maria2017" => "tet80",
            _ => "tet20",
        });
        KERNELS
            .into_iter()
            .find(|k| k.method() == method && k.layout() == layout)
            .ok_or_else(|| {
                let have: Vec<String> = KERNELS
                    .iter()
                    .map(|k| format!("{}/{}", k.method(), k.layout()))
                    .collect();
                Error::InvalidOption(format!(
                    "no GPU kernel for method {method:?} on layout {layout:?}; GPU kernels \
                     (method/layout, float32): {}",
                    have.join(", ")
                ))
            })
    }
}
