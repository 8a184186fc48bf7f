//! Which LODs a page fetches, keeps and draws, under a memory budget.
//!
//! A page has one thread: traversal hands each frame's draw list (front
//! to back) to [`Streamer::frame`], which says what to draw now and what
//! to fetch. A LOD not resident yet is drawn as a stand-in, the nearest
//! resident level of the same node (coarser first: it covers what the
//! wanted level covers, within its larger error), or not at all until
//! one arrives. A node with hidden objects (a *partial* node,
//! `gigawalk_cull::visibility`) has no stand-in: its other levels merge
//! the hidden objects with the shown ones, so only the wanted level, the
//! shown objects' pieces, is drawn. Fetches go out in the list's order, nearest first, at
//! most [`Streamer::max_in_flight`] at once. An arrival makes room by
//! evicting the least recently drawn LODs, never one the current frame
//! draws; when the frame's own LODs fill the budget, the arrival is
//! refused and the stand-in stays.

use std::ops::Range;

use gigawalk_cull::DrawItem;
use gigawalk_scene::Skeleton;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Absent,
    InFlight,
    Resident {
        last_drawn: u64,
        bytes: u64,
    },
    /// Its fetch or decode failed: never asked for again.
    Failed,
}

/// What one frame draws and fetches.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct FramePlan {
    /// LOD ids to draw (wanted ones where resident, else stand-ins).
    pub draw: Vec<u32>,
    /// LOD ids to fetch now.
    pub fetch: Vec<u32>,
    /// Wanted LODs drawn by a stand-in.
    pub stand_ins: usize,
    /// Wanted LODs drawn not at all (nothing of their node resident).
    pub missing: usize,
}

/// What an arrival came to.
#[derive(Debug, PartialEq, Eq)]
pub enum Admit {
    /// Put it on the device after taking these LODs off it.
    Insert { evict: Vec<u32> },
    /// No room without evicting what this frame draws: drop it.
    Refused,
}

pub struct Streamer {
    states: Vec<State>,
    budget: u64,
    resident_bytes: u64,
    in_flight: usize,
    pub max_in_flight: usize,
    frame: u64,
}

impl Streamer {
    /// A streamer for `lods` LODs keeping at most `budget` bytes resident.
    pub fn new(lods: usize, budget: u64, max_in_flight: usize) -> Streamer {
        Streamer {
            states: vec![State::Absent; lods],
            budget,
            resident_bytes: 0,
            in_flight: 0,
            max_in_flight: max_in_flight.max(1),
            frame: 0,
        }
    }

    pub fn resident_bytes(&self) -> u64 {
        self.resident_bytes
    }

    pub fn in_flight(&self) -> usize {
        self.in_flight
    }

    pub fn is_resident(&self, lod: u32) -> bool {
        matches!(self.states.get(lod as usize), Some(State::Resident { .. }))
    }

    /// Plans frame `frame` for traversal's `wanted` items (front to back);
    /// nodes `partial` names get no stand-in.
    pub fn frame(
        &mut self,
        frame: u64,
        wanted: &[DrawItem],
        skeleton: &Skeleton,
        partial: &dyn Fn(u32) -> bool,
    ) -> FramePlan {
        self.frame = frame;
        let mut plan = FramePlan::default();
        for item in wanted {
            let node = skeleton.node(item.node);
            let first = node.first_lod;
            let count = node.lod_count;
            let want = first + item.lod;
            if self.touch(want) {
                plan.draw.push(want);
            } else {
                // Coarser levels first, then finer ones.
                let stand_in = if partial(item.node) {
                    None
                } else {
                    (item.lod + 1..count)
                        .chain((0..item.lod).rev())
                        .map(|l| first + l)
                        .find(|&l| self.touch(l))
                };
                match stand_in {
                    Some(l) => {
                        plan.draw.push(l);
                        plan.stand_ins += 1;
                    }
                    None => plan.missing += 1,
                }
                if self.states[want as usize] == State::Absent
                    && self.in_flight + plan.fetch.len() < self.max_in_flight
                {
                    plan.fetch.push(want);
                }
            }
        }
        for &l in &plan.fetch {
            self.states[l as usize] = State::InFlight;
        }
        self.in_flight += plan.fetch.len();
        plan
    }

    /// Marks `lod` drawn this frame if it is resident.
    fn touch(&mut self, lod: u32) -> bool {
        match &mut self.states[lod as usize] {
            State::Resident { last_drawn, .. } => {
                *last_drawn = self.frame;
                true
            }
            _ => false,
        }
    }

    /// `lod` arrived, taking `bytes` once resident: room is made, or it is
    /// refused (and may be fetched again later).
    pub fn arrived(&mut self, lod: u32, bytes: u64) -> Admit {
        self.in_flight = self.in_flight.saturating_sub(1);
        if self.states[lod as usize] != State::InFlight {
            return Admit::Refused;
        }
        let mut evict = Vec::new();
        if self.resident_bytes + bytes > self.budget {
            let mut old: Vec<(u64, u32, u64)> = self
                .states
                .iter()
                .enumerate()
                .filter_map(|(i, s)| match *s {
                    State::Resident { last_drawn, bytes } if last_drawn < self.frame => {
                        Some((last_drawn, i as u32, bytes))
                    }
                    _ => None,
                })
                .collect();
            old.sort_unstable();
            let mut freed = 0;
            for (_, id, b) in old {
                if self.resident_bytes - freed + bytes <= self.budget {
                    break;
                }
                freed += b;
                evict.push(id);
            }
            if self.resident_bytes - freed + bytes > self.budget {
                self.states[lod as usize] = State::Absent;
                return Admit::Refused;
            }
            for &id in &evict {
                self.states[id as usize] = State::Absent;
            }
            self.resident_bytes -= freed;
        }
        self.states[lod as usize] = State::Resident {
            last_drawn: self.frame,
            bytes,
        };
        self.resident_bytes += bytes;
        Admit::Insert { evict }
    }

    /// The device could not take `lod` after all (out of room in one
    /// piece): forget it was admitted.
    pub fn not_inserted(&mut self, lod: u32) {
        if let State::Resident { bytes, .. } = self.states[lod as usize] {
            self.resident_bytes -= bytes;
            self.states[lod as usize] = State::Absent;
        }
    }

    /// `lod`'s fetch or decode failed: it is not asked for again.
    pub fn failed(&mut self, lod: u32) {
        if self.states[lod as usize] == State::InFlight {
            self.in_flight = self.in_flight.saturating_sub(1);
        }
        self.states[lod as usize] = State::Failed;
    }
}

/// One range request for several LODs: the byte range and the LODs in it
/// (their blobs lie wholly inside).
#[derive(Debug, PartialEq, Eq)]
pub struct Batch {
    pub range: Range<u64>,
    pub lods: Vec<u32>,
}

/// Bytes between two blobs a batch fetches rather than making two
/// requests: a request costs a round trip, a few KB cost little.
pub const BATCH_GAP: u64 = 16 << 10;
/// The most a batch spans, so a frame's first LODs are not held up by
/// one long transfer.
pub const BATCH_BYTES: u64 = 2 << 20;

/// Groups LODs to fetch (`(lod, its blob's range)`) into range requests:
/// blobs near each other in the file (the writer puts a node's levels
/// and neighbouring nodes together) share one, at most [`BATCH_GAP`]
/// apart and [`BATCH_BYTES`] in all. Batches come in the order of their
/// first LOD in `lods` (nearest first).
pub fn batches(lods: &[(u32, Range<u64>)]) -> Vec<Batch> {
    let mut order: Vec<usize> = (0..lods.len()).collect();
    order.sort_by_key(|&i| lods[i].1.start);
    let mut out: Vec<(usize, Batch)> = Vec::new();
    for i in order {
        let (lod, r) = (lods[i].0, lods[i].1.clone());
        if let Some((first, b)) = out.last_mut() {
            let end = b.range.end.max(r.end);
            if r.start <= b.range.end + BATCH_GAP && end - b.range.start <= BATCH_BYTES {
                b.range.end = end;
                b.lods.push(lod);
                *first = (*first).min(i);
                continue;
            }
        }
        out.push((
            i,
            Batch {
                range: r,
                lods: vec![lod],
            },
        ));
    }
    out.sort_by_key(|(first, _)| *first);
    out.into_iter().map(|(_, b)| b).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_scene::{Aabb, IndexFormat, LodInfo, Node, Provenance, Skeleton, NO_NODE};
    use glam::DVec3;

    /// Two leaves of three LODs each under a root of one.
    fn skeleton() -> Skeleton {
        let b = Aabb::new(DVec3::ZERO, DVec3::ONE);
        let node = |parent, first_child, child_count, first_lod, lod_count| Node {
            bounds: b,
            parent,
            first_child,
            child_count,
            first_lod,
            lod_count,
        };
        let nodes = vec![
            node(NO_NODE, 1, 2, 0, 1),
            node(0, 0, 0, 1, 3),
            node(0, 0, 0, 4, 3),
        ];
        let lod = |error: f32| LodInfo {
            error,
            triangles: 12,
            vertices: 36,
            origin: DVec3::ZERO,
            index_format: IndexFormat::U16,
            uniform_colour: None,
            encoded: false,
            grid: None,
            compressed: false,
            offset: 0,
            len: 0,
            checksum: 0,
        };
        let lods = [4.0, 0.0, 1.0, 2.0, 0.0, 1.0, 2.0].map(lod).to_vec();
        Skeleton::new(DVec3::ZERO, b, nodes, lods, Provenance::default()).expect("a valid skeleton")
    }

    fn item(node: u32, lod: u32) -> DrawItem {
        DrawItem { node, lod }
    }

    #[test]
    fn a_missing_lod_is_fetched_and_drawn_by_a_stand_in_meanwhile() {
        let sk = skeleton();
        let mut s = Streamer::new(7, 1000, 8);
        let p = s.frame(0, &[item(1, 0), item(2, 1)], &sk, &|_| false);
        assert_eq!(p.fetch, vec![1, 5]);
        assert_eq!((p.draw.len(), p.missing), (0, 2));
        // Asked once: in flight.
        let p = s.frame(1, &[item(1, 0), item(2, 1)], &sk, &|_| false);
        assert!(p.fetch.is_empty());
        assert_eq!(s.arrived(5, 100), Admit::Insert { evict: vec![] });
        // Node 2 now wants its finest level: its coarser one stands in.
        let p = s.frame(2, &[item(2, 0)], &sk, &|_| false);
        assert_eq!(
            (p.draw.clone(), p.stand_ins, p.fetch.clone()),
            (vec![5], 1, vec![4])
        );
        assert_eq!(s.arrived(4, 100), Admit::Insert { evict: vec![] });
        let p = s.frame(3, &[item(2, 0)], &sk, &|_| false);
        assert_eq!((p.draw, p.stand_ins, p.missing), (vec![4], 0, 0));
    }

    #[test]
    fn a_partial_node_has_no_stand_in() {
        let sk = skeleton();
        let mut s = Streamer::new(7, 1000, 8);
        s.frame(0, &[item(2, 1)], &sk, &|_| false);
        assert_eq!(s.arrived(5, 100), Admit::Insert { evict: vec![] });
        // Node 2's level 1 is resident, but with a hidden object in node
        // 2 it merges that object: its finest level waits, undrawn.
        let p = s.frame(1, &[item(2, 0)], &sk, &|n| n == 2);
        assert_eq!(
            (p.draw.clone(), p.stand_ins, p.missing, p.fetch.clone()),
            (vec![], 0, 1, vec![4])
        );
        assert_eq!(s.arrived(4, 100), Admit::Insert { evict: vec![] });
        let p = s.frame(2, &[item(2, 0)], &sk, &|n| n == 2);
        assert_eq!((p.draw, p.missing), (vec![4], 0));
    }

    #[test]
    fn arrivals_evict_the_least_recently_drawn_never_this_frames() {
        let sk = skeleton();
        let mut s = Streamer::new(7, 250, 8);
        s.frame(0, &[item(1, 0), item(1, 1), item(1, 2)], &sk, &|_| false);
        assert_eq!(s.arrived(1, 100), Admit::Insert { evict: vec![] });
        assert_eq!(s.arrived(2, 100), Admit::Insert { evict: vec![] });
        s.frame(1, &[item(1, 1)], &sk, &|_| false);
        s.frame(2, &[item(1, 0)], &sk, &|_| false);
        // LOD 2 was drawn at frame 1, LOD 1 at frame 2 (now): 2 goes.
        assert_eq!(s.arrived(3, 100), Admit::Insert { evict: vec![2] });
        assert_eq!(s.resident_bytes(), 200);
        // Both residents are drawn this frame: a new arrival is refused.
        s.frame(3, &[item(1, 0), item(1, 2), item(2, 0)], &sk, &|_| false);
        assert_eq!(s.arrived(4, 100), Admit::Refused);
        assert!(s.resident_bytes() <= 250);
        // Refused means absent: it is asked for again.
        let p = s.frame(4, &[item(2, 0)], &sk, &|_| false);
        assert_eq!(p.fetch, vec![4]);
    }

    #[test]
    fn nearby_blobs_share_a_request_in_the_order_they_were_wanted() {
        let k = 1024;
        let lods = [
            (7, 100 * k..101 * k),
            (1, 0..4 * k),
            (2, 4 * k..9 * k),
            (3, 20 * k..22 * k),
            (9, 22 * k..23 * k),
            (4, 60 * k..61 * k),
        ];
        let b = batches(&lods);
        assert_eq!(
            b,
            vec![
                Batch {
                    range: 100 * k..101 * k,
                    lods: vec![7]
                },
                Batch {
                    range: 0..23 * k,
                    lods: vec![1, 2, 3, 9]
                },
                Batch {
                    range: 60 * k..61 * k,
                    lods: vec![4]
                },
            ]
        );
        // A batch never spans more than BATCH_BYTES.
        let far: Vec<(u32, Range<u64>)> = (0..40)
            .map(|i| (i, i as u64 * 100 * k..(i as u64 * 100 + 90) * k))
            .collect();
        for b in batches(&far) {
            assert!(b.range.end - b.range.start <= BATCH_BYTES, "{b:?}");
        }
        assert_eq!(
            batches(&far).iter().map(|b| b.lods.len()).sum::<usize>(),
            40
        );
    }

    #[test]
    fn fetches_stay_within_the_in_flight_cap_and_failures_are_not_retried() {
        let sk = skeleton();
        let mut s = Streamer::new(7, 1000, 2);
        let p = s.frame(0, &[item(1, 0), item(2, 0), item(0, 0)], &sk, &|_| false);
        assert_eq!(p.fetch, vec![1, 4]);
        s.failed(1);
        let p = s.frame(1, &[item(1, 0), item(2, 0), item(0, 0)], &sk, &|_| false);
        assert_eq!(p.fetch, vec![0]);
        assert_eq!(s.in_flight(), 2);
    }
}
