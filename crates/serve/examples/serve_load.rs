//! How long a normal request takes while one client holds many idle
//! connections (each has sent a request line and part of a header, never
//! the rest): the figure docs/web.md quotes.
//!
//! `cargo run --release -p gigawalk-serve --example serve_load -- [IDLE
//! [REQUESTS [WORKERS [HOST:PORT]]]]` (defaults 3000, 200 and the
//! server's default workers): without an address it serves a small site
//! of its own on 127.0.0.1 with that many runtime workers; with one it
//! measures that server (say, a `gigawalk serve` started by hand),
//! asking for `/config.json`.

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let idle: usize = args.first().map_or(3000, |a| a.parse().expect("IDLE"));
    let requests: usize = args.get(1).map_or(200, |a| a.parse().expect("REQUESTS"));
    let limit = gigawalk_serve::raise_fd_limit();
    println!("open files allowed: {limit:?}");

    let dir = tempfile::tempdir().expect("a temporary directory");
    let mut own = None;
    let workers: usize = args
        .get(2)
        .map_or(gigawalk_serve::Limits::default().workers, |a| {
            a.parse().expect("WORKERS")
        });
    let addr: SocketAddr = match args.get(3) {
        Some(a) => a.parse().expect("HOST:PORT"),
        None => {
            let bundle = dir.path().join("bundle");
            std::fs::create_dir(&bundle).unwrap();
            for name in ["index.html", "gigawalk_web_bg.wasm"] {
                std::fs::write(bundle.join(name), name).unwrap();
            }
            let scene = dir.path().join("scene.gwk");
            std::fs::write(&scene, vec![1; 1 << 20]).unwrap();
            let server = gigawalk_serve::Server::bind(gigawalk_serve::Config {
                addr: "127.0.0.1:0".parse().unwrap(),
                scene,
                bundle: gigawalk_serve::Bundle::open(&bundle, "a bundle of this example").unwrap(),
                limits: gigawalk_serve::Limits {
                    header_read_timeout: Duration::from_secs(600),
                    workers,
                    ..gigawalk_serve::Limits::default()
                },
            })
            .expect("the server starts");
            let addr = server.local_addr();
            let stop = server.stopper();
            own = Some((stop, std::thread::spawn(move || server.run())));
            addr
        }
    };

    let t = Instant::now();
    let mut held = Vec::with_capacity(idle);
    for i in 0..idle {
        match TcpStream::connect(addr) {
            Ok(mut c) => {
                let _ = write!(c, "GET /config.json HTTP/1.1\r\nHost: x\r\nX-Held-{i}: ");
                held.push(c);
            }
            Err(e) => {
                println!("connection {i}: {e}");
                break;
            }
        }
    }
    println!(
        "{} idle connections opened in {:.0} ms",
        held.len(),
        t.elapsed().as_secs_f64() * 1e3
    );

    let mut times = Vec::with_capacity(requests);
    let mut statuses = std::collections::BTreeMap::new();
    for _ in 0..requests {
        let t = Instant::now();
        let status = get(addr).unwrap_or_else(|e| format!("error: {e}"));
        times.push(t.elapsed().as_secs_f64() * 1e3);
        *statuses.entry(status).or_insert(0) += 1;
    }
    times.sort_by(f64::total_cmp);
    let at = |q: f64| times[((times.len() - 1) as f64 * q).round() as usize];
    println!(
        "{requests} requests for /config.json, a new connection each, while {} are held \
         ({}): median {:.2} ms, 99th percentile {:.2} ms, slowest {:.2} ms; answers \
         {statuses:?}",
        held.len(),
        if own.is_some() {
            format!("{workers} runtime workers")
        } else {
            format!("by {addr}")
        },
        at(0.5),
        at(0.99),
        at(1.0)
    );
    drop(held);
    if let Some((stop, thread)) = own {
        stop.stop();
        let _ = thread.join();
    }
}

/// `GET /config.json` on a new connection: the status line's code, after
/// the whole answer is read.
fn get(addr: SocketAddr) -> std::io::Result<String> {
    let mut c = TcpStream::connect_timeout(&addr, Duration::from_secs(10))?;
    c.set_read_timeout(Some(Duration::from_secs(10)))?;
    write!(
        c,
        "GET /config.json HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )?;
    let mut r = BufReader::new(c);
    let mut line = String::new();
    r.read_line(&mut line)?;
    let mut rest = Vec::new();
    r.read_to_end(&mut rest)?;
    Ok(line.split(' ').nth(1).unwrap_or("?").to_string())
}
