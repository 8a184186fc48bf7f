//! One device's streamed geometry: a fixed [`GeometryPool`] under the
//! budget, its least-recently-drawn order, what arrives from the loader
//! and what is evicted or displaced for it, and the LODs a frame draws.

use std::collections::{BTreeSet, HashSet};

use crossbeam_channel::{TryRecvError, TrySendError};
use gigawalk_gpu::{DecodedLod, GeometryPool, GpuContext};
use gigawalk_scene::Skeleton;

use super::stand_ins::StandIn;
use super::{lod_bytes, Link, Loaded, Plan, Request, StreamStats, Use, STALE_FRAMES};
use crate::RuntimeError;

/// A device's streamed geometry and its bookkeeping.
pub(crate) struct DeviceStream {
    /// The device's index in the runtime (its bit in `Plan::held`).
    device: usize,
    pub(super) pool: GeometryPool,
    /// Frame + 1 when each LOD was last drawn (0: never).
    last_used: Vec<u64>,
    /// Frame + 1 when each LOD was last drawn as itself, chosen by STC or
    /// as an occluder, not as a stand-in for another (0: never).
    last_chosen: Vec<u64>,
    /// Resident, unpinned LODs by (last_used, lod): eviction order.
    lru: BTreeSet<(u64, u32)>,
    /// Frame + 1 of each LOD's last request (0: none).
    requested: Vec<u64>,
    /// Newest frame + 1 when each LOD last arrived and found no room (0:
    /// never, or it has been resident since).
    dropped: Vec<u64>,
    /// The visible frame being drawn, its ancestor stand-ins, its figures.
    frame: u64,
    /// The newest frame any stage drew on this device.
    newest: u64,
    pub(super) standins: HashSet<u32>,
    /// Device bytes of the pinned LODs in the pool.
    pinned_bytes: u64,
    stats: StreamStats,
}

impl DeviceStream {
    /// An empty pool of `plan.budget` bytes on `ctx`; [`DeviceStream::pin`]
    /// puts the pinned set in.
    pub fn new(
        ctx: &GpuContext,
        device: usize,
        skeleton: &Skeleton,
        plan: &Plan,
        max_buffer: u64,
    ) -> Result<Self, RuntimeError> {
        let pool = GeometryPool::new(ctx, skeleton.lods().len(), plan.budget, max_buffer)
            .map_err(|source| RuntimeError::Setup { source })?;
        let n = skeleton.lods().len();
        Ok(DeviceStream {
            device,
            pool,
            last_used: vec![0; n],
            last_chosen: vec![0; n],
            lru: BTreeSet::new(),
            requested: vec![0; n],
            dropped: vec![0; n],
            frame: 0,
            newest: 0,
            standins: HashSet::new(),
            pinned_bytes: 0,
            stats: StreamStats::default(),
        })
    }

    /// Puts pinned LOD `id` in the pool for good. Within its share of an
    /// empty pool a pinned LOD fits unless the pool's pages are smaller
    /// than the LOD; one that does not is left out (it is then streamed
    /// like any other).
    pub fn pin(&mut self, ctx: &GpuContext, plan: &Plan, id: u32, lod: &DecodedLod) {
        if self.pool.insert(ctx, id, lod) {
            plan.set_held(id, self.device, true);
            self.pinned_bytes += self.pool.bytes_of(id);
        }
    }

    pub fn pool(&self) -> &GeometryPool {
        &self.pool
    }

    /// The figures since the last call (a frame's, called as it ends).
    pub fn take_stats(&mut self) -> StreamStats {
        StreamStats {
            resident_bytes: self.pool.used_bytes(),
            pool_bytes: self.pool.capacity_bytes(),
            ..std::mem::take(&mut self.stats)
        }
    }

    /// `lod` is drawn in `frame`: `chosen` as itself, else as a stand-in.
    fn touch(&mut self, plan: &Plan, lod: u32, frame: u64, chosen: bool) {
        let l = lod as usize;
        if chosen {
            self.last_chosen[l] = self.last_chosen[l].max(frame + 1);
        }
        // Stages on one device draw different frames (OR i + 1, RVG i):
        // keep the newest.
        if self.last_used[l] < frame + 1 {
            if !plan.pinned[l] {
                self.lru.remove(&(self.last_used[l], lod));
                self.lru.insert((frame + 1, lod));
            }
            self.last_used[l] = frame + 1;
        }
    }

    /// Puts a loaded LOD in the pool, evicting the least recently drawn
    /// LODs not drawn in the newest two frames; one this device asked for
    /// again after it was dropped lately may also displace LODs those
    /// frames drew only as stand-ins. Drops it when even that leaves no
    /// room (it is asked for again later). An arrival asked for counts as
    /// chosen in the newest frame, so it is no stand-in to displace before
    /// its frame draws it.
    ///
    /// Stand-ins may go because they are there only for what is missing:
    /// when the LODs the camera needs fit the budget but those and their
    /// stand-ins do not, keeping the stand-ins would drop every arrival
    /// forever (a camera held still would never settle). Each arrival that
    /// displaces them is a chosen LOD, which is not displaced in turn, so
    /// a held camera converges; the frames meanwhile draw coarser
    /// stand-ins (an ancestor's, down to the pinned set), never a hole.
    /// Only a second arrival may: when first arrivals could, the demo
    /// plant's walk at a 3 MiB budget asked for 6% more LODs and drew 10%
    /// more stand-ins (a moving camera soon wants the stand-ins again);
    /// this way it asks and draws as without displacement.
    fn take(&mut self, ctx: &GpuContext, plan: &Plan, loaded: &Loaded) {
        let (id, lod) = (&loaded.0, &loaded.1);
        if self.pool.contains(*id) || !self.pool.could_hold(lod) {
            return;
        }
        let asked = self.requested.get(*id as usize).copied().unwrap_or(0);
        // Asked for lately: a LOD still wanted is asked for again every
        // STALE_FRAMES frames (a prefetch never is).
        let demanded = asked != 0 && asked + 2 * STALE_FRAMES > self.newest;
        let l = *id as usize;
        // ...and dropped lately for want of room.
        let dropped = self.dropped[l];
        let starved = demanded && dropped != 0 && dropped + 2 * STALE_FRAMES > self.newest;
        loop {
            if self.pool.insert(ctx, *id, lod) {
                self.dropped[l] = 0;
                plan.set_held(*id, self.device, true);
                self.stats.loaded_lods += 1;
                self.stats.loaded_bytes += lod.bytes();
                // A LOD that just arrived counts as drawn in the newest
                // frame: it was asked for to be drawn. (Counted as never
                // drawn, it went first, before LODs of long-past frames:
                // OR's device, which draws it only a frame later as an
                // occluder, evicted it before it was ever used.)
                self.last_used[l] = self.last_used[l].max(self.newest + 1);
                // Asked for: chosen (a second starved arrival in the same
                // inbox would otherwise displace it before it is drawn).
                if demanded {
                    self.last_chosen[l] = self.last_chosen[l].max(self.newest + 1);
                }
                if !plan.pinned[l] {
                    self.lru.insert((self.last_used[l], *id));
                }
                return;
            }
            // Evict in batches about the size of what is needed.
            let mut freed = 0;
            while freed < 2 * lod.bytes() {
                match self.lru.first().copied() {
                    // Never what the newest two frames drew: OR's frame
                    // i + 1 and RVG's frame i share one device's pool.
                    Some((used, victim)) if used < self.newest => {
                        freed += self.evict(plan, used, victim);
                    }
                    _ => break,
                }
            }
            if freed == 0 && starved {
                freed = self.displace_stand_ins(plan, lod.bytes());
            }
            if freed == 0 {
                self.dropped[l] = self.newest + 1;
                return;
            }
        }
    }

    /// Evicts LODs the newest two frames drew only as stand-ins, least
    /// recently drawn first, until `need` bytes are free, and at least one
    /// (the pool needs contiguous room: `take` calls again while the
    /// arrival does not fit); the bytes freed. None when all of them and
    /// the free room would not hold `need` bytes (the stand-ins would go
    /// for nothing).
    fn displace_stand_ins(&mut self, plan: &Plan, need: u64) -> u64 {
        let victims: Vec<(u64, u32)> = self
            .lru
            .range((self.newest, 0)..)
            .filter(|&&(_, l)| self.last_chosen[l as usize] < self.newest)
            .copied()
            .collect();
        let free = self.pool.capacity_bytes() - self.pool.used_bytes();
        let held: u64 = victims.iter().map(|&(_, l)| self.pool.bytes_of(l)).sum();
        if free + held < need {
            return 0;
        }
        let mut freed = 0;
        for (used, victim) in victims {
            if freed > 0 && free + freed >= need {
                break;
            }
            freed += self.evict(plan, used, victim);
            self.stats.displaced_stand_ins += 1;
        }
        freed
    }

    /// Takes `victim` (last drawn in frame `used` - 1) out of the pool;
    /// the bytes freed.
    fn evict(&mut self, plan: &Plan, used: u64, victim: u32) -> u64 {
        // The pinned set is never evicted (it is never in the LRU).
        assert!(
            !plan.pinned.get(victim as usize).copied().unwrap_or(false),
            "pinned LOD {victim} chosen for eviction"
        );
        self.lru.remove(&(used, victim));
        let before = self.pool.used_bytes();
        self.pool.remove(victim);
        plan.set_held(victim, self.device, false);
        self.stats.evicted_lods += 1;
        before - self.pool.used_bytes()
    }

    /// The LODs to draw for `lods` (chosen by STC) this frame: resident
    /// ones, and with [`Use::Visible`] stand-ins for the rest, which are
    /// requested from the loader. Loads that arrived go in first. `None`
    /// when the loader has stopped (its inbox is closed).
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        ctx: &GpuContext,
        skeleton: &Skeleton,
        plan: &Plan,
        link: &Link,
        frame: u64,
        lods: &[u32],
        usage: Use,
    ) -> Option<Vec<u32>> {
        let frame = plan.frame(frame);
        self.newest = self.newest.max(frame);
        if usage.is_visible() && frame != self.frame {
            self.frame = frame;
            self.standins.clear();
        }
        loop {
            match link.inbox.try_recv() {
                Ok(loaded) => self.take(ctx, plan, &loaded),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return None,
            }
        }
        // Occluders come best first (OR ranks them when streaming): those
        // that fit beside the pinned set, greedily, are kept from eviction
        // and asked for; the rest are drawn while resident, not kept. So
        // when a pose's occluders outgrow the pool, the ones that hide most
        // stay: kept all alike, whichever arrived last found no room, and
        // when those were the ones that hid most, occlusion culled less,
        // the visible set grew past the budget and never shrank again (a
        // held camera drew stand-ins for good).
        let room = self.pool.capacity_bytes().saturating_sub(self.pinned_bytes);
        let mut kept = 0u64;
        let mut out = Vec::with_capacity(lods.len());
        for &lod in lods {
            let l = lod as usize;
            let keep = usage.is_visible() || plan.pinned.get(l).copied().unwrap_or(false) || {
                let bytes = match self.pool.bytes_of(lod) {
                    0 => skeleton.lods().get(l).map_or(0, lod_bytes),
                    b => b,
                };
                let fits = kept + bytes <= room;
                kept += if fits { bytes } else { 0 };
                fits
            };
            if self.pool.contains(lod) {
                if keep {
                    self.touch(plan, lod, frame, true);
                }
                out.push(lod);
                continue;
            }
            if !keep || l >= self.requested.len() {
                continue;
            }
            let asked = self.requested[l];
            if asked == 0 || asked + STALE_FRAMES <= frame + 1 {
                if let Some(tx) = &link.requests {
                    match tx.try_send(Request {
                        lod,
                        frame,
                        // OR's: served when no stand-in waits for a load.
                        prefetch: !usage.is_visible(),
                    }) {
                        Ok(()) => {
                            self.requested[l] = frame + 1;
                            self.stats.requests += 1;
                        }
                        Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {}
                    }
                }
            }
            let Use::Visible { shown } = usage else {
                continue;
            };
            match self.stand_in(skeleton, lod, shown) {
                StandIn::Draw(s) => {
                    self.stats.substituted += 1;
                    self.touch(plan, s, frame, false);
                    out.push(s);
                }
                StandIn::Drawn => self.stats.substituted += 1,
                StandIn::None => self.stats.missing += 1,
            }
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crossbeam_channel::unbounded;
    use gigawalk_scene::{Colours, LodInfo, LodMesh};

    /// 100 triangles (the pinned share is an eighth). Also the bytes of a
    /// triangle.
    fn three_leaves() -> (Skeleton, Vec<LodMesh>, u64) {
        use gigawalk_scene::{Aabb, IndexFormat, Node, NO_NODE};
        let unit = Aabb::new(glam::DVec3::ZERO, glam::DVec3::ONE);
        let node = |parent, first_child, child_count, first_lod, lod_count| Node {
            bounds: unit,
            parent,
            first_child,
            child_count,
            first_lod,
            lod_count,
        };
        let nodes = vec![
            node(NO_NODE, 1, 3, 0, 1),
            node(0, 0, 0, 1, 2),
            node(0, 0, 0, 3, 1),
            node(0, 0, 0, 4, 1),
        ];
        let mesh = |t: u32| LodMesh {
            origin: glam::DVec3::ZERO,
            positions: vec![[0.0; 3]; 3 * t as usize],
            normals: vec![[0.0, 0.0, 1.0]; 3 * t as usize],
            colours: Colours::Uniform([9, 9, 9, 255]),
            indices: (0..3 * t).collect(),
        };
        let meshes: Vec<LodMesh> = [1, 40, 20, 40, 40].into_iter().map(mesh).collect();
        let lods = meshes
            .iter()
            .map(|m| LodInfo {
                error: 0.0,
                triangles: m.indices.len() as u32 / 3,
                vertices: m.positions.len() as u32,
                origin: m.origin,
                index_format: IndexFormat::U16,
                uniform_colour: None,
                encoded: false,
                grid: None,
                compressed: false,
                offset: 0,
                len: 0,
                checksum: 0,
            })
            .collect();
        let skeleton = Skeleton::new(glam::DVec3::ZERO, unit, nodes, lods, Default::default())
            .expect("a valid skeleton");
        // A triangle's bytes in a LOD of many (a LOD's u16 indices are
        // padded to 4 bytes, so LOD 0's one triangle takes a little more).
        let bytes = lod_bytes(skeleton.lod(1)) / skeleton.lod(1).triangles as u64;
        (skeleton, meshes, bytes)
    }

    /// A walk on [`three_leaves`] under a budget of `budget` triangles'
    /// bytes (and a half): frame i takes in `script[i].0` (in that order)
    /// and draws for the chosen LODs `script[i].1`. What each frame drew
    /// and its figures, and what is resident after.
    fn stand_in_walk(
        ctx: &GpuContext,
        budget: u64,
        script: &[(&[u32], &[u32])],
    ) -> (Vec<Vec<u32>>, Vec<StreamStats>, Vec<u32>) {
        let (drawn, stats, resident, _) = walk(ctx, budget, Use::VISIBLE, script);
        (drawn, stats, resident)
    }

    /// [`stand_in_walk`] for a stage that uses the LODs as `usage`; also
    /// what it asked the loader for.
    #[allow(clippy::type_complexity)]
    fn walk(
        ctx: &GpuContext,
        budget: u64,
        usage: Use,
        script: &[(&[u32], &[u32])],
    ) -> (Vec<Vec<u32>>, Vec<StreamStats>, Vec<u32>, Vec<Request>) {
        let (skeleton, meshes, triangle) = three_leaves();
        let plan = Plan::new(
            &skeleton,
            budget * triangle + triangle / 2,
            crate::PINNED_MAX,
        );
        assert_eq!(plan.pinned().collect::<Vec<_>>(), [0]);
        let mut s = DeviceStream::new(ctx, 0, &skeleton, &plan, 1 << 28).unwrap();
        s.pin(ctx, &plan, 0, &DecodedLod::new(&meshes[0]));
        let (req_tx, req_rx) = unbounded();
        let (in_tx, in_rx) = unbounded();
        let link = Link {
            requests: Some(req_tx),
            inbox: in_rx,
        };
        let (mut drawn, mut stats) = (Vec::new(), Vec::new());
        for (f, (arrive, chosen)) in script.iter().enumerate() {
            for &lod in arrive.iter() {
                let mesh = DecodedLod::new(&meshes[lod as usize]);
                in_tx.send(Arc::new((lod, mesh))).unwrap();
            }
            let out = s.prepare(ctx, &skeleton, &plan, &link, f as u64, chosen, usage);
            drawn.push(out.unwrap());
            stats.push(s.take_stats());
        }
        let resident = (0..meshes.len() as u32)
            .filter(|&l| s.pool.contains(l))
            .collect();
        (drawn, stats, resident, req_rx.try_iter().collect())
    }

    #[test]
    fn occluders_that_fit_are_kept_and_asked_for_best_first_and_the_rest_go_first() {
        let Some(d) = gigawalk_gpu::devices_or_skip(1, "occluder keeping") else {
            return;
        };
        // OR's occluders, best first: leaf 3 (LOD 4, not resident), leaf 2
        // (3) and leaf 1 (1), 40 triangles each; 3 and 1 arrive in frame
        // 0. In a pool of 100 triangles beside the pinned root, 4 and 3
        // fit: 4 is asked for (as a prefetch) and 3 kept, 1 is drawn but
        // not kept, so when 4 arrives in frame 3 it takes 1's room. (Kept
        // alike, 1 stayed and 4 was dropped, never asked for by OR: when
        // the occluders dropped were those that hid most, a held camera's
        // visible set grew past the budget for good.)
        let script: [(&[u32], &[u32]); 4] = [
            (&[3, 1], &[4, 3, 1]),
            (&[], &[4, 3, 1]),
            (&[], &[4, 3, 1]),
            (&[4], &[4, 3, 1]),
        ];
        let (drawn, _, resident, asked) = walk(&d[0], 100, Use::Occluders, &script);
        assert_eq!(drawn[..3], [[3, 1], [3, 1], [3, 1]]);
        assert_eq!(drawn[3], [4, 3]);
        assert_eq!(resident, [0, 3, 4]);
        assert!(!asked.is_empty());
        assert!(asked.iter().all(|r| r.lod == 4 && r.prefetch), "{asked:?}");
    }

    #[test]
    fn an_arrival_asked_for_displaces_stand_ins_in_use_only_when_that_makes_room() {
        let Some(d) = gigawalk_gpu::devices_or_skip(1, "stand-in displacement") else {
            return;
        };
        // Frame 0 draws leaf 1 coarse (LOD 2) and leaf 2 (3; first, so that
        // the room 2 leaves is next to the free end: the pool's ranges must
        // be contiguous). Frames 1-4 want leaf 1 fine (1), asked for in
        // frame 1 and again in 3, with 2 standing in. A prefetch of leaf 3
        // (4) arrives twice in frame 2, LOD 1 in frames 3 and 4.
        let script: [(&[u32], &[u32]); 5] = [
            (&[3, 2], &[2, 3]),
            (&[], &[1, 3]),
            (&[4, 4], &[1, 3]),
            (&[1], &[1, 3]),
            (&[1], &[1, 3]),
        ];
        // 100 triangles: the chosen LODs with LOD 1 fit (81 triangles),
        // with the stand-in too they do not (101). The prefetch does not
        // fit beside what the newest two frames drew and, never asked for,
        // displaces nothing however often it comes. LOD 1's first arrival
        // is dropped (a moving camera may no longer want it), its second
        // displaces the stand-in.
        let (drawn, stats, resident) = stand_in_walk(&d[0], 100, &script);
        assert_eq!(
            drawn,
            [[2, 3]; 4].iter().chain(&[[1, 3]]).collect::<Vec<_>>()
        );
        assert_eq!(resident, [0, 1, 3]);
        let displaced: Vec<u64> = stats.iter().map(|s| s.displaced_stand_ins).collect();
        assert_eq!(displaced, [0, 0, 0, 0, 1]);
        // 70 triangles: LOD 1 does not fit even without the stand-in (81):
        // the stand-in stays and is drawn.
        let (drawn, stats, resident) = stand_in_walk(&d[0], 70, &script);
        assert_eq!(drawn[4], [2, 3]);
        assert_eq!(resident, [0, 2, 3]);
        assert!(stats.iter().all(|s| s.displaced_stand_ins == 0));
    }

    #[test]
    fn a_starved_arrival_does_not_displace_one_that_just_arrived() {
        let Some(d) = gigawalk_gpu::devices_or_skip(1, "stand-in displacement") else {
            return;
        };
        // Frames 1-4 want leaf 1 fine (1), leaf 2 (3) and leaf 3 (4); 2
        // stands in for 1, the root's pinned LOD 0 for 4. LOD 4 is dropped
        // in frame 2 and LOD 1 in frame 3; in frame 4 both come again, 1
        // first: it displaces the stand-in 2, and 4, starved too, finds no
        // stand-in left to displace. Counted as a stand-in (never drawn
        // yet), LOD 1 would have gone for it, for nothing gained.
        let script: [(&[u32], &[u32]); 5] = [
            (&[3, 2], &[2, 3]),
            (&[], &[1, 3, 4]),
            (&[4], &[1, 3, 4]),
            (&[1], &[1, 3, 4]),
            (&[1, 4], &[1, 3, 4]),
        ];
        let (drawn, stats, resident) = stand_in_walk(&d[0], 100, &script);
        assert_eq!(drawn[1..4], [[2, 3, 0], [2, 3, 0], [2, 3, 0]]);
        assert_eq!(drawn[4], [1, 3, 0]);
        assert_eq!(resident, [0, 1, 3]);
        assert_eq!(stats[4].displaced_stand_ins, 1);
    }

    #[test]
    fn no_stand_in_holds_a_hidden_object() {
        let Some(d) = gigawalk_gpu::devices_or_skip(1, "stand-ins with hidden objects") else {
            return;
        };
        use gigawalk_scene::objects::{ObjectRecord, ObjectRun, ObjectTable};
        let (skeleton, _, _) = three_leaves();
        // Leaf 1's full detail (LOD 1) is two objects of 20 triangles;
        // hiding the second makes leaf 1 and the root partial: leaf 1's
        // coarse LOD 2 and the root's LOD 0 merge it with the first.
        let record = |name: &str| ObjectRecord {
            name: name.into(),
            path: name.into(),
            file: String::new(),
            metadata: None,
            bounds: skeleton.bounds(),
            triangles: 20,
        };
        let table = ObjectTable::new(
            vec![record("kept"), record("hidden")],
            vec![(
                1,
                vec![
                    ObjectRun {
                        object: 0,
                        triangles: 20,
                    },
                    ObjectRun {
                        object: 1,
                        triangles: 20,
                    },
                ],
            )],
        );
        let shown = gigawalk_cull::Visibility::new(&skeleton, &table, &|o| o == 1, &|_| false);
        // LOD 2 arrives; then leaf 1 wants its full detail (1) and leaf 2
        // its only LOD (3), neither resident.
        let script: [(&[u32], &[u32]); 2] = [(&[2], &[2]), (&[], &[1, 3])];
        let (drawn, stats, _, _) = walk(&d[0], 100, Use::VISIBLE, &script);
        assert_eq!(
            drawn[1],
            [2, 0],
            "every object shown: LOD 2 and the root stand in"
        );
        let hiding = Use::Visible {
            shown: Some(&shown),
        };
        let (drawn, stats_hiding, _, asked) = walk(&d[0], 100, hiding, &script);
        assert!(
            drawn[1].is_empty(),
            "a stand-in holds the hidden object: {:?}",
            drawn[1]
        );
        assert_eq!((stats[1].substituted, stats_hiding[1].missing), (2, 2));
        // Both are still asked for.
        assert!(asked.iter().any(|r| r.lod == 1) && asked.iter().any(|r| r.lod == 3));
    }
}
