//! Hey et al.'s lazy occlusion grid: STC draws what the frame emits into a
//! software depth image of its own and tests node boxes against a grid of
//! cells over it, refreshed only where a test needs them. No OR, no lag.

pub use gigawalk_cull::GridStats;
use gigawalk_cull::{GridCuller, OcclusionGrid, TraversalStats};

use super::figures::{Column, Counter, Figure, Pool, Setting, Table};
use super::{CullerOptionsError, Setup, Traversal};
use crate::triangles::TriangleCache;
use crate::OccluderBudget;

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
    pub fn validate(&self) -> Result<(), CullerOptionsError> {
        if !(1..=1024).contains(&self.cell) {
            return Err(CullerOptionsError::GridCell(self.cell));
        }
        Ok(())
    }

    /// The settings a replay's summary records.
    pub(super) fn settings(&self) -> Vec<(&'static str, Setting)> {
        vec![
            ("grid_cell", Setting::Whole(u64::from(self.cell))),
            ("grid_lazy", Setting::Flag(self.lazy)),
        ]
    }
}

/// The grid's command-line flags (`gigawalk replay`, `demo`).
#[derive(Clone, Debug, clap::Args)]
pub struct GridArgs {
    /// Lazy occlusion grid: cell size in pixels (1-1024; the paper's 32)
    #[arg(long, default_value_t = GridOptions::default().cell)]
    grid_cell: u32,
    /// Lazy occlusion grid: refresh cells as they are drawn over instead of when a test needs them (same culling, more depth reads; for comparison)
    #[arg(long)]
    grid_eager: bool,
    /// Lazy occlusion grid: triangles STC rasterizes a frame at most, nearest first (all, or a count such as 200k); what is not rasterized occludes nothing
    #[arg(long, value_name = "all|TRIANGLES", default_value = "all", value_parser = parse_budget)]
    grid_budget: OccluderBudget,
}

/// `all` or a triangle count (not `auto` or `adaptive`, which only OR's
/// occluder budget knows).
fn parse_budget(s: &str) -> Result<OccluderBudget, String> {
    match s.parse()? {
        b @ (OccluderBudget::All | OccluderBudget::Triangles(_)) => Ok(b),
        _ => Err(format!(
            "grid budget {s:?} is not all or a triangle count (e.g. 200000, 200k)"
        )),
    }
}

impl GridArgs {
    pub fn options(&self) -> GridOptions {
        GridOptions {
            cell: self.grid_cell,
            lazy: !self.grid_eager,
            triangle_budget: match self.grid_budget {
                OccluderBudget::Triangles(t) => t,
                _ => u64::MAX,
            },
            ..GridOptions::default()
        }
    }
}

/// The grid's counts a frame.
pub(super) const COUNTERS: &[Counter] = &[
    Counter {
        name: "grid_raster_ms",
        decimals: 3,
        csv: true,
    },
    Counter {
        name: "grid_test_ms",
        decimals: 3,
        csv: true,
    },
    Counter {
        name: "grid_pixel_reads",
        decimals: 0,
        csv: true,
    },
    Counter {
        name: "grid_triangles",
        decimals: 0,
        csv: true,
    },
];

/// `s` in the order of [`COUNTERS`].
pub(super) fn counts(s: &GridStats) -> Vec<f64> {
    vec![
        s.raster_ms,
        s.test_ms,
        s.pixel_reads as f64,
        s.triangles_drawn as f64,
    ]
}

/// The grid's figures of a run: median ms STC spent rasterizing and
/// answering box tests, mean depth pixels read a frame, mean triangles
/// rasterized a frame.
pub(super) const FIGURES: &[Figure] = &[
    Figure {
        key: "median_grid_raster_ms",
        pool: Pool::Median("grid_raster_ms"),
    },
    Figure {
        key: "median_grid_test_ms",
        pool: Pool::Median("grid_test_ms"),
    },
    Figure {
        key: "mean_grid_pixel_reads",
        pool: Pool::Mean("grid_pixel_reads"),
    },
    Figure {
        key: "mean_grid_triangles",
        pool: Pool::Mean("grid_triangles"),
    },
];

pub(super) const TABLE: Table = Table {
    title: "Lazy occlusion grid",
    preamble: |setting| {
        format!(
            "Cells of {} pixels, {} updates.",
            setting("grid_cell").whole().unwrap_or(0),
            if setting("grid_lazy").flag().unwrap_or(true) {
                "lazy"
            } else {
                "eager"
            },
        )
    },
    columns: &[
        Column::StcMs,
        Column::Figure {
            header: "rasterize ms",
            key: "median_grid_raster_ms",
            decimals: Some(2),
        },
        Column::Figure {
            header: "grid tests ms",
            key: "median_grid_test_ms",
            decimals: Some(2),
        },
        Column::Figure {
            header: "depth pixels read",
            key: "mean_grid_pixel_reads",
            decimals: None,
        },
        Column::Figure {
            header: "triangles rasterized",
            key: "mean_grid_triangles",
            decimals: None,
        },
        Column::OcclusionCulled,
    ],
};

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

#[cfg(test)]
mod tests {
    use clap::Parser as _;

    use super::*;

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        grid: GridArgs,
    }

    fn budget(arg: &str) -> Result<u64, String> {
        Cli::try_parse_from(["x", "--grid-budget", arg])
            .map(|c| c.grid.options().triangle_budget)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn the_grid_budget_is_all_or_a_triangle_count() {
        assert_eq!(budget("all"), Ok(u64::MAX));
        assert_eq!(budget("200000"), Ok(200_000));
        assert_eq!(budget("200k"), Ok(200_000));
        // OR's own budgets mean nothing to the grid: refused, not read as all.
        for arg in ["auto", "adaptive"] {
            let e = budget(arg).unwrap_err();
            assert!(e.contains("is not all or a triangle count"), "{arg}: {e}");
        }
        assert!(budget("lots").is_err());
        let o = Cli::try_parse_from(["x"]).unwrap().grid.options();
        assert_eq!(o, GridOptions::default());
    }
}
