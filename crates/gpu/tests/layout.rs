//! The structs the GPU sees agree between Rust and WGSL (checked with naga,
//! no GPU needed), and every pass's WGSL parses and validates.

use gigawalk_gpu::shader_types::{self, FrameUniforms, GpuVertex};

fn module(pass: &str) -> naga::Module {
    let src = shader_types::shader_source(pass);
    let module =
        naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{e:?}"));
    module
}

/// (size, [(member name, offset)]) of a WGSL struct.
fn wgsl_struct(module: &naga::Module, name: &str) -> (u32, Vec<(String, u32)>) {
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name} in WGSL"));
    match &ty.inner {
        naga::TypeInner::Struct { members, span } => (
            *span,
            members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                .collect(),
        ),
        other => panic!("{name} is {other:?}"),
    }
}

#[test]
fn frame_uniforms_match_wgsl() {
    for pass in [
        shader_types::OCCLUDER_DEPTH_WGSL,
        shader_types::VISIBLE_WGSL,
    ] {
        let m = module(pass);
        let (size, members) = wgsl_struct(&m, "FrameUniforms");
        assert_eq!(size as usize, std::mem::size_of::<FrameUniforms>());
        let rust = [
            ("view_proj", std::mem::offset_of!(FrameUniforms, view_proj)),
            ("light_dir", std::mem::offset_of!(FrameUniforms, light_dir)),
            ("params", std::mem::offset_of!(FrameUniforms, params)),
        ];
        assert_eq!(members.len(), rust.len());
        for ((wname, woff), (rname, roff)) in members.iter().zip(rust) {
            assert_eq!((wname.as_str(), *woff as usize), (rname, roff));
        }
    }
}

#[test]
fn vertex_inputs_match_rust_layout() {
    // The vertex attributes' offsets are the Rust struct's field offsets.
    let attrs = shader_types::VERTEX_ATTRIBUTES;
    assert_eq!(
        attrs[0].offset as usize,
        std::mem::offset_of!(GpuVertex, position)
    );
    assert_eq!(
        attrs[1].offset as usize,
        std::mem::offset_of!(GpuVertex, normal)
    );
    assert_eq!(
        attrs[2].offset as usize,
        std::mem::offset_of!(GpuVertex, colour)
    );
    assert_eq!(std::mem::size_of::<GpuVertex>(), 20);
    // The visible pass's vertex entry point takes exactly locations 0..=3.
    let m = module(shader_types::VISIBLE_WGSL);
    let ep = m.entry_points.iter().find(|e| e.name == "vs_main").unwrap();
    let locations: Vec<u32> = ep
        .function
        .arguments
        .iter()
        .filter_map(|a| match a.binding {
            Some(naga::Binding::Location { location, .. }) => Some(location),
            _ => None,
        })
        .collect();
    assert_eq!(locations, vec![0, 1, 2, 3]);
}
