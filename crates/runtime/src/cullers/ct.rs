//! Coorg and Teller's object-space culling: a node is culled when one of
//! the frame's best large convex occluders (by the area-angle metric)
//! hides its box, by tangent planes; no rendering at all. The occluders
//! are stored in the scene file (OCCL, with view cells in OCVC).

use gigawalk_cull::{ConvexOccluder, CtCuller, CtStats, PlaneCache, TraversalStats};
use gigawalk_scene::occluder_cells::OccluderCells;

use super::{Host, Setup, Traversal, Unavailable};
use crate::{OptionsError, RuntimeError};

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
    pub fn validate(&self) -> Result<(), OptionsError> {
        if !(1..=gigawalk_cull::MAX_FRAME_OCCLUDERS).contains(&self.occluders) {
            return Err(OptionsError::CtOccluders(self.occluders));
        }
        Ok(())
    }
}

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
