//! Damaged files: truncated at many lengths or with flipped bytes, every
//! damage that a checksum covers is reported as an error (never a panic,
//! never a scene that reads as if nothing happened); damage that rewrites
//! fields and fixes the checksums is an error or a scene that passes every
//! check.

mod common;

use gigawalk_scene::{ReadError, SceneReader};
use gigawalk_testkit::XorShift;
use proptest::prelude::*;

fn scene_bytes() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    // With occluders and view cells: damage to an optional section is
    // damage too (verify checks every section).
    common::write_tree_with(
        &path,
        &common::wide(5, glam::DVec3::new(3.0, -2.0, 1.0)),
        common::occluder_sections(),
    );
    std::fs::read(path).unwrap()
}

/// Opens, reads every LOD and verifies the whole file: the first error, or
/// `Ok` for a scene that passes every check.
fn exercise(bytes: Vec<u8>) -> Result<(), ReadError> {
    let r = SceneReader::from_source(bytes, "damaged.gwk")?;
    let s = r.skeleton();
    assert!(!s.nodes().is_empty());
    for l in 0..s.lods().len() as u32 {
        r.read_lod(l)?;
    }
    r.verify()
}

/// Flipped bytes of the undamaged scene: an error when any changed byte is
/// under a checksum (header, TOC, a section); otherwise (alignment padding
/// between sections, which no reader looks at) a scene that passes.
fn check_flips(damaged: Vec<u8>) {
    let original = scene_bytes_cached();
    let changed: Vec<usize> = (0..damaged.len())
        .filter(|&i| damaged[i] != original[i])
        .collect();
    let checked = changed.iter().any(|&i| covered()[i]);
    let result = exercise(damaged);
    if checked {
        assert!(
            result.is_err(),
            "bytes {changed:?} changed, yet the scene reads and verifies"
        );
    } else {
        assert!(
            result.is_ok(),
            "only padding bytes {changed:?} changed: {result:?}"
        );
    }
}

#[test]
fn the_undamaged_scene_passes() {
    exercise(scene_bytes_cached().clone()).unwrap();
    // The checks below mean something only if nearly every byte is covered.
    let uncovered = covered().iter().filter(|c| !**c).count();
    assert!(
        uncovered * 100 < covered().len(),
        "{uncovered} bytes uncovered"
    );
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
    fn flipped_bytes_are_errors(flips in prop::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 1..6)) {
        let mut bytes = scene_bytes_cached().clone();
        for (i, x) in flips {
            let i = i.index(bytes.len());
            bytes[i] ^= x;
        }
        check_flips(bytes);
    }

    #[test]
    fn truncated_and_flipped_is_an_error(cut in any::<prop::sample::Index>(), at in any::<prop::sample::Index>(), x in 1u8..=255) {
        let mut bytes = scene_bytes_cached().clone();
        let len = cut.index(bytes.len());
        bytes.truncate(len.max(1));
        let i = at.index(bytes.len());
        bytes[i] ^= x;
        // Shorter than the header says: one flip cannot fix both the
        // length and the header's checksum.
        prop_assert!(exercise(bytes).is_err(), "cut at {}, byte {} flipped", len.max(1), i);
    }
}

/// Flips that keep every checksum valid: rewrite a field, then fix the
/// checksums, so the validator itself (not the CRC) must catch it. Not every
/// rewrite is damage (a vertex moved inside its box, another colour): those
/// must pass every check, not only open; most rewrites must be caught.
#[test]
fn field_damage_with_fixed_checksums_is_an_error_or_a_valid_scene() {
    let bytes = scene_bytes();
    let mut rng = XorShift::new(0x9e3779b97f4a7c15);
    let mut next = move || rng.next_u64();
    let mut errors = 0;
    for _ in 0..3000 {
        let mut b = bytes.clone();
        let at = 64 + (next() as usize % (b.len() - 64));
        let v = next().to_le_bytes();
        let n = 1 + next() as usize % 8;
        let n = n.min(b.len() - at);
        b[at..at + n].copy_from_slice(&v[..n]);
        refresh_checksums(&mut b);
        if exercise(b).is_err() {
            errors += 1;
        }
    }
    // A rewrite of random bytes mostly lands in offsets, counts, indices
    // and boxes, which the validator checks.
    assert!(
        errors > 3000 / 2,
        "only {errors} of 3000 rewrites were errors"
    );
}

fn scene_bytes_cached() -> &'static Vec<u8> {
    static BYTES: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    BYTES.get_or_init(scene_bytes)
}

/// Which bytes of the undamaged scene a checksum covers: the header, the
/// TOC and every section the TOC lists (layout per docs/scene-format.md).
fn covered() -> &'static Vec<bool> {
    static COVERED: std::sync::OnceLock<Vec<bool>> = std::sync::OnceLock::new();
    COVERED.get_or_init(|| {
        let b = scene_bytes_cached();
        let u32_at = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap()) as usize;
        let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap()) as usize;
        let mut covered = vec![false; b.len()];
        let (count, toc) = (u32_at(12), u64_at(16));
        let mut ranges = vec![(0, 64), (toc, toc + count * 32)];
        for e in 0..count {
            let at = toc + e * 32;
            ranges.push((u64_at(at + 8), u64_at(at + 8) + u64_at(at + 16)));
        }
        for (start, end) in ranges {
            covered[start..end].fill(true);
        }
        covered
    })
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

/// A scene of 150 leaf boxes with compressed blobs: enough of them for
/// zstd to train a dictionary (ZDIC).
fn compressed_scene(compress: bool) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("z.gwk");
    common::write_tree_opts(
        &path,
        &common::wide(150, glam::DVec3::new(1.0e6, -2.0, 3.0)),
        Vec::new(),
        compress,
    );
    std::fs::read(path).unwrap()
}

/// Where the TOC says section `tag` lies: (offset, length).
fn section(b: &[u8], tag: &[u8; 4]) -> Option<(usize, usize)> {
    let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap()) as usize;
    let (count, toc) = (
        u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize,
        u64_at(16),
    );
    (0..count)
        .map(|e| toc + 32 * e)
        .find(|&at| &b[at..at + 4] == tag)
        .map(|at| (u64_at(at + 8), u64_at(at + 16)))
}

/// The LOD table's place and each record's (flags, offset, len).
fn lod_records(b: &[u8]) -> (usize, Vec<(u32, usize, usize)>) {
    let u32_at = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap());
    let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap()) as usize;
    let (at, len) = section(b, b"LODS").unwrap();
    let records = (0..len / 64)
        .map(|i| {
            let r = at + 64 * i;
            (u32_at(r + 36), u64_at(r + 48), u64_at(r + 56))
        })
        .collect();
    (at, records)
}

#[test]
fn compressed_blobs_read_back_as_written() {
    let (plain, packed) = (compressed_scene(false), compressed_scene(true));
    assert!(
        packed.len() < plain.len(),
        "{} >= {}",
        packed.len(),
        plain.len()
    );
    let (_, records) = lod_records(&packed);
    let compressed = records.iter().filter(|r| r.0 & 8 != 0).count();
    assert!(
        compressed > records.len() / 2,
        "{compressed} of {}",
        records.len()
    );
    let (a, b) = (
        SceneReader::from_source(plain, "plain.gwk").unwrap(),
        SceneReader::from_source(packed, "packed.gwk").unwrap(),
    );
    assert!(
        b.sections().iter().any(|s| s.name == "ZDIC"),
        "a dictionary was trained"
    );
    b.verify().unwrap();
    for l in 0..a.skeleton().lods().len() as u32 {
        assert_eq!(a.read_lod(l).unwrap(), b.read_lod(l).unwrap());
    }
}

/// Rewritten bytes of compressed blobs (and of the dictionary) with every
/// checksum fixed: each read is an error naming the LOD, or geometry that
/// passes every check; never a panic.
#[test]
fn damaged_compressed_blobs_are_errors_naming_the_lod() {
    let bytes = compressed_scene(true);
    let (lods_at, records) = lod_records(&bytes);
    let compressed: Vec<(usize, &(u32, usize, usize))> = records
        .iter()
        .enumerate()
        .filter(|(_, r)| r.0 & 8 != 0)
        .collect();
    let mut rng = XorShift::new(0x51ed_2705);
    let (mut errors, tries) = (0, 400);
    for t in 0..tries {
        let mut b = bytes.clone();
        let (lod, &(_, off, len)) = compressed[rng.next_u64() as usize % compressed.len()];
        let at = off + rng.next_u64() as usize % len;
        b[at] ^= 1 + (rng.next_u64() % 255) as u8;
        if t % 2 == 0 {
            // The frame's first bytes: magic, header, stated size.
            let head = off + (rng.next_u64() as usize % 8).min(len - 1);
            b[head] ^= 0x40;
        }
        let crc = crc32fast::hash(&b[off..off + len]);
        let rec = lods_at + 64 * lod;
        b[rec + 44..rec + 48].copy_from_slice(&crc.to_le_bytes());
        refresh_checksums(&mut b);
        let r = SceneReader::from_source(b, "damaged.gwk").unwrap();
        if let Err(e) = r.read_lod(lod as u32) {
            errors += 1;
            let e = e.to_string();
            assert!(e.contains(&format!("LOD {lod} ")), "{e}");
        }
    }
    assert!(
        errors > tries / 2,
        "only {errors} of {tries} damaged blobs were errors"
    );
    // A rewritten dictionary: every read an error or a valid LOD.
    let mut b = bytes.clone();
    let zdic = section(&b, b"ZDIC").unwrap();
    for i in (zdic.0..zdic.0 + zdic.1).step_by(7) {
        b[i] = b[i].wrapping_mul(31).wrapping_add(7);
    }
    refresh_checksums(&mut b);
    let r = SceneReader::from_source(b, "damaged.gwk").unwrap();
    let failed = (0..records.len() as u32)
        .filter(|&l| r.read_lod(l).is_err())
        .count();
    assert!(failed > 0, "a scrambled dictionary read every LOD");
}

/// A bumpy sheet of `n` x `n` vertices in the unit box at `x`.
fn sheet(n: u32, x: f64, seed: u32) -> gigawalk_scene::LodMesh {
    let mut positions = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (u, v) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
            let h = 0.5 + 0.4 * ((u * 9.0 + seed as f32).sin() * (v * 7.0).cos());
            positions.push([u, h, v]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            indices.extend([a, a + n, a + 1, a + 1, a + n, a + n + 1]);
        }
    }
    gigawalk_scene::LodMesh {
        origin: glam::DVec3::new(x, 0.0, 0.0),
        normals: vec![[0.0, 1.0, 0.0]; positions.len()],
        positions,
        colours: gigawalk_scene::Colours::Uniform([200, 100, 50, 255]),
        indices,
    }
}

/// Writes a root box over `leaves` sheets side by side, switching
/// compression at the LODs `switch` names.
fn write_sheets(path: &std::path::Path, leaves: u32, switch: &[(u32, bool)]) {
    use gigawalk_scene::{Aabb, Node, Provenance, SceneWriter, NO_NODE};
    let mut w = SceneWriter::create(path).unwrap();
    let all = Aabb::new(glam::DVec3::ZERO, glam::DVec3::new(leaves as f64, 1.0, 1.0));
    let mut nodes = vec![Node {
        bounds: all,
        parent: NO_NODE,
        first_child: 1,
        child_count: leaves,
        first_lod: 0,
        lod_count: 1,
    }];
    w.add_lod(&common::box_mesh(&all, [9, 9, 9, 255]), 1.0)
        .unwrap();
    for i in 0..leaves {
        if let Some(&(_, on)) = switch.iter().find(|s| s.0 == i) {
            w.set_compression(on).unwrap();
        }
        let first_lod = w.add_lod(&sheet(96, i as f64, i), 0.0).unwrap();
        nodes.push(Node {
            bounds: Aabb::new(
                glam::DVec3::new(i as f64, 0.0, 0.0),
                glam::DVec3::new(i as f64 + 1.0, 1.0, 1.0),
            ),
            parent: 0,
            first_child: 0,
            child_count: 0,
            first_lod,
            lod_count: 1,
        });
    }
    w.finish(nodes, Provenance::default()).unwrap();
}

/// Compression switched off and on again while writing, after the
/// dictionary was trained: every LOD reads back as without compression
/// (blobs compressed before the pause need the dictionary written at the
/// end).
#[test]
fn compression_switched_while_writing_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.gwk"), dir.path().join("b.gwk"));
    let leaves = 260;
    write_sheets(&a, leaves, &[]);
    write_sheets(&b, leaves, &[(0, true), (200, false), (230, true)]);
    let bytes = std::fs::read(&b).unwrap();
    let (_, records) = lod_records(&bytes);
    let compressed =
        |range: std::ops::Range<usize>| records[range].iter().filter(|r| r.0 & 8 != 0).count();
    // LOD i + 1 is leaf i: trained mid-way, paused, resumed.
    assert!(compressed(1..150) > 100, "{}", compressed(1..150));
    assert_eq!(compressed(201..231), 0);
    assert!(compressed(231..261) > 20);
    let (a, b) = (
        SceneReader::open(&a).unwrap(),
        SceneReader::open(&b).unwrap(),
    );
    assert!(b.sections().iter().any(|s| s.name == "ZDIC"));
    for l in 0..=leaves {
        assert_eq!(a.read_lod(l).unwrap(), b.read_lod(l).unwrap(), "LOD {l}");
    }
}
