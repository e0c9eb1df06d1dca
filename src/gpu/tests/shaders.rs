//! The WGSL side, no GPU needed: every kernel assembles, parses and validates; the Rust
//! mirrors of its structs have naga's sizes and offsets.

use crate::gpu::kernels::{all_kernels, KERNELS};
use crate::gpu::structs::*;
use std::mem::{offset_of, size_of};
use std::path::PathBuf;

fn shaders_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("shaders")
}

fn parse_and_validate(name: &str, source: &str) -> (naga::Module, naga::valid::ModuleInfo) {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{name}: WGSL parse error:\n{}", e.emit_to_string(source)));
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{name}: invalid WGSL:\n{}", e.emit_to_string(source)));
    (module, info)
}

/// Every .wgsl file under `dir`, as paths relative to shaders/.
fn wgsl_files(dir: &std::path::Path, out: &mut Vec<String>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let path = e.unwrap().path();
        if path.is_dir() {
            wgsl_files(&path, out);
        } else if path.extension().is_some_and(|x| x == "wgsl") {
            let rel = path.strip_prefix(shaders_dir()).unwrap();
            out.push(rel.to_string_lossy().replace('\\', "/"));
        }
    }
}

/// Every file under shaders/ is a part of some kernel (no stray copies), each part embedded is
/// the file on disk, and every kernel, assembled as the device gets it, parses and validates
/// with one compute entry point.
#[test]
fn every_shader_validates_with_naga() {
    let mut files = Vec::new();
    wgsl_files(&shaders_dir(), &mut files);
    files.sort();
    let mut used: Vec<String> = all_kernels()
        .flat_map(|k| k.parts().into_iter().map(|p| p.path.to_string()))
        .collect();
    // The octree kernel stands alone (tests/octree.rs validates it); its path is written here
    // too so that the check holds without the gpu-octree feature.
    const OCTREE: &str = "octree/portalez.wgsl";
    used.push(OCTREE.to_string());
    #[cfg(feature = "gpu-octree")]
    {
        assert_eq!(crate::gpu::octree::PATH, OCTREE);
        let disk = std::fs::read_to_string(shaders_dir().join(OCTREE)).unwrap();
        assert_eq!(disk, crate::gpu::octree::file(), "octree kernel: stale");
    }
    // The camera kernel stands alone too (one file, no parts).
    used.push(crate::gpu::camera::PATH.to_string());
    let disk = std::fs::read_to_string(shaders_dir().join(crate::gpu::camera::PATH)).unwrap();
    assert_eq!(disk, crate::gpu::camera::FILE, "camera kernel: stale");
    let (module, _) = parse_and_validate("camera", crate::gpu::camera::FILE);
    assert_eq!(module.entry_points.len(), 1, "camera: one entry point");
    assert_eq!(module.entry_points[0].workgroup_size, [WORKGROUP, 1, 1]);
    used.sort();
    used.dedup();
    assert_eq!(files, used, "shaders/ holds exactly the kernels' parts");
    for k in all_kernels() {
        for part in k.parts() {
            let disk = std::fs::read_to_string(shaders_dir().join(part.path)).unwrap();
            assert_eq!(disk, part.source, "{}: embedded source is stale", part.path);
        }
        let name = k.name();
        let (module, _) = parse_and_validate(&name, &k.source());
        let entries: Vec<_> = module
            .entry_points
            .iter()
            .map(|e| (e.name.as_str(), e.stage))
            .collect();
        assert_eq!(entries, [("main", naga::ShaderStage::Compute)], "{name}");
        assert_eq!(module.entry_points[0].workgroup_size, [WORKGROUP, 1, 1]);
    }
}

/// A broken kernel is caught: the check above can fail.
#[test]
fn naga_rejects_a_broken_kernel() {
    let bad = format!("{}\nfn f() -> u32 {{ return 1.0; }}\n", KERNELS[0].source());
    let module = naga::front::wgsl::parse_str(&bad);
    let invalid = match module {
        Err(_) => true,
        Ok(m) => naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&m)
        .is_err(),
    };
    assert!(invalid);
}

/// The Rust mirrors have the WGSL structs' sizes and member offsets, as naga lays them out.
/// Structs of shaders/methods/exact_hit.wgsl that no buffer holds.
const FINISH_LOCALS: [&str; 8] = ["Ff", "V3", "Cross", "Det", "Quo", "Cert", "Finished", "Tri"];

#[test]
fn rust_mirrors_match_wgsl_layouts() {
    // (struct, size, [(member, offset)])
    type Layout<'a> = (&'a str, usize, Vec<(&'a str, usize)>);
    let expect: Vec<Layout> = vec![
        (
            "Params",
            size_of::<Params>(),
            vec![
                ("n_rays", offset_of!(Params, n_rays)),
                ("max_steps", offset_of!(Params, max_steps)),
            ],
        ),
        ("CamParams", size_of::<crate::gpu::camera::CamParams>(), {
            use crate::gpu::camera::CamParams as C;
            vec![
                ("forward", offset_of!(C, forward)),
                ("n_rays", offset_of!(C, n_rays)),
                ("right", offset_of!(C, right)),
                ("width", offset_of!(C, width)),
                ("up", offset_of!(C, up)),
                ("first", offset_of!(C, first)),
                ("normalize", offset_of!(C, normalize)),
                ("height", offset_of!(C, height)),
            ]
        }),
        (
            "RayIn",
            size_of::<RayIn>(),
            vec![
                ("origin", offset_of!(RayIn, origin)),
                ("tet", offset_of!(RayIn, tet)),
                ("e0", offset_of!(RayIn, e0)),
                ("entry", offset_of!(RayIn, entry)),
                ("e1", offset_of!(RayIn, e1)),
                ("slack", offset_of!(RayIn, slack)),
                ("verts", offset_of!(RayIn, verts)),
            ],
        ),
        (
            "RayOut",
            size_of::<RayOut>(),
            vec![
                ("end", offset_of!(RayOut, end)),
                ("constrained", offset_of!(RayOut, constrained)),
                ("tet", offset_of!(RayOut, tet)),
                ("steps", offset_of!(RayOut, steps)),
                ("face", offset_of!(RayOut, face)),
                ("hit", offset_of!(RayOut, hit)),
            ],
        ),
        (
            "GridSide",
            size_of::<GridSide>(),
            vec![
                ("lo", offset_of!(GridSide, lo)),
                ("inv_cell", offset_of!(GridSide, inv_cell)),
                ("dims", offset_of!(GridSide, dims)),
                ("cells", offset_of!(GridSide, cells)),
                ("faces", offset_of!(GridSide, faces)),
            ],
        ),
        (
            "Shared",
            size_of::<Shared>(),
            vec![
                ("origin", offset_of!(Shared, origin)),
                ("slack", offset_of!(Shared, slack)),
                ("verts", offset_of!(Shared, verts)),
                ("box_lo", offset_of!(Shared, box_lo)),
                ("start_tet", offset_of!(Shared, start_tet)),
                ("box_hi", offset_of!(Shared, box_hi)),
                ("inside", offset_of!(Shared, inside)),
                ("beyond", offset_of!(Shared, beyond)),
                ("finish", offset_of!(Shared, finish)),
                ("sides", offset_of!(Shared, sides)),
                ("in_lo", offset_of!(Shared, in_lo)),
                ("_pad3", offset_of!(Shared, _pad3)),
                ("in_hi", offset_of!(Shared, in_hi)),
                ("beyond_at", offset_of!(Shared, beyond_at)),
                ("grid_lo", offset_of!(Shared, grid_lo)),
                ("grid_inv", offset_of!(Shared, grid_inv)),
                ("grid_dims", offset_of!(Shared, grid_dims)),
            ],
        ),
        (
            "Tet20",
            size_of::<Tet20>(),
            vec![
                ("vertex_xor", offset_of!(Tet20, vertex_xor)),
                ("links", offset_of!(Tet20, links)),
            ],
        ),
        (
            "Face80",
            size_of::<Face80>(),
            vec![
                ("constrained", offset_of!(Face80, constrained)),
                ("neighbor", offset_of!(Face80, neighbor)),
            ],
        ),
        (
            "Tet80",
            size_of::<Tet80>(),
            vec![
                ("vertices", offset_of!(Tet80, vertices)),
                ("faces", offset_of!(Tet80, faces)),
            ],
        ),
    ];
    let mut seen = std::collections::HashSet::new();
    let modules = all_kernels()
        .map(|k| (k.name(), k.source()))
        .chain([("camera".to_string(), crate::gpu::camera::FILE.to_string())]);
    for (file, source) in modules {
        let (module, _) = parse_and_validate(&file, &source);
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        for (h, ty) in module.types.iter() {
            let Some(name) = ty.name.as_deref() else {
                continue;
            };
            // The hit finishing's values (exact_hit.wgsl) live in registers: never in a
            // buffer, so nothing on the host mirrors them.
            if FINISH_LOCALS.contains(&name) {
                continue;
            }
            let naga::TypeInner::Struct { members, span } = &ty.inner else {
                continue;
            };
            let (_, size, fields) = expect
                .iter()
                .find(|e| e.0 == name)
                .unwrap_or_else(|| panic!("{file}: struct {name} has no Rust mirror here"));
            assert_eq!(*span as usize, *size, "{}: size of {name}", file);
            assert_eq!(layouter[h].size as usize, *size, "{}: size of {name}", file);
            for (f, off) in fields {
                let m = members
                    .iter()
                    .find(|m| m.name.as_deref() == Some(f))
                    .unwrap_or_else(|| panic!("{name}.{f} missing in WGSL"));
                assert_eq!(m.offset as usize, *off, "{}: offset of {name}.{f}", file);
            }
            // Storage arrays of it have the Rust stride.
            seen.insert(name.to_string());
        }
    }
    for (name, _, _) in &expect {
        assert!(
            seen.contains(*name),
            "struct {name} not found in any kernel"
        );
    }
}
