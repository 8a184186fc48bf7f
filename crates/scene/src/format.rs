//! Byte layout of the `.gwk` scene file, format 2 (docs/scene-format.md;
//! format 1 files are still read: they differ only in having no encoded
//! LODs).
//!
//! Everything is little-endian and fixed-width. The file is a 64-byte
//! header, then sections, then a table of contents (TOC) that the header
//! points at. Every section has a length and a CRC-32; the geometry
//! section's CRC is checked only by a full verify, because opening a scene
//! must not read its geometry (each LOD's blob has its own CRC instead).

use glam::DVec3;

use crate::{Aabb, GridBits, IndexFormat, LodInfo, Node};

pub const MAGIC: [u8; 8] = *b"GIGAWALK";
pub const MAJOR: u16 = 2;
/// The oldest major version this reader reads.
pub const OLDEST_MAJOR: u16 = 1;
/// Minor 1 records an encoded LOD's bits in its flags (bits 8-15: position
/// bits, 16-23: normal bits); 2.0 files leave them zero.
pub const MINOR: u16 = 1;

pub const HEADER_LEN: usize = 64;
pub const TOC_ENTRY_LEN: usize = 32;
pub const SCENE_LEN: usize = 80;
pub const NODE_LEN: usize = 72;
pub const LOD_LEN: usize = 64;
/// Sections start on this alignment so fixed-width records stay aligned.
pub const SECTION_ALIGN: u64 = 8;

pub const TAG_SCENE: [u8; 4] = *b"SCNE";
pub const TAG_NODES: [u8; 4] = *b"NODE";
pub const TAG_LODS: [u8; 4] = *b"LODS";
pub const TAG_GEOMETRY: [u8; 4] = *b"GEOM";
pub const TAG_META: [u8; 4] = *b"META";
/// The zstd dictionary of compressed blobs (format 2.1; present when
/// the writer trained one).
pub const TAG_DICTIONARY: [u8; 4] = *b"ZDIC";

/// TOC flag: a reader that does not know this section may skip it.
pub const SECTION_OPTIONAL: u32 = 1;

/// LOD flag: indices are u32 (else u16).
pub const LOD_U32_INDICES: u32 = 1;
/// LOD flag: one RGBA8 colour per vertex is stored (else the record's colour).
pub const LOD_VERTEX_COLOURS: u32 = 2;
/// LOD flag (format 2): the blob is quantized and meshopt-encoded
/// (`codec.rs`); else positions are f32 and every stream raw.
pub const LOD_ENCODED: u32 = 4;
/// LOD flags (format 2.1, encoded LODs): position bits in bits 8-15,
/// normal bits in bits 16-23; zero when unstated.
pub const LOD_POSITION_BITS_SHIFT: u32 = 8;
pub const LOD_NORMAL_BITS_SHIFT: u32 = 16;
pub const LOD_BITS_MASK: u32 = 0xff_ff00;
/// LOD flag (format 2.1): the encoded blob is zstd-compressed.
pub const LOD_COMPRESSED: u32 = 8;
pub const LOD_KNOWN_FLAGS: u32 =
    LOD_U32_INDICES | LOD_VERTEX_COLOURS | LOD_ENCODED | LOD_COMPRESSED | LOD_BITS_MASK;

pub fn section_name(tag: [u8; 4]) -> String {
    tag.iter()
        .map(|&b| if b.is_ascii_graphic() { b as char } else { '?' })
        .collect()
}

pub fn align_up(x: u64, a: u64) -> u64 {
    x.div_ceil(a) * a
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub major: u16,
    pub minor: u16,
    pub toc_count: u32,
    pub toc_offset: u64,
    pub file_len: u64,
    pub toc_crc: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TocEntry {
    pub tag: [u8; 4],
    pub flags: u32,
    pub offset: u64,
    pub len: u64,
    pub crc: u32,
}

/// Little-endian field writer over a growing byte vector.
#[derive(Default)]
pub struct Put(pub Vec<u8>);

impl Put {
    pub fn u16(&mut self, v: u16) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn dvec3(&mut self, v: DVec3) {
        self.f64(v.x);
        self.f64(v.y);
        self.f64(v.z);
    }
    pub fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
    pub fn zeros(&mut self, n: usize) {
        self.0.resize(self.0.len() + n, 0);
    }
}

/// Little-endian field reader over a slice whose length the caller checked.
pub struct Get<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Get<'a> {
    pub fn new(buf: &'a [u8]) -> Self {
        Get { buf, pos: 0 }
    }
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.buf[self.pos..self.pos + N]);
        self.pos += N;
        a
    }
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    pub fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    pub fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    pub fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    pub fn dvec3(&mut self) -> DVec3 {
        DVec3::new(self.f64(), self.f64(), self.f64())
    }
    pub fn tag(&mut self) -> [u8; 4] {
        self.take()
    }
    pub fn skip(&mut self, n: usize) {
        self.pos += n;
    }
}

impl Header {
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut p = Put::default();
        p.bytes(&MAGIC);
        p.u16(self.major);
        p.u16(self.minor);
        p.u32(self.toc_count);
        p.u64(self.toc_offset);
        p.u64(self.file_len);
        p.u32(self.toc_crc);
        p.zeros(24);
        let crc = crc32fast::hash(&p.0);
        p.u32(crc);
        p.0.try_into().expect("header is 64 bytes")
    }

    /// Decodes the fields; the caller checks magic, version and CRC first
    /// with [`Header::magic_ok`] and [`Header::crc_ok`].
    pub fn decode(b: &[u8; HEADER_LEN]) -> Header {
        let mut g = Get::new(b);
        g.skip(8);
        Header {
            major: g.u16(),
            minor: g.u16(),
            toc_count: g.u32(),
            toc_offset: g.u64(),
            file_len: g.u64(),
            toc_crc: g.u32(),
        }
    }

    pub fn magic_ok(b: &[u8; HEADER_LEN]) -> bool {
        b[..8] == MAGIC
    }

    pub fn crc_ok(b: &[u8; HEADER_LEN]) -> bool {
        let stored = u32::from_le_bytes(b[60..64].try_into().expect("4 bytes"));
        crc32fast::hash(&b[..60]) == stored
    }
}

impl TocEntry {
    pub fn encode(&self, p: &mut Put) {
        p.bytes(&self.tag);
        p.u32(self.flags);
        p.u64(self.offset);
        p.u64(self.len);
        p.u32(self.crc);
        p.u32(0);
    }
    pub fn decode(g: &mut Get) -> TocEntry {
        let e = TocEntry {
            tag: g.tag(),
            flags: g.u32(),
            offset: g.u64(),
            len: g.u64(),
            crc: g.u32(),
        };
        g.skip(4);
        e
    }
}

pub fn encode_scene(p: &mut Put, origin: DVec3, bounds: &Aabb, nodes: u32, lods: u32) {
    p.dvec3(origin);
    p.dvec3(bounds.min);
    p.dvec3(bounds.max);
    p.u32(nodes);
    p.u32(lods);
}

pub struct SceneRecord {
    pub origin: DVec3,
    pub bounds: Aabb,
    pub nodes: u32,
    pub lods: u32,
}

pub fn decode_scene(g: &mut Get) -> SceneRecord {
    SceneRecord {
        origin: g.dvec3(),
        bounds: Aabb::new(g.dvec3(), g.dvec3()),
        nodes: g.u32(),
        lods: g.u32(),
    }
}

pub fn encode_node(p: &mut Put, n: &Node) {
    p.dvec3(n.bounds.min);
    p.dvec3(n.bounds.max);
    p.u32(n.parent);
    p.u32(n.first_child);
    p.u32(n.child_count);
    p.u32(n.first_lod);
    p.u32(n.lod_count);
    p.u32(0);
}

pub fn decode_node(g: &mut Get) -> Node {
    let n = Node {
        bounds: Aabb::new(g.dvec3(), g.dvec3()),
        parent: g.u32(),
        first_child: g.u32(),
        child_count: g.u32(),
        first_lod: g.u32(),
        lod_count: g.u32(),
    };
    g.skip(4);
    n
}

pub fn encode_lod(p: &mut Put, l: &LodInfo) {
    p.dvec3(l.origin);
    p.f32(l.error);
    p.u32(l.triangles);
    p.u32(l.vertices);
    let mut flags = 0;
    if l.index_format == IndexFormat::U32 {
        flags |= LOD_U32_INDICES;
    }
    if l.uniform_colour.is_none() {
        flags |= LOD_VERTEX_COLOURS;
    }
    if l.encoded {
        flags |= LOD_ENCODED;
    }
    if l.compressed {
        flags |= LOD_COMPRESSED;
    }
    if let Some(g) = l.grid {
        flags |= (g.position as u32) << LOD_POSITION_BITS_SHIFT
            | (g.normal as u32) << LOD_NORMAL_BITS_SHIFT;
    }
    p.u32(flags);
    p.bytes(&l.uniform_colour.unwrap_or([0; 4]));
    p.u32(l.checksum);
    p.u64(l.offset);
    p.u64(l.len);
}

/// Decodes a LOD record; returns the raw flags too so the validator can
/// reject unknown bits.
pub fn decode_lod(g: &mut Get) -> (LodInfo, u32) {
    let origin = g.dvec3();
    let error = g.f32();
    let triangles = g.u32();
    let vertices = g.u32();
    let flags = g.u32();
    let colour = g.tag();
    let checksum = g.u32();
    let offset = g.u64();
    let len = g.u64();
    let info = LodInfo {
        error,
        triangles,
        vertices,
        origin,
        index_format: if flags & LOD_U32_INDICES != 0 {
            IndexFormat::U32
        } else {
            IndexFormat::U16
        },
        uniform_colour: if flags & LOD_VERTEX_COLOURS != 0 {
            None
        } else {
            Some(colour)
        },
        encoded: flags & LOD_ENCODED != 0,
        compressed: flags & LOD_COMPRESSED != 0,
        grid: match (
            (flags >> LOD_POSITION_BITS_SHIFT) as u8,
            (flags >> LOD_NORMAL_BITS_SHIFT) as u8,
        ) {
            (0, 0) => None,
            (position, normal) => Some(GridBits { position, normal }),
        },
        offset,
        len,
        checksum,
    };
    (info, flags)
}

/// Exact byte length of one raw (not encoded) LOD's geometry blob:
/// positions (3 x f32), octahedral normals (2 x i16), optional RGBA8
/// colours, indices, padded to 4.
pub fn geometry_len(l: &LodInfo) -> u64 {
    let v = l.vertices as u64;
    let colours = if l.uniform_colour.is_none() { 4 * v } else { 0 };
    let idx = 3 * l.triangles as u64 * l.index_format.bytes();
    align_up(12 * v + 4 * v + colours + idx, 4)
}
