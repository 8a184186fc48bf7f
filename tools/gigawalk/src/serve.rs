//! `gigawalk serve`: the site `gigawalk web` writes, served over HTTP
//! without writing it — the bundle's files, `/config.json` and
//! `/scene.gwk` — with the range requests the page reads the scene by.
//!
//! A small HTTP/1.1 server on `std::net`, a thread a connection: the page
//! makes a handful of connections, each with many requests (keep-alive).
//! Only GET and HEAD of the known names are answered; every name is looked
//! up in a fixed list, never joined to a path from the request, so no
//! request reaches another file. Files are streamed from disk, opened
//! anew for each request (a scene written again in place is served as it
//! is now). A malformed request gets 400 and its connection closes.

use std::io::{BufRead, BufReader, Read as _, Seek as _, SeekFrom, Write as _};
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs as _};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context as _;

use crate::web::{self, Bundle};

pub const LONG_ABOUT: &str = "\
Serve the browser viewer of a scene over HTTP, without writing a site: the \
page and its files from the viewer's bundle, /config.json, and the scene as \
/scene.gwk, streamed from its file. Prints the address to open \
(http://127.0.0.1:PORT/) on standard output once it listens, then serves \
until stopped (Ctrl-C).

The page reads the scene in pieces with HTTP range requests; this server \
answers them (Range: bytes=a-b, bytes=a- and bytes=-n with 206 Partial \
Content, 416 for a range past the end; a request for several ranges gets \
the whole file). To put the viewer on another server, write the site with \
`gigawalk web` and use a server that answers range requests too.

The bundle comes from --bundle, else $GIGAWALK_WEB_BUNDLE, else \
../web/bundle beside the gigawalk executable (target/web/bundle for \
target/release/gigawalk), where crates/web/build.sh writes it.";

#[derive(clap::Args)]
pub struct Args {
    /// The scene file (.gwk) to serve
    scene: PathBuf,
    /// The port to listen on; 0 takes any free one (the printed address
    /// says which)
    #[arg(long, value_name = "N", default_value_t = 8080)]
    port: u16,
    /// The address to listen on: 127.0.0.1 answers this machine only;
    /// 0.0.0.0 (or ::) answers every network the machine is on
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1")]
    bind: String,
    /// The viewer's bundle: a directory holding at least index.html and
    /// gigawalk_web_bg.wasm, whose files are all served (default:
    /// $GIGAWALK_WEB_BUNDLE, else ../web/bundle beside this executable)
    #[arg(long, value_name = "DIR")]
    bundle: Option<PathBuf>,
}

/// How long a connection may wait for its next request.
const IDLE: Duration = Duration::from_secs(60);
/// How long one write to a client may block.
const WRITE_TIMEOUT: Duration = Duration::from_secs(60);
/// The most bytes of a request's line or of one header line.
const MAX_LINE: usize = 8 * 1024;
/// The most header lines of a request.
const MAX_HEADERS: usize = 100;
/// The most bytes of a request body read (and dropped) to keep its
/// connection; a larger body closes it.
const MAX_DISCARDED_BODY: u64 = 64 * 1024;
/// The most connections served at once; more get 503.
const MAX_CONNECTIONS: usize = 256;

pub fn run(args: Args) -> anyhow::Result<()> {
    let scene_len = web::check_scene(&args.scene)?;
    let bundle = Bundle::find(args.bundle.as_deref())?;
    let addr = resolve(&args.bind, args.port)?;
    let listener = TcpListener::bind(addr).map_err(|e| {
        let hint = if e.kind() == std::io::ErrorKind::AddrInUse {
            "; give another --port (0 takes any free one)"
        } else {
            ""
        };
        anyhow::anyhow!("cannot listen on {addr}: {e}{hint}")
    })?;
    let local = listener
        .local_addr()
        .context("cannot tell the address listened on")?;
    let mut shown = local;
    if shown.ip().is_unspecified() {
        shown.set_ip(match shown {
            SocketAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
            SocketAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
        });
    }
    out!("http://{shown}/")?;
    eprintln!(
        "serving {} ({:.2} MiB) as /{} and the viewer from {} on {local}{}; stop with Ctrl-C",
        args.scene.display(),
        scene_len as f64 / (1 << 20) as f64,
        web::SCENE_NAME,
        bundle.dir.display(),
        if local.ip().is_unspecified() {
            " (every network interface)"
        } else {
            ""
        }
    );

    let site = Arc::new(Site {
        scene: args.scene,
        bundle_dir: bundle.dir,
        bundle_files: bundle.files,
        config: web::config_json(web::SCENE_NAME).into_bytes(),
    });
    let open = Arc::new(AtomicUsize::new(0));
    for conn in listener.incoming() {
        let stream = match conn {
            Ok(s) => s,
            Err(e) => {
                // Out of file descriptors and the like: wait, go on.
                eprintln!("warning: cannot accept a connection: {e}");
                std::thread::sleep(Duration::from_millis(100));
                continue;
            }
        };
        let slot = Slot::take(&open);
        let site = Arc::clone(&site);
        let spawned = std::thread::Builder::new()
            .name("gigawalk-serve".into())
            .spawn(move || {
                let mut stream = stream;
                match slot {
                    Some(_slot) => serve_connection(stream, &site),
                    None => {
                        let _ = write_plain(
                            &mut stream,
                            503,
                            Plain::new("too many connections; try again", false),
                        );
                        close(&mut stream);
                    }
                }
            });
        if let Err(e) = spawned {
            eprintln!("warning: cannot start a thread for a connection: {e}");
        }
    }
    Ok(())
}

/// The socket address `bind` and `port` name: an IP address or a host
/// name (its first address).
fn resolve(bind: &str, port: u16) -> anyhow::Result<SocketAddr> {
    if let Ok(ip) = bind.parse::<std::net::IpAddr>() {
        return Ok(SocketAddr::new(ip, port));
    }
    // "[::1]" as well as "::1".
    if let Ok(ip) = bind
        .trim_start_matches('[')
        .trim_end_matches(']')
        .parse::<std::net::Ipv6Addr>()
    {
        return Ok(SocketAddr::new(ip.into(), port));
    }
    (bind, port)
        .to_socket_addrs()
        .map_err(|e| anyhow::anyhow!("--bind {bind}: not an address this machine has: {e}"))?
        .next()
        .ok_or_else(|| anyhow::anyhow!("--bind {bind}: the name has no address"))
}

/// One of the [`MAX_CONNECTIONS`]: taken while a connection is served.
struct Slot(Arc<AtomicUsize>);

impl Slot {
    fn take(open: &Arc<AtomicUsize>) -> Option<Slot> {
        let n = open.fetch_add(1, Ordering::SeqCst);
        let slot = Slot(Arc::clone(open));
        (n < MAX_CONNECTIONS).then_some(slot)
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// What is served.
struct Site {
    scene: PathBuf,
    bundle_dir: PathBuf,
    /// The bundle's file names (see [`Bundle::files`]).
    bundle_files: Vec<String>,
    config: Vec<u8>,
}

/// A served thing: a file streamed from disk or bytes held here.
enum Body<'a> {
    File(PathBuf),
    Bytes(&'a [u8]),
}

impl Site {
    /// What the request path (query cut off) names, and its content type.
    fn lookup(&self, path: &str) -> Option<(Body<'_>, &'static str)> {
        let name = match path.strip_prefix('/')? {
            "" => "index.html",
            n => n,
        };
        let body = if name == web::CONFIG_NAME {
            Body::Bytes(&self.config)
        } else if name == web::SCENE_NAME {
            Body::File(self.scene.clone())
        } else if self.bundle_files.iter().any(|f| f == name) {
            Body::File(self.bundle_dir.join(name))
        } else {
            return None;
        };
        Some((body, content_type(name)))
    }
}

/// The content type of a file by its extension.
fn content_type(name: &str) -> &'static str {
    let ext = name.rsplit_once('.').map_or("", |(_, e)| e);
    match ext.to_ascii_lowercase().as_str() {
        "html" | "htm" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        // WebAssembly.instantiateStreaming refuses any other type.
        "wasm" => "application/wasm",
        "json" | "map" => "application/json",
        "css" => "text/css; charset=utf-8",
        "txt" => "text/plain; charset=utf-8",
        "svg" => "image/svg+xml",
        "png" => "image/png",
        "ico" => "image/x-icon",
        _ => "application/octet-stream",
    }
}

/// Why a request could not be read.
enum ReadFailure {
    /// The client closed the connection between requests.
    Closed,
    /// The connection failed or timed out: nothing to answer.
    Io,
    /// Not HTTP as this server reads it: answered with this status and
    /// reason, then the connection closes.
    Bad(u16, &'static str),
}

/// A request's head, as far as it matters here.
struct Request {
    method: String,
    /// The path, its query cut off.
    path: String,
    /// HTTP/1.1 or later (else 1.0: the connection closes after it).
    http11: bool,
    range: Option<String>,
    if_range: bool,
    connection_close: bool,
    /// Bytes of body that follow the head.
    body: u64,
}

fn serve_connection(stream: TcpStream, site: &Site) {
    let _ = stream.set_read_timeout(Some(IDLE));
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let _ = stream.set_nodelay(true);
    let Ok(read_half) = stream.try_clone() else {
        return;
    };
    let mut reader = BufReader::new(read_half);
    let mut out = stream;
    loop {
        let req = match read_request(&mut reader) {
            Ok(r) => r,
            Err(ReadFailure::Closed | ReadFailure::Io) => return,
            Err(ReadFailure::Bad(status, why)) => {
                let _ = write_plain(&mut out, status, Plain::new(why, false));
                close(&mut out);
                return;
            }
        };
        // A small body is read and dropped to keep the connection; a
        // larger one is not read, and the connection closes after the
        // answer.
        let mut keep = req.http11 && !req.connection_close && req.body <= MAX_DISCARDED_BODY;
        if req.body > 0 && keep {
            let mut body = (&mut reader).take(req.body);
            keep = matches!(std::io::copy(&mut body, &mut std::io::sink()), Ok(n) if n == req.body);
        }
        match answer(&mut out, &req, site, keep) {
            Ok(true) if keep => {}
            Ok(_) => {
                close(&mut out);
                return;
            }
            Err(_) => return,
        }
    }
}

/// Reads one line of at most [`MAX_LINE`] bytes, without its line end
/// (CRLF or a bare LF).
fn read_line(reader: &mut BufReader<TcpStream>, first: bool) -> Result<Vec<u8>, ReadFailure> {
    let mut line = Vec::new();
    loop {
        let buf = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(_) => return Err(ReadFailure::Io),
        };
        if buf.is_empty() {
            return Err(if first && line.is_empty() {
                ReadFailure::Closed
            } else {
                ReadFailure::Io
            });
        }
        let (take, done) = match buf.iter().position(|&b| b == b'\n') {
            Some(i) => (i + 1, true),
            None => (buf.len(), false),
        };
        line.extend_from_slice(&buf[..take]);
        reader.consume(take);
        if line.len() > MAX_LINE + 2 {
            return Err(ReadFailure::Bad(
                431,
                "a request line or header is too long",
            ));
        }
        if done {
            line.pop();
            if line.last() == Some(&b'\r') {
                line.pop();
            }
            return Ok(line);
        }
    }
}

/// A token character (RFC 9110): what methods and header names are made of.
fn is_tchar(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b)
}

fn read_request(reader: &mut BufReader<TcpStream>) -> Result<Request, ReadFailure> {
    const BAD_LINE: ReadFailure = ReadFailure::Bad(400, "malformed request line");
    // Empty lines before a request are allowed (RFC 9112, 2.2).
    let mut line = read_line(reader, true)?;
    let mut empty = 0;
    while line.is_empty() {
        empty += 1;
        if empty > 8 {
            return Err(BAD_LINE);
        }
        line = read_line(reader, true)?;
    }
    let line = std::str::from_utf8(&line).map_err(|_| BAD_LINE)?;
    let mut parts = line.split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(BAD_LINE);
    };
    if method.is_empty() || !method.bytes().all(is_tchar) {
        return Err(BAD_LINE);
    }
    let http11 = match version {
        "HTTP/1.1" => true,
        "HTTP/1.0" => false,
        v if v.starts_with("HTTP/") && v.len() == 8 => {
            return Err(ReadFailure::Bad(505, "only HTTP/1.0 and 1.1 are served"));
        }
        _ => return Err(BAD_LINE),
    };
    // Origin form (/path?query), or absolute form (http://host/path).
    let path = if target.starts_with('/') {
        target
    } else if let Some(rest) = target
        .strip_prefix("http://")
        .or_else(|| target.strip_prefix("https://"))
    {
        rest.find('/').map_or("/", |i| &rest[i..])
    } else {
        return Err(BAD_LINE);
    };
    if path.bytes().any(|b| b.is_ascii_control() || b == b' ') {
        return Err(BAD_LINE);
    }
    let path = path
        .split(['?', '#'])
        .next()
        .unwrap_or_default()
        .to_string();

    let mut req = Request {
        method: method.to_string(),
        path,
        http11,
        range: None,
        if_range: false,
        connection_close: false,
        body: 0,
    };
    let mut host = false;
    for n in 0.. {
        let line = read_line(reader, false)?;
        if line.is_empty() {
            break;
        }
        if n >= MAX_HEADERS {
            return Err(ReadFailure::Bad(431, "too many header lines"));
        }
        const BAD_HEADER: ReadFailure = ReadFailure::Bad(400, "malformed header line");
        let colon = line.iter().position(|&b| b == b':').ok_or(BAD_HEADER)?;
        let (name, value) = (&line[..colon], &line[colon + 1..]);
        // No space before the colon, no folded lines (RFC 9112, 5).
        if name.is_empty() || !name.iter().copied().all(is_tchar) {
            return Err(BAD_HEADER);
        }
        let name = String::from_utf8_lossy(name).to_ascii_lowercase();
        let value = String::from_utf8_lossy(value).trim().to_string();
        match name.as_str() {
            "host" => host = true,
            "range" => req.range = Some(value),
            "if-range" => req.if_range = true,
            "connection" => {
                req.connection_close |= value
                    .split(',')
                    .any(|t| t.trim().eq_ignore_ascii_case("close"));
            }
            "content-length" => {
                req.body = value
                    .parse()
                    .map_err(|_| ReadFailure::Bad(400, "malformed Content-Length"))?;
            }
            "transfer-encoding" => {
                return Err(ReadFailure::Bad(400, "request bodies are not accepted"));
            }
            _ => {}
        }
    }
    if req.http11 && !host {
        return Err(ReadFailure::Bad(
            400,
            "an HTTP/1.1 request needs a Host header",
        ));
    }
    Ok(req)
}

/// What a Range header asks of a body of `len` bytes.
#[derive(Debug, PartialEq)]
enum Ranged {
    /// The whole body: no Range, or one this server ignores (another unit,
    /// a malformed one, several ranges) — RFC 9110, 14.2 lets a server
    /// answer any Range with the whole body, and a request for several
    /// ranges gets it rather than a multipart/byteranges answer.
    Whole,
    /// Bytes `start..=end`.
    Part(u64, u64),
    /// No byte of the body is in the range: 416.
    Unsatisfiable,
}

/// The Range header `header` against a body of `len` bytes.
fn ranged(header: Option<&str>, len: u64) -> Ranged {
    let Some(header) = header else {
        return Ranged::Whole;
    };
    let Some((unit, spec)) = header.split_once('=') else {
        return Ranged::Whole;
    };
    if !unit.trim().eq_ignore_ascii_case("bytes") || spec.contains(',') {
        return Ranged::Whole;
    }
    let Some((first, last)) = spec.trim().split_once('-') else {
        return Ranged::Whole;
    };
    // Digits only; a number past u64 is as good as u64::MAX here.
    let number = |s: &str| {
        (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
            .then(|| s.parse::<u64>().unwrap_or(u64::MAX))
    };
    match (first, number(first), number(last)) {
        // bytes=-n: the last n bytes.
        ("", _, Some(n)) => {
            if n == 0 || len == 0 {
                Ranged::Unsatisfiable
            } else {
                Ranged::Part(len.saturating_sub(n), len - 1)
            }
        }
        // bytes=a-
        (_, Some(a), None) if last.is_empty() => {
            if a >= len {
                Ranged::Unsatisfiable
            } else {
                Ranged::Part(a, len - 1)
            }
        }
        // bytes=a-b
        (_, Some(a), Some(b)) if a <= b => {
            if a >= len {
                Ranged::Unsatisfiable
            } else {
                Ranged::Part(a, b.min(len - 1))
            }
        }
        _ => Ranged::Whole,
    }
}

/// Answers `req`; `Ok(true)` when the connection can carry another
/// request (its whole answer was written).
fn answer(out: &mut TcpStream, req: &Request, site: &Site, keep: bool) -> std::io::Result<bool> {
    let head_only = match req.method.as_str() {
        "GET" => false,
        "HEAD" => true,
        _ => {
            let mut p = Plain::new("only GET and HEAD are answered", keep);
            p.extra.push(("Allow", "GET, HEAD".into()));
            return write_plain(out, 405, p).map(|()| true);
        }
    };
    let plain = |why| Plain {
        head_only,
        ..Plain::new(why, keep)
    };
    let Some((body, ctype)) = site.lookup(&req.path) else {
        return write_plain(out, 404, plain("no such file here")).map(|()| true);
    };
    let (mut file, len) = match &body {
        Body::Bytes(b) => (None, b.len() as u64),
        Body::File(path) => match open(path) {
            Ok((f, len)) => (Some(f), len),
            Err(e) => {
                eprintln!("warning: {}: cannot read: {e}", path.display());
                let status = if e.kind() == std::io::ErrorKind::NotFound {
                    404
                } else {
                    500
                };
                return write_plain(out, status, plain("cannot read the file")).map(|()| true);
            }
        },
    };
    let range = if req.if_range {
        // No validators are sent, so none a client holds can match:
        // RFC 9110, 13.1.5 says to send the whole body then.
        Ranged::Whole
    } else {
        ranged(req.range.as_deref(), len)
    };
    let (status, start, count) = match range {
        Ranged::Whole => (200, 0, len),
        Ranged::Part(a, b) => (206, a, b - a + 1),
        Ranged::Unsatisfiable => {
            let mut p = plain("the range starts past the end");
            p.extra.push(("Content-Range", format!("bytes */{len}")));
            return write_plain(out, 416, p).map(|()| true);
        }
    };
    let mut headers = vec![
        ("Content-Type", ctype.to_string()),
        ("Content-Length", count.to_string()),
        ("Accept-Ranges", "bytes".to_string()),
        ("Cache-Control", "no-cache".to_string()),
    ];
    if status == 206 {
        headers.push((
            "Content-Range",
            format!("bytes {start}-{}/{len}", start + count - 1),
        ));
    }
    write_head(out, status, &headers, keep)?;
    if head_only {
        return Ok(true);
    }
    match (&body, file.as_mut()) {
        (Body::Bytes(b), _) => {
            // Both ends are within `b`: `ranged` keeps them below its length.
            let (s, e) = (start as usize, (start + count) as usize);
            out.write_all(&b[s..e])?;
            Ok(true)
        }
        (Body::File(_), Some(f)) => {
            f.seek(SeekFrom::Start(start))?;
            let sent = std::io::copy(&mut f.take(count), out)?;
            // A file that shrank since it was opened: the answer is short,
            // and only closing the connection tells the client so.
            Ok(sent == count)
        }
        (Body::File(_), None) => Ok(false),
    }
}

/// Opens a file to serve: the file and its length now.
fn open(path: &std::path::Path) -> std::io::Result<(std::fs::File, u64)> {
    let f = std::fs::File::open(path)?;
    let m = f.metadata()?;
    if !m.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "not a regular file",
        ));
    }
    Ok((f, m.len()))
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        206 => "Partial Content",
        400 => "Bad Request",
        404 => "Not Found",
        405 => "Method Not Allowed",
        416 => "Range Not Satisfiable",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "",
    }
}

/// Writes a status line and headers (with Date, and Connection: close
/// unless `keep`).
fn write_head(
    out: &mut TcpStream,
    status: u16,
    headers: &[(&str, String)],
    keep: bool,
) -> std::io::Result<()> {
    let mut head = format!(
        "HTTP/1.1 {status} {}\r\nDate: {}\r\nServer: gigawalk\r\n",
        reason(status),
        http_date(std::time::SystemTime::now())
    );
    for (name, value) in headers {
        head.push_str(name);
        head.push_str(": ");
        head.push_str(value);
        head.push_str("\r\n");
    }
    if !keep {
        head.push_str("Connection: close\r\n");
    }
    head.push_str("\r\n");
    out.write_all(head.as_bytes())
}

/// What an answer without a served body says beside its status.
struct Plain<'a> {
    why: &'a str,
    /// Headers before the content type and length.
    extra: Vec<(&'static str, String)>,
    /// Whether the connection stays open after it.
    keep: bool,
    /// A HEAD request's answer: the headers only.
    head_only: bool,
}

impl<'a> Plain<'a> {
    fn new(why: &'a str, keep: bool) -> Self {
        Plain {
            why,
            extra: Vec::new(),
            keep,
            head_only: false,
        }
    }
}

/// An answer with a one-line text body saying `status` and why.
fn write_plain(out: &mut TcpStream, status: u16, p: Plain) -> std::io::Result<()> {
    let body = format!("{status} {}: {}\n", reason(status), p.why);
    let mut headers = p.extra;
    headers.push(("Content-Type", "text/plain; charset=utf-8".into()));
    headers.push(("Content-Length", body.len().to_string()));
    write_head(out, status, &headers, p.keep)?;
    if p.head_only {
        return Ok(());
    }
    out.write_all(body.as_bytes())
}

/// Closes a connection after its last answer: stops sending, then reads
/// (briefly) what the client still sends, since closing with unread data
/// makes the system reset the connection, which can lose the answer before
/// the client reads it.
fn close(stream: &mut TcpStream) {
    let _ = stream.shutdown(std::net::Shutdown::Write);
    let _ = stream.set_read_timeout(Some(Duration::from_secs(1)));
    let mut rest = stream.take(MAX_DISCARDED_BODY);
    let _ = std::io::copy(&mut rest, &mut std::io::sink());
}

/// A time as HTTP writes it (RFC 9110, 5.6.7): `Sun, 06 Nov 1994 08:49:37 GMT`.
fn http_date(t: std::time::SystemTime) -> String {
    let secs = t
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rest) = (secs / 86_400, secs % 86_400);
    // Days since 1970-01-01 to a civil date (H. Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    const WEEKDAYS: [&str; 7] = ["Thu", "Fri", "Sat", "Sun", "Mon", "Tue", "Wed"];
    const MONTHS: [&str; 12] = [
        "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
    ];
    format!(
        "{}, {day:02} {} {year} {:02}:{:02}:{:02} GMT",
        WEEKDAYS[(days % 7) as usize],
        MONTHS[(month - 1) as usize],
        rest / 3600,
        rest % 3600 / 60,
        rest % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges() {
        let r = |h: &str| ranged(Some(h), 100);
        assert_eq!(ranged(None, 100), Ranged::Whole);
        assert_eq!(r("bytes=0-9"), Ranged::Part(0, 9));
        assert_eq!(r("bytes=90-200"), Ranged::Part(90, 99));
        assert_eq!(r("bytes=10-"), Ranged::Part(10, 99));
        assert_eq!(r("bytes=-10"), Ranged::Part(90, 99));
        assert_eq!(r("bytes=-1000"), Ranged::Part(0, 99));
        assert_eq!(r("Bytes = 5-5"), Ranged::Part(5, 5));
        assert_eq!(r("bytes=100-"), Ranged::Unsatisfiable);
        assert_eq!(r("bytes=100-200"), Ranged::Unsatisfiable);
        assert_eq!(r("bytes=-0"), Ranged::Unsatisfiable);
        assert_eq!(
            r("bytes=99999999999999999999999999-"),
            Ranged::Unsatisfiable
        );
        assert_eq!(r("bytes=0-99999999999999999999999999"), Ranged::Part(0, 99));
        assert_eq!(ranged(Some("bytes=0-"), 0), Ranged::Unsatisfiable);
        assert_eq!(ranged(Some("bytes=-5"), 0), Ranged::Unsatisfiable);
        for ignored in [
            "bytes=5-1",
            "bytes=0-1,5-6",
            "items=0-1",
            "bytes=a-b",
            "bytes=-",
            "bytes=1",
            "bytes=+1-2",
            "bytes",
            "",
        ] {
            assert_eq!(r(ignored), Ranged::Whole, "{ignored}");
        }
    }

    #[test]
    fn dates() {
        let t = |s| http_date(std::time::UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(t(0), "Thu, 01 Jan 1970 00:00:00 GMT");
        assert_eq!(t(784_111_777), "Sun, 06 Nov 1994 08:49:37 GMT");
        assert_eq!(t(951_782_400), "Tue, 29 Feb 2000 00:00:00 GMT");
    }

    #[test]
    fn content_types() {
        assert_eq!(content_type("index.html"), "text/html; charset=utf-8");
        assert_eq!(content_type("gigawalk_web_bg.wasm"), "application/wasm");
        assert_eq!(content_type("main.js"), "text/javascript; charset=utf-8");
        assert_eq!(content_type("config.json"), "application/json");
        assert_eq!(content_type("scene.gwk"), "application/octet-stream");
        assert_eq!(content_type("README"), "application/octet-stream");
    }
}
