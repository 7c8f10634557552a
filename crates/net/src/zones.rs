//! Zoning of a training sequence: which frames form zone `k` (0-based, increasing along the
//! training trajectory, `docs/CONVENTIONS.md`).
//!
//! - **Uniform** ([`ZoneConfig::Uniform`]): `count` zones of equal arc length of the camera path
//!   ([`UniformBy::ArcLength`], the default) or of equal frame counts ([`UniformBy::Frames`]).
//!   Arc length is the default because it gives zones of the same physical extent whatever the
//!   scope's speed: a pause of the scope (a second at one place) does not become a zone of its
//!   own, and a fast stretch is not lumped into one zone. Boundaries fall on the first frame
//!   whose cumulative path length reaches `k · L / count`. A zone over a fast stretch can then
//!   hold a frame or two, too few for its map (triangulation needs views from several
//!   frames): every zone keeps at least `min_frames` frames (default
//!   [`DEFAULT_MIN_ZONE_FRAMES`]), its bounds moved as little as needed into its neighbours
//!   (listed in [`ZoneTable::widened`]). A pass with fewer than `count · min_frames` frames
//!   gives each zone `frames / count` at least. A path of zero length falls back to equal frame
//!   counts.
//! - **Expert** ([`ZoneConfig::Expert`]): one zone per anatomical section of `sections.csv`
//!   (each contiguous run of one label along the trajectory; runs shorter than
//!   [`MIN_SECTION_RUN_FRAMES`] are merged into the run before them), then the remaining
//!   `count − sections` zones go one at a time to the section with the most frames per zone
//!   (so long sections — sigmoid, descending, transverse, ascending — are split, as in the
//!   paper). A section is split into zones of equal frame counts. A section shorter than an
//!   average zone keeps one zone of its own.
//!
//! Each zone stores its **median pose** ([`endoloc_geometry::zone_median_pose`]:
//! component-wise median of the positions, geodesic L1 median of the rotations), the pose the
//! localizer starts from.
//!
//! The table is saved as `zones.csv` in the model folder ([`ZoneTable::save`]).

use crate::NetError;
use endoloc_data::{Section, Sequence};
use endoloc_geometry::{Pose, orientation_error_deg, pose::pose_from_parts, zone_median_pose};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Runs of one section label shorter than this (frames) are merged into the previous run
/// (label flicker at a boundary, a scope jiggling across it).
pub const MIN_SECTION_RUN_FRAMES: usize = 5;

/// Fewest training frames a uniform zone holds by default ([`ZoneConfig::Uniform`]'s
/// `min_frames`): a zone's map triangulates features seen in several of its frames.
pub const DEFAULT_MIN_ZONE_FRAMES: usize = 3;

fn default_min_frames() -> usize {
    DEFAULT_MIN_ZONE_FRAMES
}

/// File name of the zone table in a model folder.
pub const ZONES_FILE: &str = "zones.csv";

/// What "uniform" means for [`ZoneConfig::Uniform`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UniformBy {
    /// Equal arc length of the camera path (mm) per zone. The default.
    #[default]
    #[serde(alias = "arc-length")]
    ArcLength,
    /// Equal numbers of frames per zone (sizes differ by at most one frame).
    Frames,
}

impl std::fmt::Display for UniformBy {
    /// `arc-length` or `frames`, as the options spell them.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            UniformBy::ArcLength => "arc-length",
            UniformBy::Frames => "frames",
        })
    }
}

impl std::str::FromStr for UniformBy {
    type Err = NetError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().replace('-', "_").as_str() {
            "arc_length" | "arclength" | "length" => Ok(UniformBy::ArcLength),
            "frames" => Ok(UniformBy::Frames),
            other => Err(NetError::Config(format!(
                "unknown uniform zoning {other:?}; expected arc-length or frames"
            ))),
        }
    }
}

/// How to cut the training sequence into zones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ZoneConfig {
    /// `count` zones of equal arc length or equal frame counts.
    Uniform {
        /// Number of zones (the paper's best: 50–70).
        count: usize,
        /// Equal arc length (default) or equal frame counts.
        #[serde(default)]
        by: UniformBy,
        /// Fewest frames a zone holds (default [`DEFAULT_MIN_ZONE_FRAMES`]): a zone over a
        /// fast stretch takes frames from its neighbours until it has this many.
        #[serde(default = "default_min_frames")]
        min_frames: usize,
    },
    /// One zone per anatomical section, long sections split so that there are `count` zones
    /// in all (the paper: 13 sections, 50 zones). Needs `sections.csv`.
    Expert {
        /// Total number of zones, at least the number of section runs.
        count: usize,
    },
}

impl Default for ZoneConfig {
    /// 50 uniform zones of equal arc length, at least [`DEFAULT_MIN_ZONE_FRAMES`] frames each.
    fn default() -> Self {
        ZoneConfig::uniform(50, UniformBy::ArcLength)
    }
}

impl ZoneConfig {
    /// `count` uniform zones cut `by` arc length or frames, at least
    /// [`DEFAULT_MIN_ZONE_FRAMES`] frames each.
    pub fn uniform(count: usize, by: UniformBy) -> Self {
        ZoneConfig::Uniform {
            count,
            by,
            min_frames: DEFAULT_MIN_ZONE_FRAMES,
        }
    }

    /// The number of zones asked for.
    pub fn count(&self) -> usize {
        match *self {
            ZoneConfig::Uniform { count, .. } | ZoneConfig::Expert { count } => count,
        }
    }
}

/// Zones as a job's options give them: a count of uniform zones (`50`) or anatomical zones
/// (`expert`, or `expert:N` for N zones in all). Written as a number (uniform) or a string
/// (expert) in TOML and JSON, read from either; parsed from and displayed as `50`, `expert`,
/// `expert:9`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ZoneSpec {
    /// This many uniform zones ([`ZoneConfig::Uniform`]).
    Uniform(usize),
    /// One zone per anatomical section, long sections split so that there are this many in
    /// all (`None`: [`ZoneSpec::DEFAULT_EXPERT_ZONES`]; [`ZoneConfig::Expert`]).
    Expert(Option<usize>),
}

impl ZoneSpec {
    /// Anatomical zones in all when `expert` gives no count (the paper's 50).
    pub const DEFAULT_EXPERT_ZONES: usize = 50;

    /// The number of zones asked for.
    pub fn count(self) -> usize {
        match self {
            ZoneSpec::Uniform(n) => n,
            ZoneSpec::Expert(n) => n.unwrap_or(Self::DEFAULT_EXPERT_ZONES),
        }
    }

    /// The zoning: uniform zones cut `by` arc length or frames, at least `min_frames` frames
    /// each (both unused for expert zones).
    pub fn config(self, by: UniformBy, min_frames: usize) -> ZoneConfig {
        match self {
            ZoneSpec::Uniform(count) => ZoneConfig::Uniform {
                count,
                by,
                min_frames,
            },
            ZoneSpec::Expert(_) => ZoneConfig::Expert {
                count: self.count(),
            },
        }
    }
}

impl Default for ZoneSpec {
    /// 50 uniform zones.
    fn default() -> Self {
        ZoneSpec::Uniform(50)
    }
}

impl std::str::FromStr for ZoneSpec {
    type Err = NetError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || {
            NetError::Config(format!(
                "zones {s:?}: expected a number, `expert` or `expert:N` with N a number"
            ))
        };
        let t = s.trim().to_ascii_lowercase();
        match t.strip_prefix("expert") {
            Some("") => Ok(ZoneSpec::Expert(None)),
            Some(rest) => {
                let n = rest.strip_prefix(':').ok_or_else(bad)?;
                Ok(ZoneSpec::Expert(Some(n.trim().parse().map_err(|_| bad())?)))
            }
            None => t.parse().map(ZoneSpec::Uniform).map_err(|_| bad()),
        }
    }
}

impl std::fmt::Display for ZoneSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ZoneSpec::Uniform(n) => write!(f, "{n}"),
            ZoneSpec::Expert(None) => f.write_str("expert"),
            ZoneSpec::Expert(Some(n)) => write!(f, "expert:{n}"),
        }
    }
}

impl Serialize for ZoneSpec {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            ZoneSpec::Uniform(n) => s.serialize_u64(*n as u64),
            ZoneSpec::Expert(_) => s.collect_str(self),
        }
    }
}

impl<'de> Deserialize<'de> for ZoneSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = ZoneSpec;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a zone count, `expert` or `expert:N`")
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<ZoneSpec, E> {
                usize::try_from(v)
                    .map(ZoneSpec::Uniform)
                    .map_err(|_| E::custom(format!("zone count {v} is too large")))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<ZoneSpec, E> {
                u64::try_from(v)
                    .map_err(|_| E::custom(format!("zone count {v} is negative")))
                    .and_then(|v| self.visit_u64(v))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<ZoneSpec, E> {
                v.parse().map_err(E::custom)
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// One zone: a contiguous range of training frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Zone {
    /// Zone index, 0-based along the training trajectory.
    pub index: usize,
    /// First training frame of the zone.
    pub first_frame: usize,
    /// Last training frame of the zone (inclusive).
    pub last_frame: usize,
    /// Anatomical section (expert zones; uniform zones: the majority label when the sequence
    /// has `sections.csv`, else `None`).
    pub section: Option<Section>,
    /// Median pose `T_wc` of the zone's frames (mm): component-wise median position,
    /// geodesic L1 median rotation.
    pub median_pose: Pose,
    /// Number of frames, `last_frame − first_frame + 1`.
    pub frame_count: usize,
    /// Length of the camera path inside the zone, mm.
    pub path_length_mm: f64,
}

impl Zone {
    /// The frames of the zone.
    pub fn frames(&self) -> std::ops::RangeInclusive<usize> {
        self.first_frame..=self.last_frame
    }
}

/// The zones of a training sequence and the zone of every training frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ZoneTable {
    /// How the zones were made.
    pub config: ZoneConfig,
    /// Zones in trajectory order; `zones[k].index == k`.
    pub zones: Vec<Zone>,
    /// Zone index of each training frame.
    pub zone_of_frame: Vec<usize>,
    /// Uniform zones that held fewer than `min_frames` frames at equal arc length (a fast
    /// stretch of the pass) and were widened into their neighbours to hold `min_frames`. Not
    /// stored in `zones.csv`: empty for a loaded table.
    pub widened: Vec<usize>,
}

/// Cumulative camera path length (mm) at each frame; `s[0] = 0`.
pub fn cumulative_path_mm(poses: &[Pose]) -> Vec<f64> {
    let mut s = Vec::with_capacity(poses.len());
    let mut acc = 0.0;
    for (i, p) in poses.iter().enumerate() {
        if i > 0 {
            acc += (p.translation.vector - poses[i - 1].translation.vector).norm();
        }
        s.push(acc);
    }
    s
}

/// Splits `n` frames into `k` contiguous parts of equal size (± 1 frame); returns the first
/// frame of each part. Requires `1 ≤ k ≤ n`.
fn equal_frame_starts(offset: usize, n: usize, k: usize) -> Vec<usize> {
    (0..k).map(|j| offset + j * n / k).collect()
}

/// First frames of `k` zones of equal arc length over `s` (cumulative lengths), each zone
/// non-empty. Requires `1 ≤ k ≤ s.len()`.
fn arc_length_starts(s: &[f64], k: usize) -> Vec<usize> {
    let n = s.len();
    let total = s.last().copied().unwrap_or(0.0);
    if total.is_nan() || total <= 0.0 {
        return equal_frame_starts(0, n, k);
    }
    let mut starts = Vec::with_capacity(k);
    starts.push(0);
    let mut frame = 0;
    for j in 1..k {
        let target = total * j as f64 / k as f64;
        while frame < n && s[frame] < target {
            frame += 1;
        }
        // Non-empty zones: after the previous start, and leaving one frame to each later zone.
        let lo = starts[j - 1] + 1;
        let hi = n - (k - j);
        starts.push(frame.clamp(lo, hi));
    }
    starts
}

/// Moves zone starts (`starts[0] == 0`, strictly increasing, within `0..n`) so that every
/// zone holds at least `m` frames (`k · m ≤ n` required), as little as possible in the least
/// squares sense: with `u_j = start_j − j·m` the constraint is `u` non-decreasing within
/// `0..=n − k·m`, so `u` is the isotonic regression (pool-adjacent-violators) of the current
/// starts, clamped and rounded. Starts that already satisfy the constraint do not move.
/// Returns the zones that held fewer than `m` frames before.
fn widen_short_zones(starts: &mut [usize], n: usize, m: usize) -> Vec<usize> {
    let k = starts.len();
    let size = |s: &[usize], j: usize| s.get(j + 1).copied().unwrap_or(n) - s[j];
    let short: Vec<usize> = (0..k).filter(|&j| size(starts, j) < m).collect();
    if short.is_empty() || k * m > n {
        return Vec::new();
    }
    // Pool adjacent violators over u_j = start_j − j·m (blocks of (sum, count)).
    let mut blocks: Vec<(f64, usize)> = Vec::with_capacity(k);
    for (j, &s) in starts.iter().enumerate() {
        blocks.push((s as f64 - (j * m) as f64, 1));
        while blocks.len() >= 2 {
            let (b, a) = (blocks[blocks.len() - 1], blocks[blocks.len() - 2]);
            if a.0 / a.1 as f64 <= b.0 / b.1 as f64 {
                break;
            }
            blocks.pop();
            let last = blocks.len() - 1;
            blocks[last] = (a.0 + b.0, a.1 + b.1);
        }
    }
    let hi = (n - k * m) as f64;
    let mut j = 0;
    for (sum, count) in blocks {
        let u = (sum / count as f64).clamp(0.0, hi).round() as usize;
        for _ in 0..count {
            starts[j] = if j == 0 { 0 } else { u + j * m };
            j += 1;
        }
    }
    short
}

/// Contiguous runs of one label: `(label, first, last_inclusive)`, runs shorter than
/// [`MIN_SECTION_RUN_FRAMES`] merged into the previous run (or the next, at the start), and
/// neighbouring runs of one label joined.
fn section_runs(labels: &[Section]) -> Vec<(Section, usize, usize)> {
    let mut runs: Vec<(Section, usize, usize)> = Vec::new();
    for (i, &l) in labels.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if r.0 == l => r.2 = i,
            _ => runs.push((l, i, i)),
        }
    }
    // Merge short runs into a neighbour until none is left (or one run remains).
    loop {
        if runs.len() <= 1 {
            break;
        }
        let Some(pos) = runs
            .iter()
            .position(|r| r.2 + 1 - r.1 < MIN_SECTION_RUN_FRAMES)
        else {
            break;
        };
        let (_, first, last) = runs.remove(pos);
        if pos > 0 {
            runs[pos - 1].2 = last;
        } else {
            runs[0].1 = first;
        }
        // Join neighbours that now carry the same label.
        let mut joined: Vec<(Section, usize, usize)> = Vec::with_capacity(runs.len());
        for r in runs.drain(..) {
            match joined.last_mut() {
                Some(j) if j.0 == r.0 => j.2 = r.2,
                _ => joined.push(r),
            }
        }
        runs = joined;
    }
    runs
}

/// Gives `total` zones to segments of the given frame counts: one each, then one at a time
/// to the segment with the most frames per zone (never more zones than frames).
fn allocate_zones(frames: &[usize], total: usize) -> Vec<usize> {
    let mut k = vec![1usize; frames.len()];
    for _ in frames.len()..total {
        let best = (0..frames.len())
            .filter(|&i| k[i] < frames[i])
            .max_by(|&a, &b| {
                let ra = frames[a] as f64 / k[a] as f64;
                let rb = frames[b] as f64 / k[b] as f64;
                ra.total_cmp(&rb).then(b.cmp(&a))
            });
        match best {
            Some(i) => k[i] += 1,
            None => break,
        }
    }
    k
}

impl ZoneTable {
    /// Cuts a training sequence into zones.
    ///
    /// # Errors
    /// [`NetError::Zoning`] for zero zones, more zones than frames, an empty sequence, fewer
    /// zones than anatomical sections (expert), or non-finite poses;
    /// [`NetError::MissingSections`] for expert zones on a sequence without `sections.csv`.
    pub fn from_sequence(seq: &Sequence, config: &ZoneConfig) -> Result<Self, NetError> {
        let poses: Vec<Pose> = seq.poses.iter().map(|p| p.pose).collect();
        if let ZoneConfig::Expert { .. } = config
            && seq.sections.is_none()
        {
            return Err(NetError::MissingSections {
                dir: seq.dir.clone(),
            });
        }
        Self::from_poses(&poses, seq.sections.as_deref(), config)
    }

    /// Cuts a trajectory (`T_wc` poses in frame order, optional section label per frame) into
    /// zones; see the module documentation for the rules.
    ///
    /// # Errors
    /// As [`ZoneTable::from_sequence`]; expert zones without labels give
    /// [`NetError::Zoning`].
    pub fn from_poses(
        poses: &[Pose],
        sections: Option<&[Section]>,
        config: &ZoneConfig,
    ) -> Result<Self, NetError> {
        let n = poses.len();
        let count = config.count();
        if n == 0 {
            return Err(NetError::Zoning(
                "the training sequence has no frames".into(),
            ));
        }
        if count == 0 {
            return Err(NetError::Zoning(
                "the number of zones must be at least 1".into(),
            ));
        }
        if count > n {
            return Err(NetError::Zoning(format!(
                "{count} zones need at least {count} frames, but the training sequence has {n}; ask for at most {n} zones"
            )));
        }
        if let Some(s) = sections
            && s.len() != n
        {
            return Err(NetError::Zoning(format!(
                "{} section labels for {n} frames; expected one per frame",
                s.len()
            )));
        }
        let s = cumulative_path_mm(poses);
        if s.iter().any(|v| !v.is_finite()) {
            return Err(NetError::Zoning("non-finite camera positions".into()));
        }
        // (first frame, section) of each zone.
        let mut starts: Vec<(usize, Option<Section>)> = Vec::with_capacity(count);
        let mut widened = Vec::new();
        match *config {
            ZoneConfig::Uniform { by, min_frames, .. } => {
                let mut firsts = match by {
                    UniformBy::Frames => equal_frame_starts(0, n, count),
                    UniformBy::ArcLength => arc_length_starts(&s, count),
                };
                let m = min_frames.min(n / count).max(1);
                widened = widen_short_zones(&mut firsts, n, m);
                starts.extend(firsts.into_iter().map(|f| (f, None)));
            }
            ZoneConfig::Expert { .. } => {
                let labels = sections.ok_or_else(|| {
                    NetError::Zoning(
                        "expert zones need an anatomical label per frame (sections.csv)".into(),
                    )
                })?;
                let runs = section_runs(labels);
                if count < runs.len() {
                    let names: Vec<&str> = runs.iter().map(|r| r.0.as_str()).collect();
                    return Err(NetError::Zoning(format!(
                        "expert zoning needs at least one zone per section: the training sequence has {} section runs ({}), but {count} zones were asked for",
                        runs.len(),
                        names.join(", ")
                    )));
                }
                let lens: Vec<usize> = runs.iter().map(|r| r.2 + 1 - r.1).collect();
                let per = allocate_zones(&lens, count);
                for (r, k) in runs.iter().zip(per) {
                    for f in equal_frame_starts(r.1, r.2 + 1 - r.1, k) {
                        starts.push((f, Some(r.0)));
                    }
                }
            }
        }
        let mut zones = Vec::with_capacity(starts.len());
        let mut zone_of_frame = vec![0usize; n];
        for (k, &(first, section)) in starts.iter().enumerate() {
            let last = starts.get(k + 1).map_or(n - 1, |next| next.0 - 1);
            let frames = &poses[first..=last];
            let median_pose = zone_median_pose(frames)
                .map_err(|e| NetError::Zoning(format!("zone {k}: median pose: {e}")))?;
            let section = section.or_else(|| sections.and_then(|l| majority(&l[first..=last])));
            zone_of_frame[first..=last].fill(k);
            zones.push(Zone {
                index: k,
                first_frame: first,
                last_frame: last,
                section,
                median_pose,
                frame_count: last + 1 - first,
                path_length_mm: s[last] - s[first],
            });
        }
        Ok(ZoneTable {
            config: *config,
            zones,
            zone_of_frame,
            widened,
        })
    }

    /// A line for the user when uniform zones had to depart from their rule for lack of
    /// frames: the zones [`ZoneTable::widened`] to hold `min_frames`, and zones that still hold
    /// fewer (a pass with fewer than `count · min_frames` frames). `None` when neither happened.
    pub fn frames_note(&self) -> Option<String> {
        let ZoneConfig::Uniform { min_frames, .. } = self.config else {
            return None;
        };
        let mut parts = Vec::new();
        if !self.widened.is_empty() {
            parts.push(format!(
                "{} zone(s) ({}) held fewer than {min_frames} training frames at equal arc length \
                 (the scope moved fast there) and were widened into their neighbours",
                self.widened.len(),
                index_ranges(&self.widened)
            ));
        }
        let short: Vec<usize> = self
            .zones
            .iter()
            .filter(|z| z.frame_count < min_frames)
            .map(|z| z.index)
            .collect();
        if !short.is_empty() {
            parts.push(format!(
                "{} zone(s) ({}) hold fewer than {min_frames} frames: {} training frames are too \
                 few for {} zones of {min_frames}; ask for at most {} zones",
                short.len(),
                index_ranges(&short),
                self.frame_count(),
                self.len(),
                self.frame_count() / min_frames.max(1)
            ));
        }
        (!parts.is_empty()).then(|| parts.join("; "))
    }

    /// Number of zones.
    pub fn len(&self) -> usize {
        self.zones.len()
    }

    /// Whether there are no zones (never true for a table built by this crate).
    pub fn is_empty(&self) -> bool {
        self.zones.is_empty()
    }

    /// Number of training frames covered.
    pub fn frame_count(&self) -> usize {
        self.zone_of_frame.len()
    }

    /// The ground-truth zone of a pose from another pass (a test frame): the zone of the
    /// training frame nearest to it, by `‖Δt‖ (mm) + angle_weight_mm_per_deg · angle (°)`.
    /// `train_poses` are the training sequence's poses (`T_wc`, mm), in frame order.
    ///
    /// The default weight ([`TRUTH_ANGLE_WEIGHT_MM_PER_DEG`]) makes 10° count as 1 mm: position
    /// decides, orientation only breaks near-ties where the colon folds back on itself.
    pub fn truth_zone(
        &self,
        train_poses: &[Pose],
        pose: &Pose,
        angle_weight_mm_per_deg: f64,
    ) -> Option<usize> {
        nearest_frame(train_poses, pose, angle_weight_mm_per_deg)
            .and_then(|i| self.zone_of_frame.get(i).copied())
    }

    /// [`ZoneTable::truth_zone`] for every pose of a sequence (parallel).
    pub fn truth_zones(&self, train_poses: &[Pose], poses: &[Pose]) -> Vec<Option<usize>> {
        use rayon::prelude::*;
        poses
            .par_iter()
            .map(|p| self.truth_zone(train_poses, p, TRUTH_ANGLE_WEIGHT_MM_PER_DEG))
            .collect()
    }

    /// Writes the table as CSV: a `# config:` comment line with the zoning config (JSON), the
    /// header `zone,first_frame,last_frame,frame_count,path_length_mm,section,tx,ty,tz,qx,qy,qz,qw`
    /// and one row per zone (median pose `T_wc`, mm, canonical quaternion `qw ≥ 0`).
    ///
    /// # Errors
    /// [`NetError::Io`] when the file cannot be written.
    pub fn save(&self, path: &Path) -> Result<(), NetError> {
        let mut out = String::new();
        let cfg =
            serde_json::to_string(&self.config).map_err(|e| NetError::Config(e.to_string()))?;
        let _ = writeln!(out, "# endoloc zone table; median poses T_wc in mm");
        let _ = writeln!(out, "# config: {cfg}");
        let _ = writeln!(out, "{ZONES_HEADER}");
        for z in &self.zones {
            let t = z.median_pose.translation.vector;
            let q = endoloc_geometry::canonical_quaternion(z.median_pose.rotation);
            let _ = writeln!(
                out,
                "{},{},{},{},{:.4},{},{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.9}",
                z.index,
                z.first_frame,
                z.last_frame,
                z.frame_count,
                z.path_length_mm,
                z.section.map_or("", |s| s.as_str()),
                t.x,
                t.y,
                t.z,
                q.i,
                q.j,
                q.k,
                q.w
            );
        }
        std::fs::write(path, out).map_err(|e| NetError::io(path, e))
    }

    /// Reads a table written by [`ZoneTable::save`].
    ///
    /// # Errors
    /// [`NetError::Io`] if the file cannot be read; [`NetError::Parse`] naming the line for a
    /// bad row, a missing config line, or zones that do not tile the frames `0..n`.
    pub fn load(path: &Path) -> Result<Self, NetError> {
        let text = std::fs::read_to_string(path).map_err(|e| NetError::io(path, e))?;
        Self::parse(path, &text)
    }

    /// Parses the text of a table written by [`ZoneTable::save`]; `path` names the file in
    /// errors.
    ///
    /// # Errors
    /// [`NetError::Parse`] naming the line for a bad row, a missing config line, or zones that
    /// do not tile the frames `0..n`.
    pub fn parse(path: &Path, text: &str) -> Result<Self, NetError> {
        let p = |line: usize, m: String| NetError::parse(PathBuf::from(path), line, m);
        let mut config = None;
        let mut header = false;
        let mut zones = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let ln = i + 1;
            let line = raw.trim();
            if line.is_empty() {
                continue;
            }
            if let Some(rest) = line.strip_prefix('#') {
                if let Some(json) = rest.trim().strip_prefix("config:") {
                    config = Some(
                        serde_json::from_str::<ZoneConfig>(json.trim()).map_err(|e| {
                            p(ln, format!("bad zoning config {:?}: {e}", json.trim()))
                        })?,
                    );
                }
                continue;
            }
            if !header {
                if line != ZONES_HEADER {
                    return Err(p(ln, format!("expected the header `{ZONES_HEADER}`")));
                }
                header = true;
                continue;
            }
            let cols: Vec<&str> = line.split(',').map(str::trim).collect();
            if cols.len() != 13 {
                return Err(p(ln, format!("expected 13 columns, found {}", cols.len())));
            }
            let int = |j: usize| {
                cols[j].parse::<usize>().map_err(|_| {
                    p(
                        ln,
                        format!("column {}: {:?} is not an integer", j + 1, cols[j]),
                    )
                })
            };
            let num = |j: usize| {
                cols[j]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        p(
                            ln,
                            format!("column {}: {:?} is not a number", j + 1, cols[j]),
                        )
                    })
            };
            let index = int(0)?;
            if index != zones.len() {
                return Err(p(
                    ln,
                    format!("zone {index}; expected zone {}", zones.len()),
                ));
            }
            let section = if cols[5].is_empty() {
                None
            } else {
                Some(
                    cols[5]
                        .parse::<Section>()
                        .map_err(|e| p(ln, e.to_string()))?,
                )
            };
            let q = Quaternion::new(num(12)?, num(9)?, num(10)?, num(11)?);
            let norm = q.norm();
            if norm.is_nan() || norm <= 0.5 {
                return Err(p(ln, "quaternion is not unit length".into()));
            }
            let (first, last) = (int(1)?, int(2)?);
            if last < first {
                return Err(p(ln, format!("last_frame {last} < first_frame {first}")));
            }
            zones.push(Zone {
                index,
                first_frame: first,
                last_frame: last,
                section,
                median_pose: pose_from_parts(
                    Vector3::new(num(6)?, num(7)?, num(8)?),
                    UnitQuaternion::from_quaternion(q),
                ),
                frame_count: last + 1 - first,
                path_length_mm: num(4)?,
            });
        }
        let config = config.ok_or_else(|| p(0, "missing the `# config:` line".into()))?;
        if zones.is_empty() {
            return Err(p(0, "no zones".into()));
        }
        let mut zone_of_frame = Vec::new();
        for z in &zones {
            if z.first_frame != zone_of_frame.len() {
                return Err(p(
                    0,
                    format!(
                        "zone {} starts at frame {}; expected {} (zones must tile the frames)",
                        z.index,
                        z.first_frame,
                        zone_of_frame.len()
                    ),
                ));
            }
            zone_of_frame.extend(std::iter::repeat_n(z.index, z.frame_count));
        }
        Ok(ZoneTable {
            config,
            zones,
            zone_of_frame,
            widened: Vec::new(),
        })
    }
}

/// Weight of orientation against position in [`ZoneTable::truth_zone`]: mm per degree.
pub const TRUTH_ANGLE_WEIGHT_MM_PER_DEG: f64 = 0.1;

/// The training frame nearest to `pose` by `‖Δt‖ (mm) + angle_weight_mm_per_deg · angle (°)`
/// (see [`ZoneTable::truth_zone`]); `None` without training poses.
pub fn nearest_frame(
    train_poses: &[Pose],
    pose: &Pose,
    angle_weight_mm_per_deg: f64,
) -> Option<usize> {
    let mut best: Option<(f64, usize)> = None;
    for (i, tp) in train_poses.iter().enumerate() {
        let d = (tp.translation.vector - pose.translation.vector).norm();
        if best.is_some_and(|(b, _)| d >= b) {
            continue;
        }
        let cost = d + angle_weight_mm_per_deg * orientation_error_deg(tp, pose);
        if best.is_none_or(|(b, _)| cost < b) {
            best = Some((cost, i));
        }
    }
    best.map(|(_, i)| i)
}

const ZONES_HEADER: &str =
    "zone,first_frame,last_frame,frame_count,path_length_mm,section,tx,ty,tz,qx,qy,qz,qw";

/// Sorted indices as ranges: `[3, 4, 5, 9]` → `"3–5, 9"`.
fn index_ranges(v: &[usize]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j + 1 < v.len() && v[j + 1] == v[j] + 1 {
            j += 1;
        }
        out.push(if j > i {
            format!("{}–{}", v[i], v[j])
        } else {
            v[i].to_string()
        });
        i = j + 1;
    }
    out.join(", ")
}

/// The most frequent label (ties: the earliest in insertion order).
fn majority(labels: &[Section]) -> Option<Section> {
    let mut counts = [0usize; Section::ALL.len()];
    for l in labels {
        counts[l.index()] += 1;
    }
    let (i, &c) = counts
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(&a.0)))?;
    (c > 0).then(|| Section::ALL[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zone_specs_round_trip_through_text_toml_and_json() {
        #[derive(Debug, PartialEq, Serialize, Deserialize)]
        struct T {
            zones: ZoneSpec,
        }
        for (text, spec) in [
            ("50", ZoneSpec::Uniform(50)),
            ("expert", ZoneSpec::Expert(None)),
            ("expert:9", ZoneSpec::Expert(Some(9))),
        ] {
            assert_eq!(text.parse::<ZoneSpec>().unwrap(), spec);
            assert_eq!(spec.to_string(), text);
            let t = T { zones: spec };
            let toml_text = toml::to_string(&t).unwrap();
            assert_eq!(toml::from_str::<T>(&toml_text).unwrap(), t);
            let json = serde_json::to_string(&t).unwrap();
            assert_eq!(serde_json::from_str::<T>(&json).unwrap(), t);
        }
        // A number for uniform zones, a string for expert ones; either is read.
        assert_eq!(
            toml::to_string(&T {
                zones: ZoneSpec::Uniform(70)
            })
            .unwrap()
            .trim(),
            "zones = 70"
        );
        assert_eq!(
            toml::to_string(&T {
                zones: ZoneSpec::Expert(Some(9))
            })
            .unwrap()
            .trim(),
            "zones = \"expert:9\""
        );
        assert_eq!(
            toml::from_str::<T>("zones = \"30\"").unwrap().zones,
            ZoneSpec::Uniform(30)
        );
        assert_eq!(
            serde_json::from_str::<T>(r#"{"zones": "Expert"}"#)
                .unwrap()
                .zones,
            ZoneSpec::Expert(None)
        );
        for bad in ["", "many", "expert:", "expert9", "expert:x", "-3"] {
            assert!(bad.parse::<ZoneSpec>().is_err(), "{bad:?}");
        }
        assert!(toml::from_str::<T>("zones = -3").is_err());
        assert_eq!(ZoneSpec::Expert(None).count(), 50);
        assert_eq!(
            ZoneSpec::Expert(Some(9)).config(UniformBy::Frames, 3),
            ZoneConfig::Expert { count: 9 }
        );
        assert_eq!(
            ZoneSpec::Uniform(20).config(UniformBy::Frames, 4),
            ZoneConfig::Uniform {
                count: 20,
                by: UniformBy::Frames,
                min_frames: 4
            }
        );
    }

    fn straight(n: usize, step: impl Fn(usize) -> f64) -> Vec<Pose> {
        let mut x = 0.0;
        (0..n)
            .map(|i| {
                if i > 0 {
                    x += step(i);
                }
                pose_from_parts(Vector3::new(x, 0.0, 0.0), UnitQuaternion::identity())
            })
            .collect()
    }

    fn check_tiling(t: &ZoneTable, n: usize) {
        assert_eq!(t.zone_of_frame.len(), n);
        let mut next = 0;
        for (k, z) in t.zones.iter().enumerate() {
            assert_eq!(z.index, k);
            assert_eq!(z.first_frame, next);
            assert!(z.frame_count >= 1);
            for f in z.frames() {
                assert_eq!(t.zone_of_frame[f], k);
            }
            next = z.last_frame + 1;
        }
        assert_eq!(next, n);
    }

    #[test]
    fn uniform_frames_are_equal_within_one() {
        let poses = straight(103, |_| 1.0);
        let cfg = ZoneConfig::uniform(10, UniformBy::Frames);
        let t = ZoneTable::from_poses(&poses, None, &cfg).unwrap();
        check_tiling(&t, 103);
        assert_eq!(t.len(), 10);
        assert!(
            t.zones
                .iter()
                .all(|z| z.frame_count == 10 || z.frame_count == 11)
        );
        // Median pose of zone 0 (frames 0..=9 at x = 0..9): x = 4.5.
        assert!((t.zones[0].median_pose.translation.x - 4.5).abs() < 1e-12);
    }

    #[test]
    fn uniform_arc_length_follows_distance_not_frames() {
        // First 50 frames move 0.1 mm each (slow), last 50 move 1.9 mm each (fast): total
        // 4.9 + 95 = 99.9 mm. Two zones of equal length split near 50 mm, i.e. in the fast part.
        let poses = straight(100, |i| if i < 50 { 0.1 } else { 1.9 });
        let cfg = ZoneConfig::uniform(2, UniformBy::ArcLength);
        let t = ZoneTable::from_poses(&poses, None, &cfg).unwrap();
        check_tiling(&t, 100);
        let split = t.zones[1].first_frame;
        assert!((72..=75).contains(&split), "split at {split}");
        let l0 = t.zones[0].path_length_mm;
        assert!((l0 - 50.0).abs() < 2.0, "{l0}");
    }

    #[test]
    fn zones_over_a_fast_stretch_are_widened_to_min_frames() {
        // 150 frames at 1 mm, then 4 frames at 12 mm (a fast stretch), then 150 at 1 mm:
        // 349 mm in 50 zones of 7 mm; over the fast stretch zones hold one frame each.
        let poses = straight(304, |i| if (150..154).contains(&i) { 12.0 } else { 1.0 });
        let plain = ZoneTable::from_poses(
            &poses,
            None,
            &ZoneConfig::Uniform {
                count: 50,
                by: UniformBy::ArcLength,
                min_frames: 1,
            },
        )
        .unwrap();
        let single = plain.zones.iter().filter(|z| z.frame_count == 1).count();
        assert!(single >= 4, "{single} one-frame zones without the minimum");
        assert!(plain.widened.is_empty() && plain.frames_note().is_none());

        let t = ZoneTable::from_poses(&poses, None, &ZoneConfig::uniform(50, UniformBy::ArcLength))
            .unwrap();
        check_tiling(&t, 304);
        assert_eq!(t.len(), 50);
        assert!(
            t.zones.iter().all(|z| z.frame_count >= 3),
            "{:?}",
            t.zones.iter().map(|z| z.frame_count).collect::<Vec<_>>()
        );
        // The widened zones are those over the fast stretch, and the note names them.
        assert!(!t.widened.is_empty());
        for &k in &t.widened {
            assert!(plain.zones[k].frame_count < 3, "zone {k} was not short");
        }
        let note = t.frames_note().unwrap();
        assert!(
            note.contains("fewer than 3 training frames") && note.contains("moved fast"),
            "{note}"
        );
        // Zones away from the fast stretch keep their equal-arc-length bounds.
        assert_eq!(t.zones[..15], plain.zones[..15]);
        assert_eq!(t.zones[35..], plain.zones[35..]);
    }

    #[test]
    fn too_few_frames_for_min_frames_zones_is_reported() {
        let poses = straight(40, |_| 1.0);
        let t = ZoneTable::from_poses(&poses, None, &ZoneConfig::uniform(20, UniformBy::ArcLength))
            .unwrap();
        check_tiling(&t, 40);
        assert!(t.zones.iter().all(|z| z.frame_count == 2));
        let note = t.frames_note().unwrap();
        assert!(
            note.contains("40 training frames are too few for 20 zones of 3"),
            "{note}"
        );
        assert!(note.contains("ask for at most 13 zones"), "{note}");
    }

    #[test]
    fn a_zone_config_without_min_frames_reads_with_the_default() {
        let c: ZoneConfig =
            serde_json::from_str(r#"{"kind":"uniform","count":50,"by":"arc_length"}"#).unwrap();
        assert_eq!(c, ZoneConfig::uniform(50, UniformBy::ArcLength));
        assert_eq!(
            ZoneConfig::default(),
            ZoneConfig::Uniform {
                count: 50,
                by: UniformBy::ArcLength,
                min_frames: 3
            }
        );
    }

    #[test]
    fn as_many_zones_as_frames_and_more_is_a_clear_error() {
        let poses = straight(7, |_| 1.0);
        for by in [UniformBy::Frames, UniformBy::ArcLength] {
            let t = ZoneTable::from_poses(&poses, None, &ZoneConfig::uniform(7, by)).unwrap();
            check_tiling(&t, 7);
            assert!(t.zones.iter().all(|z| z.frame_count == 1));
            let err = ZoneTable::from_poses(&poses, None, &ZoneConfig::uniform(8, by))
                .unwrap_err()
                .to_string();
            assert!(err.contains("8 zones") && err.contains("has 7"), "{err}");
        }
        let err = ZoneTable::from_poses(&poses, None, &ZoneConfig::uniform(0, UniformBy::Frames))
            .unwrap_err();
        assert!(err.to_string().contains("at least 1"));
    }

    #[test]
    fn arc_length_keeps_every_zone_non_empty_with_a_jump_and_a_still_camera() {
        // One huge jump between frames 4 and 5: several equal-length zones would be empty.
        let poses = straight(10, |i| if i == 5 { 1000.0 } else { 1.0 });
        let t = ZoneTable::from_poses(&poses, None, &ZoneConfig::uniform(6, UniformBy::ArcLength))
            .unwrap();
        check_tiling(&t, 10);
        // A camera that never moves: equal frame counts.
        let still = straight(12, |_| 0.0);
        let t = ZoneTable::from_poses(&still, None, &ZoneConfig::uniform(4, UniformBy::ArcLength))
            .unwrap();
        assert!(t.zones.iter().all(|z| z.frame_count == 3));
    }

    fn labels(spec: &[(Section, usize)]) -> Vec<Section> {
        spec.iter()
            .flat_map(|&(s, n)| std::iter::repeat_n(s, n))
            .collect()
    }

    #[test]
    fn expert_splits_long_sections_and_keeps_short_ones_whole() {
        use Section::*;
        // Rectum 10 frames (shorter than an average zone of 20), sigmoid 60, descending 30.
        let l = labels(&[(Rectum, 10), (Sigmoid, 60), (Descending, 30)]);
        let poses = straight(l.len(), |_| 1.0);
        let t = ZoneTable::from_poses(&poses, Some(&l), &ZoneConfig::Expert { count: 5 }).unwrap();
        check_tiling(&t, 100);
        let secs: Vec<Section> = t.zones.iter().map(|z| z.section.unwrap()).collect();
        assert_eq!(secs, vec![Rectum, Sigmoid, Sigmoid, Sigmoid, Descending]);
        assert_eq!(t.zones[0].frame_count, 10);
        assert_eq!(t.zones[1].frame_count, 20);
        // Every zone holds frames of its own section only.
        for z in &t.zones {
            assert!(z.frames().all(|f| l[f] == z.section.unwrap()));
        }
    }

    #[test]
    fn expert_merges_label_flicker_and_refuses_too_few_zones() {
        use Section::*;
        let mut l = labels(&[(Rectum, 20), (Sigmoid, 20)]);
        l[21] = Rectum; // a 1-frame flicker back into the rectum
        let poses = straight(l.len(), |_| 1.0);
        let t = ZoneTable::from_poses(&poses, Some(&l), &ZoneConfig::Expert { count: 2 }).unwrap();
        assert_eq!(t.len(), 2);
        let err = ZoneTable::from_poses(&poses, Some(&l), &ZoneConfig::Expert { count: 1 })
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("at least one zone per section") && err.contains("rectum"),
            "{err}"
        );
        // Expert zones without labels.
        let err = ZoneTable::from_poses(&poses, None, &ZoneConfig::Expert { count: 2 })
            .unwrap_err()
            .to_string();
        assert!(err.contains("sections.csv"), "{err}");
    }

    #[test]
    fn expert_zones_on_a_sequence_without_sections_csv_name_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let seq = Sequence {
            name: "train".into(),
            dir: dir.path().join("train"),
            poses: straight(10, |_| 1.0)
                .into_iter()
                .enumerate()
                .map(|(i, pose)| endoloc_data::StampedPose {
                    timestamp_s: i as f64 / 30.0,
                    pose,
                })
                .collect(),
            frame_times: None,
            image_paths: vec![],
            sections: None,
            depth_paths: None,
            image_size: None,
            mask: None,
        };
        let err = ZoneTable::from_sequence(&seq, &ZoneConfig::Expert { count: 3 })
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("train") && err.contains("no sections.csv"),
            "{err}"
        );
    }

    #[test]
    fn save_load_round_trip_and_truth_zone() {
        use Section::*;
        let l = labels(&[(Rectum, 8), (Sigmoid, 30)]);
        let poses = straight(l.len(), |_| 2.0);
        let t = ZoneTable::from_poses(&poses, Some(&l), &ZoneConfig::Expert { count: 4 }).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(ZONES_FILE);
        t.save(&path).unwrap();
        let back = ZoneTable::load(&path).unwrap();
        assert_eq!(back.config, t.config);
        assert_eq!(back.zone_of_frame, t.zone_of_frame);
        for (a, b) in back.zones.iter().zip(&t.zones) {
            assert_eq!(a.section, b.section);
            assert!(
                (a.median_pose.translation.vector - b.median_pose.translation.vector).norm() < 1e-5
            );
        }
        // A pose 0.3 mm beside frame 20 belongs to frame 20's zone.
        let q = pose_from_parts(Vector3::new(40.0, 0.3, 0.0), UnitQuaternion::identity());
        assert_eq!(t.truth_zone(&poses, &q, 0.1), Some(t.zone_of_frame[20]));
        // A corrupted row names its line.
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace(",sigmoid,", ",colon,");
        std::fs::write(&path, text).unwrap();
        let err = ZoneTable::load(&path).unwrap_err().to_string();
        assert!(
            err.contains("zones.csv:5") && err.contains("colon"),
            "{err}"
        );
    }
}
