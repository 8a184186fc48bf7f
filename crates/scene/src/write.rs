//! The scene file writer: geometry is streamed to a temporary file as LODs
//! are added, the skeleton is written and validated at the end, and only
//! then is the file renamed into place, so an interrupted or failed write
//! never leaves a file that looks valid.

use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use glam::{DVec3, Vec3};

use crate::error::WriteError;
use crate::format::{self, Header, Put, TocEntry};
use crate::mesh::encode_normal;
use crate::validate::{validate, Layout};
use crate::{Aabb, Colours, IndexFormat, LodInfo, LodMesh, Node, Provenance, Skeleton};

/// What [`SceneWriter::finish`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct WriteSummary {
    pub bytes: u64,
    pub nodes: usize,
    pub lods: usize,
    /// Bytes of each section, by tag, in file order.
    pub sections: Vec<(String, u64)>,
}

/// Writes a `.gwk` scene file. See the crate docs for the order of calls.
pub struct SceneWriter {
    path: PathBuf,
    out: BufWriter<crate::TempFile>,
    pos: u64,
    geometry_crc: crc32fast::Hasher,
    lods: Vec<LodInfo>,
    /// World bounds of each LOD's geometry exactly as stored.
    lod_bounds: Vec<Aabb>,
    /// How far quantization moved each LOD's vertices at most (0: raw).
    moved: Vec<f64>,
    /// Optional sections to write after the v1 ones.
    optional: Vec<([u8; 4], Vec<u8>)>,
    /// Bits of the position grid of each LOD (`None`: raw f32).
    position_bits: Option<u8>,
    /// Bits of each octahedral normal coordinate in encoded LODs.
    normal_bits: u8,
    /// zstd over encoded blobs.
    squeeze: Squeeze,
    /// The trained compressor's settings, for [`LodEncoder`]s on other
    /// threads, once trained.
    trained: Arc<OnceLock<Trained>>,
}

/// What a [`LodEncoder`] compresses with: the writer's dictionary (none:
/// each blob alone), and an id unique in the process.
struct Trained {
    id: u64,
    dictionary: Option<Vec<u8>>,
}

/// Encodes LODs for one [`SceneWriter`] on any thread
/// ([`SceneWriter::encoder`]): checked, re-centred, quantized and
/// meshopt-encoded with the writer's settings, and compressed once the
/// writer's dictionary is trained. [`SceneWriter::add_encoded`] stores
/// the result exactly as [`SceneWriter::add_lod_in_runs`] would have, so
/// a file is the same bytes whichever thread encoded what.
#[derive(Clone)]
pub struct LodEncoder {
    position_bits: Option<u8>,
    normal_bits: u8,
    trained: Arc<OnceLock<Trained>>,
}

/// One LOD as [`LodEncoder::encode`] left it, for [`SceneWriter::add_encoded`].
pub struct EncodedLod(Result<Encoded, String>);

struct Encoded {
    info: LodInfo,
    bounds: Aabb,
    blob: Vec<u8>,
    moved: f64,
    /// The blob compressed with the dictionary of this id.
    squeezed: Option<(u64, Vec<u8>)>,
}

impl LodEncoder {
    /// [`SceneWriter::add_lod_in_runs`]'s work, short of storing: `runs`
    /// as there. An invalid mesh is reported when the result is added.
    pub fn encode(&self, mesh: &LodMesh, error: f32, runs: &[u32]) -> EncodedLod {
        EncodedLod(
            encode_lod(mesh, error, self.position_bits, self.normal_bits, runs).map(
                |(info, bounds, blob, moved)| {
                    let squeezed = match self.trained.get() {
                        Some(t) if info.encoded => {
                            crate::squeeze::compress_with(t.id, t.dictionary.as_deref(), &blob)
                                .ok()
                                .map(|b| (t.id, b))
                        }
                        _ => None,
                    };
                    Encoded {
                        info,
                        bounds,
                        blob,
                        moved,
                        squeezed,
                    }
                },
            ),
        )
    }
}

/// Where the writer's zstd stage stands.
enum Squeeze {
    Off,
    /// Encoded blobs held back (LOD, bytes) until there are enough to
    /// train the dictionary on.
    Sampling {
        pending: Vec<(u32, Vec<u8>)>,
        bytes: usize,
    },
    /// Trained; `active` while new blobs are compressed (the dictionary
    /// is written at the end either way: earlier blobs need it).
    On {
        squeezer: crate::squeeze::Squeezer,
        active: bool,
    },
}

/// Position bits a writer uses unless told otherwise: steps of 1/65535 of
/// a LOD's box, as gltfpack's default quantization.
pub const DEFAULT_POSITION_BITS: u8 = 16;

impl SceneWriter {
    /// Adds an optional section (a reader that does not know `tag` skips
    /// it), written by [`SceneWriter::finish`] after the v1 sections.
    pub fn add_optional_section(&mut self, tag: [u8; 4], bytes: Vec<u8>) {
        self.optional.push((tag, bytes));
    }

    /// Creates a temporary file beside `path`; nothing at `path` changes
    /// until [`SceneWriter::finish`] succeeds. Dropping the writer before
    /// that removes the temporary file.
    pub fn create(path: &Path) -> Result<SceneWriter, WriteError> {
        let io_err = |source| WriteError::Io {
            path: path.display().to_string(),
            source,
        };
        let tmp = crate::temp_file_for(path).map_err(io_err)?;
        let mut out = BufWriter::with_capacity(1 << 20, tmp);
        // The header is written last, when the TOC's place is known.
        out.write_all(&[0u8; format::HEADER_LEN]).map_err(io_err)?;
        Ok(SceneWriter {
            path: path.to_path_buf(),
            out,
            pos: format::HEADER_LEN as u64,
            geometry_crc: crc32fast::Hasher::new(),
            lods: Vec::new(),
            lod_bounds: Vec::new(),
            moved: Vec::new(),
            optional: Vec::new(),
            position_bits: Some(DEFAULT_POSITION_BITS),
            normal_bits: 16,
            squeeze: Squeeze::Off,
            trained: Arc::new(OnceLock::new()),
        })
    }

    /// An encoder with this writer's settings (those set so far: set
    /// them first) for other threads.
    pub fn encoder(&self) -> LodEncoder {
        LodEncoder {
            position_bits: self.position_bits,
            normal_bits: self.normal_bits,
            trained: self.trained.clone(),
        }
    }

    /// Compresses the encoded blobs of LODs added after this with zstd,
    /// with a dictionary trained on the first few MB of them (stored
    /// once, in the ZDIC section), where that makes a blob smaller; off
    /// by default. Raw LODs are never compressed.
    pub fn set_compression(&mut self, on: bool) -> Result<(), WriteError> {
        match (&mut self.squeeze, on) {
            (Squeeze::Off, true) => {
                self.squeeze = Squeeze::Sampling {
                    pending: Vec::new(),
                    bytes: 0,
                }
            }
            (Squeeze::On { active, .. }, on) => *active = on,
            (Squeeze::Sampling { .. }, false) => {
                // What was held back is written as it is.
                if let Squeeze::Sampling { pending, .. } =
                    std::mem::replace(&mut self.squeeze, Squeeze::Off)
                {
                    for (lod, blob) in pending {
                        self.put_blob(lod, &blob, false)?;
                    }
                }
            }
            (Squeeze::Off, false) | (Squeeze::Sampling { .. }, true) => {}
        }
        Ok(())
    }

    /// Writes `lod`'s stored blob at the end of the geometry and fills in
    /// its record's place, length, checksum and compression.
    fn put_blob(&mut self, lod: u32, blob: &[u8], compressed: bool) -> Result<(), WriteError> {
        let l = &mut self.lods[lod as usize];
        l.offset = self.pos;
        l.len = blob.len() as u64;
        l.checksum = crc32fast::hash(blob);
        l.compressed = compressed;
        self.geometry_crc.update(blob);
        self.out.write_all(blob).map_err(|e| self.io_err(e))?;
        self.pos += blob.len() as u64;
        Ok(())
    }

    /// Compresses `blob` (unless an encoder did, with this squeezer's
    /// settings) and writes whichever is smaller.
    fn put_squeezed(
        &mut self,
        squeezer: &mut crate::squeeze::Squeezer,
        lod: u32,
        blob: &[u8],
        squeezed: Option<(u64, Vec<u8>)>,
    ) -> Result<(), WriteError> {
        let small = match squeezed {
            Some((id, small)) if id == squeezer.id => small,
            _ => squeezer
                .compress(blob)
                .map_err(|detail| WriteError::BadMesh { lod, detail })?,
        };
        if small.len() < blob.len() {
            self.put_blob(lod, &small, true)
        } else {
            self.put_blob(lod, blob, false)
        }
    }

    /// Trains the dictionary on the blobs held back and writes them.
    fn start_squeezing(&mut self) -> Result<(), WriteError> {
        let pending = match std::mem::replace(&mut self.squeeze, Squeeze::Off) {
            Squeeze::Sampling { pending, .. } => pending,
            other => {
                self.squeeze = other;
                return Ok(());
            }
        };
        let samples: Vec<&[u8]> = pending.iter().map(|(_, b)| b.as_slice()).collect();
        let mut squeezer =
            crate::squeeze::Squeezer::train(&samples).map_err(|detail| WriteError::BadMesh {
                lod: pending.first().map_or(0, |p| p.0),
                detail,
            })?;
        // Encoders on other threads compress with the same settings from
        // now on.
        let _ = self.trained.set(Trained {
            id: squeezer.id,
            dictionary: squeezer.dictionary.clone(),
        });
        for (lod, blob) in pending {
            self.put_squeezed(&mut squeezer, lod, &blob, None)?;
        }
        self.squeeze = Squeeze::On {
            squeezer,
            active: true,
        };
        Ok(())
    }

    /// Stores the normals of encoded LODs added after this in 2 x 16 bits
    /// (the default; within 0.004 degrees) or 2 x 8 bits (within 0.93
    /// degrees; [`codec::NORMAL_BITS`](crate::codec::NORMAL_BITS)). Raw
    /// LODs always take 16.
    pub fn set_normal_bits(&mut self, bits: u8) -> Result<(), WriteError> {
        if !crate::codec::NORMAL_BITS.contains(&bits) {
            return Err(WriteError::NormalBits(bits));
        }
        self.normal_bits = bits;
        Ok(())
    }

    /// Stores the LODs added after this on a grid of `bits` bits per axis
    /// over each LOD's box, meshopt-encoded (the default, 16 bits;
    /// [`codec::POSITION_BITS`](crate::codec::POSITION_BITS)), or with
    /// `None` raw: f32 positions, nothing encoded. Each encoded LOD's
    /// stored error grows by the farthest any of its vertices moved.
    pub fn set_position_bits(&mut self, bits: Option<u8>) -> Result<(), WriteError> {
        if let Some(b) = bits.filter(|b| !crate::codec::POSITION_BITS.contains(b)) {
            return Err(WriteError::PositionBits(b));
        }
        self.position_bits = bits;
        Ok(())
    }

    fn io_err(&self, source: io::Error) -> WriteError {
        WriteError::Io {
            path: self.path.display().to_string(),
            source,
        }
    }

    /// Appends one LOD's geometry and returns its index in the LOD table.
    /// A node's LODs must be added consecutively, finest first. Positions
    /// are re-centred on the LOD's box centre; `error` is the object-space
    /// error in model units.
    pub fn add_lod(&mut self, mesh: &LodMesh, error: f32) -> Result<u32, WriteError> {
        self.add_lod_in_runs(mesh, error, &[])
    }

    /// [`SceneWriter::add_lod`], keeping each of `runs` (consecutive
    /// triangle counts that sum to the mesh's; empty: no runs) in place:
    /// the encoder reorders triangles only within a run, so the stored
    /// LOD's triangles of a run are the run's, consecutive, in run order.
    pub fn add_lod_in_runs(
        &mut self,
        mesh: &LodMesh,
        error: f32,
        runs: &[u32],
    ) -> Result<u32, WriteError> {
        let encoded = self.encoder().encode(mesh, error, runs);
        self.add_encoded(encoded)
    }

    /// Appends one LOD an [`LodEncoder`] of this writer encoded (on any
    /// thread) and returns its index in the LOD table, as
    /// [`SceneWriter::add_lod_in_runs`] does.
    pub fn add_encoded(&mut self, lod_encoded: EncodedLod) -> Result<u32, WriteError> {
        let lod = self.lods.len() as u32;
        let Encoded {
            info,
            bounds,
            blob,
            moved,
            squeezed,
        } = lod_encoded
            .0
            .map_err(|detail| WriteError::BadMesh { lod, detail })?;
        let encoded = info.encoded;
        self.lods.push(info);
        self.lod_bounds.push(bounds);
        self.moved.push(moved);
        match std::mem::replace(&mut self.squeeze, Squeeze::Off) {
            Squeeze::Sampling {
                mut pending,
                mut bytes,
            } if encoded => {
                bytes += blob.len();
                pending.push((lod, blob));
                self.squeeze = Squeeze::Sampling { pending, bytes };
                if bytes >= crate::squeeze::SAMPLE_BYTES {
                    self.start_squeezing()?;
                }
            }
            Squeeze::On {
                mut squeezer,
                active: true,
            } if encoded => {
                let put = self.put_squeezed(&mut squeezer, lod, &blob, squeezed);
                self.squeeze = Squeeze::On {
                    squeezer,
                    active: true,
                };
                put?;
            }
            other => {
                self.squeeze = other;
                self.put_blob(lod, &blob, false)?;
            }
        }
        Ok(lod)
    }

    /// Writes hierarchy, LOD table and provenance, validates the whole
    /// skeleton, syncs, and renames over the destination path.
    ///
    /// Node boxes are grown to contain the geometry exactly as stored (f32
    /// offsets round), and then each parent to contain its children, so
    /// readers can check containment exactly. A box that would have to grow
    /// by more than rounding is the caller's bug and an error.
    pub fn finish(
        mut self,
        mut nodes: Vec<Node>,
        provenance: Provenance,
    ) -> Result<WriteSummary, WriteError> {
        self.start_squeezing()?;
        let dictionary = match &mut self.squeeze {
            Squeeze::On { squeezer, .. } => squeezer.dictionary.take(),
            _ => None,
        };
        grow_boxes(&mut nodes, &self.lod_bounds)?;
        let bounds = nodes.first().map(|n| n.bounds).unwrap_or(Aabb::EMPTY);
        let origin = if bounds.is_valid() {
            bounds.center()
        } else {
            DVec3::ZERO
        };
        // The errors as given must be in order (a caller's bug otherwise)
        // before quantization raises each LOD's by its own amount; the
        // order is then kept by raising where needed (a larger bound is
        // still a bound).
        crate::validate::check_tree(origin, &bounds, &nodes, &self.lods)
            .map_err(WriteError::Skeleton)?;
        for (l, &moved) in self.lods.iter_mut().zip(&self.moved) {
            if moved > 0.0 {
                l.error = up_f32(l.error as f64 + moved);
            }
        }
        raise_errors(&nodes, &mut self.lods);
        let geometry_at = format::HEADER_LEN as u64;
        let geometry_len = self.pos - geometry_at;
        let lods = std::mem::take(&mut self.lods);

        let mut toc = vec![TocEntry {
            tag: format::TAG_GEOMETRY,
            flags: 0,
            offset: geometry_at,
            len: geometry_len,
            crc: self.geometry_crc.clone().finalize(),
        }];
        let mut sections: Vec<([u8; 4], Vec<u8>)> = Vec::new();
        let optional = std::mem::take(&mut self.optional);
        let mut p = Put::default();
        format::encode_scene(
            &mut p,
            origin,
            &bounds,
            nodes.len() as u32,
            lods.len() as u32,
        );
        sections.push((format::TAG_SCENE, p.0));
        let mut p = Put::default();
        nodes.iter().for_each(|n| format::encode_node(&mut p, n));
        sections.push((format::TAG_NODES, p.0));
        let mut p = Put::default();
        lods.iter().for_each(|l| format::encode_lod(&mut p, l));
        sections.push((format::TAG_LODS, p.0));
        let meta = serde_json::to_vec_pretty(&provenance).expect("provenance serialises");
        sections.push((format::TAG_META, meta));
        if let Some(d) = dictionary {
            sections.push((format::TAG_DICTIONARY, d));
        }

        let flagged = sections
            .iter()
            .map(|s| (s, 0))
            .chain(optional.iter().map(|s| (s, format::SECTION_OPTIONAL)));
        for ((tag, bytes), flags) in flagged {
            self.pad_to_alignment()?;
            toc.push(TocEntry {
                tag: *tag,
                flags,
                offset: self.pos,
                len: bytes.len() as u64,
                crc: crc32fast::hash(bytes),
            });
            self.out.write_all(bytes).map_err(|e| self.io_err(e))?;
            self.pos += bytes.len() as u64;
        }
        let at = |tag| {
            toc.iter()
                .find(|e| e.tag == tag)
                .expect("section written")
                .offset
        };
        let layout = Layout {
            nodes_at: at(format::TAG_NODES),
            lods_at: at(format::TAG_LODS),
            geometry_at,
            geometry_len,
        };
        let skeleton = Skeleton::new(origin, bounds, nodes, lods, provenance)
            .map_err(|e| WriteError::Invalid(e.located(&layout)))?;
        validate(&skeleton, &layout).map_err(WriteError::Invalid)?;

        self.pad_to_alignment()?;
        let toc_offset = self.pos;
        let mut p = Put::default();
        toc.iter().for_each(|e| e.encode(&mut p));
        self.out.write_all(&p.0).map_err(|e| self.io_err(e))?;
        self.pos += p.0.len() as u64;
        let header = Header {
            major: format::MAJOR,
            minor: format::MINOR,
            toc_count: toc.len() as u32,
            toc_offset,
            file_len: self.pos,
            toc_crc: crc32fast::hash(&p.0),
        };
        let bytes = self.pos;
        self.out
            .seek(SeekFrom::Start(0))
            .map_err(|e| self.io_err(e))?;
        self.out
            .write_all(&header.encode())
            .map_err(|e| self.io_err(e))?;
        let path = self.path.clone();
        let io_err = |source| WriteError::Io {
            path: path.display().to_string(),
            source,
        };
        let tmp = self.out.into_inner().map_err(|e| io_err(e.into_error()))?;
        tmp.as_file().sync_all().map_err(io_err)?;
        tmp.persist(&path).map_err(io_err)?;
        // Make the rename itself durable where the platform allows.
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            let _ = File::open(dir).and_then(|d| d.sync_all());
        }
        Ok(WriteSummary {
            bytes,
            nodes: skeleton.nodes().len(),
            lods: skeleton.lods().len(),
            sections: toc
                .iter()
                .map(|e| (format::section_name(e.tag), e.len))
                .collect(),
        })
    }

    fn pad_to_alignment(&mut self) -> Result<(), WriteError> {
        let pad = format::align_up(self.pos, format::SECTION_ALIGN) - self.pos;
        self.out
            .write_all(&[0u8; 8][..pad as usize])
            .map_err(|e| self.io_err(e))?;
        self.pos += pad;
        Ok(())
    }
}

/// Checks and encodes one LOD: its record (offset left 0), the world
/// bounds of the stored geometry, and the blob.
fn encode_lod(
    mesh: &LodMesh,
    error: f32,
    position_bits: Option<u8>,
    normal_bits: u8,
    runs: &[u32],
) -> Result<(LodInfo, Aabb, Vec<u8>, f64), String> {
    let nv = mesh.positions.len();
    let triangles: u64 = runs.iter().map(|&r| r as u64).sum();
    if !runs.is_empty() && triangles != (mesh.indices.len() / 3) as u64 {
        return Err(format!(
            "runs of {triangles} triangles for {} triangles",
            mesh.indices.len() / 3
        ));
    }
    if mesh.indices.is_empty() || !mesh.indices.len().is_multiple_of(3) {
        return Err(format!(
            "{} indices is not a positive multiple of 3",
            mesh.indices.len()
        ));
    }
    if nv == 0 || nv > u32::MAX as usize || mesh.indices.len() / 3 > u32::MAX as usize {
        return Err(format!("{nv} vertices is out of range"));
    }
    if mesh.normals.len() != nv {
        return Err(format!("{} normals for {nv} positions", mesh.normals.len()));
    }
    if let Colours::PerVertex(c) = &mesh.colours {
        if c.len() != nv {
            return Err(format!("{} colours for {nv} positions", c.len()));
        }
    }
    if !(error.is_finite() && error >= 0.0) {
        return Err(format!("error {error} is not a finite non-negative number"));
    }
    if let Some((i, &v)) = mesh
        .indices
        .iter()
        .enumerate()
        .find(|(_, &v)| v as usize >= nv)
    {
        return Err(format!("index {i} is {v}, beyond the {nv} vertices"));
    }
    let world = |p: [f32; 3]| mesh.origin + Vec3::from(p).as_dvec3();
    if let Some(i) = mesh.positions.iter().position(|&p| !world(p).is_finite()) {
        return Err(format!("vertex {i} position is not finite"));
    }
    let origin = Aabb::from_points(mesh.positions.iter().map(|&p| world(p))).center();
    let stored: Vec<[f32; 3]> = mesh
        .positions
        .iter()
        .map(|&p| (world(p) - origin).as_vec3().to_array())
        .collect();
    // A per-vertex colour list that is one colour is stored as that colour.
    let uniform_colour = match &mesh.colours {
        Colours::Uniform(c) => Some(*c),
        Colours::PerVertex(c) if c.iter().all(|x| *x == c[0]) => Some(c[0]),
        Colours::PerVertex(_) => None,
    };
    // The record; the blob's length and checksum are filled in below.
    let info = LodInfo {
        error,
        triangles: (mesh.indices.len() / 3) as u32,
        vertices: nv as u32,
        origin,
        index_format: IndexFormat::for_vertex_count(nv as u32),
        uniform_colour,
        encoded: position_bits.is_some(),
        compressed: false,
        grid: position_bits.map(|position| crate::GridBits {
            position,
            normal: normal_bits,
        }),
        offset: 0,
        len: 0,
        checksum: 0,
    };
    let with_blob = |blob: &[u8]| LodInfo {
        len: blob.len() as u64,
        checksum: crc32fast::hash(blob),
        ..info
    };
    let world_box =
        |p: &[[f32; 3]]| Aabb::from_points(p.iter().map(|&p| origin + Vec3::from(p).as_dvec3()));
    if let Some(bits) = position_bits {
        let streams = crate::codec::Streams {
            positions: stored,
            normals: mesh.normals.clone(),
            colours: match (&mesh.colours, uniform_colour) {
                (Colours::PerVertex(c), None) => Some(c.clone()),
                _ => None,
            },
            indices: mesh.indices.clone(),
        };
        let e = crate::codec::encode_in_runs(&streams, bits, normal_bits, runs)?;
        return Ok((with_blob(&e.blob), world_box(&e.positions), e.blob, e.moved));
    }
    let bounds = world_box(&stored);
    let mut p = Put(Vec::with_capacity(format::geometry_len(&info) as usize));
    for v in &stored {
        v.iter().for_each(|&c| p.f32(c));
    }
    for &n in &mesh.normals {
        let [u, v] = encode_normal(n);
        p.u16(u as u16);
        p.u16(v as u16);
    }
    if let (None, Colours::PerVertex(c)) = (uniform_colour, &mesh.colours) {
        c.iter().for_each(|c| p.bytes(c));
    }
    match info.index_format {
        IndexFormat::U16 => mesh.indices.iter().for_each(|&i| p.u16(i as u16)),
        IndexFormat::U32 => mesh.indices.iter().for_each(|&i| p.u32(i)),
    }
    let len = format::geometry_len(&info);
    p.zeros(len as usize - p.0.len());
    Ok((with_blob(&p.0), bounds, p.0, 0.0))
}

/// `v` as an f32 no smaller than it.
fn up_f32(v: f64) -> f32 {
    let f = v as f32;
    if (f as f64) < v {
        f.next_up()
    } else {
        f
    }
}

/// Raises LOD errors where needed so that they do not decrease from a
/// node's finest LOD to its coarsest, nor from a node's finest to its
/// nearest ancestor with LODs. Children come after their parents, so one
/// backward pass carries a child's raise up to every ancestor. Indices
/// out of range are left for the validation after it to report.
fn raise_errors(nodes: &[Node], lods: &mut [LodInfo]) {
    for i in (0..nodes.len()).rev() {
        let r = nodes[i].lods();
        if r.is_empty() || r.end > lods.len() {
            continue;
        }
        for l in r.start + 1..r.end {
            lods[l].error = lods[l].error.max(lods[l - 1].error);
        }
        let finest = lods[r.start].error;
        let mut a = i;
        while a != 0 {
            let p = nodes[a].parent as usize;
            if p >= a {
                break;
            }
            a = p;
            if let Some(l) = lods
                .get_mut(nodes[a].first_lod as usize)
                .filter(|_| nodes[a].lod_count > 0)
            {
                l.error = l.error.max(finest);
                break;
            }
        }
    }
}

/// Grows node boxes by f32 rounding so they contain their stored geometry
/// and their children exactly. Children have larger indices than parents,
/// so one backward pass suffices.
fn grow_boxes(nodes: &mut [Node], lod_bounds: &[Aabb]) -> Result<(), WriteError> {
    for i in (0..nodes.len()).rev() {
        let n = nodes[i];
        let mut b = n.bounds;
        for l in n.lods() {
            let g = lod_bounds.get(l).ok_or_else(|| {
                WriteError::Invalid(crate::error::ReadErrorKind::Node {
                    node: i as u32,
                    offset: 0,
                    detail: format!("LOD {l} was never added"),
                })
            })?;
            b = b.union(g);
        }
        for c in n.children() {
            if let Some(child) = nodes.get(c as usize) {
                b = b.union(&child.bounds);
            }
        }
        if b != n.bounds {
            // Allow growth by f32 rounding of offsets within the box (a few
            // ulps of its extent), plus f64 rounding of its coordinates.
            let magnitude = b.min.abs().max(b.max.abs());
            let allowed = DVec3::splat(b.extent().max_element() * 1e-6)
                + magnitude * 1e-15
                + DVec3::splat(1e-12);
            let grown = (n.bounds.min - b.min).max(b.max - n.bounds.max);
            if !n.bounds.is_valid() || grown.cmpgt(allowed).any() {
                return Err(WriteError::Invalid(crate::error::ReadErrorKind::Node {
                    node: i as u32,
                    offset: 0,
                    detail: format!(
                        "box {:?} does not contain its geometry and children {:?}",
                        n.bounds, b
                    ),
                }));
            }
            nodes[i].bounds = b;
        }
    }
    Ok(())
}
