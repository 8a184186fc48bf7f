//! `gigawalk serve`: its flags and help. The server (what it answers,
//! its limits) is `gigawalk_serve`.

use std::path::PathBuf;

use anyhow::Context as _;
use gigawalk_serve::{Bundle, Config, Limits, Server};

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

Every answer carries an ETag and Last-Modified date, so a browser asking \
again gets 304 Not Modified while its copy is current (a scene written \
again in place is served as it is now). The page's text and WebAssembly go \
gzipped to a browser that takes gzip; the scene never does. Idle clients \
cost no thread: a request's headers must arrive within 10 s, a connection \
on which nothing moves for 60 s is closed, and up to 10,000 are open at \
once (the soft limit on open files is raised to the hard limit for them).

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

pub fn run(args: Args) -> anyhow::Result<()> {
    let scene_len = gigawalk_serve::check_scene(&args.scene)?;
    let bundle = Bundle::find(args.bundle.as_deref())?;
    let addr = gigawalk_serve::resolve(&args.bind, args.port).context("--bind")?;
    let bundle_dir = bundle.dir.clone();
    let server = Server::bind(Config {
        addr,
        scene: args.scene.clone(),
        bundle,
        limits: Limits::default(),
    })?;
    out!("{}", server.url())?;
    let local = server.local_addr();
    eprintln!(
        "serving {} ({:.2} MiB) as /{} and the viewer from {} on {local}{}; stop with Ctrl-C",
        args.scene.display(),
        scene_len as f64 / (1 << 20) as f64,
        gigawalk_serve::SCENE_NAME,
        bundle_dir.display(),
        if local.ip().is_unspecified() {
            " (every network interface)"
        } else {
            ""
        }
    );
    server.run()?;
    Ok(())
}
