//! How a page fetches LODs: nearby blobs share one range request.
//!
//! What to fetch is the runtime's (its stepped schedule names the LODs
//! its frames want, in its loader's order); how is the page's: a range
//! request costs a round trip, so blobs close together in the file go in
//! one.

use std::ops::Range;

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
}
