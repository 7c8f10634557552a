//! `EvalJob`: errors, plots and a report for an estimated trajectory.

use std::fmt;
use std::path::{Path, PathBuf};

use endoloc_data::{MIDLINE_FILE, TumReader};
use endoloc_eval::align::AlignmentKind;
use endoloc_eval::association::AssociationConfig;
use endoloc_eval::rpe::RpeConfig;
use endoloc_eval::{
    EvalConfig, EvalFiles, FramesCsvReader, Metrics, Midline, Sources, WriteOptions,
    ZonesCsvReader, evaluate_files, write_results,
};
use serde::{Deserialize, Serialize};

use crate::error::{Context, Result};
use crate::progress::Progress;

/// Evaluates an estimated trajectory against the ground truth (TUM files, `T_wc`, mm,
/// associated by timestamp as evo does): APE, RPE, localized fraction, zone accuracy, per-zone
/// and per-status tables. Writes `metrics.json`, `errors.csv`, `report.md` and the PNG plots
/// into `out`; existing files are kept unless `force`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct EvalJob {
    /// Ground-truth trajectory of the test sequence (TUM; e.g. the dataset's test/poses.txt).
    #[cfg_attr(feature = "cli", arg(long))]
    pub gt: PathBuf,
    /// Estimated trajectory (TUM; a localization run's trajectory.txt).
    #[cfg_attr(feature = "cli", arg(long))]
    pub est: PathBuf,
    /// The run's frames.csv (status, zone, ... per frame). Default: frames.csv next to `est`,
    /// when it exists.
    #[cfg_attr(feature = "cli", arg(long))]
    pub frames: Option<PathBuf>,
    /// True zone of each test frame: CSV with header `frame,zone` (0-based frame and zone
    /// indices). Enables zone_accuracy.
    #[cfg_attr(feature = "cli", arg(long, value_name = "CSV"))]
    pub gt_zones: Option<PathBuf>,
    /// Output folder. Default (empty): `eval/` next to `est`.
    #[cfg_attr(
        feature = "cli",
        arg(short, long, value_parser = crate::path_or_empty(), default_value_os_t = EvalJob::default().out, hide_default_value = true)
    )]
    pub out: PathBuf,
    /// Replace existing output files.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
    /// Align the estimate onto the ground truth before computing errors: `none`, `se3`
    /// (rigid Umeyama, evo -a) or `sim3` (with scale, evo -a -s).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_parser = alignment_parser(), default_value = alignment_name(EvalJob::default().align))
    )]
    pub align: AlignmentKind,
    /// Largest timestamp difference for associating poses, seconds (evo --t_max_diff).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = EvalJob::default().t_max_diff))]
    pub t_max_diff: f64,
    /// Offset added to the estimate's timestamps before associating, seconds (evo --t_offset).
    #[cfg_attr(
        feature = "cli",
        arg(long, default_value_t = EvalJob::default().t_offset, allow_hyphen_values = true)
    )]
    pub t_offset: f64,
    /// RPE pair distance, in associated poses (evo_rpe --delta N --delta_unit f).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = EvalJob::default().rpe_delta))]
    pub rpe_delta: usize,
    /// RPE over every pair (i, i+delta) instead of consecutive pairs (evo_rpe --all_pairs).
    #[cfg_attr(feature = "cli", arg(long))]
    pub rpe_all_pairs: bool,
    /// Do not draw the PNG plots.
    #[cfg_attr(feature = "cli", arg(long))]
    pub no_plots: bool,
    /// The colon's mid-line for the error along the colon (`x y z` per line, mm, anus →
    /// caecum). Default: the dataset's midline.txt beside the ground truth's sequence folder,
    /// else the dataset's training pass standing in for it.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE"))]
    pub midline: Option<PathBuf>,
}

/// The names of the alignments, as in the job's TOML table.
#[cfg(feature = "cli")]
const ALIGNMENTS: [(&str, AlignmentKind); 3] = [
    ("none", AlignmentKind::None),
    ("se3", AlignmentKind::Se3),
    ("sim3", AlignmentKind::Sim3),
];

/// The name of an alignment, as in the job's TOML table.
#[cfg(feature = "cli")]
fn alignment_name(kind: AlignmentKind) -> &'static str {
    ALIGNMENTS
        .iter()
        .find(|(_, k)| *k == kind)
        .map_or("none", |(name, _)| name)
}

/// Parses an alignment by its name.
#[cfg(feature = "cli")]
fn alignment_parser() -> impl clap::builder::TypedValueParser<Value = AlignmentKind> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(ALIGNMENTS.map(|(name, _)| name)).map(|s| {
        ALIGNMENTS
            .iter()
            .find(|(name, _)| *name == s)
            .map_or(AlignmentKind::None, |(_, k)| *k)
    })
}

impl Default for EvalJob {
    fn default() -> Self {
        let cfg = EvalConfig::default();
        EvalJob {
            gt: PathBuf::new(),
            est: PathBuf::new(),
            frames: None,
            gt_zones: None,
            out: PathBuf::new(),
            force: false,
            align: cfg.alignment,
            t_max_diff: cfg.association.max_diff_s,
            t_offset: cfg.association.offset_s,
            rpe_delta: cfg.rpe.delta_frames,
            rpe_all_pairs: cfg.rpe.all_pairs,
            no_plots: false,
            midline: None,
        }
    }
}

/// What `EvalJob` found and wrote.
#[derive(Debug, Clone)]
pub struct EvalReport {
    /// The metrics (as in `metrics.json`).
    pub metrics: Metrics,
    /// Every file written, in order.
    pub files: Vec<PathBuf>,
    /// The output folder.
    pub out: PathBuf,
}

fn parent_or_dot(p: &Path) -> PathBuf {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

impl EvalJob {
    /// The library configuration of this job.
    pub fn eval_config(&self) -> EvalConfig {
        EvalConfig {
            association: AssociationConfig {
                max_diff_s: self.t_max_diff,
                offset_s: self.t_offset,
            },
            alignment: self.align,
            rpe: RpeConfig {
                delta_frames: self.rpe_delta,
                all_pairs: self.rpe_all_pairs,
            },
        }
    }

    /// The output folder: `out`, or `eval/` next to `est`.
    pub fn out_dir(&self) -> PathBuf {
        if self.out.as_os_str().is_empty() {
            parent_or_dot(&self.est).join("eval")
        } else {
            self.out.clone()
        }
    }

    /// The colon's mid-line for the error along the colon: `midline`; else the dataset's
    /// `midline.txt` beside the ground truth's sequence folder; else that dataset's training
    /// pass standing in for it; else none.
    ///
    /// # Errors
    /// An unreadable or malformed mid-line or training trajectory.
    pub fn resolve_midline(&self) -> Result<Option<Midline>> {
        if let Some(p) = &self.midline {
            return Ok(Some(
                Midline::from_file(p).context("reading the mid-line (`midline`)")?,
            ));
        }
        let Some(dataset) = self.gt.parent().and_then(Path::parent) else {
            return Ok(None);
        };
        let file = dataset.join(MIDLINE_FILE);
        if file.is_file() {
            return Ok(Some(
                Midline::from_file(&file).context("reading the dataset's mid-line")?,
            ));
        }
        let train = dataset.join("train").join("poses.txt");
        if dataset.join("dataset.toml").is_file() && train.is_file() && train != self.gt {
            let poses = endoloc_data::read_tum(&train).context("reading the training pass")?;
            let source = format!(
                "the training pass {} (the dataset has no {MIDLINE_FILE})",
                train.display()
            );
            return Ok(Some(Midline::from_trajectory(&poses, source)?));
        }
        Ok(None)
    }

    /// Evaluates and writes the results.
    ///
    /// # Errors
    /// An unreadable input, trajectories that do not associate, or existing outputs without
    /// `force`.
    pub fn run(&self, progress: &dyn Progress) -> Result<EvalReport> {
        let frames_path = self.frames.clone().or_else(|| {
            let p = parent_or_dot(&self.est).join("frames.csv");
            p.is_file().then(|| {
                tracing::info!("using {}", p.display());
                p
            })
        });
        // Every input is read line by line, here once to say which one is bad and then by
        // the evaluation's passes: memory does not grow with the length of the pass.
        type Checked = std::result::Result<(), endoloc_eval::EvalError>;
        let tum = |p: &Path| -> Checked { Ok(TumReader::open(p)?.try_for_each(|r| r.map(drop))?) };
        tum(&self.gt).context("reading the ground truth (`gt`)")?;
        tum(&self.est).context("reading the estimate (`est`)")?;
        if let Some(p) = &frames_path {
            let frames = || -> Checked { FramesCsvReader::open(p)?.try_for_each(|r| r.map(drop)) };
            frames().context("reading frames.csv")?;
        }
        if let Some(p) = &self.gt_zones {
            let zones = || -> Checked { ZonesCsvReader::open(p)?.try_for_each(|r| r.map(drop)) };
            zones().context("reading the ground-truth zones (`gt_zones`)")?;
        }
        let midline = self.resolve_midline()?;
        let out = self.out_dir();
        // Written next to `out` first, then moved in together: a killed run leaves the
        // earlier results as they were.
        let staged = crate::output::StagedFiles::new(&out)?;
        let evaluation = evaluate_files(
            &EvalFiles {
                gt: self.gt.clone(),
                est: self.est.clone(),
                frames: frames_path.clone(),
                gt_zones: self.gt_zones.clone(),
                scratch_dir: Some(staged.dir().to_path_buf()),
                midline,
            },
            &self.eval_config(),
        )
        .with_context(|| {
            format!(
                "evaluating {} against {}",
                self.est.display(),
                self.gt.display()
            )
        })?;
        let shown = |p: &Path| p.display().to_string();
        let written = write_results(
            &evaluation,
            staged.dir(),
            &WriteOptions {
                force: true,
                no_plots: self.no_plots,
                plot: Default::default(),
                sources: Sources {
                    gt: shown(&self.gt),
                    est: shown(&self.est),
                    frames: frames_path.as_deref().map(shown),
                    gt_zones: self.gt_zones.as_deref().map(shown),
                },
            },
        )?;
        let names: Vec<std::ffi::OsString> = written
            .files
            .iter()
            .filter_map(|f| f.file_name().map(|n| n.to_os_string()))
            .collect();
        if !self.force
            && let Some(name) = names.iter().find(|n| out.join(n).exists())
        {
            return Err(endoloc_eval::EvalError::AlreadyExists {
                path: out.join(name),
            }
            .into());
        }
        staged.publish()?;
        let files = names.iter().map(|n| out.join(n)).collect();
        if !self.no_plots && !written.plot_text {
            progress.note("warning: no usable system font (fontconfig): plots drawn without text");
        }
        Ok(EvalReport {
            metrics: evaluation.metrics,
            files,
            out,
        })
    }
}

impl fmt::Display for EvalReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.metrics;
        writeln!(
            f,
            "frames {}  localized {} ({:.1} %)",
            m.frames,
            m.localized,
            100.0 * m.localized_fraction
        )?;
        for (name, s) in [
            ("position mm", &m.position_mm),
            ("orientation °", &m.orientation_deg),
        ] {
            writeln!(
                f,
                "{name:>14}: mean {:.3}  median {:.3}  rmse {:.3}  p90 {:.3}  max {:.3}",
                s.mean, s.median, s.rmse, s.p90, s.max
            )?;
        }
        if let Some(r) = &m.rpe {
            writeln!(
                f,
                "{:>14}: {:.3} mm  {:.3}° (rmse, delta {} frames)",
                "RPE", r.translation_mm.rmse, r.rotation_deg.rmse, r.delta_frames
            )?;
        }
        if let Some(a) = &m.along_colon_mm {
            writeln!(
                f,
                "{:>14}: mean {:.3}  median {:.3}  p90 {:.3}  max {:.3} (mm of mid-line)",
                "along colon", a.mean, a.median, a.p90, a.max
            )?;
        }
        if let Some(acc) = m.zone_accuracy {
            writeln!(f, "{:>14}: {:.1} %", "zone accuracy", 100.0 * acc)?;
        }
        write!(
            f,
            "wrote {} files to {}",
            self.files.len(),
            self.out.display()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_library_defaults() {
        assert_eq!(EvalJob::default().eval_config(), EvalConfig::default());
        let from_toml: EvalJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, EvalJob::default());
        let job = EvalJob {
            est: "runs/a/trajectory.txt".into(),
            ..EvalJob::default()
        };
        assert_eq!(job.out_dir(), PathBuf::from("runs/a/eval"));
    }
}
