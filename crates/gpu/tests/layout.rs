//! The structs the GPU sees agree between Rust and WGSL (checked with naga,
//! no GPU needed), and every shader in shaders/ parses and validates as its
//! pass compiles it.

use gigawalk_gpu::shader_types::{
    self, CompactVertex, DrawInstance, FrameUniforms, GpuVertex, HzbLevelUniforms, VertexLayout,
};

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
            ("clip", std::mem::offset_of!(FrameUniforms, clip)),
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
    let compact = shader_types::COMPACT_ATTRIBUTES;
    assert_eq!(
        compact[0].offset as usize,
        std::mem::offset_of!(CompactVertex, position)
    );
    assert_eq!(
        compact[1].offset as usize,
        std::mem::offset_of!(CompactVertex, colour)
    );
    assert_eq!(std::mem::size_of::<CompactVertex>(), 12);
    let instance = shader_types::INSTANCE_ATTRIBUTES;
    assert_eq!(
        instance[1].offset as usize,
        std::mem::offset_of!(DrawInstance, scale)
    );
    // Each pass's entry point for a layout takes exactly that layout's
    // locations and the instance's it reads, and the layout's stride is
    // its struct's size.
    let locations = |m: &naga::Module, name: &str| -> Vec<u32> {
        let ep = m.entry_points.iter().find(|e| e.name == name).unwrap();
        ep.function
            .arguments
            .iter()
            .filter_map(|a| match a.binding {
                Some(naga::Binding::Location { location, .. }) => Some(location),
                _ => None,
            })
            .collect()
    };
    let visible = module(shader_types::VISIBLE_WGSL);
    let depth = module(shader_types::OCCLUDER_DEPTH_WGSL);
    for layout in VertexLayout::ALL {
        let (ep, rvg, or, size) = match layout {
            VertexLayout::Wide => (
                "vs_main",
                vec![0, 1, 2, 3],
                vec![0, 3],
                std::mem::size_of::<GpuVertex>(),
            ),
            VertexLayout::Compact => (
                "vs_compact",
                vec![0, 2, 3, 4],
                vec![0, 3, 4],
                std::mem::size_of::<CompactVertex>(),
            ),
        };
        assert_eq!(layout.entry_point(), ep);
        assert_eq!(locations(&visible, ep), rvg, "{layout:?}");
        assert_eq!(locations(&depth, ep), or, "{layout:?}");
        assert_eq!(layout.stride() as usize, size);
    }
}

/// The compact layout's normal packing as the shader unpacks it: two
/// snorm8, sign-extended, u in the low byte.
#[test]
fn compact_normals_pack_as_the_shader_unpacks_them() {
    for (u, v) in [(0i8, 0i8), (127, -127), (-1, 1), (-128, 127), (5, -90)] {
        let w = CompactVertex::pack_normal(u, v) as u32;
        // compact_normal in common.wgsl, in Rust.
        let su = ((w << 24) as i32) >> 24;
        let sv = ((w << 16) as i32) >> 24;
        assert_eq!((su, sv), (u as i32, v as i32));
    }
}

#[test]
fn hzb_level_uniforms_match_wgsl() {
    let src = gigawalk_gpu::HZB_DOWNSAMPLE_WGSL;
    let m =
        naga::front::wgsl::parse_str(src).unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
    let (size, members) = wgsl_struct(&m, "Level");
    assert_eq!(size as usize, std::mem::size_of::<HzbLevelUniforms>());
    let rust = [
        ("src_size", std::mem::offset_of!(HzbLevelUniforms, src_size)),
        ("dst_size", std::mem::offset_of!(HzbLevelUniforms, dst_size)),
        (
            "src_offset",
            std::mem::offset_of!(HzbLevelUniforms, src_offset),
        ),
        (
            "dst_offset",
            std::mem::offset_of!(HzbLevelUniforms, dst_offset),
        ),
        ("_pad", std::mem::offset_of!(HzbLevelUniforms, _pad)),
    ];
    assert_eq!(members.len(), rust.len());
    for ((wname, woff), (rname, roff)) in members.iter().zip(rust) {
        assert_eq!((wname.as_str(), *woff as usize), (rname, roff));
    }
}

#[test]
fn every_shader_in_the_tree_parses_and_validates() {
    // As each pass compiles it: the scene passes and the query boxes after
    // the shared common.wgsl, the full-screen and overlay passes alone.
    let passes = [
        (
            "occluder_depth.wgsl",
            shader_types::OCCLUDER_DEPTH_WGSL,
            true,
        ),
        ("visible.wgsl", shader_types::VISIBLE_WGSL, true),
        ("query_box.wgsl", gigawalk_gpu::QUERY_BOX_WGSL, true),
        ("depth_copy.wgsl", gigawalk_gpu::DEPTH_COPY_WGSL, false),
        ("blit.wgsl", gigawalk_gpu::BLIT_WGSL, false),
        ("look.wgsl", gigawalk_gpu::LOOK_WGSL, false),
        ("overlay.wgsl", gigawalk_gpu::OVERLAY_WGSL, false),
        (
            "hzb_downsample.wgsl",
            gigawalk_gpu::HZB_DOWNSAMPLE_WGSL,
            false,
        ),
    ];
    for (_, src, with_common) in passes {
        if with_common {
            module(src);
        } else {
            validate_alone(src);
        }
    }
    // The clip-distance variants, appended to their pass.
    let clip_passes = [
        (
            "occluder_depth_clip.wgsl",
            shader_types::OCCLUDER_DEPTH_WGSL,
            shader_types::OCCLUDER_DEPTH_CLIP_WGSL,
        ),
        (
            "visible_clip.wgsl",
            shader_types::VISIBLE_WGSL,
            shader_types::VISIBLE_CLIP_WGSL,
        ),
    ];
    for (_, pass, clip) in clip_passes {
        let src = shader_types::clip_shader_source(pass, clip);
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::CLIP_DISTANCES,
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{e:?}"));
    }
    // Every file in shaders/ is one of them (common.wgsl is the prefix).
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shaders");
    let mut files: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl") && n != "common.wgsl")
        .collect();
    files.sort();
    let mut named: Vec<String> = passes
        .iter()
        .map(|p| p.0.to_string())
        .chain(clip_passes.iter().map(|p| p.0.to_string()))
        .collect();
    named.sort();
    assert_eq!(files, named, "a shader no test validates");
}

fn validate_alone(src: &str) {
    let module =
        naga::front::wgsl::parse_str(src).unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{e:?}"));
}
