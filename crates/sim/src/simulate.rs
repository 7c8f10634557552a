//! The simulation driver: colon → texture → passes → rendered dataset on disk.

use std::path::{Path, PathBuf};
use std::time::Instant;

use endoloc_data::{DatasetMeta, DatasetWriter, StampedPose};
use rayon::prelude::*;

use crate::SimError;
use crate::appearance::{MucosaAtlas, splitmix64};
use crate::change::{ChangedPass, Deformation};
use crate::colon::{ColonModel, from_mesh, procedural};
use crate::config::{ColonSource, SimConfig};
use crate::render::{RenderConfig, RenderScratch, Renderer};
use crate::trajectory::{Pass, PassGenerator};

/// What the driver reports while it works (called from worker threads).
#[derive(Debug, Clone)]
pub enum Progress<'a> {
    /// A preparation stage started (colon, texture, passes).
    Stage(&'a str),
    /// Something the user should know about the colon model (see [`ColonModel::notes`]):
    /// a missing landmark and where it was placed, where the pass stops short of the appendix.
    Note(&'a str),
    /// Rendering of a sequence started, with its frame count.
    SequenceStarted {
        /// The sequence's name (its folder in the dataset).
        name: &'a str,
        /// Number of frames it will have.
        frames: usize,
    },
    /// One more frame of the current sequence is on disk.
    FrameDone,
}

/// Summary of a finished simulation.
#[derive(Debug, Clone)]
pub struct SimSummary {
    /// The dataset folder.
    pub dataset: PathBuf,
    /// Description of the colon model.
    pub colon: String,
    /// What the colon model had to assume ([`ColonModel::notes`]).
    pub notes: Vec<String>,
    /// Mid-line length, mm.
    pub colon_length_mm: f64,
    /// Frames per sequence, `(name, frames)`.
    pub sequences: Vec<(String, usize)>,
    /// Smallest distance from the lens to the wall over all frames, mm.
    pub min_clearance_mm: f64,
    /// Wall-clock time of the rendering and writing, seconds.
    pub render_seconds: f64,
    /// Wall-clock time of everything, seconds.
    pub total_seconds: f64,
}

impl SimSummary {
    /// Rendered frames per second (rendering and PNG writing).
    pub fn frames_per_second(&self) -> f64 {
        let frames: usize = self.sequences.iter().map(|s| s.1).sum();
        frames as f64 / self.render_seconds.max(1e-9)
    }
}

/// Builds the colon a config describes.
///
/// # Errors
/// Invalid parameters, or unreadable mesh/path/landmark files.
pub fn build_colon(cfg: &SimConfig) -> Result<ColonModel, SimError> {
    match &cfg.colon {
        ColonSource::Procedural(p) => procedural::build(p),
        ColonSource::Mesh(m) => from_mesh::build(m),
    }
}

/// Runs a whole simulation and writes the dataset to `out` (train/ and test/ sequences).
///
/// Refuses to replace an existing `out` unless `overwrite`; the dataset appears at `out` only
/// once complete.
///
/// # Errors
/// Invalid config, unreadable inputs, or I/O errors while writing.
pub fn simulate(
    cfg: &SimConfig,
    out: &Path,
    overwrite: bool,
    progress: &(dyn Fn(Progress<'_>) + Sync),
) -> Result<SimSummary, SimError> {
    let start = Instant::now();
    cfg.validate()?;
    let camera = cfg.camera.camera()?;
    let mut meta = DatasetMeta::new(cfg.name.clone(), camera);
    meta.source
        .insert("generator".into(), "endoloc simulate".into());
    meta.source
        .insert("version".into(), env!("CARGO_PKG_VERSION").into());
    let sim_table: toml::Table = toml::Table::try_from(cfg)
        .map_err(|e| SimError::InvalidConfig(format!("cannot store the config: {e}")))?;
    meta.simulation = Some(sim_table);
    // Fail on an existing destination before any expensive work.
    let mut writer = DatasetWriter::create(out, &meta, overwrite)?;

    progress(Progress::Stage("colon"));
    let colon = build_colon(cfg)?;
    for note in &colon.notes {
        progress(Progress::Note(note));
    }
    writer.write_midline(&colon.centerline.points)?;
    progress(Progress::Stage("texture"));
    let atlas = MucosaAtlas::bake(&colon, &cfg.appearance)?;
    progress(Progress::Stage("passes"));
    let passes = [
        ("train", PassGenerator::new(&colon, &cfg.train)?),
        ("test", PassGenerator::new(&colon, &cfg.test)?),
    ];
    let renderer = Renderer::new(&colon, &atlas, camera, cfg.render.clone())?;
    let changed = if cfg.changes.is_none() {
        None
    } else {
        progress(Progress::Stage("changed colon"));
        let changed = ChangedPass::new(&cfg.changes, &cfg.appearance, &colon)?;
        for note in &changed.notes {
            progress(Progress::Note(note));
        }
        Some(changed)
    };
    // The test scope: the map scope's optics with another field of view, when it changes.
    let test_camera = if cfg.changes.scope.hfov_change_deg == 0.0 {
        camera
    } else {
        crate::config::CameraConfig {
            hfov_deg: cfg.camera.hfov_deg + cfg.changes.scope.hfov_change_deg,
            ..cfg.camera.clone()
        }
        .camera()
        .map_err(|e| {
            SimError::InvalidConfig(format!(
                "the test scope (changes.scope.hfov_change_deg): {e}"
            ))
        })?
    };
    let test_renderer = match &changed {
        Some(c) => Some(
            Renderer::new(
                c.colon.as_ref().unwrap_or(&colon),
                c.atlas.as_ref().unwrap_or(&atlas),
                test_camera,
                RenderConfig {
                    motion_blur_samples: c
                        .motion_blur_samples
                        .unwrap_or(cfg.render.motion_blur_samples),
                    motion_blur_mm: c.motion_blur_mm.unwrap_or(cfg.render.motion_blur_mm),
                    ..cfg.render.clone()
                },
            )?
            .with_look(&c.look),
        ),
        None => None,
    };
    if let Some(mask) = renderer.mask() {
        let img = image::GrayImage::from_raw(camera.width, camera.height, mask.to_vec())
            .expect("the mask has one byte per pixel");
        writer.write_mask(&img)?;
    }

    let render_start = Instant::now();
    let mut sequences = Vec::new();
    let mut min_clearance = f64::INFINITY;
    for (name, generator) in &passes {
        let pass = generator.generate()?;
        // The test pass of a changed colon: rendered there, its anatomical poses kept.
        let (renderer, deformation) = match (*name, &test_renderer, &changed) {
            ("test", Some(r), Some(c)) => (r, c.deformation.as_ref()),
            _ => (&renderer, None),
        };
        min_clearance = pass
            .clearance_mm
            .iter()
            .copied()
            .fold(min_clearance, f64::min);
        progress(Progress::SequenceStarted {
            name,
            frames: pass.poses.len(),
        });
        let seq = writer.sequence(name)?;
        if *name == "test" && test_camera != camera {
            seq.write_camera(&test_camera)?;
        }
        let seq_seed = splitmix64(generator.config().seed ^ 0x5EED);
        render_pass(
            renderer,
            generator,
            &pass,
            seq_seed,
            deformation,
            |frame, rendered| {
                let (w, h) = (camera.width, camera.height);
                seq.write_rgb(frame, w, h, &rendered.rgb)?;
                if cfg.depth {
                    seq.write_depth(frame, w, h, &rendered.depth_mm)?;
                }
                progress(Progress::FrameDone);
                Ok::<(), SimError>(())
            },
        )?;
        let stamped: Vec<StampedPose> = pass
            .timestamps_s
            .iter()
            .zip(&pass.poses)
            .map(|(t, p)| StampedPose {
                timestamp_s: *t,
                pose: *p,
            })
            .collect();
        if let Some(d) = deformation {
            let moved: Vec<StampedPose> = stamped
                .iter()
                .zip(&pass.s_mm)
                .map(|(p, s)| StampedPose {
                    timestamp_s: p.timestamp_s,
                    pose: d.map_pose(&p.pose, *s),
                })
                .collect();
            seq.write_trajectory(endoloc_data::CHANGED_POSES_FILE, &moved)?;
        }
        seq.finish(&stamped, Some(&pass.sections))?;
        sequences.push((name.to_string(), pass.poses.len()));
    }
    let render_seconds = render_start.elapsed().as_secs_f64();
    let dataset = writer.finish()?;
    let mut notes = colon.notes.clone();
    notes.extend(changed.iter().flat_map(|c| c.notes.iter().cloned()));
    Ok(SimSummary {
        dataset,
        colon: colon.description.clone(),
        notes,
        colon_length_mm: colon.centerline.length_mm(),
        sequences,
        min_clearance_mm: min_clearance,
        render_seconds,
        total_seconds: start.elapsed().as_secs_f64(),
    })
}

/// The exposure around frame `k`, in frame intervals: the render setting `shutter_fraction`,
/// or with `motion_blur_mm` the time the camera takes to travel that far along its path at
/// its speed around `k` (at most one frame interval; a camera at rest blurs nothing more).
pub fn exposure_frames(cfg: &RenderConfig, generator: &PassGenerator<'_>, k: usize) -> f64 {
    if cfg.motion_blur_mm <= 0.0 {
        return cfg.shutter_fraction;
    }
    // The camera's path length over the frame interval around `k`, mm (eight chords).
    let at = |t: f64| {
        generator
            .pose_at(k as f64 + t / 8.0 - 0.5)
            .0
            .translation
            .vector
    };
    let step_mm: f64 = (0..8)
        .map(|i| (at(i as f64 + 1.0) - at(i as f64)).norm())
        .sum();
    if step_mm <= cfg.motion_blur_mm {
        1.0
    } else {
        cfg.motion_blur_mm / step_mm
    }
}

/// Renders every frame of a pass in parallel and hands each to `sink` (called from worker
/// threads, in no particular order). Stops at the first error. With a `deformation` every
/// pose of the pass (planned in the unchanged colon) is carried into the changed colon the
/// renderer draws.
///
/// # Errors
/// The first error returned by `sink`.
pub fn render_pass<E: Send>(
    renderer: &Renderer<'_>,
    generator: &PassGenerator<'_>,
    pass: &Pass,
    seed: u64,
    deformation: Option<&Deformation>,
    sink: impl Fn(usize, &crate::render::RenderedFrame) -> Result<(), E> + Sync,
) -> Result<(), E> {
    let samples = renderer.config().motion_blur_samples.max(1) | 1; // odd: middle = frame time
    (0..pass.poses.len())
        .into_par_iter()
        .try_for_each_init(RenderScratch::default, |scratch, k| {
            let mut sub: Vec<_> = if samples == 1 {
                vec![(pass.poses[k], pass.s_mm[k])]
            } else {
                let shutter = exposure_frames(renderer.config(), generator, k);
                (0..samples)
                    .map(|j| {
                        let dt = (j as f64 / (samples - 1) as f64 - 0.5) * shutter;
                        let (pose, s, _) = generator.pose_at(k as f64 + dt);
                        (pose, s)
                    })
                    .collect()
            };
            if let Some(d) = deformation {
                for (pose, s) in &mut sub {
                    *pose = d.map_pose(pose, *s);
                }
            }
            let frame = renderer.render_frame(&sub, splitmix64(seed ^ k as u64), k, scratch);
            sink(k, &frame)
        })
}
