//! Batch runs: a folder of scenarios in, a folder of CSVs out. Plain scenarios give a plan CSV,
//! sweeps (a `[sweep]` section) one row per case; `summary.csv` has one row per scenario.
//! Output is identical for any number of jobs; `--shard I/N` computes a stable, disjoint part
//! (plain scenarios by their index, sweep cases by theirs) and a later run with `--resume`
//! over the same output folder merges the parts into exactly the single-machine result.
//! Files are written atomically, and a content hash beside each lets `--resume` skip finished
//! work. A failing scenario is reported by name while the others still run.

mod cases;
mod files;
mod progress;
mod summary;

use crate::commands::args::check_out;
use crate::error::{Error, Result};
use crate::io::output::{remove_stale_temporaries, write_atomic};
use crate::io::scenario::Scenario;
use cases::{cases, run_cases, saves_progress, Case};
use files::{
    content_hash, draw_job, draws, merge_parts, pictures_ok, result_problem, stored, write_job,
    write_with_hash, Stored,
};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use summary::summary_csv;

/// How to run a batch.
#[derive(Debug, Clone)]
pub struct BatchOptions {
    /// The output folder (`--out`): each scenario's results, `summary.csv` and `timing.csv`.
    pub out: PathBuf,
    /// Worker threads (default: all cores).
    pub jobs: Option<usize>,
    /// Run only part I of N.
    pub shard: Option<Shard>,
    /// Skip work whose output exists with a matching content hash; merge shard parts.
    pub resume: bool,
    /// Show a progress bar (only drawn on a terminal).
    pub progress: bool,
    /// Also draw each result's pictures and pages (see `report`).
    pub plots: bool,
}

/// Part `index` of `count` (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This part, 0-based (below `count`).
    pub index: usize,
    /// How many parts the batch is split into (at least 1).
    pub count: usize,
}

impl Shard {
    /// Parses `I/N` with 0 <= I < N.
    pub fn parse(text: &str) -> Result<Shard> {
        let bad = || Error::Arg {
            arg: "--shard".into(),
            expected: format!("I/N with 0 <= I < N (e.g. 0/3), got '{text}'"),
        };
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let (i, n) = (
            i.trim().parse::<usize>().map_err(|_| bad())?,
            n.trim().parse::<usize>().map_err(|_| bad())?,
        );
        if n == 0 || i >= n {
            return Err(bad());
        }
        Ok(Shard { index: i, count: n })
    }

    fn takes(&self, k: usize) -> bool {
        k % self.count == self.index
    }

    fn suffix(&self) -> String {
        format!("shard-{}-of-{}", self.index, self.count)
    }
}

/// What a batch did.
#[derive(Debug, Clone, Default)]
pub struct BatchReport {
    /// Scenario names computed now.
    pub ran: Vec<String>,
    /// Scenario names skipped by --resume (output up to date) or merged from shard parts.
    pub skipped: Vec<String>,
    /// (scenario file or name, error) for each failure.
    pub failed: Vec<(String, String)>,
    /// Damaged state found and not trusted (a result or progress file that is not what was
    /// written: its work is computed again), each naming the file.
    pub warnings: Vec<String>,
}

/// The most worker threads a batch runs (`--jobs`).
pub const MAX_JOBS: usize = 256;

/// The header of a sweep CSV.
pub const SWEEP_HEADER: [&str; 20] = [
    "case",
    "scheme",
    "model",
    "pairs_per_step",
    "axis_x",
    "axis_y",
    "axis_z",
    "angle_deg",
    "steps",
    "final_angle_deg",
    "max_axis_error_deg",
    "max_path_deviation_deg",
    "reached",
    "total_settle_time_s",
    "pivot_floor_deg",
    "start_qx",
    "start_qy",
    "start_qz",
    "start_qw",
    "final_orientation_error_deg",
];

/// The header of summary.csv.
pub const SUMMARY_HEADER: [&str; 14] = [
    "name",
    "kind",
    "cases",
    "axis",
    "angle_deg",
    "scheme",
    "model",
    "pairs_per_step",
    "steps",
    "final_angle_deg",
    "max_axis_error_deg",
    "max_path_deviation_deg",
    "reached",
    "total_settle_time_s",
];

/// The scenario files named by the arguments: folders give their `*.toml` files; all sorted.
pub fn collect_inputs(args: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for a in args {
        if a.is_dir() {
            let rd = std::fs::read_dir(a).map_err(|e| Error::io(a, e))?;
            for e in rd {
                let p = e.map_err(|e| Error::io(a, e))?.path();
                if p.extension().is_some_and(|x| x == "toml") && p.is_file() {
                    files.push(p);
                }
            }
        } else {
            files.push(a.clone());
        }
    }
    files.sort();
    files.dedup();
    Ok(files)
}

/// Names a batch writes itself into `--out` (compared without case).
const RESERVED_NAMES: [&str; 2] = ["summary", "timing"];

/// Checks that a scenario name can name its files in `--out` (`NAME.csv`, `NAME.csv.hash`,
/// pictures, a folder of kept plans): a plain file name, not hidden, no path, not one of the
/// batch's own files, not a shard part, at most 200 bytes. Returns what was expected.
fn check_name(name: &str) -> std::result::Result<(), String> {
    let rule = "a name usable as a file name in --out (no `/`, `\\`, `:`, control characters, \
                no leading `.` or space, not summary or timing, no `.shard-`, at most 200 bytes; \
                without a `name` field it is the file's name)";
    let bad = name.is_empty()
        || name.len() > 200
        || name.starts_with(['.', ' '])
        || name.ends_with([' ', '.'])
        || name.chars().any(|c| {
            c.is_control() || matches!(c, '/' | '\\' | ':' | '*' | '?' | '"' | '<' | '>' | '|')
        })
        || name.contains(".shard-")
        || RESERVED_NAMES.iter().any(|r| name.eq_ignore_ascii_case(r));
    if bad {
        Err(format!("{rule}, got \"{}\"", name.escape_debug()))
    } else {
        Ok(())
    }
}

/// One scenario's work in this run: its cases and where its result goes.
struct Job {
    name: String,
    file: PathBuf,
    scenario: Scenario,
    /// The scenario file's text (part of the content hash).
    text: String,
    cases: Vec<Case>,
    /// Where the result goes (the whole CSV or this shard's part).
    csv: PathBuf,
    hash: String,
    /// With `--resume`, the sweep cases taken from its progress file (case index -> row).
    saved: BTreeMap<usize, Vec<String>>,
}

/// Runs a batch. Progress goes to `progress` when set; the report says what ran and failed.
pub fn run_batch(inputs: &[PathBuf], opts: &BatchOptions) -> Result<BatchReport> {
    if let Some(j) = opts.jobs.filter(|j| !(1..=MAX_JOBS).contains(j)) {
        return Err(Error::Arg {
            arg: "--jobs".into(),
            expected: format!("a number of worker threads from 1 to {MAX_JOBS}, got {j}"),
        });
    }
    prepare_out(&opts.out)?;
    let mut report = BatchReport::default();
    let mut jobs: Vec<Job> = Vec::new();
    let mut plain_index = 0usize;
    let loaded = load_scenarios(inputs, &mut report);
    let read: Vec<PathBuf> = loaded
        .iter()
        .flat_map(|(file, sc, _)| std::iter::once(file.clone()).chain(sc.files.iter().cloned()))
        .collect();
    for name in ["summary.csv", "timing.csv"] {
        check_out(&opts.out.join(name), &read)?;
    }
    for (file, sc, text) in loaded {
        let Some(mut job) = job_for(file, sc, text, opts, &mut plain_index) else {
            continue;
        };
        let written = [
            job.csv.clone(),
            files::hash_path(&job.csv),
            progress::progress_path(&job.csv),
        ];
        if let Err(e) = written.iter().try_for_each(|w| check_out(w, &read)) {
            report
                .failed
                .push((job.file.display().to_string(), e.to_string()));
            continue;
        }
        if opts.resume && resumed(&job, opts, &mut report)? {
            continue;
        }
        if opts.resume && saves_progress(&job, opts) {
            let by_index: BTreeMap<usize, &Case> = job.cases.iter().map(|c| (c.index, c)).collect();
            let check = |i: usize, row: &[String]| {
                let c = by_index.get(&i)?;
                Some(cases::sweep_row_problem(c, row).map_or(Ok(()), Err))
            };
            let (saved, warning) = progress::read_progress(&job.csv, &job.hash, &check);
            job.saved = saved;
            report.warnings.extend(warning);
        }
        jobs.push(job);
    }
    let results = compute(&jobs, opts)?;
    let mut timing = String::from("name,compute_time_s\n");
    for (job, (seconds, written)) in jobs.iter().zip(results) {
        match written {
            Ok(()) => {
                report.ran.push(job.name.clone());
                timing.push_str(&format!("{},{seconds:.3}\n", job.name));
            }
            Err(e) => report
                .failed
                .push((job.file.display().to_string(), e.to_string())),
        }
    }
    if opts.shard.is_none() {
        let sums = summary_csv(inputs, &opts.out, &report)?;
        write_atomic(&opts.out.join("summary.csv"), sums.as_bytes())?;
        if !jobs.is_empty() {
            write_atomic(&opts.out.join("timing.csv"), timing.as_bytes())?;
        }
    }
    Ok(report)
}

/// Creates the output folder and removes the temporaries of killed runs, there and in the
/// kept plans' folders.
fn prepare_out(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    remove_stale_temporaries(out);
    if let Ok(rd) = std::fs::read_dir(out) {
        for e in rd.flatten().filter(|e| e.path().is_dir()) {
            remove_stale_temporaries(&e.path());
        }
    }
    Ok(())
}

/// Loads the scenarios (file, scenario, text); a file that does not load, or whose name is
/// unusable or taken, goes to the report's failures.
fn load_scenarios(
    inputs: &[PathBuf],
    report: &mut BatchReport,
) -> Vec<(PathBuf, Scenario, String)> {
    let mut names: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut loaded = Vec::new();
    for file in inputs {
        let fail = |e: String| (file.display().to_string(), e);
        let text = match crate::io::input::read_text(file) {
            Ok(t) => t,
            Err(e) => {
                report.failed.push(fail(Error::io(file, e).to_string()));
                continue;
            }
        };
        let sc = match Scenario::from_toml(&text, file) {
            Ok(s) => s,
            Err(e) => {
                report.failed.push(fail(e.to_string()));
                continue;
            }
        };
        if let Err(expected) = check_name(&sc.name) {
            report
                .failed
                .push(fail(Error::field(file, "name", expected).to_string()));
            continue;
        }
        if let Some(other) = names.get(&sc.name) {
            report.failed.push(fail(format!(
                "{}: field `name`: expected a name not used by {} already, got \"{}\"",
                file.display(),
                other.display(),
                sc.name
            )));
            continue;
        }
        names.insert(sc.name.clone(), file.clone());
        loaded.push((file.clone(), sc, text));
    }
    loaded
}

/// The job of a scenario in this run: all its cases into `NAME.csv`, or with `--shard` this
/// shard's part (plain scenarios counted by `plain_index`); `None` when the shard has none.
fn job_for(
    file: PathBuf,
    sc: Scenario,
    text: String,
    opts: &BatchOptions,
    plain_index: &mut usize,
) -> Option<Job> {
    let name = sc.name.clone();
    let all = cases(&sc);
    let whole = opts.out.join(format!("{name}.csv"));
    let whole_hash = content_hash(&sc, &text, "whole");
    let (csv, hash, mine) = match (opts.shard, &sc.sweep) {
        (None, _) => (whole, whole_hash, all),
        (Some(sh), None) => {
            let k = *plain_index;
            *plain_index += 1;
            if !sh.takes(k) {
                return None;
            }
            (whole, whole_hash, all)
        }
        (Some(sh), Some(_)) => {
            let part = opts.out.join(format!("{name}.{}.csv", sh.suffix()));
            let hash = content_hash(&sc, &text, &sh.suffix());
            let mine = all.into_iter().filter(|c| sh.takes(c.index)).collect();
            (part, hash, mine)
        }
    };
    Some(Job {
        name,
        file,
        scenario: sc,
        text,
        cases: mine,
        csv,
        hash,
        saved: BTreeMap::new(),
    })
}

/// With `--resume`: whether the job's result is up to date (or merged now from a complete set
/// of shard parts) with its pictures; missing pictures are drawn from the result file where it
/// holds what they need (a sweep of one axis draws every plan, so it is computed again).
fn resumed(job: &Job, opts: &BatchOptions, report: &mut BatchReport) -> Result<bool> {
    let (sc, csv, hash) = (&job.scenario, &job.csv, &job.hash);
    let mut ready = match stored(csv, hash, |t| result_problem(sc, &job.cases, csv, t)) {
        Stored::Current => true,
        Stored::Absent => false,
        Stored::Damaged(why) => {
            report
                .warnings
                .push(format!("{}: {why}: computed again", csv.display()));
            false
        }
    };
    if !ready && opts.shard.is_none() && sc.sweep.is_some() {
        let merged = merge_parts(&opts.out, &job.name, sc, &job.text, &mut report.warnings)?;
        if let Some(bytes) = merged {
            write_with_hash(csv, &bytes, hash)?;
            ready = true;
        }
    }
    let missing = opts.plots && draws(csv) && !pictures_ok(csv, hash, &opts.out);
    let from_file = sc.sweep.as_ref().is_none_or(|sw| sw.axes.len() > 1);
    if ready && !missing {
        report.skipped.push(job.name.clone());
        return Ok(true);
    }
    if ready && from_file {
        match draw_job(job, &[], &opts.out) {
            Ok(()) => report.skipped.push(job.name.clone()),
            Err(e) => report
                .failed
                .push((job.file.display().to_string(), e.to_string())),
        }
        return Ok(true);
    }
    Ok(false)
}

/// Computes the jobs: scenarios in parallel, and each scenario's cases in parallel within it; a
/// scenario's file (and pictures) is written as soon as its last case is done. Per job: the
/// compute time, s, and whether writing succeeded.
fn compute(jobs: &[Job], opts: &BatchOptions) -> Result<Vec<(f64, Result<()>)>> {
    let total: usize = jobs.iter().map(|j| j.cases.len()).sum();
    let bar = if opts.progress {
        indicatif::ProgressBar::new(total as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    let bar = crate::commands::styled(bar, "{bar:40} {pos}/{len} cases, {elapsed} ({eta} left)");
    let run = || -> Vec<(f64, Result<()>)> {
        jobs.par_iter()
            .map(|job| {
                let outcomes = run_cases(job, opts, &bar);
                let seconds = outcomes.iter().fold(0.0, |a, o| a + o.seconds);
                let written = write_job(job, &outcomes).and_then(|()| match opts.plots {
                    true => draw_job(job, &outcomes, &opts.out),
                    false => Ok(()),
                });
                (seconds, written)
            })
            .collect()
    };
    let results = match opts.jobs {
        Some(threads) => rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|source| Error::Threads { threads, source })?
            .install(run),
        None => run(),
    };
    bar.finish_and_clear();
    Ok(results)
}
