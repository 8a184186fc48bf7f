//! Every link in the repository's markdown files leads somewhere: to a file
//! or directory that exists and, with a `#fragment`, to a heading of that
//! file (GitHub's anchors: lowercase, spaces to '-', punctuation dropped).
//! Links to other sites are not followed. Build output (`target/`), hidden
//! directories, the fuzzers' generated corpora and installed npm packages
//! are not read.

use std::collections::HashSet;
use std::path::{Component, Path, PathBuf};

/// Directories under the repository root that hold no documentation of
/// ours: build output, what the fuzzers generate, and the packages
/// that `npm ci` installs for the tiles clients and the page driver.
const SKIPPED: [&str; 6] = [
    "target",
    "fuzz/corpus",
    "fuzz/artifacts",
    "fuzz/target",
    "tests/tiles-clients/node_modules",
    "tests/web-page/node_modules",
];

#[test]
fn no_markdown_file_links_to_a_missing_file_or_heading() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let files = markdown_files(root);
    assert!(
        files.iter().any(|f| f.ends_with("README.md")),
        "found no README.md under {}",
        root.display()
    );
    let broken = broken_links(root, &files);
    assert!(
        broken.is_empty(),
        "links to nothing:\n{}",
        broken.join("\n")
    );
}

#[test]
fn a_link_to_a_missing_file_is_reported() {
    check(
        &[
            ("a.md", "# A\n\nSee [b](b.md) and [gone](gone.md).\n"),
            ("b.md", "# B\n"),
        ],
        &["a.md:3: gone.md: no such file"],
    );
}

#[test]
fn a_link_to_a_missing_heading_is_reported() {
    check(
        &[
            (
                "docs/a.md",
                "# A\n\n## Two words\n\n[here](#two-words), [there](../b.md#b-c), [no](#three), [nor](../b.md#d)\n",
            ),
            ("b.md", "# B: c\n"),
        ],
        &[
            "docs/a.md:5: #three: no such heading in docs/a.md",
            "docs/a.md:5: ../b.md#d: no such heading in b.md",
        ],
    );
}

#[test]
fn links_in_code_and_to_other_sites_are_not_followed() {
    check(
        &[(
            "a.md",
            "# A\n\n```sh\n[x](gone.md)\n```\n\n`[y](gone.md)` [site](https://example.com/gone.md) [mail](mailto:a@b.c)\n",
        )],
        &[],
    );
}

#[test]
fn images_reference_links_and_directories_count() {
    check(
        &[
            (
                "a.md",
                "# A\n\n![plot](img.png) [dir](sub/) [ref][r] ![gone](gone.png)\n\n[r]: sub/c.md#c\n[s]: nothing.md\n",
            ),
            ("img.png", ""),
            ("sub/c.md", "# C\n"),
        ],
        &["a.md:3: gone.png: no such file", "a.md:6: nothing.md: no such file"],
    );
}

#[test]
fn anchors_follow_github() {
    for (heading, anchor) in [
        (
            "Frame cost on the CPU (null GPU)",
            "frame-cost-on-the-cpu-null-gpu",
        ),
        (
            "Speed: och against vfc, hlod and occ",
            "speed-och-against-vfc-hlod-and-occ",
        ),
        (
            "Real GPU (`benches/gpu-run.sh`)",
            "real-gpu-benchesgpu-runsh",
        ),
        ("The HZB: build and box test", "the-hzb-build-and-box-test"),
        ("**Bold** and [a link](x.md)", "bold-and-a-link"),
        ("snake_case stays", "snake_case-stays"),
    ] {
        assert_eq!(github_anchor(heading), anchor, "{heading}");
    }
    // A repeated heading gets -1, -2, ... as GitHub numbers it.
    let a = anchors("# Rerun\n## Rerun\n### Rerun\n");
    for x in ["rerun", "rerun-1", "rerun-2"] {
        assert!(a.contains(x), "{x} in {a:?}");
    }
}

/// Writes `files` (path, text) under a fresh directory and checks that the
/// broken links found are exactly `expected` ("file:line: link: why").
#[track_caller]
fn check(files: &[(&str, &str)], expected: &[&str]) {
    let dir = tempfile::tempdir().expect("temporary directory");
    for (name, text) in files {
        let path = dir.path().join(name);
        std::fs::create_dir_all(path.parent().expect("a parent")).expect("directory");
        std::fs::write(&path, text).expect("write");
    }
    let found = broken_links(dir.path(), &markdown_files(dir.path()));
    assert_eq!(found, expected);
}

/// Every `.md` file under `root`, sorted, without the skipped directories
/// and hidden ones (`.git`).
fn markdown_files(root: &Path) -> Vec<PathBuf> {
    let skipped: Vec<PathBuf> = SKIPPED.iter().map(|s| root.join(s)).collect();
    let mut out = Vec::new();
    let mut todo = vec![root.to_path_buf()];
    while let Some(dir) = todo.pop() {
        let entries = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()));
        for entry in entries {
            let path = entry.expect("a directory entry").path();
            let hidden = path
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'));
            if hidden || skipped.contains(&path) {
                continue;
            }
            if path.is_dir() {
                todo.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// Every link of `files` that leads nowhere, as "file:line: link: why" with
/// the file relative to `root`.
fn broken_links(root: &Path, files: &[PathBuf]) -> Vec<String> {
    let mut out = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(file)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", file.display()));
        let name = relative(root, file);
        for (line, link) in links(&text) {
            if let Err(why) = follow(root, file, &text, &link) {
                out.push(format!("{name}:{line}: {link}: {why}"));
            }
        }
    }
    out
}

/// Whether `link`, found in `file` (whose text is `text`), leads somewhere.
fn follow(root: &Path, file: &Path, text: &str, link: &str) -> Result<(), String> {
    let (target, fragment) = match link.split_once('#') {
        Some((t, f)) => (t, Some(f)),
        None => (link, None),
    };
    let (path, target_text) = if target.is_empty() {
        (file.to_path_buf(), Some(text.to_string()))
    } else {
        let path = match target.strip_prefix('/') {
            Some(from_root) => root.join(from_root),
            None => file.parent().expect("a file has a directory").join(target),
        };
        let path = normalize(&path);
        if !path.exists() {
            return Err("no such file".into());
        }
        let is_md = path.extension().is_some_and(|e| e == "md");
        let text = is_md.then(|| std::fs::read_to_string(&path).unwrap_or_default());
        (path, text)
    };
    let Some(fragment) = fragment else {
        return Ok(());
    };
    match target_text {
        Some(t) if anchors(&t).contains(fragment) => Ok(()),
        Some(_) => Err(format!("no such heading in {}", relative(root, &path))),
        // A fragment into a file that is not markdown (a line of source
        // on GitHub): not a heading to check.
        None => Ok(()),
    }
}

/// The links of a markdown text with their 1-based line numbers: inline
/// links and images `[text](target)`, and reference definitions
/// `[name]: target`; not inside fenced code blocks or code spans, and not
/// to other sites.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fenced = false;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("```") || trimmed.starts_with("~~~") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        let line = without_code_spans(line);
        let mut found = Vec::new();
        if let Some(rest) = line.trim_start().strip_prefix('[') {
            if let Some((name, def)) = rest.split_once("]:") {
                if let (false, Some(target)) = (name.contains(']'), def.split_whitespace().next()) {
                    found.push(target.to_string());
                }
            }
        }
        let mut rest = line.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            // A title after the target (`[a](b "c")`) is not part of it.
            if let Some(target) = after[..end].split_whitespace().next() {
                found.push(target.trim_matches(['<', '>']).to_string());
            }
            rest = &after[end..];
        }
        for target in found {
            let external = target.contains("://") || target.starts_with("mailto:");
            if !external && !target.is_empty() {
                out.push((i + 1, target));
            }
        }
    }
    out
}

/// `line` with the contents of its code spans (`...`) removed.
fn without_code_spans(line: &str) -> String {
    let mut out = String::new();
    for (i, part) in line.split('`').enumerate() {
        if i % 2 == 0 {
            out.push_str(part);
        }
    }
    out
}

/// The anchors GitHub gives the headings of a markdown text (outside fenced
/// code), repeated ones numbered from -1, plus explicit `id` / `name`
/// attributes of HTML anchors.
fn anchors(text: &str) -> HashSet<String> {
    let mut out = HashSet::new();
    let mut fenced = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("```") || trimmed.starts_with("~~~") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        for attr in ["id=\"", "name=\""] {
            let mut rest = line;
            while let Some(at) = rest.find(attr) {
                let after = &rest[at + attr.len()..];
                let Some(end) = after.find('"') else { break };
                out.insert(after[..end].to_string());
                rest = &after[end..];
            }
        }
        let level = trimmed.chars().take_while(|&c| c == '#').count();
        let Some(heading) = trimmed.get(level..) else {
            continue;
        };
        if level == 0 || level > 6 || !(heading.is_empty() || heading.starts_with(' ')) {
            continue;
        }
        let heading = heading.trim().trim_end_matches('#').trim();
        let base = github_anchor(heading);
        let mut anchor = base.clone();
        let mut n = 0;
        while out.contains(&anchor) {
            n += 1;
            anchor = format!("{base}-{n}");
        }
        out.insert(anchor);
    }
    out
}

/// GitHub's anchor for a heading: the text as rendered (link targets and
/// emphasis marks dropped), lowercase, punctuation other than '-' and '_'
/// dropped, each space a '-'.
fn github_anchor(heading: &str) -> String {
    let mut rendered = String::new();
    let mut rest = heading;
    // [text](target) renders as text.
    while let Some(open) = rest.find('[') {
        let Some(close) = rest[open..].find("](").map(|c| open + c) else {
            break;
        };
        let Some(end) = rest[close..].find(')').map(|e| close + e) else {
            break;
        };
        rendered.push_str(&rest[..open]);
        rendered.push_str(&rest[open + 1..close]);
        rest = &rest[end + 1..];
    }
    rendered.push_str(rest);
    rendered
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            '-' | '_' => Some(c),
            c if c.is_alphanumeric() => Some(c),
            _ => None,
        })
        .collect()
}

/// `path` without `.` and `..` components (it need not exist).
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// `path` relative to `root`, with '/' separators, for messages.
fn relative(root: &Path, path: &Path) -> String {
    let rel = path.strip_prefix(root).unwrap_or(path);
    rel.components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}
