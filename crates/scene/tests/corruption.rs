//! Damaged files: truncated at many lengths or with flipped bytes, every
//! case is an error or a scene that passes validation, never a panic.

mod common;

use gigawalk_scene::SceneReader;
use proptest::prelude::*;

fn scene_bytes() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    common::write_tree(&path, &common::wide(5, glam::DVec3::new(3.0, -2.0, 1.0)));
    std::fs::read(path).unwrap()
}

/// Opens, then reads every LOD: any outcome but a panic is fine, and a
/// scene that opens must have a consistent skeleton.
fn exercise(bytes: Vec<u8>) {
    if let Ok(r) = SceneReader::from_source(bytes, "damaged.gwk") {
        let s = r.skeleton();
        assert!(!s.nodes.is_empty());
        for l in 0..s.lods.len() as u32 {
            let _ = r.read_lod(l);
        }
        let _ = r.verify();
    }
}

#[test]
fn every_truncation_is_an_error() {
    let bytes = scene_bytes();
    for len in 0..bytes.len() {
        assert!(
            SceneReader::from_source(bytes[..len].to_vec(), "cut.gwk").is_err(),
            "truncated at {len} opened"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn flipped_bytes_never_panic(flips in prop::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 1..6)) {
        let mut bytes = scene_bytes_cached().clone();
        for (i, x) in flips {
            let i = i.index(bytes.len());
            bytes[i] ^= x;
        }
        exercise(bytes);
    }

    #[test]
    fn truncated_and_flipped_never_panic(cut in any::<prop::sample::Index>(), at in any::<prop::sample::Index>(), x in 1u8..=255) {
        let mut bytes = scene_bytes_cached().clone();
        let len = cut.index(bytes.len());
        bytes.truncate(len.max(1));
        let i = at.index(bytes.len());
        bytes[i] ^= x;
        exercise(bytes);
    }
}

/// Flips that keep every checksum valid: rewrite a field, then fix the
/// checksums, so the validator itself (not the CRC) must catch it.
#[test]
fn field_damage_with_fixed_checksums_never_panics() {
    let bytes = scene_bytes();
    let mut rng = 0x9e3779b97f4a7c15u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    for _ in 0..3000 {
        let mut b = bytes.clone();
        let at = 64 + (next() as usize % (b.len() - 64));
        let v = next().to_le_bytes();
        let n = 1 + next() as usize % 8;
        let n = n.min(b.len() - at);
        b[at..at + n].copy_from_slice(&v[..n]);
        refresh_checksums(&mut b);
        exercise(b);
    }
}

fn scene_bytes_cached() -> &'static Vec<u8> {
    static BYTES: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    BYTES.get_or_init(scene_bytes)
}

/// Recomputes section, TOC and header CRCs after a deliberate edit (layout
/// per docs/scene-format.md). Leaves the file alone if the TOC is unusable.
fn refresh_checksums(b: &mut [u8]) {
    let u32_at = |b: &[u8], i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap());
    let u64_at = |b: &[u8], i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap());
    let count = u32_at(b, 12) as usize;
    let toc = u64_at(b, 16) as usize;
    if toc.checked_add(count * 32).is_none_or(|e| e > b.len()) {
        return;
    }
    for e in 0..count {
        let at = toc + e * 32;
        let (off, len) = (u64_at(b, at + 8) as usize, u64_at(b, at + 16) as usize);
        if off.checked_add(len).is_some_and(|end| end <= b.len()) {
            let crc = crc32fast::hash(&b[off..off + len]);
            b[at + 24..at + 28].copy_from_slice(&crc.to_le_bytes());
        }
    }
    let crc = crc32fast::hash(&b[toc..toc + count * 32]);
    b[32..36].copy_from_slice(&crc.to_le_bytes());
    let crc = crc32fast::hash(&b[..60]);
    b[60..64].copy_from_slice(&crc.to_le_bytes());
}
