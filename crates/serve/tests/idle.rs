//! Clients that hold connections without finishing a request delay no
//! one: a normal request is answered (within a 2 s deadline) while one
//! client holds 3,000 connections that sent a request line and part of a
//! header; the held connections stay usable; a server at its connection
//! cap makes the next client wait, not fail; it keeps serving after; a
//! head that does not arrive in time, and a connection left idle, are
//! closed.
//! Loopback only. `examples/serve_load.rs` measures the time.

mod common;

use std::io::{BufReader, Write as _};
use std::net::TcpStream;
use std::sync::mpsc;
use std::time::Duration;

use common::{Response, Site};
use gigawalk_serve::Limits;

/// The connections the idle client holds.
const IDLE: usize = 3000;
/// How long the normal request may take.
const DEADLINE: Duration = Duration::from_secs(2);

/// Whether this process may open `n` more files; prints SKIP and why
/// when it may not.
fn files_allowed(n: u64) -> bool {
    match gigawalk_serve::raise_fd_limit() {
        Some(limit) if limit >= n => true,
        Some(limit) => {
            eprintln!(
                "SKIP: the limit on open files is {limit} even raised to the hard limit; this \
                 test needs {n} (raise it with ulimit -n)"
            );
            false
        }
        None => {
            eprintln!("SKIP: the limit on open files cannot be told or raised here");
            false
        }
    }
}

/// `GET path` on a new connection, answered within [`DEADLINE`] or the
/// test fails saying `what`.
fn get_within_deadline(addr: std::net::SocketAddr, path: &str, what: &str) -> Response {
    let (tx, rx) = mpsc::channel();
    let path = path.to_string();
    std::thread::spawn(move || {
        let mut c = TcpStream::connect_timeout(&addr, DEADLINE).unwrap();
        c.set_read_timeout(Some(DEADLINE)).unwrap();
        write!(c, "GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
        let _ = tx.send(Response::read(&mut BufReader::new(c), false));
    });
    rx.recv_timeout(DEADLINE)
        .unwrap_or_else(|_| panic!("no answer within {DEADLINE:?} {what}"))
}

#[test]
fn a_request_is_answered_while_thousands_of_connections_idle() {
    // Both ends of each connection are in this process.
    if !files_allowed(2 * IDLE as u64 + 256) {
        return;
    }
    let site = Site::new();
    let scene = site.scene();
    // Timeouts longer than the test: every connection is still held when
    // the normal request is made.
    let server = site.serve(Limits {
        header_read_timeout: Duration::from_secs(600),
        idle_timeout: Duration::from_secs(600),
        ..Limits::default()
    });
    let mut held = Vec::with_capacity(IDLE);
    for i in 0..IDLE {
        let mut c = TcpStream::connect(server.addr).unwrap();
        write!(c, "GET /scene.gwk HTTP/1.1\r\nHost: x\r\nX-Held-{i}: ").unwrap();
        held.push(c);
    }

    let r = get_within_deadline(
        server.addr,
        "/scene.gwk",
        "while 3,000 connections are held",
    );
    assert_eq!(r.status, 200);
    assert!(r.body == scene, "the whole scene");

    // The held connections were waited on, not dropped: finished, they
    // are answered.
    for c in held.iter_mut().step_by(IDLE / 10) {
        c.write_all(b"1\r\nRange: bytes=0-9\r\n\r\n").unwrap();
        c.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        let r = Response::read(&mut BufReader::new(&*c), false);
        assert_eq!((r.status, &r.body[..]), (206, &scene[..10]));
    }

    drop(held);
    for path in ["/index.html", "/config.json", "/scene.gwk"] {
        let r = get_within_deadline(server.addr, path, "after the held connections closed");
        assert_eq!(r.status, 200, "{path}: still serving");
    }
}

#[test]
fn at_its_connection_cap_the_server_makes_the_next_client_wait() {
    let site = Site::new();
    let server = site.serve(Limits {
        max_connections: 2,
        ..Limits::default()
    });
    let mut held: Vec<TcpStream> = (0..2)
        .map(|_| {
            let mut c = TcpStream::connect(server.addr).unwrap();
            c.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n").unwrap();
            c
        })
        .collect();
    // Both held connections are being served (their heads have begun)
    // before the third comes.
    std::thread::sleep(Duration::from_millis(200));

    let (tx, rx) = mpsc::channel();
    let addr = server.addr;
    std::thread::spawn(move || {
        let mut c = TcpStream::connect(addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        c.write_all(b"GET /config.json HTTP/1.1\r\nHost: x\r\n\r\n")
            .unwrap();
        let _ = tx.send(Response::read(&mut BufReader::new(c), false));
    });
    assert!(
        rx.recv_timeout(Duration::from_millis(500)).is_err(),
        "answered past the cap of 2 connections"
    );
    drop(held.pop());
    let r = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("answered once a connection closed");
    assert_eq!(r.status, 200, "waited, not refused");
}

/// Reads what the server sends on `c` until it closes the connection;
/// fails when it has not closed it within a minute.
#[track_caller]
fn read_until_closed(c: &mut TcpStream) -> String {
    c.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let mut got = Vec::new();
    if let Err(e) = std::io::Read::read_to_end(c, &mut got) {
        // A reset closes it too; a timeout does not.
        assert!(
            !matches!(
                e.kind(),
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
            ),
            "the server kept the connection open: {e}"
        );
    }
    String::from_utf8_lossy(&got).into_owned()
}

#[test]
fn slow_heads_and_idle_connections_are_closed() {
    let site = Site::new();
    let server = site.serve(Limits {
        header_read_timeout: Duration::from_millis(300),
        idle_timeout: Duration::from_millis(500),
        ..Limits::default()
    });
    // A head begun and never finished.
    let mut slow = server.connect();
    slow.write_all(b"GET / HTTP/1.1\r\nHost: x\r\nX-Slow: ")
        .unwrap();
    let got = read_until_closed(&mut slow);
    assert!(
        got.is_empty() || got.starts_with("HTTP/1.1 408"),
        "a slow head got {got:?}"
    );
    // A connection that never sends a byte.
    let mut silent = server.connect();
    assert_eq!(read_until_closed(&mut silent), "");
    // A kept-alive connection after its answer.
    let mut kept = server.connect();
    kept.write_all(b"GET /config.json HTTP/1.1\r\nHost: x\r\n\r\n")
        .unwrap();
    let got = read_until_closed(&mut kept);
    assert!(got.starts_with("HTTP/1.1 200"), "{got:?}");
    assert!(got.ends_with("{\"scene\":\"scene.gwk\"}\n"), "{got:?}");

    let r = get_within_deadline(server.addr, "/index.html", "after closing them");
    assert_eq!(r.status, 200);
}
