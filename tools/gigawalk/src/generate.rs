//! `gigawalk generate`: procedural test scenes (glTF binary) and camera
//! paths through them; the work is in gigawalk-procgen.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use gigawalk_procgen::{generate, Kind, DEFAULT_POSES};

#[derive(clap::Args)]
pub struct Args {
    /// Scene kind: plant (industrial plant, the paper's Power Plant), city
    /// (blocks of tall buildings, street furniture), forest (many small
    /// occluders, deep visibility) or machine (a factory floor of CAD-like
    /// machines, each hundreds of small disjoint parts, no building shell)
    #[arg(value_parser = parse_kind)]
    kind: Kind,
    /// Triangles to generate, approximately (the summary says exactly how
    /// many); accepts suffixes k and M, e.g. 500k, 2M
    #[arg(long, default_value = "1M", value_parser = parse_count)]
    triangles: u64,
    /// Random seed: the same seed and triangle count give a byte-identical file
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output glTF binary (.glb), written atomically
    #[arg(short, long)]
    output: PathBuf,
    /// Also write a camera path walking through the scene (docs/path-format.md)
    #[arg(long)]
    path: Option<PathBuf>,
    /// Number of poses in the camera path, at 10 poses per second
    #[arg(long, default_value_t = DEFAULT_POSES)]
    poses: usize,
    /// Write the scene as this many .glb files of about equal triangles,
    /// each a run of neighbouring objects, named after --output with the
    /// piece number: plant.glb becomes plant-1.glb, plant-2.glb, ... (a .glb
    /// holds at most 4 GiB, about 250M generated triangles). `gigawalk
    /// preprocess` takes them all, or their folder, as one model
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    parts: u32,
}

fn parse_kind(s: &str) -> Result<Kind, String> {
    s.parse()
}

/// `1000`, `500k`, `2M`, `1.5M`.
pub(crate) fn parse_count(s: &str) -> Result<u64, String> {
    let (num, mul) = match s.as_bytes().last() {
        Some(b'k' | b'K') => (&s[..s.len() - 1], 1e3),
        Some(b'm' | b'M') => (&s[..s.len() - 1], 1e6),
        _ => (s, 1.0),
    };
    let v: f64 = num
        .parse()
        .map_err(|_| format!("{s:?} is not a count (e.g. 250000, 500k, 2M)"))?;
    if !(v.is_finite() && v >= 1.0) || v * mul > 4e9 {
        return Err(format!("{s:?} is out of range (1 to 4000M)"));
    }
    Ok((v * mul).round() as u64)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let start = Instant::now();
    let g = generate(args.kind, args.triangles, args.seed, args.poses);
    let pieces = g.split(args.parts as usize);
    let mut bytes = 0;
    let mut written = Vec::with_capacity(pieces.len());
    for (k, piece) in pieces.iter().enumerate() {
        let file = piece_path(&args.output, k, pieces.len());
        let (n, report) = write_atomically(&file, |w| {
            if pieces.len() == 1 {
                g.write_glb(w).map(|n| (n, g.report.clone()))
            } else {
                g.write_glb_part(piece, w)
            }
        })
        .map_err(|e| match e.downcast_ref::<std::io::Error>() {
            Some(io) if io.kind() == std::io::ErrorKind::FileTooLarge => {
                let need = g
                    .data_bytes()
                    .div_ceil(3 << 30)
                    .max(pieces.len() as u64 + 1);
                e.context(format!(
                    "{} is too big for one .glb file; write it in pieces with --parts {need}",
                    file.display()
                ))
            }
            _ => e,
        })?;
        if pieces.len() > 1 {
            out!(
                "{}: {} triangles, {} objects, {:.1} MB",
                file.display(),
                report.triangles,
                report.objects,
                n as f64 / 1e6
            )?;
        }
        bytes += n;
        written.push(file);
    }
    if let Some(p) = &args.path {
        g.path
            .write(p)
            .with_context(|| format!("cannot write camera path {}", p.display()))?;
    }
    let r = &g.report;
    let (lo, hi) = (r.bounds.min, r.bounds.max);
    let files = match written.as_slice() {
        [one] => one.display().to_string(),
        many => format!("{} files", many.len()),
    };
    out!(
        "{files}: {} {} triangles, {} objects, bounds [{:.1} {:.1} {:.1}]..[{:.1} {:.1} {:.1}], {:.1} MB{}, {:.2} s",
        args.kind.name(),
        r.triangles,
        r.objects,
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        bytes as f64 / 1e6,
        match &args.path {
            Some(p) => format!(", path {} ({} poses)", p.display(), g.path.poses.len()),
            None => String::new(),
        },
        start.elapsed().as_secs_f64()
    )?;
    Ok(())
}

/// `plant.glb` for a scene in one piece; `plant-07.glb` for piece 7 of 12
/// (numbers padded so the pieces sort in order).
fn piece_path(output: &Path, k: usize, pieces: usize) -> PathBuf {
    if pieces == 1 {
        return output.to_path_buf();
    }
    let width = pieces.to_string().len();
    let stem = output.file_stem().unwrap_or_default().to_string_lossy();
    let ext = output
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    output.with_file_name(format!("{stem}-{:0width$}{ext}", k + 1))
}

/// Writes `file` through a temporary file beside it, renamed into place
/// only once complete.
fn write_atomically<T>(
    file: &Path,
    write: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<(u64, T)>,
) -> anyhow::Result<(u64, T)> {
    let cannot = || format!("cannot write {}", file.display());
    let mut tmp = gigawalk_scene::temp_file_for(file)
        .with_context(|| format!("cannot create a temporary file beside {}", file.display()))?;
    let got = {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        let got = write(&mut w).with_context(cannot)?;
        w.flush().with_context(cannot)?;
        got
    };
    tmp.persist(file).with_context(cannot)?;
    Ok(got)
}

#[cfg(test)]
mod tests {
    use super::parse_count;

    #[test]
    fn counts_with_suffixes() {
        assert_eq!(parse_count("1000"), Ok(1000));
        assert_eq!(parse_count("500k"), Ok(500_000));
        assert_eq!(parse_count("2M"), Ok(2_000_000));
        assert_eq!(parse_count("1.5m"), Ok(1_500_000));
        assert!(parse_count("lots").is_err());
        assert!(parse_count("0").is_err());
        assert!(parse_count("-5k").is_err());
    }
}
