//! `experiment changes`: how far endoloc's figures carry into a colon that changed between
//! the passes. Every factor of the simulator's change model (docs/SIMULATOR.md) alone at each
//! severity, and the presets with every factor at once (or chosen factors together:
//! [`Factors`]), over several colons, each localized live and per frame against the colon as
//! mapped.
//!
//! Per colon (`colons/<name>/`): the unchanged dataset (`none/data`), its index and map
//! (`model/`), then one dataset per condition (`<factor>-<severity>/data`: the training pass is
//! byte-identical in all of them, so the one model and map serve every condition), localized
//! by `endoloc-live-confirm` and `endoloc-confirm` (the `localize` defaults, live and per
//! frame) through the compare experiment, evaluated against the anatomical truth. A condition's
//! figures go to `colons/<name>/rows/<condition>.json` as soon as it is done (a second run
//! continues), and its dataset is deleted then unless `keep_data`.
//!
//! The merge writes `changes.md` (a table of the mean over the colons ± the half-width of the
//! 95 % interval per condition, and for each factor the first severity where endoloc stops
//! holding, with the reason), `changes.json` and `changes.png` (each factor's live refined
//! fraction, median error and wrong `refined` share against severity).

use std::path::{Path, PathBuf};

use endoloc_eval::{BarRow, PlotConfig, Series, SeriesPanel, plot_row_bars, plot_series};
use endoloc_jobs::bail;
use endoloc_jobs::error::{Context, Result};
use endoloc_jobs::note;
use endoloc_jobs::progress::Progress;
use endoloc_jobs::{SimulateJob, TrainJob};
use endoloc_net::ZoneSpec;
use endoloc_sim::change::ChangeConfig;
use endoloc_sim::{Preset, Severity};
use serde::{Deserialize, Serialize};

use super::benchmark::{
    BenchmarkJob, Colon, Interval, Seeds, colon_options, interval, job_lines, parse_seeds,
    select_colons,
};
use super::common::{self, DataArgs, MethodRow, shell_quote};
use super::compare::{CompareJob, Method};

/// One factor of the change model (docs/SIMULATOR.md's table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Factor {
    /// Mobile segments shifted (`shape.shift_mm`).
    Shift,
    /// Lumen radius changed (`shape.insufflation`).
    Insufflation,
    /// Local deformation of the wall (`shape.deform_mm`).
    Deform,
    /// Exposure gain drifting over the pass (`look.gain`).
    Exposure,
    /// Gamma and white balance (`look.gamma`, `look.white_balance`).
    Colour,
    /// Light power and beam (`look.light_power`, `look.beam_exponent`).
    Light,
    /// Specular highlights and wet sheen (`look.specular`, `look.sheen`).
    Specular,
    /// Texture contrast (`look.texture_contrast`).
    Texture,
    /// Residue and fluid on the wall (`look.residue_fraction`, `look.fluid_fraction`).
    Residue,
    /// Bubbles on the lens (`look.bubble_frames`, `look.bubble_cover`).
    Bubbles,
    /// Motion blur and defocus of the test scope (`scope.motion_blur_samples`,
    /// `scope.motion_blur_mm`, `scope.defocus_px`).
    Blur,
    /// The test scope's wider field of view (`scope.hfov_change_deg`; its camera known).
    Fov,
}

impl Factor {
    /// Every factor: shape, then look, then scope.
    pub const EACH: [Factor; 12] = [
        Factor::Shift,
        Factor::Insufflation,
        Factor::Deform,
        Factor::Exposure,
        Factor::Colour,
        Factor::Light,
        Factor::Specular,
        Factor::Texture,
        Factor::Residue,
        Factor::Bubbles,
        Factor::Blur,
        Factor::Fov,
    ];

    /// The name on the command line and in folder names.
    pub fn name(self) -> &'static str {
        match self {
            Factor::Shift => "shift",
            Factor::Insufflation => "insufflation",
            Factor::Deform => "deform",
            Factor::Exposure => "exposure",
            Factor::Colour => "colour",
            Factor::Light => "light",
            Factor::Specular => "specular",
            Factor::Texture => "texture",
            Factor::Residue => "residue",
            Factor::Bubbles => "bubbles",
            Factor::Blur => "blur",
            Factor::Fov => "fov",
        }
    }

    /// What it changes, for tables.
    pub fn description(self) -> &'static str {
        match self {
            Factor::Shift => "mobile segments shifted",
            Factor::Insufflation => "lumen radius (insufflation)",
            Factor::Deform => "local deformation",
            Factor::Exposure => "exposure gain",
            Factor::Colour => "gamma, white balance",
            Factor::Light => "light power, beam",
            Factor::Specular => "specular, wet sheen",
            Factor::Texture => "texture contrast",
            Factor::Residue => "residue, fluid",
            Factor::Bubbles => "bubbles on the lens",
            Factor::Blur => "motion blur, defocus",
            Factor::Fov => "wider field of view",
        }
    }

    /// Copies this factor's settings from `preset` into `c`.
    fn apply(self, c: &mut ChangeConfig, p: &ChangeConfig) {
        match self {
            Factor::Shift => c.shape.shift_mm = p.shape.shift_mm,
            Factor::Insufflation => c.shape.insufflation = p.shape.insufflation,
            Factor::Deform => c.shape.deform_mm = p.shape.deform_mm,
            Factor::Exposure => c.look.gain = p.look.gain,
            Factor::Colour => {
                c.look.gamma = p.look.gamma;
                c.look.white_balance = p.look.white_balance;
            }
            Factor::Light => {
                c.look.light_power = p.look.light_power;
                c.look.beam_exponent = p.look.beam_exponent;
            }
            Factor::Specular => {
                c.look.specular = p.look.specular;
                c.look.sheen = p.look.sheen;
            }
            Factor::Texture => c.look.texture_contrast = p.look.texture_contrast,
            Factor::Residue => {
                c.look.residue_fraction = p.look.residue_fraction;
                c.look.fluid_fraction = p.look.fluid_fraction;
            }
            Factor::Bubbles => {
                c.look.bubble_frames = p.look.bubble_frames;
                c.look.bubble_cover = p.look.bubble_cover;
            }
            Factor::Blur => {
                c.scope.motion_blur_samples = p.scope.motion_blur_samples;
                c.scope.motion_blur_mm = p.scope.motion_blur_mm;
                c.scope.defocus_px = p.scope.defocus_px;
            }
            Factor::Fov => c.scope.hfov_change_deg = p.scope.hfov_change_deg,
        }
    }

    fn bit(self) -> u16 {
        1 << Factor::EACH.iter().position(|f| *f == self).unwrap_or(0)
    }
}

impl std::fmt::Display for Factor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The groups a set of factors can name at once: name, description, members (consecutive in
/// [`Factor::EACH`]).
const GROUPS: [(&str, &str, &[Factor]); 3] = [
    ("shape", "the colon's shape", Factor::EACH.split_at(3).0),
    (
        "look",
        "the colon's look",
        Factor::EACH.split_at(3).1.split_at(7).0,
    ),
    ("scope", "the test scope", Factor::EACH.split_at(10).1),
];

/// Factors changed together in one condition: one factor (`shift`), a combination
/// (`shift+texture`), a group (`shape`, `look`, `scope`, and combinations of them and of single
/// factors: `shape+blur`), or `all` (every factor: the severity preset). Written and read as
/// that name; a group is named whenever all its factors are in the set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Factors(u16);

impl Factors {
    /// Every factor at once: the severity preset.
    pub const ALL: Factors = Factors((1 << Factor::EACH.len()) - 1);

    /// One factor alone.
    pub fn one(f: Factor) -> Factors {
        Factors(f.bit())
    }

    /// Whether `f` is one of them.
    pub fn contains(self, f: Factor) -> bool {
        self.0 & f.bit() != 0
    }

    /// The factors, in [`Factor::EACH`]'s order.
    pub fn iter(self) -> impl Iterator<Item = Factor> {
        Factor::EACH.into_iter().filter(move |f| self.contains(*f))
    }

    /// The default conditions of the study: each factor alone, then all at once.
    pub fn each_and_all() -> Vec<Factors> {
        let mut v: Vec<Factors> = Factor::EACH.into_iter().map(Factors::one).collect();
        v.push(Factors::ALL);
        v
    }

    /// Its parts, groups whole where they are: (name, description).
    fn parts(self) -> Vec<(&'static str, &'static str)> {
        if self == Factors::ALL {
            return vec![("all", "every change at once")];
        }
        let mut parts = Vec::new();
        for (name, description, members) in GROUPS {
            if members.len() > 1 && members.iter().all(|f| self.contains(*f)) {
                parts.push((name, description));
            } else {
                parts.extend(
                    members
                        .iter()
                        .filter(|f| self.contains(**f))
                        .map(|f| (f.name(), f.description())),
                );
            }
        }
        parts
    }

    /// The name on the command line and in folder names: `shift`, `shape+texture`, `all`.
    pub fn name(self) -> String {
        let names: Vec<&str> = self.parts().iter().map(|p| p.0).collect();
        names.join("+")
    }

    /// What it changes, for tables.
    pub fn description(self) -> String {
        let d: Vec<&str> = self.parts().iter().map(|p| p.1).collect();
        d.join(" + ")
    }

    /// The change of these factors at `severity`: their settings from the severity preset
    /// (docs/SIMULATOR.md's table), every other as in `none`; all of them: the whole preset.
    pub fn change(self, severity: Severity) -> ChangeConfig {
        let p = ChangeConfig::preset(severity);
        if self == Factors::ALL {
            return p;
        }
        let mut c = ChangeConfig {
            severity,
            ..ChangeConfig::default()
        };
        for f in self.iter() {
            f.apply(&mut c, &p);
        }
        c
    }
}

impl From<Factor> for Factors {
    fn from(f: Factor) -> Factors {
        Factors::one(f)
    }
}

impl std::fmt::Display for Factors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl std::str::FromStr for Factors {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let mut bits = 0;
        for part in s.split('+').map(str::trim) {
            bits |= if part == "all" {
                Factors::ALL.0
            } else if let Some((_, _, members)) = GROUPS.iter().find(|g| g.0 == part) {
                members.iter().fold(0, |b, f| b | f.bit())
            } else if let Some(f) = Factor::EACH.iter().find(|f| f.name() == part) {
                f.bit()
            } else {
                let names: Vec<&str> = Factor::EACH.iter().map(|f| f.name()).collect();
                return Err(format!(
                    "unknown factor {part:?}; expected one of {}, a group (shape, look, scope), \
                     all, or several joined by `+`",
                    names.join(", ")
                ));
            };
        }
        Ok(Factors(bits))
    }
}

impl TryFrom<String> for Factors {
    type Error = String;
    fn try_from(s: String) -> std::result::Result<Self, String> {
        s.parse()
    }
}

impl From<Factors> for String {
    fn from(f: Factors) -> String {
        f.name()
    }
}

/// Severities on the command line: a comma-separated list of `mild`, `moderate`, `severe`.
fn parse_severity(s: &str) -> std::result::Result<Severity, String> {
    Severity::ALL
        .into_iter()
        .find(|v| v.name() == s && *v != Severity::None)
        .ok_or_else(|| format!("unknown severity {s:?}; expected mild, moderate or severe"))
}

/// Every factor alone at each severity, and the presets, over several colons.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ChangesJob {
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long, default_value_os_t = ChangesJob::default().out))]
    pub out: PathBuf,
    /// Simulator preset of every colon (see the simulate job's `preset`).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ChangesJob::default().preset))]
    pub preset: Preset,
    /// Procedural colons: simulator seeds, e.g. 1-5, 1,3,5 or none.
    #[cfg_attr(feature = "cli", arg(long, default_value = "1-5", value_parser = parse_seeds))]
    pub seeds: Seeds,
    /// A CT colon: GCA model folder (repeatable; see the simulate job's `gca`).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub gca: Vec<PathBuf>,
    /// Lumen inflation of the CT colons (see the simulate job's `inflation`).
    #[cfg_attr(feature = "cli", arg(long))]
    pub inflation: Option<f64>,
    /// Conditions, each a factor alone or factors together (default: every factor alone, and
    /// `all`, every factor at once): shift, insufflation, deform, exposure, colour, light,
    /// specular, texture, residue, bubbles, blur, fov; the groups shape, look, scope; all;
    /// several joined by `+` change together (`shape+texture`).
    #[cfg_attr(feature = "cli", arg(long, value_delimiter = ','))]
    pub factors: Vec<Factors>,
    /// Severities of each factor (default: mild, moderate, severe).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_delimiter = ',', value_parser = parse_severity)
    )]
    pub severities: Vec<Severity>,
    /// Frames of each training pass (default: the preset's).
    #[cfg_attr(feature = "cli", arg(long))]
    pub train_frames: Option<usize>,
    /// Frames of each test pass (default: the preset's).
    #[cfg_attr(feature = "cli", arg(long))]
    pub test_frames: Option<usize>,
    /// Zones (a count, or `expert`).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ChangesJob::default().zones))]
    pub zones: ZoneSpec,
    /// Start weights of the zone network: `builtin-joint` (the shipped network, indexed
    /// without training), a weights file, or `none` to train from scratch on each colon.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ChangesJob::default().pretrained))]
    pub pretrained: String,
    /// Seed of every training.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ChangesJob::default().seed))]
    pub seed: u64,
    /// σ of each map's smoothed level, pixels (the map job's `smoothed_level_px`; default: 1.5
    /// per 320 pixels of image width; 0: none).
    #[cfg_attr(feature = "cli", arg(long = "smoothed-level", value_name = "SIGMA_PX"))]
    pub smoothed_level_px: Option<f64>,
    /// Zoom-blurred views of every training frame in each zone index (the train job's
    /// `index_zoom_blur`, e.g. 0.03,0.06,0.12; default: none). A colon's model made earlier is
    /// used only when it has them.
    #[cfg_attr(feature = "cli", arg(long, value_name = "A,..|none"))]
    pub index_zoom_blur: Option<String>,
    /// With `index_zoom_blur`: the train job's `index_view_penalty` (default 0).
    #[cfg_attr(feature = "cli", arg(long, value_name = "D"))]
    pub index_view_penalty: Option<f64>,
    /// Keep each condition's dataset (by default it is deleted once its figures are written:
    /// a condition of the `small` preset takes about 50 MB).
    #[cfg_attr(feature = "cli", arg(long))]
    pub keep_data: bool,
    /// How far the colon wall may have moved since the mapping pass, mm (the localize job's
    /// `wall_motion_mm`; 0: a rigid colon). A folder's
    /// conditions already finished were localized with its `changes.toml`'s value: another
    /// value needs another folder.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ChangesJob::default().wall_motion_mm))]
    pub wall_motion_mm: f64,
    /// Run only this colon (`seed-N` or `ct-<folder>`, as printed with `print_jobs`); the
    /// tables are not written.
    #[cfg_attr(feature = "cli", arg(long))]
    pub colon: Option<String>,
    /// Print one command per colon and the merge command, and stop.
    #[cfg_attr(feature = "cli", arg(long))]
    pub print_jobs: bool,
    /// Run nothing: write the tables from the conditions already finished.
    #[cfg_attr(feature = "cli", arg(long, conflicts_with = "colon"))]
    pub merge: bool,
    /// Use an output folder that holds something else.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for ChangesJob {
    fn default() -> Self {
        ChangesJob {
            out: "experiments/changes".into(),
            preset: Preset::Small,
            seeds: (1..=5).collect(),
            gca: Vec::new(),
            inflation: None,
            factors: Vec::new(),
            severities: Vec::new(),
            train_frames: None,
            test_frames: None,
            zones: ZoneSpec::default(),
            pretrained: "builtin-joint".into(),
            seed: 0,
            smoothed_level_px: None,
            index_zoom_blur: None,
            index_view_penalty: None,
            keep_data: false,
            wall_motion_mm: 0.0,
            colon: None,
            print_jobs: false,
            merge: false,
            force: false,
        }
    }
}

/// One condition: the test pass unchanged (`factor` `None`), or some factors (or all) at one
/// severity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Condition {
    /// The factors changed; `None`: nothing.
    pub factor: Option<Factors>,
    /// Its severity (`None` for the unchanged pass).
    pub severity: Severity,
}

impl Condition {
    /// The unchanged pass.
    pub const NONE: Condition = Condition {
        factor: None,
        severity: Severity::None,
    };

    /// Folder and file name: `none`, or `<factor>-<severity>`.
    pub fn name(&self) -> String {
        match self.factor {
            None => "none".into(),
            Some(f) => format!("{f}-{}", self.severity.name()),
        }
    }

    /// The change of the test pass.
    pub fn change(&self) -> ChangeConfig {
        self.factor
            .map_or_else(ChangeConfig::default, |f| f.change(self.severity))
    }
}

/// The figures of one condition on one colon.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConditionRow {
    /// The colon.
    pub colon: String,
    /// The condition's name (`none`, `<factor>-<severity>`).
    pub condition: String,
    /// `endoloc-live-confirm` (live) and `endoloc-confirm` (per frame).
    pub methods: Vec<MethodRow>,
}

/// One condition's figures over the colons: mean ± interval of each.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConditionSummary {
    /// The condition's name.
    pub condition: String,
    /// The factors (`None`: unchanged).
    pub factor: Option<Factors>,
    /// Its severity.
    pub severity: Severity,
    /// Colons with this condition finished.
    pub colons: usize,
    /// Their names.
    pub colon_names: Vec<String>,
    /// Live: refined frames, % of all.
    pub live_refined_pct: Option<Interval>,
    /// Live: median position error of the refined frames, mm.
    pub live_refined_median_mm: Option<Interval>,
    /// Live: refined frames more than 5 mm off, % of the refined ones.
    pub live_wrong_pct: Option<Interval>,
    /// Live: median error along the colon of every localized frame, mm of mid-line.
    pub live_along_median_mm: Option<Interval>,
    /// Live: frames whose zone is within one of the true zone, %.
    pub live_zone_within_one_pct: Option<Interval>,
    /// Per frame: refined frames, %.
    pub frame_refined_pct: Option<Interval>,
    /// Per frame: median position error of the refined frames, mm.
    pub frame_refined_median_mm: Option<Interval>,
    /// Per frame: refined frames more than 5 mm off, % of the refined ones.
    pub frame_wrong_pct: Option<Interval>,
    /// Live: refined frames within their stated 95 % bound (1.96 × `position_std_mm`), % of
    /// the refined ones.
    #[serde(default)]
    pub live_within_bound_pct: Option<Interval>,
    /// Per frame: refined frames within their stated 95 % bound, % of the refined ones.
    #[serde(default)]
    pub frame_within_bound_pct: Option<Interval>,
}

/// What [`ChangesJob::run`] did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChangesReport {
    /// One summary per condition (empty for one colon or printed jobs).
    pub summary: Vec<ConditionSummary>,
    /// Colon and condition pairs not finished.
    pub missing: Vec<String>,
    /// `changes.md`'s table.
    pub table: String,
    /// Output folder.
    pub out: PathBuf,
    /// Printed commands (`print_jobs`).
    pub jobs: Vec<String>,
}

impl std::fmt::Display for ChangesReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if !self.jobs.is_empty() {
            return write!(f, "{}", self.jobs.join("\n"));
        }
        if !self.table.is_empty() {
            writeln!(f, "\n{}", self.table.trim_end())?;
        }
        if !self.missing.is_empty() {
            writeln!(f, "not finished: {}", self.missing.join(", "))?;
        }
        if self.summary.is_empty() {
            return write!(f, "done      {}", self.out.display());
        }
        write!(
            f,
            "wrote     {}/changes.md, changes.json, changes.png",
            self.out.display()
        )
    }
}

/// The methods run on every condition: live, then per frame.
const LIVE: Method = Method::EndolocLiveConfirm;
const PER_FRAME: Method = Method::EndolocConfirm;

/// When a condition no longer holds: live refined below this, %.
const HOLDS_REFINED_PCT: f64 = 90.0;
/// … or more than this share of the refined frames more than 5 mm off, %.
const HOLDS_WRONG_PCT: f64 = 1.0;
/// … or a median error of the refined frames above this, mm.
const HOLDS_MEDIAN_MM: f64 = 1.0;

impl ChangesJob {
    /// The zone indexes' views this experiment asks for.
    fn index_views(&self) -> common::IndexViews<'_> {
        common::IndexViews {
            zoom_blur: self.index_zoom_blur.as_deref(),
            penalty: self.index_view_penalty,
        }
    }

    fn factors(&self) -> Vec<Factors> {
        if self.factors.is_empty() {
            Factors::each_and_all()
        } else {
            self.factors.clone()
        }
    }

    fn severities(&self) -> Vec<Severity> {
        let mut s = if self.severities.is_empty() {
            vec![Severity::Mild, Severity::Moderate, Severity::Severe]
        } else {
            self.severities.clone()
        };
        s.sort_by_key(|v| Severity::ALL.iter().position(|a| a == v));
        s.dedup();
        s
    }

    /// Every condition, the unchanged pass first, then each factor at each severity.
    pub fn conditions(&self) -> Vec<Condition> {
        let mut v = vec![Condition::NONE];
        for f in self.factors() {
            for s in self.severities() {
                v.push(Condition {
                    factor: Some(f),
                    severity: s,
                });
            }
        }
        v
    }

    /// The colons, as the benchmark names them.
    fn colons(&self) -> Vec<Colon> {
        BenchmarkJob {
            seeds: self.seeds.clone(),
            gca: self.gca.clone(),
            ..BenchmarkJob::default()
        }
        .colons()
    }

    /// The command line that runs one colon (or, with `None`, merges the finished ones).
    pub fn command(&self, colon: Option<&str>) -> String {
        let q = |p: &Path| shell_quote(&p.display().to_string());
        let mut c = format!(
            "endoloc experiment changes --out {} --preset {} --zones {} --seed {}",
            q(&self.out),
            self.preset,
            self.zones,
            self.seed
        );
        c.push_str(&colon_options(
            &self.seeds,
            &self.gca,
            self.inflation,
            self.train_frames,
            self.test_frames,
        ));
        if !self.factors.is_empty() {
            let f: Vec<String> = self.factors.iter().map(|f| f.name()).collect();
            c.push_str(&format!(" --factors {}", f.join(",")));
        }
        if !self.severities.is_empty() {
            let s: Vec<&str> = self.severities().iter().map(|s| s.name()).collect();
            c.push_str(&format!(" --severities {}", s.join(",")));
        }
        c.push_str(&format!(" --pretrained {}", shell_quote(&self.pretrained)));
        if let Some(s) = self.smoothed_level_px {
            c.push_str(&format!(" --smoothed-level {s}"));
        }
        c.push_str(&self.index_views().options());
        if self.keep_data {
            c.push_str(" --keep-data");
        }
        if self.wall_motion_mm != 0.0 {
            c.push_str(&format!(" --wall-motion-mm {}", self.wall_motion_mm));
        }
        match colon {
            Some(name) => c.push_str(&format!(" --colon {}", shell_quote(name))),
            None => c.push_str(" --merge"),
        }
        c
    }

    /// Refuses a `wall_motion_mm` other than the one the folder's finished conditions were
    /// localized with (its `changes.toml`): their rows are reused as they are.
    fn check_wall_motion(&self) -> Result<()> {
        let file = self.out.join("changes.toml");
        let Ok(text) = std::fs::read_to_string(&file) else {
            return Ok(());
        };
        let before: ChangesJob = toml::from_str(&text)
            .with_context(|| format!("reading the study's settings in {}", file.display()))?;
        if before.wall_motion_mm != self.wall_motion_mm {
            bail!(
                "{} was localized with --wall-motion-mm {}, not {}: its finished conditions \
                 would be reused as they are; choose another --out",
                self.out.display(),
                before.wall_motion_mm,
                self.wall_motion_mm
            );
        }
        Ok(())
    }

    /// Runs the study (or one colon of it, or only the merge).
    ///
    /// # Errors
    /// A failed stage, an unknown `colon`, or an output folder that holds something else.
    pub fn run(&self, progress: &dyn Progress) -> Result<ChangesReport> {
        let colons = self.colons();
        if colons.is_empty() {
            bail!("no colons: give `seeds` and/or `gca`");
        }
        endoloc_jobs::map::check_smoothed_level(self.smoothed_level_px)?;
        self.index_views().parsed()?;
        if self.print_jobs {
            return Ok(ChangesReport {
                summary: Vec::new(),
                missing: Vec::new(),
                table: String::new(),
                out: self.out.clone(),
                jobs: job_lines(&colons, &|c| self.command(c)),
            });
        }
        let selected = select_colons(&colons, self.colon.as_deref(), self.merge, "study")?;
        // A colon's model made earlier (and its conditions' figures) is used as it is.
        self.index_views().check_models(
            selected
                .iter()
                .map(|c| self.out.join("colons").join(&c.name).join("model")),
        )?;
        common::prepare_out(&self.out, "changes.toml", self.force)?;
        self.check_wall_motion()?;
        common::create_out(&self.out, "changes.toml")?;
        let saved = ChangesJob {
            colon: None,
            print_jobs: false,
            merge: false,
            force: false,
            ..self.clone()
        };
        common::write_text(
            &self.out.join("changes.toml"),
            &toml::to_string_pretty(&saved).context("serializing the configuration")?,
        )?;
        for (k, c) in selected.iter().enumerate() {
            note!(
                progress,
                "\n=== colon {} ({} of {})",
                c.name,
                k + 1,
                selected.len()
            );
            self.run_colon(c, progress)?;
        }
        let (rows, missing) = self.finished(&colons)?;
        if self.colon.is_some() {
            return Ok(ChangesReport {
                summary: Vec::new(),
                missing,
                table: String::new(),
                out: self.out.clone(),
                jobs: Vec::new(),
            });
        }
        if rows.is_empty() {
            bail!(
                "no condition of {} is finished; run the colons first (see `print_jobs`)",
                self.out.display()
            );
        }
        let summary: Vec<ConditionSummary> = self
            .conditions()
            .iter()
            .map(|c| summarise(c, &rows))
            .filter(|s| s.colons > 0)
            .collect();
        let table = self.write_outputs(&summary, &rows, &missing)?;
        Ok(ChangesReport {
            summary,
            missing,
            table,
            out: self.out.clone(),
            jobs: Vec::new(),
        })
    }

    fn run_colon(&self, c: &Colon, progress: &dyn Progress) -> Result<()> {
        let dir = self.out.join("colons").join(&c.name);
        let base = SimulateJob {
            preset: self.preset,
            seed: Some(c.seed),
            gca: c.gca.clone(),
            inflation: c.gca.as_ref().and(self.inflation),
            train_frames: self.train_frames,
            test_frames: self.test_frames,
            // Nothing here reads depth maps.
            depth: Some(false),
            ..SimulateJob::default()
        };
        let model = dir.join("model");
        for (k, cond) in self.conditions().iter().enumerate() {
            let row_file = row_path(&self.out, &c.name, &cond.name());
            if row_file.is_file() {
                note!(progress, "reusing   {} {} (done)", c.name, cond.name());
                continue;
            }
            note!(
                progress,
                "\n== {} {} ({} of {})",
                c.name,
                cond.name(),
                k + 1,
                self.conditions().len()
            );
            let cond_dir = dir.join(cond.name());
            let data = cond_dir.join("data");
            if !data.join("dataset.toml").is_file() {
                let mut cfg = base.sim_config()?;
                cfg.changes = ChangeConfig {
                    seed: cfg.changes.seed,
                    ..cond.change()
                };
                std::fs::create_dir_all(&cond_dir)
                    .with_context(|| format!("creating {}", cond_dir.display()))?;
                let file = cond_dir.join("simulate.toml");
                common::write_text(&file, &cfg.to_toml()?)?;
                let report = SimulateJob {
                    config: Some(file),
                    out: data.clone(),
                    force: data.exists(),
                    ..SimulateJob::default()
                }
                .run(progress)?;
                note!(progress, "{report}");
            }
            if !model.join("model.toml").is_file() {
                let pretrained = {
                    let p = self.pretrained.trim();
                    (!p.is_empty() && p != "none").then(|| PathBuf::from(p))
                };
                note!(progress, "zone network for {}", c.name);
                let report = self
                    .index_views()
                    .apply(TrainJob {
                        data: data.clone(),
                        zones: self.zones,
                        out: model.clone(),
                        force: model.exists(),
                        epochs: pretrained.as_ref().map(|_| 0),
                        pretrained,
                        seed: self.seed,
                        ..Default::default()
                    })
                    .run(progress)?;
                note!(progress, "{report}");
            }
            let report = CompareJob {
                data: DataArgs {
                    data: data.clone(),
                    ..Default::default()
                },
                out: cond_dir.join("compare"),
                zones: self.zones,
                seed: self.seed,
                model: Some(model.clone()),
                methods: vec![LIVE, PER_FRAME],
                smoothed_level_px: self.smoothed_level_px,
                wall_motion_mm: self.wall_motion_mm,
                force: true,
                ..Default::default()
            }
            .run(progress)?;
            let row = ConditionRow {
                colon: c.name.clone(),
                condition: cond.name(),
                methods: report.rows,
            };
            common::write_text(&row_file, &serde_json::to_string_pretty(&row)?)?;
            if !self.keep_data && cond.factor.is_some() {
                std::fs::remove_dir_all(&data)
                    .with_context(|| format!("removing {}", data.display()))?;
            }
        }
        Ok(())
    }

    /// The rows of the finished conditions, and the colon/condition pairs missing.
    fn finished(&self, colons: &[Colon]) -> Result<(Vec<ConditionRow>, Vec<String>)> {
        let mut rows = Vec::new();
        let mut missing = Vec::new();
        for c in colons {
            for cond in self.conditions() {
                let p = row_path(&self.out, &c.name, &cond.name());
                match std::fs::read_to_string(&p) {
                    Ok(text) => rows.push(
                        serde_json::from_str::<ConditionRow>(&text)
                            .with_context(|| format!("reading {}", p.display()))?,
                    ),
                    Err(_) => missing.push(format!("{}/{}", c.name, cond.name())),
                }
            }
        }
        Ok((rows, missing))
    }

    fn write_outputs(
        &self,
        summary: &[ConditionSummary],
        rows: &[ConditionRow],
        missing: &[String],
    ) -> Result<String> {
        let table = summary_table(summary);
        let mut md = String::from("# A colon that changes between the passes\n\n");
        md.push_str(&format!(
            "{} colons (`{}` preset{}), {} zones, zone network {}. The test pass of each colon \
             changed by one factor at a time (docs/SIMULATOR.md), localized against the \
             unchanged map; errors against the anatomical truth. Mean over the colons ± the \
             half-width of the 95 % interval (Student's t). Live: `localize --live`; per \
             frame: `localize`. Wrong: refined frames more than 5 mm off, as a share of the \
             refined ones.\n\n",
            self.colons().len(),
            self.preset,
            if self.gca.is_empty() {
                ""
            } else {
                " and CT colons"
            },
            self.zones,
            self.pretrained,
        ));
        md.push_str(&table);
        md.push_str(&format!(
            "\n## Where it breaks\n\nA condition holds when live at least {HOLDS_REFINED_PCT} % \
             of the frames are refined, at most {HOLDS_WRONG_PCT} % of them more than 5 mm off, \
             and their median error is at most {HOLDS_MEDIAN_MM} mm (means over the colons); \
             a limit the unchanged pass itself misses counts only where the condition is clearly \
             worse (5 points fewer refined, 1 point more wrong, twice the median error).\n\n"
        ));
        // Each condition against the unchanged pass of the same colons.
        let baseline = |s: &ConditionSummary| {
            let same: Vec<ConditionRow> = rows
                .iter()
                .filter(|r| s.colon_names.contains(&r.colon))
                .cloned()
                .collect();
            Some(summarise(&Condition::NONE, &same)).filter(|b| b.colons > 0)
        };
        for line in breakpoints(summary, &self.severities(), &baseline) {
            md.push_str(&format!("- {line}\n"));
        }
        if !missing.is_empty() {
            // Per colon: how many conditions are missing.
            let mut per_colon: Vec<(String, usize)> = Vec::new();
            for m in missing {
                let colon = m.split('/').next().unwrap_or(m).to_string();
                match per_colon.iter_mut().find(|(c, _)| *c == colon) {
                    Some((_, n)) => *n += 1,
                    None => per_colon.push((colon, 1)),
                }
            }
            let parts: Vec<String> = per_colon
                .iter()
                .map(|(c, n)| format!("{c} ({n} of {})", self.conditions().len()))
                .collect();
            md.push_str(&format!(
                "\nNot finished (conditions missing per colon): {}.\n",
                parts.join(", ")
            ));
        }
        md.push_str("\n![changes](changes.png)\n");
        common::write_text(&self.out.join("changes.md"), &md)?;
        common::write_text(
            &self.out.join("changes.json"),
            &serde_json::to_string_pretty(summary)?,
        )?;
        self.plot(summary)?;
        Ok(table)
    }

    /// Each factor's live figures against severity (the unchanged pass at `none`); with
    /// factors changed together, whose names are too long for a legend, one row of bars per
    /// condition instead.
    fn plot(&self, summary: &[ConditionSummary]) -> Result<()> {
        let severities = self.severities();
        if self
            .factors()
            .iter()
            .any(|f| *f != Factors::ALL && f.iter().count() > 1)
        {
            let rows: Vec<BarRow> = summary
                .iter()
                .map(|s| {
                    let name = match s.factor {
                        None => "none".to_string(),
                        Some(f) if severities.len() > 1 => format!("{f} ({})", s.severity.name()),
                        Some(f) => f.name(),
                    };
                    let mean = |i: &Option<Interval>| i.as_ref().map(|i| i.mean);
                    BarRow {
                        name,
                        values: vec![
                            mean(&s.live_refined_pct),
                            mean(&s.live_wrong_pct),
                            mean(&s.frame_refined_pct),
                        ],
                    }
                })
                .collect();
            let config = PlotConfig {
                width_px: 1100,
                height_px: 140 + 40 * rows.len() as u32,
                ..PlotConfig::default()
            };
            plot_row_bars(
                &rows,
                &[
                    "live: refined",
                    "live: refined > 5 mm off (% of refined)",
                    "per frame: refined",
                ],
                "Conditions: means over the colons",
                "%",
                (0.0, 100.0),
                &self.out.join("changes.png"),
                &config,
            )?;
            return Ok(());
        }
        let mut ticks = vec!["none"];
        ticks.extend(severities.iter().map(|s| s.name()));
        let none = summary.iter().find(|s| s.factor.is_none());
        let series = |value: &dyn Fn(&ConditionSummary) -> Option<f64>| -> Vec<Series> {
            self.factors()
                .into_iter()
                .map(|f| {
                    let mut points = vec![(0.0, none.and_then(value))];
                    for (k, sev) in severities.iter().enumerate() {
                        let s = summary
                            .iter()
                            .find(|s| s.factor == Some(f) && s.severity == *sev);
                        points.push(((k + 1) as f64, s.and_then(value)));
                    }
                    Series {
                        name: f.name(),
                        points,
                    }
                })
                .collect()
        };
        let mean = |i: &Option<Interval>| i.as_ref().map(|i| i.mean);
        let panels = [
            SeriesPanel {
                title: "Live: refined frames".into(),
                unit: "%".into(),
                y: (0.0, 100.0),
                series: series(&|s| mean(&s.live_refined_pct)),
            },
            SeriesPanel {
                title: "Live: median position error of the refined frames (clipped at 10 mm)"
                    .into(),
                unit: "mm".into(),
                y: (0.0, 10.0),
                series: series(&|s| mean(&s.live_refined_median_mm)),
            },
            SeriesPanel {
                title: "Live: refined frames more than 5 mm off".into(),
                unit: "% of refined".into(),
                y: (0.0, 100.0),
                series: series(&|s| mean(&s.live_wrong_pct)),
            },
        ];
        let config = PlotConfig {
            width_px: 900,
            height_px: 1200,
            ..PlotConfig::default()
        };
        plot_series(
            &panels,
            &ticks,
            "severity",
            &self.out.join("changes.png"),
            &config,
        )?;
        Ok(())
    }
}

fn row_path(out: &Path, colon: &str, condition: &str) -> PathBuf {
    out.join("colons")
        .join(colon)
        .join("rows")
        .join(format!("{condition}.json"))
}

/// One condition's figures over the colons that finished it.
fn summarise(c: &Condition, rows: &[ConditionRow]) -> ConditionSummary {
    let name = c.name();
    let of: Vec<&ConditionRow> = rows.iter().filter(|r| r.condition == name).collect();
    let method = |m: Method| -> Vec<&MethodRow> {
        of.iter()
            .filter_map(|r| r.methods.iter().find(|x| x.method == m.name()))
            .collect()
    };
    let figure = |m: Method, f: &dyn Fn(&MethodRow) -> Option<f64>| -> Option<Interval> {
        let v: Vec<f64> = method(m).into_iter().filter_map(f).collect();
        interval(&v)
    };
    let refined_pct = |r: &MethodRow| r.refined.map(|k| 100.0 * k as f64 / r.frames.max(1) as f64);
    let wrong_pct = |r: &MethodRow| match (r.refined_over_5mm, r.refined) {
        (Some(w), Some(k)) if k > 0 => Some(100.0 * w as f64 / k as f64),
        _ => None,
    };
    let within_pct = |r: &MethodRow| match (r.refined_within_bound, r.refined) {
        (Some(w), Some(k)) if k > 0 => Some(100.0 * w as f64 / k as f64),
        _ => None,
    };
    ConditionSummary {
        condition: name.clone(),
        factor: c.factor,
        severity: c.severity,
        colons: of.len(),
        colon_names: of.iter().map(|r| r.colon.clone()).collect(),
        live_refined_pct: figure(LIVE, &refined_pct),
        live_refined_median_mm: figure(LIVE, &|r| r.refined_median_position_mm),
        live_wrong_pct: figure(LIVE, &wrong_pct),
        live_along_median_mm: figure(LIVE, &|r| r.median_along_mm),
        live_zone_within_one_pct: figure(LIVE, &|r| r.zone_within_one.map(|z| 100.0 * z)),
        frame_refined_pct: figure(PER_FRAME, &refined_pct),
        frame_refined_median_mm: figure(PER_FRAME, &|r| r.refined_median_position_mm),
        frame_wrong_pct: figure(PER_FRAME, &wrong_pct),
        live_within_bound_pct: figure(LIVE, &within_pct),
        frame_within_bound_pct: figure(PER_FRAME, &within_pct),
    }
}

const HEADER: [&str; 13] = [
    "change",
    "severity",
    "colons",
    "live: refined (%)",
    "live: median pos of refined (mm)",
    "live: wrong (% of refined)",
    "live: along the colon, median (mm)",
    "live: zone ±1 (%)",
    "per frame: refined (%)",
    "per frame: median pos of refined (mm)",
    "per frame: wrong (% of refined)",
    "live: within the stated 95 % bound (% of refined)",
    "per frame: within the stated 95 % bound (% of refined)",
];

fn pm(i: &Option<Interval>, digits: usize) -> String {
    match i {
        None => "—".into(),
        Some(i) if i.colons > 1 => format!("{:.digits$} ± {:.digits$}", i.mean, i.half_width),
        Some(i) => format!("{:.digits$}", i.mean),
    }
}

fn summary_table(summary: &[ConditionSummary]) -> String {
    let mut s = format!("| {} |\n", HEADER.join(" | "));
    s.push_str(&format!("|{}\n", "---|".repeat(HEADER.len())));
    for c in summary {
        let cells = [
            c.factor.map_or("nothing".to_string(), Factors::description),
            c.severity.name().to_string(),
            c.colons.to_string(),
            pm(&c.live_refined_pct, 1),
            pm(&c.live_refined_median_mm, 2),
            pm(&c.live_wrong_pct, 1),
            pm(&c.live_along_median_mm, 1),
            pm(&c.live_zone_within_one_pct, 1),
            pm(&c.frame_refined_pct, 1),
            pm(&c.frame_refined_median_mm, 2),
            pm(&c.frame_wrong_pct, 1),
            pm(&c.live_within_bound_pct, 1),
            pm(&c.frame_within_bound_pct, 1),
        ];
        s.push_str(&format!("| {} |\n", cells.join(" | ")));
    }
    s
}

/// Why a condition does not hold (live, means over the colons), or `None` when it does. A
/// condition fails a limit only where it is also clearly worse than the unchanged pass
/// (`none`): 5 points fewer refined, 1 point more wrong, twice the median error.
fn fails(s: &ConditionSummary, none: Option<&ConditionSummary>) -> Option<String> {
    let mean = |i: &Option<Interval>| i.as_ref().map(|i| i.mean);
    let base = |f: &dyn Fn(&ConditionSummary) -> Option<f64>| none.and_then(f);
    let mut why = Vec::new();
    let refined_limit = base(&|n| mean(&n.live_refined_pct))
        .map_or(HOLDS_REFINED_PCT, |n| HOLDS_REFINED_PCT.min(n - 5.0));
    match mean(&s.live_refined_pct) {
        Some(r) if r >= refined_limit => {}
        Some(r) => why.push(format!("{r:.1} % refined live")),
        None => why.push("nothing refined".into()),
    }
    let wrong_limit = base(&|n| mean(&n.live_wrong_pct))
        .map_or(HOLDS_WRONG_PCT, |n| HOLDS_WRONG_PCT.max(n + 1.0));
    if let Some(w) = mean(&s.live_wrong_pct).filter(|w| *w > wrong_limit) {
        why.push(format!("{w:.1} % of the refined frames more than 5 mm off"));
    }
    let median_limit = base(&|n| mean(&n.live_refined_median_mm))
        .map_or(HOLDS_MEDIAN_MM, |n| HOLDS_MEDIAN_MM.max(2.0 * n));
    if let Some(m) = mean(&s.live_refined_median_mm).filter(|m| *m > median_limit) {
        why.push(format!("median error {m:.2} mm"));
    }
    (!why.is_empty()).then(|| why.join(", "))
}

/// One sentence per factor: the mildest severity at which it stops holding, and why, each
/// condition against `baseline`, the unchanged pass of the same colons.
fn breakpoints(
    summary: &[ConditionSummary],
    severities: &[Severity],
    baseline: &dyn Fn(&ConditionSummary) -> Option<ConditionSummary>,
) -> Vec<String> {
    let mut factors: Vec<Factors> = Vec::new();
    for s in summary {
        if let Some(f) = s.factor
            && !factors.contains(&f)
        {
            factors.push(f);
        }
    }
    factors
        .into_iter()
        .map(|f| {
            let first_failure = severities.iter().find_map(|sev| {
                let s = summary
                    .iter()
                    .find(|s| s.factor == Some(f) && s.severity == *sev)?;
                fails(s, baseline(s).as_ref()).map(|why| (*sev, why))
            });
            match first_failure {
                Some((sev, why)) => format!(
                    "**{}** ({}): breaks at `{}` — {why}.",
                    f.name(),
                    f.description(),
                    sev.name()
                ),
                None => format!(
                    "**{}** ({}): holds up to `{}`.",
                    f.name(),
                    f.description(),
                    severities.last().map_or("none", |s| s.name())
                ),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_factor_changes_only_its_own_settings_and_all_is_the_preset() {
        for sev in [Severity::Mild, Severity::Moderate, Severity::Severe] {
            let preset = ChangeConfig::preset(sev);
            assert_eq!(Factors::ALL.change(sev), preset);
            for f in Factor::EACH {
                let c = Factors::one(f).change(sev);
                assert!(!c.is_none(), "{f} at {} changes something", sev.name());
                // Only one of the three groups moves.
                let groups = [!c.shape.is_none(), !c.look.is_none(), !c.scope.is_none()];
                assert_eq!(groups.iter().filter(|g| **g).count(), 1, "{f}");
            }
            // Together the factors are the preset (the seed and the informative severity aside).
            let mut sum = ChangeConfig {
                severity: sev,
                ..ChangeConfig::default()
            };
            for f in Factor::EACH {
                let c = Factors::one(f).change(sev);
                let d = ChangeConfig::default();
                if c.shape != d.shape {
                    sum.shape.shift_mm = sum.shape.shift_mm.max(c.shape.shift_mm);
                    sum.shape.insufflation = sum.shape.insufflation.max(c.shape.insufflation);
                    sum.shape.deform_mm = sum.shape.deform_mm.max(c.shape.deform_mm);
                }
                macro_rules! take {
                    ($($g:ident . $f:ident),*) => {$(
                        if c.$g.$f != d.$g.$f { sum.$g.$f = c.$g.$f; }
                    )*};
                }
                take!(
                    look.gain,
                    look.gamma,
                    look.white_balance,
                    look.light_power,
                    look.beam_exponent,
                    look.specular,
                    look.sheen,
                    look.texture_contrast,
                    look.residue_fraction,
                    look.fluid_fraction,
                    look.bubble_frames,
                    look.bubble_cover,
                    scope.motion_blur_samples,
                    scope.motion_blur_mm,
                    scope.defocus_px,
                    scope.hfov_change_deg
                );
            }
            assert_eq!(sum, preset, "{}", sev.name());
            // The three groups together are the preset too; two factors are their union.
            assert_eq!(
                "shape+look+scope".parse::<Factors>().unwrap().change(sev),
                preset
            );
            let (shift, blur) = (Factors::one(Factor::Shift), Factors::one(Factor::Blur));
            let both = "blur+shift".parse::<Factors>().unwrap().change(sev);
            assert_eq!(both.shape, shift.change(sev).shape);
            assert_eq!(both.scope, blur.change(sev).scope);
            assert!(both.look.is_none());
        }
    }

    #[test]
    fn factors_read_and_write_as_names_with_groups_whole() {
        let parse = |s: &str| s.parse::<Factors>().unwrap();
        assert_eq!(parse("fov"), Factors::one(Factor::Fov));
        assert_eq!(parse("fov").name(), "fov");
        assert_eq!(parse("fov").description(), "wider field of view");
        // Named in the model's order, a whole group by its name, everything as `all`.
        assert_eq!(
            parse("texture+deform+insufflation+shift").name(),
            "shape+texture"
        );
        assert_eq!(parse("look+scope").name(), "look+scope");
        assert_eq!(parse("shape+look+scope"), Factors::ALL);
        let members = |s: &str| parse(s).iter().collect::<Vec<_>>();
        assert_eq!(
            members("shape"),
            [Factor::Shift, Factor::Insufflation, Factor::Deform]
        );
        assert_eq!(members("look").len(), 7);
        assert_eq!(members("scope"), [Factor::Blur, Factor::Fov]);
        assert_eq!(parse("all").name(), "all");
        assert_eq!(parse("all").description(), "every change at once");
        assert_eq!(
            parse("shift+blur").description(),
            "mobile segments shifted + motion blur, defocus"
        );
        for f in Factors::each_and_all() {
            assert_eq!(parse(&f.name()), f);
            let json = serde_json::to_string(&f).unwrap();
            assert_eq!(json, format!("\"{f}\""));
            assert_eq!(serde_json::from_str::<Factors>(&json).unwrap(), f);
        }
        let e = "shift+foam".parse::<Factors>().unwrap_err();
        assert!(
            e.contains("\"foam\"") && e.contains("shift") && e.contains("scope"),
            "{e}"
        );
    }

    #[test]
    fn a_factor_breaks_at_the_first_severity_that_fails() {
        let row = |f, sev, refined: f64, wrong: f64, median: f64| ConditionSummary {
            condition: String::new(),
            factor: Some(f),
            severity: sev,
            colons: 5,
            colon_names: Vec::new(),
            live_refined_pct: interval(&[refined, refined]),
            live_refined_median_mm: interval(&[median, median]),
            live_wrong_pct: interval(&[wrong, wrong]),
            live_along_median_mm: None,
            live_zone_within_one_pct: None,
            frame_refined_pct: None,
            frame_refined_median_mm: None,
            frame_wrong_pct: None,
            live_within_bound_pct: None,
            frame_within_bound_pct: None,
        };
        let sevs = [Severity::Mild, Severity::Moderate, Severity::Severe];
        let mut none = row(Factors::ALL, Severity::None, 85.0, 0.5, 0.3);
        none.factor = None;
        let summary = [
            none,
            // As the unchanged pass: below 90 % refined, but not worse than without a change.
            row(Factor::Fov.into(), Severity::Mild, 84.0, 0.5, 0.3),
            row(Factor::Shift.into(), Severity::Mild, 97.0, 0.0, 0.5),
            row(Factor::Shift.into(), Severity::Moderate, 96.0, 20.0, 2.5),
            row(Factor::Shift.into(), Severity::Severe, 60.0, 40.0, 6.0),
            row(Factor::Exposure.into(), Severity::Mild, 99.0, 0.0, 0.2),
            row(Factor::Exposure.into(), Severity::Moderate, 98.0, 0.0, 0.3),
            row(Factor::Exposure.into(), Severity::Severe, 97.0, 0.5, 0.4),
        ];
        let base = summary[0].clone();
        let lines = breakpoints(&summary, &sevs, &|_| Some(base.clone()));
        assert_eq!(lines.len(), 3);
        assert!(
            lines[0].contains("**fov**") && lines[0].contains("holds up to"),
            "{}",
            lines[0]
        );
        assert!(
            lines[1].contains("breaks at `moderate`")
                && lines[1].contains("20.0 % of the refined frames more than 5 mm off")
                && lines[1].contains("median error 2.50 mm")
                && !lines[1].contains("refined live"),
            "{}",
            lines[1]
        );
        assert!(lines[2].contains("holds up to `severe`"), "{}", lines[2]);
    }

    #[test]
    fn every_colon_is_one_command_and_the_merge_is_the_last() {
        let job = ChangesJob {
            seeds: vec![1, 2],
            factors: vec![Factor::Fov.into(), Factor::Blur.into()],
            severities: vec![Severity::Severe, Severity::Mild],
            print_jobs: true,
            ..ChangesJob::default()
        };
        let report = job.run(&endoloc_jobs::Silent).unwrap();
        assert_eq!(report.jobs.len(), 3);
        assert!(
            report.jobs[0].ends_with("--colon seed-1"),
            "{}",
            report.jobs[0]
        );
        assert!(
            report.jobs[0].contains("--factors fov,blur --severities mild,severe"),
            "{}",
            report.jobs[0]
        );
        assert!(report.jobs[2].ends_with("--merge"));
        // The zone indexes' views go with every command; a bad list stops before anything.
        let views = ChangesJob {
            index_zoom_blur: Some("0.03,0.06".into()),
            index_view_penalty: Some(0.07),
            ..job.clone()
        };
        let report = views.run(&endoloc_jobs::Silent).unwrap();
        assert!(
            report.jobs[0].contains("--index-zoom-blur 0.03,0.06 --index-view-penalty 0.07"),
            "{}",
            report.jobs[0]
        );
        let e = ChangesJob {
            index_zoom_blur: Some("0.7".into()),
            ..views
        }
        .run(&endoloc_jobs::Silent)
        .unwrap_err()
        .to_string();
        assert!(e.contains("index_zoom_blur") && e.contains("0.7"), "{e}");
        let names: Vec<String> = job.conditions().iter().map(Condition::name).collect();
        assert_eq!(
            names,
            ["none", "fov-mild", "fov-severe", "blur-mild", "blur-severe"]
        );
    }
}
