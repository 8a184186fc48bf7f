//! What each request gets: a name looked up in the site's fixed list (the
//! bundle's files, `config.json`, `scene.gwk`; never a path joined to the
//! file system), then what a static server answers for it — the whole
//! file or one byte range, HEAD, 304 for a copy the client still holds —
//! streamed from a file opened anew for the request.

use std::convert::Infallible;
use std::future::Future;
use std::io::SeekFrom;
use std::path::PathBuf;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::SystemTime;

use bytes::Bytes;
use http::header::{self, HeaderMap, HeaderValue};
use http::{Method, Request, Response, StatusCode, Version};
use http_body::{Body, Frame, SizeHint};
use tokio::io::{AsyncRead, AsyncSeekExt as _, ReadBuf};

use crate::bundle::{CONFIG_NAME, SCENE_NAME};
use crate::range::{if_range_holds, ranged, Ranged};

/// The bytes read from a file per body frame.
const CHUNK: usize = 64 * 1024;

/// What is served.
pub(crate) struct Site {
    pub scene: PathBuf,
    pub bundle_dir: PathBuf,
    /// The bundle's file names (see [`crate::Bundle::files`]).
    pub bundle_files: Vec<String>,
    pub config: Bytes,
    /// config.json's validators: it is made once, when the server starts.
    pub config_etag: String,
    pub started: SystemTime,
}

/// Where a served name's bytes come from.
enum Source {
    File(PathBuf),
    Config,
}

impl Site {
    /// What the request path (its query already cut off by the URI)
    /// names.
    fn lookup(&self, path: &str) -> Option<(Source, &'static str)> {
        let name = match path.strip_prefix('/')? {
            "" => "index.html",
            n => n,
        };
        let source = if name == CONFIG_NAME {
            Source::Config
        } else if name == SCENE_NAME {
            Source::File(self.scene.clone())
        } else if self.bundle_files.iter().any(|f| f == name) {
            Source::File(self.bundle_dir.join(name))
        } else {
            return None;
        };
        Some((source, content_type(name)))
    }

    /// The answer to `req`.
    pub(crate) async fn answer(&self, req: &http::request::Parts) -> Response<Payload> {
        // Origin form (/path?query) and absolute form (http://host/path)
        // have a path; authority form and `*` do not, and are for CONNECT
        // and OPTIONS, which are not served.
        let path = req.uri.path();
        if !path.starts_with('/') {
            return plain(StatusCode::BAD_REQUEST, "malformed request target").closing();
        }
        if req.version == Version::HTTP_11 && !req.headers.contains_key(header::HOST) {
            return plain(
                StatusCode::BAD_REQUEST,
                "an HTTP/1.1 request needs a Host header",
            )
            .closing();
        }
        let head_only = match req.method {
            Method::GET => false,
            Method::HEAD => true,
            _ => {
                let mut r = plain(
                    StatusCode::METHOD_NOT_ALLOWED,
                    "only GET and HEAD are answered",
                );
                r.headers_mut()
                    .insert(header::ALLOW, HeaderValue::from_static("GET, HEAD"));
                return r;
            }
        };
        let Some((source, ctype)) = self.lookup(path) else {
            return plain(StatusCode::NOT_FOUND, "no such file here").head_only(head_only);
        };
        let compressible = compressible(ctype);
        let (content, len, etag, modified) = match source {
            Source::Config => (
                Content::Bytes(self.config.clone()),
                self.config.len() as u64,
                self.config_etag.clone(),
                Some(self.started),
            ),
            Source::File(path) => match open(&path).await {
                Ok((file, len, modified)) => {
                    let etag = file_etag(len, modified, compressible);
                    (Content::File(file, path), len, etag, modified)
                }
                Err(e) => {
                    tracing::warn!("{}: cannot read: {e}", path.display());
                    let status = if e.kind() == std::io::ErrorKind::NotFound {
                        StatusCode::NOT_FOUND
                    } else {
                        StatusCode::INTERNAL_SERVER_ERROR
                    };
                    return plain(status, "cannot read the file").head_only(head_only);
                }
            },
        };

        let mut headers = HeaderMap::new();
        headers.insert(header::CONTENT_TYPE, HeaderValue::from_static(ctype));
        headers.insert(header::ACCEPT_RANGES, HeaderValue::from_static("bytes"));
        // Asked again each time, answered with 304 while unchanged: a
        // scene written again in place is never shown from a stale copy.
        headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
        if let Ok(v) = HeaderValue::from_str(&etag) {
            headers.insert(header::ETAG, v);
        }
        if let Some(m) = modified {
            if let Ok(v) = HeaderValue::from_str(&httpdate::fmt_http_date(m)) {
                headers.insert(header::LAST_MODIFIED, v);
            }
        }

        // Conditions before ranges (RFC 9110, 13.2.2).
        if not_modified(&req.headers, &etag, modified) {
            headers.remove(header::CONTENT_TYPE);
            return respond(StatusCode::NOT_MODIFIED, headers, Payload::empty());
        }
        let range_header = req.headers.get(header::RANGE).and_then(text);
        let if_range = req.headers.get(header::IF_RANGE).and_then(text);
        let range = match if_range {
            Some(v) if !if_range_holds(v, &etag, modified) => Ranged::Whole,
            _ => ranged(range_header, len),
        };
        let (status, start, count) = match range {
            Ranged::Whole => (StatusCode::OK, 0, len),
            Ranged::Part(a, b) => (StatusCode::PARTIAL_CONTENT, a, b - a + 1),
            Ranged::Unsatisfiable => {
                let mut r = plain(
                    StatusCode::RANGE_NOT_SATISFIABLE,
                    "the range starts past the end",
                )
                .head_only(head_only);
                if let Ok(v) = HeaderValue::from_str(&format!("bytes */{len}")) {
                    r.headers_mut().insert(header::CONTENT_RANGE, v);
                }
                return r;
            }
        };
        headers.insert(header::CONTENT_LENGTH, HeaderValue::from(count));
        if status == StatusCode::PARTIAL_CONTENT {
            let range = format!("bytes {start}-{}/{len}", start + count - 1);
            if let Ok(v) = HeaderValue::from_str(&range) {
                headers.insert(header::CONTENT_RANGE, v);
            }
        }
        if head_only {
            return respond(status, headers, Payload::empty());
        }
        let body = match content {
            // Both ends are within the bytes: `ranged` keeps them below
            // its length.
            Content::Bytes(b) => Payload::bytes(b.slice(start as usize..(start + count) as usize)),
            Content::File(mut file, path) => {
                if let Err(e) = file.seek(SeekFrom::Start(start)).await {
                    tracing::warn!("{}: cannot read: {e}", path.display());
                    return plain(StatusCode::INTERNAL_SERVER_ERROR, "cannot read the file");
                }
                Payload::file(file, count)
            }
        };
        respond(status, headers, body)
    }
}

/// A served thing's bytes, once opened.
enum Content {
    File(tokio::fs::File, PathBuf),
    Bytes(Bytes),
}

/// A header's value as text, if it is.
fn text(v: &HeaderValue) -> Option<&str> {
    v.to_str().ok()
}

/// Opens a file to serve: the file, its length and its modification time
/// now.
async fn open(
    path: &std::path::Path,
) -> std::io::Result<(tokio::fs::File, u64, Option<SystemTime>)> {
    let f = tokio::fs::File::open(path).await?;
    let m = f.metadata().await?;
    if !m.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "not a regular file",
        ));
    }
    Ok((f, m.len(), m.modified().ok()))
}

/// A file's entity tag, from its length and modification time: a file
/// written again gets another. Weak for what may be sent gzipped (the
/// gzipped bytes are another representation, RFC 9110, 8.8.3), strong
/// for the rest, so If-Range can match it.
pub(crate) fn file_etag(len: u64, modified: Option<SystemTime>, weak: bool) -> String {
    let nanos = modified
        .and_then(|m| m.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    format!("{}\"{len:x}-{nanos:x}\"", if weak { "W/" } else { "" })
}

/// Whether the client's copy (its If-None-Match, else its
/// If-Modified-Since) is still the one served (RFC 9110, 13.1.2 and
/// 13.1.3): a weak comparison of entity tags, dates to the second.
fn not_modified(headers: &HeaderMap, etag: &str, modified: Option<SystemTime>) -> bool {
    let opaque = |t: &str| t.trim().trim_start_matches("W/").to_string();
    if let Some(v) = headers.get(header::IF_NONE_MATCH) {
        let Some(v) = text(v) else {
            return false;
        };
        return v.trim() == "*" || v.split(',').any(|t| opaque(t) == opaque(etag));
    }
    let since = headers
        .get(header::IF_MODIFIED_SINCE)
        .and_then(text)
        .and_then(|v| httpdate::parse_http_date(v).ok());
    match (since, modified) {
        (Some(since), Some(m)) => {
            let secs = |t: SystemTime| {
                t.duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs())
            };
            secs(m) <= secs(since)
        }
        _ => false,
    }
}

/// The content type of a file by its extension.
pub(crate) fn content_type(name: &str) -> &'static str {
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

/// Whether answers of this content type are gzipped for a client that
/// takes gzip: the page's text and its wasm, which shrink severalfold;
/// never the scene, whose geometry is already compressed and which is
/// read in ranges.
pub(crate) fn compressible(ctype: &str) -> bool {
    ctype.starts_with("text/")
        || ctype.starts_with("application/wasm")
        || ctype.starts_with("application/json")
        || ctype.starts_with("image/svg+xml")
}

/// Which answers tower-http's compression gzips: whole bodies (200) of
/// [`compressible`] types above a few hundred bytes (smaller ones gain
/// less than gzip's header costs).
#[derive(Clone, Copy)]
pub(crate) struct Gzippable;

impl tower_http::compression::Predicate for Gzippable {
    fn should_compress<B: Body>(&self, r: &Response<B>) -> bool {
        let h = r.headers();
        let small = h
            .get(header::CONTENT_LENGTH)
            .and_then(text)
            .and_then(|v| v.parse::<u64>().ok())
            .is_some_and(|n| n < 256);
        r.status() == StatusCode::OK
            && !small
            && !h.contains_key(header::CONTENT_RANGE)
            && h.get(header::CONTENT_TYPE)
                .and_then(text)
                .is_some_and(compressible)
    }
}

fn respond(status: StatusCode, headers: HeaderMap, body: Payload) -> Response<Payload> {
    let mut r = Response::new(body);
    *r.status_mut() = status;
    *r.headers_mut() = headers;
    r
}

/// An answer with a one-line text body saying `status` and why.
fn plain(status: StatusCode, why: &str) -> Response<Payload> {
    let body = format!(
        "{} {}: {why}\n",
        status.as_u16(),
        status.canonical_reason().unwrap_or("")
    );
    let mut headers = HeaderMap::new();
    headers.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/plain; charset=utf-8"),
    );
    headers.insert(header::CONTENT_LENGTH, HeaderValue::from(body.len()));
    respond(status, headers, Payload::bytes(Bytes::from(body)))
}

/// What [`plain`] answers can be made into.
trait PlainExt {
    /// The connection closes after it: the request was not HTTP as this
    /// server reads it, so what follows on the connection cannot be
    /// trusted to be the next request.
    fn closing(self) -> Self;
    /// The headers only, for a HEAD request.
    fn head_only(self, yes: bool) -> Self;
}

impl PlainExt for Response<Payload> {
    fn closing(mut self) -> Self {
        self.headers_mut()
            .insert(header::CONNECTION, HeaderValue::from_static("close"));
        self
    }

    fn head_only(mut self, yes: bool) -> Self {
        if yes {
            *self.body_mut() = Payload::empty();
        }
        self
    }
}

/// A response body: bytes held here, or a file streamed [`CHUNK`] bytes
/// a frame.
pub struct Payload(Inner);

enum Inner {
    Bytes(Option<Bytes>),
    File {
        file: tokio::fs::File,
        left: u64,
        buf: Box<[u8]>,
    },
}

impl Payload {
    fn empty() -> Payload {
        Payload(Inner::Bytes(None))
    }

    fn bytes(b: Bytes) -> Payload {
        Payload(Inner::Bytes((!b.is_empty()).then_some(b)))
    }

    /// The next `count` bytes of `file`.
    fn file(file: tokio::fs::File, count: u64) -> Payload {
        Payload(Inner::File {
            file,
            left: count,
            buf: vec![0; CHUNK.min(count as usize)].into_boxed_slice(),
        })
    }
}

impl Body for Payload {
    type Data = Bytes;
    type Error = std::io::Error;

    fn poll_frame(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, std::io::Error>>> {
        match &mut self.get_mut().0 {
            Inner::Bytes(b) => Poll::Ready(b.take().map(|b| Ok(Frame::data(b)))),
            Inner::File { file, left, buf } => {
                if *left == 0 {
                    return Poll::Ready(None);
                }
                let n = (buf.len() as u64).min(*left) as usize;
                let mut rb = ReadBuf::new(&mut buf[..n]);
                match Pin::new(file).poll_read(cx, &mut rb) {
                    Poll::Pending => Poll::Pending,
                    Poll::Ready(Err(e)) => Poll::Ready(Some(Err(e))),
                    // A file that shrank since it was opened: the answer
                    // is short, and only an error (the connection closed)
                    // tells the client so.
                    Poll::Ready(Ok(())) if rb.filled().is_empty() => {
                        Poll::Ready(Some(Err(std::io::Error::new(
                            std::io::ErrorKind::UnexpectedEof,
                            "the file shrank while it was sent",
                        ))))
                    }
                    Poll::Ready(Ok(())) => {
                        let got = rb.filled();
                        *left -= got.len() as u64;
                        Poll::Ready(Some(Ok(Frame::data(Bytes::copy_from_slice(got)))))
                    }
                }
            }
        }
    }

    fn is_end_stream(&self) -> bool {
        match &self.0 {
            Inner::Bytes(b) => b.is_none(),
            Inner::File { left, .. } => *left == 0,
        }
    }

    fn size_hint(&self) -> SizeHint {
        match &self.0 {
            Inner::Bytes(b) => SizeHint::with_exact(b.as_ref().map_or(0, |b| b.len() as u64)),
            Inner::File { left, .. } => SizeHint::with_exact(*left),
        }
    }
}

/// The site as a tower service, which tower-http's compression wraps and
/// hyper calls.
#[derive(Clone)]
pub(crate) struct SiteService(pub Arc<Site>);

impl<B: Send + 'static> tower_service::Service<Request<B>> for SiteService {
    type Response = Response<Payload>;
    type Error = Infallible;
    type Future = Pin<Box<dyn Future<Output = Result<Response<Payload>, Infallible>> + Send>>;

    fn poll_ready(&mut self, _: &mut Context<'_>) -> Poll<Result<(), Infallible>> {
        Poll::Ready(Ok(()))
    }

    fn call(&mut self, req: Request<B>) -> Self::Future {
        let site = Arc::clone(&self.0);
        // The head only: the body (which GET and HEAD do not have) is
        // not read, and the head can be held across awaits.
        let (head, _) = req.into_parts();
        Box::pin(async move { Ok(site.answer(&head).await) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn content_types() {
        assert_eq!(content_type("index.html"), "text/html; charset=utf-8");
        assert_eq!(content_type("gigawalk_web_bg.wasm"), "application/wasm");
        assert_eq!(content_type("main.js"), "text/javascript; charset=utf-8");
        assert_eq!(content_type("config.json"), "application/json");
        assert_eq!(content_type("scene.gwk"), "application/octet-stream");
        assert_eq!(content_type("README"), "application/octet-stream");
        assert!(compressible(content_type("main.js")));
        assert!(compressible(content_type("gigawalk_web_bg.wasm")));
        assert!(!compressible(content_type("scene.gwk")));
        assert!(!compressible(content_type("icon.png")));
    }

    #[test]
    fn conditions_compare_tags_weakly_and_dates_to_the_second() {
        let m = std::time::UNIX_EPOCH + std::time::Duration::from_millis(784_111_777_500);
        let strong = file_etag(10, Some(m), false);
        let weak = file_etag(10, Some(m), true);
        assert_eq!(weak, format!("W/{strong}"));
        assert_ne!(strong, file_etag(11, Some(m), false), "another length");
        let check = |name: header::HeaderName, v: &str, etag: &str| {
            let mut h = HeaderMap::new();
            h.insert(name, HeaderValue::from_str(v).unwrap());
            not_modified(&h, etag, Some(m))
        };
        assert!(check(header::IF_NONE_MATCH, &strong, &weak));
        assert!(check(
            header::IF_NONE_MATCH,
            &format!("\"x\", {weak}"),
            &strong
        ));
        assert!(check(header::IF_NONE_MATCH, "*", &strong));
        assert!(!check(header::IF_NONE_MATCH, "\"x\"", &strong));
        let date = "Sun, 06 Nov 1994 08:49:37 GMT";
        assert!(check(header::IF_MODIFIED_SINCE, date, &strong));
        assert!(!check(
            header::IF_MODIFIED_SINCE,
            "Sun, 06 Nov 1994 08:49:36 GMT",
            &strong
        ));
        assert!(!check(header::IF_MODIFIED_SINCE, "not a date", &strong));
        assert!(!not_modified(&HeaderMap::new(), &strong, Some(m)));
        // If-None-Match decides when both are sent.
        let mut h = HeaderMap::new();
        h.insert(header::IF_NONE_MATCH, HeaderValue::from_static("\"x\""));
        h.insert(header::IF_MODIFIED_SINCE, HeaderValue::from_static(date));
        assert!(!not_modified(&h, &strong, Some(m)));
    }
}
