//! Hey et al.'s lazy occlusion grid: STC draws what the frame emits into a
//! software depth image of its own and tests node boxes against a grid of
//! cells over it, refreshed only where a test needs them. No OR, no lag.

use gigawalk_cull::{GridCuller, GridStats, OcclusionGrid, TraversalStats};

use super::{Setup, Traversal};
use crate::triangles::TriangleCache;
use crate::OptionsError;

/// The lazy occlusion grid's knobs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridOptions {
    /// Cell size in pixels (the paper: 32).
    pub cell: u32,
    /// Refresh cells only when a test needs them (false: as they are
    /// drawn over, for comparison).
    pub lazy: bool,
    /// Triangles STC rasterizes a frame at most, nearest items first
    /// (u64::MAX: all). What is not rasterized occludes nothing.
    pub triangle_budget: u64,
    /// Bytes of triangles STC keeps on the host for rasterizing, least
    /// recently drawn evicted first.
    pub cache_bytes: u64,
}

impl Default for GridOptions {
    fn default() -> Self {
        GridOptions {
            cell: gigawalk_cull::DEFAULT_GRID_CELL,
            lazy: true,
            triangle_budget: u64::MAX,
            cache_bytes: 512 << 20,
        }
    }
}

impl GridOptions {
    pub fn validate(&self) -> Result<(), OptionsError> {
        if !(1..=1024).contains(&self.cell) {
            return Err(OptionsError::GridCell(self.cell));
        }
        Ok(())
    }
}

/// The grid and the host-side triangles it rasterizes.
pub(crate) struct State<'a> {
    grid: OcclusionGrid,
    triangles: TriangleCache<'a>,
}

impl<'a> State<'a> {
    pub fn new(setup: &Setup<'a>, opts: &GridOptions) -> Self {
        let mut grid = OcclusionGrid::new(opts.cell, opts.lazy);
        // The software depth stands in for RVG's: it leaves room for that
        // device's depth error (GL's).
        if let Some(rt) = setup.gpu {
            grid.set_absolute_slack(f64::from(rt.devices[setup.rvg_device].depth_error()));
        }
        State {
            grid,
            triangles: TriangleCache::new(setup.source, opts.cache_bytes),
        }
    }

    pub fn cull(
        &mut self,
        t: &mut Traversal<'_, 'a>,
        opts: &GridOptions,
    ) -> (TraversalStats, GridStats) {
        let mut c = GridCuller::new(
            &mut self.grid,
            t.skeleton,
            &mut self.triangles,
            opts.triangle_budget,
        );
        let stats = t.run(&mut c);
        (stats, c.grid.stats)
    }
}
