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
    /// error, 0 elsewhere); w: unused.
    pub params: [f32; 4],
}

/// One vertex as the GPU reads it: 20 bytes.
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

/// Per-draw instance data: the LOD origin minus the camera position,
/// computed in f64 and rounded once (location 3).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DrawInstance {
    pub offset: [f32; 4],
}

pub const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 3] = wgpu::vertex_attr_array![
    0 => Float32x3,
    1 => Snorm16x2,
    2 => Unorm8x4,
];
pub const INSTANCE_ATTRIBUTES: [wgpu::VertexAttribute; 1] =
    wgpu::vertex_attr_array![3 => Float32x4];

pub fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRIBUTES,
    }
}

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

/// A pass's full WGSL: the shared declarations, then the pass.
pub fn shader_source(pass: &str) -> String {
    format!("{COMMON_WGSL}\n{pass}")
}
