//! `endoloc experiment zones`: the Monte-Carlo zone-count sweep (the paper's Fig. 4).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use endoloc_eval::stats::{mean, median};
use endoloc_eval::{BoxColumn, HtmlReport, PlotConfig, plot_error_boxes};
use endoloc_geometry::Status;
use endoloc_jobs::bail;
use endoloc_jobs::error::{Context, Result};
use endoloc_net::{ZoneClassifier, ZoneSpec};
use serde::{Deserialize, Serialize};

use super::common::{
    self, Data, DataArgs, EndolocRun, ExperimentReport, FeatureCache, TrainSpec, ZoneChoice,
    ensure_map, ensure_model, pose_error, predict_zones, run_endoloc, shell_quote,
};
use endoloc_jobs::note;
use endoloc_jobs::progress::Progress;

/// Sweep the number of uniform zones: for every count from --from to --to (step --step),
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ZoneSweepJob {
    /// Where the data is.
    #[cfg_attr(feature = "cli", command(flatten))]
    pub data: DataArgs,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long, default_value_os_t = ZoneSweepJob::default().out))]
    pub out: PathBuf,
    /// Smallest zone count.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ZoneSweepJob::default().from))]
    pub from: usize,
    /// Largest zone count.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ZoneSweepJob::default().to))]
    pub to: usize,
    /// Step between zone counts.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ZoneSweepJob::default().step))]
    pub step: usize,
    /// Runs (training seeds 0, 1, …) per zone count.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ZoneSweepJob::default().runs))]
    pub runs: usize,
    /// Training epochs per run (the `fast` schedule with fewer epochs, to fit a night).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ZoneSweepJob::default().epochs))]
    pub epochs: usize,
    /// SURF threshold of the maps; test frames keep their strongest keypoints above 0.4 times
    /// it (a budget per frame, as the localize job does by default).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ZoneSweepJob::default().threshold))]
    pub threshold: f32,
    /// Zones tried per frame (1 = the paper's rule).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ZoneSweepJob::default().candidate_zones))]
    pub candidate_zones: usize,
    /// Keep each run's model folder (weights, descriptors) instead of deleting it once the
    /// run is recorded (its map is kept for the next runs either way).
    #[cfg_attr(feature = "cli", arg(long))]
    pub keep_models: bool,
    /// Start weights of every run's zone network: a file, or `builtin`, `builtin-track`,
    /// `builtin-joint`, `builtin-changes` (the shipped networks). With 0 `epochs` a run only
    /// indexes the training pass with them (the shipped network without training; one run per
    /// count).
    #[cfg_attr(feature = "cli", arg(long))]
    pub pretrained: Option<PathBuf>,
    /// Run only this cell of the grid, COUNT:RUN (e.g. 50:3), as printed with `print_jobs`;
    /// the tables are not written.
    #[cfg_attr(feature = "cli", arg(long, value_name = "COUNT:RUN", conflicts_with_all = ["print_jobs", "merge"]))]
    pub cell: Option<String>,
    /// Print one command per cell (for GNU parallel or a Slurm job array) and the merge
    /// command, and stop.
    #[cfg_attr(feature = "cli", arg(long, conflicts_with = "merge"))]
    pub print_jobs: bool,
    /// Run nothing: write the tables from the cells already finished (and list the others).
    #[cfg_attr(feature = "cli", arg(long))]
    pub merge: bool,
    /// Use an output folder that holds something else.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for ZoneSweepJob {
    fn default() -> Self {
        ZoneSweepJob {
            data: Default::default(),
            out: "experiments/zones".into(),
            from: 10,
            to: 170,
            step: 10,
            runs: 10,
            epochs: 30,
            threshold: endoloc_localize::DEFAULT_MAP_THRESHOLD,
            candidate_zones: 3,
            keep_models: false,
            pretrained: None,
            cell: None,
            print_jobs: false,
            merge: false,
            force: false,
        }
    }
}

/// One finished run of the sweep.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunRow {
    /// Zone count.
    pub zones: usize,
    /// Run index at this count.
    pub run: usize,
    /// Training seed.
    pub seed: u64,
    /// Test frames.
    pub frames: usize,
    /// Frames `refined`.
    pub refined: usize,
    /// Frames with a pose.
    pub localized: usize,
    /// Mean position error, mm.
    pub mean_position_mm: f64,
    /// Median position error, mm.
    pub median_position_mm: f64,
    /// Mean orientation error, degrees.
    pub mean_orientation_deg: f64,
    /// Median orientation error, degrees.
    pub median_orientation_deg: f64,
    /// Wall time of the run, seconds.
    pub seconds: f64,
}

const RESULTS: &str = "results.csv";

/// A finished run's own row, in its model folder (`models/zNNN/runRR/row.csv`, the format of
/// `results.csv`): cells run as separate jobs never write one shared file.
const ROW: &str = "row.csv";

fn read_results(path: &Path) -> Result<Vec<RunRow>> {
    if !path.is_file() {
        return Ok(Vec::new());
    }
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let row = parse_row(line)
            .with_context(|| format!("{} line {}: {line:?}", path.display(), i + 1))?;
        rows.push(row);
    }
    Ok(rows)
}

const HEADER: &str = "zones,run,seed,frames,refined,localized,mean_position_mm,median_position_mm,mean_orientation_deg,median_orientation_deg,seconds";

fn parse_row(line: &str) -> Result<RunRow> {
    let v: Vec<&str> = line.split(',').map(str::trim).collect();
    if v.len() != 11 {
        bail!("expected 11 comma-separated values, found {}", v.len());
    }
    let u = |i: usize| -> Result<usize> {
        v[i].parse()
            .with_context(|| format!("column {}: {:?} is not a count", i + 1, v[i]))
    };
    let f = |i: usize| -> Result<f64> {
        v[i].parse()
            .with_context(|| format!("column {}: {:?} is not a number", i + 1, v[i]))
    };
    Ok(RunRow {
        zones: u(0)?,
        run: u(1)?,
        seed: u(2)? as u64,
        frames: u(3)?,
        refined: u(4)?,
        localized: u(5)?,
        mean_position_mm: f(6)?,
        median_position_mm: f(7)?,
        mean_orientation_deg: f(8)?,
        median_orientation_deg: f(9)?,
        seconds: f(10)?,
    })
}

fn format_results(rows: &[RunRow]) -> String {
    let mut s = format!("{HEADER}\n");
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.1}\n",
            r.zones,
            r.run,
            r.seed,
            r.frames,
            r.refined,
            r.localized,
            r.mean_position_mm,
            r.median_position_mm,
            r.mean_orientation_deg,
            r.median_orientation_deg,
            r.seconds
        ));
    }
    s
}

impl ZoneSweepJob {
    /// The zone counts of the sweep.
    fn counts(&self) -> Vec<usize> {
        (self.from..=self.to).step_by(self.step.max(1)).collect()
    }

    /// Every cell `(count, run)` of the grid, counts first.
    fn grid(&self) -> Vec<(usize, usize)> {
        self.counts()
            .into_iter()
            .flat_map(|n| (0..self.runs).map(move |r| (n, r)))
            .collect()
    }

    /// The folder of one run (its model, map and `row.csv`).
    fn run_dir(&self, zones: usize, run: usize) -> PathBuf {
        self.out.join(format!("models/z{zones:03}/run{run:02}"))
    }

    /// The command line that runs one cell (or, with `None`, merges the finished ones).
    pub fn command(&self, cell: Option<(usize, usize)>) -> String {
        let q = |p: &Path| shell_quote(&p.display().to_string());
        let mut c = format!(
            "endoloc experiment zones --data {} --train {} --test {} --out {} --from {} --to {} \
             --step {} --runs {} --epochs {} --threshold {} --candidate-zones {}",
            q(&self.data.data),
            shell_quote(&self.data.train),
            shell_quote(&self.data.test),
            q(&self.out),
            self.from,
            self.to,
            self.step,
            self.runs,
            self.epochs,
            self.threshold,
            self.candidate_zones
        );
        if let Some(p) = &self.pretrained {
            c.push_str(&format!(" --pretrained {}", q(p)));
        }
        if self.keep_models {
            c.push_str(" --keep-models");
        }
        match cell {
            Some((n, r)) => c.push_str(&format!(" --cell {n}:{r}")),
            None => c.push_str(" --merge"),
        }
        c
    }

    /// The cell named by [`ZoneSweepJob::cell`], checked against the grid.
    fn selected_cell(&self, text: &str) -> Result<(usize, usize)> {
        let parsed = text
            .split_once(':')
            .and_then(|(n, r)| Some((n.trim().parse().ok()?, r.trim().parse().ok()?)));
        let Some(cell) = parsed else {
            bail!("`cell` {text:?}: expected COUNT:RUN, e.g. 50:3");
        };
        if !self.grid().contains(&cell) {
            bail!(
                "`cell` {text}: not a cell of this sweep; expected a count of {} and a run \
                 below {}",
                self.counts()
                    .iter()
                    .map(usize::to_string)
                    .collect::<Vec<_>>()
                    .join(", "),
                self.runs
            );
        }
        Ok(cell)
    }

    /// Runs the experiment (or one cell of it, or only the merge).
    ///
    /// # Errors
    /// Bad inputs, a failed stage, an unknown cell, or an output folder that holds something
    /// else.
    pub fn run(&self, progress: &dyn Progress) -> Result<ExperimentReport<RunRow>> {
        let args = self;
        if args.step == 0 || args.from == 0 || args.from > args.to || args.runs == 0 {
            bail!(
                "`from` {}, `to` {}, `step` {}, `runs` {}: need 0 < from ≤ to, step > 0, runs > 0",
                args.from,
                args.to,
                args.step,
                args.runs
            );
        }
        if args.epochs == 0 && args.pretrained.is_none() {
            bail!("`epochs` 0 needs `pretrained` (start weights to index the pass with)");
        }
        if args.epochs == 0 && args.runs > 1 {
            bail!(
                "`epochs` 0, `runs` {}: without training every run indexes the pass with the same \
                 weights and gives the same figures; use `runs` 1",
                args.runs
            );
        }
        let grid = args.grid();
        if args.print_jobs {
            let mut jobs: Vec<String> = grid.iter().map(|&c| args.command(Some(c))).collect();
            jobs.push(format!("# when every cell is done: {}", args.command(None)));
            return Ok(ExperimentReport {
                rows: Vec::new(),
                table: jobs.join("\n"),
                out: args.out.clone(),
                files: Vec::new(),
            });
        }
        let selected: Vec<(usize, usize)> = match &args.cell {
            Some(text) => vec![args.selected_cell(text)?],
            None if args.merge => Vec::new(),
            None => grid.clone(),
        };
        common::prepare_out(&args.out, RESULTS, args.force)?;
        let data = Data::from_args(&args.data)?;
        common::create_out(&args.out, RESULTS)?;
        let results_path = args.out.join(RESULTS);
        let mut rows = args.finished_rows(&results_path, &grid)?;
        let todo: Vec<(usize, usize)> = selected
            .iter()
            .copied()
            .filter(|&(n, r)| !rows.iter().any(|x| (x.zones, x.run) == (n, r)))
            .collect();
        let mut features: Option<FeatureCache> = None;
        let t_start = Instant::now();
        for (k, &(n, r)) in todo.iter().enumerate() {
            note!(
                progress,
                "\n=== run {}/{}: {n} zones, seed {r}{}",
                k + 1,
                todo.len(),
                eta(t_start, k, todo.len() - k)
            );
            // Another job on the same folder (`--cell`, or a sweep over other counts) may have
            // finished the cell since the list was made.
            let done_elsewhere = read_results(&args.run_dir(n, r).join(ROW))?;
            if let Some(row) = done_elsewhere.into_iter().next() {
                note!(progress, "finished by another job: {n} zones, run {r}");
                rows.push(row);
            } else {
                let row = args.run_cell(&data, n, r, &mut features, progress)?;
                rows.push(row);
            }
            if args.cell.is_none() {
                rows = union(rows, args.finished_rows(&results_path, &grid)?);
                common::write_text(&results_path, &format_results(&rows))?;
            }
        }
        if args.cell.is_some() {
            let done: Vec<RunRow> = rows
                .into_iter()
                .filter(|x| selected.contains(&(x.zones, x.run)))
                .collect();
            return Ok(ExperimentReport {
                table: format_results(&done),
                rows: done,
                out: args.out.clone(),
                files: vec![],
            });
        }
        // results.csv keeps every finished cell (another sweep's on the folder too); the
        // tables are this grid's.
        let all = union(rows, args.finished_rows(&results_path, &grid)?);
        let rows: Vec<RunRow> = all
            .iter()
            .filter(|x| grid.contains(&(x.zones, x.run)))
            .cloned()
            .collect();
        if rows.is_empty() {
            bail!(
                "no cell of {} is finished; run the cells first (see `print_jobs`)",
                args.out.display()
            );
        }
        common::write_text(&results_path, &format_results(&all))?;
        let missing: Vec<String> = grid
            .iter()
            .filter(|&&(n, r)| !rows.iter().any(|x| (x.zones, x.run) == (n, r)))
            .map(|(n, r)| format!("{n}:{r}"))
            .collect();
        let table = write_outputs(args, &rows, &missing, progress)?;
        Ok(ExperimentReport {
            rows,
            table,
            out: args.out.clone(),
            files: vec!["results.csv", "zones.md", "zones.png", "report.html"],
        })
    }

    /// The finished rows, sorted: `results.csv`, and the `row.csv` of every cell of `grid` that
    /// it lacks (cells finished by `--cell` jobs, or by another sweep on the same folder).
    fn finished_rows(&self, results_path: &Path, grid: &[(usize, usize)]) -> Result<Vec<RunRow>> {
        let mut rows = read_results(results_path)?;
        for &(n, r) in grid {
            if !rows.iter().any(|x| (x.zones, x.run) == (n, r)) {
                rows.extend(read_results(&self.run_dir(n, r).join(ROW))?);
            }
        }
        rows.sort_by_key(|x| (x.zones, x.run));
        Ok(rows)
    }

    /// Trains (or indexes), maps and localizes one cell; writes its `row.csv`.
    fn run_cell(
        &self,
        data: &Data,
        n: usize,
        r: usize,
        features: &mut Option<FeatureCache>,
        progress: &dyn Progress,
    ) -> Result<RunRow> {
        let args = self;
        let run_dirs: Vec<PathBuf> = (0..args.runs).map(|k| args.run_dir(n, k)).collect();
        let dir = &run_dirs[r];
        let t = Instant::now();
        let spec = TrainSpec {
            zones: ZoneSpec::Uniform(n),
            epochs: Some(args.epochs),
            seed: r as u64,
            pretrained: args.pretrained.clone(),
        };
        ensure_model(dir, data, &spec, progress)?;
        ensure_map(dir, data, args.threshold, None, &run_dirs, progress)?;
        let classifier = ZoneClassifier::load(dir)?;
        let map_surf = endoloc_localize::map_io::load_map(dir)?.config.surf.clone();
        let cache = FeatureCache::get(features, &data.test, &map_surf, progress)?;
        let (preds, zone_ms) = predict_zones(&classifier, &data.test, progress)?;
        drop(classifier);
        let results = run_endoloc(
            dir,
            cache,
            &preds,
            zone_ms,
            EndolocRun {
                choice: ZoneChoice::PerFrame,
                candidate_zones: args.candidate_zones,
                confirm: false,
                wall_motion_mm: 0.0,
            },
            progress,
        )?;
        let mut pos = Vec::new();
        let mut rot = Vec::new();
        for (i, res) in results.iter().enumerate() {
            if let Some(p) = res.t_wc {
                let (dp, dr) = pose_error(&p, &data.test.poses[i].pose);
                pos.push(dp);
                rot.push(dr);
            }
        }
        let (mp, dp) = (mean(&pos), median(&pos));
        let (mr, dr) = (mean(&rot), median(&rot));
        let row = RunRow {
            zones: n,
            run: r,
            seed: r as u64,
            frames: results.len(),
            refined: results
                .iter()
                .filter(|x| x.status == Status::Refined)
                .count(),
            localized: pos.len(),
            mean_position_mm: mp,
            median_position_mm: dp,
            mean_orientation_deg: mr,
            median_orientation_deg: dr,
            seconds: t.elapsed().as_secs_f64(),
        };
        note!(
            progress,
            "zones {n:>3} run {r:>2}: mean {mp:.2} mm / {mr:.2}°, median {dp:.2} mm / {dr:.2}°, refined {:.1} %, {:.0} s",
            100.0 * row.refined as f64 / row.frames.max(1) as f64,
            row.seconds
        );
        common::write_text(&dir.join(ROW), &format_results(std::slice::from_ref(&row)))?;
        if !args.keep_models {
            prune_model(dir)?;
        }
        Ok(row)
    }
}

/// The rows of `a` and those of `b` for cells `a` lacks, sorted by cell.
fn union(mut a: Vec<RunRow>, b: Vec<RunRow>) -> Vec<RunRow> {
    for row in b {
        if !a.iter().any(|x| (x.zones, x.run) == (row.zones, row.run)) {
            a.push(row);
        }
    }
    a.sort_by_key(|x| (x.zones, x.run));
    a
}

/// Deletes a recorded run's weights, descriptors and exports, keeping its zone table and map
/// (for the next runs with the same count).
fn prune_model(dir: &Path) -> Result<()> {
    for f in ["weights.safetensors", "database.bin", "checkpoint"] {
        let p = dir.join(f);
        if p.is_file() {
            std::fs::remove_file(&p).with_context(|| format!("removing {}", p.display()))?;
        } else if p.is_dir() {
            std::fs::remove_dir_all(&p).with_context(|| format!("removing {}", p.display()))?;
        }
    }
    for d in ["map_ply", "map_colmap"] {
        let p = dir.join(d);
        if p.is_dir() {
            std::fs::remove_dir_all(&p).with_context(|| format!("removing {}", p.display()))?;
        }
    }
    Ok(())
}

fn eta(start: Instant, done: usize, left: usize) -> String {
    if done == 0 {
        return String::new();
    }
    let per = start.elapsed().as_secs_f64() / done as f64;
    let s = per * left as f64;
    format!(" (about {:.0} min left)", s / 60.0)
}

fn write_outputs(
    args: &ZoneSweepJob,
    rows: &[RunRow],
    missing: &[String],
    progress: &dyn Progress,
) -> Result<String> {
    let mut by_count: BTreeMap<usize, Vec<&RunRow>> = BTreeMap::new();
    for r in rows {
        by_count.entry(r.zones).or_default().push(r);
    }
    let columns: Vec<BoxColumn> = by_count
        .iter()
        .map(|(&n, rs)| BoxColumn {
            x: n as f64,
            position_mm: rs.iter().map(|r| r.mean_position_mm).collect(),
            orientation_deg: rs.iter().map(|r| r.mean_orientation_deg).collect(),
        })
        .collect();
    let png = args.out.join("zones.png");
    plot_error_boxes(&columns, "number of zones", &png, &PlotConfig::default())?;
    // The median over the runs that produced a figure (NaN when none did); with an even
    // number of runs, the mean of the two middle ones.
    let med = |mut v: Vec<f64>| -> f64 {
        v.retain(|x| x.is_finite());
        median(&v)
    };
    let header = [
        "zones",
        "runs",
        "median of run means, pos (mm)",
        "median of run means, rot (°)",
        "best run pos (mm)",
        "median of run medians, pos (mm)",
        "refined (%)",
        "s / run",
    ];
    let mut table = Vec::new();
    for (&n, rs) in &by_count {
        let pos: Vec<f64> = rs.iter().map(|r| r.mean_position_mm).collect();
        let best = pos
            .iter()
            .copied()
            .filter(|x| x.is_finite())
            .fold(f64::INFINITY, f64::min);
        let refined: f64 = rs
            .iter()
            .map(|r| r.refined as f64 / r.frames.max(1) as f64)
            .sum::<f64>()
            / rs.len() as f64;
        table.push(vec![
            n.to_string(),
            rs.len().to_string(),
            format!("{:.2}", med(pos)),
            format!(
                "{:.2}",
                med(rs.iter().map(|r| r.mean_orientation_deg).collect())
            ),
            format!("{best:.2}"),
            format!(
                "{:.2}",
                med(rs.iter().map(|r| r.median_position_mm).collect())
            ),
            format!("{:.1}", 100.0 * refined),
            format!(
                "{:.0}",
                rs.iter().map(|r| r.seconds).sum::<f64>() / rs.len() as f64
            ),
        ]);
    }
    let best = by_count
        .iter()
        .map(|(&n, rs)| (n, med(rs.iter().map(|r| r.mean_position_mm).collect())))
        .filter(|x| x.1.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let training = match (&args.pretrained, args.epochs) {
        (Some(p), 0) => format!(
            "the pass indexed with the start weights `{}` (no training)",
            p.display()
        ),
        (Some(p), e) => format!("{e} epochs of training from `{}`", p.display()),
        (None, e) => format!("{e} epochs of training from random weights"),
    };
    let mut md = format!(
        "# Zone-count sweep (the paper's Fig. 4)\n\nDataset `{}`, {} run(s) per count, {training}, \
         {} candidate zone(s). Each box: the mean errors of the runs. The means count every frame \
         with a pose, so the few frames given a wrong zone dominate them; the medians are a \
         typical frame's error.\n\n| {} |\n|{}\n",
        args.data.data.display(),
        args.runs,
        args.candidate_zones,
        header.join(" | "),
        "---|".repeat(header.len())
    );
    for row in &table {
        md.push_str(&format!("| {} |\n", row.join(" | ")));
    }
    if let Some((n, e)) = best {
        md.push_str(&format!(
            "\nBest zone count: {n} (median of run means {e:.2} mm).\n"
        ));
    }
    if !missing.is_empty() {
        md.push_str(&format!(
            "\nNot finished: {} cell(s) ({}).\n",
            missing.len(),
            missing.join(", ")
        ));
    }
    md.push_str("\n![errors against the zone count](zones.png)\n");
    md.push_str(&format!(
        "\nReproduce: `{}`\n",
        args.command(None).replace(" --merge", "")
    ));
    common::write_text(&args.out.join("zones.md"), &md)?;
    let mut html = HtmlReport::new("endoloc — zone-count sweep");
    html.push(endoloc_eval::Block::Paragraph(format!(
        "Dataset {}, {} run(s) per count (training seeds 0…{}), {training}, {} candidate \
         zone(s). Each box shows the runs' mean errors.",
        args.data.data.display(),
        args.runs,
        args.runs - 1,
        args.candidate_zones
    )))
    .push(endoloc_eval::Block::Table {
        header: header.iter().map(|s| s.to_string()).collect(),
        rows: table,
    });
    if let Some((n, e)) = best {
        html.push(endoloc_eval::Block::Paragraph(format!(
            "Best zone count: {n} (median of run means {e:.2} mm)."
        )));
    }
    if let Some(b) = common::image_block(
        &png,
        "Mean errors of the runs against the zone count",
        progress,
    ) {
        html.push(b);
    }
    common::write_text(&args.out.join("report.html"), &html.render())?;
    Ok(md
        .lines()
        .skip(4)
        .take_while(|l| !l.starts_with("!["))
        .collect::<Vec<_>>()
        .join("\n")
        .trim_end()
        .to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_round_trip_and_bad_lines_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![RunRow {
            zones: 10,
            run: 1,
            seed: 1,
            frames: 100,
            refined: 90,
            localized: 100,
            mean_position_mm: 2.5,
            median_position_mm: 1.25,
            mean_orientation_deg: 3.0,
            median_orientation_deg: 2.0,
            seconds: 61.0,
        }];
        let p = dir.path().join(RESULTS);
        std::fs::write(&p, format_results(&rows)).unwrap();
        let back = read_results(&p).unwrap();
        assert_eq!(back.len(), 1);
        assert_eq!((back[0].zones, back[0].run, back[0].refined), (10, 1, 90));
        assert!((back[0].mean_position_mm - 2.5).abs() < 1e-9);
        std::fs::write(&p, format!("{HEADER}\n10,1,1,100\n")).unwrap();
        let e = read_results(&p).unwrap_err().full_message();
        assert!(e.contains("line 2") && e.contains("expected 11"), "{e}");
    }
}
