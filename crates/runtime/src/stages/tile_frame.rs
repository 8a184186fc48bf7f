//! A tiled display's frame (Nirnimesh, Harish and Narayanan): which
//! tile draws which of the frame's visible items.

use web_time::Instant;

use gigawalk_cull::tiles::{self, TileFrustums, TileGrid, TileMethod};
use gigawalk_cull::{CullView, DrawItem};
use gigawalk_scene::Skeleton;

use crate::ms_since;

/// One frame's tiles: what each draws, and what sending items to them
/// cost.
#[derive(Clone, Debug)]
pub struct TileFrame {
    pub grid: TileGrid,
    /// Per tile, its pixel rectangle `[x, y, w, h]` and the indices of the
    /// frame's visible items it draws.
    pub rects: Vec<[u32; 4]>,
    pub lists: Vec<Vec<u32>>,
    /// Milliseconds sending the items to the tiles by the adaptive and the
    /// naive method (both run every frame), and box tests of the one used.
    pub ms_adaptive: f64,
    pub ms_naive: f64,
    pub tests: u64,
    /// Triangles of the busiest tile, and the mean over tiles.
    pub max_triangles: u64,
    pub mean_triangles: f64,
}

impl TileFrame {
    /// Sends `visible` to the tiles of `grid` by `method`, timing the
    /// adaptive and naive methods on the same items.
    pub fn new(
        skeleton: &Skeleton,
        view: &CullView,
        grid: TileGrid,
        method: TileMethod,
        visible: &[DrawItem],
    ) -> TileFrame {
        let timed = |m: TileMethod| {
            let t = Instant::now();
            let tiles = TileFrustums::new(view, grid);
            let lists = tiles::assign(skeleton, view, &tiles, visible, m);
            (lists, ms_since(t))
        };
        let (adaptive, ms_adaptive) = timed(TileMethod::Adaptive);
        let (naive, ms_naive) = timed(TileMethod::Naive);
        let used = match method {
            TileMethod::Adaptive => adaptive,
            TileMethod::Naive => naive,
            m => timed(m).0,
        };
        let triangles: Vec<u64> = used
            .lists
            .iter()
            .map(|l| {
                l.iter()
                    .map(|&i| {
                        let it = visible[i as usize];
                        let lod = skeleton.nodes()[it.node as usize].first_lod + it.lod;
                        skeleton
                            .lods()
                            .get(lod as usize)
                            .map_or(0, |l| l.triangles as u64)
                    })
                    .sum()
            })
            .collect();
        let (w, h) = (view.viewport.width, view.viewport.height);
        TileFrame {
            grid,
            rects: (0..grid.count()).map(|t| grid.rect(t, w, h)).collect(),
            lists: used.lists,
            ms_adaptive,
            ms_naive,
            tests: used.tests,
            max_triangles: triangles.iter().copied().max().unwrap_or(0),
            mean_triangles: triangles.iter().sum::<u64>() as f64 / triangles.len().max(1) as f64,
        }
    }
}
