//! `spherestep design`: the layout optimiser (issue 56). A scenario's `[design]` section says
//! what may change; NSGA-II ([`crate::planning::design::search`]) proposes layouts a
//! generation at a time, and each generation's layouts are planned about the coarse axes as
//! one batch folder (`DIR/gen-GGG/coarse`: a scenario per layout, its sweep's results with
//! their `.hash`), the first front's newcomers about the full axes as another
//! (`DIR/gen-GGG/full`). So a generation shards like a batch (`--shard I/N` computes its part
//! of the first stage not finished, then merges once every part is there), a killed run
//! resumes (`--resume` replays the seeded evolution, taking each finished stage's results),
//! and the bytes are the same on any thread count. At the end: `DIR/front.csv` (the layouts
//! no other fully planned layout dominates), `DIR/layouts/*.toml` (their complete scenarios)
//! `DIR/history.csv` (per generation: evaluations and the best objectives), `DIR/front.svg`
//! and `.png` (every fully planned layout's worst axis error against its median steps) and
//! `DIR/best-layouts.svg` and `.png` (the scenario's layout and the front's best in 3-D).

mod files;
mod pictures;

use crate::commands::batch::{run_batch, BatchOptions, Shard};
use crate::error::{Error, Result};
use crate::io::output::write_atomic;
use crate::io::scenario::Scenario;
use crate::model::geometry::UnitVec;
use crate::planning::design::layout::{decode, gene_bounds, seeds, Layout, Own};
use crate::planning::design::objectives::{non_dominated, Objectives};
use crate::planning::design::search::{Evolution, Member, Ranked};
use crate::planning::design::DesignSpec;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How to run a design search.
#[derive(Debug, Clone)]
pub struct DesignOptions {
    /// The output folder (`--out`).
    pub out: PathBuf,
    /// The evolution's seed (`--seed`).
    pub seed: u64,
    /// Worker threads (default: all cores); the bytes are the same for any number.
    pub jobs: Option<usize>,
    /// Compute only this part of the first stage not finished.
    pub shard: Option<Shard>,
    /// Take the stages already computed (and merge finished shard parts).
    pub resume: bool,
    /// Show each stage's progress bar (only drawn on a terminal).
    pub progress: bool,
}

/// What a design run did.
#[derive(Debug, Clone, Default)]
pub struct DesignReport {
    /// Generations finished (the first counts).
    pub generations: usize,
    /// With `--shard`: the stage whose other parts are still to come (`None`: the run ended).
    pub waiting: Option<String>,
    /// The front: each layout's name and full objectives, as in `front.csv`.
    pub front: Vec<(String, Objectives)>,
    /// Layouts planned about the coarse axes (or penalised without planning).
    pub evaluations: usize,
    /// Layouts planned about the full axes.
    pub full_evaluations: usize,
    /// Damaged results found and computed again, each naming its file.
    pub warnings: Vec<String>,
}

/// One run's fixed parts.
struct Run<'a> {
    spec: &'a DesignSpec,
    base: toml::Table,
    opts: &'a DesignOptions,
    report: DesignReport,
}

/// Runs the design search of the scenario file `spec_file`.
///
/// # Errors
///
/// A scenario that does not load or has no `[design]` section, an output that cannot be
/// written, a layout whose batch fails (named).
pub fn run_design(spec_file: &Path, opts: &DesignOptions) -> Result<DesignReport> {
    let text = crate::io::input::text(spec_file)?;
    let sc = Scenario::from_toml(&text, spec_file)?;
    let spec = sc.design.clone().ok_or_else(|| {
        Error::field(
            spec_file,
            "design",
            "a [design] section (what the search may change)",
        )
    })?;
    std::fs::create_dir_all(&opts.out).map_err(|e| Error::io(&opts.out, e))?;
    let mut run = Run {
        spec: &spec,
        base: files::base_table(&text, spec_file)?,
        opts,
        report: DesignReport::default(),
    };
    let own = Own::of(&sc.stator, &sc.rotor);
    let mut evo = Evolution::new(opts.seed, gene_bounds(&spec));
    let mut genes = seeds(&spec, own);
    genes.extend(evo.random_genes(spec.population - genes.len()));
    let mut ranked: Option<Ranked> = None;
    let mut full: BTreeMap<String, (Layout, Objectives)> = BTreeMap::new();
    let mut history = files::history_header();
    for g in 0..=spec.generations {
        if let Some(r) = &ranked {
            genes = evo.offspring(r, spec.population);
        }
        let Some(next) = run.generation(g, &genes, own, &mut evo, ranked.take(), &mut full)? else {
            return Ok(run.report);
        };
        history.push_str(&history_row(g, &run.report, &next, full.len()));
        ranked = Some(next);
        run.report.generations = g + 1;
    }
    write_atomic(&opts.out.join("history.csv"), history.as_bytes())?;
    run.write_front(&full, own)?;
    Ok(run.report)
}

/// `history.csv`'s row of generation `g`: evaluations so far, the front's size and the
/// best of each objective among the generation's survivors (coarse axes).
fn history_row(g: usize, report: &DesignReport, ranked: &Ranked, front: usize) -> String {
    let best: Vec<String> = (0..6)
        .map(|k| {
            let b = ranked
                .members
                .iter()
                .map(|m| m.objectives[k])
                .fold(f64::INFINITY, f64::min);
            b.to_string()
        })
        .collect();
    format!(
        "{g},{},{},{front},{}\n",
        report.evaluations,
        report.full_evaluations,
        best.join(",")
    )
}

impl Run<'_> {
    /// Generation `g`: its layouts planned about the coarse axes, the survivors of them and
    /// `parents` (a parent planned about the full axes ranked on its full objectives), and the
    /// first front's newcomers planned about the full axes (into `full`).
    /// `None` when a sharded stage waits for its other parts.
    fn generation(
        &mut self,
        g: usize,
        genes: &[Vec<f64>],
        own: Own,
        evo: &mut Evolution,
        parents: Option<Ranked>,
        full: &mut BTreeMap<String, (Layout, Objectives)>,
    ) -> Result<Option<Ranked>> {
        let layouts: Vec<(String, Layout)> = genes
            .iter()
            .enumerate()
            .map(|(k, gs)| (format!("g{g:03}-{k:03}"), decode(self.spec, gs, own)))
            .collect();
        let dir = self.opts.out.join(format!("gen-{g:03}"));
        let axes = self.spec.axes_of(self.spec.axes);
        let Some(objs) = self.stage(&dir.join("coarse"), &layouts, &axes)? else {
            return Ok(None);
        };
        self.report.evaluations += layouts.len();
        // a parent planned about the full axes competes on those (steadier) objectives
        let mut pool: Vec<Member> = parents.map(|p| p.members).unwrap_or_default();
        for m in &mut pool {
            if let Some((_, o)) = full.get(&m.id) {
                m.objectives = o.values().to_vec();
            }
        }
        pool.extend(
            layouts
                .iter()
                .zip(genes)
                .zip(&objs)
                .map(|(((id, _), gs), o)| Member {
                    id: id.clone(),
                    genes: gs.clone(),
                    objectives: o.values().to_vec(),
                }),
        );
        let ranked = evo.survivors(pool, self.spec.population);
        let ranks = ranked.ranks();
        let promoted: Vec<(String, Layout)> = ranked
            .members
            .iter()
            .zip(&ranks)
            .filter(|(m, &r)| r == 0 && !full.contains_key(&m.id))
            .map(|(m, _)| (m.id.clone(), decode(self.spec, &m.genes, own)))
            .filter(|(_, l)| l.violation_deg == 0.0)
            .take(self.spec.population.div_ceil(2))
            .collect();
        let axes = self.spec.axes_of(self.spec.full_axes);
        let Some(objs) = self.stage(&dir.join("full"), &promoted, &axes)? else {
            return Ok(None);
        };
        self.report.full_evaluations += promoted.len();
        full.extend(
            promoted
                .into_iter()
                .zip(objs)
                .map(|((id, l), o)| (id, (l, o))),
        );
        Ok(Some(ranked))
    }

    /// One stage's batch: each layout that keeps the separations written as a scenario in
    /// `dir/scenarios`, planned about `axes` into `dir/results`, and its objectives read back
    /// (a layout that breaks them is penalised unplanned). `None` when this shard's part is
    /// done and others are not.
    fn stage(
        &mut self,
        dir: &Path,
        layouts: &[(String, Layout)],
        axes: &[UnitVec],
    ) -> Result<Option<Vec<Objectives>>> {
        let scenarios = dir.join("scenarios");
        let results = dir.join("results");
        std::fs::create_dir_all(&scenarios).map_err(|e| Error::io(&scenarios, e))?;
        let angle = self.spec.angle.0.to_degrees();
        let mut inputs = Vec::new();
        for (id, l) in layouts.iter().filter(|(_, l)| l.violation_deg == 0.0) {
            let what = format!("design layout {id} ({} family)", l.family.name());
            let text = files::layout_toml(&self.base, id, &what, l, axes, angle)?;
            let path = scenarios.join(format!("{id}.toml"));
            write_atomic(&path, text.as_bytes())?;
            inputs.push((id.clone(), path));
        }
        if !self.computed(&inputs, &results)? {
            return Ok(None);
        }
        let mut out = Vec::with_capacity(layouts.len());
        for (id, l) in layouts {
            out.push(match l.violation_deg {
                v if v > 0.0 => Objectives::penalised(v, l.stator.len()),
                _ => {
                    let rows = files::read_sweep(&results.join(format!("{id}.csv")))?;
                    Objectives::from_axes(&rows, l.stator.len())
                }
            });
        }
        Ok(Some(out))
    }

    /// Runs a stage's batch (this shard's part, then the merge once every part is there);
    /// whether its results are all there.
    fn computed(&mut self, inputs: &[(String, PathBuf)], results: &Path) -> Result<bool> {
        let files: Vec<PathBuf> = inputs.iter().map(|(_, p)| p.clone()).collect();
        let whole = |resume: bool, shard: Option<Shard>| BatchOptions {
            out: results.to_path_buf(),
            jobs: self.opts.jobs,
            shard,
            resume,
            progress: self.opts.progress,
            plots: false,
        };
        let all = |name: &dyn Fn(&str) -> String| {
            inputs
                .iter()
                .all(|(id, _)| results.join(name(id)).is_file())
        };
        let parts_there = |sh: Shard| {
            (0..sh.count).all(|i| all(&|id| format!("{id}.shard-{i}-of-{}.csv", sh.count)))
        };
        let mut run = |o: BatchOptions| -> Result<()> {
            let report = run_batch(&files, &o)?;
            self.report.warnings.extend(report.warnings);
            match report.failed.first() {
                None => Ok(()),
                Some((file, e)) => Err(Error::Parse {
                    file: PathBuf::from(file),
                    message: format!("the design's batch failed: {e}"),
                }),
            }
        };
        let Some(sh) = self.opts.shard else {
            run(whole(self.opts.resume, None))?;
            return Ok(true);
        };
        if !(all(&|id| format!("{id}.csv")) || parts_there(sh)) {
            run(whole(self.opts.resume, Some(sh)))?;
            if !parts_there(sh) {
                self.report.waiting = Some(results.display().to_string());
                return Ok(false);
            }
        }
        run(whole(true, None))?;
        Ok(true)
    }

    /// `front.csv` and `layouts/*.toml`: the fully planned layouts no other dominates (the
    /// scenarios of earlier fronts in `layouts/` removed).
    fn write_front(
        &mut self,
        full: &BTreeMap<String, (Layout, Objectives)>,
        own: Own,
    ) -> Result<()> {
        let entries: Vec<pictures::Entry> = full.iter().collect();
        let objs: Vec<Objectives> = entries.iter().map(|(_, (_, o))| *o).collect();
        let front: Vec<usize> = non_dominated(&objs);
        let dir = self.opts.out.join("layouts");
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let axes = self.spec.axes_of(self.spec.full_axes);
        let angle = self.spec.angle.0.to_degrees();
        let mut rows = Vec::new();
        for &k in &front {
            let (id, (l, o)) = entries[k];
            let what = format!(
                "design layout {id} ({} family): axis error worst {:.2} deg, mean of the worst \
                 quarter {:.2} deg, median steps {} on the design's {} full axes",
                l.family.name(),
                o.worst_axis_error_deg,
                o.tail_axis_error_deg,
                o.median_steps,
                axes.len()
            );
            let text = files::layout_toml(&self.base, id, &what, l, &axes, angle)?;
            write_atomic(&dir.join(format!("{id}.toml")), text.as_bytes())?;
            rows.push(files::FrontRow {
                id,
                layout: l,
                objectives: *o,
                scenario: format!("layouts/{id}.toml"),
            });
            self.report.front.push((id.clone(), *o));
        }
        if let Ok(rd) = std::fs::read_dir(&dir) {
            for e in rd.flatten() {
                let stem = e
                    .path()
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned());
                let kept = stem.is_some_and(|s| rows.iter().any(|r| r.id == s));
                if !kept && e.path().extension().is_some_and(|x| x == "toml") {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
        write_atomic(
            &self.opts.out.join("front.csv"),
            files::front_csv(&rows).as_bytes(),
        )?;
        if !entries.is_empty() {
            let picture = pictures::front_picture(&entries, &front, own);
            crate::figures::write_figure(&picture, &self.opts.out.join("front"))?;
        }
        let best = pictures::best_picture(&entries, &front, own);
        crate::figures::write_figure(&best, &self.opts.out.join("best-layouts"))?;
        Ok(())
    }
}
