//! What streaming needs of the scene, shared by every device and the
//! loader: the pinned set, which device holds which LOD,
//! and the frame clock that spans runs.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, AtomicU8, Ordering};

use gigawalk_scene::Skeleton;

use super::{lod_bytes, PINNED_SHARE, STALE_FRAMES};

/// What streaming needs of the scene, shared by the devices.
pub(crate) struct Plan {
    pub(super) pinned: Vec<bool>,
    /// Per LOD, a bit per device holding it (device i: bit i), so that
    /// STC and the loader skip what every device of a run already has.
    held: Vec<AtomicU8>,
    /// Frame numbers restart at 0 with every run, but what the devices
    /// remember (last drawn, last asked for) spans runs: a run's frame f
    /// is `base + f`, `base` past every frame an earlier run used.
    base: AtomicU64,
    seen: AtomicU64,
    pub budget: u64,
}

impl Plan {
    /// The plan for `budget` bytes a device, its pinned set at most
    /// [`PINNED_SHARE`] of it and `pinned_max` bytes.
    pub fn new(skeleton: &Skeleton, budget: u64, pinned_max: u64) -> Plan {
        // Breadth first from the root: each node's coarsest LOD, while the
        // pinned set stays within its share of the budget.
        let mut pinned = vec![false; skeleton.lods().len()];
        let limit = ((budget as f64 * PINNED_SHARE) as u64).min(pinned_max);
        let mut bytes = 0u64;
        let mut queue = VecDeque::from([0u32]);
        while let Some(n) = queue.pop_front() {
            let node = skeleton.node(n);
            if let Some(l) = node.lods().last() {
                let b = lod_bytes(&skeleton.lods()[l]);
                if bytes + b > limit {
                    break;
                }
                bytes += b;
                pinned[l] = true;
            }
            queue.extend(node.children());
        }
        Plan {
            held: (0..skeleton.lods().len())
                .map(|_| AtomicU8::new(0))
                .collect(),
            pinned,
            base: AtomicU64::new(0),
            seen: AtomicU64::new(0),
            budget,
        }
    }

    /// A new run begins: its frames come after every earlier one's, far
    /// enough that nothing of the last run counts as recent.
    pub fn start_run(&self) {
        let next = self.seen.load(Ordering::Relaxed) + STALE_FRAMES + 2;
        self.base.store(next, Ordering::Relaxed);
        self.seen.fetch_max(next, Ordering::Relaxed);
    }

    /// The run's frame `frame` on the clock that spans runs.
    pub fn frame(&self, frame: u64) -> u64 {
        let f = self.base.load(Ordering::Relaxed) + frame;
        self.seen.fetch_max(f, Ordering::Relaxed);
        f
    }

    /// Whether every device in `mask` holds `lod`.
    pub fn held_by(&self, lod: u32, mask: u8) -> bool {
        self.held
            .get(lod as usize)
            .is_some_and(|h| h.load(Ordering::Relaxed) & mask == mask)
    }

    pub(super) fn set_held(&self, lod: u32, device: usize, held: bool) {
        if let Some(h) = self.held.get(lod as usize) {
            let bit = 1u8 << device.min(7);
            if held {
                h.fetch_or(bit, Ordering::Relaxed);
            } else {
                h.fetch_and(!bit, Ordering::Relaxed);
            }
        }
    }

    pub fn pinned(&self) -> impl Iterator<Item = u32> + '_ {
        self.pinned
            .iter()
            .enumerate()
            .filter(|(_, &p)| p)
            .map(|(l, _)| l as u32)
    }
}

#[cfg(test)]
impl Plan {
    /// A plan for `lods` LODs of one node, none pinned, held by no device.
    pub(super) fn unowned(lods: usize) -> Plan {
        Plan {
            pinned: vec![false; lods],
            held: (0..lods).map(|_| AtomicU8::new(0)).collect(),
            base: AtomicU64::new(0),
            seen: AtomicU64::new(0),
            budget: 1 << 20,
        }
    }
}
