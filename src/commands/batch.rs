//! Batch runs: a folder of scenarios in, a folder of CSVs out. Plain scenarios give a plan CSV,
//! sweeps (a `[sweep]` section) one row per case; `summary.csv` has one row per scenario.
//! Output is identical for any number of jobs; `--shard I/N` computes a stable, disjoint part
//! (plain scenarios by their index, sweep cases by theirs) and a later run with `--resume`
//! over the same output folder merges the parts into exactly the single-machine result.
//! Files are written atomically, and a content hash beside each lets `--resume` skip finished
//! work. A failing scenario is reported by name while the others still run.

use crate::error::{Error, Result};
use crate::figures::report;
use crate::io::output::write_atomic;
use crate::io::planfile::{parse_plan, write_plan};
use crate::io::scenario::Scenario;
use crate::model::geometry::UnitVec;
use crate::physics::torque::MagnetTorques;
use crate::planning::commutation::{pivot_floor, StepModel};
use crate::planning::plan::PlanRow;
use crate::planning::planner::{max_axis_error_deg, plan, total_settle_time, PlanSettings};
use rayon::prelude::*;
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How to run a batch.
#[derive(Debug, Clone)]
pub struct BatchOptions {
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
    pub index: usize,
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
}

/// The header of a sweep CSV.
pub const SWEEP_HEADER: [&str; 14] = [
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
    "reached",
    "total_settle_time_s",
    "pivot_floor_deg",
];

/// The header of summary.csv.
pub const SUMMARY_HEADER: [&str; 13] = [
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

/// One planning case of a scenario.
#[derive(Debug, Clone)]
struct Case {
    index: usize,
    settings: PlanSettings,
}

fn model_name(m: StepModel) -> &'static str {
    m.name()
}

/// The cases of a scenario, in their fixed order (models, schemes, angles, axes).
fn cases(sc: &Scenario) -> Vec<Case> {
    let Some(sw) = &sc.sweep else {
        return vec![Case {
            index: 0,
            settings: sc.plan.clone(),
        }];
    };
    let mut out = Vec::new();
    for &(model, pairs) in &sw.models {
        for &scheme in &sw.schemes {
            for &angle in &sw.angles {
                for axis in &sw.axes {
                    out.push(Case {
                        index: out.len(),
                        settings: PlanSettings {
                            axis: *axis,
                            angle,
                            scheme,
                            model,
                            pairs,
                            ..sc.plan.clone()
                        },
                    });
                }
            }
        }
    }
    out
}

/// The content hash of a scenario's work: program version, the scenario as loaded (points,
/// wells, settings) and which part of it.
fn content_hash(sc: &Scenario, text: &str, part: &str) -> String {
    let mut h = Sha256::new();
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(text.as_bytes());
    h.update(format!("{:?}", sc.torques).as_bytes());
    h.update(format!("{:?}{:?}{:?}{:?}", sc.body, sc.settle, sc.plan, sc.sweep).as_bytes());
    h.update(part.as_bytes());
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

fn hash_path(csv: &Path) -> PathBuf {
    let mut s = csv.as_os_str().to_owned();
    s.push(".hash");
    PathBuf::from(s)
}

fn up_to_date(csv: &Path, hash: &str) -> bool {
    csv.is_file() && std::fs::read_to_string(hash_path(csv)).is_ok_and(|h| h.trim() == hash)
}

/// Writes a result and then its hash (a killed run leaves at worst a result without a hash,
/// which --resume recomputes).
fn write_with_hash(csv: &Path, bytes: &[u8], hash: &str) -> Result<()> {
    write_atomic(csv, bytes)?;
    write_atomic(&hash_path(csv), format!("{hash}\n").as_bytes())
}

struct Job {
    name: String,
    file: PathBuf,
    scenario: Scenario,
    cases: Vec<Case>,
    /// Where the result goes (the whole CSV or this shard's part).
    csv: PathBuf,
    hash: String,
}

/// The result of one case.
struct Outcome {
    /// The plan (empty for a sweep case taken from the progress file).
    rows: Vec<PlanRow>,
    reached: bool,
    seconds: f64,
    /// The case's row of a sweep CSV.
    record: Vec<String>,
    /// Writing the case's kept plan failed.
    error: Option<Error>,
}

/// The progress file of a sweep result being computed (`NAME.csv.progress`): a first line
/// `hash HASH`, then the CSV row of each finished case, appended (one write per row) as the
/// case ends, so that a killed sweep is continued by `--resume`. Removed once the result is
/// written.
fn progress_path(csv: &Path) -> PathBuf {
    let mut s = csv.as_os_str().to_owned();
    s.push(".progress");
    PathBuf::from(s)
}

/// The finished cases in `csv`'s progress file (case index -> row), when the file belongs to
/// this `hash`; a row cut short by a kill (no line end, or not a whole row) counts for nothing.
fn read_progress(csv: &Path, hash: &str) -> BTreeMap<usize, Vec<String>> {
    let mut done = BTreeMap::new();
    let Ok(text) = std::fs::read_to_string(progress_path(csv)) else {
        return done;
    };
    let Some((first, rest)) = text.split_once('\n') else {
        return done;
    };
    if first.strip_prefix("hash ") != Some(hash) {
        return done;
    }
    let whole = &rest[..rest.rfind('\n').map_or(0, |k| k + 1)];
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(whole.as_bytes());
    for rec in rdr.records().flatten() {
        if rec.len() != SWEEP_HEADER.len() {
            continue;
        }
        if let Ok(case) = rec[0].parse::<usize>() {
            done.insert(case, rec.iter().map(str::to_string).collect());
        }
    }
    done
}

/// One CSV row as bytes (with its line end).
fn csv_line(record: &[String]) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(record).map_err(csv_err)?;
    w.into_inner()
        .map_err(|e| Error::io("<csv>", e.into_error()))
}

/// Starts a job's progress file with the cases already `done`; the open file, to append to
/// (`None` when it cannot be written: the sweep then runs without saving progress).
fn start_progress(
    job: &Job,
    done: &BTreeMap<usize, Vec<String>>,
) -> Option<std::sync::Mutex<std::fs::File>> {
    let path = progress_path(&job.csv);
    let mut bytes = format!("hash {}\n", job.hash).into_bytes();
    for r in done.values() {
        bytes.extend(csv_line(r).ok()?);
    }
    write_atomic(&path, &bytes).ok()?;
    let f = std::fs::OpenOptions::new().append(true).open(&path).ok()?;
    Some(std::sync::Mutex::new(f))
}

/// Appends a finished case's row to the progress file (one write, so a kill leaves whole rows
/// and at most one torn last row, which is ignored on reading).
fn append_progress(file: &std::sync::Mutex<std::fs::File>, record: &[String]) {
    use std::io::Write;
    if let (Ok(line), Ok(mut f)) = (csv_line(record), file.lock()) {
        let _ = f.write_all(&line);
    }
}

/// Writes a kept plan of a sweep case (`[sweep] keep_plans`).
fn write_kept_plan(job: &Job, c: &Case, rows: &[PlanRow], out: &Path) -> Result<()> {
    let mut buf = Vec::new();
    write_plan(rows, &mut buf)?;
    let p = out.join(&job.name).join(format!(
        "case-{}-{}-{}{}.csv",
        c.index,
        c.settings.scheme.name(),
        model_name(c.settings.model),
        c.settings.pairs
    ));
    write_atomic(&p, &buf)
}

/// Computes a job's cases (those of a sweep found in its progress file with `--resume` are
/// taken from there), saving each sweep case's row as it ends.
fn run_cases(job: &Job, opts: &BatchOptions, bar: &indicatif::ProgressBar) -> Vec<Outcome> {
    let keep_plans = job.scenario.sweep.as_ref().is_some_and(|sw| sw.keep_plans);
    // A sweep's pictures of one axis draw every case's plan: those need them all computed.
    let saves = job
        .scenario
        .sweep
        .as_ref()
        .is_some_and(|sw| !(opts.plots && sw.axes.len() == 1));
    let done = if saves && opts.resume {
        read_progress(&job.csv, &job.hash)
    } else {
        BTreeMap::new()
    };
    let progress = if saves {
        start_progress(job, &done)
    } else {
        None
    };
    job.cases
        .par_iter()
        .map(|case| {
            if let Some(record) = done.get(&case.index) {
                bar.inc(1);
                return Outcome {
                    rows: Vec::new(),
                    reached: record.get(11).is_some_and(|r| r == "true"),
                    seconds: 0.0,
                    record: record.clone(),
                    error: None,
                };
            }
            let t = Instant::now();
            let p = plan(&job.scenario.motor(), &case.settings);
            let mut o = Outcome {
                rows: p.rows,
                reached: p.reached,
                seconds: t.elapsed().as_secs_f64(),
                record: Vec::new(),
                error: None,
            };
            o.record = sweep_record(case, &o, &job.scenario.torques);
            if keep_plans {
                o.error = write_kept_plan(job, case, &o.rows, &opts.out).err();
            }
            if let (Some(f), None) = (&progress, &o.error) {
                append_progress(f, &o.record);
            }
            bar.inc(1);
            o
        })
        .collect()
}

/// Runs a batch. Progress goes to `progress` when set; the report says what ran and failed.
pub fn run_batch(inputs: &[PathBuf], opts: &BatchOptions) -> Result<BatchReport> {
    std::fs::create_dir_all(&opts.out).map_err(|e| Error::io(&opts.out, e))?;
    // Temporaries of killed runs, here and in the kept plans' folders.
    crate::io::output::remove_stale_temporaries(&opts.out);
    if let Ok(rd) = std::fs::read_dir(&opts.out) {
        for e in rd.flatten().filter(|e| e.path().is_dir()) {
            crate::io::output::remove_stale_temporaries(&e.path());
        }
    }
    let mut report = BatchReport::default();
    let mut jobs: Vec<Job> = Vec::new();
    let mut names: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut plain_index = 0usize;
    let mut loaded: Vec<(String, PathBuf, Scenario, String)> = Vec::new();
    for file in inputs {
        let text = match std::fs::read_to_string(file) {
            Ok(t) => t,
            Err(e) => {
                report
                    .failed
                    .push((file.display().to_string(), Error::io(file, e).to_string()));
                continue;
            }
        };
        let sc = match Scenario::from_toml(&text, file) {
            Ok(s) => s,
            Err(e) => {
                report
                    .failed
                    .push((file.display().to_string(), e.to_string()));
                continue;
            }
        };
        if let Err(expected) = check_name(&sc.name) {
            report.failed.push((
                file.display().to_string(),
                Error::field(file, "name", expected).to_string(),
            ));
            continue;
        }
        if let Some(other) = names.get(&sc.name) {
            report.failed.push((
                file.display().to_string(),
                format!(
                    "{}: field `name`: expected a name not used by {} already, got \"{}\"",
                    file.display(),
                    other.display(),
                    sc.name
                ),
            ));
            continue;
        }
        names.insert(sc.name.clone(), file.clone());
        loaded.push((sc.name.clone(), file.clone(), sc, text));
    }
    for (name, file, sc, text) in loaded {
        let all = cases(&sc);
        let whole = opts.out.join(format!("{name}.csv"));
        let whole_hash = content_hash(&sc, &text, "whole");
        let (csv, hash, mine) = match (opts.shard, &sc.sweep) {
            (None, _) => (whole, whole_hash, all),
            (Some(sh), None) => {
                let k = plain_index;
                plain_index += 1;
                if !sh.takes(k) {
                    continue;
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
        let job = Job {
            name,
            file,
            scenario: sc,
            cases: mine,
            csv,
            hash,
        };
        let (sc, csv, hash) = (&job.scenario, &job.csv, &job.hash);
        if opts.resume {
            let mut ready = up_to_date(csv, hash);
            if !ready && opts.shard.is_none() && sc.sweep.is_some() {
                if let Some(bytes) = merge_parts(&opts.out, &job.name, sc, &text)? {
                    write_with_hash(csv, &bytes, hash)?;
                    ready = true;
                }
            }
            // Up to date, but with --plots its pictures may be missing (never drawn, or a
            // kill while drawing): they are drawn from the result file where it holds what
            // they need; a sweep of one axis draws every plan, so it is computed again.
            let missing = opts.plots && draws(csv) && !pictures_ok(csv, hash, &opts.out);
            let from_file = sc.sweep.as_ref().is_none_or(|sw| sw.axes.len() > 1);
            if ready && !missing {
                report.skipped.push(job.name);
                continue;
            }
            if ready && from_file {
                match draw_job(&job, &[], &opts.out) {
                    Ok(()) => report.skipped.push(job.name),
                    Err(e) => report
                        .failed
                        .push((job.file.display().to_string(), e.to_string())),
                }
                continue;
            }
        }
        jobs.push(job);
    }

    let total: usize = jobs.iter().map(|j| j.cases.len()).sum();
    let bar = if opts.progress {
        indicatif::ProgressBar::new(total as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} cases, {elapsed} ({eta} left)",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // Scenarios in parallel, and each scenario's cases in parallel within it; a scenario's
    // file is written as soon as its last case is done.
    let compute = || -> Vec<(f64, Result<()>)> {
        jobs.par_iter()
            .map(|job| {
                let outcomes = run_cases(job, opts, &bar);
                let seconds = outcomes.iter().fold(0.0, |a, o| a + o.seconds);
                let written = write_job(job, &outcomes).and_then(|()| {
                    if opts.plots {
                        draw_job(job, &outcomes, &opts.out)
                    } else {
                        Ok(())
                    }
                });
                (seconds, written)
            })
            .collect()
    };
    let results = match opts.jobs {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| Error::Arg {
                arg: "--jobs".into(),
                expected: format!("a usable number of threads: {e}"),
            })?
            .install(compute),
        None => compute(),
    };
    bar.finish_and_clear();

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
        let sums = summary_csv(inputs, &opts.out, &mut report)?;
        write_atomic(&opts.out.join("summary.csv"), sums.as_bytes())?;
        if !jobs.is_empty() {
            write_atomic(&opts.out.join("timing.csv"), timing.as_bytes())?;
        }
    }
    Ok(report)
}

fn csv_err(e: csv::Error) -> Error {
    Error::io("<csv>", std::io::Error::other(e.to_string()))
}

fn sweep_record(c: &Case, o: &Outcome, torques: &MagnetTorques) -> Vec<String> {
    let s = &c.settings;
    vec![
        c.index.to_string(),
        s.scheme.name().to_string(),
        model_name(s.model).to_string(),
        s.pairs.to_string(),
        s.axis.x.to_string(),
        s.axis.y.to_string(),
        s.axis.z.to_string(),
        s.angle.0.to_degrees().to_string(),
        o.rows.len().saturating_sub(1).to_string(),
        o.rows
            .last()
            .map(|r| r.cum_angle_deg)
            .unwrap_or(0.0)
            .to_string(),
        max_axis_error_deg(&o.rows).to_string(),
        o.reached.to_string(),
        total_settle_time(&o.rows).to_string(),
        pivot_floor(torques, &s.axis).0.to_degrees().to_string(),
    ]
}

fn write_job(job: &Job, outcomes: &[Outcome]) -> Result<()> {
    match &job.scenario.sweep {
        None => {
            let o = outcomes.first().ok_or_else(|| Error::Arg {
                arg: job.name.clone(),
                expected: "one plan".into(),
            })?;
            let mut buf = Vec::new();
            write_plan(&o.rows, &mut buf)?;
            write_with_hash(&job.csv, &buf, &job.hash)
        }
        Some(_) => {
            if let Some(e) = outcomes.iter().find_map(|o| o.error.as_ref()) {
                return Err(Error::io(&job.csv, std::io::Error::other(e.to_string())));
            }
            let mut w = csv::Writer::from_writer(Vec::new());
            w.write_record(SWEEP_HEADER).map_err(csv_err)?;
            for o in outcomes {
                w.write_record(&o.record).map_err(csv_err)?;
            }
            let bytes = w
                .into_inner()
                .map_err(|e| Error::io(&job.csv, e.into_error()))?;
            write_with_hash(&job.csv, &bytes, &job.hash)?;
            let _ = std::fs::remove_file(progress_path(&job.csv));
            Ok(())
        }
    }
}

fn case_label(c: &Case) -> String {
    let s = &c.settings;
    match s.model {
        StepModel::Pivot => s.scheme.name().to_string(),
        StepModel::Dynamic => format!("{} (dynamic, {} pairs)", s.scheme.name(), s.pairs),
        StepModel::Coils => format!("{} (coil sets, {} coils)", s.scheme.name(), s.pairs),
    }
}

/// Whether `--plots` draws pictures for this result file (shard parts have none).
fn draws(csv: &Path) -> bool {
    !csv.to_string_lossy().contains(".shard-")
}

/// The list of a result's pictures (`NAME.csv.pictures`): `hash HASH`, then one file name a
/// line. Written after the last picture, so a kill while drawing leaves none.
fn pictures_path(csv: &Path) -> PathBuf {
    let mut s = csv.as_os_str().to_owned();
    s.push(".pictures");
    PathBuf::from(s)
}

/// Whether every picture of the result `csv` (of this `hash`) is in `out`.
fn pictures_ok(csv: &Path, hash: &str, out: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(pictures_path(csv)) else {
        return false;
    };
    let mut lines = text.lines();
    lines.next().and_then(|l| l.strip_prefix("hash ")) == Some(hash)
        && lines.all(|f| out.join(f).is_file())
}

/// The pictures of a job (`--plots`): a plan's figures and page (from its file); a sweep's
/// per-scheme figure and last plan's (one motion, from `outcomes`) or maps (many axes, from its
/// file). Their list goes last.
fn draw_job(job: &Job, outcomes: &[Outcome], out: &Path) -> Result<()> {
    let sc = &job.scenario;
    if !draws(&job.csv) {
        return Ok(());
    }
    let mut files = Vec::new();
    match &sc.sweep {
        None => {
            if let Some(c) = job.cases.first() {
                // From the plan as written, so that pictures drawn again by --resume (from the
                // file) are the same bytes.
                let rows = crate::io::planfile::read_plan(&job.csv)?;
                files = report::plan_pictures(
                    sc,
                    &c.settings.axis,
                    &case_label(c),
                    &rows,
                    out,
                    &job.name,
                )?;
            }
        }
        Some(sw) => {
            if sw.axes.len() > 1 {
                files = report::sweep_pictures(sc, &job.csv, out)?;
            } else {
                let plans: Vec<(String, Vec<PlanRow>)> = job
                    .cases
                    .iter()
                    .zip(outcomes)
                    .map(|(c, o)| (case_label(c), o.rows.clone()))
                    .collect();
                files = report::schemes_picture(sc, &plans, out, &job.name)?;
                if let (Some(c), Some(o)) = (job.cases.last(), outcomes.last()) {
                    files.extend(report::plan_pictures(
                        sc,
                        &c.settings.axis,
                        &case_label(c),
                        &o.rows,
                        out,
                        &job.name,
                    )?);
                }
            }
        }
    }
    let mut list = format!("hash {}\n", job.hash);
    for f in &files {
        if let Some(n) = f.file_name() {
            list.push_str(&format!("{}\n", n.to_string_lossy()));
        }
    }
    write_atomic(&pictures_path(&job.csv), list.as_bytes())
}

/// Merges the shard parts of a sweep, when a complete, up-to-date set of them is present.
fn merge_parts(out: &Path, name: &str, sc: &Scenario, text: &str) -> Result<Option<Vec<u8>>> {
    let prefix = format!("{name}.shard-");
    let mut counts: Vec<usize> = Vec::new();
    if let Ok(rd) = std::fs::read_dir(out) {
        for e in rd.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            if let Some(rest) = n.strip_prefix(&prefix).and_then(|r| r.strip_suffix(".csv")) {
                if let Some((_, c)) = rest.split_once("-of-") {
                    if let Ok(c) = c.parse::<usize>() {
                        if !counts.contains(&c) {
                            counts.push(c);
                        }
                    }
                }
            }
        }
    }
    counts.sort();
    for count in counts {
        let parts: Vec<(PathBuf, Shard)> = (0..count)
            .map(|index| {
                let sh = Shard { index, count };
                (out.join(format!("{name}.{}.csv", sh.suffix())), sh)
            })
            .collect();
        if !parts
            .iter()
            .all(|(p, sh)| up_to_date(p, &content_hash(sc, text, &sh.suffix())))
        {
            continue;
        }
        let mut rows: Vec<(usize, csv::StringRecord)> = Vec::new();
        for (p, _) in &parts {
            let mut rdr = csv::Reader::from_path(p).map_err(csv_err)?;
            for rec in rdr.records() {
                let rec = rec.map_err(csv_err)?;
                let case = rec
                    .get(0)
                    .and_then(|c| c.parse::<usize>().ok())
                    .ok_or_else(|| Error::Row {
                        file: p.clone(),
                        line: 0,
                        message: "column `case`: expected a case number".into(),
                    })?;
                rows.push((case, rec));
            }
        }
        rows.sort_by_key(|r| r.0);
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(SWEEP_HEADER).map_err(csv_err)?;
        for (_, r) in rows {
            w.write_record(&r).map_err(csv_err)?;
        }
        return Ok(Some(
            w.into_inner().map_err(|e| Error::io(out, e.into_error()))?,
        ));
    }
    Ok(None)
}

fn axis_text(a: &UnitVec) -> String {
    format!("{:.4};{:.4};{:.4}", a.x, a.y, a.z)
}

/// summary.csv, built from the output files (so that a merged run gives the same summary).
fn summary_csv(inputs: &[PathBuf], out: &Path, report: &mut BatchReport) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(SUMMARY_HEADER).map_err(csv_err)?;
    let failed: Vec<String> = report.failed.iter().map(|f| f.0.clone()).collect();
    for file in inputs {
        if failed.contains(&file.display().to_string()) {
            continue;
        }
        let Ok(sc) = Scenario::load(file) else {
            continue;
        };
        let csv = out.join(format!("{}.csv", sc.name));
        let Ok(text) = std::fs::read_to_string(&csv) else {
            continue;
        };
        let rec: Vec<String> = match &sc.sweep {
            None => {
                let rows = parse_plan(&text, &csv)?;
                let s = &sc.plan;
                let fin = rows.last().map(|r| r.cum_angle_deg).unwrap_or(0.0);
                let reached = fin >= (s.angle.0 - s.angle_tolerance.0).to_degrees();
                vec![
                    sc.name.clone(),
                    "plan".into(),
                    "1".into(),
                    axis_text(&s.axis),
                    s.angle.0.to_degrees().to_string(),
                    s.scheme.name().into(),
                    model_name(s.model).into(),
                    s.pairs.to_string(),
                    rows.len().saturating_sub(1).to_string(),
                    fin.to_string(),
                    max_axis_error_deg(&rows).to_string(),
                    reached.to_string(),
                    total_settle_time(&rows).to_string(),
                ]
            }
            Some(sw) => {
                let mut rdr = csv::Reader::from_reader(text.as_bytes());
                let (mut n, mut reached, mut steps) = (0usize, 0usize, 0usize);
                let (mut worst, mut settle, mut min_final) = (0.0f64, 0.0f64, f64::INFINITY);
                for r in rdr.records() {
                    let r = r.map_err(csv_err)?;
                    let num =
                        |k: usize| r.get(k).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
                    n += 1;
                    steps += num(8) as usize;
                    min_final = min_final.min(num(9));
                    worst = worst.max(num(10));
                    if r.get(11) == Some("true") {
                        reached += 1;
                    }
                    settle += num(12);
                }
                let join = |v: Vec<String>| v.join(";");
                vec![
                    sc.name.clone(),
                    "sweep".into(),
                    n.to_string(),
                    format!("{} axes", sw.axes.len()),
                    join(
                        sw.angles
                            .iter()
                            .map(|a| a.0.to_degrees().to_string())
                            .collect(),
                    ),
                    join(sw.schemes.iter().map(|s| s.name().to_string()).collect()),
                    join(
                        sw.models
                            .iter()
                            .map(|m| model_name(m.0).to_string())
                            .collect(),
                    ),
                    join(sw.models.iter().map(|m| m.1.to_string()).collect()),
                    steps.to_string(),
                    if n == 0 {
                        "0".into()
                    } else {
                        min_final.to_string()
                    },
                    worst.to_string(),
                    format!("{reached}/{n}"),
                    settle.to_string(),
                ]
            }
        };
        w.write_record(rec).map_err(csv_err)?;
    }
    let bytes = w.into_inner().map_err(|e| Error::io(out, e.into_error()))?;
    String::from_utf8(bytes).map_err(|e| Error::io(out, std::io::Error::other(e.to_string())))
}
