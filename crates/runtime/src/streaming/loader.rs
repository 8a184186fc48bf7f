//! The loader thread: reads the LODs the stages ask for, demands before
//! prefetches and newest frame first, and hands each to every device.

use std::collections::HashMap;
use std::sync::Arc;

use crossbeam_channel::{Receiver, Sender};
use gigawalk_gpu::DecodedLod;

use super::{Loaded, LodSource, Plan, Request, STALE_FRAMES};
use crate::RuntimeError;

/// The loader (the fourth stage): reads requested LODs, newest frame's
/// first (prefetches only when no LOD a frame had to stand in for is
/// waiting), skipping those every device of the run (`mask`) holds, and
/// hands each to every device. Requests more than
/// [`STALE_FRAMES`] older than the newest frame asked for are dropped
/// (the camera has moved on; they are asked again if still needed). Ends
/// when RVG's request queue closes, or every device's inbox has; a read
/// error ends it with that error, and the stages see their inboxes close
/// and stop.
pub(crate) fn loader(
    source: &dyn LodSource,
    requests: Receiver<Request>,
    prefetches: Receiver<Request>,
    mut devices: Vec<Sender<Loaded>>,
    plan: &Plan,
    mask: u8,
) -> Result<(), RuntimeError> {
    let mut queue = Queue::default();
    let mut prefetching = true;
    loop {
        if queue.is_empty() {
            // Idle: wait for either queue (prefetches only while STC or OR runs).
            if prefetching {
                crossbeam_channel::select! {
                    recv(requests) -> r => match r {
                        Ok(r) => queue.add(r),
                        Err(_) => return Ok(()),
                    },
                    recv(prefetches) -> r => match r {
                        Ok(r) => queue.add(r),
                        Err(_) => prefetching = false,
                    },
                }
            } else {
                match requests.recv() {
                    Ok(r) => queue.add(r),
                    Err(_) => return Ok(()),
                }
            }
        }
        for r in requests.try_iter().chain(prefetches.try_iter()) {
            queue.add(r);
        }
        let Some(lod) = queue.next(plan, mask) else {
            continue;
        };
        let stored = source
            .read_lod_stored(lod)
            .map_err(|source| RuntimeError::Load {
                source: Box::new(source),
            })?;
        let loaded: Loaded = Arc::new((lod, DecodedLod::from_stored(stored)));
        // A stage that has finished (OR at the end of the cameras) closes
        // its inbox; the others still take loads.
        devices.retain(|d| d.send(loaded.clone()).is_ok());
        if devices.is_empty() {
            return Ok(());
        }
    }
}
/// The LODs asked for and not yet read, in the order they are read: one
/// entry per LOD, its newest request's frame, a demand outranking a
/// prefetch. The loader thread and the stepped schedule's caller (a page
/// fetching LODs) read in this one order.
#[derive(Default)]
pub(crate) struct Queue {
    /// LOD -> (demand, frame, arrival).
    pending: HashMap<u32, (bool, u64, u64)>,
    /// The newest frame any request came from.
    newest: u64,
    arrivals: u64,
}

impl Queue {
    pub fn add(&mut self, r: Request) {
        let e = self
            .pending
            .entry(r.lod)
            .or_insert((!r.prefetch, r.frame, self.arrivals));
        e.0 |= !r.prefetch;
        e.1 = e.1.max(r.frame);
        self.arrivals += 1;
    }

    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }

    /// The next LOD to read: demands first, then the newest frame's first
    /// request (STC's order: near before far). Requests more than
    /// [`STALE_FRAMES`] older than the newest are dropped (the camera has
    /// moved on; they are asked again if still needed), and so are LODs
    /// every device in `mask` holds.
    pub fn next(&mut self, plan: &Plan, mask: u8) -> Option<u32> {
        self.newest = self
            .pending
            .values()
            .map(|p| p.1)
            .fold(self.newest, u64::max);
        let newest = self.newest;
        self.pending
            .retain(|&lod, p| p.1 + STALE_FRAMES >= newest && !plan.held_by(lod, mask));
        let (&lod, _) = self
            .pending
            .iter()
            .max_by_key(|(_, &(demand, frame, arrival))| {
                (demand, frame, std::cmp::Reverse(arrival))
            })?;
        self.pending.remove(&lod);
        Some(lod)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crossbeam_channel::{bounded, unbounded};
    use gigawalk_scene::{Colours, LodMesh, ReadError};

    /// Hands out a one-triangle LOD for any id; `bad` is unreadable.
    struct Fake {
        bad: u32,
    }

    impl LodSource for Fake {
        fn read_lod(&self, lod: u32) -> Result<LodMesh, ReadError> {
            if lod == self.bad {
                return Err(ReadError {
                    file: "fake.gwk".into(),
                    kind: gigawalk_scene::ReadErrorKind::NoSuchLod { lod, count: 0 },
                });
            }
            Ok(LodMesh {
                origin: glam::DVec3::splat(lod as f64),
                positions: vec![[0.0; 3]; 3],
                normals: vec![[0.0, 0.0, 1.0]; 3],
                colours: Colours::Uniform([1, 2, 3, 255]),
                indices: vec![0, 1, 2],
            })
        }
    }

    fn plan(lods: usize) -> Plan {
        Plan::unowned(lods)
    }

    fn req(lod: u32, frame: u64, prefetch: bool) -> Request {
        Request {
            lod,
            frame,
            prefetch,
        }
    }

    /// Runs the loader over requests queued before it starts; the LODs it
    /// hands out, in order.
    fn load(plan: &Plan, demands: &[Request], prefetches: &[Request]) -> Vec<u32> {
        let (rtx, rrx) = unbounded();
        let (ptx, prx) = unbounded();
        for r in demands {
            rtx.send(*r).unwrap();
        }
        for r in prefetches {
            ptx.send(*r).unwrap();
        }
        drop((rtx, ptx));
        let (dtx, drx) = bounded(64);
        loader(&Fake { bad: u32::MAX }, rrx, prx, vec![dtx], plan, 1).unwrap();
        drx.try_iter().map(|l| l.0).collect()
    }

    /// A root over three leaves; leaf 1 has a fine LOD 1 (40 triangles)
    /// and a coarse LOD 2 (20), leaves 2 and 3 one LOD each (3, 4: 40).
    /// Only the root's one-triangle LOD 0 is pinned under budgets of 70 to
    #[test]
    fn loader_serves_demands_first_newest_frame_first_and_skips_stale_and_held() {
        let p = plan(16);
        p.set_held(9, 0, true);
        let order = load(
            &p,
            &[
                req(1, 4, false),
                req(2, 5, false),
                req(3, 5, false),
                req(7, 1, false), // the camera moved on: dropped
                req(9, 5, false), // already on the device
                req(2, 5, false), // asked twice, loaded once
            ],
            &[req(5, 5, true), req(3, 5, true), req(6, 4, true)],
        );
        assert_eq!(order, vec![2, 3, 1, 5, 6]);
    }

    #[test]
    fn a_read_error_ends_the_loader_with_it() {
        let p = plan(4);
        let (rtx, rrx) = unbounded();
        let (_ptx, prx) = unbounded::<Request>();
        rtx.send(req(2, 0, false)).unwrap();
        let (dtx, _drx) = bounded(4);
        let e = loader(&Fake { bad: 2 }, rrx, prx, vec![dtx], &p, 1).unwrap_err();
        assert!(matches!(e, RuntimeError::Load { .. }), "{e}");
        assert!(e.to_string().contains("fake.gwk"), "{e}");
    }

    #[test]
    fn the_loader_ends_when_every_device_is_gone() {
        let p = plan(4);
        let (rtx, rrx) = unbounded();
        let (_ptx, prx) = unbounded::<Request>();
        rtx.send(req(1, 0, false)).unwrap();
        let (dtx, drx) = bounded(4);
        drop(drx);
        loader(&Fake { bad: u32::MAX }, rrx, prx, vec![dtx], &p, 1).unwrap();
        drop(rtx);
    }
}
