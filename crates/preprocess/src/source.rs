//! Where the pipeline reads the model's objects: a [`Model`] in memory, or
//! a [`Spill`], the objects written to an unnamed file on disk as they are
//! imported and read back one at a time, so a model of any size costs
//! memory only for what each step works on (GigaWalk Section 6.3 built
//! the 82M-triangle Double Eagle in at most 1 GB this way).
//!
//! A spill keeps, per object, where its bytes are (16 bytes), the box of
//! every position and the raw geometry's size; objects read back sit in a
//! small cache, so the leaves of one large object, made one after another,
//! read it once.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Write as _};
use std::ops::Deref;
use std::os::unix::fs::FileExt as _;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use gigawalk_import::{Identity, ImportStats, Model, Object};
use glam::{DVec3, Vec3};

/// A model's objects, by index.
pub trait Source: Sync {
    /// How many objects there are.
    fn len(&self) -> usize;
    /// Whether there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Object `i` (< [`Source::len`]).
    fn object(&self, i: u32) -> Result<ObjectRef<'_>, SpillError>;
    /// The raw size of the geometry ([`crate::Stats::raw_input_bytes`]).
    fn raw_bytes(&self) -> u64;
    /// The box of every position (`None` when there is none or a
    /// non-finite one).
    fn bounds(&self) -> Option<(DVec3, DVec3)>;
}

/// An object borrowed from memory or shared from a spill's cache.
pub enum ObjectRef<'a> {
    Borrowed(&'a Object),
    Shared(Arc<Object>),
}

impl Deref for ObjectRef<'_> {
    type Target = Object;
    fn deref(&self) -> &Object {
        match self {
            ObjectRef::Borrowed(o) => o,
            ObjectRef::Shared(o) => o,
        }
    }
}

/// The objects some pieces use, each read once.
pub(crate) struct Loaded<'a> {
    ids: Vec<u32>,
    objects: Vec<ObjectRef<'a>>,
}

impl<'a> Loaded<'a> {
    pub(crate) fn of(
        source: &'a dyn Source,
        ids: impl Iterator<Item = u32>,
    ) -> Result<Loaded<'a>, SpillError> {
        let mut ids: Vec<u32> = ids.collect();
        ids.sort_unstable();
        ids.dedup();
        let objects = ids
            .iter()
            .map(|&i| source.object(i))
            .collect::<Result<_, _>>()?;
        Ok(Loaded { ids, objects })
    }

    /// Object `id`, which must be one [`Loaded::of`] was given.
    pub(crate) fn get(&self, id: u32) -> &Object {
        let k = self
            .ids
            .binary_search(&id)
            .expect("only objects of the pieces are asked for");
        &self.objects[k]
    }
}

/// Reading a spilled object back failed (the disk, not the model).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("cannot read object {object} back from the spill file in {}: {reason}", dir.display())]
pub struct SpillError {
    pub dir: PathBuf,
    pub object: u32,
    pub reason: String,
}

impl Source for Model {
    fn len(&self) -> usize {
        self.objects.len()
    }
    fn object(&self, i: u32) -> Result<ObjectRef<'_>, SpillError> {
        self.objects
            .get(i as usize)
            .map(ObjectRef::Borrowed)
            .ok_or_else(|| SpillError {
                dir: PathBuf::new(),
                object: i,
                reason: "no such object".into(),
            })
    }
    fn raw_bytes(&self) -> u64 {
        self.objects.iter().map(raw_bytes).sum()
    }
    fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let (lo, hi) = self
            .objects
            .iter()
            .flat_map(|o| &o.positions)
            .fold(EMPTY, |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        finite(lo, hi)
    }
}

const EMPTY: (DVec3, DVec3) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));

fn finite(lo: DVec3, hi: DVec3) -> Option<(DVec3, DVec3)> {
    (hi - lo).length().is_finite().then_some((lo, hi))
}

/// An object's raw geometry: f64 positions, u32 indices and, when it has
/// them, RGBA f32 vertex colours.
pub(crate) fn raw_bytes(o: &Object) -> u64 {
    let v = o.positions.len() as u64;
    let colours = if o.vertex_colours.is_some() {
        16 * v
    } else {
        0
    };
    24 * v + colours + 4 * o.indices.len() as u64
}

/// Bytes an object takes once read back (what the cache counts).
fn resident_bytes(o: &Object) -> u64 {
    let v = o.positions.len() as u64;
    let colours = if o.vertex_colours.is_some() {
        16 * v
    } else {
        0
    };
    (24 + 12) * v
        + colours
        + 4 * o.indices.len() as u64
        + o.name.len() as u64
        + o.identity.path.len() as u64
        + o.identity.extras.as_ref().map_or(0, |e| e.len() as u64)
        + 64
}

/// A model imported under a memory budget ([`import_within`]).
pub enum Imported {
    /// It fit: every object in memory.
    Memory(Model),
    /// It did not: every object on disk.
    Spilled(Box<Spill>),
}

impl Imported {
    pub fn source(&self) -> &dyn Source {
        match self {
            Imported::Memory(m) => m,
            Imported::Spilled(s) => s.as_ref(),
        }
    }
    pub fn stats(&self) -> &ImportStats {
        match self {
            Imported::Memory(m) => &m.stats,
            Imported::Spilled(s) => s.stats(),
        }
    }
    /// The spill file's size, 0 in memory.
    pub fn spilled_bytes(&self) -> u64 {
        match self {
            Imported::Memory(_) => 0,
            Imported::Spilled(s) => s.bytes(),
        }
    }
}

/// `--memory-budget auto`: half the machine's physical memory, at most
/// [`AUTO_BUDGET_MAX`]; `None` when /proc/meminfo cannot be read.
pub fn auto_budget() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some((kib.checked_mul(1024)? / 2).min(AUTO_BUDGET_MAX))
}

/// The most `auto` gives: 2 GiB.
pub const AUTO_BUDGET_MAX: u64 = 2 << 30;

/// The share of a memory budget the imported objects may take in
/// memory; a model that needs more goes to a spill file.
pub const MEMORY_SHARE: f64 = 0.4;

/// The share of a memory budget the whole process may take while objects
/// are still held in memory (checked as they are read).
pub const RESIDENT_SHARE: f64 = 0.5;

/// The share of a memory budget a spill's cache of objects read back
/// takes.
pub const CACHE_SHARE: f64 = 0.1;

/// Imports `inputs` ([`gigawalk_import::import_all_each`]) under a memory
/// budget: objects are held in memory while they take at most
/// [`MEMORY_SHARE`] of `budget` and the process as a whole (the file being
/// read, its glTF document) at most [`RESIDENT_SHARE`] of it; the moment
/// either would be more, all of them go to a spill file in `spill_dir`, as
/// do the rest as they are read. `None`: no budget, all in memory.
pub fn import_within(
    inputs: &[PathBuf],
    budget: Option<u64>,
    spill_dir: &Path,
    each: &mut dyn FnMut(usize, usize, &Path),
) -> Result<Imported, gigawalk_import::ImportError> {
    let limit = budget.map_or(u64::MAX, |b| (b as f64 * MEMORY_SHARE) as u64);
    let spill_err = |source| gigawalk_import::ImportError::Spill {
        dir: spill_dir.display().to_string(),
        source,
    };
    let resident_limit = budget.map_or(u64::MAX, |b| (b as f64 * RESIDENT_SHARE) as u64);
    let mut held: Vec<Object> = Vec::new();
    let mut held_bytes = 0u64;
    let mut checked_at = 0u64;
    let mut spill: Option<SpillWriter> = None;
    let stats = gigawalk_import::import_all_each(inputs, each, &mut |o| {
        if let Some(w) = &mut spill {
            return w.push(&o).map_err(spill_err);
        }
        held_bytes += resident_bytes(&o);
        held.push(o);
        // The process's size is read every 16 MiB of objects held.
        let over = budget.is_some() && held_bytes >= checked_at + (16 << 20) && {
            checked_at = held_bytes;
            crate::stats::resident_memory_bytes().is_some_and(|r| r > resident_limit)
        };
        if held_bytes > limit || over {
            let mut w = SpillWriter::create_in(spill_dir).map_err(spill_err)?;
            for o in held.drain(..) {
                w.push(&o).map_err(spill_err)?;
            }
            held.shrink_to_fit();
            spill = Some(w);
        }
        Ok(())
    })?;
    Ok(match spill {
        None => Imported::Memory(Model {
            objects: held,
            stats,
        }),
        Some(w) => {
            let cache = cache_bytes(budget);
            Imported::Spilled(Box::new(w.finish(cache, &stats).map_err(spill_err)?))
        }
    })
}

/// Imports `inputs` into a named spill at `path` for plan `id`
/// ([`SpillWriter::create_named`]): every object on disk, for any number
/// of processes to read ([`Spill::open`]).
pub fn import_to_named_spill(
    inputs: &[PathBuf],
    path: &Path,
    id: &str,
    cache_bytes: u64,
    each: &mut dyn FnMut(usize, usize, &Path),
) -> Result<Spill, gigawalk_import::ImportError> {
    let spill_err = |source| gigawalk_import::ImportError::Spill {
        dir: path.display().to_string(),
        source,
    };
    let mut w = SpillWriter::create_named(path, id).map_err(spill_err)?;
    let stats =
        gigawalk_import::import_all_each(inputs, each, &mut |o| w.push(&o).map_err(spill_err))?;
    w.finish(cache_bytes, &stats).map_err(spill_err)
}

/// The cache a spill read under `budget` gets (`None`: no budget, so
/// every object read back stays).
pub fn cache_bytes(budget: Option<u64>) -> u64 {
    budget.map_or(u64::MAX, |b| (b as f64 * CACHE_SHARE) as u64)
}

/// Writes objects to a spill as they come ([`SpillWriter::push`]), then
/// [`SpillWriter::finish`] gives the [`Spill`] to read them from.
pub struct SpillWriter {
    dir: PathBuf,
    out: BufWriter<Out>,
    pos: u64,
    at: Vec<(u64, u64, u32)>,
    raw_bytes: u64,
    bounds: (DVec3, DVec3),
    largest: u64,
}

/// Where a spill is written: an unnamed file, or a named one (for other
/// processes to read) under a temporary name until it is whole.
enum Out {
    Unnamed(File),
    Named(gigawalk_scene::TempFile, PathBuf),
}

impl std::io::Write for Out {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        match self {
            Out::Unnamed(f) => f.write(b),
            Out::Named(f, _) => f.write(b),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Out::Unnamed(f) => f.flush(),
            Out::Named(f, _) => f.flush(),
        }
    }
}

/// A named spill's first bytes, before the plan id it belongs to.
const SPILL_MAGIC: &[u8; 8] = b"GWSPILL2";

impl SpillWriter {
    /// An unnamed file in `dir`: the system removes it when the run ends,
    /// however it ends, so nothing is left behind.
    pub fn create_in(dir: &Path) -> std::io::Result<SpillWriter> {
        let file = tempfile::tempfile_in(dir)?;
        Ok(Self::new(dir, Out::Unnamed(file)))
    }

    /// A spill other processes can open at `path` ([`Spill::open`]) once
    /// [`SpillWriter::finish`] has renamed it into place; `id` (the plan's)
    /// is written in it and checked on opening.
    pub fn create_named(path: &Path, id: &str) -> std::io::Result<SpillWriter> {
        let tmp = gigawalk_scene::temp_file_for(path)?;
        let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let mut w = Self::new(&dir, Out::Named(tmp, path.to_path_buf()));
        w.out.write_all(SPILL_MAGIC)?;
        w.out.write_all(&(id.len() as u32).to_le_bytes())?;
        w.out.write_all(id.as_bytes())?;
        w.pos = (SPILL_MAGIC.len() + 4 + id.len()) as u64;
        Ok(w)
    }

    fn new(dir: &Path, out: Out) -> SpillWriter {
        SpillWriter {
            dir: dir.to_path_buf(),
            out: BufWriter::with_capacity(1 << 20, out),
            pos: 0,
            at: Vec::new(),
            raw_bytes: 0,
            bounds: EMPTY,
            largest: 0,
        }
    }

    /// Appends one object.
    pub fn push(&mut self, o: &Object) -> std::io::Result<()> {
        let bytes = encode(o);
        self.out.write_all(&bytes)?;
        self.at
            .push((self.pos, bytes.len() as u64, crc32fast::hash(&bytes)));
        self.pos += bytes.len() as u64;
        self.raw_bytes += raw_bytes(o);
        self.largest = self.largest.max(resident_bytes(o));
        for p in &o.positions {
            self.bounds = (self.bounds.0.min(*p), self.bounds.1.max(*p));
        }
        Ok(())
    }

    /// Objects pushed so far.
    pub fn len(&self) -> usize {
        self.at.len()
    }

    /// Whether none was pushed.
    pub fn is_empty(&self) -> bool {
        self.at.is_empty()
    }

    /// Bytes written so far.
    pub fn bytes(&self) -> u64 {
        self.pos
    }

    /// The spill, reading objects back through a cache of about
    /// `cache_bytes` (never less than the largest object). A named spill
    /// gets its table (`stats`, every object's place and checksum) at its
    /// end, is synced and renamed into place.
    pub fn finish(mut self, cache_bytes: u64, stats: &ImportStats) -> std::io::Result<Spill> {
        let table = Table {
            at: std::mem::take(&mut self.at),
            raw_bytes: self.raw_bytes,
            bounds: finite(self.bounds.0, self.bounds.1),
            largest: self.largest,
            stats: stats.clone(),
        };
        let (file, bytes) = match self.out.into_inner().map_err(|e| e.into_error())? {
            Out::Unnamed(f) => (f, self.pos),
            Out::Named(mut tmp, path) => {
                let t = table.encode(self.pos);
                tmp.write_all(&t)?;
                tmp.as_file().sync_all()?;
                tmp.persist(&path)?;
                (File::open(&path)?, self.pos + t.len() as u64)
            }
        };
        Ok(Spill {
            dir: self.dir,
            file,
            bytes,
            cache: Mutex::new(Cache {
                limit: cache_bytes.max(table.largest),
                ..Default::default()
            }),
            table,
        })
    }
}

/// What a spill knows of its objects.
struct Table {
    /// Offset, length and CRC-32 of each object's bytes.
    at: Vec<(u64, u64, u32)>,
    raw_bytes: u64,
    bounds: Option<(DVec3, DVec3)>,
    largest: u64,
    stats: ImportStats,
}

impl Table {
    /// The table as a named spill ends: the table, where it starts (u64)
    /// and its CRC-32 (u32).
    fn encode(&self, start: u64) -> Vec<u8> {
        let mut b = Vec::with_capacity(20 * self.at.len() + 256);
        let u64s = |b: &mut Vec<u8>, v: u64| b.extend_from_slice(&v.to_le_bytes());
        u64s(&mut b, self.at.len() as u64);
        for &(o, l, c) in &self.at {
            u64s(&mut b, o);
            u64s(&mut b, l);
            b.extend_from_slice(&c.to_le_bytes());
        }
        u64s(&mut b, self.raw_bytes);
        match self.bounds {
            None => b.push(0),
            Some((lo, hi)) => {
                b.push(1);
                for x in lo.to_array().into_iter().chain(hi.to_array()) {
                    b.extend_from_slice(&x.to_le_bytes());
                }
            }
        }
        u64s(&mut b, self.largest);
        let s = &self.stats;
        for v in [
            s.triangles,
            s.degenerate_triangles_dropped,
            s.skipped_primitives,
        ] {
            u64s(&mut b, v);
        }
        u64s(&mut b, s.warnings.len() as u64);
        for w in &s.warnings {
            u64s(&mut b, w.len() as u64);
            b.extend_from_slice(w.as_bytes());
        }
        u64s(&mut b, start);
        let crc = crc32fast::hash(&b);
        b.extend_from_slice(&crc.to_le_bytes());
        b
    }

    /// [`Table::encode`]'s bytes (from the table's start to the file's
    /// end); `None` when they do not decode.
    fn decode(b: &[u8], start: u64) -> Option<Table> {
        let (body, crc) = b.split_last_chunk::<4>()?;
        if crc32fast::hash(body) != u32::from_le_bytes(*crc) {
            return None;
        }
        let mut r = Reader { b: body, at: 0 };
        let u64s = |r: &mut Reader| Some(u64::from_le_bytes(r.take()?));
        let n = usize::try_from(u64s(&mut r)?).ok()?;
        if n.checked_mul(20)? > body.len() {
            return None;
        }
        let mut at = Vec::with_capacity(n);
        let mut next = 0;
        for _ in 0..n {
            let (o, l, c) = (u64s(&mut r)?, u64s(&mut r)?, u32::from_le_bytes(r.take()?));
            // Objects lie one after another, before the table.
            if (next != 0 && o != next) || o.checked_add(l)? > start {
                return None;
            }
            next = o + l;
            at.push((o, l, c));
        }
        let raw_bytes = u64s(&mut r)?;
        let bounds = match r.take::<1>()?[0] {
            0 => None,
            1 => {
                let lo = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
                let hi = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
                Some((lo, hi))
            }
            _ => return None,
        };
        let largest = u64s(&mut r)?;
        let (t, d, s) = (u64s(&mut r)?, u64s(&mut r)?, u64s(&mut r)?);
        let warnings = (0..u64s(&mut r)?)
            .map(|_| {
                let len = usize::try_from(u64s(&mut r)?).ok()?;
                String::from_utf8(r.bytes(len)?.to_vec()).ok()
            })
            .collect::<Option<Vec<_>>>()?;
        if u64s(&mut r)? != start || r.at != body.len() {
            return None;
        }
        Some(Table {
            at,
            raw_bytes,
            bounds,
            largest,
            stats: ImportStats {
                triangles: t,
                degenerate_triangles_dropped: d,
                skipped_primitives: s,
                warnings,
                ..Default::default()
            },
        })
    }
}

/// Objects spilled to disk ([`SpillWriter`]).
pub struct Spill {
    dir: PathBuf,
    file: File,
    table: Table,
    bytes: u64,
    cache: Mutex<Cache>,
}

impl Spill {
    /// The spill file's size.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// What the import that made it said.
    pub fn stats(&self) -> &ImportStats {
        &self.table.stats
    }

    /// A named spill another process wrote ([`SpillWriter::create_named`])
    /// for the plan `id`; `None` when there is none at `path`, or it is
    /// not whole, not a spill, or another plan's (then it is made again).
    pub fn open(path: &Path, id: &str, cache_bytes: u64) -> Option<Spill> {
        let file = File::open(path).ok()?;
        let len = file.metadata().ok()?.len();
        let head = SPILL_MAGIC.len() as u64 + 4 + id.len() as u64;
        if len < head + 12 {
            return None;
        }
        let mut h = vec![0u8; head as usize];
        file.read_exact_at(&mut h, 0).ok()?;
        let mut expect = SPILL_MAGIC.to_vec();
        expect.extend_from_slice(&(id.len() as u32).to_le_bytes());
        expect.extend_from_slice(id.as_bytes());
        if h != expect {
            return None;
        }
        let mut tail = [0u8; 12];
        file.read_exact_at(&mut tail, len - 12).ok()?;
        let start = u64::from_le_bytes(tail[..8].try_into().ok()?);
        if start < head || start > len - 12 {
            return None;
        }
        let mut t = vec![0u8; (len - start) as usize];
        file.read_exact_at(&mut t, start).ok()?;
        let table = Table::decode(&t, start)?;
        if table.at.first().is_some_and(|a| a.0 != head) {
            return None;
        }
        Some(Spill {
            dir: path.to_path_buf(),
            file,
            bytes: len,
            cache: Mutex::new(Cache {
                limit: cache_bytes.max(table.largest),
                ..Default::default()
            }),
            table,
        })
    }

    fn read(&self, i: u32) -> Result<Object, SpillError> {
        let err = |reason: String| SpillError {
            dir: self.dir.clone(),
            object: i,
            reason,
        };
        let &(offset, len, crc) = self
            .table
            .at
            .get(i as usize)
            .ok_or_else(|| err(format!("only {} objects", self.table.at.len())))?;
        let mut bytes = vec![0u8; len as usize];
        self.file
            .read_exact_at(&mut bytes, offset)
            .map_err(|e| err(e.to_string()))?;
        if crc32fast::hash(&bytes) != crc {
            return Err(err(
                "its checksum does not match (remove the file to make it again)".into(),
            ));
        }
        decode(&bytes).ok_or_else(|| err("its bytes do not decode".into()))
    }
}

impl Source for Spill {
    fn len(&self) -> usize {
        self.table.at.len()
    }
    fn object(&self, i: u32) -> Result<ObjectRef<'_>, SpillError> {
        let lock = || self.cache.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(o) = lock().get(i) {
            return Ok(ObjectRef::Shared(o));
        }
        // Read outside the lock, so threads read different objects at once.
        let o = Arc::new(self.read(i)?);
        lock().put(i, o.clone());
        Ok(ObjectRef::Shared(o))
    }
    fn raw_bytes(&self) -> u64 {
        self.table.raw_bytes
    }
    fn bounds(&self) -> Option<(DVec3, DVec3)> {
        self.table.bounds
    }
}

/// Objects read back, least recently used dropped first once they hold
/// more than `limit` bytes; every operation O(log n) in the objects held.
#[derive(Default)]
struct Cache {
    limit: u64,
    held: u64,
    tick: u64,
    /// Object: it, when it was last used, its bytes.
    entries: HashMap<u32, (Arc<Object>, u64, u64)>,
    /// When each held object was last used: the oldest first.
    by_use: std::collections::BTreeMap<u64, u32>,
}

impl Cache {
    fn touch(&mut self, i: u32) -> u64 {
        self.tick += 1;
        let tick = self.tick;
        if let Some(e) = self.entries.get_mut(&i) {
            self.by_use.remove(&e.1);
            e.1 = tick;
            self.by_use.insert(tick, i);
        }
        tick
    }

    fn get(&mut self, i: u32) -> Option<Arc<Object>> {
        self.touch(i);
        self.entries.get(&i).map(|e| e.0.clone())
    }

    fn put(&mut self, i: u32, o: Arc<Object>) {
        if self.entries.contains_key(&i) {
            // Another thread read it meanwhile.
            self.touch(i);
            return;
        }
        self.tick += 1;
        let bytes = resident_bytes(&o);
        self.entries.insert(i, (o, self.tick, bytes));
        self.by_use.insert(self.tick, i);
        self.held += bytes;
        while self.held > self.limit && self.entries.len() > 1 {
            let Some((_, oldest)) = self.by_use.pop_first() else {
                break;
            };
            if let Some(e) = self.entries.remove(&oldest) {
                self.held -= e.2;
            }
        }
    }
}

// One object's bytes, little-endian: name length (u32) and UTF-8 name;
// its identity (name, path, file: each a u32 length and UTF-8; extras the
// same, length u32::MAX when absent; node index as u64, u64::MAX when
// absent); colour (4 f32); vertex and index counts (u64 each); a flag (u8, 1 when
// vertex colours follow); positions (3 f64 each), normals (3 f32 each),
// indices (u32), vertex colours (4 f32 each).

fn encode(o: &Object) -> Vec<u8> {
    let nv = o.positions.len();
    let vc = o.vertex_colours.as_ref();
    let mut b = Vec::with_capacity(
        4 + o.name.len() + 33 + 36 * nv + 4 * o.indices.len() + vc.map_or(0, |_| 16 * nv),
    );
    let mut string = |s: &str| {
        b.extend_from_slice(&(s.len() as u32).to_le_bytes());
        b.extend_from_slice(s.as_bytes());
    };
    let id = &o.identity;
    string(&o.name);
    string(&id.name);
    string(&id.path);
    string(&id.file);
    match &id.extras {
        Some(e) => string(e),
        None => b.extend_from_slice(&u32::MAX.to_le_bytes()),
    }
    b.extend_from_slice(&id.node.map_or(u64::MAX, |n| n as u64).to_le_bytes());
    for c in o.colour {
        b.extend_from_slice(&c.to_le_bytes());
    }
    b.extend_from_slice(&(nv as u64).to_le_bytes());
    b.extend_from_slice(&(o.indices.len() as u64).to_le_bytes());
    b.push(vc.is_some() as u8);
    for p in &o.positions {
        for x in p.to_array() {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    for n in &o.normals {
        for x in n.to_array() {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in &o.indices {
        b.extend_from_slice(&i.to_le_bytes());
    }
    for c in vc.into_iter().flatten() {
        for x in c {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    b
}

/// Reads [`encode`]'s bytes; `None` when they do not fit.
fn decode(b: &[u8]) -> Option<Object> {
    let mut r = Reader { b, at: 0 };
    let name = r.string()?;
    let identity = Identity {
        name: r.string()?,
        path: r.string()?,
        file: r.string()?,
        extras: {
            let save = r.at;
            if u32::from_le_bytes(r.take()?) == u32::MAX {
                None
            } else {
                r.at = save;
                Some(r.string()?)
            }
        },
        node: match u64::from_le_bytes(r.take()?) {
            u64::MAX => None,
            n => Some(usize::try_from(n).ok()?),
        },
    };
    let colour = [r.f32()?, r.f32()?, r.f32()?, r.f32()?];
    let nv = usize::try_from(u64::from_le_bytes(r.take()?)).ok()?;
    let ni = usize::try_from(u64::from_le_bytes(r.take()?)).ok()?;
    let has_vc = r.take::<1>()?[0] == 1;
    // Counts are checked against the bytes before anything is allocated.
    let need = nv
        .checked_mul(36 + if has_vc { 16 } else { 0 })?
        .checked_add(ni.checked_mul(4)?)?;
    if need != b.len() - r.at {
        return None;
    }
    let positions = (0..nv)
        .map(|_| Some(DVec3::new(r.f64()?, r.f64()?, r.f64()?)))
        .collect::<Option<Vec<_>>>()?;
    let normals = (0..nv)
        .map(|_| Some(Vec3::new(r.f32()?, r.f32()?, r.f32()?)))
        .collect::<Option<Vec<_>>>()?;
    let indices = (0..ni)
        .map(|_| Some(u32::from_le_bytes(r.take()?)))
        .collect::<Option<Vec<_>>>()?;
    let vertex_colours = if has_vc {
        Some(
            (0..nv)
                .map(|_| Some([r.f32()?, r.f32()?, r.f32()?, r.f32()?]))
                .collect::<Option<Vec<_>>>()?,
        )
    } else {
        None
    };
    Some(Object {
        name,
        positions,
        normals,
        indices,
        colour,
        vertex_colours,
        identity,
    })
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn bytes(&mut self, n: usize) -> Option<&[u8]> {
        let s = self.b.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        self.bytes(N)?.try_into().ok()
    }
    fn f32(&mut self) -> Option<f32> {
        Some(f32::from_le_bytes(self.take()?))
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_le_bytes(self.take()?))
    }
    fn string(&mut self) -> Option<String> {
        let n = u32::from_le_bytes(self.take()?) as usize;
        String::from_utf8(self.bytes(n)?.to_vec()).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn object(k: u32, colours: bool) -> Object {
        let nv = 3 + k as usize;
        Object {
            name: format!("part {k} \u{e9}"),
            positions: (0..nv)
                .map(|i| DVec3::new(i as f64, 1e7 + k as f64, -0.5 * i as f64))
                .collect(),
            normals: (0..nv).map(|i| Vec3::new(0.0, 1.0, i as f32)).collect(),
            indices: (0..nv as u32 - 2).flat_map(|i| [0, i + 1, i + 2]).collect(),
            colour: [0.1, 0.2, 0.3, 1.0],
            vertex_colours: colours.then(|| vec![[0.5, 0.25, 1.0, 1.0]; nv]),
            identity: Identity {
                name: format!("n{k}"),
                path: format!("root/n{k}"),
                file: "f.glb".into(),
                extras: k.is_multiple_of(2).then(|| format!("{{\"k\":{k}}}")),
                node: (!k.is_multiple_of(3)).then_some(k as usize),
            },
        }
    }

    #[test]
    fn objects_read_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let model = Model {
            objects: (0..50).map(|k| object(k, k % 3 == 0)).collect(),
            ..Default::default()
        };
        let mut w = SpillWriter::create_in(dir.path()).unwrap();
        for o in &model.objects {
            w.push(o).unwrap();
        }
        assert_eq!(w.len(), 50);
        // A cache of one object at a time: every read after the first
        // few goes back to the file.
        let spill = w.finish(0, &ImportStats::default()).unwrap();
        assert_eq!(spill.len(), 50);
        for k in [0u32, 7, 49, 7, 3, 0] {
            assert_eq!(*spill.object(k).unwrap(), model.objects[k as usize]);
        }
        assert_eq!(spill.raw_bytes(), Source::raw_bytes(&model));
        assert_eq!(spill.bounds(), Source::bounds(&model));
        assert!(spill.object(50).is_err());
        // Nothing is left in the directory: the file has no name.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn a_model_over_the_budget_spills_midway_and_reads_back_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let mut files = Vec::new();
        for f in 0..3 {
            let path = dir.path().join(format!("m{f}.obj"));
            let mut text = String::new();
            for g in 0..4 {
                let z = (f * 4 + g) as f64;
                text += &format!("o part{g}\nv 0 0 {z}\nv 1 0 {z}\nv 0 1 {z}\n");
                let b = 3 * g + 1;
                text += &format!("f {} {} {}\n", b, b + 1, b + 2);
            }
            std::fs::write(&path, text).unwrap();
            files.push(path);
        }
        let whole = gigawalk_import::import_all(&files, &mut |_, _, _| {}).unwrap();
        let held = import_within(&files, None, dir.path(), &mut |_, _, _| {}).unwrap();
        assert!(matches!(held, Imported::Memory(_)));
        assert_eq!(held.spilled_bytes(), 0);
        // Five objects fit the budget's share; the sixth spills them all.
        let one = resident_bytes(&whole.objects[0]);
        let budget = ((5 * one) as f64 / MEMORY_SHARE) as u64 + 1;
        let spilled = import_within(&files, Some(budget), dir.path(), &mut |_, _, _| {}).unwrap();
        assert!(matches!(spilled, Imported::Spilled(..)));
        assert!(spilled.spilled_bytes() > 0);
        let s = spilled.source();
        assert_eq!(s.len(), whole.objects.len());
        for (i, o) in whole.objects.iter().enumerate() {
            assert_eq!(*s.object(i as u32).unwrap(), *o, "object {i}");
        }
        assert_eq!(spilled.stats(), &whole.stats);
        assert_eq!(s.bounds(), Source::bounds(&whole));
        // The spill has no name: only the model files are in the directory.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 3);
    }

    #[test]
    fn a_named_spill_opens_elsewhere_and_refuses_what_is_not_its_own() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.spill");
        let objects: Vec<Object> = (0..20).map(|k| object(k, k % 2 == 0)).collect();
        let stats = ImportStats {
            triangles: 7,
            warnings: vec!["w1".into(), "w\u{e9}2".into()],
            ..Default::default()
        };
        let mut w = SpillWriter::create_named(&path, "plan-a").unwrap();
        for o in &objects {
            w.push(o).unwrap();
        }
        // Not in place until whole.
        assert!(!path.exists());
        let written = w.finish(0, &stats).unwrap();
        let s = Spill::open(&path, "plan-a", 0).expect("whole and its own");
        assert_eq!(s.stats(), &stats);
        assert_eq!(s.len(), 20);
        assert_eq!(s.bounds(), written.bounds());
        assert_eq!(s.raw_bytes(), written.raw_bytes());
        for k in [19u32, 0, 5] {
            assert_eq!(*s.object(k).unwrap(), objects[k as usize]);
        }
        assert!(Spill::open(&path, "plan-b", 0).is_none());
        assert!(Spill::open(&dir.path().join("none"), "plan-a", 0).is_none());
        let bytes = std::fs::read(&path).unwrap();
        for cut in [0, 10, bytes.len() / 2, bytes.len() - 1] {
            std::fs::write(&path, &bytes[..cut]).unwrap();
            assert!(Spill::open(&path, "plan-a", 0).is_none(), "cut at {cut}");
        }
        // A flipped byte in the table: refused; in an object: that
        // object's read is an error, the others read.
        let mut b = bytes.clone();
        let n = b.len();
        b[n - 20] ^= 1;
        std::fs::write(&path, &b).unwrap();
        assert!(Spill::open(&path, "plan-a", 0).is_none());
        let mut b = bytes.clone();
        b[60] ^= 1;
        std::fs::write(&path, &b).unwrap();
        let s = Spill::open(&path, "plan-a", 0).unwrap();
        let e = s.object(0).map(|_| ()).unwrap_err();
        assert!(e.reason.contains("checksum"), "{e}");
        assert_eq!(*s.object(1).unwrap(), objects[1]);
    }

    #[test]
    fn the_cache_drops_the_least_recently_used_first() {
        let o = Arc::new(object(2, false));
        let each = resident_bytes(&o);
        let mut c = Cache {
            limit: 3 * each,
            ..Default::default()
        };
        for i in 0..3 {
            c.put(i, o.clone());
        }
        assert!(c.get(0).is_some());
        c.put(3, o.clone());
        // 1 was the least recently used.
        assert!(c.get(1).is_none());
        for i in [0, 2, 3] {
            assert!(c.get(i).is_some(), "{i}");
        }
        c.put(3, o.clone());
        assert_eq!((c.entries.len(), c.by_use.len(), c.held), (3, 3, 3 * each));
    }

    #[test]
    fn bad_bytes_do_not_decode() {
        let bytes = encode(&object(4, true));
        assert!(decode(&bytes).is_some());
        for cut in [0, 1, 10, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..cut]).is_none(), "cut at {cut}");
        }
        let mut huge = bytes.clone();
        let at = 4 + object(4, true).name.len() + 16;
        huge[at..at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        assert!(decode(&huge).is_none());
    }
}
