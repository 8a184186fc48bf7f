//! The crate dependency arrows are the ones ARCHITECTURE.md draws: each
//! workspace crate's gigawalk dependencies (normal, not dev) as
//! `cargo metadata` reports them, against the `deps` block there.

use std::collections::BTreeMap;
use std::process::Command;

type Arrows = BTreeMap<String, Vec<String>>;

/// The `deps` block of ARCHITECTURE.md: `crate: dependency ...` per line.
fn drawn(doc: &str) -> Arrows {
    let start = doc
        .find("```deps")
        .expect("ARCHITECTURE.md has a ```deps block");
    let body = &doc[start + "```deps".len()..];
    let end = body.find("```").expect("the deps block ends");
    body[..end]
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| {
            let (name, deps) = l.split_once(':').expect("`crate: deps` lines");
            let mut deps: Vec<String> = deps.split_whitespace().map(String::from).collect();
            deps.sort();
            (name.trim().to_string(), deps)
        })
        .collect()
}

/// What `cargo metadata` says the workspace's crates depend on.
fn actual() -> Arrows {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("metadata is JSON");
    meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| {
            let mut deps: Vec<String> = p["dependencies"]
                .as_array()
                .expect("dependencies")
                .iter()
                .filter(|d| d["kind"].is_null())
                .filter_map(|d| d["name"].as_str())
                .filter(|n| n.starts_with("gigawalk"))
                .map(String::from)
                .collect();
            deps.sort();
            (p["name"].as_str().expect("name").to_string(), deps)
        })
        .collect()
}

#[test]
fn crate_dependencies_are_the_ones_architecture_md_draws() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/ARCHITECTURE.md"))
        .expect("ARCHITECTURE.md");
    assert_eq!(
        actual(),
        drawn(&doc),
        "update the code or ARCHITECTURE.md's deps block"
    );
}

#[test]
fn the_deps_block_parses() {
    let d = drawn("x\n```deps\na:\nb: c a\n```\n");
    assert_eq!(d["a"], Vec::<String>::new());
    assert_eq!(d["b"], vec!["a".to_string(), "c".to_string()]);
}
