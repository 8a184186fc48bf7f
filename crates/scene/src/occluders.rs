//! The optional OCCL section: large convex planar polygons for
//! object-space occlusion culling (Coorg and Teller), written by
//! preprocess. Layout (little-endian): u32 version (1), u32 count, then per
//! polygon: u32 vertex count (3..=64), f64 area, that many f64x3 world
//! positions. A reader without OCCL support skips the section (it is
//! flagged optional); a file without it has no occluders.

use glam::DVec3;

use crate::format::{Get, Put};
use crate::{ReadAt, ReadError, SceneReader};

pub const TAG_OCCLUDERS: [u8; 4] = *b"OCCL";
pub const OCCLUDERS_VERSION: u32 = 1;
/// Most vertices one occluder may have.
pub const MAX_OCCLUDER_VERTICES: usize = 64;

/// One stored occluder: a convex planar polygon, vertices in order.
#[derive(Clone, Debug, PartialEq)]
pub struct OccluderRecord {
    pub vertices: Vec<DVec3>,
    pub area: f64,
}

/// The section's bytes.
pub fn encode_occluders(occluders: &[OccluderRecord]) -> Vec<u8> {
    let mut p = Put::default();
    p.u32(OCCLUDERS_VERSION);
    p.u32(occluders.len() as u32);
    for o in occluders {
        p.u32(o.vertices.len() as u32);
        p.f64(o.area);
        for v in &o.vertices {
            p.dvec3(*v);
        }
    }
    p.0
}

/// Parses the section; the error says what is wrong and where.
pub fn decode_occluders(bytes: &[u8]) -> Result<Vec<OccluderRecord>, (u64, String)> {
    let need = |at: usize, n: usize| {
        if at + n > bytes.len() {
            Err((
                at as u64,
                format!("ends after {} bytes, inside a record", bytes.len()),
            ))
        } else {
            Ok(())
        }
    };
    need(0, 8)?;
    let mut g = Get::new(bytes);
    let version = g.u32();
    if version != OCCLUDERS_VERSION {
        return Err((
            0,
            format!("version {version}; this gigawalk reads {OCCLUDERS_VERSION}"),
        ));
    }
    let count = g.u32() as usize;
    let mut at = 8;
    let mut out = Vec::with_capacity(count.min(bytes.len() / 60));
    for i in 0..count {
        need(at, 12)?;
        let n = g.u32() as usize;
        let area = g.f64();
        if !(3..=MAX_OCCLUDER_VERTICES).contains(&n) {
            return Err((at as u64, format!("occluder {i} has {n} vertices (3..=64)")));
        }
        if !(area.is_finite() && area > 0.0) {
            return Err((at as u64, format!("occluder {i} has area {area}")));
        }
        need(at + 12, n * 24)?;
        let vertices: Vec<DVec3> = (0..n).map(|_| g.dvec3()).collect();
        if vertices.iter().any(|v| !v.is_finite()) {
            return Err((at as u64, format!("occluder {i} has a non-finite vertex")));
        }
        at += 12 + n * 24;
        out.push(OccluderRecord { vertices, area });
    }
    if at != bytes.len() {
        return Err((
            at as u64,
            format!("{} bytes after the last occluder", bytes.len() - at),
        ));
    }
    Ok(out)
}

impl<R: ReadAt> SceneReader<R> {
    /// The scene's occluders; `None` only when the table of contents lists
    /// no OCCL section (written before it existed). A stored section that
    /// fails its checksum or its checks is an error naming the file and
    /// OCCL, never `None`.
    pub fn occluders(&self) -> Result<Option<Vec<OccluderRecord>>, ReadError> {
        self.decode_optional(TAG_OCCLUDERS, decode_occluders)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(at: f64) -> OccluderRecord {
        OccluderRecord {
            vertices: vec![
                DVec3::new(at, 0.0, 0.0),
                DVec3::new(at + 1.0, 0.0, 0.0),
                DVec3::new(at + 1.0, 1.0, 0.0),
                DVec3::new(at, 1.0, 0.0),
            ],
            area: 1.0,
        }
    }

    #[test]
    fn occluders_round_trip_and_every_truncation_is_an_error() {
        let occ = vec![square(0.0), square(1e7)];
        let bytes = encode_occluders(&occ);
        assert_eq!(decode_occluders(&bytes).unwrap(), occ);
        assert_eq!(decode_occluders(&encode_occluders(&[])).unwrap(), vec![]);
        for cut in 0..bytes.len() {
            assert!(decode_occluders(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode_occluders(&longer).is_err());
        let mut bad = bytes.clone();
        bad[0] = 9;
        assert!(decode_occluders(&bad).unwrap_err().1.contains("version"));
        let mut bad = bytes.clone();
        bad[8] = 2; // two vertices
        assert!(decode_occluders(&bad).unwrap_err().1.contains("vertices"));
        let mut bad = bytes;
        bad[12..20].copy_from_slice(&f64::NAN.to_le_bytes());
        assert!(decode_occluders(&bad).unwrap_err().1.contains("area"));
    }
}
