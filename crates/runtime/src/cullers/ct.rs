//! Coorg and Teller's object-space culling: a node is culled when one of
//! the frame's best large convex occluders (by the area-angle metric)
//! hides its box, by tangent planes; no rendering at all. The occluders
//! are stored in the scene file (OCCL, with view cells in OCVC).

pub use gigawalk_cull::CtStats;
use gigawalk_cull::{ConvexOccluder, CtCuller, PlaneCache, TraversalStats};
use gigawalk_scene::occluder_cells::OccluderCells;

use super::figures::{Counter, Figure, Pool, Setting};
use super::{CullerOptionsError, Host, Setup, Traversal, Unavailable};
use crate::RuntimeError;

/// The object-space culler's knobs (Coorg and Teller; docs/culling.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CtOptions {
    /// Occluders a frame uses, the best by the area-angle metric (the
    /// paper's k; 1..=64).
    pub occluders: usize,
    /// (node, occluder) tangent-plane pairs cached across frames (0: no
    /// cache).
    pub cache_pairs: usize,
    /// Candidates from the scene's view cells when it has them (Section
    /// 3.1); `false`: every occluder is scored each frame.
    pub cells: bool,
    /// Occluders reaching nearer than the near plane are clipped to it
    /// (`false`: left out, which culls less and costs less).
    pub clip: bool,
}

impl Default for CtOptions {
    fn default() -> Self {
        CtOptions {
            occluders: 32,
            cache_pairs: 1 << 20,
            cells: true,
            clip: true,
        }
    }
}

impl CtOptions {
    pub fn validate(&self) -> Result<(), CullerOptionsError> {
        if !(1..=gigawalk_cull::MAX_FRAME_OCCLUDERS).contains(&self.occluders) {
            return Err(CullerOptionsError::CtOccluders(self.occluders));
        }
        Ok(())
    }

    /// The settings a replay's summary records (none yet).
    pub(super) fn settings(&self) -> Vec<(&'static str, Setting)> {
        Vec::new()
    }
}

/// The object-space culler's command-line flags (`gigawalk replay`,
/// `demo`).
#[derive(Clone, Debug, clap::Args)]
pub struct CtArgs {
    /// Large occluders (ct): occluders a frame, the best by the paper's area-angle metric (1-64; the paper's k)
    #[arg(long, default_value_t = CtOptions::default().occluders)]
    ct_occluders: usize,
    /// Large occluders (ct): (node, occluder) tangent-plane pairs cached across frames (0 = no cache)
    #[arg(long, default_value_t = CtOptions::default().cache_pairs)]
    ct_cache: usize,
    /// Large occluders (ct): score every stored occluder each frame instead of the eye's view cell's list (the scene's OCVC section)
    #[arg(long)]
    ct_all_occluders: bool,
    /// Large occluders (ct): leave out occluders that reach nearer than the near plane instead of clipping them to it (culls less; their planes are not cached)
    #[arg(long)]
    ct_no_clip: bool,
}

impl CtArgs {
    pub fn options(&self) -> CtOptions {
        CtOptions {
            occluders: self.ct_occluders,
            cache_pairs: self.ct_cache,
            cells: !self.ct_all_occluders,
            clip: !self.ct_no_clip,
        }
    }
}

/// The culler's counts a frame (none in frames.csv yet).
pub(super) const COUNTERS: &[Counter] = &[
    Counter {
        name: "ct_nodes_tested",
        decimals: 0,
        csv: false,
    },
    Counter {
        name: "ct_pair_tests",
        decimals: 0,
        csv: false,
    },
    Counter {
        name: "ct_cache_hits",
        decimals: 0,
        csv: false,
    },
    Counter {
        name: "ct_cache_lookups",
        decimals: 0,
        csv: false,
    },
    Counter {
        name: "ct_candidates",
        decimals: 0,
        csv: false,
    },
    Counter {
        name: "ct_clipped",
        decimals: 0,
        csv: false,
    },
];

/// `s` in the order of [`COUNTERS`].
pub(super) fn counts(s: &CtStats) -> Vec<f64> {
    vec![
        s.nodes_tested as f64,
        s.pair_tests as f64,
        s.cache_hits as f64,
        (s.cache_hits + s.cache_misses) as f64,
        s.candidates as f64,
        s.clipped as f64,
    ]
}

/// The culler's figures of a run: mean nodes tested and (node, occluder)
/// classifications a frame, the share of tangent planes found in the
/// cache, mean candidates scored a frame (the view cell's list, or every
/// occluder) and mean chosen occluders clipped to the near plane.
pub(super) const FIGURES: &[Figure] = &[
    Figure {
        key: "mean_ct_nodes_tested",
        pool: Pool::Mean("ct_nodes_tested"),
    },
    Figure {
        key: "mean_ct_pair_tests",
        pool: Pool::Mean("ct_pair_tests"),
    },
    Figure {
        key: "ct_cache_hit_fraction",
        pool: Pool::Share {
            part: "ct_cache_hits",
            whole: "ct_cache_lookups",
        },
    },
    Figure {
        key: "mean_ct_candidates",
        pool: Pool::Mean("ct_candidates"),
    },
    Figure {
        key: "mean_ct_clipped",
        pool: Pool::Mean("ct_clipped"),
    },
];

/// The culler needs the scene's occluders.
pub(super) fn check(host: &Host) -> Result<(), Unavailable> {
    if host.occluders {
        Ok(())
    } else {
        Err(Unavailable::NoOccluders)
    }
}

/// The object-space culler's occluders and cache, kept across frames.
pub(crate) struct State {
    occluders: Vec<ConvexOccluder>,
    areas: Vec<f64>,
    /// Lists indexing `occluders` (not the records).
    cells: Option<OccluderCells>,
    cache: PlaneCache,
}

impl State {
    /// Occluders that are not convex planar polygons are left out (and
    /// from the cells' lists).
    fn new(
        records: &[gigawalk_scene::occluders::OccluderRecord],
        cells: Option<OccluderCells>,
        cache_pairs: usize,
    ) -> Self {
        let mut index = vec![None; records.len()];
        let (mut occluders, mut areas) = (Vec::new(), Vec::new());
        for (i, r) in records.iter().enumerate() {
            if let Some(o) = ConvexOccluder::new(&r.vertices) {
                index[i] = Some(occluders.len() as u32);
                occluders.push(o);
                areas.push(r.area);
            }
        }
        let cells = cells.map(|mut c| {
            for l in &mut c.lists {
                *l = l.iter().filter_map(|&i| index[i as usize]).collect();
            }
            c
        });
        State {
            occluders,
            areas,
            cells,
            cache: PlaneCache::new(cache_pairs),
        }
    }

    /// The scene's occluders (and cells, when asked for).
    pub fn load(setup: &Setup<'_>, opts: &CtOptions) -> Result<Self, RuntimeError> {
        let load = |source| RuntimeError::Load {
            source: Box::new(source),
        };
        let records =
            setup
                .source
                .occluders()
                .map_err(load)?
                .ok_or(RuntimeError::CullerUnavailable {
                    culler: super::CullMethod::Ct,
                    why: Unavailable::NoOccluders,
                })?;
        let cells = if opts.cells {
            setup.source.occluder_cells(records.len()).map_err(load)?
        } else {
            None
        };
        Ok(State::new(&records, cells, opts.cache_pairs))
    }

    pub fn cull(
        &mut self,
        t: &mut Traversal<'_, '_>,
        opts: &CtOptions,
    ) -> (TraversalStats, CtStats) {
        let mut c = CtCuller::new(
            t.skeleton,
            &self.occluders,
            &self.areas,
            self.cells.as_ref(),
            opts.occluders,
            &mut self.cache,
        );
        if !opts.clip {
            c = c.without_clipping();
        }
        let stats = t.run(&mut c);
        (stats, c.stats)
    }
}
