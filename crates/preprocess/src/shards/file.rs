//! Shard files: one shard's nodes' LODs, written as they are made, then
//! an index of where each node's lie and what the shard's roots leave for
//! their parents, checksummed, written atomically and named by the plan's
//! id. Read back, every byte is checked against the checksum and the plan
//! before the merge takes a level from it; a corrupt or foreign file is an
//! error, never a panic.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use gigawalk_scene::{Colours, LodMesh};
use glam::DVec3;

use super::{io, Plan, ShardError};
use crate::hlod::{Lod, WorkMesh};
use crate::Done;

const SHARD_MAGIC: &[u8; 8] = b"GWSHARD3";

/// Where shard `index`'s output goes.
pub fn shard_path(dir: &Path, plan: &Plan, index: usize) -> PathBuf {
    dir.join(format!("shard-{index:05}-{}.bin", plan.id))
}

/// Writes a shard file as its nodes' LODs come (only one node's are held),
/// then the index of where each node's lie and the roots' [`Done`]:
///
/// - header: [`SHARD_MAGIC`], the plan id, the shard index (u32), the
///   node count (u32);
/// - per node, in the order they were made: its LOD count (u32), then
///   per LOD the length of its compressed bytes (u32), the length they
///   decompress to (u32), and those bytes: its error (f32) and mesh,
///   zstd-compressed (level [`SHARD_ZSTD_LEVEL`]) on the thread that
///   made the LOD, about a third of the raw bytes (which at 500M
///   triangles were 44 GB of shards);
/// - the trailer: the node count again, per node its index (u32) and
///   the byte range of its LODs (two u64); the root count, per root its
///   index, its levels (count, then error and mesh each) and its full
///   detail (flag u8, then the mesh);
/// - where the trailer starts (u64), and the CRC-32 of every byte before.
///
/// Written to a temporary file and renamed into place when whole.
pub(super) struct ShardWriter {
    path: PathBuf,
    out: std::io::BufWriter<gigawalk_scene::TempFile>,
    crc: crc32fast::Hasher,
    pos: u64,
    /// The current node's LODs, encoded.
    node: Put,
    count: usize,
    index: Put,
    nodes: u64,
}

impl ShardWriter {
    pub(super) fn create(
        path: &Path,
        plan: &Plan,
        index: usize,
        nodes: u64,
    ) -> Result<Self, ShardError> {
        let tmp = gigawalk_scene::temp_file_for(path).map_err(io(path))?;
        let mut w = ShardWriter {
            path: path.to_path_buf(),
            out: std::io::BufWriter::with_capacity(1 << 20, tmp),
            crc: crc32fast::Hasher::new(),
            pos: 0,
            node: Put(Vec::new()),
            count: 0,
            index: Put(Vec::new()),
            nodes: 0,
        };
        let mut h = Put(Vec::new());
        h.0.extend_from_slice(SHARD_MAGIC);
        h.0.extend_from_slice(plan.id.as_bytes());
        h.len(index);
        h.len(nodes as usize);
        w.write(&h.0).map_err(io(path))?;
        w.index.len(nodes as usize);
        Ok(w)
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        use std::io::Write as _;
        self.out.write_all(bytes)?;
        self.crc.update(bytes);
        self.pos += bytes.len() as u64;
        Ok(())
    }

    /// The trailer and checksum, then the rename into place.
    pub(super) fn finish(mut self, roots: &[(u32, Done)]) -> Result<(), ShardError> {
        let path = self.path.clone();
        let trailer_at = self.pos;
        let mut t = std::mem::replace(&mut self.index, Put(Vec::new()));
        t.len(roots.len());
        for (ni, d) in roots {
            t.u32(*ni);
            t.len(d.levels.len());
            for l in &d.levels {
                t.f32(l.error);
                t.work_mesh(&l.mesh);
            }
            match &d.full {
                None => t.u8(0),
                Some(m) => {
                    t.u8(1);
                    t.work_mesh(m);
                }
            }
        }
        t.0.extend_from_slice(&trailer_at.to_le_bytes());
        self.write(&t.0).map_err(io(&path))?;
        let crc = self.crc.clone().finalize();
        self.write(&crc.to_le_bytes()).map_err(io(&path))?;
        let tmp = self
            .out
            .into_inner()
            .map_err(|e| io(&path)(e.into_error()))?;
        tmp.as_file().sync_all().map_err(io(&path))?;
        tmp.persist(&path).map_err(io(&path))
    }
}

impl crate::LodSink for ShardWriter {
    type Error = ShardError;
    /// The LOD as the shard file stores it.
    type Prepared = Vec<u8>;
    fn preparer(&self) -> Box<dyn Fn(&LodMesh, f32, &[u32]) -> Vec<u8> + Send + Sync> {
        Box::new(|mesh, error, _| {
            let mut p = Put(Vec::new());
            p.f32(error);
            p.lod_mesh(mesh);
            let packed = zstd::bulk::compress(&p.0, SHARD_ZSTD_LEVEL)
                .expect("zstd compresses any bytes in memory at a valid level");
            let mut out = Put(Vec::with_capacity(packed.len() + 8));
            out.len(packed.len());
            out.len(p.0.len());
            out.0.extend_from_slice(&packed);
            out.0
        })
    }
    fn add_prepared(&mut self, lod: Vec<u8>) -> Result<u32, ShardError> {
        self.node.0.extend_from_slice(&lod);
        self.count += 1;
        Ok(0)
    }
    fn node_done(&mut self, node: u32) -> Result<(), ShardError> {
        let start = self.pos;
        let mut c = Put(Vec::new());
        c.len(self.count);
        let body = std::mem::replace(&mut self.node, Put(Vec::new()));
        let path = self.path.clone();
        self.write(&c.0).map_err(io(&path))?;
        self.write(&body.0).map_err(io(&path))?;
        self.index.u32(node);
        self.index.0.extend_from_slice(&start.to_le_bytes());
        self.index.0.extend_from_slice(&self.pos.to_le_bytes());
        self.count = 0;
        self.nodes += 1;
        Ok(())
    }
}
/// zstd's level for a shard's LODs: fast, as they are written once and
/// read once.
const SHARD_ZSTD_LEVEL: i32 = 1;

/// Most raw bytes a shard's LOD may claim (a corrupt length is refused
/// before anything is allocated for it).
const MAX_LOD_BYTES: usize = 1 << 31;

struct Put(Vec<u8>);

impl Put {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn len(&mut self, n: usize) {
        self.u32(u32::try_from(n).expect("a shard's arrays fit in u32"));
    }
    fn dvec3(&mut self, v: DVec3) {
        self.f64(v.x);
        self.f64(v.y);
        self.f64(v.z);
    }
    fn vec3s(&mut self, v: &[[f32; 3]]) {
        self.len(v.len());
        for p in v {
            p.iter().for_each(|&x| self.f32(x));
        }
    }
    fn rgba(&mut self, v: &[[u8; 4]]) {
        self.len(v.len());
        for c in v {
            self.0.extend_from_slice(c);
        }
    }
    fn u32s(&mut self, v: &[u32]) {
        self.len(v.len());
        v.iter().for_each(|&x| self.u32(x));
    }
    fn lod_mesh(&mut self, m: &LodMesh) {
        self.dvec3(m.origin);
        self.vec3s(&m.positions);
        self.vec3s(&m.normals);
        match &m.colours {
            Colours::Uniform(c) => {
                self.u8(0);
                self.0.extend_from_slice(c);
            }
            Colours::PerVertex(v) => {
                self.u8(1);
                self.rgba(v);
            }
        }
        self.u32s(&m.indices);
    }
    fn work_mesh(&mut self, m: &WorkMesh) {
        self.dvec3(m.origin);
        self.vec3s(&m.positions);
        self.vec3s(&m.normals);
        self.rgba(&m.colours);
        self.u32s(&m.indices);
    }
}

/// A bounds-checked reader; every failure is a message, never a panic.
struct Get<'a> {
    b: &'a [u8],
}

type R<T> = Result<T, String>;

impl<'a> Get<'a> {
    fn take(&mut self, n: usize) -> R<&'a [u8]> {
        if n > self.b.len() {
            return Err(format!(
                "ends early ({n} bytes wanted, {} left)",
                self.b.len()
            ));
        }
        let (h, t) = self.b.split_at(n);
        self.b = t;
        Ok(h)
    }
    fn u8(&mut self) -> R<u8> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> R<u32> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().map_err(|_| "u32")?,
        ))
    }
    fn f32(&mut self) -> R<f32> {
        Ok(f32::from_le_bytes(
            self.take(4)?.try_into().map_err(|_| "f32")?,
        ))
    }
    fn f64(&mut self) -> R<f64> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().map_err(|_| "f64")?,
        ))
    }
    fn u64(&mut self) -> R<u64> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().map_err(|_| "u64")?,
        ))
    }
    /// A length, checked against the bytes left (`each` bytes an item).
    fn len(&mut self, each: usize) -> R<usize> {
        let n = self.u32()? as usize;
        if n.saturating_mul(each) > self.b.len() {
            return Err(format!("an array of {n} items runs past the end"));
        }
        Ok(n)
    }
    fn dvec3(&mut self) -> R<DVec3> {
        Ok(DVec3::new(self.f64()?, self.f64()?, self.f64()?))
    }
    fn vec3s(&mut self) -> R<Vec<[f32; 3]>> {
        let n = self.len(12)?;
        (0..n)
            .map(|_| Ok([self.f32()?, self.f32()?, self.f32()?]))
            .collect()
    }
    fn rgba(&mut self) -> R<Vec<[u8; 4]>> {
        let n = self.len(4)?;
        (0..n)
            .map(|_| Ok(self.take(4)?.try_into().map_err(|_| "rgba")?))
            .collect()
    }
    fn u32s(&mut self) -> R<Vec<u32>> {
        let n = self.len(4)?;
        (0..n).map(|_| self.u32()).collect()
    }
    fn lod_mesh(&mut self) -> R<LodMesh> {
        let origin = self.dvec3()?;
        let positions = self.vec3s()?;
        let normals = self.vec3s()?;
        let colours = match self.u8()? {
            0 => Colours::Uniform(self.take(4)?.try_into().map_err(|_| "rgba")?),
            1 => Colours::PerVertex(self.rgba()?),
            k => return Err(format!("colour kind {k}")),
        };
        let indices = self.u32s()?;
        check_mesh(positions.len(), normals.len(), &indices)?;
        Ok(LodMesh {
            origin,
            positions,
            normals,
            colours,
            indices,
        })
    }
    /// One node's LODs, as `Put::node_lods` wrote them.
    fn node_lods(&mut self) -> R<Vec<(LodMesh, f32)>> {
        let n = self.len(8)?;
        (0..n)
            .map(|_| {
                let packed = self.len(1)?;
                let raw = self.u32()? as usize;
                if raw > MAX_LOD_BYTES {
                    return Err(format!("a LOD of {raw} bytes"));
                }
                let bytes = zstd::bulk::decompress(self.take(packed)?, raw)
                    .map_err(|e| format!("a LOD does not decompress: {e}"))?;
                if bytes.len() != raw {
                    return Err("a LOD decompresses to another length".into());
                }
                let mut g = Get { b: &bytes };
                let e = g.f32()?;
                let m = g.lod_mesh()?;
                if !g.b.is_empty() {
                    return Err("a LOD's bytes run past its mesh".into());
                }
                Ok((m, e))
            })
            .collect()
    }
    fn work_mesh(&mut self) -> R<WorkMesh> {
        let origin = self.dvec3()?;
        let positions = self.vec3s()?;
        let normals = self.vec3s()?;
        let colours = self.rgba()?;
        let indices = self.u32s()?;
        check_mesh(positions.len(), normals.len(), &indices)?;
        if colours.len() != positions.len() {
            return Err("colours and positions differ in number".into());
        }
        Ok(WorkMesh {
            origin,
            positions,
            normals,
            colours,
            indices,
        })
    }
}

fn check_mesh(positions: usize, normals: usize, indices: &[u32]) -> R<()> {
    if normals != positions {
        return Err("normals and positions differ in number".into());
    }
    if !indices.len().is_multiple_of(3) || indices.iter().any(|&i| i as usize >= positions) {
        return Err("indices out of range".into());
    }
    Ok(())
}

/// Where each node's LODs lie in a shard file, and its roots' [`Done`].
type ShardIndex = (HashMap<u32, std::ops::Range<usize>>, HashMap<u32, Done>);

/// Shard `index`'s output at `path`, checked against the plan (every byte
/// read, a piece at a time, and its checksum verified; only the trailer is
/// kept); the open file, for reading the LODs again where the index says.
pub(super) fn read_shard(
    path: &Path,
    plan: &Plan,
    index: usize,
) -> Result<(std::fs::File, ShardIndex), ShardError> {
    use std::io::Read as _;
    use std::os::unix::fs::FileExt as _;
    let corrupt = |reason: String| ShardError::Corrupt {
        path: path.to_path_buf(),
        reason,
    };
    let file = std::fs::File::open(path).map_err(io(path))?;
    let len = file.metadata().map_err(io(path))?.len();
    if len < 12 {
        return Err(corrupt("too short".into()));
    }
    let mut crc = crc32fast::Hasher::new();
    let mut left = len - 4;
    let mut r = std::io::BufReader::with_capacity(1 << 20, &file);
    let mut buf = vec![0u8; 1 << 20];
    while left > 0 {
        let n = left.min(buf.len() as u64) as usize;
        r.read_exact(&mut buf[..n]).map_err(io(path))?;
        crc.update(&buf[..n]);
        left -= n as u64;
    }
    let mut tail = [0u8; 12];
    file.read_exact_at(&mut tail, len - 12).map_err(io(path))?;
    if crc.finalize() != u32::from_le_bytes([tail[8], tail[9], tail[10], tail[11]]) {
        return Err(corrupt("checksum mismatch".into()));
    }
    let trailer_at = u64::from_le_bytes(tail[..8].try_into().map_err(|_| corrupt("u64".into()))?);
    let head_len = SHARD_MAGIC.len() + plan.id.len() + 8;
    if trailer_at < head_len as u64 || trailer_at > len - 12 {
        return Err(corrupt(format!(
            "trailer at {trailer_at}, the file has {len} bytes"
        )));
    }
    let mut head = vec![0u8; head_len];
    file.read_exact_at(&mut head, 0).map_err(io(path))?;
    let mut trailer = vec![0u8; (len - 12 - trailer_at) as usize];
    file.read_exact_at(&mut trailer, trailer_at)
        .map_err(io(path))?;
    let index = decode_shard(&head, &trailer, trailer_at, plan, index).map_err(corrupt)?;
    Ok((file, index))
}

/// One node's LODs from a shard file checked by [`read_shard`], at the
/// range its index gave. The file is opened for the read (any number of
/// threads read at once, and no handle is held between nodes).
pub(crate) fn read_node_lods(
    path: &Path,
    range: std::ops::Range<usize>,
) -> Result<Vec<(LodMesh, f32)>, String> {
    use std::os::unix::fs::FileExt as _;
    let mut bytes = vec![0u8; range.len()];
    std::fs::File::open(path)
        .and_then(|f| f.read_exact_at(&mut bytes, range.start as u64))
        .map_err(|e| format!("cannot read {} again: {e}", path.display()))?;
    let mut g = Get { b: &bytes };
    let lods = g.node_lods()?;
    if !g.b.is_empty() {
        return Err("a node's LODs do not fill their range".into());
    }
    Ok(lods)
}

/// A shard file's header and trailer (at `trailer_at`), checked against
/// the plan: where each node's LODs lie, and the roots' [`Done`].
fn decode_shard(
    head: &[u8],
    trailer: &[u8],
    trailer_at: u64,
    plan: &Plan,
    index: usize,
) -> R<ShardIndex> {
    let mut g = Get { b: head };
    if g.take(SHARD_MAGIC.len())? != SHARD_MAGIC {
        return Err("not a shard file".into());
    }
    if g.take(plan.id.len())? != plan.id.as_bytes() {
        return Err("made for another plan".into());
    }
    if g.u32()? as usize != index {
        return Err(format!("not shard {index}'s"));
    }
    let spec = plan.shards.get(index).ok_or("no such shard in the plan")?;
    let nodes = g.u32()? as u64;
    let mut g = Get { b: trailer };
    if nodes != spec.nodes || g.u32()? as u64 != nodes {
        return Err(format!("{nodes} nodes, the plan says {}", spec.nodes));
    }
    let mut lods = HashMap::with_capacity(nodes as usize);
    let mut at = head.len() as u64;
    for _ in 0..nodes {
        let ni = g.u32()?;
        let (start, end) = (g.u64()?, g.u64()?);
        // Nodes lie one after another, up to the trailer.
        if start != at || end < start.saturating_add(4) || end > trailer_at {
            return Err(format!("node {ni}'s LODs at {start}..{end}"));
        }
        at = end;
        if lods.insert(ni, start as usize..end as usize).is_some() {
            return Err(format!("node {ni} twice"));
        }
    }
    if at != trailer_at {
        return Err("the nodes' LODs do not reach the trailer".into());
    }
    let roots = g.len(9)?;
    let mut done = HashMap::with_capacity(roots);
    for _ in 0..roots {
        let ni = g.u32()?;
        let n = g.len(8)?;
        let levels = (0..n)
            .map(|_| {
                let error = g.f32()?;
                Ok(Lod {
                    mesh: g.work_mesh()?,
                    error,
                })
            })
            .collect::<R<Vec<_>>>()?;
        let full = match g.u8()? {
            0 => None,
            1 => Some(g.work_mesh()?),
            k => return Err(format!("full-detail flag {k}")),
        };
        done.insert(ni, Done { levels, full });
    }
    if !g.b.is_empty()
        || spec.roots.iter().any(|r| !done.contains_key(r))
        || done.len() != spec.roots.len()
    {
        return Err("its roots are not the plan's".into());
    }
    Ok((lods, done))
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::shards::plan::{FORMAT, PLAN_VERSION};
    use crate::shards::ShardSpec;
    use crate::{Params, REVISION};

    #[test]
    fn a_shard_file_round_trips_and_every_flipped_byte_is_caught() {
        let mesh = WorkMesh {
            origin: DVec3::new(1e7, -2.5, 0.125),
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, f32::MIN_POSITIVE],
            ],
            normals: vec![[0.0, 0.0, 1.0]; 3],
            colours: vec![[1, 2, 3, 255]; 3],
            indices: vec![0, 1, 2],
        };
        let plan = Plan {
            format: FORMAT.into(),
            version: PLAN_VERSION,
            revision: REVISION,
            id: "0123456789abcdef0123456789abcdef".into(),
            source: "m.glb".into(),
            inputs: Vec::new(),
            params: Params::default(),
            shard_triangles: 10,
            nodes: 3,
            triangles: 2,
            shards: vec![ShardSpec {
                index: 0,
                roots: vec![1],
                nodes: 2,
                triangles: 2,
            }],
        };
        let lods: Vec<(u32, Vec<(LodMesh, f32)>)> = vec![
            (
                1,
                vec![(mesh.to_lod_mesh(), 0.5), (mesh.to_lod_mesh(), 1.5)],
            ),
            (2, vec![]),
        ];
        let done = vec![(
            1,
            Done {
                levels: vec![Lod {
                    mesh: mesh.clone(),
                    error: 0.25,
                }],
                full: Some(mesh.clone()),
            },
        )];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.bin");
        let mut w = ShardWriter::create(&path, &plan, 0, 2).unwrap();
        for (ni, l) in &lods {
            for (m, e) in l {
                crate::LodSink::add_lod(&mut w, m, *e).unwrap();
            }
            crate::LodSink::node_done(&mut w, *ni).unwrap();
        }
        w.finish(&done).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let (_, (l, d)) = read_shard(&path, &plan, 0).unwrap();
        assert_eq!(read_node_lods(&path, l[&1].clone()).unwrap(), lods[0].1);
        assert!(read_node_lods(&path, l[&2].clone()).unwrap().is_empty());
        assert!(read_node_lods(&path, l[&1].start..l[&1].end - 1).is_err());
        let gone = dir.path().join("gone.bin");
        let e = read_node_lods(&gone, l[&1].clone()).unwrap_err();
        assert!(e.contains("gone.bin"), "{e}");
        assert_eq!(d[&1], done[0].1);
        let check = |b: &[u8], plan: &Plan, index: usize| {
            std::fs::write(dir.path().join("t.bin"), b).unwrap();
            read_shard(&dir.path().join("t.bin"), plan, index).map(|_| ())
        };
        for i in (0..bytes.len()).step_by(7) {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            assert!(check(&b, &plan, 0).is_err(), "byte {i}");
        }
        for cut in [0, 11, bytes.len() / 2, bytes.len() - 1] {
            assert!(check(&bytes[..cut], &plan, 0).is_err(), "cut at {cut}");
        }
        assert!(check(&bytes, &plan, 1).is_err());
        let other = Plan {
            id: "ffffffffffffffffffffffffffffffff".into(),
            ..plan.clone()
        };
        assert!(check(&bytes, &other, 0).is_err());
    }
}
