//! Opening a scene reads the header, table of contents and skeleton only:
//! no geometry byte is touched until a LOD is asked for.

mod common;

use std::cell::RefCell;
use std::io;

use gigawalk_scene::{ReadAt, SceneReader};

/// Records every byte range read.
struct Counting {
    bytes: Vec<u8>,
    reads: RefCell<Vec<(u64, u64)>>,
}

impl ReadAt for Counting {
    fn read_exact_at(&self, buf: &mut [u8], offset: u64) -> io::Result<()> {
        self.reads
            .borrow_mut()
            .push((offset, offset + buf.len() as u64));
        self.bytes.read_exact_at(buf, offset)
    }
    fn size(&self) -> io::Result<u64> {
        Ok(self.bytes.len() as u64)
    }
}

#[test]
fn open_reads_no_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    common::write_tree(&path, &common::wide(500, glam::DVec3::ZERO));
    let src = Counting {
        bytes: std::fs::read(&path).unwrap(),
        reads: RefCell::new(Vec::new()),
    };
    let r = SceneReader::from_source(&src, "s.gwk").unwrap();
    let geom = r
        .sections()
        .iter()
        .find(|s| s.name == "GEOM")
        .unwrap()
        .clone();
    assert!(
        geom.len > 500 * 60,
        "geometry section is {} bytes",
        geom.len
    );
    let overlaps = |&(a, b): &(u64, u64)| a < geom.offset + geom.len && geom.offset < b;
    let read: u64 = src.reads.borrow().iter().map(|(a, b)| b - a).sum();
    assert!(
        !src.reads.borrow().iter().any(overlaps),
        "open read geometry: {:?}",
        src.reads.borrow()
    );
    assert!(
        read < src.bytes.len() as u64 / 2,
        "open read {read} of {} bytes",
        src.bytes.len()
    );

    // Reading one LOD touches exactly that LOD's bytes.
    src.reads.borrow_mut().clear();
    let lod = r.skeleton().lods()[7];
    r.read_lod(7).unwrap();
    assert_eq!(
        *src.reads.borrow(),
        vec![(lod.offset, lod.offset + lod.len)]
    );
}
