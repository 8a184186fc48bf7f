//! The rules of ARCHITECTURE.md that a machine can check:
//! - the crate dependency arrows are the ones it draws: each workspace
//!   crate's gigawalk dependencies (normal, not dev) as `cargo metadata`
//!   reports them, against the `deps` block there;
//! - the threads block names every source file that starts a thread of
//!   its own (`std::thread` spawns, scopes and builders; rayon's pool
//!   running data-parallel loops is not one), outside test modules;
//! - gigawalk-cull holds culling alone: the reviewer state (selection,
//!   find, hide, saved views, sections, the fly controller) is
//!   gigawalk-review's, which depends on it, never the reverse;
//! - only gigawalk-gpu depends on wgpu, and no source file outside it,
//!   tests and benches included, names it;
//! - only gigawalk-serve depends on an HTTP stack (hyper, tokio,
//!   tower-http, axum), in any kind of dependency, and no source file
//!   outside it names one; the CLI's `serve.rs` holds no server of its
//!   own (no socket, no thread).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

type Arrows = BTreeMap<String, Vec<String>>;

/// A block of ARCHITECTURE.md fenced as `tag`: `crate: item ...` per
/// line, items sorted.
fn block(doc: &str, tag: &str) -> Arrows {
    let fence = format!("```{tag}");
    let start = doc
        .find(&fence)
        .unwrap_or_else(|| panic!("ARCHITECTURE.md has a {fence} block"));
    let body = &doc[start + fence.len()..];
    let end = body.find("```").expect("the block ends");
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

/// The `deps` block of ARCHITECTURE.md: `crate: dependency ...` per line.
fn drawn(doc: &str) -> Arrows {
    block(doc, "deps")
}

fn architecture_md() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/ARCHITECTURE.md"))
        .expect("ARCHITECTURE.md")
}

/// `cargo metadata` of the workspace's own packages, run once for every
/// test of this file.
fn metadata() -> &'static [serde_json::Value] {
    static PACKAGES: OnceLock<Vec<serde_json::Value>> = OnceLock::new();
    PACKAGES.get_or_init(run_metadata)
}

fn run_metadata() -> Vec<serde_json::Value> {
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
    meta["packages"].as_array().expect("packages").clone()
}

/// Each package's normal (not dev) dependencies whose names `keep` keeps.
fn dependencies(keep: impl Fn(&str) -> bool) -> Arrows {
    metadata()
        .iter()
        .map(|p| {
            let mut deps: Vec<String> = p["dependencies"]
                .as_array()
                .expect("dependencies")
                .iter()
                .filter(|d| d["kind"].is_null())
                .filter_map(|d| d["name"].as_str())
                .filter(|n| keep(n))
                .map(String::from)
                .collect();
            deps.sort();
            (p["name"].as_str().expect("name").to_string(), deps)
        })
        .collect()
}

/// What `cargo metadata` says the workspace's crates depend on.
fn actual() -> Arrows {
    dependencies(|n| n.starts_with("gigawalk"))
}

/// Every package's name and directory, deepest first, so a file belongs
/// to the first whose directory holds it (the root package holds the
/// others' directories).
fn packages() -> Vec<(String, PathBuf)> {
    let mut out: Vec<(String, PathBuf)> = metadata()
        .iter()
        .map(|p| {
            let manifest = PathBuf::from(p["manifest_path"].as_str().expect("manifest_path"));
            let dir = manifest
                .parent()
                .expect("a manifest's folder")
                .to_path_buf();
            (p["name"].as_str().expect("name").to_string(), dir)
        })
        .collect();
    out.sort_by_key(|(_, d)| std::cmp::Reverse(d.components().count()));
    out
}

/// The `.rs` files below `dir`, skipping build output, hidden folders and
/// the fuzz targets (outside the workspace).
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let path = e.path();
        let name = e.file_name().to_string_lossy().to_string();
        if path.is_dir() {
            if !(name.starts_with('.') || name == "target" || name == "fuzz") {
                rust_files(&path, out);
            }
        } else if name.ends_with(".rs") {
            out.push(path);
        }
    }
}

/// Every workspace `.rs` file with its package's name and its path
/// within that package.
fn sources() -> Vec<(String, String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(root, &mut files);
    let packages = packages();
    files
        .into_iter()
        .filter_map(|f| {
            let (name, dir) = packages.iter().find(|(_, d)| f.starts_with(d))?;
            let rel = f
                .strip_prefix(dir)
                .ok()?
                .to_string_lossy()
                .replace('\\', "/");
            let text = std::fs::read_to_string(&f).ok()?;
            Some((name.clone(), rel, text))
        })
        .collect()
}

/// Whether library or binary code (not a test module) starts a thread.
fn starts_threads(text: &str) -> bool {
    let code = text.split("#[cfg(test)]\nmod tests {").next().unwrap_or("");
    [
        "thread::spawn",
        "thread::scope",
        "thread::Builder",
        "spawn_scoped",
    ]
    .iter()
    .any(|p| code.contains(p))
}

#[test]
fn crate_dependencies_are_the_ones_architecture_md_draws() {
    let doc = architecture_md();
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

#[test]
fn only_the_files_architecture_md_names_start_threads() {
    let mut found = Arrows::new();
    for (package, file, text) in sources() {
        let in_src = file.starts_with("src/");
        if in_src && starts_threads(&text) {
            found.entry(package).or_default().push(file);
        }
    }
    for files in found.values_mut() {
        files.sort();
    }
    let drawn: Arrows = block(&architecture_md(), "threads")
        .into_iter()
        .filter(|(_, files)| !files.is_empty())
        .collect();
    assert_eq!(
        found, drawn,
        "a thread started where ARCHITECTURE.md's threads block does not say (or no longer started where it does)"
    );
}

/// Whether `file` (a path within gigawalk-cull) is one of the reviewer
/// state's modules, which live in gigawalk-review.
fn is_reviewer_state(file: &str) -> bool {
    let Some(module) = file.strip_prefix("src/") else {
        return false;
    };
    ["review.rs", "select.rs", "fly.rs"].contains(&module) || module.starts_with("review/")
}

#[test]
fn the_culling_core_holds_no_reviewer_state() {
    let in_cull: Vec<String> = sources()
        .into_iter()
        .filter(|(package, file, _)| package == "gigawalk-cull" && is_reviewer_state(file))
        .map(|(_, file, _)| file)
        .collect();
    assert!(
        in_cull.is_empty(),
        "reviewer state in gigawalk-cull (it belongs in gigawalk-review): {in_cull:?}"
    );
    let naming: Vec<String> = sources()
        .into_iter()
        .filter(|(package, _, text)| package == "gigawalk-cull" && text.contains("gigawalk_review"))
        .map(|(_, file, _)| file)
        .collect();
    assert!(
        naming.is_empty(),
        "gigawalk-cull names gigawalk-review: {naming:?}"
    );
}

#[test]
fn is_reviewer_state_sees_the_modules_and_nothing_else() {
    assert!(is_reviewer_state("src/review.rs"));
    assert!(is_reviewer_state("src/review/objects.rs"));
    assert!(is_reviewer_state("src/select.rs"));
    assert!(is_reviewer_state("src/fly.rs"));
    assert!(!is_reviewer_state("src/pick.rs"));
    assert!(!is_reviewer_state("src/visibility.rs"));
    assert!(!is_reviewer_state("examples/fly.rs"));
}

#[test]
fn only_the_gpu_crate_names_wgpu() {
    let with_wgpu: Vec<String> = dependencies(|n| n == "wgpu")
        .into_iter()
        .filter(|(_, deps)| !deps.is_empty())
        .map(|(name, _)| name)
        .collect();
    assert_eq!(with_wgpu, ["gigawalk-gpu"], "crates that depend on wgpu");
    let naming: Vec<String> = sources()
        .into_iter()
        // This file names wgpu only in the patterns it looks for.
        .filter(|(package, file, text)| {
            package != "gigawalk-gpu"
                && file != file!()
                && (text.contains("wgpu::") || text.contains("use wgpu"))
        })
        .map(|(package, file, _)| format!("{package}: {file}"))
        .collect();
    assert!(
        naming.is_empty(),
        "wgpu named outside gigawalk-gpu: {naming:?}"
    );
}

/// The crates an HTTP server is made of, and the paths code names them by.
const HTTP_STACK: [(&str, &str); 4] = [
    ("hyper", "hyper::"),
    ("tokio", "tokio::"),
    ("tower-http", "tower_http::"),
    ("axum", "axum::"),
];

#[test]
fn only_the_serve_crate_speaks_http() {
    let with_http: Vec<String> = metadata()
        .iter()
        .filter(|p| {
            p["dependencies"]
                .as_array()
                .expect("dependencies")
                .iter()
                .filter_map(|d| d["name"].as_str())
                .any(|n| HTTP_STACK.iter().any(|(c, _)| *c == n))
        })
        .map(|p| p["name"].as_str().expect("name").to_string())
        .collect();
    assert_eq!(
        with_http,
        ["gigawalk-serve"],
        "crates that depend on an HTTP stack"
    );
    let naming: Vec<String> = sources()
        .into_iter()
        // This file names them only in the patterns it looks for.
        .filter(|(package, file, text)| {
            package != "gigawalk-serve"
                && file != file!()
                && HTTP_STACK.iter().any(|(_, path)| text.contains(path))
        })
        .map(|(package, file, _)| format!("{package}: {file}"))
        .collect();
    assert!(
        naming.is_empty(),
        "an HTTP stack named outside gigawalk-serve: {naming:?}"
    );

    // `gigawalk serve` parses its flags and calls the crate.
    let (_, _, cli) = sources()
        .into_iter()
        .find(|(package, file, _)| package == "gigawalk" && file == "src/serve.rs")
        .expect("tools/gigawalk/src/serve.rs");
    let server_words = [
        "TcpListener",
        "TcpStream",
        "std::net",
        "hyper",
        "tokio",
        "Content-Range",
        "fn answer",
    ];
    let found: Vec<&str> = server_words
        .into_iter()
        .filter(|w| cli.contains(w))
        .collect();
    assert!(
        found.is_empty() && !starts_threads(&cli),
        "the CLI's serve.rs serves (it names {found:?}); that belongs in crates/serve"
    );
}

#[test]
fn starts_threads_sees_spawns_and_scopes_but_not_test_modules() {
    assert!(starts_threads("fn f() { std::thread::scope(|s| {}); }"));
    assert!(starts_threads(
        "use std::thread;\nfn f() { thread::spawn(|| {}); }"
    ));
    assert!(!starts_threads(
        "fn f() {}\n#[cfg(test)]\nmod tests {\n    fn g() { std::thread::spawn(|| {}); }\n}"
    ));
    // A test module in a file of its own hides nothing after it.
    assert!(starts_threads(
        "#[cfg(test)]\nmod tests;\nfn f() { std::thread::scope(|s| {}); }"
    ));
    assert!(!starts_threads(
        "let n = std::thread::available_parallelism();"
    ));
}

/// What running the stages means in code: the culling and drawing parts
/// only a schedule of the runtime puts together.
const STAGE_PARTS: [&str; 7] = [
    "Traverser",
    "DepthPass",
    "Hzb::",
    "HzbOcclusion",
    "GeometryPool",
    "reselect_lods",
    "fn gpu_view",
];

#[test]
fn the_page_runs_the_runtimes_schedule_and_keeps_no_copy_of_it() {
    let copies: Vec<String> = sources()
        .into_iter()
        .filter(|(package, _, _)| package == "gigawalk-web")
        .flat_map(|(_, file, text)| {
            STAGE_PARTS
                .iter()
                .filter(|p| text.contains(*p))
                .map(|p| format!("{file}: {p}"))
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(
        copies.is_empty(),
        "the page runs stages of its own (it steps gigawalk-runtime's schedule): {copies:?}"
    );
    let stepped = sources().into_iter().any(|(package, file, text)| {
        package == "gigawalk-web" && file.starts_with("src/") && text.contains("Stepped")
    });
    assert!(stepped, "the page no longer steps the runtime's schedule");
}

#[test]
fn the_scene_crate_knows_nothing_about_threads() {
    let naming: Vec<String> = sources()
        .into_iter()
        .filter(|(package, file, text)| {
            package == "gigawalk-scene"
                && file.starts_with("src/")
                && (starts_threads(text)
                    || ["NbWorkers", "rayon::", "std::thread"]
                        .iter()
                        .any(|p| text.contains(p)))
        })
        .map(|(_, file, _)| file)
        .collect();
    assert!(
        naming.is_empty(),
        "gigawalk-scene starts or asks for threads: {naming:?}"
    );
}

#[test]
fn every_adapter_the_gpu_crate_asks_for_passes_the_capability_check() {
    let unchecked: Vec<String> = sources()
        .into_iter()
        .filter(|(package, file, text)| {
            package == "gigawalk-gpu"
                && file.starts_with("src/")
                && text.contains("request_adapter(")
                && text.matches("request_adapter(").count() > text.matches(".qualifies()").count()
        })
        .map(|(_, file, _)| file)
        .collect();
    assert!(
        unchecked.is_empty(),
        "an adapter asked for without `AdapterReport::qualifies` (capabilities.rs): {unchecked:?}"
    );
}
