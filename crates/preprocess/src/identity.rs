//! Object identity through preprocessing: the scene's object table
//! (docs/scene-format.md, "OBJT") and the runs of each leaf's full
//! detail.
//!
//! An imported object is a glTF primitive or an OBJ group; a user's object
//! is a glTF node or an OBJ group, so consecutive imported objects of the
//! same node ([`Identity::same_object`]) are one table entry. Partition-I's
//! pieces keep their imported object's index, and clustering and
//! Partition-II keep each part's pieces one per imported object in index
//! order, so a leaf's full-detail mesh ([`crate::hlod::leaf_mesh`]) is its
//! pieces' triangles in piece order: runs of triangles per entry.

use gigawalk_import::{Identity, Object};
use gigawalk_scene::objects::{ObjectRecord, ObjectRun, ObjectTable};
use gigawalk_scene::Aabb;

/// What the table needs of one imported object, taken while it is checked.
#[derive(Clone, Debug)]
pub(crate) struct Seen {
    pub index: u32,
    pub identity: Identity,
    /// Its object's name in messages, for an identity the file left empty
    /// (empty otherwise).
    pub label: String,
    pub bounds: Aabb,
    pub triangles: u64,
}

impl Seen {
    pub fn of(index: u32, o: &Object, bounds: Aabb, triangles: u64) -> Seen {
        Seen {
            index,
            identity: o.identity.clone(),
            label: if o.identity.path.is_empty() {
                o.name.clone()
            } else {
                String::new()
            },
            bounds,
            triangles,
        }
    }
}

/// The table's entries and which entry each imported object is.
#[derive(Clone, Debug, Default)]
pub(crate) struct Identities {
    /// Imported object -> table entry (`u32::MAX` for an object with no
    /// triangles left).
    entry: Vec<u32>,
    records: Vec<ObjectRecord>,
}

impl Identities {
    /// From every imported object that kept triangles, in index order, of
    /// `objects` in all.
    pub fn new(objects: usize, seen: Vec<Seen>) -> Identities {
        let mut entry = vec![u32::MAX; objects];
        let mut records: Vec<ObjectRecord> = Vec::new();
        let mut last: Option<Identity> = None;
        for s in seen {
            // An identity the importer left empty (objects made in memory)
            // is an object of its own, named as in messages.
            let anonymous = s.identity.path.is_empty();
            let joins = !anonymous && last.as_ref().is_some_and(|l| l.same_object(&s.identity));
            if joins {
                let r = records.last_mut().unwrap_or_else(|| unreachable!());
                r.bounds = r.bounds.union(&s.bounds);
                r.triangles += s.triangles;
            } else {
                let id = &s.identity;
                records.push(ObjectRecord {
                    name: if anonymous {
                        s.label.clone()
                    } else {
                        id.name.clone()
                    },
                    path: if anonymous {
                        s.label.clone()
                    } else {
                        id.path.clone()
                    },
                    file: id.file.clone(),
                    metadata: id.extras.clone(),
                    bounds: s.bounds,
                    triangles: s.triangles,
                });
            }
            entry[s.index as usize] = records.len() as u32 - 1;
            last = (!anonymous).then_some(s.identity);
        }
        Identities { entry, records }
    }

    /// A leaf's runs: its pieces' triangles per table entry, in order.
    /// `pieces` gives each piece's model object and triangle count.
    pub fn runs(&self, pieces: impl IntoIterator<Item = (u32, u32)>) -> Vec<ObjectRun> {
        let mut runs: Vec<ObjectRun> = Vec::new();
        for (model_object, triangles) in pieces {
            let object = self.entry[model_object as usize];
            match runs.last_mut() {
                Some(r) if r.object == object => r.triangles += triangles,
                _ => runs.push(ObjectRun { object, triangles }),
            }
        }
        runs
    }

    /// The table, with each leaf LOD's runs (LODs ascending).
    pub fn table(&self, lod_runs: Vec<(u32, Vec<ObjectRun>)>) -> ObjectTable {
        ObjectTable::new(self.records.clone(), lod_runs)
    }

    pub fn len(&self) -> usize {
        self.records.len()
    }
}

/// The object table's body is compressed (zstd level 19) in jobs of this
/// many bytes on worker threads, each job seeing the data before it as
/// zstd's multithreaded mode gives it (the ratio is that of one thread),
/// into one frame whose bytes do not depend on the number of workers.
pub(crate) const COMPRESSION_JOB_BYTES: usize = 2 << 20;

/// `body` as one zstd frame compressed on `workers` (at least one) worker
/// threads; `None` if zstd fails (the table is then stored plain).
pub(crate) fn compress(body: &[u8], workers: usize) -> Option<Vec<u8>> {
    use zstd::stream::raw::CParameter;
    let mut z = zstd::bulk::Compressor::new(19).ok()?;
    // One worker or more, never the single-threaded mode, whose bytes
    // differ from the multithreaded mode's.
    z.set_parameter(CParameter::NbWorkers(workers.clamp(1, 64) as u32))
        .ok()?;
    z.set_parameter(CParameter::JobSize(COMPRESSION_JOB_BYTES as u32))
        .ok()?;
    z.compress(body).ok()
}

#[cfg(test)]
mod compression_tests {
    use super::*;

    /// A body of several compression jobs: one frame, the same bytes on
    /// one worker thread or several, decoded whole.
    #[test]
    fn a_big_table_compresses_in_jobs_the_same_on_any_number_of_threads() {
        let objects: Vec<ObjectRecord> = (0..60_000)
            .map(|i| ObjectRecord {
                name: format!("Part.{i:05}"),
                path: format!("Plant/Unit{}/Bay{}/Part.{i:05}", i % 7, i % 113),
                file: "plant.glb".into(),
                metadata: Some(r#"{"tag":"P-101"}"#.into()),
                bounds: Aabb::new(glam::DVec3::ZERO, glam::DVec3::ONE),
                triangles: (i * 7919 % 5000) as u64,
            })
            .collect();
        let t = ObjectTable::new(objects, Vec::new());
        let plain = t.encode();
        assert!(plain.len().div_ceil(COMPRESSION_JOB_BYTES) > 2);
        let one = t.encode_with(|b| compress(b, 1));
        assert!(one.len() < plain.len() / 2);
        assert_eq!(t.encode_with(|b| compress(b, 3)), one);
        assert_eq!(ObjectTable::decode(&one).unwrap(), t);
    }
}
