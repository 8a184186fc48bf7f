//! What a preprocess run did: object counts after each step (the paper's
//! Table 1 columns), the hierarchy's shape, triangles per LOD level, sizes
//! and times. Printed as a table and written as JSON by the CLI.

use std::fmt::Write as _;

use gigawalk_import::Model;

use crate::params::Resolved;

/// Statistics of one run. Times are seconds.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Stats {
    /// Triangles in the model as given.
    pub input_triangles: u64,
    /// Degenerate triangles dropped (repeated vertex or zero area).
    pub degenerate_dropped: u64,
    /// Triangles kept: exactly the triangles of the leaves' finest LODs.
    pub triangles: u64,
    /// Table 1, "Init": objects with at least one triangle.
    pub objects_init: usize,
    /// Table 1, "Part-I": objects after Partition-I.
    pub objects_part1: usize,
    /// Table 1, "Clust": objects after clustering.
    pub objects_clust: usize,
    /// Table 1, "Part-II": objects after Partition-II (the leaves).
    pub objects_part2: usize,
    /// Edges of the clustering graph.
    pub cluster_edges: usize,
    pub nodes: usize,
    pub leaves: usize,
    /// Levels on the longest root-to-leaf path (1 for a lone root).
    pub depth: u32,
    pub lods: usize,
    /// Triangles of the leaves' k-th LODs, summed over leaves, by k.
    pub leaf_lod_triangles: Vec<u64>,
    /// Triangles of the inner nodes' k-th HLODs, summed over nodes, by k.
    pub inner_lod_triangles: Vec<u64>,
    /// Geometry of the input as glTF stores it: f32 positions and normals,
    /// f32 RGBA vertex colours when present, u32 indices.
    pub raw_input_bytes: u64,
    /// Size of the input file, when the caller read one (0 otherwise).
    pub input_file_bytes: u64,
    /// Size of the scene file written; 0 when nothing was written.
    pub output_bytes: u64,
    /// Convex occluders stored for object-space culling (OCCL section).
    #[serde(default)]
    pub occluders: usize,
    /// View cells listing them (OCVC section).
    #[serde(default)]
    pub occluder_cells: usize,
    /// Entries of the object table (a glTF node or OBJ group each).
    #[serde(default)]
    pub objects: usize,
    /// Bytes of the object table and the leaves' runs (OBJT section).
    #[serde(default)]
    pub identity_bytes: u64,
    /// Compressing the OBJT section's body, in jobs (in the write phase).
    #[serde(default)]
    pub identity_compression: Pieces,
    /// `output_bytes / raw_input_bytes`.
    pub output_ratio: f64,
    /// `output_bytes / triangles`.
    pub bytes_per_triangle: f64,
    /// Seconds per phase, in pipeline order.
    pub phase_seconds: Vec<(String, f64)>,
    /// Cores busy per phase on average: the process's CPU seconds over
    /// the phase's seconds (Linux; absent elsewhere).
    #[serde(default)]
    pub phase_cores: Vec<(String, f64)>,
    pub total_seconds: f64,
    /// Triangles kept per second of total time.
    pub triangles_per_second: f64,
    /// Bytes of the model written to a spill file because it did not fit
    /// the memory budget (0: held in memory).
    #[serde(default)]
    pub spilled_bytes: u64,
    /// What certifying the levels' errors took (this process's levels; a
    /// merge of shards counts only the levels it made).
    #[serde(default)]
    pub certification: Certification,
    /// The HLOD phase's work and critical path, and the speed-ups they
    /// allow (`None` when no level was made).
    #[serde(default)]
    pub schedule: Option<Schedule>,
    /// Peak resident memory of the process (Linux VmHWM), when known.
    pub peak_memory_bytes: Option<u64>,
    /// The thresholds in model units.
    pub resolved: Option<Resolved>,
}

/// Counts of the error certifier's work ([`crate::hlod::Tally`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Certification {
    /// Levels whose error was measured in full.
    pub levels_measured: u64,
    /// Levels that had a rival (vertex clustering beside edge collapse)
    /// measured against the same reference.
    pub rivals: u64,
    /// Rivals kept instead.
    pub rivals_won: u64,
    /// Rivals whose measurement stopped as soon as they had lost.
    pub rivals_stopped: u64,
    /// Levels (collapsed or clustered) measured far off their limit for
    /// which a gentler edge collapse was measured too.
    pub gentler: u64,
    /// Gentler collapses kept instead (they measured nearer).
    pub gentler_won: u64,
    /// Leaves whose chain covers vanished pieces (as an inner node's
    /// does) rather than keeping a triangle of each: it draws less.
    pub leaf_cover_chosen: u64,
    /// Pair-contraction (GAPS) levels made and compared with the level
    /// edge collapse or clustering made.
    pub gaps: u64,
    /// GAPS levels kept instead.
    pub gaps_won: u64,
    /// Merged proxies made and measured beside the chains' levels.
    pub proxies: u64,
    /// Proxies kept: each beat every level of at most its triangles.
    pub proxies_kept: u64,
}

/// The HLOD phase as a graph of tasks: every node's levels are one task,
/// after its children's; handing the levels to the sink is one serial
/// stream beside them. Seconds are each task's time on its thread.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Schedule {
    /// Nodes whose levels this run made.
    pub tasks: usize,
    /// W: every task's seconds, and the sink's.
    pub work_seconds: f64,
    /// S: the costliest chain of tasks from a leaf to a root, or the
    /// sink's serial seconds if longer.
    pub span_seconds: f64,
    /// Seconds the sink took (encoding, compressing and writing levels),
    /// on the calling thread.
    pub sink_seconds: f64,
    /// The costliest single task's seconds.
    pub largest_task_seconds: f64,
    /// Seconds the window of units in flight was full while fewer nodes
    /// were running or waiting to run than there are threads: cores idle
    /// because no further leaf could start.
    #[serde(default)]
    pub window_starved_seconds: f64,
    /// Seconds of W by kind of work, each charged once (a BVH built for
    /// a measurement is not also the measurement's), and `other` for the
    /// rest (merging, cutting, covering what vanished, copies).
    pub seconds_by_kind: Vec<(String, f64)>,
    /// W / max(W / N, S) for N cores: the speed-up over one core the
    /// work and the critical path allow the phase, by N.
    pub speedup: Vec<(usize, f64)>,
    /// The same for the whole run, the other phases taken as serial at
    /// the CPU seconds they used (their seconds x cores busy), less the
    /// pieces of them that ran in parallel (P seconds, longest piece L, on
    /// at most T threads): (W + P + R) / (max(W / N, S) + max(P / min(N,
    /// T), L) + R). Filled when the run is done.
    #[serde(default)]
    pub run_speedup: Vec<(usize, f64)>,
}

/// Work outside the HLOD phase done in pieces on several threads: the
/// object table's compression jobs (equal in size, so each is taken to
/// cost the mean), on at most `most_threads`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Pieces {
    pub pieces: usize,
    /// CPU seconds of every piece.
    pub seconds: f64,
    /// The longest piece's seconds.
    pub longest_seconds: f64,
    /// Most threads the pieces run on, whatever the cores.
    pub most_threads: usize,
}

impl Pieces {
    /// `pieces` of equal size that took `seconds` of CPU time in all, run
    /// on at most `most_threads`.
    pub fn even(pieces: usize, seconds: f64, most_threads: usize) -> Self {
        let seconds = seconds.max(0.0);
        Pieces {
            pieces,
            seconds,
            longest_seconds: if pieces > 0 {
                seconds / pieces as f64
            } else {
                seconds
            },
            most_threads: most_threads.max(1),
        }
    }

    /// Their seconds on `n` cores.
    fn on(&self, n: usize) -> f64 {
        (self.seconds / n.min(self.most_threads).max(1) as f64).max(self.longest_seconds)
    }
}

impl Schedule {
    /// The figures of a run's [`crate::schedule::Work`].
    pub(crate) fn of(work: &crate::schedule::Work, tree: &[crate::hierarchy::HNode]) -> Self {
        Schedule {
            tasks: work.node_seconds.iter().filter(|&&s| s > 0.0).count(),
            work_seconds: work.total(),
            span_seconds: work.span(tree),
            sink_seconds: work.emit_seconds,
            largest_task_seconds: work.node_seconds.iter().copied().fold(0.0, f64::max),
            window_starved_seconds: work.window_starved_seconds,
            seconds_by_kind: {
                let mut by: Vec<(String, f64)> = crate::spent::KINDS
                    .iter()
                    .zip(&work.spent)
                    .map(|((_, name), &s)| (name.to_string(), s))
                    .collect();
                let charged: f64 = work.spent.iter().sum();
                by.push(("other".into(), (work.total() - charged).max(0.0)));
                by
            },
            speedup: [2, 4, 8, 16, 32]
                .into_iter()
                .map(|n| (n, work.speedup(tree, n)))
                .collect(),
            run_speedup: Vec::new(),
        }
    }
}

/// The raw size of a model's geometry (see [`Stats::raw_input_bytes`]).
pub fn raw_input_bytes(model: &Model) -> u64 {
    model
        .objects
        .iter()
        .map(|o| {
            let v = o.positions.len() as u64;
            let colours = if o.vertex_colours.is_some() {
                16 * v
            } else {
                0
            };
            24 * v + colours + 4 * o.indices.len() as u64
        })
        .sum()
}

/// Peak resident set size of this process, from /proc (Linux only).
pub fn peak_memory_bytes() -> Option<u64> {
    proc_status("VmHWM:")
}

/// CPU seconds this process has used, all threads, user and system
/// (Linux: /proc/self/stat, in the kernel's fixed 100 ticks a second).
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // After the command name (in parentheses, which may hold spaces):
    // state is field 3, utime 14 and stime 15.
    let rest = stat.get(stat.rfind(')')? + 1..)?;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i - 3)?.parse::<u64>().ok();
    Some((ticks(14)? + ticks(15)?) as f64 / 100.0)
}

/// Resident set size of this process now, from /proc (Linux only).
pub fn resident_memory_bytes() -> Option<u64> {
    proc_status("VmRSS:")
}

fn proc_status(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

impl Stats {
    /// Fills the derived ratios from the counts and times.
    pub fn finish(&mut self) {
        self.total_seconds = self.phase_seconds.iter().map(|(_, s)| s).sum();
        if self.total_seconds > 0.0 {
            self.triangles_per_second = self.triangles as f64 / self.total_seconds;
        }
        if self.raw_input_bytes > 0 {
            self.output_ratio = self.output_bytes as f64 / self.raw_input_bytes as f64;
        }
        if self.triangles > 0 {
            self.bytes_per_triangle = self.output_bytes as f64 / self.triangles as f64;
        }
        self.peak_memory_bytes = peak_memory_bytes();
        // The phases other than the levels, as serial CPU seconds.
        let rest: f64 = self
            .phase_seconds
            .iter()
            .filter(|(p, _)| p != "hlod")
            .map(|(p, secs)| {
                let cores = self.phase_cores.iter().find(|(q, _)| q == p);
                secs * cores.map_or(1.0, |c| c.1.max(1.0))
            })
            .sum();
        let pieces = &self.identity_compression;
        let rest = (rest - pieces.seconds).max(0.0);
        if let Some(w) = &mut self.schedule {
            let (work, span) = (w.work_seconds, w.span_seconds);
            w.run_speedup = w
                .speedup
                .iter()
                .map(|&(n, _)| {
                    let on_n = (work / n as f64).max(span) + pieces.on(n) + rest;
                    (n, (work + pieces.seconds + rest) / on_n)
                })
                .collect();
        }
    }

    /// A plain-text table for people.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        let _ = writeln!(
            s,
            "triangles         {} kept, {} degenerate dropped",
            self.triangles, self.degenerate_dropped
        );
        let _ = writeln!(
            s,
            "objects           Init {}  Part-I {}  Clust {}  Part-II {}",
            self.objects_init, self.objects_part1, self.objects_clust, self.objects_part2
        );
        let _ = writeln!(s, "clustering graph  {} edges", self.cluster_edges);
        let _ = writeln!(
            s,
            "hierarchy         {} nodes, {} leaves, depth {}, {} LODs",
            self.nodes, self.leaves, self.depth, self.lods
        );
        let list = |v: &[u64]| {
            v.iter()
                .map(|t| t.to_string())
                .collect::<Vec<_>>()
                .join(" / ")
        };
        let _ = writeln!(s, "leaf LODs (tris)  {}", list(&self.leaf_lod_triangles));
        let _ = writeln!(s, "HLODs (tris)      {}", list(&self.inner_lod_triangles));
        let _ = writeln!(
            s,
            "occluders         {} convex faces (OCCL), listed in {} view cells (OCVC)",
            self.occluders, self.occluder_cells
        );
        let _ = writeln!(
            s,
            "objects           {} named, {:.1} KiB of identity (OBJT), {:.2}% of the scene, compressed in {} jobs, {:.1} s CPU",
            self.objects,
            self.identity_bytes as f64 / 1024.0,
            100.0 * self.identity_bytes as f64 / self.output_bytes.max(1) as f64,
            self.identity_compression.pieces,
            self.identity_compression.seconds
        );
        let _ = writeln!(
            s,
            "size              {:.1} MiB out / {:.1} MiB raw input = {:.2}x, {:.1} bytes per triangle",
            mib(self.output_bytes),
            mib(self.raw_input_bytes),
            self.output_ratio,
            self.bytes_per_triangle
        );
        for (name, secs) in &self.phase_seconds {
            let cores = self
                .phase_cores
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, c)| format!("  ({c:.2} cores busy)"))
                .unwrap_or_default();
            let _ = writeln!(s, "time {name:<13}{secs:>9.3} s{cores}");
        }
        let _ = writeln!(
            s,
            "time total        {:>9.3} s  ({:.0} triangles/s)",
            self.total_seconds, self.triangles_per_second
        );
        if let Some(w) = &self.schedule {
            let _ = writeln!(
                s,
                "hlod work         W {:.1} s in {} tasks (largest {:.2} s) + sink {:.1} s; critical path S {:.2} s; window starved {:.1} s",
                w.work_seconds,
                w.tasks,
                w.largest_task_seconds,
                w.sink_seconds,
                w.span_seconds,
                w.window_starved_seconds
            );
            let ups = |v: &[(usize, f64)]| {
                v.iter()
                    .map(|(n, x)| format!("{n} cores {x:.1}x"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let _ = writeln!(s, "hlod speed-up     W / max(W/N, S): {}", ups(&w.speedup));
            if !w.run_speedup.is_empty() {
                let _ = writeln!(
                    s,
                    "run speed-up      the other phases serial: {}",
                    ups(&w.run_speedup)
                );
            }
            let kinds: Vec<String> = w
                .seconds_by_kind
                .iter()
                .map(|(k, x)| format!("{k} {x:.1} s"))
                .collect();
            let _ = writeln!(s, "hlod work by kind {}", kinds.join(", "));
        }
        if let Some(p) = self.peak_memory_bytes {
            let _ = writeln!(s, "peak memory       {:.1} MiB", mib(p));
        }
        if self.spilled_bytes > 0 {
            let _ = writeln!(
                s,
                "spilled           {:.1} MiB of objects on disk (over the memory budget's share)",
                mib(self.spilled_bytes)
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The run's speed-up: the levels' work over N cores or their span,
    /// the object table's jobs over N or the longest, the rest serial at
    /// its CPU seconds.
    #[test]
    fn the_run_speed_up_counts_the_compression_jobs_as_parallel() {
        let mut st = Stats {
            phase_seconds: vec![
                ("import".into(), 4.0),
                ("hlod".into(), 50.0),
                ("write".into(), 6.0),
            ],
            phase_cores: vec![
                ("import".into(), 1.0),
                ("hlod".into(), 2.0),
                ("write".into(), 2.0),
            ],
            // The write phase's 12 s of CPU: 10 s of them in 5 jobs, on
            // at most 4 threads.
            identity_compression: Pieces::even(5, 10.0, 4),
            schedule: Some(Schedule {
                work_seconds: 100.0,
                span_seconds: 2.0,
                speedup: vec![(2, 2.0), (16, 16.0), (100, 50.0)],
                ..Default::default()
            }),
            ..Default::default()
        };
        st.finish();
        let run = &st.schedule.as_ref().unwrap().run_speedup;
        // Rest: import 4 s + write 12 s - the jobs' 10 s = 6 s serial.
        let want = |n: f64| {
            (100.0 + 10.0 + 6.0) / ((100.0 / n).max(2.0) + (10.0 / n.min(4.0)).max(2.0) + 6.0)
        };
        for &(n, x) in run {
            assert!(
                (x - want(n as f64)).abs() < 1e-9,
                "{n}: {x} against {}",
                want(n as f64)
            );
        }
        assert!(Pieces::even(0, 3.0, 4).longest_seconds == 3.0);
        assert!(Pieces::even(4, -1.0, 4).seconds == 0.0);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn process_cpu_time_counts_this_threads_work() {
        let before = process_cpu_seconds().expect("Linux has /proc/self/stat");
        let t = std::time::Instant::now();
        let mut x = 0u64;
        // Busy until the count moves by 0.1 s (ten ticks): on a shared box
        // that takes longer, never forever.
        let mut after = before;
        while after - before < 0.1 {
            assert!(t.elapsed().as_secs() < 30, "{before} -> {after} in 30 s");
            for _ in 0..1_000_000 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
            }
            after = process_cpu_seconds().unwrap();
        }
        std::hint::black_box(x);
        assert!(after >= before + 0.1);
    }
}
