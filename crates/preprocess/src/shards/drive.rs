//! Driving a split build from one command: plan (or find the plan), run
//! the shards not done, in this process or in worker processes, then
//! merge. Also what a run's memory budget allows: threads, workers.
//!
//! Everything is said through [`Progress::line`]; the caller prints.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use super::{plan, unfinished_shards, Plan, Planned, ShardError, PLAN_FILE};
use crate::{Params, Progress, Stats};

/// What a run needs whatever its budget (code, threads' working sets,
/// one unit of levels): 60-110 MiB measured on the plants, 2 cores.
pub const FIXED_MEMORY: u64 = 128 << 20;

/// What each thread of a run needs of the budget: a unit's working set
/// and one node's chain (2 threads held 15 MiB more than one on the 2M
/// plant; twice that, for larger nodes).
pub const THREAD_MEMORY: u64 = 32 << 20;

/// The least memory a worker is given: what one shard of the default size
/// needs, with the model spilled (about 150 MiB measured on the plants,
/// docs/results.md "Memory").
pub const MIN_WORKER_BUDGET: u64 = 192 << 20;

/// Shards a process runs at once ([`run_shards_here`]): two keep the
/// cores busy through one shard's serial end; each holds its unit window
/// (a few MiB a thread) beside the other's.
const SHARDS_IN_FLIGHT: usize = 2;

/// How a finished shard reports its peak memory ([`shard_done_line`]);
/// the driver reads it back from a worker's standard error.
const PEAK: &str = "peak memory ";

/// `bytes` in whole MiB, as the progress lines give sizes.
pub fn mib(bytes: u64) -> String {
    format!("{:.0} MiB", bytes as f64 / (1024.0 * 1024.0))
}

/// "peak memory N MiB", as every progress line that reports it says it.
pub fn peak_text(bytes: u64) -> String {
    format!("{PEAK}{}", mib(bytes))
}

/// The line a shard's worker ends with: its time and peak memory, which
/// [`build_split`] reads back from the worker's standard error.
pub fn shard_done_line(index: usize, seconds: f64, peak_bytes: u64) -> String {
    format!(
        "shard {index} done in {seconds:.1} s, {}",
        peak_text(peak_bytes)
    )
}

/// The peak memory a worker's standard error reports (the last
/// [`shard_done_line`] in it).
fn reported_peak(stderr: &str) -> Option<u64> {
    let (_, rest) = stderr.rsplit_once(PEAK)?;
    let mib: f64 = rest.split_whitespace().next()?.parse().ok()?;
    Some((mib * 1024.0 * 1024.0) as u64)
}

/// Threads that give each [`THREAD_MEMORY`] of `budget`, at least one
/// and at most `cores`.
pub fn threads_for(budget: u64, cores: usize) -> usize {
    ((budget / THREAD_MEMORY) as usize).clamp(1, cores.max(1))
}

/// `jobs`, or fewer so that each worker has [`MIN_WORKER_BUDGET`] of
/// `budget` (at least one); `None`: no budget, `jobs`.
pub fn workers_for(jobs: u32, budget: Option<u64>) -> u32 {
    match budget {
        None => jobs,
        Some(b) => (b / MIN_WORKER_BUDGET).clamp(1, jobs.max(1) as u64) as u32,
    }
}

/// Caps this process's thread pool at [`threads_for`] the budget (unless
/// RAYON_NUM_THREADS says how many, or the pool is already made), and
/// says so when that is fewer than the cores.
pub fn threads_within(budget: u64, progress: &dyn Progress) {
    if std::env::var_os("RAYON_NUM_THREADS").is_some() {
        return;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let fit = threads_for(budget, cores);
    if fit < cores
        && rayon::ThreadPoolBuilder::new()
            .num_threads(fit)
            .build_global()
            .is_ok()
    {
        progress.line(&format!(
            "{fit} threads, not {cores}: the memory budget of {} gives each {}",
            mib(budget),
            mib(THREAD_MEMORY)
        ));
    }
}

/// Why a driven split build failed: the step, and the shard error.
#[derive(Debug, thiserror::Error)]
pub enum SplitError {
    #[error("cannot make a work directory in {}", dir.display())]
    WorkDir {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot plan {inputs} in {}", dir.display())]
    Plan {
        inputs: String,
        dir: PathBuf,
        #[source]
        source: Box<ShardError>,
    },
    #[error("shard {index}")]
    Shard {
        index: usize,
        #[source]
        source: Box<ShardError>,
    },
    #[error("cannot find the program to start workers")]
    NoWorkerProgram(#[source] std::io::Error),
    #[error("cannot start a worker for shard {index}: {source}")]
    WorkerStart {
        index: usize,
        source: std::io::Error,
    },
    #[error("shard {index}'s worker failed ({status}):\n{stderr}")]
    Worker {
        index: usize,
        status: std::process::ExitStatus,
        stderr: String,
    },
    #[error("cannot read the plan and model of {}", dir.display())]
    Open {
        dir: PathBuf,
        #[source]
        source: Box<ShardError>,
    },
    #[error("cannot merge {} into {}", dir.display(), output.display())]
    Merge {
        dir: PathBuf,
        output: PathBuf,
        #[source]
        source: Box<ShardError>,
    },
}

/// A worker process that runs shard K of the plan in a work directory
/// under a memory budget (`None`: all): the caller knows its program and
/// arguments.
pub type WorkerCommand<'a> =
    dyn Fn(&Path, usize, Option<u64>) -> std::io::Result<Command> + Sync + 'a;

/// A split build as one command asks for it.
pub struct SplitBuild<'a> {
    /// The model's files or directories.
    pub inputs: &'a [PathBuf],
    /// How the inputs are named in messages and provenance.
    pub label: &'a str,
    pub params: &'a Params,
    /// Triangles per shard ([`super::DEFAULT_SHARD_TRIANGLES`]).
    pub shard_triangles: u64,
    /// The work directory; `None`: a temporary one beside `output`,
    /// removed however the run ends.
    pub work_dir: Option<&'a Path>,
    /// The scene file the merge writes.
    pub output: &'a Path,
    /// Write the plan and stop.
    pub plan_only: bool,
    /// Only merge (making any shard not done here).
    pub merge_only: bool,
    /// Worker processes; 1 runs the shards in this process.
    pub jobs: u32,
    /// The run's memory budget, shared by its workers; `None`: all.
    pub budget: Option<u64>,
    /// Starts the workers when `jobs` is above 1.
    pub worker: &'a WorkerCommand<'a>,
}

/// What [`build_split`] ended with.
pub enum SplitOutcome {
    /// The plan is written (`plan_only`); it has this many shards.
    Planned { shards: usize },
    /// The scene is written: the merge's statistics and the model files.
    Built {
        stats: Box<Stats>,
        files: Vec<PathBuf>,
    },
}

/// Plans (or finds the plan), runs the shards not done (here, or in
/// `jobs` worker processes), merges.
pub fn build_split(
    build: &SplitBuild,
    progress: &dyn Progress,
) -> Result<SplitOutcome, SplitError> {
    let temp;
    let dir: &Path = match build.work_dir {
        Some(d) => d,
        None => {
            let parent = match build.output.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            // Named with this process's id: should it be killed, a later
            // run removes the directory (gigawalk_scene's atomic writes).
            temp = tempfile::Builder::new()
                .prefix(&gigawalk_scene::work_dir_prefix())
                .tempdir_in(parent)
                .map_err(|source| SplitError::WorkDir {
                    dir: parent.to_path_buf(),
                    source,
                })?;
            temp.path()
        }
    };
    let mut planned = None;
    if !build.merge_only {
        let t = Instant::now();
        progress.line(&format!("planning {}", build.label));
        let here = plan(
            build.inputs,
            build.label,
            build.params,
            build.shard_triangles,
            dir,
            build.budget,
            progress,
        )
        .map_err(|source| SplitError::Plan {
            inputs: build.label.to_string(),
            dir: dir.to_path_buf(),
            source: Box::new(source),
        })?;
        let plan = here.plan().clone();
        let todo = unfinished_shards(dir, &plan);
        progress.line(&format!(
            "plan: {} shards of at most {} triangles ({} triangles, {} nodes), {} to do, in {:.1} s: {}",
            plan.shards.len(),
            plan.shard_triangles,
            plan.triangles,
            plan.nodes,
            todo.len(),
            t.elapsed().as_secs_f64(),
            dir.join(PLAN_FILE).display()
        ));
        if build.plan_only {
            return Ok(SplitOutcome::Planned {
                shards: plan.shards.len(),
            });
        }
        if build.jobs <= 1 || todo.is_empty() {
            run_shards_here(&here, &todo, progress)?;
            planned = Some(here);
        } else {
            // The workers share the budget; this process holds nothing
            // meanwhile and imports the model again for the merge.
            drop(here);
            let jobs = workers_for(build.jobs, build.budget);
            if jobs < build.jobs {
                progress.line(&format!(
                    "{jobs} workers, not {}: the memory budget of {} gives each at least {}",
                    build.jobs,
                    mib(build.budget.unwrap_or(0)),
                    mib(MIN_WORKER_BUDGET)
                ));
            }
            run_workers(
                dir,
                &plan,
                &todo,
                jobs,
                build.budget.map(|b| b / jobs as u64),
                build.worker,
                progress,
            )?;
        }
    }
    let planned = match planned {
        Some(p) => p,
        None => Planned::open(dir, build.budget, progress).map_err(|source| SplitError::Open {
            dir: dir.to_path_buf(),
            source: Box::new(source),
        })?,
    };
    let files = planned
        .plan()
        .inputs
        .iter()
        .map(|f| f.path.clone())
        .collect();
    let t = Instant::now();
    let stats = planned
        .merge(build.output, progress, &mut |k, why| {
            progress.line(&format!("shard {k} is not done ({why}): making it here"))
        })
        .map_err(|source| SplitError::Merge {
            dir: dir.to_path_buf(),
            output: build.output.to_path_buf(),
            source: Box::new(source),
        })?;
    progress.line(&format!("merge done in {:.1} s", t.elapsed().as_secs_f64()));
    Ok(SplitOutcome::Built {
        stats: Box::new(stats),
        files,
    })
}

/// The run's one progress line after each shard: shards and triangles
/// done, triangles per second, time left at that rate, peak memory.
struct ShardProgress<'a> {
    plan: &'a Plan,
    todo: u64,
    started: Instant,
    shards: usize,
    triangles: u64,
    worker_peak: u64,
}

impl<'a> ShardProgress<'a> {
    fn new(plan: &'a Plan, todo: &[usize]) -> Self {
        ShardProgress {
            plan,
            todo: todo.iter().map(|&k| plan.shards[k].triangles).sum(),
            started: Instant::now(),
            shards: plan.shards.len() - todo.len(),
            triangles: 0,
            worker_peak: 0,
        }
    }

    fn done(&mut self, k: usize, peak: Option<u64>) -> String {
        self.shards += 1;
        self.triangles += self.plan.shards[k].triangles;
        self.worker_peak = self.worker_peak.max(peak.unwrap_or(0));
        let secs = self.started.elapsed().as_secs_f64().max(1e-3);
        let rate = self.triangles as f64 / secs;
        let left = self.todo.saturating_sub(self.triangles) as f64 / rate.max(1.0);
        let own = crate::stats::peak_memory_bytes().unwrap_or(0);
        format!(
            "shards {}/{} done ({} of {} triangles), {:.0} triangles/s, {:.0} s, eta {:.0} s, {} (largest worker {})",
            self.shards,
            self.plan.shards.len(),
            self.triangles,
            self.todo,
            rate,
            secs,
            left,
            peak_text(own),
            mib(self.worker_peak)
        )
    }
}

/// Hands out `todo`'s shards to any number of runners until one fails:
/// the first failure stops new shards (those in flight finish) and is
/// the error; the shards done are kept, so a rerun resumes.
struct Queue<'a> {
    todo: &'a [usize],
    next: AtomicUsize,
    failed: AtomicBool,
    error: Mutex<Option<SplitError>>,
}

impl<'a> Queue<'a> {
    fn new(todo: &'a [usize]) -> Self {
        Queue {
            todo,
            next: AtomicUsize::new(0),
            failed: AtomicBool::new(false),
            error: Mutex::new(None),
        }
    }

    /// The next shard to run, `None` when all are handed out or one failed.
    fn take(&self) -> Option<usize> {
        if self.failed.load(Ordering::SeqCst) {
            return None;
        }
        self.todo
            .get(self.next.fetch_add(1, Ordering::SeqCst))
            .copied()
    }

    fn fail(&self, e: SplitError) {
        self.failed.store(true, Ordering::SeqCst);
        let mut slot = self.error.lock().unwrap_or_else(|p| p.into_inner());
        slot.get_or_insert(e);
    }

    /// Runs `runner` on `threads` scoped threads until the queue is empty
    /// or a shard failed.
    fn run(self, threads: usize, runner: impl Fn(&Self) + Sync) -> Result<(), SplitError> {
        std::thread::scope(|s| {
            for _ in 0..threads.min(self.todo.len()) {
                s.spawn(|| runner(&self));
            }
        });
        match self.error.into_inner().unwrap_or_else(|p| p.into_inner()) {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// Runs shards `todo` in this process, [`SHARDS_IN_FLIGHT`] at a time on
/// the one thread pool: a shard's top nodes and its file's write run
/// with few tasks ready, and the next shard's leaves fill the cores
/// meanwhile.
fn run_shards_here(
    planned: &Planned,
    todo: &[usize],
    progress: &dyn Progress,
) -> Result<(), SplitError> {
    let line = Mutex::new(ShardProgress::new(planned.plan(), todo));
    Queue::new(todo).run(SHARDS_IN_FLIGHT, |queue| {
        while let Some(k) = queue.take() {
            if let Err(source) = planned.run_shard(k, progress) {
                queue.fail(SplitError::Shard {
                    index: k,
                    source: Box::new(source),
                });
                return;
            }
            let done = line.lock().unwrap_or_else(|p| p.into_inner()).done(k, None);
            progress.line(&done);
        }
    })
}

/// Runs shards `todo` of `plan` (in `dir`) in `jobs` worker processes at a
/// time, each given `budget`.
fn run_workers(
    dir: &Path,
    plan: &Plan,
    todo: &[usize],
    jobs: u32,
    budget: Option<u64>,
    worker: &WorkerCommand,
    progress: &dyn Progress,
) -> Result<(), SplitError> {
    let line = Mutex::new(ShardProgress::new(plan, todo));
    Queue::new(todo).run(jobs as usize, |queue| {
        while let Some(k) = queue.take() {
            let out = match worker(dir, k, budget) {
                Ok(mut command) => command.stdin(std::process::Stdio::null()).output(),
                Err(e) => {
                    queue.fail(SplitError::NoWorkerProgram(e));
                    return;
                }
            };
            let stderr = match out {
                Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stderr).into_owned(),
                Ok(o) => {
                    queue.fail(SplitError::Worker {
                        index: k,
                        status: o.status,
                        stderr: String::from_utf8_lossy(&o.stderr).trim_end().to_string(),
                    });
                    return;
                }
                Err(source) => {
                    queue.fail(SplitError::WorkerStart { index: k, source });
                    return;
                }
            };
            let done = line
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .done(k, reported_peak(&stderr));
            progress.line(&format!("{done} [{jobs} workers]"));
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threads_get_their_share_of_the_budget() {
        assert_eq!(threads_for(THREAD_MEMORY * 3, 8), 3);
        assert_eq!(threads_for(THREAD_MEMORY * 3 + THREAD_MEMORY / 2, 8), 3);
        // Never more than the cores, never none.
        assert_eq!(threads_for(THREAD_MEMORY * 100, 2), 2);
        assert_eq!(threads_for(1, 16), 1);
        assert_eq!(threads_for(THREAD_MEMORY * 4, 0), 1);
    }

    #[test]
    fn workers_get_their_share_of_the_budget() {
        assert_eq!(workers_for(8, None), 8);
        assert_eq!(workers_for(8, Some(MIN_WORKER_BUDGET * 3)), 3);
        assert_eq!(workers_for(2, Some(MIN_WORKER_BUDGET * 100)), 2);
        // A budget below one worker's share still runs one.
        assert_eq!(workers_for(4, Some(MIN_WORKER_BUDGET / 2)), 1);
        assert_eq!(workers_for(0, Some(MIN_WORKER_BUDGET * 4)), 1);
    }

    #[test]
    fn a_workers_peak_is_read_back_from_its_last_line() {
        let out = format!(
            "planning\n{}\n{}\n",
            shard_done_line(3, 1.0, 10 << 20),
            shard_done_line(3, 2.5, 300 << 20)
        );
        assert_eq!(reported_peak(&out), Some(300 << 20));
        assert_eq!(reported_peak("shard 3 failed"), None);
        assert_eq!(reported_peak("peak memory lots"), None);
    }

    #[test]
    fn the_first_failure_stops_the_queue_and_is_the_error() {
        let todo: Vec<usize> = (0..50).collect();
        // One runner: nothing after the failing shard runs.
        let ran = AtomicUsize::new(0);
        let result = Queue::new(&todo).run(1, |q| {
            while let Some(k) = q.take() {
                ran.fetch_add(1, Ordering::SeqCst);
                if k == 5 {
                    q.fail(SplitError::NoWorkerProgram(std::io::Error::other("x")));
                }
            }
        });
        assert!(matches!(result, Err(SplitError::NoWorkerProgram(_))));
        assert_eq!(ran.load(Ordering::SeqCst), 6);
        // Several: the first failure is the error, a later one is not.
        let result = Queue::new(&todo).run(4, |q| {
            while let Some(k) = q.take() {
                if k == 7 {
                    q.fail(SplitError::Shard {
                        index: 7,
                        source: Box::new(ShardError::NoSuchShard { index: 7, count: 0 }),
                    });
                    q.fail(SplitError::NoWorkerProgram(std::io::Error::other("later")));
                }
            }
        });
        assert!(matches!(result, Err(SplitError::Shard { index: 7, .. })));
        // None: every shard runs once.
        let ran = AtomicUsize::new(0);
        let all = Queue::new(&todo).run(3, |q| {
            while q.take().is_some() {
                ran.fetch_add(1, Ordering::SeqCst);
            }
        });
        assert!(all.is_ok());
        assert_eq!(ran.load(Ordering::SeqCst), 50);
    }
}
