//! `endoloc dataset info`: a readable summary of a dataset.

use crate::dataset::{Dataset, DatasetMeta};
use crate::png_io::decode;
use crate::{DataError, Section};
use endoloc_geometry::{Camera, Distortion};
use std::fmt;
use std::path::{Path, PathBuf};

/// Summary of one sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceInfo {
    /// Sequence name.
    pub name: String,
    /// Number of frames.
    pub frames: usize,
    /// Last minus first timestamp, seconds.
    pub duration_s: f64,
    /// Length of the camera path (sum of distances between consecutive positions), mm.
    pub path_length_mm: f64,
    /// `path_length_mm / duration_s`, mm/s (0 when the duration is 0).
    pub mean_speed_mm_s: f64,
    /// Sections present, in insertion order, with their number of frames (empty without
    /// `sections.csv`).
    pub sections: Vec<(Section, usize)>,
    /// Whether the sequence has depth maps.
    pub has_depth: bool,
    /// Whether each frame has a pose (false for a pass without poses, `frames.txt`: its
    /// path length and speed are then 0).
    pub posed: bool,
    /// Pixel type of the first image ("grey 8-bit", "RGB 8-bit"), if it could be read.
    pub pixel_type: Option<String>,
}

/// Summary of a dataset.
#[derive(Debug, Clone)]
pub struct DatasetInfo {
    /// Dataset folder.
    pub root: PathBuf,
    /// `dataset.toml` contents.
    pub meta: DatasetMeta,
    /// One entry per sequence, sorted by name.
    pub sequences: Vec<SequenceInfo>,
}

/// Summarizes the dataset at `dir` (reads poses and labels, and the first image of each
/// sequence).
///
/// # Errors
/// As [`Dataset::open`] and [`Dataset::sequence`] (e.g. counts that differ: run
/// `endoloc dataset check` for a full report).
pub fn dataset_info(dir: &Path) -> Result<DatasetInfo, DataError> {
    let ds = Dataset::open(dir)?;
    let mut sequences = Vec::with_capacity(ds.sequences.len() + ds.unposed.len());
    let mut names: Vec<&String> = ds.sequences.iter().chain(&ds.unposed).collect();
    names.sort();
    for name in names {
        let seq = if ds.unposed.contains(name) {
            crate::Sequence::open_frames(&ds.root.join(name))?
        } else {
            ds.sequence(name)?
        };
        let times = seq.timestamps();
        let duration_s = match (times.first(), times.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        };
        let path_length_mm: f64 = seq
            .poses
            .windows(2)
            .map(|w| (w[1].pose.translation.vector - w[0].pose.translation.vector).norm())
            .sum();
        let sections = seq
            .sections
            .as_ref()
            .map(|labels| {
                Section::ALL
                    .iter()
                    .map(|&s| (s, labels.iter().filter(|&&l| l == s).count()))
                    .filter(|&(_, n)| n > 0)
                    .collect()
            })
            .unwrap_or_default();
        let pixel_type = seq
            .image_paths
            .first()
            .and_then(|p| decode(p).ok())
            .map(|img| match img.color() {
                image::ColorType::L8 => "grey 8-bit".to_string(),
                image::ColorType::Rgb8 => "RGB 8-bit".to_string(),
                other => format!("{other:?}"),
            });
        sequences.push(SequenceInfo {
            name: name.clone(),
            frames: seq.len(),
            duration_s,
            path_length_mm,
            mean_speed_mm_s: if duration_s > 0.0 {
                path_length_mm / duration_s
            } else {
                0.0
            },
            sections,
            has_depth: seq.depth_paths.is_some(),
            posed: seq.is_posed(),
            pixel_type,
        });
    }
    Ok(DatasetInfo {
        root: ds.root,
        meta: ds.meta,
        sequences,
    })
}

fn distortion_text(d: &Distortion) -> String {
    match *d {
        Distortion::None => "none".to_string(),
        Distortion::RadialTangential { k1, k2, p1, p2, k3 } => {
            format!("radial-tangential k1 {k1} k2 {k2} p1 {p1} p2 {p2} k3 {k3}")
        }
        Distortion::Fisheye { k1, k2, k3, k4 } => {
            format!("fisheye k1 {k1} k2 {k2} k3 {k3} k4 {k4}")
        }
    }
}

fn camera_text(c: &Camera) -> String {
    format!(
        "{}x{} px, fx {:.2} fy {:.2} cx {:.2} cy {:.2}, fov {:.1}° x {:.1}°, distortion {}",
        c.width,
        c.height,
        c.fx,
        c.fy,
        c.cx,
        c.cy,
        c.hfov_deg(),
        c.vfov_deg(),
        distortion_text(&c.distortion)
    )
}

impl fmt::Display for DatasetInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.meta;
        writeln!(f, "dataset    {}", m.name)?;
        writeln!(f, "folder     {}", self.root.display())?;
        writeln!(f, "format     v{}, units {}", m.format_version, m.units)?;
        if m.source.is_empty() {
            writeln!(f, "source     (none)")?;
        } else {
            for (i, (k, v)) in m.source.iter().enumerate() {
                let label = if i == 0 { "source" } else { "" };
                writeln!(f, "{label:<10} {k} = {v}")?;
            }
        }
        writeln!(f, "camera     {}", camera_text(&m.camera))?;
        writeln!(
            f,
            "simulation {}",
            if m.simulation.is_some() {
                "config stored in dataset.toml"
            } else {
                "none"
            }
        )?;
        writeln!(f)?;
        let w = self
            .sequences
            .iter()
            .map(|s| s.name.len())
            .max()
            .unwrap_or(0)
            .max("sequence".len());
        writeln!(
            f,
            "{:<w$}  {:>7}  {:>10}  {:>10}  {:>10}  {:>5}  pixels",
            "sequence", "frames", "duration s", "path mm", "speed mm/s", "depth"
        )?;
        for s in &self.sequences {
            let (path, speed) = if s.posed {
                (
                    format!("{:.1}", s.path_length_mm),
                    format!("{:.2}", s.mean_speed_mm_s),
                )
            } else {
                ("no poses".to_string(), "–".to_string())
            };
            writeln!(
                f,
                "{:<w$}  {:>7}  {:>10.2}  {:>10}  {:>10}  {:>5}  {}",
                s.name,
                s.frames,
                s.duration_s,
                path,
                speed,
                if s.has_depth { "yes" } else { "no" },
                s.pixel_type.as_deref().unwrap_or("?")
            )?;
        }
        for s in &self.sequences {
            write!(f, "\nsections of {}:", s.name)?;
            if s.sections.is_empty() {
                write!(f, " (no sections.csv)")?;
            }
            for (sec, n) in &s.sections {
                write!(f, "\n  {:<16} {n:>7} frames", sec.as_str())?;
            }
            writeln!(f)?;
        }
        Ok(())
    }
}
