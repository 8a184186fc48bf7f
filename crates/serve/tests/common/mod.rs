//! What the server's tests share: a site in a temporary directory (a
//! bundle of files of known content standing in for the browser viewer's
//! build, and a fake scene: the server never reads a scene's contents),
//! a server on port 0 in this process, and a plain HTTP/1.1 client over
//! TCP that shows every byte the server sends.

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;
use std::time::Duration;

use gigawalk_serve::{Bundle, Config, Limits, Server, Stopper};

/// Text long enough to be worth gzipping.
pub fn page_text(what: &str) -> Vec<u8> {
    (0..200)
        .map(|i| format!("// {what}: line {i} of the page's text\n"))
        .collect::<String>()
        .into_bytes()
}

/// The bundle's files and their content.
pub fn bundle_files() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("index.html", page_text("index.html")),
        ("main.js", page_text("main.js")),
        (
            "gigawalk_web.js",
            b"export default async function init() {}\n".to_vec(),
        ),
        (
            "gigawalk_web_bg.wasm",
            [&b"\0asm\x01\0\0\0"[..], &[7; 4000]].concat(),
        ),
    ]
}

/// A fake scene of `len` bytes, each byte a function of its offset.
pub fn scene_bytes(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i * 7 + i / 251) as u8).collect()
}

/// A site in a temporary directory.
pub struct Site {
    pub dir: tempfile::TempDir,
    pub bundle: PathBuf,
    pub scene: PathBuf,
}

impl Site {
    /// [`bundle_files`] plus a hidden file, a subdirectory and files
    /// beside the bundle that are not part of the site; a scene of
    /// 5,000 bytes.
    pub fn new() -> Site {
        let dir = tempfile::tempdir().unwrap();
        let bundle = dir.path().join("bundle");
        std::fs::create_dir_all(bundle.join("sub")).unwrap();
        for (name, bytes) in bundle_files() {
            std::fs::write(bundle.join(name), bytes).unwrap();
        }
        std::fs::write(bundle.join(".hidden"), b"not served").unwrap();
        std::fs::write(bundle.join("sub").join("x.js"), b"not served").unwrap();
        std::fs::write(dir.path().join("secret.txt"), b"not served").unwrap();
        let scene = dir.path().join("plant.gwk");
        std::fs::write(&scene, scene_bytes(5000)).unwrap();
        Site { dir, bundle, scene }
    }

    pub fn scene(&self) -> Vec<u8> {
        std::fs::read(&self.scene).unwrap()
    }

    /// A server of this site on 127.0.0.1, port 0.
    pub fn serve(&self, limits: Limits) -> Running {
        let config = Config {
            addr: "127.0.0.1:0".parse().unwrap(),
            scene: self.scene.clone(),
            bundle: Bundle::open(&self.bundle, "the test's bundle").unwrap(),
            limits,
        };
        let server = Server::bind(config).unwrap();
        let addr = server.local_addr();
        assert_eq!(server.url(), format!("http://{addr}/"));
        let stopper = server.stopper();
        let thread = std::thread::spawn(move || server.run().unwrap());
        Running {
            addr,
            stopper,
            thread: Some(thread),
        }
    }
}

/// A server running on a thread of the test, stopped when dropped.
pub struct Running {
    pub addr: SocketAddr,
    stopper: Stopper,
    thread: Option<JoinHandle<()>>,
}

impl Drop for Running {
    fn drop(&mut self) {
        self.stopper.stop();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Running {
    pub fn connect(&self) -> TcpStream {
        let c = TcpStream::connect(self.addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        c
    }

    /// Sends `method path` with `headers` (and a Host) on a new
    /// connection and reads the answer.
    pub fn ask(&self, method: &str, path: &str, headers: &[&str]) -> Response {
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

    pub fn get(&self, path: &str, headers: &[&str]) -> Response {
        self.ask("GET", path, headers)
    }

    /// Sends `bytes` as they are on a new connection and reads all the
    /// server sends until it closes the connection.
    pub fn raw(&self, bytes: &[u8]) -> String {
        let mut c = self.connect();
        // The server may answer and close before reading everything.
        let _ = c.write_all(bytes);
        let mut answer = Vec::new();
        let _ = c.read_to_end(&mut answer);
        String::from_utf8_lossy(&answer).into_owned()
    }
}

#[derive(Debug)]
pub struct Response {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    /// The body as sent (chunks joined; still gzipped when it was).
    pub body: Vec<u8>,
}

impl Response {
    /// Reads one answer: its head, then its body by Content-Length or in
    /// chunks (none for HEAD, 304 and 204).
    pub fn read(r: &mut impl BufRead, head: bool) -> Response {
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
        if head || status == 304 || status == 204 {
            return resp;
        }
        if resp.header("transfer-encoding") == Some("chunked") {
            loop {
                let mut size = String::new();
                r.read_line(&mut size).unwrap();
                let n = usize::from_str_radix(size.trim(), 16).expect("a chunk size");
                let mut chunk = vec![0; n + 2];
                r.read_exact(&mut chunk).unwrap();
                assert_eq!(&chunk[n..], b"\r\n", "a chunk's end");
                if n == 0 {
                    break;
                }
                resp.body.extend_from_slice(&chunk[..n]);
            }
        } else {
            let len: usize = resp
                .header("content-length")
                .expect("a length or chunks")
                .parse()
                .unwrap();
            resp.body = vec![0; len];
            r.read_exact(&mut resp.body).unwrap();
        }
        resp
    }

    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// The file `name` of the bundle in `site`.
pub fn bundle_file(name: &str) -> Vec<u8> {
    bundle_files()
        .into_iter()
        .find(|(n, _)| *n == name)
        .unwrap()
        .1
}

/// `path` as text.
pub fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}
