//! The scene file reader: opening reads and validates the header, table of
//! contents and skeleton only; a LOD's geometry is read, checked and
//! decoded when asked for, with positioned reads (no memory map, so a file
//! truncated under us is an error rather than a crash).

use std::fs::File;
use std::io;
use std::path::Path;

use glam::{DVec3, Vec3};

use crate::error::{ReadError, ReadErrorKind};
use crate::format::{self, Get, Header, TocEntry};
use crate::mesh::decode_normal;
use crate::validate::{validate, Layout};
use crate::{Colours, IndexFormat, LodMesh, Provenance, Skeleton};

/// A byte source with positioned reads. Implemented for files and byte
/// slices; tests wrap it to count what a reader touches.
pub trait ReadAt {
    fn read_exact_at(&self, buf: &mut [u8], offset: u64) -> io::Result<()>;
    fn size(&self) -> io::Result<u64>;
}

impl ReadAt for File {
    fn read_exact_at(&self, buf: &mut [u8], offset: u64) -> io::Result<()> {
        #[cfg(unix)]
        {
            std::os::unix::fs::FileExt::read_exact_at(self, buf, offset)
        }
        #[cfg(windows)]
        {
            let (mut buf, mut offset) = (buf, offset);
            while !buf.is_empty() {
                match std::os::windows::fs::FileExt::seek_read(self, buf, offset)? {
                    0 => return Err(io::ErrorKind::UnexpectedEof.into()),
                    n => {
                        buf = &mut buf[n..];
                        offset += n as u64;
                    }
                }
            }
            Ok(())
        }
        #[cfg(not(any(unix, windows)))]
        {
            let _ = (buf, offset);
            Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "positioned reads of files are not available on this platform",
            ))
        }
    }
    fn size(&self) -> io::Result<u64> {
        Ok(self.metadata()?.len())
    }
}

impl ReadAt for [u8] {
    fn read_exact_at(&self, buf: &mut [u8], offset: u64) -> io::Result<()> {
        let start =
            usize::try_from(offset).map_err(|_| io::Error::from(io::ErrorKind::UnexpectedEof))?;
        let src = start
            .checked_add(buf.len())
            .and_then(|end| self.get(start..end))
            .ok_or(io::ErrorKind::UnexpectedEof)?;
        buf.copy_from_slice(src);
        Ok(())
    }
    fn size(&self) -> io::Result<u64> {
        Ok(self.len() as u64)
    }
}

impl ReadAt for Vec<u8> {
    fn read_exact_at(&self, buf: &mut [u8], offset: u64) -> io::Result<()> {
        self.as_slice().read_exact_at(buf, offset)
    }
    fn size(&self) -> io::Result<u64> {
        Ok(self.len() as u64)
    }
}

impl<T: ReadAt + ?Sized> ReadAt for &T {
    fn read_exact_at(&self, buf: &mut [u8], offset: u64) -> io::Result<()> {
        (**self).read_exact_at(buf, offset)
    }
    fn size(&self) -> io::Result<u64> {
        (**self).size()
    }
}

/// One section as the table of contents lists it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SectionInfo {
    pub name: String,
    pub offset: u64,
    pub len: u64,
}

/// An open scene file: the validated skeleton in memory, geometry on disk.
pub struct SceneReader<R = File> {
    src: R,
    file: String,
    skeleton: Skeleton,
    sections: Vec<SectionInfo>,
    geometry: TocEntry,
    /// Optional sections (known to this reader or not), read on demand.
    optional: Vec<TocEntry>,
    file_len: u64,
    version: (u16, u16),
    /// The zstd dictionary of compressed blobs (ZDIC), when there is one.
    dictionary: Option<crate::squeeze::Dictionary>,
}

impl SceneReader<File> {
    /// Opens and validates a scene file, reading everything but geometry.
    pub fn open(path: &Path) -> Result<Self, ReadError> {
        let file = File::open(path).map_err(|e| ReadError {
            file: path.display().to_string(),
            kind: e.into(),
        })?;
        Self::from_source(file, &path.display().to_string())
    }
}

impl<R: ReadAt> SceneReader<R> {
    /// Opens a scene from any positioned-read source; `name` is used in
    /// error messages.
    pub fn from_source(src: R, name: &str) -> Result<Self, ReadError> {
        open(src, name).map_err(|kind| ReadError {
            file: name.to_string(),
            kind,
        })
    }

    pub fn skeleton(&self) -> &Skeleton {
        &self.skeleton
    }

    pub fn sections(&self) -> &[SectionInfo] {
        &self.sections
    }

    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// The (major, minor) format version of the file.
    pub fn version(&self) -> (u16, u16) {
        self.version
    }

    /// The bytes of optional section `tag`, CRC checked; `None` only when
    /// the table of contents lists no such section. A listed section that
    /// fails its checksum is an error naming the file and section, never
    /// `None`.
    pub fn optional_section(&self, tag: [u8; 4]) -> Result<Option<Vec<u8>>, ReadError> {
        let Some(e) = self.optional.iter().find(|e| e.tag == tag) else {
            return Ok(None);
        };
        self.checked_optional(e).map(Some)
    }

    /// One optional section's bytes, CRC checked.
    fn checked_optional(&self, e: &TocEntry) -> Result<Vec<u8>, ReadError> {
        let err = |kind| ReadError {
            file: self.file.clone(),
            kind,
        };
        let bytes = read_bytes(&self.src, e.offset, e.len).map_err(err)?;
        if crc32fast::hash(&bytes) != e.crc {
            return Err(err(ReadErrorKind::Checksum {
                section: format::section_name(e.tag),
                offset: e.offset,
                end: e.offset + e.len,
            }));
        }
        Ok(bytes)
    }

    /// Optional section `tag` decoded by `decode`, whose error (byte
    /// offset, what is wrong) becomes a corrupt-section error naming the
    /// file and section; `None` only when the file has no such section (a
    /// bad checksum is an error, as for [`SceneReader::optional_section`]).
    pub fn decode_optional<T>(
        &self,
        tag: [u8; 4],
        decode: impl FnOnce(&[u8]) -> Result<T, (u64, String)>,
    ) -> Result<Option<T>, ReadError> {
        let Some(bytes) = self.optional_section(tag)? else {
            return Ok(None);
        };
        decode(&bytes)
            .map(Some)
            .map_err(|(offset, detail)| ReadError {
                file: self.file.clone(),
                kind: corrupt(&format::section_name(tag), offset, detail),
            })
    }

    /// Reads, checks (checksum, index range, geometry inside its node's
    /// box) and decodes one LOD's geometry.
    pub fn read_lod(&self, lod: u32) -> Result<LodMesh, ReadError> {
        self.read_lod_stored(lod).map(StoredLod::into_mesh)
    }

    /// [`SceneReader::read_lod`] without dequantizing an encoded LOD:
    /// its positions stay on their grid (what a renderer that reads grid
    /// coordinates takes), with the same checks.
    pub fn read_lod_stored(&self, lod: u32) -> Result<StoredLod, ReadError> {
        self.read_lod_kind(lod).map_err(|kind| ReadError {
            file: self.file.clone(),
            kind,
        })
    }

    fn read_lod_kind(&self, lod: u32) -> Result<StoredLod, ReadErrorKind> {
        let count = self.skeleton.lods().len() as u32;
        let info = *self
            .skeleton
            .lods()
            .get(lod as usize)
            .ok_or(ReadErrorKind::NoSuchLod { lod, count })?;
        let node = self.skeleton.owner(lod);
        let err = |detail: String| ReadErrorKind::Lod {
            lod,
            node,
            offset: info.offset,
            detail,
        };
        let mut blob = vec![0u8; info.len as usize];
        self.src.read_exact_at(&mut blob, info.offset)?;
        if crc32fast::hash(&blob) != info.checksum {
            return Err(ReadErrorKind::Checksum {
                section: format!("GEOM (LOD {lod} of node {node})"),
                offset: info.offset,
                end: info.offset + info.len,
            });
        }
        if info.compressed {
            let limit = crate::codec::blob_limit(
                info.vertices,
                info.triangles,
                info.uniform_colour.is_none(),
            );
            blob =
                crate::squeeze::decompress(&blob, self.dictionary.as_ref(), limit).map_err(err)?;
        }
        let nv = info.vertices as usize;
        let bounds = self.skeleton.node(node).bounds;
        let outside = |i: usize, p: [f32; 3]| {
            let w = info.origin + Vec3::from(p).as_dvec3();
            (!bounds.contains_point(w))
                .then(|| err(format!("vertex {i} at {w} lies outside the node's box")))
        };
        let stored = if info.encoded {
            let streams = crate::codec::decode_grid(
                &blob,
                nv,
                info.triangles as usize,
                info.uniform_colour.is_none(),
            )
            .map_err(err)?;
            if let Some(g) = info.grid {
                if (g.position, g.normal) != (streams.bits, streams.normal_bits) {
                    return Err(err(format!(
                        "the record states {} position and {} normal bits, the blob {} and {}",
                        g.position, g.normal, streams.bits, streams.normal_bits
                    )));
                }
            }
            // Dequantizing is monotonic per axis and a box is checked
            // axis by axis: the extent's two corners lie inside exactly
            // when every vertex does (the vertex loop only names one).
            if let Some((lo, hi)) = streams.corners() {
                if outside(0, lo).is_some() || outside(0, hi).is_some() {
                    if let Some(e) = (0..nv).find_map(|i| outside(i, streams.position(i))) {
                        return Err(e);
                    }
                }
            }
            StoredLod::Grid(GridLod {
                origin: info.origin,
                uniform_colour: info.uniform_colour,
                streams,
            })
        } else {
            let s = raw_streams(&blob, &info);
            if let Some(e) = s
                .positions
                .iter()
                .enumerate()
                .find_map(|(i, p)| outside(i, *p))
            {
                return Err(e);
            }
            StoredLod::Mesh(lod_mesh(info.origin, info.uniform_colour, s))
        };
        let indices = match &stored {
            StoredLod::Grid(g) => &g.streams.indices,
            StoredLod::Mesh(m) => &m.indices,
        };
        if let Some(i) = indices.iter().position(|&v| v as usize >= nv) {
            return Err(err(format!(
                "index {i} is {}, beyond the {nv} vertices",
                indices[i]
            )));
        }
        Ok(stored)
    }

    /// Reads every byte: checks the geometry section's checksum, every
    /// optional section's checksum (known to this reader or not), the
    /// contents of the optional sections it knows (OCCL, OCVC, OBJT) and every
    /// LOD. What `gigawalk info --verify` runs.
    pub fn verify(&self) -> Result<(), ReadError> {
        let e = |kind| ReadError {
            file: self.file.clone(),
            kind,
        };
        let mut crc = crc32fast::Hasher::new();
        let mut buf = vec![0u8; 1 << 20];
        let (mut at, end) = (
            self.geometry.offset,
            self.geometry.offset + self.geometry.len,
        );
        while at < end {
            let n = ((end - at) as usize).min(buf.len());
            self.src
                .read_exact_at(&mut buf[..n], at)
                .map_err(|x| e(x.into()))?;
            crc.update(&buf[..n]);
            at += n as u64;
        }
        if crc.finalize() != self.geometry.crc {
            return Err(e(ReadErrorKind::Checksum {
                section: "GEOM".into(),
                offset: self.geometry.offset,
                end,
            }));
        }
        for o in &self.optional {
            self.checked_optional(o)?;
        }
        let occluders = self.occluders()?.map_or(0, |o| o.len());
        self.occluder_cells(occluders)?;
        self.objects()?;
        for lod in 0..self.skeleton.lods().len() as u32 {
            self.read_lod(lod)?;
        }
        Ok(())
    }
}

fn corrupt(section: &str, offset: u64, detail: impl Into<String>) -> ReadErrorKind {
    ReadErrorKind::Corrupt {
        section: section.into(),
        offset,
        detail: detail.into(),
    }
}

/// The header and table of contents, read and checked: the first two
/// reads of opening a scene.
fn header_and_toc<R: ReadAt + ?Sized>(src: &R) -> Result<(Header, Vec<TocEntry>), ReadErrorKind> {
    let actual = src.size()?;
    if actual < format::HEADER_LEN as u64 {
        return Err(
            if actual >= 8 && {
                let mut m = [0u8; 8];
                src.read_exact_at(&mut m, 0)?;
                m != format::MAGIC
            } {
                ReadErrorKind::NotAScene
            } else {
                corrupt(
                    "header",
                    0,
                    format!("file is {actual} bytes, shorter than the header"),
                )
            },
        );
    }
    let mut hb = [0u8; format::HEADER_LEN];
    src.read_exact_at(&mut hb, 0)?;
    if !Header::magic_ok(&hb) {
        return Err(ReadErrorKind::NotAScene);
    }
    let h = Header::decode(&hb);
    // Check the version before the checksum: a newer writer may lay out the
    // rest of the header differently, and "use a newer gigawalk" is the
    // useful message then.
    if h.major > format::MAJOR {
        return Err(ReadErrorKind::NewerVersion {
            major: h.major,
            minor: h.minor,
        });
    }
    if h.major < format::OLDEST_MAJOR {
        return Err(ReadErrorKind::OlderVersion {
            major: h.major,
            minor: h.minor,
        });
    }
    if !Header::crc_ok(&hb) {
        return Err(ReadErrorKind::Checksum {
            section: "header".into(),
            offset: 0,
            end: format::HEADER_LEN as u64,
        });
    }
    if h.file_len != actual {
        return Err(ReadErrorKind::LengthMismatch {
            expected: h.file_len,
            actual,
        });
    }
    let toc_len = h.toc_count as u64 * format::TOC_ENTRY_LEN as u64;
    if h.toc_offset < format::HEADER_LEN as u64
        || h.toc_offset.checked_add(toc_len).is_none_or(|e| e > actual)
    {
        return Err(corrupt(
            "header",
            16,
            format!(
                "table of contents at {}+{toc_len} lies outside the file",
                h.toc_offset
            ),
        ));
    }
    let toc_bytes = read_bytes(src, h.toc_offset, toc_len)?;
    if crc32fast::hash(&toc_bytes) != h.toc_crc {
        return Err(ReadErrorKind::Checksum {
            section: "table of contents".into(),
            offset: h.toc_offset,
            end: h.toc_offset + toc_len,
        });
    }
    let mut g = Get::new(&toc_bytes);
    let toc: Vec<TocEntry> = (0..h.toc_count).map(|_| TocEntry::decode(&mut g)).collect();
    for (i, e) in toc.iter().enumerate() {
        let at = h.toc_offset + (i * format::TOC_ENTRY_LEN) as u64;
        let name = format::section_name(e.tag);
        if e.offset < format::HEADER_LEN as u64
            || e.offset
                .checked_add(e.len)
                .is_none_or(|end| end > h.toc_offset)
        {
            return Err(corrupt(
                "table of contents",
                at,
                format!(
                    "section {name} at {}+{} lies outside the data area",
                    e.offset, e.len
                ),
            ));
        }
    }
    Ok((h, toc))
}

/// The byte ranges opening a scene reads besides the header and the table
/// of contents (which this reads): its required sections but the
/// geometry. What a reader that fetches bytes over a network fetches
/// before [`SceneReader::from_source`], in one request when they lie
/// together (the writer puts them together).
pub fn opening_reads<R: ReadAt + ?Sized>(
    src: &R,
    name: &str,
) -> Result<Vec<std::ops::Range<u64>>, ReadError> {
    let (_, toc) = header_and_toc(src).map_err(|kind| ReadError {
        file: name.to_string(),
        kind,
    })?;
    Ok(toc
        .iter()
        .filter(|e| e.flags & format::SECTION_OPTIONAL == 0 && e.tag != format::TAG_GEOMETRY)
        .map(|e| e.offset..e.offset + e.len)
        .collect())
}

fn open<R: ReadAt>(src: R, name: &str) -> Result<SceneReader<R>, ReadErrorKind> {
    let actual = src.size()?;
    let (h, toc) = header_and_toc(&src)?;
    let mut sorted: Vec<&TocEntry> = toc.iter().collect();
    sorted.sort_by_key(|e| e.offset);
    for w in sorted.windows(2) {
        if w[0].offset + w[0].len > w[1].offset {
            return Err(corrupt(
                "table of contents",
                h.toc_offset,
                format!(
                    "sections {} and {} overlap",
                    format::section_name(w[0].tag),
                    format::section_name(w[1].tag)
                ),
            ));
        }
    }
    let find = |tag: [u8; 4]| -> Result<TocEntry, ReadErrorKind> {
        let mut it = toc.iter().filter(|e| e.tag == tag);
        match (it.next(), it.next()) {
            (Some(e), None) => Ok(*e),
            (None, _) => Err(corrupt(
                "table of contents",
                h.toc_offset,
                format!("required section {} is missing", format::section_name(tag)),
            )),
            (Some(_), Some(_)) => Err(corrupt(
                "table of contents",
                h.toc_offset,
                format!("section {} appears twice", format::section_name(tag)),
            )),
        }
    };
    if let Some(e) = toc.iter().find(|e| {
        e.flags & format::SECTION_OPTIONAL == 0
            && ![
                format::TAG_SCENE,
                format::TAG_NODES,
                format::TAG_LODS,
                format::TAG_GEOMETRY,
                format::TAG_META,
                format::TAG_DICTIONARY,
            ]
            .contains(&e.tag)
    }) {
        return Err(corrupt(
            "table of contents",
            h.toc_offset,
            format!("unknown required section {}", format::section_name(e.tag)),
        ));
    }
    // Read and check every section but the geometry.
    let checked = |tag| -> Result<(TocEntry, Vec<u8>), ReadErrorKind> {
        let e = find(tag)?;
        let bytes = read_bytes(&src, e.offset, e.len)?;
        if crc32fast::hash(&bytes) != e.crc {
            return Err(ReadErrorKind::Checksum {
                section: format::section_name(tag),
                offset: e.offset,
                end: e.offset + e.len,
            });
        }
        Ok((e, bytes))
    };
    let (scene_e, scene_b) = checked(format::TAG_SCENE)?;
    if scene_b.len() != format::SCENE_LEN {
        return Err(corrupt(
            "SCNE",
            scene_e.offset,
            format!(
                "section is {} bytes, expected {}",
                scene_b.len(),
                format::SCENE_LEN
            ),
        ));
    }
    let scene = format::decode_scene(&mut Get::new(&scene_b));
    let (nodes_e, nodes_b) = checked(format::TAG_NODES)?;
    if nodes_b.len() as u64 != scene.nodes as u64 * format::NODE_LEN as u64 {
        return Err(corrupt(
            "NODE",
            nodes_e.offset,
            format!(
                "section is {} bytes, expected {} nodes of {} bytes",
                nodes_b.len(),
                scene.nodes,
                format::NODE_LEN
            ),
        ));
    }
    let (lods_e, lods_b) = checked(format::TAG_LODS)?;
    if lods_b.len() as u64 != scene.lods as u64 * format::LOD_LEN as u64 {
        return Err(corrupt(
            "LODS",
            lods_e.offset,
            format!(
                "section is {} bytes, expected {} LODs of {} bytes",
                lods_b.len(),
                scene.lods,
                format::LOD_LEN
            ),
        ));
    }
    let (meta_e, meta_b) = checked(format::TAG_META)?;
    let provenance: Provenance = serde_json::from_slice(&meta_b).map_err(|e| {
        corrupt(
            "META",
            meta_e.offset,
            format!("provenance is not valid JSON: {e}"),
        )
    })?;
    let geometry = find(format::TAG_GEOMETRY)?;
    let dictionary = if toc.iter().any(|e| e.tag == format::TAG_DICTIONARY) {
        Some(crate::squeeze::Dictionary::new(
            checked(format::TAG_DICTIONARY)?.1,
        ))
    } else {
        None
    };

    let mut g = Get::new(&nodes_b);
    let nodes = (0..scene.nodes)
        .map(|_| format::decode_node(&mut g))
        .collect();
    let mut g = Get::new(&lods_b);
    let mut lods = Vec::with_capacity(scene.lods as usize);
    for i in 0..scene.lods {
        let (l, flags) = format::decode_lod(&mut g);
        // Format 1 has no encoded LODs.
        let known = match h.major {
            1 => {
                format::LOD_KNOWN_FLAGS
                    & !(format::LOD_ENCODED | format::LOD_COMPRESSED | format::LOD_BITS_MASK)
            }
            _ => format::LOD_KNOWN_FLAGS,
        };
        if flags & !known != 0 {
            return Err(ReadErrorKind::Lod {
                lod: i,
                node: crate::NO_NODE,
                offset: lods_e.offset + i as u64 * format::LOD_LEN as u64,
                detail: format!("unknown flags {flags:#x}"),
            });
        }
        lods.push(l);
    }
    let layout = Layout {
        nodes_at: nodes_e.offset,
        lods_at: lods_e.offset,
        geometry_at: geometry.offset,
        geometry_len: geometry.len,
    };
    let skeleton = Skeleton::new(scene.origin, scene.bounds, nodes, lods, provenance)
        .map_err(|e| e.located(&layout))?;
    validate(&skeleton, &layout)?;
    Ok(SceneReader {
        src,
        file: name.to_string(),
        skeleton,
        sections: toc
            .iter()
            .map(|e| SectionInfo {
                name: format::section_name(e.tag),
                offset: e.offset,
                len: e.len,
            })
            .collect(),
        geometry,
        optional: toc
            .iter()
            .filter(|e| e.flags & format::SECTION_OPTIONAL != 0)
            .cloned()
            .collect(),
        file_len: actual,
        version: (h.major, h.minor),
        dictionary,
    })
}

fn read_bytes<R: ReadAt + ?Sized>(
    src: &R,
    offset: u64,
    len: u64,
) -> Result<Vec<u8>, ReadErrorKind> {
    // Callers have checked offset + len against the file's real length, so
    // this allocation is bounded by the file size.
    let mut b = vec![0u8; len as usize];
    src.read_exact_at(&mut b, offset)?;
    Ok(b)
}

/// A raw blob's streams (format 1's layout; its length was checked
/// against the record's counts when the file was opened).
/// One LOD as its blob stores it ([`SceneReader::read_lod_stored`]).
#[derive(Clone, Debug, PartialEq)]
pub enum StoredLod {
    /// An encoded LOD: positions on their grid, octahedral normals.
    Grid(GridLod),
    /// A raw LOD (f32 positions), decoded.
    Mesh(LodMesh),
}

impl StoredLod {
    /// The LOD decoded, as [`SceneReader::read_lod`] returns it.
    pub fn into_mesh(self) -> LodMesh {
        match self {
            StoredLod::Mesh(m) => m,
            StoredLod::Grid(g) => lod_mesh(g.origin, g.uniform_colour, g.streams.into_streams()),
        }
    }
}

/// A LOD's decoded streams as a mesh: the record's colour when it has
/// one, else the per-vertex colours.
fn lod_mesh(origin: DVec3, uniform_colour: Option<[u8; 4]>, s: crate::codec::Streams) -> LodMesh {
    LodMesh {
        origin,
        colours: match (uniform_colour, s.colours) {
            (Some(c), _) => Colours::Uniform(c),
            (None, c) => Colours::PerVertex(c.unwrap_or_default()),
        },
        positions: s.positions,
        normals: s.normals,
        indices: s.indices,
    }
}

/// An encoded LOD, decoded but not dequantized.
#[derive(Clone, Debug, PartialEq)]
pub struct GridLod {
    /// World point the grid's origin is relative to.
    pub origin: DVec3,
    /// The LOD's colour when it has one (`streams.colours` is then `None`).
    pub uniform_colour: Option<[u8; 4]>,
    pub streams: crate::codec::GridStreams,
}

impl GridLod {
    /// Vertex `i`'s sRGB-encoded RGBA colour.
    pub fn colour(&self, i: usize) -> [u8; 4] {
        match (&self.streams.colours, self.uniform_colour) {
            (Some(c), _) => c[i],
            (None, c) => c.unwrap_or([255; 4]),
        }
    }
}

fn raw_streams(blob: &[u8], info: &crate::LodInfo) -> crate::codec::Streams {
    let nv = info.vertices as usize;
    let mut g = Get::new(blob);
    let positions = (0..nv).map(|_| [g.f32(), g.f32(), g.f32()]).collect();
    let normals = (0..nv)
        .map(|_| decode_normal([g.u16() as i16, g.u16() as i16]))
        .collect();
    let colours = info
        .uniform_colour
        .is_none()
        .then(|| (0..nv).map(|_| g.tag()).collect());
    let ni = 3 * info.triangles as usize;
    let indices = match info.index_format {
        IndexFormat::U16 => (0..ni).map(|_| g.u16() as u32).collect(),
        IndexFormat::U32 => (0..ni).map(|_| g.u32()).collect(),
    };
    crate::codec::Streams {
        positions,
        normals,
        colours,
        indices,
    }
}
