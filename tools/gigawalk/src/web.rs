//! `gigawalk web`: the browser viewer as a static site — the viewer's
//! bundle (the page, its JavaScript and WebAssembly), the scene, and the
//! `config.json` that tells the page where the scene is. Finding and
//! listing the bundle is `gigawalk_serve`'s, shared with `gigawalk serve`.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use gigawalk_serve::{check_scene, config_json, Bundle, CONFIG_NAME, SCENE_NAME};

pub const LONG_ABOUT: &str = "\
Write the browser viewer as a static site in a directory: the viewer's \
bundle (index.html, its JavaScript and WebAssembly), the scene copied as \
scene.gwk, and config.json, which tells the page where the scene is \
({\"scene\":\"scene.gwk\"}, or the URL given with --scene-url, in which case \
the scene is not copied).

The page reads the scene in pieces with HTTP range requests, so the site \
needs a server that answers them (Range: bytes=a-b with 206 Partial \
Content): nginx, Caddy, or `gigawalk serve`, which serves the same site \
without writing it. A server that ignores Range sends the whole scene for \
every piece. The page's own ?scene=URL query string overrides config.json.

The bundle comes from --bundle, else $GIGAWALK_WEB_BUNDLE, else \
../web/bundle beside the gigawalk executable (target/web/bundle for \
target/release/gigawalk), where crates/web/build.sh writes it.";

#[derive(clap::Args)]
pub struct Args {
    /// The scene file (.gwk) to put on the site; optional with
    /// --scene-url (then, when given, it is only checked to be a scene)
    #[arg(required_unless_present = "scene_url")]
    scene: Option<PathBuf>,
    /// The output directory; refused when it exists and is not empty,
    /// unless --force
    #[arg(short, long, value_name = "DIR")]
    out: PathBuf,
    /// The viewer's bundle: a directory holding at least index.html and
    /// gigawalk_web_bg.wasm, whose files are all copied (default:
    /// $GIGAWALK_WEB_BUNDLE, else ../web/bundle beside this executable)
    #[arg(long, value_name = "DIR")]
    bundle: Option<PathBuf>,
    /// Where the page finds the scene, written to config.json instead of
    /// copying the scene (relative to the page, or absolute; a server on
    /// another host must answer range requests and allow the site's
    /// origin by CORS)
    #[arg(long, value_name = "URL")]
    scene_url: Option<String>,
    /// Write into an output directory that is not empty: its config.json
    /// and scene.gwk are removed first (config.json before anything else),
    /// the bundle's files are written over; nothing else in it is touched
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let scene_len = match &args.scene {
        Some(scene) => Some(check_scene(scene)?),
        None => None,
    };
    if args
        .scene_url
        .as_deref()
        .is_some_and(|u| u.trim().is_empty())
    {
        anyhow::bail!("--scene-url is empty: give the URL the page loads the scene from");
    }
    let bundle = Bundle::find(args.bundle.as_deref())?;
    let site = Site {
        out: &args.out,
        bundle: &bundle,
        scene: if args.scene_url.is_some() {
            None
        } else {
            args.scene.as_deref()
        },
        scene_url: args.scene_url.as_deref().unwrap_or(SCENE_NAME),
    };
    let created = prepare_dir(&args.out, args.force, args.scene.as_deref())?;
    let mut written = Vec::new();
    if let Err(e) = site.write(&mut written) {
        // Nothing half-written stays: config.json was never written, and
        // what this run wrote goes (the directory too when it made it).
        for p in written.iter().rev() {
            let _ = std::fs::remove_file(p);
        }
        if created {
            let _ = std::fs::remove_dir(&args.out);
        }
        return Err(e);
    }

    let config = args.out.join(CONFIG_NAME);
    out!(
        "site        {} ({} files: {})",
        args.out.display(),
        bundle.files.len() + 1 + usize::from(site.scene.is_some()),
        bundle
            .files
            .iter()
            .map(String::as_str)
            .chain(site.scene.map(|_| SCENE_NAME))
            .chain([CONFIG_NAME])
            .collect::<Vec<_>>()
            .join(", ")
    )?;
    out!("bundle      {}", bundle.dir.display())?;
    match (&args.scene_url, &args.scene, scene_len) {
        (Some(url), Some(scene), Some(len)) => out!(
            "scene       {url} (in {}; not copied: {} ({}) must be served there)",
            config.display(),
            scene.display(),
            mib(len)
        )?,
        (Some(url), _, _) => out!("scene       {url} (in {}; not copied)", config.display())?,
        (None, Some(scene), Some(len)) => out!(
            "scene       {} ({}), copied from {}",
            args.out.join(SCENE_NAME).display(),
            mib(len),
            scene.display()
        )?,
        (None, _, _) => {}
    }
    out!(
        "serve it    with a static HTTP server that answers range requests (nginx, Caddy), \
         then open its index.html; or without writing a site: gigawalk serve SCENE"
    )?;
    if args.scene_url.is_some() {
        out!(
            "            the scene's server must answer range requests too, and allow the \
             site's origin (CORS) when it is another host"
        )?;
    }
    Ok(())
}

fn mib(b: u64) -> String {
    format!("{:.2} MiB", b as f64 / (1 << 20) as f64)
}

/// What `gigawalk web` writes.
struct Site<'a> {
    out: &'a Path,
    bundle: &'a Bundle,
    /// The scene to copy, `None` when config.json points elsewhere.
    scene: Option<&'a Path>,
    scene_url: &'a str,
}

impl Site<'_> {
    /// Writes every file, each through a temporary renamed into place,
    /// config.json last (synced): until it is there the site is not
    /// complete. `written` lists what was renamed into place.
    fn write(&self, written: &mut Vec<PathBuf>) -> anyhow::Result<()> {
        for name in &self.bundle.files {
            let from = self.bundle.dir.join(name);
            let to = self.out.join(name);
            // The output directory may be the bundle (a site written over
            // its own bundle): nothing to copy then.
            if !same_file(&from, &to) {
                copy_file(&from, &to)?;
                written.push(to);
            }
        }
        if let Some(scene) = self.scene {
            let to = self.out.join(SCENE_NAME);
            if !same_file(scene, &to) {
                copy_file(scene, &to)?;
                written.push(to);
            }
        }
        let config = self.out.join(CONFIG_NAME);
        gigawalk_scene::write_atomic(&config, config_json(self.scene_url).as_bytes())
            .with_context(|| format!("{}: cannot write", config.display()))?;
        Ok(())
    }
}

/// Copies `from` to `to` through a temporary file beside `to`.
fn copy_file(from: &Path, to: &Path) -> anyhow::Result<()> {
    let mut src =
        std::fs::File::open(from).with_context(|| format!("{}: cannot read", from.display()))?;
    let mut tmp = gigawalk_scene::temp_file_for(to)
        .with_context(|| format!("{}: cannot write", to.display()))?;
    std::io::copy(&mut src, &mut tmp)
        .with_context(|| format!("cannot copy {} to {}", from.display(), to.display()))?;
    tmp.persist(to)
        .with_context(|| format!("{}: cannot write", to.display()))
}

/// Whether `a` and `b` are the same existing file.
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// Makes `out` ready: created when missing (returns true), refused when it
/// holds anything and `force` is off, else rid of an earlier site's
/// config.json (first: the site no longer looks complete) and scene.gwk
/// (unless that is the scene being put on the site).
fn prepare_dir(out: &Path, force: bool, scene: Option<&Path>) -> anyhow::Result<bool> {
    match std::fs::metadata(out) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::create_dir_all(out)
                .with_context(|| format!("{}: cannot create the directory", out.display()))?;
            Ok(true)
        }
        Err(e) => Err(anyhow::anyhow!("{}: {e}", out.display())),
        Ok(m) if !m.is_dir() => anyhow::bail!("{}: exists and is not a directory", out.display()),
        Ok(_) => {
            let empty = std::fs::read_dir(out)
                .with_context(|| format!("{}: cannot list", out.display()))?
                .next()
                .is_none();
            if !empty {
                if !force {
                    anyhow::bail!(
                        "{}: the output directory exists and is not empty; give --force to \
                         write over it, or another directory",
                        out.display()
                    );
                }
                for name in [CONFIG_NAME, SCENE_NAME] {
                    let p = out.join(name);
                    let keep = name == SCENE_NAME && scene.is_some_and(|s| same_file(s, &p));
                    if !keep && std::fs::symlink_metadata(&p).is_ok() {
                        std::fs::remove_file(&p)
                            .with_context(|| format!("{}: cannot remove", p.display()))?;
                    }
                }
            }
            Ok(false)
        }
    }
}
