//! The host copy of the triangles STC rasterizes for the lazy occlusion
//! grid: positions and indices of the LODs it drew lately, read from the
//! scene on first use (CRC checked), least recently drawn evicted beyond
//! a byte cap.

use std::collections::{BTreeSet, HashMap};

use gigawalk_cull::{LodTriangles, TriangleSource};
use glam::DVec3;

use crate::streaming::LodSource;

struct CpuLod {
    origin: DVec3,
    positions: Vec<[f32; 3]>,
    indices: Vec<u32>,
    last_used: u64,
}

impl CpuLod {
    fn bytes(&self) -> u64 {
        (self.positions.len() * 12 + self.indices.len() * 4) as u64
    }
}

pub(crate) struct TriangleCache<'a> {
    source: &'a dyn LodSource,
    lods: HashMap<u32, CpuLod>,
    /// (last use, LOD): eviction order.
    lru: BTreeSet<(u64, u32)>,
    bytes: u64,
    cap: u64,
    clock: u64,
    failed: bool,
}

impl<'a> TriangleCache<'a> {
    pub fn new(source: &'a dyn LodSource, cap: u64) -> Self {
        TriangleCache {
            source,
            lods: HashMap::new(),
            lru: BTreeSet::new(),
            bytes: 0,
            cap,
            clock: 0,
            failed: false,
        }
    }
}

impl TriangleSource for TriangleCache<'_> {
    fn lod_triangles(&mut self, lod: u32) -> Option<LodTriangles<'_>> {
        self.clock += 1;
        let now = self.clock;
        if let Some(l) = self.lods.get_mut(&lod) {
            self.lru.remove(&(l.last_used, lod));
            l.last_used = now;
            self.lru.insert((now, lod));
        } else {
            let mesh = match self.source.read_lod(lod) {
                Ok(m) => m,
                Err(e) => {
                    // Not rasterized: it occludes nothing (conservative).
                    // The stage drawing it meets the same error and ends
                    // the run with it.
                    if !std::mem::replace(&mut self.failed, true) {
                        tracing::warn!("grid culler: {e}");
                    }
                    return None;
                }
            };
            let l = CpuLod {
                origin: mesh.origin,
                positions: mesh.positions,
                indices: mesh.indices,
                last_used: now,
            };
            self.bytes += l.bytes();
            self.lods.insert(lod, l);
            self.lru.insert((now, lod));
            while self.bytes > self.cap {
                match self.lru.first().copied() {
                    Some((_, old)) if old != lod => {
                        self.lru.pop_first();
                        if let Some(o) = self.lods.remove(&old) {
                            self.bytes -= o.bytes();
                        }
                    }
                    _ => break,
                }
            }
        }
        let l = self.lods.get(&lod)?;
        Some(LodTriangles {
            origin: l.origin,
            positions: &l.positions,
            indices: &l.indices,
        })
    }
}
