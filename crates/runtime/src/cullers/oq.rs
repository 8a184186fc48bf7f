//! The occlusion-query culler (Bartz, Meissner and Huettner): traversal
//! nearest first; every emitted item is drawn into a depth image on RVG's
//! device; a node is tested by drawing its box inside an occlusion query
//! against that depth and culled when no sample (or, adaptive, fewer than
//! N) passes. Queries go in batches: the popped node with the nearest
//! queued ones, one round trip per batch. Coherent: nodes visible last
//! frame are not waited for; their queries run with the next batch and
//! decide the next frame. A time budget (cost-adaptive) stops querying
//! for the rest of the frame.

use std::collections::HashSet;
use web_time::Instant;

use gigawalk_cull::{
    BoxProjection, Containment, CullView, Culler, DrawItem, RelBox, Verdict, ALL_PLANES,
};
use gigawalk_gpu::{GpuContext, QueryBox, QueryPass, Residency};
use gigawalk_scene::Skeleton;

use super::figures::{Column, Counter, Figure, Pool, Setting, Table};
use super::{CullerOptionsError, Host, Setup, Traversal, Unavailable};
use crate::gpu_view;
use crate::streaming::Geometry;
use crate::{RuntimeError, Stage};

/// The occlusion-query culler's knobs (Bartz et al.; docs/culling.md).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OqOptions {
    /// Boxes queried per round trip: the popped node and the nearest
    /// queued ones (1 = the paper: a round trip per test).
    pub batch: u32,
    /// Coherent (after CHC): nodes visible last frame are drawn without
    /// waiting and queried for the next frame.
    pub coherent: bool,
    /// Adaptive culling (the paper's Eq. 1): a box passing fewer samples
    /// than this is culled (approximate; 0 = off). Needs a device whose
    /// queries count samples.
    pub adaptive: u64,
    /// Cost-adaptive culling (Eq. 2): after this fraction of the previous
    /// frame's time (measured from one traversal's start to the next),
    /// nodes get frustum culling only. `None`: no budget; `Some(0)`:
    /// frustum culling only; the paper: 1/3.
    pub budget: Option<f64>,
    /// Test leaves too (the paper draws leaves without a query).
    pub test_leaves: bool,
}

impl Default for OqOptions {
    fn default() -> Self {
        OqOptions {
            batch: 32,
            coherent: false,
            adaptive: 0,
            budget: None,
            test_leaves: true,
        }
    }
}

impl OqOptions {
    pub fn validate(&self) -> Result<(), CullerOptionsError> {
        if !(1..=4096).contains(&self.batch) {
            return Err(CullerOptionsError::OqBatch(self.batch));
        }
        if let Some(b) = self
            .budget
            .filter(|b| !(b.is_finite() && (0.0..=10.0).contains(b)))
        {
            return Err(CullerOptionsError::OqBudget(b));
        }
        Ok(())
    }

    /// The settings a replay's summary records.
    pub(super) fn settings(&self) -> Vec<(&'static str, Setting)> {
        vec![
            ("oq_batch", Setting::Whole(u64::from(self.batch))),
            ("oq_coherent", Setting::Flag(self.coherent)),
            ("oq_adaptive", Setting::Whole(self.adaptive)),
            (
                "oq_budget",
                self.budget.map_or(Setting::Unset, Setting::Number),
            ),
            ("oq_test_leaves", Setting::Flag(self.test_leaves)),
        ]
    }
}

/// The occlusion queries' command-line flags (`gigawalk replay`, `demo`).
#[derive(Clone, Debug, clap::Args)]
pub struct OqArgs {
    /// Occlusion queries: boxes per round trip to the device, the node being tested and the nearest queued ones (1-4096; 1 = the paper: one round trip per test)
    #[arg(long, default_value_t = OqOptions::default().batch)]
    oq_batch: u32,
    /// Occlusion queries, coherent (after CHC): nodes visible last frame are drawn without waiting and queried for the next frame
    #[arg(long)]
    oq_coherent: bool,
    /// Occlusion queries, adaptive (the paper's Eq. 1; approximate): cull boxes passing fewer than N samples (0 = off; needs a device that counts samples)
    #[arg(long, default_value_t = 0)]
    oq_adaptive: u64,
    /// Occlusion queries, cost-adaptive (Eq. 2): stop querying after this fraction of the previous frame's time (the paper: 0.33; 0 = frustum culling only; absent = no budget)
    #[arg(long)]
    oq_budget: Option<f64>,
    /// Occlusion queries: draw leaves without testing them, as the paper does
    #[arg(long)]
    oq_untested_leaves: bool,
}

impl OqArgs {
    pub fn options(&self) -> OqOptions {
        OqOptions {
            batch: self.oq_batch,
            coherent: self.oq_coherent,
            adaptive: self.oq_adaptive,
            budget: self.oq_budget,
            test_leaves: !self.oq_untested_leaves,
        }
    }
}

/// The queries' counts a frame ("untested": passed as visible without a
/// test, over the time budget or coherent).
pub(super) const COUNTERS: &[Counter] = &[
    Counter {
        name: "oq_queries",
        decimals: 0,
        csv: true,
    },
    Counter {
        name: "oq_round_trips",
        decimals: 0,
        csv: true,
    },
    Counter {
        name: "oq_ms",
        decimals: 3,
        csv: true,
    },
    Counter {
        name: "oq_untested",
        decimals: 0,
        csv: true,
    },
];

/// `s` in the order of [`COUNTERS`].
pub(super) fn counts(s: &OqStats) -> Vec<f64> {
    vec![
        s.queries as f64,
        s.round_trips as f64,
        s.ms,
        (s.over_budget + s.coherent) as f64,
    ]
}

/// The queries' figures of a run: mean boxes queried and round trips a
/// frame, median ms in round trips, mean nodes passed untested.
pub(super) const FIGURES: &[Figure] = &[
    Figure {
        key: "mean_oq_queries",
        pool: Pool::Mean("oq_queries"),
    },
    Figure {
        key: "mean_oq_round_trips",
        pool: Pool::Mean("oq_round_trips"),
    },
    Figure {
        key: "median_oq_ms",
        pool: Pool::Median("oq_ms"),
    },
    Figure {
        key: "mean_oq_untested",
        pool: Pool::Mean("oq_untested"),
    },
];

pub(super) const TABLE: Table = Table {
    title: "Occlusion queries",
    preamble: |setting| {
        let budget = match setting("oq_budget").number() {
            Some(b) => format!("{b} of the last frame"),
            None => "none".into(),
        };
        format!(
            "Batches of {} boxes a round trip, coherent {}, adaptive threshold {} samples, time budget {budget}, leaves {}.",
            setting("oq_batch").whole().unwrap_or(0),
            if setting("oq_coherent").flag().unwrap_or(false) {
                "on"
            } else {
                "off"
            },
            setting("oq_adaptive").whole().unwrap_or(0),
            if setting("oq_test_leaves").flag().unwrap_or(true) {
                "tested"
            } else {
                "drawn untested (the paper)"
            },
        )
    },
    columns: &[
        Column::StcMs,
        Column::Figure {
            header: "queries",
            key: "mean_oq_queries",
            decimals: None,
        },
        Column::Figure {
            header: "round trips",
            key: "mean_oq_round_trips",
            decimals: Some(1),
        },
        Column::Figure {
            header: "ms in round trips",
            key: "median_oq_ms",
            decimals: Some(2),
        },
        Column::Figure {
            header: "passed untested",
            key: "mean_oq_untested",
            decimals: None,
        },
        Column::OcclusionCulled,
        Column::Triangles,
    ],
};

/// The culler draws on RVG's device, which must hold the whole scene.
pub(super) fn check(host: &Host) -> Result<(), Unavailable> {
    if !host.device {
        Err(Unavailable::NoDevice)
    } else if !host.resident {
        Err(Unavailable::NotResident)
    } else {
        Ok(())
    }
}

/// What the occlusion queries did in a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OqStats {
    /// Boxes queried, and round trips (waits for the device).
    pub queries: u64,
    pub round_trips: u64,
    /// Nodes passed as visible without a test: over the time budget, or
    /// (coherent) visible last frame.
    pub over_budget: u64,
    pub coherent: u64,
    /// Milliseconds in round trips (drawing, querying, waiting).
    pub ms: f64,
}

/// What lives from frame to frame: the device's pass, last frame's
/// visible nodes (coherent), the previous frame's time (budget).
pub(crate) struct State<'a> {
    pub ctx: &'a GpuContext,
    pub residency: &'a dyn Residency,
    pass: QueryPass,
    visible_last: HashSet<u32>,
    visible_now: HashSet<u32>,
    last_start: Option<Instant>,
    last_frame_ms: Option<f64>,
}

impl<'a> State<'a> {
    fn with_pass(ctx: &'a GpuContext, residency: &'a dyn Residency, w: u32, h: u32) -> Self {
        State {
            ctx,
            residency,
            pass: QueryPass::new(ctx, w, h),
            visible_last: HashSet::new(),
            visible_now: HashSet::new(),
            last_start: None,
            last_frame_ms: None,
        }
    }

    /// The query pass on RVG's device; adaptive culling needs a device
    /// whose queries count samples.
    pub fn new(setup: &Setup<'a>, opts: &crate::ResolvedOptions) -> Result<Self, RuntimeError> {
        let unavailable = |why| RuntimeError::CullerUnavailable {
            culler: super::CullMethod::Oq,
            why,
        };
        let rt = setup.gpu.ok_or(unavailable(Unavailable::NoDevice))?;
        let b = setup.rvg_device;
        let Geometry::Resident(geometry) = &rt.geometry[b] else {
            return Err(unavailable(Unavailable::NotResident));
        };
        let ctx = &rt.devices[b];
        if opts.cullers.oq.adaptive > 0
            && gigawalk_gpu::query_counts(ctx).map_err(|source| RuntimeError::Setup { source })?
                != gigawalk_gpu::QueryCounts::Exact
        {
            return Err(unavailable(Unavailable::NoSampleCounts));
        }
        Ok(Self::with_pass(ctx, geometry, opts.width, opts.height))
    }

    /// A frame's traversal with the queries; a device error ends it.
    pub fn cull(
        &mut self,
        t: &mut Traversal<'_, 'a>,
        opts: OqOptions,
    ) -> Result<(gigawalk_cull::TraversalStats, OqStats), RuntimeError> {
        let mut c = OqCuller::new(self, t.skeleton, opts);
        let stats = t.run(&mut c);
        let (s, error) = c.end();
        match error {
            Some(e) => Err(e),
            None => Ok((stats, s)),
        }
    }
}

/// The culler for one frame.
pub(crate) struct OqCuller<'s, 'a> {
    state: &'s mut State<'a>,
    skeleton: &'a Skeleton,
    opts: OqOptions,
    /// Queued nodes in the frustum not yet queried: (distance, node, box).
    queued: Vec<(f32, u32, QueryBox)>,
    /// Nodes already tested this frame (their queued entries are stale).
    tested: HashSet<u32>,
    /// Coherent: nodes passed without waiting, to query with the next batch.
    deferred: Vec<(u32, QueryBox)>,
    /// Samples per node queried this frame.
    results: std::collections::HashMap<u32, u64>,
    deadline: Option<Instant>,
    pub stats: OqStats,
    pub error: Option<RuntimeError>,
}

/// The box a node is queried with: its camera-relative box grown by a
/// hair so a face lying exactly on drawn geometry still passes the depth
/// test (GreaterEqual) whatever the rasterizer's rounding. The near-plane
/// check must use this box, not the node's: a grown box can reach the eye.
fn padded(b: &RelBox) -> RelBox {
    let pad =
        (b.max - b.min).max_element() * 1e-4 + b.min.abs().max(b.max.abs()).max_element() * 1e-6;
    RelBox {
        min: b.min - pad,
        max: b.max + pad,
    }
}

fn query_box(b: &RelBox) -> QueryBox {
    QueryBox::new(b.min, b.max)
}

impl<'s, 'a> OqCuller<'s, 'a> {
    pub fn new(state: &'s mut State<'a>, skeleton: &'a Skeleton, opts: OqOptions) -> Self {
        OqCuller {
            state,
            skeleton,
            opts,
            queued: Vec::new(),
            tested: HashSet::new(),
            deferred: Vec::new(),
            results: Default::default(),
            deadline: None,
            stats: OqStats::default(),
            error: None,
        }
    }

    /// One round trip for `batch`; results stored. On a device error the
    /// boxes count as visible and the error is kept for the frame.
    fn round_trip(&mut self, batch: Vec<(u32, QueryBox)>) {
        let t = Instant::now();
        let boxes: Vec<QueryBox> = batch.iter().map(|b| b.1).collect();
        let samples =
            match self
                .state
                .pass
                .query(self.state.ctx, Some(self.state.residency), &boxes)
            {
                Ok(s) => s,
                Err(source) => {
                    self.error.get_or_insert(RuntimeError::Gpu {
                        stage: Stage::Stc,
                        source,
                    });
                    vec![u64::MAX; boxes.len()]
                }
            };
        self.stats.queries += boxes.len() as u64;
        self.stats.round_trips += 1;
        for ((node, _), n) in batch.into_iter().zip(samples) {
            self.results.insert(node, n);
        }
        self.stats.ms += t.elapsed().as_secs_f64() * 1e3;
    }

    fn is_leaf(&self, node: u32) -> bool {
        self.skeleton
            .nodes()
            .get(node as usize)
            .is_none_or(|n| n.is_leaf())
    }

    fn passes(&self, samples: u64) -> bool {
        samples > 0 && samples >= self.opts.adaptive
    }

    /// After traversal: the coherent queries still waiting decide the next
    /// frame; the frame's time sets the next budget.
    pub fn end(mut self) -> (OqStats, Option<RuntimeError>) {
        if !self.deferred.is_empty() {
            let batch = std::mem::take(&mut self.deferred);
            self.round_trip(batch);
        }
        if self.opts.coherent {
            let results = &self.results;
            let adaptive = self.opts.adaptive;
            let now: HashSet<u32> = self
                .state
                .visible_now
                .iter()
                .copied()
                .filter(|n| results.get(n).is_none_or(|&s| s > 0 && s >= adaptive))
                .collect();
            self.state.visible_last = now;
        }
        (self.stats, self.error)
    }
}

impl Culler for OqCuller<'_, '_> {
    type Ctx = ();
    const HEARS_QUEUED: bool = true;

    fn begin(&mut self, view: &CullView) {
        let now = Instant::now();
        if let Some(s) = self.state.last_start.replace(now) {
            self.state.last_frame_ms = Some((now - s).as_secs_f64() * 1e3);
        }
        // No budget before a frame time is known, except a zero one.
        self.deadline = match (self.opts.budget, self.state.last_frame_ms) {
            (Some(0.0), _) => Some(now),
            (Some(b), Some(ms)) => Some(now + std::time::Duration::from_secs_f64(ms * b / 1e3)),
            _ => None,
        };
        self.state.visible_now.clear();
        self.state
            .pass
            .set_pieces(view.visibility().and_then(|v| v.lod_pieces()));
        self.state.pass.begin(self.state.ctx, &gpu_view(view));
    }

    fn queued(&mut self, view: &CullView, node: u32, b: &RelBox, _: &()) {
        if self.opts.batch <= 1 {
            return;
        }
        let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
        if view.frustum.test(min, max, ALL_PLANES).0 == Containment::Outside {
            return;
        }
        // What `test` passes without a query is not worth one.
        let p = padded(b);
        if !self.opts.test_leaves && self.is_leaf(node)
            || matches!(view.project_box(&p), BoxProjection::CrossesNear)
        {
            return;
        }
        let d = gigawalk_cull::lod::distance_to_rel_box(min, max) as f32;
        self.queued.push((d, node, query_box(&p)));
    }

    fn test(&mut self, view: &CullView, node: u32, b: &RelBox, _: &()) -> (Verdict, ()) {
        self.tested.insert(node);
        let p = padded(b);
        // Leaves untested (the paper), boxes at the near plane or around
        // the eye (as queried: grown), everything past the budget or after
        // a device error: visible.
        let untested = (!self.opts.test_leaves && self.is_leaf(node))
            || matches!(view.project_box(&p), BoxProjection::CrossesNear)
            || self.error.is_some();
        if untested {
            self.state.visible_now.insert(node);
            return (Verdict::Visible, ());
        }
        if self.deadline.is_some_and(|d| Instant::now() >= d) {
            self.stats.over_budget += 1;
            self.state.visible_now.insert(node);
            return (Verdict::Visible, ());
        }
        if self.opts.coherent && self.state.visible_last.contains(&node) {
            self.stats.coherent += 1;
            self.deferred.push((node, query_box(&p)));
            self.state.visible_now.insert(node);
            return (Verdict::Visible, ());
        }
        if !self.results.contains_key(&node) {
            let mut batch = vec![(node, query_box(&p))];
            // The nearest queued nodes not yet tested: the next to pop.
            let (tested, results) = (&self.tested, &self.results);
            self.queued
                .retain(|(_, n, _)| !tested.contains(n) && !results.contains_key(n));
            let room = (self.opts.batch as usize - 1).min(self.queued.len());
            if room > 0 {
                if room < self.queued.len() {
                    self.queued
                        .select_nth_unstable_by(room, |a, b| a.0.total_cmp(&b.0));
                }
                batch.extend(self.queued.drain(..room).map(|(_, n, b)| (n, b)));
            }
            batch.append(&mut self.deferred);
            self.round_trip(batch);
        }
        let samples = self.results.get(&node).copied().unwrap_or(u64::MAX);
        if self.passes(samples) {
            self.state.visible_now.insert(node);
            (Verdict::Visible, ())
        } else {
            (Verdict::Occluded, ())
        }
    }

    fn drawn(&mut self, _: &CullView, item: DrawItem) {
        let n = self.skeleton.node(item.node);
        self.state.pass.draw(&[n.first_lod + item.lod]);
    }
}
