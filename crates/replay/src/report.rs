//! Writing a replay's report directory: summary.md, summary.json,
//! frames.csv, fps.png and (for a pixel-error sweep) tradeoff.png.
//! docs/report-format.md describes every file.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::replay::Replay;
use crate::summary::Summary;

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    #[error("{file}: cannot write: {source}")]
    Io {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: cannot draw the plot: {source}")]
    Plot {
        file: PathBuf,
        source: crate::plot::PlotError,
    },
}

/// The files written, in the order written.
#[derive(Clone, Debug, Default)]
pub struct Written {
    pub files: Vec<PathBuf>,
}

/// Writes `name` in `dir` through a temporary file renamed into place, so
/// an interrupted write never leaves a half-written report file.
fn write(dir: &Path, name: &str, bytes: &[u8], w: &mut Written) -> Result<(), ReportError> {
    let file = dir.join(name);
    gigawalk_scene::write_atomic(&file, bytes).map_err(|source| ReportError::Io {
        file: file.clone(),
        source,
    })?;
    w.files.push(file);
    Ok(())
}

impl Replay {
    /// Writes the report into `dir` (created if missing; files in it are
    /// replaced).
    pub fn write_report(&self, dir: &Path) -> Result<Written, ReportError> {
        std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
            file: dir.to_owned(),
            source,
        })?;
        let summary = self.summary();
        let mut w = Written::default();
        let json = serde_json::to_string_pretty(&summary).expect("summary serialises") + "\n";
        write(dir, "summary.json", json.as_bytes(), &mut w)?;
        write(dir, "summary.md", markdown(&summary).as_bytes(), &mut w)?;
        write(dir, "frames.csv", self.csv().as_bytes(), &mut w)?;
        let fps = dir.join("fps.png");
        crate::plot::fps(self, &fps).map_err(|source| ReportError::Plot {
            file: fps.clone(),
            source,
        })?;
        w.files.push(fps);
        if self.options.target.is_some() {
            let p = dir.join("pixel_error.png");
            crate::plot::pixel_error(self, &p).map_err(|source| ReportError::Plot {
                file: p.clone(),
                source,
            })?;
            w.files.push(p);
        }
        if crate::plot::is_sweep(&summary) {
            let t = dir.join("tradeoff.png");
            crate::plot::tradeoff(&summary, &t).map_err(|source| ReportError::Plot {
                file: t.clone(),
                source,
            })?;
            w.files.push(t);
        }
        Ok(w)
    }

    /// frames.csv: one row per frame of every run.
    pub fn csv(&self) -> String {
        let mut s = format!(
            "mode,pixel_error,frame,pose_time_s,frame_ms,fps,latency_ms,or_ms,hzb_ms,stc_ms,rvg_ms,\
             visited,frustum_culled,occlusion_culled,drawn_nodes,drawn_triangles,occlusion_used,warmup,\
             accuracy_pixels,differing_pixels,wrongly_culled_pixels,bound_violating_pixels,\
             bound_violating_fraction,psnr_db,resident_bytes,loaded_bytes,requests,substituted_draws,\
             missing_draws,culler,{}tile_ms_adaptive,tile_ms_naive,tile_tests,\
             max_tile_triangles,mean_tile_triangles,pixel_error_used,popping,speculative_before,rvg_wait_ms,\
             bound_exceeding_pixels,bound_exceeding_fraction,occluder_triangles,occluder_limit,\
             hzb_level,or_encode_ms,or_submit_ms,or_wait_ms,or_copy_ms,traversal_ms,cull_test_ms,\
             rvg_encode_ms,rvg_submit_ms,rvg_device_wait_ms,rvg_copy_ms,or_read_bytes,rvg_read_bytes,device_waits,\
             section_culled\n",
            csv_counters().map(|(_, _, k)| format!("{},", k.name)).collect::<String>(),
        );
        for run in &self.runs {
            for f in &run.frames {
                let opt =
                    |x: Option<f64>, d: usize| x.map_or(String::new(), |x| format!("{x:.d$}"));
                let a = f.accuracy.as_ref();
                let _ = write!(
                    s,
                    "{},{},{},{:.3},{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}{},{},{},{},{},{:.4},{},{},{:.3},{},{},{},{}",
                    run.mode,
                    run.pixel_error,
                    f.frame,
                    f.pose_time_s,
                    opt(f.frame_ms, 3),
                    opt(f.frame_ms.map(|ms| 1e3 / ms), 2),
                    f.latency_ms,
                    f.or_ms,
                    f.hzb_ms,
                    f.stc_ms,
                    f.rvg_ms,
                    f.visited,
                    f.frustum_culled,
                    f.occlusion_culled,
                    f.drawn_nodes,
                    f.drawn_triangles,
                    f.occlusion_used as u8,
                    f.warmup as u8,
                    a.map_or(String::new(), |a| a.pixels.to_string()),
                    a.map_or(String::new(), |a| a.differing_pixels.to_string()),
                    a.map_or(String::new(), |a| a.wrongly_culled_pixels.to_string()),
                    a.map_or(String::new(), |a| a.bound_violating_pixels.to_string()),
                    opt(a.map(|a| a.bound_violating_fraction()), 6),
                    // Identical images: PSNR is infinite; written as "inf".
                    a.map_or(String::new(), |a| a
                        .psnr_db()
                        .map_or("inf".into(), |p| format!("{p:.2}"))),
                    f.resident_bytes,
                    f.loaded_bytes,
                    f.requests,
                    f.substituted_draws,
                    f.missing_draws,
                    run.culler.map_or(String::new(), |c| c.to_string()),
                    culler_cells(f.culler_work.as_ref()),
                    opt(f.tiles.map(|t| t.ms_adaptive), 4),
                    opt(f.tiles.map(|t| t.ms_naive), 4),
                    f.tiles.map_or(String::new(), |t| t.tests.to_string()),
                    f.tiles.map_or(String::new(), |t| t.max_triangles.to_string()),
                    opt(f.tiles.map(|t| t.mean_triangles), 1),
                    f.pixel_error_used,
                    opt(f.popping, 6),
                    f.speculative_before,
                    f.rvg_wait_ms,
                    a.map_or(String::new(), |a| a.bound_exceeding_pixels.to_string()),
                    opt(a.map(|a| a.bound_exceeding_fraction()), 6),
                    f.occluder_triangles,
                    f.occluder_limit.map_or(String::new(), |l| l.to_string()),
                );
                let c = &f.cpu;
                let _ = writeln!(
                    s,
                    ",{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{}",
                    c.hzb_level,
                    c.or_encode_ms,
                    c.or_submit_ms,
                    c.or_wait_ms,
                    c.or_copy_ms,
                    c.traversal_ms,
                    c.cull_test_ms,
                    c.rvg_encode_ms,
                    c.rvg_submit_ms,
                    c.rvg_wait_ms,
                    c.rvg_copy_ms,
                    c.or_read_bytes,
                    c.rvg_read_bytes,
                    c.device_waits,
                    f.section_culled,
                );
            }
        }
        s
    }
}

/// Every culler's counts that frames.csv has a column for, in the
/// registry's order: the culler, the count's index in its counts, the
/// count.
fn csv_counters() -> impl Iterator<
    Item = (
        gigawalk_runtime::CullMethod,
        usize,
        &'static gigawalk_runtime::Counter,
    ),
> {
    gigawalk_runtime::CullMethod::ALL.into_iter().flat_map(|c| {
        c.counters()
            .iter()
            .enumerate()
            .filter(|(_, k)| k.csv)
            .map(move |(i, k)| (c, i, k))
    })
}

/// A frame's cells of those columns, each followed by a comma; empty
/// cells for the counts of cullers that did not run.
fn culler_cells(work: Option<&gigawalk_runtime::CullerWork>) -> String {
    let counts = work.map(|w| (w.culler(), w.counts()));
    let mut s = String::new();
    for (c, i, k) in csv_counters() {
        if let Some((_, v)) = counts.as_ref().filter(|(w, _)| *w == c) {
            let d = k.decimals;
            let _ = write!(s, "{:.d$}", v[i]);
        }
        s.push(',');
    }
    s
}

/// summary.md.
pub fn markdown(s: &Summary) -> String {
    let mut m = String::new();
    let _ = writeln!(m, "# gigawalk replay report\n");
    if s.null_adapter {
        let _ = writeln!(
            m,
            "**Null adapter: every GPU operation was free and drew nothing. The frame rates are the CPU's ceiling, what it can feed a GPU, with nothing occluded (depth reads back as zeros, so occlusion culls nothing and traversal and drawing do their most work); accuracy is not measured.**\n"
        );
    }
    if let Some(section) = &s.section {
        let _ = writeln!(
            m,
            "**Section: {section}. The reference and every run draw only what it keeps; nodes wholly on its removed side are dropped (`mean_section_culled`).**\n"
        );
    }
    if let Some(look) = &s.look {
        let _ = writeln!(
            m,
            "**Look: {look}. Every run's frames also ran these passes, so their cost is in the frame times; accuracy reads each frame as drawn, before them.**\n"
        );
    }
    if s.xray {
        let _ = writeln!(
            m,
            "**X-ray: the hidden objects were drawn as faint ghosts in the reference and every run, by a second traversal without occlusion culling (its cost is in the frame times); they write no depth.**\n"
        );
    }
    if s.hidden_objects > 0 {
        let _ = writeln!(
            m,
            "**{} objects hidden: the reference and every run leave them out, and the nodes above them are refined to their leaves (what hiding costs is in the triangles and frame times below).**\n",
            s.hidden_objects
        );
    }
    let _ = writeln!(m, "- scene: `{}`", s.scene);
    let _ = writeln!(m, "- path: `{}`, {} frames per run", s.path, s.frames);
    let _ = writeln!(m, "- viewport: {}x{}", s.width, s.height);
    let _ = writeln!(
        m,
        "- runtime: {} schedule on {}; occluders from frame i-{} ({}), occluder resolution x{}, HZB {}",
        s.schedule,
        s.devices.join(" + "),
        s.occluder_lag,
        match (s.occluder_budget, s.occluder_selection.as_str()) {
            (Some(b), _) => format!("at most {b} triangles"),
            (None, "adaptive") => "an adaptive budget".to_string(),
            (None, _) => "all of them".to_string(),
        },
        s.occluder_scale,
        s.hzb_reduction
    );
    let _ = writeln!(
        m,
        "- frame time = interval between frames finishing at RVG; the first {} frames of every run are warm-up (startup bypass without occluders, pipeline filling) and are left out of every frame statistic (they are in frames.csv)",
        s.warmup_frames
    );
    if s.accuracy_every > 0 {
        let _ = writeln!(
            m,
            "- accuracy: every {}th frame (read back, so those frames include a colour and depth read-back) against a full-detail, frustum-culling-only reference of the same camera; pixel counts summed over the compared frames, PSNR from their pooled mean squared error (\"identical\": every compared frame is bit-identical); \"bound-violating\": pixels whose surface (view distance within {}%) appears nowhere within ceil(pixel error) + 1 pixels in the other image, either way; \"beyond the bound\": the same with the view-distance match scaled to the tolerance, {}% + pixel error / pixels per radian (docs/report-format.md)",
            s.accuracy_every,
            100.0 * crate::accuracy::BOUND_RELATIVE_DEPTH,
            100.0 * crate::accuracy::BOUND_RELATIVE_DEPTH
        );
    } else if s.null_adapter {
        let _ = writeln!(
            m,
            "- accuracy: not measured (the null adapter draws nothing)"
        );
    } else {
        let _ = writeln!(m, "- accuracy: not measured (`--accuracy-every 0`)");
    }
    let _ = writeln!(m, "- wall time of the whole replay: {:.1} s", s.seconds);
    if !s.complete {
        let _ = writeln!(
            m,
            "\n**Stopped early: the figures cover only the frames measured before the stop.**"
        );
    }
    let _ = writeln!(m, "\n## Frame rate and accuracy\n");
    m += &s.table();
    let _ = writeln!(m, "\n## Stages (medians) and nodes (means)\n");
    m += &s.stage_table();
    let _ = writeln!(
        m,
        "\n## CPU time a frame (medians, ms) and read-back (means)\n\nOR: recording its depth pass and pyramid, submitting, waiting for the read-back, copying it out; the HZB level read back (0: the whole image) and STC's build of the rest; traversal and the culler's tests within it; RVG: recording, submitting, waiting for the device; KB OR read back a frame (its depth, or the level of its pyramid), and how many times a stage waited for a device (RVG's read-backs of compared frames are left out of the KB).\n"
    );
    m += &s.cpu_table();
    for c in gigawalk_runtime::CullMethod::ALL {
        if let Some((title, table)) = s.culler_table(c) {
            let _ = writeln!(m, "\n## {title}\n");
            m += &table;
        }
    }
    let popping: Vec<String> = s
        .modes
        .iter()
        .filter_map(|m| {
            m.popping
                .map(|p| format!("{} {:.3}%", s.mode_cell(m), 100.0 * p))
        })
        .collect();
    if !popping.is_empty() {
        let _ = writeln!(
            m,
            "\nPopping (share of pixels a frame that change to the next where the full-detail reference's do not: LOD switches and culling changes, not camera motion; compared frames and the ones after them): {}.",
            popping.join(", ")
        );
    }
    let targets: Vec<String> = s
        .modes
        .iter()
        .filter_map(|m| {
            Some(format!(
                "{}: target {:.1} fps, median {:.2} ms (target {:.2}), p95 {:.2} ms, pixel error chosen mean {:.2} / median {:.2}, controller {:.1} us a frame",
                s.mode_cell(m),
                m.target_fps?,
                m.median_frame_ms,
                1e3 / m.target_fps?,
                m.p95_frame_ms,
                m.mean_pixel_error_used?,
                m.median_pixel_error_used?,
                m.mean_controller_us?,
            ))
        })
        .collect();
    if !targets.is_empty() {
        let _ = writeln!(m, "\n## Target frame rate\n");
        for t in targets {
            let _ = writeln!(m, "- {t}");
        }
        let _ = writeln!(m, "\n![pixel error chosen along the path](pixel_error.png)");
    }
    let tiles = s.tile_table();
    if !tiles.is_empty() {
        let _ = writeln!(m, "\n## Tiled display\n");
        m += &tiles;
    }
    if s.memory_budget.is_some() {
        let _ = writeln!(m, "\n## Streaming (out of core)\n");
        m += &s.streaming_table();
    }
    let _ = writeln!(m, "\n![frame rate along the path](fps.png)");
    if crate::plot::is_sweep(s) {
        let _ = writeln!(m, "\n![frame rate against image error](tradeoff.png)");
    }
    m
}
