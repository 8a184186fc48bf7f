//! The optional OBJT section: object identity. Which objects of the
//! model a scene holds (name, source file, path in the file, metadata,
//! box), and for every leaf's full-detail LOD which objects its
//! triangles belong to, as runs of consecutive triangles
//! (docs/scene-format.md, "OBJT"). An inner node's LODs, and a leaf's
//! coarser ones, stand for every object with a run in a leaf of the
//! node's subtree ([`ObjectTable::node_objects`]).
//!
//! Read on demand ([`SceneReader::objects`]); a scene written before the
//! section existed has no identity, and only what needs it (pick, find,
//! hide) says so.

use std::collections::HashMap;
use std::ops::Range;

use glam::DVec3;

use crate::format::{Get, Put};
use crate::{Aabb, ReadAt, ReadError, SceneReader, Skeleton};

pub const TAG_OBJECTS: [u8; 4] = *b"OBJT";
pub const OBJECTS_VERSION: u32 = 1;

/// One object as its file names it.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectRecord {
    /// The file's name for it (a glTF node's name, an OBJ group's).
    pub name: String,
    /// Where it is in its file: glTF node names from the root, `/`-joined.
    pub path: String,
    /// The model file it came from, as named to preprocess.
    pub file: String,
    /// The glTF node's `extras`, compact JSON, when it had any.
    pub metadata: Option<String>,
    /// Its triangles' box, world coordinates.
    pub bounds: Aabb,
    /// Its triangles in the scene (after degenerate ones were dropped).
    pub triangles: u64,
}

impl ObjectRecord {
    /// `file/path`, or the path alone for a model of one unnamed file:
    /// what a user tells objects apart by.
    pub fn full_path(&self) -> String {
        if self.file.is_empty() {
            self.path.clone()
        } else {
            format!("{}/{}", self.file, self.path)
        }
    }
}

/// Consecutive triangles of a leaf's full-detail LOD that belong to one
/// object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ObjectRun {
    pub object: u32,
    pub triangles: u32,
}

/// Consecutive triangles of a leaf's full-detail LOD to draw, plain or
/// highlighted: what is left of a leaf some of whose objects are hidden
/// or highlighted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    pub first_triangle: u32,
    pub triangles: u32,
    pub highlight: bool,
}

/// The pieces to draw of each LOD drawn in pieces (a leaf's finest); a
/// LOD not listed is drawn whole.
pub type LodPieces = HashMap<u32, Vec<Piece>>;

/// The decoded section: the objects, and the runs of every leaf's
/// full-detail LOD.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectTable {
    objects: Vec<ObjectRecord>,
    runs: Vec<ObjectRun>,
    /// LOD -> its runs in `runs`, in LOD order.
    lods: Vec<(u32, Range<usize>)>,
}

/// How far a stated decompressed size may exceed the stored bytes: names
/// and boxes compress well, but never a thousandfold.
const MAX_EXPANSION: u64 = 1000;

impl ObjectTable {
    /// A table from its objects and each leaf LOD's runs (LODs ascending).
    pub fn new(objects: Vec<ObjectRecord>, lod_runs: Vec<(u32, Vec<ObjectRun>)>) -> Self {
        let mut runs = Vec::new();
        let mut lods = Vec::with_capacity(lod_runs.len());
        for (lod, r) in lod_runs {
            let start = runs.len();
            runs.extend(r);
            lods.push((lod, start..runs.len()));
        }
        ObjectTable {
            objects,
            runs,
            lods,
        }
    }

    pub fn objects(&self) -> &[ObjectRecord] {
        &self.objects
    }

    pub fn object(&self, id: u32) -> Option<&ObjectRecord> {
        self.objects.get(id as usize)
    }

    /// The runs of `lod`, when it is a leaf's full-detail LOD.
    pub fn runs(&self, lod: u32) -> Option<&[ObjectRun]> {
        let i = self.lods.binary_search_by_key(&lod, |(l, _)| *l).ok()?;
        Some(&self.runs[self.lods[i].1.clone()])
    }

    /// Every LOD with runs, ascending, and its runs.
    pub fn lod_runs(&self) -> impl Iterator<Item = (u32, &[ObjectRun])> + '_ {
        self.lods.iter().map(|(l, r)| (*l, &self.runs[r.clone()]))
    }

    /// The object a triangle of a leaf's full-detail LOD belongs to.
    pub fn object_of_triangle(&self, lod: u32, triangle: u32) -> Option<u32> {
        let mut first = 0u32;
        for r in self.runs(lod)? {
            if triangle < first + r.triangles {
                return Some(r.object);
            }
            first += r.triangles;
        }
        None
    }

    /// The objects every node's LODs stand for: those with a run in a
    /// leaf of its subtree, sorted and unique, per node.
    pub fn node_objects(&self, skeleton: &Skeleton) -> Vec<Vec<u32>> {
        let nodes = skeleton.nodes();
        let mut out: Vec<Vec<u32>> = vec![Vec::new(); nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            if n.is_leaf() && n.lod_count > 0 {
                if let Some(r) = self.runs(n.first_lod) {
                    out[i] = r.iter().map(|r| r.object).collect();
                    out[i].sort_unstable();
                    out[i].dedup();
                }
            }
        }
        // Children have larger indices than their parents.
        for i in (1..nodes.len()).rev() {
            let p = nodes[i].parent as usize;
            let child = std::mem::take(&mut out[i]);
            let mut merged = std::mem::take(&mut out[p]);
            merged.extend_from_slice(&child);
            merged.sort_unstable();
            merged.dedup();
            out[p] = merged;
            out[i] = child;
        }
        out
    }

    /// The objects `pattern` matches, in table order.
    pub fn find(&self, pattern: &Pattern) -> Vec<u32> {
        (0..self.objects.len() as u32)
            .filter(|&i| pattern.matches(&self.objects[i as usize]))
            .collect()
    }

    /// The section's bytes, its body stored plain (a reader takes it
    /// plain or compressed).
    pub fn encode(&self) -> Vec<u8> {
        self.encode_with(|_| None)
    }

    /// The section's bytes, its body as `compress` makes it (one zstd
    /// frame; `None`, or one no smaller: stored plain). This crate starts
    /// no threads: the writer compresses (gigawalk-preprocess, on its
    /// workers).
    pub fn encode_with(&self, compress: impl FnOnce(&[u8]) -> Option<Vec<u8>>) -> Vec<u8> {
        let mut files: Vec<&str> = Vec::new();
        let mut file_index: HashMap<&str, u32> = HashMap::new();
        for o in &self.objects {
            file_index.entry(o.file.as_str()).or_insert_with(|| {
                files.push(o.file.as_str());
                files.len() as u32 - 1
            });
        }
        let mut b = Put::default();
        b.u32(files.len() as u32);
        for f in &files {
            put_str(&mut b, f);
        }
        for o in &self.objects {
            b.u32(file_index[o.file.as_str()]);
            put_str(&mut b, &o.name);
            put_str(&mut b, &o.path);
            match &o.metadata {
                Some(m) => put_str(&mut b, m),
                None => b.u32(u32::MAX),
            }
            b.u64(o.triangles);
            b.dvec3(o.bounds.min);
            b.dvec3(o.bounds.max);
        }
        for (lod, r) in &self.lods {
            b.u32(*lod);
            b.u32(r.len() as u32);
            for run in &self.runs[r.clone()] {
                b.u32(run.object);
                b.u32(run.triangles);
            }
        }
        let body = compress(&b.0).unwrap_or_else(|| b.0.clone());
        let compressed = body.len() < b.0.len();
        let mut p = Put::default();
        p.u32(OBJECTS_VERSION);
        p.u32(self.objects.len() as u32);
        p.u32(self.lods.len() as u32);
        p.u32(compressed as u32);
        p.u64(b.0.len() as u64);
        p.bytes(if compressed { &body } else { &b.0 });
        p.0
    }

    /// Parses the section; the error says what is wrong and where (a byte
    /// offset into the section, or into its decompressed body).
    pub fn decode(bytes: &[u8]) -> Result<ObjectTable, (u64, String)> {
        if bytes.len() < 24 {
            return Err((0, format!("{} bytes, shorter than its header", bytes.len())));
        }
        let mut g = Get::new(bytes);
        let version = g.u32();
        if version != OBJECTS_VERSION {
            return Err((
                0,
                format!("version {version}; this gigawalk reads {OBJECTS_VERSION}"),
            ));
        }
        let count = g.u32() as usize;
        let lod_count = g.u32() as usize;
        let compressed = g.u32();
        let body_len = g.u64();
        let stored = &bytes[24..];
        let body = match compressed {
            0 if body_len == stored.len() as u64 => stored.to_vec(),
            1 if body_len <= MAX_EXPANSION * stored.len() as u64 + 4096 => {
                let b = crate::unpack::decompress(stored, None, body_len as usize)
                    .map_err(|e| (24, format!("the body does not decompress: {e}")))?;
                if b.len() as u64 != body_len {
                    return Err((24, format!("the body is {} bytes, not {body_len}", b.len())));
                }
                b
            }
            0 | 1 => return Err((16, format!("states a body of {body_len} bytes"))),
            c => return Err((12, format!("compression {c} (0 or 1)"))),
        };
        let mut r = Reader { b: &body, at: 0 };
        let files = r.u32()? as usize;
        if files > body.len() / 4 + 1 {
            return Err((
                0,
                format!("{files} files in a body of {} bytes", body.len()),
            ));
        }
        let files: Vec<String> = (0..files).map(|_| r.string()).collect::<Result<_, _>>()?;
        if count > body.len() / 72 {
            return Err((
                0,
                format!("{count} objects in a body of {} bytes", body.len()),
            ));
        }
        let mut objects = Vec::with_capacity(count);
        for i in 0..count {
            let at = r.at as u64;
            let file = r.u32()? as usize;
            let file = files.get(file).cloned().ok_or((
                at,
                format!("object {i} names file {file} of {}", files.len()),
            ))?;
            let name = r.string()?;
            let path = r.string()?;
            let metadata = r.optional_string()?;
            if let Some(m) = &metadata {
                if serde_json::from_str::<serde_json::Value>(m).is_err() {
                    return Err((at, format!("object {i}'s metadata is not JSON")));
                }
            }
            let triangles = r.u64()?;
            let min = r.dvec3()?;
            let max = r.dvec3()?;
            if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
                return Err((at, format!("object {i} has box {min} .. {max}")));
            }
            objects.push(ObjectRecord {
                name,
                path,
                file,
                metadata,
                bounds: Aabb { min, max },
                triangles,
            });
        }
        let mut lods: Vec<(u32, Range<usize>)> = Vec::with_capacity(lod_count.min(body.len() / 8));
        let mut runs = Vec::new();
        for _ in 0..lod_count {
            let at = r.at as u64;
            let lod = r.u32()?;
            if lods.last().is_some_and(|(l, _)| *l >= lod) {
                return Err((at, format!("LOD {lod}'s runs are out of order")));
            }
            let n = r.u32()? as usize;
            if n == 0 || n > (body.len() - r.at) / 8 {
                return Err((at, format!("LOD {lod} has {n} runs")));
            }
            let start = runs.len();
            for _ in 0..n {
                let object = r.u32()?;
                let triangles = r.u32()?;
                if object as usize >= count || triangles == 0 {
                    return Err((
                        at,
                        format!("LOD {lod}: a run of {triangles} triangles of object {object} ({count} objects)"),
                    ));
                }
                runs.push(ObjectRun { object, triangles });
            }
            lods.push((lod, start..runs.len()));
        }
        if r.at != body.len() {
            return Err((
                r.at as u64,
                format!("{} bytes after the last run", body.len() - r.at),
            ));
        }
        Ok(ObjectTable {
            objects,
            runs,
            lods,
        })
    }

    /// Checks the runs against `skeleton`: each names a leaf's finest LOD
    /// and covers its triangles exactly.
    pub fn check(&self, skeleton: &Skeleton) -> Result<(), String> {
        let lods = skeleton.lods();
        for (lod, r) in self.lod_runs() {
            let Some(info) = lods.get(lod as usize) else {
                return Err(format!("runs of LOD {lod}, of {} LODs", lods.len()));
            };
            let node = skeleton.node(skeleton.owner(lod));
            if !node.is_leaf() || node.first_lod != lod {
                return Err(format!("runs of LOD {lod}, not a leaf's finest"));
            }
            let sum: u64 = r.iter().map(|r| r.triangles as u64).sum();
            if sum != info.triangles as u64 {
                return Err(format!(
                    "LOD {lod}'s runs cover {sum} triangles of {}",
                    info.triangles
                ));
            }
        }
        Ok(())
    }
}

fn put_str(p: &mut Put, s: &str) {
    p.u32(s.len() as u32);
    p.bytes(s.as_bytes());
}

/// Bounds-checked reads from a decompressed body.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], (u64, String)> {
        if n > self.b.len() - self.at {
            return Err((
                self.at as u64,
                format!("ends after {} bytes, inside a record", self.b.len()),
            ));
        }
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, (u64, String)> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or_default(),
        ))
    }
    fn u64(&mut self) -> Result<u64, (u64, String)> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or_default(),
        ))
    }
    fn dvec3(&mut self) -> Result<DVec3, (u64, String)> {
        let b = self.take(24)?;
        let f = |i: usize| f64::from_le_bytes(b[8 * i..8 * i + 8].try_into().unwrap_or_default());
        Ok(DVec3::new(f(0), f(1), f(2)))
    }
    fn string(&mut self) -> Result<String, (u64, String)> {
        let at = self.at as u64;
        let n = self.u32()? as usize;
        let s = self.take(n)?;
        String::from_utf8(s.to_vec()).map_err(|_| (at, "a name that is not UTF-8".to_string()))
    }
    fn optional_string(&mut self) -> Result<Option<String>, (u64, String)> {
        let save = self.at;
        if self.u32()? == u32::MAX {
            return Ok(None);
        }
        self.at = save;
        self.string().map(Some)
    }
}

/// What `find`, `--hide` and the viewer's search match objects by:
/// case-insensitive, against an object's name and its path in its file,
/// and when the pattern holds a `/`, also `file/path`; with `*` (any run
/// of characters) or `?` (any one) the whole string must match, else the
/// pattern need only appear in it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pattern {
    text: Vec<char>,
    glob: bool,
}

impl Pattern {
    /// A pattern; an empty one is an error (it would match everything).
    pub fn new(pattern: &str) -> Result<Pattern, String> {
        let p = pattern.trim();
        if p.is_empty() {
            return Err("an empty pattern matches every object; say which".into());
        }
        Ok(Pattern {
            text: p.to_lowercase().chars().collect(),
            glob: p.contains(['*', '?']),
        })
    }

    pub fn as_string(&self) -> String {
        self.text.iter().collect()
    }

    pub fn matches(&self, o: &ObjectRecord) -> bool {
        if self.matches_str(&o.name) || self.matches_str(&o.path) {
            return true;
        }
        // The file only when the pattern names one: `unit2.glb/`.
        self.text.contains(&'/') && self.matches_str(&o.full_path())
    }

    fn matches_str(&self, s: &str) -> bool {
        let s: Vec<char> = s.to_lowercase().chars().collect();
        if self.glob {
            glob(&self.text, &s)
        } else {
            s.windows(self.text.len())
                .any(|w| w == self.text.as_slice())
        }
    }
}

/// Whole-string glob match of `p` (`*`, `?`) against `s`, by the usual
/// greedy backtracking (linear in practice, quadratic at worst).
fn glob(p: &[char], s: &[char]) -> bool {
    let (mut pi, mut si) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while si < s.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == s[si]) {
            pi += 1;
            si += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some((pi, si));
            pi += 1;
        } else if let Some((sp, ss)) = star {
            pi = sp + 1;
            si = ss + 1;
            star = Some((sp, ss + 1));
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

impl<R: ReadAt> SceneReader<R> {
    /// The scene's object identity; `None` only when the table of contents
    /// lists no OBJT section (a scene written before it existed). A stored
    /// section that fails its checksum, its checks, or does not fit the
    /// skeleton is an error naming the file and OBJT.
    pub fn objects(&self) -> Result<Option<ObjectTable>, ReadError> {
        let skeleton = self.skeleton();
        self.decode_optional(TAG_OBJECTS, |b| {
            let t = ObjectTable::decode(b)?;
            t.check(skeleton).map_err(|e| (0, e))?;
            Ok(t)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(name: &str, path: &str, file: &str) -> ObjectRecord {
        ObjectRecord {
            name: name.into(),
            path: path.into(),
            file: file.into(),
            metadata: Some(r#"{"tag":"P-101"}"#.into()),
            bounds: Aabb {
                min: DVec3::new(1e7, 0.0, -1.0),
                max: DVec3::new(1e7 + 1.0, 2.0, 0.5),
            },
            triangles: 12,
        }
    }

    fn table() -> ObjectTable {
        ObjectTable::new(
            vec![
                record("Pipe.003", "Plant/Area1/Pipe.003", "a.glb"),
                record("Valve", "Plant/Valve", "b.glb"),
                record("Pump", "pump", ""),
            ],
            vec![
                (
                    3,
                    vec![
                        ObjectRun {
                            object: 0,
                            triangles: 5,
                        },
                        ObjectRun {
                            object: 2,
                            triangles: 7,
                        },
                    ],
                ),
                (
                    9,
                    vec![ObjectRun {
                        object: 1,
                        triangles: 4,
                    }],
                ),
            ],
        )
    }

    #[test]
    fn the_table_round_trips_and_every_truncation_is_an_error() {
        let t = table();
        // Compressed as the writer does (a zstd frame: a flipped byte
        // fails its checksum).
        let bytes = t.encode_with(|b| zstd::bulk::compress(b, 19).ok());
        assert_eq!(ObjectTable::decode(&bytes).unwrap(), t);
        for n in 0..bytes.len() {
            assert!(ObjectTable::decode(&bytes[..n]).is_err(), "{n} bytes");
        }
        let mut flipped = bytes.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 0x40;
        assert!(ObjectTable::decode(&flipped).is_err());
        // Any byte of the stored (uncompressed) form changed: decoded or
        // refused, never a panic.
        let body = {
            let mut t = t.clone();
            t.objects[0].name = "x".repeat(3);
            t
        };
        let raw = {
            let mut b = body.encode();
            // Stored: compression flag 0, the body as is.
            if b[12..16] == 1u32.to_le_bytes() {
                let len = u64::from_le_bytes(b[16..24].try_into().unwrap()) as usize;
                let plain = zstd::bulk::decompress(&b[24..], len).unwrap();
                b.truncate(24);
                b[12..16].copy_from_slice(&0u32.to_le_bytes());
                b.extend_from_slice(&plain);
            }
            b
        };
        assert_eq!(ObjectTable::decode(&raw).unwrap(), body);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..4000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let mut m = raw.clone();
            let at = (seed % m.len() as u64) as usize;
            m[at] = m[at].wrapping_add((seed >> 32) as u8 | 1);
            let _ = ObjectTable::decode(&m);
        }
    }

    /// A compressed body (one zstd frame, as the writer makes it) decodes
    /// to the same table; a cut is refused.
    #[test]
    fn a_compressed_table_decodes_whole_and_a_cut_is_refused() {
        let objects: Vec<ObjectRecord> = (0..2000)
            .map(|i| {
                record(
                    &format!("Part.{i:05}"),
                    &format!("Plant/Part.{i:05}"),
                    "p.glb",
                )
            })
            .collect();
        let t = ObjectTable::new(objects, Vec::new());
        let packed = t.encode_with(|b| zstd::bulk::compress(b, 3).ok());
        assert!(packed.len() < t.encode().len() / 2);
        assert_eq!(ObjectTable::decode(&packed).unwrap(), t);
        for cut in [packed.len() / 3, packed.len() - 1] {
            assert!(ObjectTable::decode(&packed[..cut]).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn runs_say_which_object_each_triangle_belongs_to() {
        let t = table();
        assert_eq!(t.object_of_triangle(3, 0), Some(0));
        assert_eq!(t.object_of_triangle(3, 4), Some(0));
        assert_eq!(t.object_of_triangle(3, 5), Some(2));
        assert_eq!(t.object_of_triangle(3, 11), Some(2));
        assert_eq!(t.object_of_triangle(3, 12), None);
        assert_eq!(t.object_of_triangle(4, 0), None);
        assert_eq!(t.runs(9).unwrap().len(), 1);
    }

    #[test]
    fn patterns_match_names_paths_and_files_without_case() {
        let t = table();
        let find = |p: &str| t.find(&Pattern::new(p).unwrap());
        assert_eq!(find("pipe"), vec![0]);
        assert_eq!(find("PLANT/"), vec![0, 1]);
        assert_eq!(find("b.glb/"), vec![1]);
        assert!(find("b.glb").is_empty(), "a file only with a slash");
        assert_eq!(find("*.003"), vec![0]);
        assert_eq!(find("p?mp"), vec![2]);
        assert_eq!(find("a.glb/*"), vec![0]);
        assert_eq!(find("*"), vec![0, 1, 2]);
        assert!(find("nothing").is_empty());
        assert!(Pattern::new("  ").is_err());
    }
}
