//! The CPU's stand-in for a device (tests, feature `testing`): LODs drawn
//! into a conservative software depth image, no colour, no streaming.

use gigawalk_cull::{CullView, Hzb, Reduction, SoftDepth, TriangleSource};
use gigawalk_gpu::{DepthImage, DepthLevel, FrameImage};

use super::or::OccluderTarget;
use super::rvg::VisibleTarget;
use crate::RuntimeError;

use crate::streaming::LodSource;
use crate::triangles::TriangleCache;

/// The CPU's stand-in for a device: LODs drawn into a software depth
/// image (gigawalk-cull's conservative rasterizer) from triangles read
/// on first use. Depth only; colour reads back as zeros.
pub(crate) struct CpuRaster<'a> {
    triangles: TriangleCache<'a>,
    soft: SoftDepth,
    view_proj: glam::DMat4,
    eye: glam::DVec3,
    width: u32,
    height: u32,
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

    fn start(&mut self, view: &CullView) {
        self.soft.reset(self.width, self.height);
        self.view_proj = view.camera.view_projection_rel_f64();
        self.eye = view.camera.position;
    }

    fn raster(&mut self, lods: &[u32]) {
        for &l in lods {
            if let Some(t) = self.triangles.lod_triangles(l) {
                self.soft
                    .draw_mesh(&self.view_proj, t.origin - self.eye, t.positions, t.indices);
            }
        }
    }

    fn depth_image(&self) -> DepthImage {
        DepthImage {
            width: self.width,
            height: self.height,
            depth: self.soft.depth().to_vec(),
        }
    }
}

impl OccluderTarget for CpuRaster<'_> {
    /// Level `level` reduced here as OR's device reduces it.
    fn depth(
        &mut self,
        _: u64,
        view: &CullView,
        lods: &[u32],
        level: u32,
    ) -> Result<DepthLevel, RuntimeError> {
        self.start(view);
        self.raster(lods);
        let whole = self.depth_image();
        let (width, height) = (whole.width, whole.height);
        let (level, image) = match level {
            0 => (0, whole),
            k => {
                let hzb = Hzb::build(width, height, &whole.depth, Reduction::Farthest)
                    .expect("a software depth image of the pass's size");
                // Past the top reads the top, as on a device.
                let k = (k as usize).min(hzb.levels().len() - 1);
                let l = &hzb.levels()[k];
                let image = DepthImage {
                    width: l.width,
                    height: l.height,
                    depth: l.data.clone(),
                };
                (k as u32, image)
            }
        };
        Ok(DepthLevel {
            level,
            width,
            height,
            image,
            figures: Default::default(),
        })
    }
}

impl VisibleTarget for CpuRaster<'_> {
    fn begin(&mut self, view: &CullView, _: super::FrameStyle) {
        self.start(view);
    }

    fn scissor(&mut self, rect: Option<[u32; 4]>) {
        self.soft.set_scissor(rect);
    }

    fn draw(&mut self, _: u64, lods: &[u32]) -> Result<(), RuntimeError> {
        self.raster(lods);
        Ok(())
    }

    /// Depth, and colour as zeros.
    fn read_back(&mut self) -> Result<FrameImage, RuntimeError> {
        Ok(FrameImage {
            colour: vec![0; self.width as usize * self.height as usize * 4],
            depth: self.depth_image(),
        })
    }
}
