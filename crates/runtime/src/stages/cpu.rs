//! The CPU's stand-in for a device (tests): LODs drawn into a
//! conservative software depth image, no colour, no streaming.

use gigawalk_cull::{CullView, SoftDepth, TriangleSource};
use gigawalk_gpu::DepthImage;

use crate::streaming::LodSource;
use crate::triangles::TriangleCache;

/// The CPU's stand-in for a device: LODs drawn into a software depth
/// image (gigawalk-cull's conservative rasterizer) from triangles read
/// on first use. Depth only; colour reads back as zeros.
pub(crate) struct CpuRaster<'a> {
    pub(super) triangles: TriangleCache<'a>,
    pub(super) soft: SoftDepth,
    pub(super) view_proj: glam::DMat4,
    pub(super) eye: glam::DVec3,
    pub(super) width: u32,
    pub(super) height: u32,
}

impl<'a> CpuRaster<'a> {
    pub(super) fn new(source: &'a dyn LodSource, width: u32, height: u32) -> Self {
        CpuRaster {
            triangles: TriangleCache::new(source, u64::MAX),
            soft: SoftDepth::new(),
            view_proj: glam::DMat4::IDENTITY,
            eye: glam::DVec3::ZERO,
            width,
            height,
        }
    }

    pub(super) fn begin(&mut self, view: &CullView) {
        self.soft.reset(self.width, self.height);
        self.view_proj = view.camera.view_projection_rel_f64();
        self.eye = view.camera.position;
    }

    pub(super) fn draw(&mut self, lods: &[u32]) {
        for &l in lods {
            if let Some(t) = self.triangles.lod_triangles(l) {
                self.soft
                    .draw_mesh(&self.view_proj, t.origin - self.eye, t.positions, t.indices);
            }
        }
    }

    pub(super) fn depth(&self) -> DepthImage {
        DepthImage {
            width: self.width,
            height: self.height,
            depth: self.soft.depth().to_vec(),
        }
    }
}
