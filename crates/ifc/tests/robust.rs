//! Bad input never panics: a real file cut at many places, and with bytes
//! overwritten at random, either reads or fails with an error.

use gigawalk_ifc::IfcFile;

fn models() -> Option<std::path::PathBuf> {
    gigawalk_testkit::models::shared_ifc_models()
}

/// Parses and reads `bytes`; true when it read objects.
fn read(bytes: Vec<u8>) -> bool {
    match IfcFile::parse(bytes, "t.ifc") {
        Ok(f) => f.read(&mut |_| true).is_ok(),
        Err(e) => {
            assert!(e.to_string().starts_with("t.ifc: "), "{e}");
            false
        }
    }
}

/// xorshift64: reproducible positions and bytes.
fn next(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

#[test]
fn a_file_cut_anywhere_is_an_error_not_a_panic() {
    let Some(dir) = models() else { return };
    let bytes = std::fs::read(dir.join("revit2014_unicode.ifc")).unwrap();
    assert!(read(bytes.clone()));
    let end = bytes.windows(6).rposition(|w| w == b"ENDSEC").unwrap();
    for k in 0..200 {
        let cut = end * k / 200;
        let e = IfcFile::parse(bytes[..cut].to_vec(), "t.ifc").err();
        let e = e
            .unwrap_or_else(|| panic!("a file cut at {cut} parsed"))
            .to_string();
        assert!(
            e.contains("truncated") || e.contains("empty file") || e.contains("not a STEP"),
            "cut at {cut}: {e}"
        );
    }
}

#[test]
fn overwritten_bytes_give_errors_or_objects_never_panics() {
    let Some(dir) = models() else { return };
    for name in [
        "revit2014_unicode.ifc",
        "slab-standard-case.ifc",
        "basin-advanced-brep.ifc",
    ] {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let alphabet = b"#0123456789.,()'$*-E;=XABC \\";
        let (mut read_ok, mut failed) = (0, 0);
        for _ in 0..300 {
            let mut b = bytes.clone();
            for _ in 0..1 + next(&mut state) % 4 {
                let at = (next(&mut state) % b.len() as u64) as usize;
                b[at] = alphabet[(next(&mut state) % alphabet.len() as u64) as usize];
            }
            if read(b) {
                read_ok += 1;
            } else {
                failed += 1;
            }
        }
        println!("{name}: {read_ok} read, {failed} refused");
        assert_eq!(read_ok + failed, 300);
    }
}
