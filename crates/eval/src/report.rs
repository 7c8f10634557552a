//! `report.md`: a human-readable summary of an evaluation, referencing the plots.

use std::fmt::Write as _;

use crate::align::AlignmentKind;
use crate::metrics::{Metrics, ZoneSource};
use crate::stats::Statistics;

/// Where the evaluated files came from (as given on the command line), for the report.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Sources {
    /// Ground-truth trajectory.
    pub gt: String,
    /// Estimated trajectory.
    pub est: String,
    /// The run's frames.csv, if given.
    pub frames: Option<String>,
    /// Ground-truth zones, if given.
    pub gt_zones: Option<String>,
}

/// A plot the report links to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlotRef {
    /// File name, relative to the report.
    pub file: String,
    /// One-line caption.
    pub caption: String,
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map(|x| format!("{x:.digits$}"))
        .unwrap_or_else(|| "–".into())
}

fn stats_row(name: &str, s: &Statistics) -> String {
    format!(
        "| {name} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |\n",
        s.count, s.mean, s.median, s.rmse, s.p90, s.max, s.min, s.std
    )
}

const STATS_HEADER: &str = "| error | n | mean | median | rmse | p90 | max | min | std |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";

/// Renders the markdown report.
pub fn render_report(metrics: &Metrics, sources: &Sources, plots: &[PlotRef]) -> String {
    let m = metrics;
    let mut s = String::new();
    s.push_str("# Localization evaluation\n\n");
    let _ = writeln!(s, "- ground truth: `{}`", sources.gt);
    let _ = writeln!(s, "- estimate: `{}`", sources.est);
    if let Some(f) = &sources.frames {
        let _ = writeln!(s, "- frames: `{f}`");
    }
    if let Some(z) = &sources.gt_zones {
        let _ = writeln!(s, "- ground-truth zones: `{z}`");
    }
    let align = match m.alignment.kind {
        AlignmentKind::None => "none (errors in the ground truth's world frame)".to_string(),
        AlignmentKind::Se3 => "SE(3) Umeyama (rigid)".to_string(),
        AlignmentKind::Sim3 => format!("Sim(3) Umeyama, scale {:.6}", m.alignment.scale),
    };
    let _ = writeln!(s, "- alignment: {align}");
    let a = &m.association;
    let _ = writeln!(
        s,
        "- association: {} of {} estimated poses matched to the {} ground-truth poses by timestamp (max. difference {} s, offset {} s)\n",
        a.matched, a.est_poses, a.gt_poses, a.config.max_diff_s, a.config.offset_s
    );

    s.push_str("## Summary\n\n| quantity | value |\n|---|---:|\n");
    let _ = writeln!(s, "| test frames | {} |", m.frames);
    let _ = writeln!(
        s,
        "| localized | {} ({:.1} %) |",
        m.localized,
        100.0 * m.localized_fraction
    );
    let _ = writeln!(
        s,
        "| median position error | {:.2} mm |",
        m.position_mm.median
    );
    let _ = writeln!(
        s,
        "| median orientation error | {:.2}° |",
        m.orientation_deg.median
    );
    if let Some(acc) = m.zone_accuracy {
        let _ = writeln!(
            s,
            "| zone accuracy | {:.1} % (within one zone: {}) over {} frames |",
            100.0 * acc,
            m.zone_within_one
                .map(|v| format!("{:.1} %", 100.0 * v))
                .unwrap_or_else(|| "–".into()),
            m.zone_frames.unwrap_or(0)
        );
    }
    s.push('\n');

    s.push_str("## Absolute pose error\n\nPosition: `‖t_est − t_gt‖` (mm, evo_ape `trans_part`); orientation: geodesic angle of `R_estᵀ R_gt` (degrees, evo_ape `angle_deg`). p90: 90th percentile, linear interpolation.\n\n");
    s.push_str(STATS_HEADER);
    s.push_str(&stats_row("position (mm)", &m.position_mm));
    s.push_str(&stats_row("orientation (°)", &m.orientation_deg));
    if let Some(a) = &m.along_colon_mm {
        s.push_str(&stats_row("along the colon (mm)", a));
    }
    if let Some(a) = &m.along_colon_refined_mm {
        s.push_str(&stats_row("along the colon, refined (mm)", a));
    }
    if let Some(src) = &m.midline {
        let _ = write!(
            s,
            "\nAlong the colon: mm of mid-line between the mid-line points nearest to the estimate and to the truth (mid-line: {src}).\n"
        );
    }
    s.push('\n');

    if let Some(r) = &m.rpe {
        let _ = writeln!(
            s,
            "## Relative pose error\n\nPairs of associated poses {} apart ({} pairs; evo_rpe `--delta {} --delta_unit f`{}); where frames are missing, a pair spans the gap.\n",
            r.delta_frames,
            if r.all_pairs { "all" } else { "consecutive" },
            r.delta_frames,
            if r.all_pairs { " --all_pairs" } else { "" }
        );
        s.push_str(STATS_HEADER);
        s.push_str(&stats_row("translation (mm)", &r.translation_mm));
        s.push_str(&stats_row("rotation (°)", &r.rotation_deg));
        s.push('\n');
    }

    if let Some(c) = &m.status_counts {
        s.push_str("## Frames by status\n\n| status | frames | median position (mm) | median orientation (°) |\n|---|---:|---:|---:|\n");
        for (name, n) in [
            ("refined", c.refined),
            ("init_only", c.init_only),
            ("rejected", c.rejected),
            ("(no row in frames.csv)", c.without_row),
        ] {
            let e = m.by_status.get(name);
            let _ = writeln!(
                s,
                "| {name} | {n} | {} | {} |",
                opt(e.map(|e| e.position_mm.median), 2),
                opt(e.map(|e| e.orientation_deg.median), 2)
            );
        }
        s.push('\n');
    }

    if !m.per_zone.is_empty() {
        let key = match m.zone_source {
            Some(ZoneSource::GroundTruth) => "true zone",
            _ => "predicted zone",
        };
        let _ = writeln!(s, "## Per zone\n\nFrames grouped by {key}.\n");
        let with_acc = m.per_zone.iter().any(|z| z.zone_accuracy.is_some());
        s.push_str("| zone | frames | localized | position mean (mm) | position median (mm) | orientation mean (°) | orientation median (°) |");
        s.push_str(if with_acc {
            " zone accuracy (%) |\n"
        } else {
            "\n"
        });
        s.push_str("|---:|---:|---:|---:|---:|---:|---:|");
        s.push_str(if with_acc { "---:|\n" } else { "\n" });
        for z in &m.per_zone {
            let _ = write!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} |",
                z.zone,
                z.frames,
                z.localized,
                opt(z.position_mm_mean, 2),
                opt(z.position_mm_median, 2),
                opt(z.orientation_deg_mean, 2),
                opt(z.orientation_deg_median, 2)
            );
            if with_acc {
                let _ = write!(s, " {} |", opt(z.zone_accuracy.map(|v| 100.0 * v), 1));
            }
            s.push('\n');
        }
        s.push('\n');
    }

    if !plots.is_empty() {
        s.push_str("## Plots\n\n");
        for p in plots {
            let _ = writeln!(s, "![{}]({})\n\n*{}*\n", p.caption, p.file, p.caption);
        }
    }

    let flags = match m.alignment.kind {
        AlignmentKind::None => "",
        AlignmentKind::Se3 => " -a",
        AlignmentKind::Sim3 => " -a -s",
    };
    let _ = writeln!(
        s,
        "## Reproduce with evo\n\n```\nevo_ape tum {gt} {est} -r trans_part{flags} --t_max_diff {d}\nevo_ape tum {gt} {est} -r angle_deg{flags} --t_max_diff {d}\nevo_rpe tum {gt} {est} -r trans_part{flags} --delta {delta} --delta_unit f --t_max_diff {d}\n```",
        gt = sources.gt,
        est = sources.est,
        d = m.association.config.max_diff_s,
        delta = m.config.rpe.delta_frames,
    );
    s
}
