//! gigawalk's HTTP server for the browser viewer (`gigawalk serve`): the
//! site `gigawalk web` writes, served without writing it — the bundle's
//! files, `/config.json` and `/scene.gwk` — with the range requests the
//! page reads the scene by.
//!
//! Main items: [`Server`] (bound by [`Server::bind`], then
//! [`Server::run`] or [`Server::run_until`]; [`Stopper`] ends a run),
//! [`Config`] and its [`Limits`], [`resolve`] (an address from a host and
//! port); [`Bundle`], [`check_scene`] and [`config_json`], what a site is
//! made of, shared with `gigawalk web`; errors [`ServeError`],
//! [`BundleError`], [`SceneError`].
//!
//! What it answers, as a static server would: GET and HEAD of a fixed
//! list of names (the bundle's files as listed at start, `/config.json`,
//! `/scene.gwk`; `/` is index.html), each looked up by name, never joined
//! to a path on disk, so no request reaches another file; everything
//! else 404, other methods 405, a request that is not HTTP 400 (431 for
//! an oversized head). One byte range (`bytes=a-b`, `a-`, `-n`) gets 206,
//! one past the end 416, several the whole file. Every answer carries
//! `ETag` and `Last-Modified` with `Cache-Control: no-cache`, so a
//! browser asks again each time and gets 304 while its copy is current
//! (`If-None-Match`, else `If-Modified-Since`). The page's text and wasm
//! are gzipped for a client that takes it; the scene never is. Files are
//! opened anew for each request: a scene written again in place is
//! served as it is now, with a new entity tag.
//!
//! The stack: hyper 1's HTTP/1.1 connections on a tokio runtime this
//! crate creates and owns (multi-threaded, [`Limits::workers`] threads,
//! two by default: with 3,000 idle connections held, one and two
//! answered alike, median 0.19 ms (`examples/serve_load.rs`), but gzip
//! runs on the worker answering, so a second keeps ranges flowing while
//! the wasm is compressed), tower-http's `CompressionLayer` for gzip. tower-http's `ServeDir` maps
//! request paths onto the file system, which this server never does; its
//! `ServeFile` answers several ranges with 416 where this server (as
//! before it) sends the whole file, sends no entity tag, and cannot serve
//! config.json from memory. So what a static server adds to hyper here
//! (the lookup, one range, the two conditions, HEAD) is `site.rs` and
//! `range.rs`, tested byte for byte; axum would add a router that a fixed
//! list of names has no use for.
//!
//! Holding connections costs a task and a socket each, not a thread:
//! thousands of idle clients (a slow network, or one client holding them
//! open on purpose) delay no other request. A request head must arrive
//! within [`Limits::header_read_timeout`]; a connection on which no byte
//! moves either way for [`Limits::idle_timeout`] is closed; at most
//! [`Limits::max_connections`] are open at once, and the next waits in
//! the listen backlog until one closes rather than being refused.
//! [`Server::bind`] raises the process's soft limit on open files to its
//! hard limit, so that cap is reachable; when the hard limit is lower,
//! the cap is what the system allows ([`Server::fd_limit`] says it).

#![forbid(unsafe_code)]

mod bundle;
mod range;
mod site;

use std::future::Future;
use std::net::{SocketAddr, ToSocketAddrs as _};
use std::path::PathBuf;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::task::{Context, Poll};
use std::time::{Duration, Instant, SystemTime};

use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::sync::{Notify, Semaphore};
use tower_http::compression::CompressionLayer;
use tower_layer::Layer as _;

pub use bundle::{
    check_scene, config_json, Bundle, BundleError, SceneError, BUNDLE_ENV, CONFIG_NAME, SCENE_NAME,
};
pub use site::Payload;

use site::{Gzippable, Site, SiteService};

/// The most bytes a request's head may take (request line and headers);
/// a larger one gets 431. Also bounds what a client that never finishes
/// its head makes the server hold.
const MAX_HEAD: usize = 64 * 1024;
/// How long to wait before accepting again when accepting fails (out of
/// file descriptors and the like: connections closing free them).
const ACCEPT_RETRY: Duration = Duration::from_millis(100);

/// How much the server lets clients hold.
#[derive(Clone, Debug)]
pub struct Limits {
    /// The most connections open at once; the next waits to be accepted
    /// until one closes. Each holds a file descriptor.
    pub max_connections: usize,
    /// How long a request's head (its line and headers) may take to
    /// arrive once it has begun.
    pub header_read_timeout: Duration,
    /// How long a connection may go without a byte read or written
    /// before it is closed: a kept-alive connection between requests, or
    /// a client that stopped reading an answer.
    pub idle_timeout: Duration,
    /// The runtime's worker threads: connections are tasks spread over
    /// them, file reads go to tokio's blocking pool beside them.
    pub workers: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_connections: 10_000,
            header_read_timeout: Duration::from_secs(10),
            idle_timeout: Duration::from_secs(60),
            workers: 2,
        }
    }
}

/// What a server serves, and where.
#[derive(Clone, Debug)]
pub struct Config {
    /// The address to listen on (port 0: any free one).
    pub addr: SocketAddr,
    /// The scene file, served as `/scene.gwk`.
    pub scene: PathBuf,
    /// The viewer's bundle, whose files are served by name.
    pub bundle: Bundle,
    pub limits: Limits,
}

/// Why a server cannot start or run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ServeError {
    #[error("cannot listen on {addr}: {source}{hint}")]
    Bind {
        addr: SocketAddr,
        #[source]
        source: std::io::Error,
        /// What to do about it, when there is something.
        hint: &'static str,
    },
    #[error("{bind}: not an address this machine has: {source}")]
    Resolve {
        bind: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{bind}: the name has no address")]
    NoAddress { bind: String },
    #[error("cannot start the server's runtime: {0}")]
    Runtime(#[source] std::io::Error),
    #[error("cannot tell the address listened on: {0}")]
    LocalAddr(#[source] std::io::Error),
}

/// The socket address `bind` and `port` name: an IP address (`::1` or
/// `[::1]` for IPv6) or a host name (its first address).
pub fn resolve(bind: &str, port: u16) -> Result<SocketAddr, ServeError> {
    if let Ok(ip) = bind.parse::<std::net::IpAddr>() {
        return Ok(SocketAddr::new(ip, port));
    }
    if let Ok(ip) = bind
        .trim_start_matches('[')
        .trim_end_matches(']')
        .parse::<std::net::Ipv6Addr>()
    {
        return Ok(SocketAddr::new(ip.into(), port));
    }
    (bind, port)
        .to_socket_addrs()
        .map_err(|source| ServeError::Resolve {
            bind: bind.to_string(),
            source,
        })?
        .next()
        .ok_or_else(|| ServeError::NoAddress {
            bind: bind.to_string(),
        })
}

/// Raises the soft limit on open files to the hard limit where the
/// system lets it; returns the soft limit now (`None` where it cannot be
/// told).
pub fn raise_fd_limit() -> Option<u64> {
    rlimit::increase_nofile_limit(u64::MAX).ok()
}

/// A bound server, not yet serving.
pub struct Server {
    runtime: tokio::runtime::Runtime,
    listener: std::net::TcpListener,
    local: SocketAddr,
    site: Arc<Site>,
    limits: Limits,
    stop: Stopper,
    fd_limit: Option<u64>,
}

/// Ends a [`Server::run`] from another thread: the server stops accepting
/// and closes its connections.
#[derive(Clone)]
pub struct Stopper(Arc<Notify>);

impl Stopper {
    pub fn stop(&self) {
        // A stored permit: a stop before the run waits still ends it.
        self.0.notify_one();
    }
}

impl Server {
    /// Listens on `config.addr` and makes the runtime; serves nothing yet.
    /// Raises the soft limit on open files (see the crate doc).
    pub fn bind(config: Config) -> Result<Server, ServeError> {
        let fd_limit = raise_fd_limit();
        let listener =
            std::net::TcpListener::bind(config.addr).map_err(|source| ServeError::Bind {
                addr: config.addr,
                hint: if source.kind() == std::io::ErrorKind::AddrInUse {
                    "; give another --port (0 takes any free one)"
                } else {
                    ""
                },
                source,
            })?;
        listener
            .set_nonblocking(true)
            .map_err(ServeError::LocalAddr)?;
        let local = listener.local_addr().map_err(ServeError::LocalAddr)?;
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(config.limits.workers.max(1))
            .thread_name("gigawalk-serve")
            .enable_io()
            .enable_time()
            .build()
            .map_err(ServeError::Runtime)?;
        let config_bytes = bytes::Bytes::from(config_json(SCENE_NAME));
        let config_etag = site::file_etag(config_bytes.len() as u64, None, true);
        let site = Site {
            scene: config.scene,
            bundle_dir: config.bundle.dir,
            bundle_files: config.bundle.files,
            config: config_bytes,
            config_etag,
            started: SystemTime::now(),
        };
        Ok(Server {
            runtime,
            listener,
            local,
            site: Arc::new(site),
            limits: config.limits,
            stop: Stopper(Arc::new(Notify::new())),
            fd_limit,
        })
    }

    /// The address listened on (the port chosen when 0 was asked for).
    pub fn local_addr(&self) -> SocketAddr {
        self.local
    }

    /// The page's address: `http://ADDR/`, with the loopback address in
    /// place of an unspecified one (0.0.0.0, ::), which a browser cannot
    /// open.
    pub fn url(&self) -> String {
        let mut shown = self.local;
        if shown.ip().is_unspecified() {
            shown.set_ip(match shown {
                SocketAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
                SocketAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
            });
        }
        format!("http://{shown}/")
    }

    /// The soft limit on open files after [`Server::bind`] raised it, if
    /// it could be told.
    pub fn fd_limit(&self) -> Option<u64> {
        self.fd_limit
    }

    /// What ends [`Server::run`] from elsewhere.
    pub fn stopper(&self) -> Stopper {
        self.stop.clone()
    }

    /// Serves until the [`Stopper`] says stop.
    pub fn run(self) -> Result<(), ServeError> {
        self.run_until(std::future::pending())
    }

    /// Serves until `shutdown` completes or the [`Stopper`] says stop;
    /// then stops accepting and closes every connection.
    pub fn run_until(
        self,
        shutdown: impl Future<Output = ()> + Send + 'static,
    ) -> Result<(), ServeError> {
        let Server {
            runtime,
            listener,
            site,
            limits,
            stop,
            ..
        } = self;
        runtime.block_on(async move {
            let listener =
                tokio::net::TcpListener::from_std(listener).map_err(ServeError::LocalAddr)?;
            tokio::select! {
                () = accept_loop(listener, site, limits) => {}
                () = shutdown => {}
                () = stop.0.notified() => {}
            }
            Ok::<_, ServeError>(())
        })?;
        // The tasks still serving connections are dropped with the
        // runtime, which closes their sockets.
        runtime.shutdown_timeout(Duration::from_secs(1));
        Ok(())
    }
}

async fn accept_loop(listener: tokio::net::TcpListener, site: Arc<Site>, limits: Limits) {
    let permits = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    let mut http = http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(limits.header_read_timeout)
        .max_buf_size(MAX_HEAD)
        .keep_alive(true);
    let http = Arc::new(http);
    let service = TowerToHyperService::new(
        CompressionLayer::new()
            .compress_when(Gzippable)
            .layer(SiteService(site)),
    );
    loop {
        let Ok(permit) = Arc::clone(&permits).acquire_owned().await else {
            return;
        };
        let stream = match listener.accept().await {
            Ok((s, _)) => s,
            Err(e) => {
                tracing::warn!("cannot accept a connection: {e}");
                tokio::time::sleep(ACCEPT_RETRY).await;
                continue;
            }
        };
        let _ = stream.set_nodelay(true);
        let http = Arc::clone(&http);
        let service = service.clone();
        let idle = limits.idle_timeout;
        tokio::spawn(async move {
            let activity = Activity::default();
            let io = TokioIo::new(Watched {
                inner: stream,
                activity: activity.clone(),
            });
            let conn = http.serve_connection(io, service);
            tokio::pin!(conn);
            loop {
                let quiet_until = tokio::time::Instant::from_std(activity.last() + idle);
                tokio::select! {
                    // A client gone or a malformed request (answered by
                    // hyper) ends the connection: nothing to report.
                    _ = conn.as_mut() => break,
                    () = tokio::time::sleep_until(quiet_until) => {
                        if activity.last() + idle <= Instant::now() {
                            break;
                        }
                    }
                }
            }
            drop(permit);
        });
    }
}

/// When a connection last moved a byte, shared by its stream and the task
/// that closes it when idle.
#[derive(Clone)]
struct Activity(Arc<AtomicU64>);

/// The instant [`Activity`] counts from.
fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

impl Default for Activity {
    fn default() -> Self {
        let a = Activity(Arc::new(AtomicU64::new(0)));
        a.touch();
        a
    }
}

impl Activity {
    fn touch(&self) {
        let ms = epoch().elapsed().as_millis() as u64;
        self.0.store(ms, Ordering::Relaxed);
    }

    fn last(&self) -> Instant {
        epoch() + Duration::from_millis(self.0.load(Ordering::Relaxed))
    }
}

/// A stream that notes in its [`Activity`] each time bytes move.
struct Watched {
    inner: tokio::net::TcpStream,
    activity: Activity,
}

impl AsyncRead for Watched {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        let this = self.get_mut();
        let before = buf.filled().len();
        let r = Pin::new(&mut this.inner).poll_read(cx, buf);
        if buf.filled().len() > before {
            this.activity.touch();
        }
        r
    }
}

impl AsyncWrite for Watched {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        let this = self.get_mut();
        let r = Pin::new(&mut this.inner).poll_write(cx, buf);
        if matches!(r, Poll::Ready(Ok(n)) if n > 0) {
            this.activity.touch();
        }
        r
    }

    fn poll_write_vectored(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> Poll<std::io::Result<usize>> {
        let this = self.get_mut();
        let r = Pin::new(&mut this.inner).poll_write_vectored(cx, bufs);
        if matches!(r, Poll::Ready(Ok(n)) if n > 0) {
            this.activity.touch();
        }
        r
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_shutdown(cx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_resolve_from_ips_and_names() {
        assert_eq!(
            resolve("127.0.0.1", 80).unwrap(),
            "127.0.0.1:80".parse().unwrap()
        );
        assert_eq!(resolve("[::1]", 8).unwrap(), "[::1]:8".parse().unwrap());
        assert_eq!(resolve("::", 0).unwrap(), "[::]:0".parse().unwrap());
        assert!(resolve("localhost", 1).unwrap().ip().is_loopback());
        let e = resolve("no such host.invalid", 1).unwrap_err().to_string();
        assert!(e.starts_with("no such host.invalid: "), "{e}");
    }
}
