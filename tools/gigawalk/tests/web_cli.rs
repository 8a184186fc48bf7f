//! `gigawalk web` and `gigawalk serve` with a bundle made here (files of
//! known content stand in for the browser viewer's build): the site's
//! files and bytes, config.json both ways, --force, where the bundle is
//! found, bad input; the server's answers over a plain TCP connection —
//! whole files, each form of range, 416, HEAD, content types, 404 for
//! anything else, 400 for a malformed request while it keeps serving.

mod common;

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use common::{s, small_plant, BIN};
use gigawalk_testkit::cli::{output, Output};

const BUNDLE_ENV: &str = "GIGAWALK_WEB_BUNDLE";

/// The bundle's files and their content.
const BUNDLE: [(&str, &[u8]); 4] = [
    ("index.html", b"<!doctype html><title>gigawalk</title>\n"),
    (
        "main.js",
        b"import init from './gigawalk_web.js'; init();\n",
    ),
    (
        "gigawalk_web.js",
        b"export default async function init() {}\n",
    ),
    ("gigawalk_web_bg.wasm", b"\0asm\x01\0\0\0 not really wasm"),
];

/// A bundle in `dir/name`: [`BUNDLE`], plus a hidden file and a
/// subdirectory that are not part of the site.
fn fake_bundle(dir: &Path, name: &str) -> PathBuf {
    let b = dir.join(name);
    std::fs::create_dir_all(b.join("sub")).unwrap();
    for (name, bytes) in BUNDLE {
        std::fs::write(b.join(name), bytes).unwrap();
    }
    std::fs::write(b.join(".hidden"), b"not served").unwrap();
    std::fs::write(b.join("sub").join("x.js"), b"not served").unwrap();
    b
}

/// Runs `bin args` with the bundle variable unset, or set to `env`.
fn run_with(bin: &Path, args: &[&str], env: Option<&Path>) -> Output {
    let mut cmd = Command::new(bin);
    cmd.args(args).env_remove(BUNDLE_ENV);
    if let Some(v) = env {
        cmd.env(BUNDLE_ENV, v);
    }
    output(&mut cmd)
}

fn gigawalk(args: &[&str]) -> Output {
    run_with(Path::new(BIN), args, None)
}

#[track_caller]
fn gigawalk_ok(args: &[&str]) -> Output {
    gigawalk(args).assert_success()
}

/// Runs `gigawalk args`, which must fail with an error on stderr holding
/// every one of `words`.
#[track_caller]
fn fails_saying(args: &[&str], words: &[&str]) {
    let out = gigawalk(args);
    assert!(!out.success(), "`{}` succeeded", out.command);
    for w in words {
        assert!(
            out.stderr.contains(w),
            "`{}`: the error does not say {w:?}:\n{}",
            out.command,
            out.stderr
        );
    }
    assert!(
        !out.stderr.contains("panicked"),
        "`{}` panicked:\n{}",
        out.command,
        out.stderr
    );
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    v.sort();
    v
}

fn sorted(v: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = v.iter().map(|s| s.to_string()).collect();
    v.sort();
    v
}

fn config(site: &Path) -> serde_json::Value {
    common::json(&std::fs::read_to_string(site.join("config.json")).unwrap())
}

#[test]
fn web_writes_the_bundle_the_scene_and_config() {
    let t = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(t.path());
    let bundle = fake_bundle(t.path(), "bundle");
    let site = t.path().join("site");
    let out = gigawalk_ok(&["web", s(&gwk), "-o", s(&site), "--bundle", s(&bundle)]);

    assert_eq!(
        names(&site),
        sorted(&[
            "index.html",
            "main.js",
            "gigawalk_web.js",
            "gigawalk_web_bg.wasm",
            "scene.gwk",
            "config.json"
        ]),
        "the bundle's files, the scene and config.json, nothing else"
    );
    for (name, bytes) in BUNDLE {
        assert_eq!(std::fs::read(site.join(name)).unwrap(), bytes, "{name}");
    }
    assert_eq!(
        std::fs::read(site.join("scene.gwk")).unwrap(),
        std::fs::read(&gwk).unwrap()
    );
    assert_eq!(config(&site), serde_json::json!({ "scene": "scene.gwk" }));
    assert!(out.stdout.contains(s(&site)), "{}", out.stdout);
    assert!(out.stdout.contains("range requests"), "{}", out.stdout);
    assert!(out.stdout.contains("gigawalk serve"), "{}", out.stdout);

    // The bundle can come from the environment too.
    let site2 = t.path().join("site2");
    run_with(
        Path::new(BIN),
        &["web", s(&gwk), "-o", s(&site2)],
        Some(&bundle),
    )
    .assert_success();
    assert_eq!(names(&site2), names(&site));
}

#[test]
fn web_with_a_scene_url_points_config_there_and_copies_no_scene() {
    let t = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(t.path());
    let bundle = fake_bundle(t.path(), "bundle");
    let url = "https://example.com/models/plant \"big\".gwk";

    let site = t.path().join("site");
    let out = gigawalk_ok(&[
        "web",
        s(&gwk),
        "-o",
        s(&site),
        "--bundle",
        s(&bundle),
        "--scene-url",
        url,
    ]);
    assert!(!site.join("scene.gwk").exists());
    assert_eq!(config(&site), serde_json::json!({ "scene": url }));
    assert!(out.stdout.contains(url), "{}", out.stdout);

    // No scene file at all: only the URL.
    let site = t.path().join("site2");
    gigawalk_ok(&[
        "web",
        "-o",
        s(&site),
        "--bundle",
        s(&bundle),
        "--scene-url",
        "../scenes/a.gwk",
    ]);
    assert_eq!(
        names(&site),
        sorted(&[
            "index.html",
            "main.js",
            "gigawalk_web.js",
            "gigawalk_web_bg.wasm",
            "config.json"
        ])
    );
    assert_eq!(
        config(&site),
        serde_json::json!({ "scene": "../scenes/a.gwk" })
    );

    // Neither: nothing to show.
    fails_saying(&["web", "-o", s(&t.path().join("site3"))], &["SCENE"]);
    assert!(!t.path().join("site3").exists());
}

#[test]
fn web_refuses_a_directory_that_is_not_empty_without_force() {
    let t = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(t.path());
    let bundle = fake_bundle(t.path(), "bundle");
    let site = t.path().join("site");
    std::fs::create_dir(&site).unwrap();
    std::fs::write(site.join("notes.txt"), b"mine").unwrap();

    let args = ["web", s(&gwk), "-o", s(&site), "--bundle", s(&bundle)];
    fails_saying(&args, &[s(&site), "not empty", "--force"]);
    assert_eq!(names(&site), ["notes.txt"], "nothing was written");

    // An empty directory is fine without --force.
    let empty = t.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    gigawalk_ok(&["web", s(&gwk), "-o", s(&empty), "--bundle", s(&bundle)]);
    assert!(empty.join("config.json").exists());

    let mut forced = args.to_vec();
    forced.push("--force");
    gigawalk_ok(&forced);
    assert!(names(&site).contains(&"notes.txt".to_string()));
    assert!(site.join("scene.gwk").exists());
    assert_eq!(config(&site), serde_json::json!({ "scene": "scene.gwk" }));

    // Written over with a scene URL: the copy made before goes.
    forced.extend(["--scene-url", "https://example.com/a.gwk"]);
    gigawalk_ok(&forced);
    assert!(!site.join("scene.gwk").exists());
    assert_eq!(
        config(&site),
        serde_json::json!({ "scene": "https://example.com/a.gwk" })
    );
    assert_eq!(std::fs::read(site.join("notes.txt")).unwrap(), b"mine");
    assert!(
        names(&site).iter().all(|n| !n.starts_with('.')),
        "no temporary file left: {:?}",
        names(&site)
    );

    // A site written over with its own scene keeps it.
    let own = site.join("scene.gwk");
    std::fs::copy(&gwk, &own).unwrap();
    gigawalk_ok(&[
        "web",
        s(&own),
        "-o",
        s(&site),
        "--bundle",
        s(&bundle),
        "--force",
    ]);
    assert_eq!(std::fs::read(&own).unwrap(), std::fs::read(&gwk).unwrap());
    assert_eq!(config(&site), serde_json::json!({ "scene": "scene.gwk" }));
}

#[test]
fn web_names_what_is_wrong_with_its_input() {
    let t = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(t.path());
    let bundle = fake_bundle(t.path(), "bundle");
    let site = t.path().join("site");

    let missing = t.path().join("missing.gwk");
    fails_saying(
        &["web", s(&missing), "-o", s(&site), "--bundle", s(&bundle)],
        &[s(&missing)],
    );
    let not_scene = t.path().join("notes.gwk");
    std::fs::write(&not_scene, b"these are notes, not a scene file").unwrap();
    fails_saying(
        &["web", s(&not_scene), "-o", s(&site), "--bundle", s(&bundle)],
        &[s(&not_scene), "not a gigawalk scene"],
    );

    let no_bundle = t.path().join("no-bundle");
    fails_saying(
        &["web", s(&gwk), "-o", s(&site), "--bundle", s(&no_bundle)],
        &[s(&no_bundle), "bundle", "crates/web/build.sh"],
    );
    let out = run_with(
        Path::new(BIN),
        &["web", s(&gwk), "-o", s(&site)],
        Some(&no_bundle),
    );
    assert!(!out.success());
    assert!(
        out.stderr.contains(BUNDLE_ENV) && out.stderr.contains(s(&no_bundle)),
        "{}",
        out.stderr
    );

    let partial = fake_bundle(t.path(), "partial");
    std::fs::remove_file(partial.join("gigawalk_web_bg.wasm")).unwrap();
    fails_saying(
        &["web", s(&gwk), "-o", s(&site), "--bundle", s(&partial)],
        &[s(&partial), "gigawalk_web_bg.wasm", "crates/web/build.sh"],
    );
    assert!(!site.exists(), "no output directory after a failure");

    let file = t.path().join("file");
    std::fs::write(&file, b"x").unwrap();
    fails_saying(
        &["web", s(&gwk), "-o", s(&file), "--bundle", s(&bundle)],
        &[s(&file), "not a directory"],
    );
    fails_saying(
        &[
            "web",
            s(&gwk),
            "-o",
            s(&site),
            "--bundle",
            s(&bundle),
            "--scene-url",
            " ",
        ],
        &["--scene-url"],
    );
    assert!(!site.exists());
}

/// The `gigawalk` binary linked (or copied) to `dir/bin/gigawalk`.
fn relocated_binary(dir: &Path) -> PathBuf {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let exe = bin.join(Path::new(BIN).file_name().unwrap());
    if std::fs::hard_link(BIN, &exe).is_err() {
        std::fs::copy(BIN, &exe).unwrap();
    }
    exe
}

#[test]
fn web_finds_the_bundle_beside_the_executable() {
    // Beside the build's target directory: the same file system as the
    // binary, so it can be linked rather than copied.
    let t = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let (_, gwk) = small_plant(t.path());
    let exe = relocated_binary(t.path());
    let site = t.path().join("site");
    let args = ["web", s(&gwk), "-o", s(&site)];

    let out = run_with(&exe, &args, None);
    assert!(!out.success());
    let tmp = t.path().file_name().unwrap().to_str().unwrap();
    let expected = format!("{tmp}/web/bundle");
    for w in [&expected, "missing", "crates/web/build.sh", BUNDLE_ENV] {
        assert!(out.stderr.contains(w), "no {w:?} in:\n{}", out.stderr);
    }
    assert!(!site.exists());

    std::fs::create_dir(t.path().join("web")).unwrap();
    fake_bundle(&t.path().join("web"), "bundle");
    let out = run_with(&exe, &args, None).assert_success();
    assert!(out.stdout.contains("bundle"), "{}", out.stdout);
    assert!(site.join("gigawalk_web_bg.wasm").exists());
}

#[test]
fn help_explains_both_commands_and_the_range_requirement() {
    for cmd in ["web", "serve"] {
        let out = gigawalk_ok(&[cmd, "--help"]);
        assert!(out.stdout.contains("range requests"), "{}", out.stdout);
        assert!(out.stdout.contains("--bundle"), "{}", out.stdout);
        assert!(out.stdout.contains(BUNDLE_ENV), "{}", out.stdout);
    }
    let top = gigawalk_ok(&["--help"]).stdout;
    assert!(top.contains("web") && top.contains("serve"), "{top}");
}

/// A running `gigawalk serve`, killed when dropped (a failed test leaves
/// no server behind).
struct Server {
    child: Child,
    /// host:port, from the address it printed.
    addr: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Server {
    /// Starts `gigawalk serve scene --port 0 --bundle bundle` and waits for
    /// the address it prints.
    fn start(scene: &Path, bundle: &Path) -> Server {
        let child = Command::new(BIN)
            .args(["serve", s(scene), "--port", "0", "--bundle", s(bundle)])
            .env_remove(BUNDLE_ENV)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("gigawalk serve starts");
        let mut server = Server {
            child,
            addr: String::new(),
        };
        let stdout = server.child.stdout.take().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let _ = BufReader::new(stdout).read_line(&mut line);
            let _ = tx.send(line);
        });
        let line = rx
            .recv_timeout(Duration::from_secs(120))
            .unwrap_or_default();
        let line = line.trim();
        let Some(addr) = line
            .strip_prefix("http://")
            .and_then(|r| r.strip_suffix('/'))
        else {
            let _ = server.child.kill();
            let mut err = String::new();
            if let Some(mut e) = server.child.stderr.take() {
                let _ = e.read_to_string(&mut err);
            }
            panic!("gigawalk serve printed {line:?}, not its address; its stderr:\n{err}");
        };
        assert!(addr.starts_with("127.0.0.1:"), "{line}");
        server.addr = addr.to_string();
        server
    }

    fn connect(&self) -> TcpStream {
        let c = TcpStream::connect(&self.addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        c
    }

    /// Sends `GET path` (or another method) with `headers` on a new
    /// connection and reads the answer.
    fn ask(&self, method: &str, path: &str, headers: &[&str]) -> Response {
        let mut c = self.connect();
        let mut req = format!("{method} {path} HTTP/1.1\r\nHost: {}\r\n", self.addr);
        for h in headers {
            req.push_str(h);
            req.push_str("\r\n");
        }
        req.push_str("\r\n");
        c.write_all(req.as_bytes()).unwrap();
        Response::read(&mut BufReader::new(c), method == "HEAD")
    }

    fn get(&self, path: &str, headers: &[&str]) -> Response {
        self.ask("GET", path, headers)
    }
}

#[derive(Debug)]
struct Response {
    status: u16,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl Response {
    /// Reads one answer: its head, then Content-Length bytes of body
    /// (none for HEAD).
    fn read(r: &mut impl std::io::BufRead, head: bool) -> Response {
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        let mut parts = line.trim_end().splitn(3, ' ');
        assert_eq!(parts.next(), Some("HTTP/1.1"), "status line {line:?}");
        let status = parts.next().unwrap().parse().unwrap();
        let mut headers = Vec::new();
        loop {
            let mut h = String::new();
            r.read_line(&mut h).unwrap();
            assert!(h.ends_with("\r\n"), "header line {h:?}");
            let h = h.trim_end();
            if h.is_empty() {
                break;
            }
            let (n, v) = h.split_once(':').expect("name: value");
            headers.push((n.to_ascii_lowercase(), v.trim().to_string()));
        }
        let mut resp = Response {
            status,
            headers,
            body: Vec::new(),
        };
        if !head {
            let len: usize = resp.header("content-length").unwrap().parse().unwrap();
            resp.body = vec![0; len];
            r.read_exact(&mut resp.body).unwrap();
        }
        resp
    }

    fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

#[test]
fn serve_answers_whole_files_and_every_form_of_range() {
    let t = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(t.path());
    let bundle = fake_bundle(t.path(), "bundle");
    let scene = std::fs::read(&gwk).unwrap();
    let len = scene.len();
    assert!(len > 2000, "a scene of {len} bytes");
    let server = Server::start(&gwk, &bundle);

    let whole = server.get("/scene.gwk", &[]);
    assert_eq!(whole.status, 200);
    assert_eq!(whole.header("accept-ranges"), Some("bytes"));
    assert_eq!(
        whole.header("content-type"),
        Some("application/octet-stream")
    );
    assert_eq!(whole.header("content-length"), Some(&*len.to_string()));
    assert_eq!(whole.header("cache-control"), Some("no-cache"));
    assert!(whole.header("content-range").is_none());
    assert!(whole.body == scene, "the whole scene, byte for byte");

    // (Range header, first byte, last byte)
    let cases = [
        ("bytes=0-99".to_string(), 0, 99),
        ("bytes=1000-1999".to_string(), 1000, 1999),
        (
            format!("bytes={}-{}", len - 10, len + 500),
            len - 10,
            len - 1,
        ),
        ("bytes=1500-".to_string(), 1500, len - 1),
        ("bytes=-256".to_string(), len - 256, len - 1),
        (format!("bytes=-{}", len * 3), 0, len - 1),
        ("bytes=7-7".to_string(), 7, 7),
    ];
    for (range, a, b) in &cases {
        let r = server.get("/scene.gwk", &[&format!("Range: {range}")]);
        assert_eq!(r.status, 206, "{range}");
        assert_eq!(
            r.header("content-range"),
            Some(&*format!("bytes {a}-{b}/{len}")),
            "{range}"
        );
        assert_eq!(
            r.header("content-length"),
            Some(&*(b - a + 1).to_string()),
            "{range}"
        );
        assert!(r.body == scene[*a..=*b], "{range}: the bytes");
    }

    for range in [
        format!("bytes={len}-"),
        format!("bytes={}-{}", len + 5, len + 9),
        "bytes=-0".into(),
    ] {
        let r = server.get("/scene.gwk", &[&format!("Range: {range}")]);
        assert_eq!(r.status, 416, "{range}");
        assert_eq!(
            r.header("content-range"),
            Some(&*format!("bytes */{len}")),
            "{range}"
        );
    }

    // Several ranges: the whole file.
    let r = server.get("/scene.gwk", &["Range: bytes=0-9,20-29"]);
    assert_eq!(r.status, 200);
    assert!(r.body == scene);

    // HEAD: the headers a GET gets, no body.
    let h = server.ask("HEAD", "/scene.gwk", &[]);
    assert_eq!(h.status, 200);
    assert_eq!(h.header("content-length"), Some(&*len.to_string()));
    assert_eq!(h.header("accept-ranges"), Some("bytes"));
    let h = server.ask("HEAD", "/scene.gwk", &["Range: bytes=10-19"]);
    assert_eq!(h.status, 206);
    assert_eq!(h.header("content-length"), Some("10"));
    assert_eq!(
        h.header("content-range"),
        Some(&*format!("bytes 10-19/{len}"))
    );

    // The bundle's files and config.json, with their types.
    let types = [
        ("index.html", "text/html"),
        ("main.js", "text/javascript"),
        ("gigawalk_web.js", "text/javascript"),
        ("gigawalk_web_bg.wasm", "application/wasm"),
    ];
    for (name, ctype) in types {
        let r = server.get(&format!("/{name}"), &[]);
        assert_eq!(r.status, 200, "{name}");
        let bytes = BUNDLE.iter().find(|(n, _)| *n == name).unwrap().1;
        assert_eq!(r.body, bytes, "{name}");
        let got = r.header("content-type").unwrap();
        assert!(got.starts_with(ctype), "{name}: {got}");
    }
    assert_eq!(
        server
            .get("/gigawalk_web_bg.wasm", &[])
            .header("content-type"),
        Some("application/wasm")
    );
    let root = server.get("/?scene=other.gwk", &[]);
    assert_eq!(root.status, 200);
    assert_eq!(root.body, BUNDLE[0].1, "/ is index.html");
    let c = server.get("/config.json", &[]);
    assert_eq!(c.status, 200);
    assert_eq!(c.header("content-type"), Some("application/json"));
    assert_eq!(
        common::json(std::str::from_utf8(&c.body).unwrap()),
        serde_json::json!({ "scene": "scene.gwk" })
    );
    let c = server.get("/config.json", &["Range: bytes=0-0"]);
    assert_eq!((c.status, c.body.as_slice()), (206, &b"{"[..]));

    // Many requests on one connection.
    let mut conn = server.connect();
    let mut reader = BufReader::new(conn.try_clone().unwrap());
    for (range, a, b) in &cases {
        write!(
            conn,
            "GET /scene.gwk HTTP/1.1\r\nHost: x\r\nRange: {range}\r\n\r\n"
        )
        .unwrap();
        let r = Response::read(&mut reader, false);
        assert_eq!(r.status, 206);
        assert!(r.body == scene[*a..=*b], "{range} on a kept connection");
    }
}

#[test]
fn serve_refuses_what_it_does_not_serve_and_goes_on() {
    let t = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(t.path());
    let bundle = fake_bundle(t.path(), "bundle");
    let server = Server::start(&gwk, &bundle);

    for path in [
        "/../Cargo.toml",
        "/..%2FCargo.toml",
        "/%2e%2e/Cargo.toml",
        "/sub/x.js",
        "/.hidden",
        "/nothing.html",
        "/scene.gwk/",
        "//etc/passwd",
        "/index.html/..",
    ] {
        let r = server.get(path, &[]);
        assert_eq!(r.status, 404, "{path}");
    }
    let h = server.ask("HEAD", "/nothing", &[]);
    assert_eq!(h.status, 404);
    let p = server.ask("POST", "/scene.gwk", &["Content-Length: 0"]);
    assert_eq!(p.status, 405);
    assert_eq!(p.header("allow"), Some("GET, HEAD"));

    // Malformed requests: 400, the connection closes, the server goes on.
    for bad in [
        "NONSENSE\r\n\r\n",
        "GET /index.html\r\n\r\n",
        "GET index.html HTTP/1.1\r\nHost: x\r\n\r\n",
        "GET /index.html HTTP/1.1 extra\r\nHost: x\r\n\r\n",
        "GET /index.html HTTP/1.1\r\nno colon here\r\n\r\n",
        "GET /index.html HTTP/1.1\r\nBad Name: x\r\n\r\n",
        "GET /index.html HTTP/1.1\r\n\r\n",
        "\u{1}\u{2}\u{3}\r\n\r\n",
    ] {
        let mut c = server.connect();
        c.write_all(bad.as_bytes()).unwrap();
        let mut answer = Vec::new();
        c.read_to_end(&mut answer).unwrap();
        let answer = String::from_utf8_lossy(&answer);
        assert!(
            answer.starts_with("HTTP/1.1 400 "),
            "{bad:?} got {answer:?}"
        );
    }
    let mut c = server.connect();
    c.write_all(&[0xff; 20_000]).unwrap();
    let mut answer = Vec::new();
    let _ = c.read_to_end(&mut answer);
    assert!(
        String::from_utf8_lossy(&answer).starts_with("HTTP/1.1 4"),
        "a line without end"
    );
    // A client that goes away mid-request.
    let mut c = server.connect();
    c.write_all(b"GET /scene.gwk HT").unwrap();
    drop(c);

    let r = server.get("/scene.gwk", &["Range: bytes=0-3"]);
    assert_eq!(r.status, 206, "still serving");
    assert_eq!(r.body, std::fs::read(&gwk).unwrap()[..4]);
}

#[test]
fn serve_names_what_is_wrong_with_its_input() {
    let t = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(t.path());
    let bundle = fake_bundle(t.path(), "bundle");

    let missing = t.path().join("missing.gwk");
    fails_saying(
        &["serve", s(&missing), "--port", "0", "--bundle", s(&bundle)],
        &[s(&missing)],
    );
    let not_scene = t.path().join("notes.gwk");
    std::fs::write(&not_scene, b"these are notes, not a scene file").unwrap();
    fails_saying(
        &[
            "serve",
            s(&not_scene),
            "--port",
            "0",
            "--bundle",
            s(&bundle),
        ],
        &[s(&not_scene), "not a gigawalk scene"],
    );
    let no_bundle = t.path().join("no-bundle");
    fails_saying(
        &["serve", s(&gwk), "--port", "0", "--bundle", s(&no_bundle)],
        &[s(&no_bundle), "crates/web/build.sh"],
    );
    for port in ["http", "99999"] {
        fails_saying(
            &["serve", s(&gwk), "--port", port, "--bundle", s(&bundle)],
            &["--port", port],
        );
    }
    fails_saying(
        &[
            "serve",
            s(&gwk),
            "--port",
            "0",
            "--bind",
            "no such host.invalid",
            "--bundle",
            s(&bundle),
        ],
        &["--bind", "no such host.invalid"],
    );
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    fails_saying(
        &["serve", s(&gwk), "--port", &port, "--bundle", s(&bundle)],
        &[&format!("127.0.0.1:{port}"), "--port"],
    );
}
