//! The two render passes: OR (depth of the occluders, reduced to the HZB's
//! pyramid on the device and a level of it read back) and RVG (colour + depth of the visible set, to an offscreen target
//! or a window). Both draw a list of LODs camera-relatively.
//!
//! Here: what the passes and their callers share (the camera [`View`], the
//! read-back images, the target formats and conventions) and the render
//! target helpers. The passes themselves are in `depth` (OR) and `visible`
//! (RVG); `drawer` holds the draw loop both use, `pipelines` the pipeline
//! builders, and `readback` the copy of a texture back to the host.

mod depth;
mod drawer;
mod hzb;
mod look;
mod pipelines;
mod readback;
mod visible;

use glam::{DVec3, Mat4, Vec3};

use crate::shader_types::MAX_CLIP_PLANES;
use crate::GpuContext;

pub use depth::{DepthLevel, DepthPass, PendingLevel};
pub(crate) use drawer::Drawer;
pub use hzb::{PyramidPath, HZB_DOWNSAMPLE_WGSL};
pub use look::{Antialias, Look, LookChoice, LOOK_WGSL};
pub(crate) use pipelines::{
    draw_fullscreen, fullscreen_pipeline, fullscreen_pipeline_entry, fullscreen_pipeline_with,
    pipeline, sampled_texture_layout, scene_pipelines, ScenePipelines, Surface,
};
pub use readback::PassFigures;
pub(crate) use readback::{device_error, map_and_wait, ms_since, Pending, ReadBack, Rows};
pub use visible::{PendingFrame, VisiblePass};

/// What a pass needs to know about the camera. `view_proj` has no
/// translation: positions are made camera-relative per draw, in f64.
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub eye: DVec3,
    pub view_proj: Mat4,
    /// Direction the camera looks (the head light's direction).
    pub forward: Vec3,
    /// The section's half-spaces relative to the eye (none: nothing cut).
    pub clip: ClipPlanes,
}

/// Up to [`MAX_CLIP_PLANES`] half-spaces, camera-relative: a point `p`
/// relative to the eye is kept when `dot(xyz, p) + w >= 0` for each.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClipPlanes {
    planes: [[f32; 4]; MAX_CLIP_PLANES],
    count: u32,
}

impl ClipPlanes {
    /// Nothing cut.
    pub const NONE: ClipPlanes = ClipPlanes {
        planes: [[0.0; 4]; MAX_CLIP_PLANES],
        count: 0,
    };

    /// These half-spaces; `None` when there are more than
    /// [`MAX_CLIP_PLANES`].
    pub fn new(half_spaces: &[[f32; 4]]) -> Option<ClipPlanes> {
        if half_spaces.len() > MAX_CLIP_PLANES {
            return None;
        }
        let mut planes = [[0.0; 4]; MAX_CLIP_PLANES];
        planes[..half_spaces.len()].copy_from_slice(half_spaces);
        Some(ClipPlanes {
            planes,
            count: half_spaces.len() as u32,
        })
    }

    /// What `section` keeps, its half-spaces relative to `eye` (the
    /// passes draw camera-relative); nothing cut without one, or where it
    /// has more than [`MAX_CLIP_PLANES`].
    pub fn of_section(
        section: Option<&gigawalk_scene::section::Section>,
        eye: glam::DVec3,
    ) -> ClipPlanes {
        section
            .and_then(|s| ClipPlanes::new(&s.relative_to(eye)))
            .unwrap_or(ClipPlanes::NONE)
    }

    pub fn count(&self) -> usize {
        self.count as usize
    }

    /// Whether the eye lies on some half-space's removed side (only then
    /// can a cut be looked into and a cap show).
    pub fn eye_removed(&self) -> bool {
        self.planes[..self.count()].iter().any(|p| p[3] < 0.0)
    }

    /// All [`MAX_CLIP_PLANES`] slots, those past `count` zero.
    pub fn planes(&self) -> [[f32; 4]; MAX_CLIP_PLANES] {
        self.planes
    }
}

/// A depth image as read back: row-major, row 0 at the top, reversed-Z
/// (1 at the near plane, 0 = nothing drawn / infinitely far).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
}

impl DepthImage {
    /// An image of depths read back as their f32 bits.
    pub(crate) fn from_bits(width: u32, height: u32, bits: Vec<u32>) -> DepthImage {
        DepthImage {
            width,
            height,
            depth: bits.into_iter().map(f32::from_bits).collect(),
        }
    }
}

/// A colour image (sRGB RGBA8, row 0 at the top) with its depth.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameImage {
    pub colour: Vec<u8>,
    pub depth: DepthImage,
}

pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Where depth is copied, bit for bit, to be read back on adapters that
/// cannot copy a depth texture to a buffer (GL): integer formats are
/// renderable everywhere, 32-bit floats not on every GLES.
pub(crate) const DEPTH_COPY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
pub const DEPTH_COPY_WGSL: &str = include_str!("../../../../shaders/depth_copy.wgsl");
pub const COLOUR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// How RVG draws triangles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DrawStyle {
    /// Filled, lit by the head light.
    #[default]
    Shaded,
    /// Triangle edges only, in the object's unlit colour. Needs the
    /// adapter's `POLYGON_MODE_LINE` ([`GpuContext::supports_wireframe`]);
    /// without it RVG draws `Shaded` and logs a warning once.
    Wireframe,
}

/// Reversed-Z: clear to 0 (infinitely far), keep the greater depth.
pub(crate) const DEPTH_COMPARE: wgpu::CompareFunction = wgpu::CompareFunction::GreaterEqual;

pub(crate) fn target(
    ctx: &GpuContext,
    label: &str,
    w: u32,
    h: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    })
}

pub(crate) fn depth_attachment(
    view: &wgpu::TextureView,
    clear: bool,
) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations {
            load: if clear {
                wgpu::LoadOp::Clear(0.0)
            } else {
                wgpu::LoadOp::Load
            },
            store: wgpu::StoreOp::Store,
        }),
        stencil_ops: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_are_needed_only_where_the_eye_is_on_a_removed_side() {
        assert!(!ClipPlanes::NONE.eye_removed());
        // Keeps x >= -2 relative to the eye: the eye is kept.
        let kept = ClipPlanes::new(&[[1.0, 0.0, 0.0, 2.0]]).unwrap();
        assert!(!kept.eye_removed());
        // A box around the eye, then one face moved past it.
        let mut faces = [[0.0f32; 4]; 6];
        for (i, face) in faces.iter_mut().enumerate() {
            face[i / 2] = if i % 2 == 0 { 1.0 } else { -1.0 };
            face[3] = 1.0;
        }
        assert!(!ClipPlanes::new(&faces).unwrap().eye_removed());
        faces[3][3] = -0.5;
        assert!(ClipPlanes::new(&faces).unwrap().eye_removed());
        // Slots past the count do not count.
        let mut one = ClipPlanes::new(&[[0.0, 1.0, 0.0, 3.0]]).unwrap();
        one.planes[5] = [0.0, 0.0, 1.0, -1.0];
        assert!(!one.eye_removed());
        assert!(ClipPlanes::new(&[[0.0; 4]; MAX_CLIP_PLANES + 1]).is_none());
    }
}
