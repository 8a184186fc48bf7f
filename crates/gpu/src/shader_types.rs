//! Structs the GPU sees, defined once here (`#[repr(C)]`, bytemuck) and
//! mirrored once in shaders/common.wgsl; tests/layout.rs checks the two
//! agree with naga. Also the WGSL sources of each pass.

use bytemuck::{Pod, Zeroable};

/// Per-frame uniforms (WGSL `FrameUniforms`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    /// Projection x camera rotation (camera-relative: no translation).
    pub view_proj: [[f32; 4]; 4],
    /// The head light's direction (= view direction), w unused.
    pub light_dir: [f32; 4],
    /// x: ambient term; y: 1 for the unlit object colour (wireframe); z:
    /// depth bias toward the eye (query boxes: twice the device's depth
    /// error, 0 elsewhere); w: how many of `clip` the section uses.
    pub params: [f32; 4],
    /// The section's half-spaces, camera-relative: a fragment at `p`
    /// (relative to the eye) is kept when `dot(xyz, p) + w >= 0` for the
    /// first `params.w` of them.
    pub clip: [[f32; 4]; MAX_CLIP_PLANES],
}

/// The most half-spaces a section clips by: six planes and a box's six
/// faces (`gigawalk_scene::section::Section::MAX_HALF_SPACES`).
pub const MAX_CLIP_PLANES: usize = 12;

/// What one step of OR's HZB pyramid reads (WGSL `Level` in
/// shaders/hzb_downsample.wgsl): the source and destination level sizes
/// in texels, and where each starts in the pyramid's storage buffer (in
/// u32s; compute passes only).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct HzbLevelUniforms {
    pub src_size: [u32; 2],
    pub dst_size: [u32; 2],
    pub src_offset: u32,
    pub dst_offset: u32,
    pub _pad: [u32; 2],
}

/// One vertex in the wide layout ([`VertexLayout::Wide`]): 20 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    /// Offset from the LOD's origin (location 0).
    pub position: [f32; 3],
    /// Octahedral snorm16x2 normal (location 1).
    pub normal: [i16; 2],
    /// sRGB-encoded RGBA8 (location 2).
    pub colour: [u8; 4],
}

/// One vertex in the compact layout ([`VertexLayout::Compact`]): 12
/// bytes. A scene's encoded LODs keep their positions on a grid of at
/// most 16 bits over the LOD's box; the GPU reads those coordinates and
/// scales them per draw (`DrawInstance::scale`), as Nanite keeps cluster
/// positions quantized.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct CompactVertex {
    /// Grid coordinates x, y, z; w holds the octahedral normal as two
    /// snorm8, u in the low byte, v in the high (location 0).
    pub position: [u16; 4],
    /// sRGB-encoded RGBA8 (location 2).
    pub colour: [u8; 4],
}

impl CompactVertex {
    /// `w` for an octahedral snorm8 normal.
    pub fn pack_normal(u: i8, v: i8) -> u16 {
        u as u8 as u16 | (v as u8 as u16) << 8
    }
}

/// How a resident LOD's vertices are laid out on a device. A scene may
/// hold both: each LOD takes the compact layout when its blob allows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VertexLayout {
    /// [`GpuVertex`]: f32 positions relative to the LOD's origin,
    /// snorm16 octahedral normals. Raw LODs, grids over 16 bits, 16-bit
    /// normals.
    Wide,
    /// [`CompactVertex`]: grid coordinates of at most 16 bits and snorm8
    /// octahedral normals (`gigawalk preprocess`'s defaults).
    Compact,
}

impl VertexLayout {
    pub const ALL: [VertexLayout; 2] = [VertexLayout::Wide, VertexLayout::Compact];

    /// Bytes a vertex takes.
    pub const fn stride(self) -> u64 {
        match self {
            VertexLayout::Wide => std::mem::size_of::<GpuVertex>() as u64,
            VertexLayout::Compact => std::mem::size_of::<CompactVertex>() as u64,
        }
    }

    /// The layout for an encoded LOD of these bits.
    pub fn for_grid(position_bits: u8, normal_bits: u8) -> VertexLayout {
        if position_bits <= 16 && normal_bits == 8 {
            VertexLayout::Compact
        } else {
            VertexLayout::Wide
        }
    }

    /// The layout a LOD of this record takes (a 2.0 file's encoded LODs
    /// do not state their bits: counted wide, the larger).
    pub fn of(info: &gigawalk_scene::LodInfo) -> VertexLayout {
        match info.grid {
            Some(g) => VertexLayout::for_grid(g.position, g.normal),
            None => VertexLayout::Wide,
        }
    }

    /// The vertex shader entry point that reads this layout.
    pub fn entry_point(self) -> &'static str {
        match self {
            VertexLayout::Wide => "vs_main",
            VertexLayout::Compact => "vs_compact",
        }
    }

    pub fn buffer_layout(self) -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: self.stride(),
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: match self {
                VertexLayout::Wide => &VERTEX_ATTRIBUTES,
                VertexLayout::Compact => &COMPACT_ATTRIBUTES,
            },
        }
    }
}

/// Per-draw instance data (locations 3 and 4): where the LOD's position
/// 0 lies relative to the camera, computed in f64 and rounded once, and
/// model units per coordinate on each axis (the grid's step for the
/// compact layout; the wide layout's shader does not read it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DrawInstance {
    pub offset: [f32; 4],
    pub scale: [f32; 4],
}

pub const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 3] = wgpu::vertex_attr_array![
    0 => Float32x3,
    1 => Snorm16x2,
    2 => Unorm8x4,
];
pub const COMPACT_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![
    0 => Uint16x4,
    2 => Unorm8x4,
];
pub const INSTANCE_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![3 => Float32x4, 4 => Float32x4];

pub fn instance_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<DrawInstance>() as u64,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &INSTANCE_ATTRIBUTES,
    }
}

pub const COMMON_WGSL: &str = include_str!("../../../shaders/common.wgsl");
pub const OCCLUDER_DEPTH_WGSL: &str = include_str!("../../../shaders/occluder_depth.wgsl");
pub const VISIBLE_WGSL: &str = include_str!("../../../shaders/visible.wgsl");

pub const OCCLUDER_DEPTH_CLIP_WGSL: &str =
    include_str!("../../../shaders/occluder_depth_clip.wgsl");
pub const VISIBLE_CLIP_WGSL: &str = include_str!("../../../shaders/visible_clip.wgsl");

/// A pass's full WGSL: the shared declarations, then the pass.
pub fn shader_source(pass: &str) -> String {
    format!("{COMMON_WGSL}\n{pass}")
}

/// A pass's WGSL with its clip-distance entry points (`clip`), for
/// devices with `Features::CLIP_DISTANCES`.
pub fn clip_shader_source(pass: &str, clip: &str) -> String {
    format!("enable clip_distances;\n{COMMON_WGSL}\n{pass}\n{clip}")
}
